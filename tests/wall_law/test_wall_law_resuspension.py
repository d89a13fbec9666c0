"""The wall law's resuspension column (issue 32 item 4): ``stay_probability``.

Oracles: the Rock'n'Roll quadrature of
:func:`microimpact.physics.resuspension.remaining_fraction_ramp` at each diameter
node (computed here, not read back from the table); closed forms (no flow leaves
everything; a delta-function adhesion decays as exp(-p t), p written out below
from the paper's erf form); the format of ``c/swl.h`` (sizes, offsets, the
sections word, CRC-32); an independent NumPy rule for the conditional stay
probability of a query; the frequency of "stays" among sampled captures against
that probability within 4 standard errors. C (ctypes) and Python must give the
same flags for the same uniforms (test_wall_law_c.py, on every format).
"""

from __future__ import annotations

import ctypes
import json
import math
import re
import struct
import warnings
import zlib

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_wall_law_c import (
    C_DIR,
    CAPTURED,
    CC,
    E_CHECKSUM,
    E_SIZE,
    E_TRUNCATED,
    E_VALUE,
    REBOUND,
    STAY,
    TRAPS,
    K,
    Swl,
    compile_shared,
    fluent_udf,
    queries,
    reference_sample,
    synthetic_dataset,
    with_stay,
)

import microimpact as mi
from microimpact.cli import main
from microimpact.errors import DataFormatError
from microimpact.physics import resuspension as rnr
from microimpact.scenario.resuspension import ResuspensionSpec
from microimpact.wall_law import WallLaw, WallLawSpec, build_wall_law, export_c
from microimpact.wall_law.export_c import read_binary, write_binary

pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler")

RESUSPENDED = 16  # swl.h: SWL_FLAG_RESUSPENDED
E_NO_STAY = -11
AIR = {"density_kg_m3": 1.2, "kinematic_viscosity_m2_s": 1.5e-5}


# ------------------------------------------------------------------ helpers
def _scenario(**kw):
    coefficients = mi.ImpactCoefficients(
        k1=4.0,
        k2=mi.PowerLaw(a=0.05, b=-1.5, d_ref=10e-6),
        v_c=kw.pop("v_c", mi.PowerLaw(a=0.5, b=-1.0, d_ref=10e-6)),
        friction=0.2,
    )
    return mi.Scenario(
        name="stay",
        particles=mi.lognormal_diameters(10.0, 1.5),
        coefficients=coefficients,
        surfaces=(
            mi.SurfaceVariant("smooth"),
            mi.SurfaceVariant("r", mi.normal_angles(8.0)),
        ),
        seed=5,
        samples=kw.pop("samples", 200),
    )


SPEC = WallLawSpec(
    diameters_um=(1.0, 4.0, 16.0),
    speeds_m_s=(0.3, 3.0),
    angles_deg=(20.0, 90.0),
    reservoir=8,
)


def _spec(u=(0.5, 1.0, 2.0), t=(1.0, 2.0, 0.5), **kw):
    return ResuspensionSpec(
        friction_velocities_m_s=u,
        exposures_s=t,
        surface_energy_j_m2=kw.pop("gamma", 0.56),
        **AIR,
        **kw,
    )


def _paper_rate(radius, u_tau, gamma, fprime):
    """The quasi-static rate p [1/s] of one particle, written out from Reeks &
    Hall (2001) / Biasi et al. (2001) with the erf form of Phi (not the code's
    log_ndtr), for the closed-form check."""
    rho, nu = AIR["density_kg_m3"], AIR["kinematic_viscosity_m2_s"]
    r_plus = radius * u_tau / nu
    drag = 32.0 * rho * nu**2 * r_plus**2
    lift = 20.9 * rho * nu**2 * r_plus**2.31
    mean = 0.5 * lift + 100.0 * drag
    rms = 0.2 * mean
    n_theta = 0.00658 * u_tau**2 / nu
    fa = fprime * 1.5 * math.pi * gamma * radius
    x = (fa - mean) / rms
    return n_theta * math.exp(-0.5 * x * x) / (0.5 * (1.0 + math.erf(x / math.sqrt(2))))


@pytest.fixture(scope="module")
def swl(tmp_path_factory):
    lib = Swl(
        compile_shared([C_DIR / "swl.c", TRAPS], tmp_path_factory.mktemp("s") / "l.so")
    )
    d, i, vp = ctypes.c_double, ctypes.c_int, ctypes.c_void_p
    P = ctypes.POINTER
    raw = lib.lib._lib if hasattr(lib.lib, "_lib") else lib.lib
    raw.swl_stay_probability.argtypes = [vp, i, d, d, d, P(d), P(i)]
    raw.swl_has_stay.argtypes = [vp]
    return lib


@pytest.fixture(scope="module")
def stay_ds():
    return with_stay(synthetic_dataset())


def _stay_c(swl, handle, surface, d, v, a):
    out, codes = np.empty(len(d)), np.empty(len(d), int)
    p, f = ctypes.c_double(), ctypes.c_int()
    for j in range(len(d)):
        codes[j] = swl.lib.swl_stay_probability(
            handle, surface, d[j], v[j], a[j], ctypes.byref(p), ctypes.byref(f)
        )
        out[j] = p.value
    return codes, out


def _stay_reference(ds, surface, t_fractions, lower):
    """P(stay | captured) of each query from the corner weights written out
    independently: weights prod(t or 1 - t), sums over corners with data."""
    dims = ("surface", "diameter_um", "speed_m_s", "angle_deg")
    p = ds["capture_probability"].transpose(*dims).values
    q = ds["stay_probability"].transpose(*dims).values
    n = t_fractions.shape[0]
    out = np.empty(n)
    for j in range(n):
        num = den = wq = ws = 0.0
        for bits in np.ndindex(2, 2, 2):
            w = np.prod(
                [t if b else 1 - t for b, t in zip(bits, t_fractions[j], strict=True)]
            )
            if w == 0:
                continue
            idx = tuple(
                min(lower[a][j] + b, p.shape[a + 1] - 1) for a, b in enumerate(bits)
            )
            pc, qc = p[(surface, *idx)], q[(surface, *idx)]
            if np.isnan(pc):
                continue
            num, den, wq, ws = num + w * pc * qc, den + w * pc, wq + w * qc, ws + w
        out[j] = num / den if den > 0 else (wq / ws if ws > 0 else np.nan)
    return out


def _lower(ds, d, v, a):
    """The lower node of each query on each axis (np.searchsorted, clipped)."""
    out = []
    for c, x in (("diameter_um", d), ("speed_m_s", v), ("angle_deg", a)):
        coord = ds[c].values
        out.append(
            np.clip(
                np.searchsorted(coord, x, side="right") - 1, 0, max(coord.size - 2, 0)
            )
        )
    return out


# --------------------------------------------------- the column and its oracle
def test_the_column_is_the_quadrature_at_each_diameter_node():
    res = _spec()
    law = build_wall_law(_scenario(), SPEC, resuspension=res)
    q = (
        law.dataset["stay_probability"]
        .transpose("surface", "diameter_um", "speed_m_s", "angle_deg")
        .values
    )
    for j, d_um in enumerate(SPEC.diameters_um):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rnr.AdhesionRangeWarning)
            want = rnr.remaining_fraction_ramp(
                d_um * 1e-6 / 2, [0.5, 1.0, 2.0], [1.0, 2.0, 0.5], 1.2, 1.5e-5, 0.56
            )[-1]
        assert_allclose(q[:, j], want, rtol=1e-12, atol=0)  # every (s, v, theta)
    assert 0.0 < q.min() < q.max() < 1.0  # the flow removes some, not all
    attrs = law.dataset["stay_probability"].attrs
    assert_allclose(attrs["friction_velocity_m_s"], [0.5, 1.0, 2.0])
    assert_allclose(attrs["exposure_s"], [1.0, 2.0, 0.5])
    assert (
        "quasi-steady" in attrs["assumptions"] and "independent" in attrs["assumptions"]
    )
    # the capture columns are those of a build without resuspension
    plain = build_wall_law(_scenario(), SPEC)
    for v in ("capture_probability", "reservoir_e_n", "reservoir_count"):
        np.testing.assert_array_equal(law.dataset[v].values, plain.dataset[v].values)
    assert "stay_probability" not in plain.dataset and not plain.has_stay_probability


def test_no_flow_leaves_everything():
    law = build_wall_law(_scenario(), SPEC, resuspension=_spec(u=(0.0,), t=(100.0,)))
    assert np.all(law.dataset["stay_probability"].values == 1.0)


def test_a_delta_adhesion_decays_at_the_papers_rate():
    # spread 1 + 1e-6: every particle has f' = median, and the stay probability
    # after a ramp is exp(-sum p_k t_k), p from the erf form. The second step's
    # friction velocity is solved (brentq, on the erf form) so that the 16 um
    # node's exponent is 1: its stay probability is 1/e.
    from scipy.optimize import brentq

    median, t, r16 = 0.01, (2.0, 3.0), 8e-6

    def exponent(radius, u):
        return sum(
            _paper_rate(radius, uk, 0.56, median) * tk
            for uk, tk in zip(u, t, strict=True)
        )

    u2 = brentq(lambda x: exponent(r16, (0.3, x)) - 1.0, 0.3, 5.0, xtol=1e-14)
    res = _spec(u=(0.3, u2), t=t, adhesion_median=median, adhesion_spread=1 + 1e-6)
    law = build_wall_law(_scenario(), SPEC, resuspension=res)
    q = law.dataset["stay_probability"].values[0, :, 0, 0]
    assert_allclose(q[-1], math.exp(-1.0), rtol=1e-4)
    for j, d_um in enumerate(SPEC.diameters_um):
        want = math.exp(-exponent(d_um * 1e-6 / 2, (0.3, u2)))
        assert_allclose(q[j], want, rtol=1e-4, atol=1e-12)


# ------------------------------------------------------ the binary format
def test_format_3_holds_the_section_and_old_formats_are_unchanged(stay_ds, tmp_path):
    path = write_binary(stay_ds, tmp_path / "s.swl")
    data = path.read_bytes()
    n = 2 * 3 * 4 * 3
    base = 64 + 2 * 64 + 8 * (3 + 4 + 3) + 8 * n * (1 + 4 * K) + 4 * n
    assert len(data) == base + 8 * n  # swl.h: plus 8 N with the section
    assert struct.unpack_from("<8sI", data) == (b"SWLTABL\0", 3)
    assert struct.unpack_from("<I", data, 52) == (1,)  # sections: bit 0
    assert data[56:64] == bytes(8)
    assert struct.unpack_from("<I", data, 48)[0] == zlib.crc32(data[64:])
    stay = np.frombuffer(data, "<f8", n, base).reshape(2, 3, 4, 3)
    np.testing.assert_array_equal(stay[:, :, 0, 0], np.array([STAY, STAY]))
    back = read_binary(path)
    np.testing.assert_array_equal(
        back["stay_probability"].values, stay_ds["stay_probability"].values
    )
    # without the column: version 2 as before, byte for byte
    plain = synthetic_dataset()
    assert export_c.encode(plain) == export_c.encode(plain, 2)
    assert struct.unpack_from("<I", export_c.encode(plain), 8) == (2,)
    # version 3 without sections is version 2 but for the version word
    v3 = export_c.encode(plain, 3)
    assert (
        v3[:8] + v3[12:]
        == export_c.encode(plain, 2)[:8] + export_c.encode(plain, 2)[12:]
    )
    with pytest.raises(ValueError, match="version 3"):
        export_c.encode(stay_ds, 2)


def test_c_reads_the_section_and_refuses_bad_ones(swl, stay_ds, tmp_path):
    data = export_c.encode(stay_ds)
    n = 2 * 3 * 4 * 3
    at = len(data) - 8 * n
    path = tmp_path / "t.swl"

    def load(content):
        path.write_bytes(content)
        rc, handle = swl.load(path)
        if rc == 0:
            has = swl.lib.swl_has_stay(handle)
            swl.lib.swl_free(handle)
            return rc, has
        return rc, None

    def patched(offset, fmt, *values, crc=True):
        out = bytearray(data)
        struct.pack_into(fmt, out, offset, *values)
        if crc:
            struct.pack_into("<I", out, 48, zlib.crc32(bytes(out[64:])))
        return bytes(out)

    assert load(data) == (0, 1)
    assert load(export_c.encode(synthetic_dataset())) == (0, 0)  # version 2
    assert load(export_c.encode(synthetic_dataset(), 3)) == (0, 0)  # no section
    for bad in (1.5, -0.1, math.nan, math.inf, math.nextafter(1.0, 2.0)):
        assert load(patched(at + 8 * 5, "<d", bad))[0] == E_VALUE, bad
    assert load(patched(at, "<d", 1.0))[0] == 0  # the bounds themselves
    assert load(patched(at, "<d", 0.0))[0] == 0
    assert (
        load(patched(at + 3, "<B", 0x55, crc=False))[0] == E_CHECKSUM
    )  # CRC covers it
    assert load(data[:-8])[0] == E_TRUNCATED
    assert load(data[: -8 * n])[0] == E_TRUNCATED  # the section announced, absent
    assert load(patched(52, "<I", 3, crc=False))[0] == E_SIZE  # an unknown section
    assert load(patched(52, "<I", 0, crc=False))[0] == E_SIZE  # trailing section bytes
    assert load(patched(8, "<I", 2, crc=False))[0] == E_SIZE  # version 2: no sections
    assert load(patched(60, "<B", 1, crc=False))[0] == E_SIZE  # reserved
    with pytest.raises(DataFormatError):  # the Python reader of the .swl refuses too
        path.write_bytes(patched(52, "<I", 3, crc=False))
        read_binary(path)


@pytest.mark.parametrize("bad", [1.5, -0.25, np.nan, np.inf])
def test_every_reader_and_the_writer_refuse_a_bad_column(stay_ds, bad, tmp_path):
    ds = stay_ds.copy(deep=True)
    ds["stay_probability"].values[1, 2, 0, 1] = bad
    with pytest.raises(DataFormatError, match="stay_probability") as err:
        WallLaw(ds)
    assert "\n" not in str(err.value) and "np." not in str(err.value)
    with pytest.raises(ValueError, match="stay_probability"):
        write_binary(ds, tmp_path / "bad.swl")
    assert not (tmp_path / "bad.swl").exists()


# --------------------------------------------------------- C against Python
def test_stay_probability_of_a_query_in_c_python_and_by_hand(swl, stay_ds, tmp_path):
    rc, handle = swl.load(write_binary(stay_ds, tmp_path / "s.swl"))
    assert rc == 0
    law = WallLaw(stay_ds)
    rng = np.random.default_rng(7)
    _, d, v, a, u = queries(3000, rng)
    try:
        for surface in (0, 1):
            codes, c_q = _stay_c(swl, handle, surface, d, v, a)
            py_q = law.stay_probability(d, v, a, surface=surface)
            t = reference_sample(stay_ds, surface, d, v, a, u)[3]
            want = _stay_reference(stay_ds, surface, t, _lower(stay_ds, d, v, a))
            ok = codes == 0
            assert np.all(ok | np.isnan(want)) and np.all(codes[~ok] == 2)
            assert_allclose(c_q[ok], want[ok], rtol=1e-12, atol=1e-15)
            assert_allclose(py_q, c_q, rtol=1e-12, atol=1e-15, equal_nan=True)
            assert np.mean(py_q[ok] == c_q[ok]) > 0.99  # the same bits, but for log
            assert np.all((c_q[ok] >= 0) & (c_q[ok] <= 1))
        # on a diameter node, far from capture edges: that node's value
        assert_allclose(law.stay_probability(5.0, 2.0, 50.0), 0.37, rtol=1e-12)
        p = ctypes.c_double()
        assert (
            swl.lib.swl_stay_probability(
                handle, 0, 0.0, 1.0, 40.0, ctypes.byref(p), None
            )
            == -1
        )
        assert math.isnan(p.value)
    finally:
        swl.lib.swl_free(handle)
    rc, plain = swl.load(write_binary(synthetic_dataset(), tmp_path / "p.swl"))
    p = ctypes.c_double()
    assert (
        swl.lib.swl_stay_probability(plain, 0, 4.0, 2.0, 50.0, ctypes.byref(p), None)
        == E_NO_STAY
    )
    assert b"stay" in swl.lib.swl_strerror(E_NO_STAY)
    swl.lib.swl_free(plain)
    with pytest.raises(ValueError, match="resuspension"):
        WallLaw(synthetic_dataset()).stay_probability(4.0, 2.0, 50.0)


def test_the_share_that_stays_is_the_stay_probability(swl, stay_ds, tmp_path):
    # u[3] decides capture and staying: among sampled captures at a query the
    # share that stays is P(stay | captured), within 4 standard errors
    rc, handle = swl.load(write_binary(stay_ds, tmp_path / "s.swl"))
    assert rc == 0
    rng = np.random.default_rng(2026)
    try:
        for d, v, a in ((2.0, 1.0, 40.0), (9.0, 5.0, 70.0), (4.0, 0.7, 90.0)):
            n = 100_000
            u = rng.random((n, 5))
            status, flags, _ = swl.sample_n(
                handle, 0, np.full(n, d), np.full(n, v), np.full(n, a), u
            )
            captured = status == CAPTURED
            stays = captured & ((flags & RESUSPENDED) == 0)
            share = stays.sum() / captured.sum()
            q = float(_stay_c(swl, handle, 0, [d], [v], [a])[1][0])
            se = math.sqrt(q * (1 - q) / captured.sum())
            assert abs(share - q) < 4 * se + 1e-12, (d, v, a, share, q, se)
            assert {REBOUND, CAPTURED} <= set(status)
    finally:
        swl.lib.swl_free(handle)


# --------------------------------------- the scenario, the CLI, the adhesion range
TOML = """
name = "stay-cli"
seed = 4
samples = 150
[particles]
distribution = "lognormal"
median_um = 8
geometric_std = 1.5
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = {v_c}
[sweep]
speed_m_s = [0.5, 2.0]
angle_deg = [90]
[wall_law]
diameter_um = {diameters}
speed_m_s = [0.3, 3.0]
angle_deg = [30, 90]
reservoir = 8
[resuspension]
friction_velocity_m_s = [0.5, 1.0]
exposure_s = 2.0
{gamma}fluid = {{ name = "air", temperature_k = 293.15, pressure_pa = 101325 }}
"""


def _toml(
    diameters="[2.0, 6.0, 12.0]", gamma="surface_energy_j_m2 = 0.56\n", v_c="0.2"
):
    return TOML.format(diameters=diameters, gamma=gamma, v_c=v_c)


def test_the_wall_law_verb_writes_the_column_everywhere(tmp_path, capsys):
    (tmp_path / "s.toml").write_text(_toml())
    out = tmp_path / "out"
    assert (
        main(["wall-law", str(tmp_path / "s.toml"), "--out", str(out), "--quiet"]) == 0
    )
    law = WallLaw.open(out)
    q = law.dataset["stay_probability"].values
    rho, nu = rnr.air_properties(293.15, 101325.0)
    want = [
        rnr.remaining_fraction_ramp(
            d * 1e-6 / 2, [0.5, 1.0], [2.0, 2.0], rho, nu, 0.56
        )[-1]
        for d in (2.0, 6.0, 12.0)
    ]
    assert_allclose(q[0, :, 0, 0], want, rtol=1e-12)
    back = read_binary(out / "c" / "wall_law.swl")
    assert back.attrs["format_version"] == 3
    np.testing.assert_array_equal(back["stay_probability"].values, q)
    import pandas as pd

    csv = pd.read_csv(out / "wall_law.csv")
    assert_allclose(np.sort(csv["stay_probability"].unique()), np.sort(want), rtol=1e-8)
    assert "stay probability" in (out / "c" / "README.md").read_text().replace("_", " ")


def test_a_diameter_node_beyond_biasi_is_refused_and_outside_its_fit_warned(
    tmp_path, capsys
):
    # leftover (b): the range named where a radius enters the wall-law column
    (tmp_path / "big.toml").write_text(_toml(diameters="[2.0, 80.0]"))
    rc = main(["wall-law", str(tmp_path / "big.toml"), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    for part in (
        "big.toml",
        "resuspension.adhesion",
        "wall_law.diameter_um",
        "80",
        "70",
    ):
        assert part in err[0], (part, err)
    assert not (tmp_path / "o" / "wall_law.nc").exists()

    def nodes(*d_um):
        return WallLawSpec(
            diameters_um=d_um, speeds_m_s=(0.3,), angles_deg=(90.0,), reservoir=4
        )

    with pytest.warns(
        rnr.AdhesionRangeWarning,
        match=r"diameter 30 µm \(wall_law\.diameter_um\).*0\.2 to 20 µm.*0\.1 to 10",
    ):
        build_wall_law(tmp_path / "big.toml", nodes(2.0, 30.0))
    with warnings.catch_warnings():  # inside the fitted range: no warning
        warnings.simplefilter("error", rnr.AdhesionRangeWarning)
        build_wall_law(tmp_path / "big.toml", nodes(2.0, 20.0))


def test_the_wall_law_takes_the_surface_energy_from_the_capture_law(tmp_path):
    # without surface_energy_j_m2, gamma is the thornton_ning law's work of
    # adhesion: polystyrene on itself, 2 x 40.7 mJ/m2 (S. Wu 1982)
    tn = '{ law = "thornton_ning", particle = "polystyrene", surface = "polystyrene" }'
    (tmp_path / "m.toml").write_text(_toml(gamma="", v_c=tn))
    law = build_wall_law(
        tmp_path / "m.toml",
        WallLawSpec(
            diameters_um=(4.0,), speeds_m_s=(0.3,), angles_deg=(90.0,), reservoir=4
        ),
    )
    rho, nu = rnr.air_properties(293.15, 101325.0)
    want = rnr.remaining_fraction_ramp(2e-6, [0.5, 1.0], 2.0, rho, nu, 2 * 0.0407)
    assert_allclose(law.dataset["stay_probability"].values, want[-1], rtol=1e-12)
    source = json.loads(law.dataset.attrs["resuspension"])["surface_energy_source"]
    assert "thornton_ning" in source


def test_fluent_counts_the_resuspended(swl, stay_ds, tmp_path, monkeypatch):
    # the wrapper ends a resuspended capture as a capture and counts it apart:
    # its report gives the number swl_rebound_velocity's flags give
    table = write_binary(stay_ds, tmp_path / "t.swl")
    rc, law = swl.load(table)
    assert rc == 0
    udf = fluent_udf(tmp_path, table, monkeypatch, "polished")
    d3 = ctypes.c_double * 3
    rng = np.random.default_rng(3)
    counts = {"captured": 0, "resuspended": 0}
    for _ in range(600):
        v = np.array([rng.normal(), rng.normal(), -abs(rng.normal()) - 0.1]) * 3
        u = rng.random(5).astype(np.float32).astype(float)
        diam = float(np.exp(rng.uniform(np.log(0.8e-6), np.log(25e-6))))
        out, v0 = d3(), d3()
        status = udf.hit(
            d3(*v), d3(0, 0, 1.0), diam, (ctypes.c_double * 5)(*u), out, v0
        )
        rc, flags, _ = swl.rebound(law, 0, diam * 1e6, v, [0, 0, 1.0], u)
        if rc == CAPTURED:
            counts["captured"] += 1
            counts["resuspended"] += bool(flags & RESUSPENDED)
            assert status == 3  # PATH_ABORT, resuspended or not
    swl.lib.swl_free(law)
    assert 0 < counts["resuspended"] < counts["captured"]
    udf.microimpact_wall_report()
    message = udf.message().decode()
    assert (
        f"{counts['captured']} captured ({counts['resuspended']} of them resuspended"
        in message
    )


# ------------------------------------------------------------------ OpenFOAM
def test_openfoam_removes_the_resuspended_captures(tmp_path):
    # The exported coefficients say `resuspension yes;` for a table with the
    # column, and the model then removes, of the parcels captured at a node, the
    # node's stay probability's complement, within 4 SE; the others stick.
    # Switched to no, nothing is removed; a table without the column is
    # exported with no, and switched to yes it is a fatal error that says why.
    # The model is built once per source (foam_box.build_library's cache).
    import shutil

    import test_wall_law_openfoam_model as fm
    from foam_box import build_error, build_library

    if shutil.which(fm.SOLVER) is None:
        pytest.skip("OpenFOAM (Debian package openfoam) is not installed")
    spec = WallLawSpec(
        diameters_um=(10.0, fm.DIAMETER_UM, 40.0),
        speeds_m_s=(0.5, 1.0, 2.0, 4.0),
        angles_deg=(30.0, fm.ANGLE_DEG, 90.0),
        reservoir=256,
        samples=2000,
    )
    scenario = mi.Scenario.from_preset("sst76-formica-oblique").with_options(
        surfaces=(mi.SurfaceVariant("formica", mi.normal_angles(22.0)),)
    )
    res = _spec(u=(0.5,), t=(1.0,))
    with warnings.catch_warnings():  # 40 um: outside Biasi's fitted diameters
        warnings.simplefilter("ignore", rnr.AdhesionRangeWarning)
        law = build_wall_law(scenario, spec, seed=3, resuspension=res)
    out = tmp_path / "law"
    law.write(out)
    rc, libdir, build_log = build_library(out / "openfoam", fm.SOLVER)
    if rc == 3:  # something missing in the environment
        pytest.skip(f"stochasticWallLaw cannot be built here: {build_error(build_log)}")
    assert rc == 0, build_log
    q = float(
        law.dataset["stay_probability"].sel(diameter_um=fm.DIAMETER_UM).values.flat[0]
    )
    assert 0.3 < q < 0.8

    def run(name, exported, switch, table_out=out):
        # the case's coefficients as exported, the switch set to `switch`
        case = tmp_path / name
        fm._case(case, table_out, 1.0, max_reimpacts=0)
        coeffs = case / "constant" / fm.STOCHASTIC_FILE
        text = coeffs.read_text()
        entry = re.compile(r"^(\s*)resuspension\s+(\w+);", re.M)
        assert [m[2] for m in entry.finditer(text)] == [exported], text
        coeffs.write_text(entry.sub(rf"\1resuspension {switch};", text))
        return fm._run(case, libdir, check=False)

    log, rc = run("on", "yes", "yes")
    assert rc == 0, log[-3000:]
    c = fm._counters(log)
    gone = re.findall(r"stochasticWallLaw: resuspended (\d+) of the captured", log)
    assert gone, log[-2000:]
    r, k = int(gone[-1]), c["captured_first"]
    se = math.sqrt(q * (1 - q) / k)
    assert abs((k - r) / k - q) < 4 * se, (k, r, q, se)
    assert c["formica_escape"] == r and c["formica_stick"] == k - r + c["forced"]
    log, rc = run("off", "yes", "no")
    assert rc == 0 and not re.search(r"resuspended \d+", log)
    assert fm._counters(log)["formica_escape"] == 0
    plain = tmp_path / "plain"
    build_wall_law(scenario, spec, seed=3).write(plain)
    log, rc = run("no-column", "no", "yes", table_out=plain)
    assert rc != 0 and "stay_probability" in log
