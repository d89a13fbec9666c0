"""A sampler that cannot crash its host (issue 34).

OpenFOAM runs with floating-point traps on (FOAM_SIGFPE): an ordered comparison
of a NaN, a division by zero or an overflow inside the sampler is a SIGFPE, not a
FatalError. These tests hold the sampler to swl.h's contract with traps on:

* crafted tables outside the documented value ranges (docs/wall-law.md, "Value
  ranges") are refused alike by the C reader (SWL_E_VALUE), the Python reader
  (DataFormatError naming the variable, the node and the value) and the writer
  (ValueError): a NaN lateral angle, e_n = 1e300, a doubled speed ratio, angle
  nodes outside (0, 90], axes equal in log, ...;
* the writer never writes what the readers refuse: tables built by
  :func:`microimpact.build_wall_law` at random (hypothesis) load in C under traps;
* a fuzz harness (tests/c/swl_fuzz.c, under AddressSanitizer, UBSan and traps)
  mutates real exported tables, rewrites their CRC-32 and samples what loads: no
  trap, no memory error, no non-finite or faster-than-incoming rebound, a named
  code for every refusal. A few seconds here, a minute under ``-m slow``.
"""

from __future__ import annotations

import math
import re
import signal
import subprocess
import sys
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_wall_law import ROUGH, _areal_and_rough, _scenario
from test_wall_law_c import (
    C_DIR,
    CC,
    E_VALUE,
    FLAGS,
    ROOT,
    TRAPS,
    Swl,
    _patched,
    compile_shared,
    synthetic_dataset,
)

import microimpact as mi
from microimpact.errors import DataFormatError
from microimpact.physics.resuspension import AdhesionRangeWarning
from microimpact.scenario.resuspension import ResuspensionSpec
from microimpact.wall_law import WallLaw, WallLawSpec, build_wall_law, export_c

pytestmark = [
    pytest.mark.skipif(CC is None, reason="no C compiler"),
    pytest.mark.skipif(
        not sys.platform.startswith("linux"), reason="traps need glibc's feenableexcept"
    ),
]

FUZZ = ROOT / "tests" / "c" / "swl_fuzz.c"
E_UNIT = -10


# ---------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def swl(tmp_path_factory):
    lib = Swl(
        compile_shared([C_DIR / "swl.c", TRAPS], tmp_path_factory.mktemp("s") / "l.so")
    )
    assert lib.traps, "floating-point traps are not available"
    return lib


@pytest.fixture(scope="module")
def fuzzer(tmp_path_factory):
    """swl_fuzz built with AddressSanitizer and UBSan (skip where the compiler
    has no sanitizers)."""
    out = tmp_path_factory.mktemp("fuzz") / "swl_fuzz"
    cmd = [
        CC,
        *FLAGS,
        "-O1",
        "-g",
        "-fsanitize=address,undefined",
        "-fno-sanitize-recover=all",
        "-fno-omit-frame-pointer",
        f"-I{C_DIR}",
        str(FUZZ),
        str(C_DIR / "swl.c"),
        "-o",
        str(out),
        "-lm",
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if run.returncode != 0:
        pytest.skip(f"no sanitizers: {run.stderr.strip().splitlines()[-1:]}")
    return out


@pytest.fixture(scope="module")
def real_tables(tmp_path_factory):
    """Tables exported from real builds: an absolute axis with a rough and an
    areal surface (lateral angles filled), grazing to normal incidence (e_n up to
    1 / sin 3 deg), and a reduced speed axis; small reservoirs keep the files
    small for the fuzzer."""
    out = tmp_path_factory.mktemp("real")
    absolute = build_wall_law(
        _scenario(_areal_and_rough(), samples=400),
        WallLawSpec(
            diameters_um=(3.0, 30.0),
            speeds_m_s=(0.3, 3.0, 10.0),
            angles_deg=(3.0, 40.0, 90.0),
            reservoir=12,
        ),
    )
    reduced = build_wall_law(
        _scenario(ROUGH, samples=400),
        WallLawSpec(
            diameters_um=(3.0, 30.0),
            speeds_m_s=None,
            angles_deg=(10.0, 90.0),
            reservoir=12,
            speed_axis="reduced",
            reduced_speeds=(0.7, 1.4, 4.0),
        ),
    )
    stay = build_wall_law(  # format version 3: the stay_probability section
        _scenario(ROUGH, samples=400),
        WallLawSpec(
            diameters_um=(3.0, 12.0),
            speeds_m_s=(0.3, 3.0),
            angles_deg=(10.0, 90.0),
            reservoir=12,
        ),
        resuspension=ResuspensionSpec(
            friction_velocities_m_s=(1.0, 3.0),
            exposures_s=(1.0,),
            surface_energy_j_m2=0.56,
            density_kg_m3=1.2,
            kinematic_viscosity_m2_s=1.5e-5,
        ),
    )
    return [
        export_c.write_binary(absolute, out / "absolute.swl"),
        export_c.write_binary(reduced, out / "reduced.swl"),
        export_c.write_binary(stay, out / "stay.swl"),
        ROOT / "tests" / "wall_law" / "data" / "format_v1.swl",
    ]


def _counts(line: str) -> dict:
    """The last output line of swl_fuzz: iterations, and loads and samples by
    result code."""
    m = re.fullmatch(r"iterations (\d+) loads(.*) samples (\d+)(.*)", line.strip())
    assert m, line

    def codes(text):
        return {int(c): int(n) for c, n in re.findall(r"(-?\d+):(\d+)", text)}

    return {
        "iterations": int(m[1]),
        "loads": codes(m[2]),
        "samples": int(m[3]),
        "results": codes(m[4]),
    }


def _run(fuzzer, *args, timeout=120):
    run = subprocess.run(
        [str(fuzzer), *map(str, args)],
        capture_output=True,
        text=True,
        check=False,
        timeout=timeout,
    )
    assert run.returncode == 0, (run.returncode, run.stderr[-3000:])
    return _counts(run.stdout.strip().splitlines()[-1])


# ------------------------------------------------------- the traps are real
def test_the_traps_are_live(tmp_path):
    """The harness' traps kill a process on an invalid operation (sqrt(-1) in
    libm with traps on): a sampler that traps cannot pass unseen."""
    lib = compile_shared([TRAPS], tmp_path / "traps.so")
    code = (
        "import ctypes, ctypes.util\n"
        f"t = ctypes.CDLL({str(lib)!r})\n"
        "m = ctypes.CDLL(ctypes.util.find_library('m'))\n"
        "m.sqrt.argtypes = [ctypes.c_double]\n"
        "m.sqrt.restype = ctypes.c_double\n"
        "assert t.swl_test_traps_on() == 0\n"
        "m.sqrt(-1.0)\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, check=False)
    assert run.returncode == -signal.SIGFPE


# ------------------------------------------------- crafted tables, three readers
def _held(ds, node=(0, 0, 0, 2)):
    assert int(ds["reservoir_count"].values[node]) >= 1
    return (*node, 0)


def _set(name, value, node=(0, 0, 0, 2)):
    def change(ds):
        ds = ds.copy(deep=True)
        at = _held(ds, node)
        ds[name].values[at[: ds[name].ndim]] = value
        return ds

    return change


def _axis(name, values):
    def change(ds):
        return ds.assign_coords({name: np.asarray(values, dtype=float)})

    return change


#: (case, change, the variable the messages name). Node (0, 0, 0, 2) is at 90
#: degrees, node (0, 0, 0, 0) at 15.
CRAFTED = [
    ("nan-lateral", _set("reservoir_lateral_angle_deg", np.nan), "lateral_angle"),
    ("lateral-90", _set("reservoir_lateral_angle_deg", 90.0), "lateral_angle"),
    ("lateral-minus-90", _set("reservoir_lateral_angle_deg", -90.0), "lateral_angle"),
    ("e_n-1e300", _set("reservoir_e_n", 1e300), "e_n"),
    ("e_n-nan", _set("reservoir_e_n", np.nan), "e_n"),
    ("e_n-above-1-at-90", _set("reservoir_e_n", 1.01), "e_n"),
    ("e_n-below-minus-1-at-90", _set("reservoir_e_n", -1.01), "e_n"),
    ("mu-inf", _set("reservoir_mu", np.inf), "mu"),
    ("mu-above-cap", _set("reservoir_mu", 2e12), "mu"),
    ("mu-tangential-too-fast", _set("reservoir_mu", -0.2, (0, 0, 0, 0)), "mu"),
    ("ratio-doubled", _set("reservoir_speed_ratio", 2.0), "speed_ratio"),
    ("ratio-1-ulp-above", _set("reservoir_speed_ratio", math.nextafter(1, 2)), "speed"),
    ("ratio-negative", _set("reservoir_speed_ratio", -0.1), "speed_ratio"),
    ("ratio-nan", _set("reservoir_speed_ratio", np.nan), "speed_ratio"),
    ("capture-1.5", _set("capture_probability", 1.5), "capture_probability"),
    ("angle-node-0", _axis("angle_deg", [0.0, 50.0, 90.0]), "angle_deg"),
    ("angle-node-95", _axis("angle_deg", [15.0, 50.0, 95.0]), "angle_deg"),
    ("angle-node-negative", _axis("angle_deg", [-15.0, 50.0, 90.0]), "angle_deg"),
    ("angles-unsorted", _axis("angle_deg", [50.0, 15.0, 90.0]), "angle_deg"),
    (
        "diameters-equal-in-log",
        _axis("diameter_um", [5.0, 1e300, math.nextafter(1e300, math.inf)]),
        "diameter_um",
    ),
]


@pytest.fixture(scope="module")
def dataset():
    ds = synthetic_dataset()
    # node (0, 0, 0, 0) at 15 deg: cos 15 - mu (1 + e_n) sin 15 with mu = -0.2
    # exceeds 1 unless e_n is low; make sure the crafted case breaks the bound
    ds["reservoir_e_n"].values[0, 0, 0, 0, 0] = 0.9
    return ds


@pytest.mark.parametrize(
    ("case", "change", "named"), CRAFTED, ids=[c[0] for c in CRAFTED]
)
def test_tables_outside_the_ranges_are_refused_by_every_reader(
    swl, dataset, case, change, named, tmp_path, monkeypatch
):
    assert WallLaw(dataset) is not None  # the untouched table is valid
    bad = change(dataset)
    with pytest.raises(ValueError, match=named):  # the writer refuses
        export_c.write_binary(bad, tmp_path / "refused.swl")
    assert not (tmp_path / "refused.swl").exists()
    with pytest.raises(DataFormatError, match=named) as err:  # Python reader
        WallLaw(bad)
    assert "\n" not in str(err.value) and "np." not in str(err.value)
    # the C reader, on the same table written past the writer's check
    monkeypatch.setattr(export_c, "_check", lambda names, ds: None)
    path = export_c.write_binary(bad, tmp_path / "crafted.swl")
    rc, handle = swl.load(path)  # with traps on: a NaN compared would be SIGFPE
    assert rc == E_VALUE and handle.value is None, (case, swl.lib.swl_strerror(rc))
    assert b"documented range" in swl.lib.swl_strerror(rc)


def test_a_signalling_nan_is_read_quietly(swl, dataset, tmp_path):
    """A signalling NaN raises FE_INVALID even in isnan(): swl_load turns every
    NaN into the quiet one by its bits. As a capture probability it is "no data";
    as a reservoir value it is refused."""
    data = export_c.encode(dataset)
    nodes = 2 * 3 * 4 * 3
    capture_at = 64 + 2 * 64 + 8 * (3 + 4 + 3)
    e_n_at = capture_at + 8 * nodes
    path = tmp_path / "snan.swl"
    snan = 0x7FF0000000000001
    node = (0 * 3 + 0) * 4 * 3 + 0 * 3 + 2  # node (0, 0, 0, 2)
    path.write_bytes(_patched(data, capture_at + 8 * node, "<Q", snan, crc=True))
    rc, handle = swl.load(path)
    assert rc == 0
    try:
        status, _, vel = swl.sample(handle, 0, 1.0, 0.5, 90.0, [0.0] * 5)
        assert status == 2 and np.isnan(vel).all()  # SWL_NO_DATA
    finally:
        swl.lib.swl_free(handle)
    path.write_bytes(_patched(data, e_n_at + 8 * node * 8, "<Q", snan, crc=True))
    assert swl.load(path)[0] == E_VALUE


def test_a_subnormal_direction_is_scaled_without_overflow(swl, dataset, tmp_path):
    """A sample whose direction per unit speed is subnormal (e_n = 1e-320 at 90
    degrees and mu = cos(pi/2), so U_x = 0 exactly) scales to |U| = speed_ratio s
    straight out of the wall: (0, 0, 0.25) for s = 0.5 and speed_ratio 0.5, in C
    (with traps: ratio s / |u| would overflow) and in Python."""
    ds = dataset.copy(deep=True)
    at = (0, 0, 0, 2, 0)  # 1 um, 0.5 m/s, 90 deg, sample 0
    ds["capture_probability"].values[at[:4]] = 0.0
    ds["reservoir_e_n"].values[at] = 1e-320
    ds["reservoir_mu"].values[at] = math.cos(math.pi / 2)
    ds["reservoir_lateral_angle_deg"].values[at] = 0.0
    ds["reservoir_speed_ratio"].values[at] = 0.5
    path = export_c.write_binary(ds, tmp_path / "tiny.swl")
    u = [0.99, 0.99, 0.5, 0.5, 0.0]  # lower d and v nodes, the 90-deg node, sample 0
    rc, handle = swl.load(path)
    assert rc == 0
    try:
        status, _, vel = swl.sample(handle, 0, 1.0, 0.5, 90.0, u)
    finally:
        swl.lib.swl_free(handle)
    assert status == 0
    np.testing.assert_allclose(vel, [0.0, 0.0, 0.25], rtol=1e-15, atol=0)
    py = WallLaw(ds).sample_uniform(1.0, 0.5, 90.0, [u])
    np.testing.assert_allclose(py.velocity[0], [0.0, 0.0, 0.25], rtol=1e-15, atol=0)


# --------------------------------------------------- queries that trap nothing
@pytest.mark.parametrize(
    ("d", "v", "a"),
    [
        (float("nan"), 1.0, 45.0),
        (1.0, float("nan"), 45.0),
        (1.0, 1.0, float("nan")),
        (float("inf"), 1.0, 45.0),
        (1.0, float("-inf"), 45.0),
        (1.0, 1e-320, 45.0),  # subnormal: |U| <= s cannot be rounded so
    ],
)
def test_nan_and_inf_queries_are_refused_without_a_trap(
    swl, dataset, tmp_path, d, v, a
):
    path = export_c.write_binary(dataset, tmp_path / "t.swl")
    rc, handle = swl.load(path)
    assert rc == 0
    try:
        status, _, vel = swl.sample(handle, 0, d, v, a, [0.5] * 5)
        assert status == -1 and np.isnan(vel).all()
        status, _, vel = swl.sample(handle, 0, 1.0, 1.0, 45.0, [float("nan")] * 5)
        assert status == -1
    finally:
        swl.lib.swl_free(handle)


# ------------------------------------------------------ the writer's guarantee
@settings(max_examples=200, deadline=None)
@given(
    xs=st.lists(
        st.floats(1.0, 100.0).flatmap(
            lambda x: st.sampled_from([x, np.nextafter(x, 0.0), np.nextafter(x, 1e9)])
        ),
        min_size=1,
        max_size=6,
    )
)
def test_a_spec_the_scenario_accepts_has_axes_the_readers_accept(xs):
    """Node axes as typed (near-duplicates one ulp apart included, the case
    hypothesis found: 80 and 79.99999999999999 have one logarithm): a spec either
    refuses them naming the pair, or holds axes the table's readers accept."""
    from microimpact.errors import ScenarioError
    from microimpact.wall_law.checks import axis_problem

    try:
        spec = WallLawSpec(diameters_um=xs, speeds_m_s=xs, angles_deg=(60.0, 90.0))
    except ScenarioError as exc:
        assert "are one node on the table's logarithmic axis" in str(exc)
        return
    assert axis_problem("diameter_um", spec.diameters_um, log=True) is None
    assert axis_problem("speed_m_s", spec.speeds_m_s, log=True) is None


@settings(
    max_examples=6,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    angles=st.lists(st.floats(0.5, 90.0), min_size=1, max_size=3, unique=True),
    std=st.sampled_from([0.0, 8.0, 30.0]),
    reservoir=st.integers(1, 24),
    seed=st.integers(0, 2**32),
    stay=st.none()
    | st.tuples(
        st.lists(st.floats(0.0, 5.0), min_size=1, max_size=3),
        st.floats(0.0, 1e6),
        st.none() | st.tuples(st.floats(1e-4, 0.1), st.floats(1.01, 10.0)),
    ),
)
def test_the_writer_never_writes_what_the_readers_refuse(
    swl, tmp_path, angles, std, reservoir, seed, stay
):
    """Built tables at random (grazing to normal incidence, smooth to very rough:
    e_n reaches 1 / sin(angle), re-impacts make it negative; with or without a
    resuspension column of any flow and adhesion) always pass the Python reader,
    the writer and the C reader under traps, and C rebounds are finite and never
    faster than the impact; only captures are flagged resuspended."""
    surfaces = (
        (mi.SurfaceVariant("smooth"),)
        if std == 0
        else (mi.SurfaceVariant("r", mi.normal_angles(std)),)
    )
    spec = WallLawSpec(
        diameters_um=(3.0, 30.0),
        speeds_m_s=(0.3, 10.0),
        angles_deg=sorted(angles),
        reservoir=reservoir,
        samples=96,
    )
    res = None
    if stay is not None:
        u_tau, exposure, adhesion = stay
        median, spread = adhesion if adhesion is not None else (None, None)
        res = ResuspensionSpec(
            friction_velocities_m_s=tuple(u_tau),
            exposures_s=(exposure,),
            surface_energy_j_m2=0.56,
            density_kg_m3=1.2,
            kinematic_viscosity_m2_s=1.5e-5,
            adhesion_median=median,
            adhesion_spread=spread,
        )
    with warnings.catch_warnings():  # Biasi at 30 um: outside its fitted range
        warnings.simplefilter("ignore", AdhesionRangeWarning)
        # the Python reader
        law = build_wall_law(_scenario(surfaces, seed=seed), spec, resuspension=res)
    path = export_c.write_binary(law, tmp_path / f"w{seed}.swl")  # the writer
    rc, handle = swl.load(path)
    assert rc == 0, swl.lib.swl_strerror(rc)
    try:
        rng = np.random.default_rng(seed)
        n = 400
        d = np.exp(rng.uniform(np.log(0.5), np.log(100.0), n))
        v = np.exp(rng.uniform(np.log(0.05), np.log(50.0), n))
        a = rng.uniform(0.1, 90.0, n)
        status, flags, vel = swl.sample_n(handle, 0, d, v, a, rng.random((n, 5)))
        assert not np.any((flags & 16) & (status != 1))  # SWL_FLAG_RESUSPENDED
        reb = status == 0
        assert np.isfinite(vel[reb]).all()
        assert np.all(np.linalg.norm(vel[reb], axis=1) <= v[reb] * (1 + 1e-12))
    finally:
        swl.lib.swl_free(handle)


# ------------------------------------------------------------------ fuzzing
def test_real_tables_load_and_sample_under_sanitizers_and_traps(fuzzer, real_tables):
    counts = _run(fuzzer, "check", *real_tables)
    assert counts["loads"] == {0: len(real_tables)}
    assert counts["results"].get(0, 0) > 0  # rebounds were checked


def test_fuzzed_tables_never_trap_crash_or_speed_up(fuzzer, real_tables, tmp_path):
    """A few seconds of mutated real tables (CRC rewritten): every file is loaded
    or refused with a named code, and every sample of what loads keeps the
    contract (swl_fuzz.c)."""
    counts = _run(fuzzer, "fuzz", 34, 2.0, 20000, tmp_path, *real_tables)
    assert counts["iterations"] >= 200
    loads = counts["loads"]
    assert loads.get(0, 0) > 0 and loads.get(E_VALUE, 0) > 0  # both reached
    assert set(loads) <= {0, -2, -3, -4, -5, -6, -7, -8, -9}
    assert counts["results"].get(E_UNIT, 0) > 0  # wrong units refused


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_fuzzing_for_longer(fuzzer, real_tables, tmp_path, seed):
    counts = _run(
        fuzzer, "fuzz", seed, 30.0, 10**8, tmp_path, *real_tables, timeout=300
    )
    assert counts["iterations"] >= 2000 and counts["loads"].get(0, 0) > 0


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            _axis("angle_deg", [15.0, 50.0, 95.0]),
            "angle_deg must be in (0, 90]; node 2 is 95",
        ),
        (
            _axis("speed_m_s", [-0.5, 2.0, 8.0, 30.0]),
            "speed_m_s must be finite and > 0; node 0 is -0.5",
        ),
        (
            _set("reservoir_speed_ratio", 2.0),
            "reservoir_speed_ratio must be in [0, 1] where it is held; at surface 0, "
            "diameter_um 0, speed_m_s 0, angle_deg 2, sample 0 it is 2",
        ),
        (
            _set("capture_probability", 1.5),
            "capture_probability must be in [0, 1] or NaN; at surface 0, "
            "diameter_um 0, speed_m_s 0, angle_deg 2 it is 1.5",
        ),
        (
            _set("reservoir_count", 9),
            "reservoir_count must be in [0, 8]; at surface 0, diameter_um 0, "
            "speed_m_s 0, angle_deg 2 it is 9",
        ),
        (
            _set("reservoir_count", -1),
            "reservoir_count must be in [0, 8]; at surface 0, diameter_um 0, "
            "speed_m_s 0, angle_deg 2 it is -1",
        ),
        (
            _set("reservoir_e_n", 1e300),
            "reservoir_e_n must be in [-1e+06, 1e+06] where it is held; at surface 0,"
            " diameter_um 0, speed_m_s 0, angle_deg 2, sample 0 it is 1e+300",
        ),
        (
            _set("reservoir_mu", 2e12),
            "reservoir_mu must be in [-1e+12, 1e+12] where it is held",
        ),
        (
            _set("reservoir_lateral_angle_deg", 90.0),
            "reservoir_lateral_angle_deg must be in (-90, 90) where it is held",
        ),
        (
            _set("reservoir_e_n", 1.01),
            "reservoir_e_n must be such that |e_n sin(angle)| <= 1 (no normal "
            "rebound faster than the impact) where it is held",
        ),
        (
            _set("reservoir_mu", -0.2, (0, 0, 0, 0)),
            "reservoir_mu must be such that |cos(angle) - mu (1 + e_n) sin(angle)| "
            "<= 1 (no tangential rebound faster than the impact) where it is held; "
            "at surface 0, diameter_um 0, speed_m_s 0, angle_deg 0, sample 0 it is "
            "-0.2",
        ),
    ],
)
def test_the_message_names_the_node_and_the_value(dataset, change, message):
    with pytest.raises(DataFormatError) as err:
        WallLaw(change(dataset))
    assert message in str(err.value), str(err.value)


def test_python_refuses_a_subnormal_speed_as_c_does(dataset):
    with pytest.raises(ValueError, match="speed_m_s"):
        WallLaw(dataset).sample(1.0, 1e-320, 45.0, rng=1)


def test_the_bounds_themselves_are_inside(dataset):
    """A rebound exactly as fast as the impact is allowed: e_n = 1, mu = 0 at 90
    degrees (|U_z| = s), a speed ratio of exactly 1 and 0."""
    ds = dataset.copy(deep=True)
    at = (0, 0, 0, 2, 0)
    ds["reservoir_e_n"].values[at] = 1.0
    ds["reservoir_e_n"].values[(0, 0, 0, 2, 1)] = -1.0
    ds["reservoir_mu"].values[at] = 0.0
    ds["reservoir_speed_ratio"].values[at] = 1.0
    ds["reservoir_speed_ratio"].values[(0, 0, 0, 2, 1)] = 0.0
    assert int(ds["reservoir_count"].values[at[:4]]) >= 2
    assert WallLaw(ds) is not None


def test_any_dimension_order_is_read_in_node_order(dataset):
    """A table whose dimensions another writer put in another order is the same
    law: the same node arrays and draws, and a value out of range is named at
    its own node (the checks and the reader transpose each variable)."""
    order = ("sample", "angle_deg", "surface", "speed_m_s", "diameter_um")
    a, b = WallLaw(dataset), WallLaw(dataset.transpose(*order))
    np.testing.assert_array_equal(a._p, b._p)
    np.testing.assert_array_equal(a._count, b._count)
    for name in a._res:
        np.testing.assert_array_equal(a._res[name], b._res[name], err_msg=name)
    d = np.geomspace(dataset["diameter_um"].values[0], 50.0, 40)
    draws = [law.sample(d, 2.0, 45.0, rng=np.random.default_rng(7)) for law in (a, b)]
    np.testing.assert_array_equal(draws[0].velocity, draws[1].velocity)
    bad = _set("reservoir_count", 9)(dataset).transpose(*order)
    with pytest.raises(DataFormatError) as err:
        WallLaw(bad)
    assert (
        "reservoir_count must be in [0, 8]; at surface 0, diameter_um 0, "
        "speed_m_s 0, angle_deg 2 it is 9"
    ) in str(err.value)
