"""The C sampler of the wall law (src/microimpact/wall_law/c) against Python.

swl.c is compiled with ``cc -std=c99 -Wall -Wextra -Werror`` and called through
ctypes. For the same uniform numbers it must give what docs/wall-law.md, "The
sampling rule", gives: here computed twice in Python, by an independent reference
written in this file and by :meth:`microimpact.wall_law.WallLaw.sample_uniform`.
The two sides call different ``log``/``sin``/``cos``/``tan`` (C library vs NumPy),
which may differ in the last place: velocities are compared to 1e-12 of the speed,
and a query whose cell corner differs is accepted only where a uniform number lay
within 1e-12 of its fraction t (a last-place difference of t flips the choice).
The binary reader must refuse truncated and corrupt files with an error code, and
the Fluent wrapper must compile against a mock udf.h and rebound like
``swl_rebound_velocity``.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import struct
import subprocess
import zlib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from microimpact.wall_law import export_c
from microimpact.wall_law.export_c import read_binary, write_binary, write_c

ROOT = Path(__file__).resolve().parents[2]
C_DIR = ROOT / "src" / "microimpact" / "wall_law" / "c"
MOCK_UDF = ROOT / "tests" / "c" / "mock_udf"
CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler")

FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"]
REBOUND, CAPTURED, NO_DATA = 0, 1, 2
E_ARG, E_IO, E_MAGIC, E_VERSION, E_TRUNCATED, E_SIZE, E_CHECKSUM, E_VALUE = range(
    -1, -9, -1
)
CLAMPED, REIMPACT, RESUSPENDED = 7, 8, 16
TOL = 1e-12

DIMS = ("surface", "diameter_um", "speed_m_s", "angle_deg")
REDUCED_DIMS = ("surface", "diameter_um", "reduced_speed", "angle_deg")
#: The reduced table: ratios r = v / v_c(d) and v_c at the diameter nodes (not a
#: power law, so the interpolation of log v_c in log d is piecewise).
RATIOS = np.array([0.5, 1.0, 2.0, 4.0])
CRITICAL = np.array([2.0, 0.8, 0.5])
CLAMP_TOL = 1e-9  # docs/wall-law.md: relative, in the axis' variable
SURFACES = ("polished", "grit-blasted")
DIAMETERS = np.array([1.0, 5.0, 20.0])
SPEEDS = np.array([0.5, 2.0, 8.0, 30.0])
ANGLES = np.array([15.0, 50.0, 90.0])
K = 8


# ---------------------------------------------------------------- the table
def synthetic_dataset(seed=7):
    """A small wall-law Dataset with the schema of docs/wall-law.md: 2 surfaces x 3
    diameters x 4 speeds x 3 angles, K = 8; reservoirs partly filled, some
    rebounds re-impacting (e_n < 0), one node fully captured, one with no impact."""
    rng = np.random.default_rng(seed)
    shape = (len(SURFACES), DIAMETERS.size, SPEEDS.size, ANGLES.size)
    n_impacts = rng.integers(50, 200, shape)
    p = np.round(rng.uniform(0.0, 0.9, shape), 3)
    p[rng.random(shape) < 0.15] = 0.0
    count = rng.integers(1, K + 1, shape)
    count[rng.random(shape) < 0.5] = K
    p[0, 1, 2, 1], count[0, 1, 2, 1] = 1.0, 0  # every impact captured
    p[1, 0, 0, 0], count[1, 0, 0, 0] = np.nan, 0  # every draw shadowed
    n_impacts[1, 0, 0, 0] = 0
    e_n = rng.uniform(0.2, 0.95, (*shape, K))
    e_n[rng.random(e_n.shape) < 0.1] *= -0.3  # re-impacts
    # within swl.h's value ranges: |U_x| <= s at every node (|mu (1 + e_n)| <= 1)
    mu = rng.uniform(-0.05, 0.5, (*shape, K))
    lateral = rng.uniform(-40.0, 40.0, (*shape, K))
    th = np.deg2rad(ANGLES)[None, None, None, :, None]
    u_x, u_z = np.cos(th) - mu * (1 + e_n) * np.sin(th), e_n * np.sin(th)
    e_t = np.where(ANGLES[:, None] < 90, u_x / np.cos(th), np.nan)
    ratio = np.minimum(np.hypot(u_x, u_z) / np.cos(np.deg2rad(lateral)), 1.0)
    ratio[rng.random(ratio.shape) < 0.02] = 0.0  # a rebound at rest
    held = np.arange(K) < count[..., None]
    res = {
        name: np.where(held, a, np.nan)
        for name, a in (
            ("e_n", e_n),
            ("mu", mu),
            ("e_t", e_t),
            ("lateral_angle_deg", lateral),
            ("speed_ratio", ratio),
        )
    }
    data = {
        "n_impacts": (DIMS, n_impacts),
        "capture_probability": (DIMS, p),
        "reservoir_count": (DIMS, count.astype(np.int32)),
    }
    for name, a in res.items():
        data[f"reservoir_{name}"] = ((*DIMS, "sample"), a)
    return xr.Dataset(
        data,
        coords={
            "surface": np.array(SURFACES, dtype=object),
            "diameter_um": DIAMETERS,
            "speed_m_s": SPEEDS,
            "angle_deg": ANGLES,
            "sample": np.arange(K, dtype=np.int32),
        },
    )


#: Stay probabilities of the three diameters of a table with the resuspension
#: column (format version 3): the edges 1 and 0 and one between.
STAY = (1.0, 0.37, 0.0)


def with_stay(ds, stay=STAY):
    """`ds` with a ``stay_probability`` per diameter node on every node."""
    ds = ds.copy(deep=True)
    p = ds["capture_probability"]
    q = np.asarray(stay, float)[None, :, None, None]
    ds["stay_probability"] = (p.dims, np.broadcast_to(q, p.shape).copy())
    return ds


def reduced_dataset(seed=7):
    """The synthetic table on a reduced speed axis: the same nodes' values, the
    speed axis the ratios :data:`RATIOS`, v_c(d) :data:`CRITICAL`."""
    ds = synthetic_dataset(seed).rename(speed_m_s="reduced_speed")
    ds = ds.assign_coords(reduced_speed=RATIOS)
    ds["critical_speed_m_s"] = (("diameter_um",), CRITICAL)
    return ds


# ------------------------------------------------ the independent reference
def reference_sample(ds, surface, d, v, a, u):
    """docs/wall-law.md, "The sampling rule", written out for this test: status
    (0 rebound, 1 captured, 2 no data), flags (as C's), velocity and the fractions
    t (N x 3) of the three axes. On a reduced speed axis the speed variable is
    log v - log v_c(d), log v_c linear in log d at the diameter's fraction. With
    a ``stay_probability`` q a capture is flagged resuspended where
    u[3] >= p q."""
    reduced = "reduced_speed" in ds.dims
    ds = ds.transpose(*(REDUCED_DIMS if reduced else DIMS), "sample", ...)
    n = u.shape[0]
    index, lower, fractions = [], [], np.zeros((n, 3))
    flags = np.zeros(n, np.int64)
    speed_axis = "reduced_speed" if reduced else "speed_m_s"
    for axis, (coord, q) in enumerate(
        (
            (np.log(ds["diameter_um"].values), np.log(d)),
            (np.log(ds[speed_axis].values), np.log(v)),
            (ds["angle_deg"].values, a),
        )
    ):
        if axis == 1 and reduced:
            lvc = np.log(ds["critical_speed_m_s"].values)
            i0, t0 = lower[0], fractions[:, 0]
            if lvc.size > 1:
                q = q - (lvc[i0] + t0 * (lvc[i0 + 1] - lvc[i0]))
            else:
                q = q - lvc[0]
        below, above = q < coord[0], q > coord[-1]
        tol = (CLAMP_TOL, CLAMP_TOL) if axis < 2 else CLAMP_TOL * np.abs(coord[[0, -1]])
        off = (q < coord[0] - tol[0]) | (q > coord[-1] + tol[1])
        if coord.size == 1:
            i, t = np.zeros(n, np.int64), np.zeros(n)
            up = np.zeros(n, bool)
        else:
            i = np.clip(
                (coord[None, :] <= q[:, None]).sum(axis=1) - 1, 0, coord.size - 2
            )
            t = np.where(
                below,
                0.0,
                np.where(above, 1.0, (q - coord[i]) / (coord[i + 1] - coord[i])),
            )
            up = u[:, axis] < t
        lower.append(i)
        index.append(i + up)
        fractions[:, axis] = t
        flags |= np.where(off, 1 << axis, 0)
    node = (surface, *index)
    p = ds["capture_probability"].values[node]
    count = ds["reservoir_count"].values[node].astype(np.int64)
    status = np.where(np.isnan(p), NO_DATA, np.where(u[:, 3] < p, CAPTURED, REBOUND))
    k = np.minimum(np.floor(u[:, 4] * count).astype(np.int64), count - 1)
    k = np.clip(k, 0, ds.sizes["sample"] - 1)  # any k where nothing is drawn
    e_n, mu, psi, ratio = (
        ds[f"reservoir_{q}"].values[(*node, k)]
        for q in ("e_n", "mu", "lateral_angle_deg", "speed_ratio")
    )
    th = a * (np.pi / 180.0)
    uz = e_n * v * np.sin(th)
    ux = v * np.cos(th) - mu * (1.0 + e_n) * v * np.sin(th)
    uy = np.tan(psi * (np.pi / 180.0)) * np.hypot(ux, uz)
    vel = np.stack([ux, uy, uz], axis=1)
    norm = np.linalg.norm(vel, axis=1)
    vel *= np.divide(ratio * v, norm, out=np.zeros(n), where=norm > 0)[:, None]
    uz = vel[:, 2]
    vel[status == CAPTURED] = 0.0
    vel[status == NO_DATA] = np.nan
    flags |= np.where((status == REBOUND) & (uz < 0), REIMPACT, 0)
    if "stay_probability" in ds:
        q = ds["stay_probability"].values[node]
        flags |= np.where((status == CAPTURED) & ~(u[:, 3] < p * q), RESUSPENDED, 0)
    return status, flags, vel, fractions


def queries(n, rng, *, surfaces=2):
    """n queries: inside the table, outside it, exactly on nodes, at 90 degrees,
    and uniforms partly exactly 0."""
    d = np.exp(rng.uniform(np.log(0.3), np.log(60.0), n))
    v = np.exp(rng.uniform(np.log(0.1), np.log(100.0), n))
    a = rng.uniform(1.0, 90.0, n)
    on = rng.random((n, 3)) < 0.2  # exactly on a node, axis by axis
    d[on[:, 0]] = rng.choice(DIAMETERS, on[:, 0].sum())
    v[on[:, 1]] = rng.choice(SPEEDS, on[:, 1].sum())
    a[on[:, 2]] = rng.choice(ANGLES, on[:, 2].sum())
    a[rng.random(n) < 0.1] = 90.0
    u = rng.random((n, 5))
    u[rng.random((n, 5)) < 0.01] = 0.0
    s = rng.integers(0, surfaces, n)
    return s, d, v, a, u


# ---------------------------------------------------------------- C library
def compile_shared(sources, out, *extra):
    cmd = [
        CC,
        *FLAGS,
        "-O2",
        "-shared",
        "-fPIC",
        *extra,
        *map(str, sources),
        "-o",
        str(out),
        "-lm",
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr
    return out


#: Switches floating-point traps on and off around each call into the library
#: (glibc), as OpenFOAM runs: a NaN compared, a division by zero or an overflow
#: inside swl.c kills the test process with SIGFPE instead of passing unseen.
TRAPS = ROOT / "tests" / "c" / "fpe_traps.c"


class _Trapped:
    """A ctypes library whose functions each run with floating-point traps on
    (FE_INVALID, FE_DIVBYZERO, FE_OVERFLOW; tests/c/fpe_traps.c)."""

    def __init__(self, lib):
        self._lib = lib

    def __getattr__(self, name):
        fn = getattr(self._lib, name)
        on, off = self._lib.swl_test_traps_on, self._lib.swl_test_traps_off

        def call(*args):
            on()
            try:
                return fn(*args)
            finally:
                off()

        return call


class Swl:
    """ctypes bindings of swl.h; with traps on where the library holds
    tests/c/fpe_traps.c and the C library can trap (glibc)."""

    def __init__(self, path):
        lib = ctypes.CDLL(str(path))
        P = ctypes.POINTER
        d, i, vp = ctypes.c_double, ctypes.c_int, ctypes.c_void_p
        lib.swl_load.argtypes = [ctypes.c_char_p, P(vp)]
        lib.swl_free.argtypes = [vp]
        lib.swl_free.restype = None
        lib.swl_strerror.argtypes = [i]
        lib.swl_strerror.restype = ctypes.c_char_p
        lib.swl_surface_index.argtypes = [vp, ctypes.c_char_p]
        lib.swl_size.argtypes = [vp, i]
        lib.swl_speed_axis.argtypes = [vp]
        lib.swl_surface_name.argtypes = [vp, i]
        lib.swl_surface_name.restype = ctypes.c_char_p
        lib.swl_sample.argtypes = [vp, i, d, d, d, P(d), P(d), P(i)]
        lib.swl_sample_n.argtypes = [vp, i, ctypes.c_long, *[P(d)] * 5, P(i), P(i)]
        lib.swl_rebound_velocity.argtypes = [vp, i, d, P(d), P(d), P(d), P(d), P(i)]
        self.traps = hasattr(lib, "swl_test_traps_on") and lib.swl_test_traps_on() == 0
        if self.traps:
            lib.swl_test_traps_off()
        self.lib = _Trapped(lib) if self.traps else lib

    def load(self, path):
        """(code, handle); handle is None on error."""
        handle = ctypes.c_void_p()
        rc = self.lib.swl_load(str(path).encode(), ctypes.byref(handle))
        assert (handle.value is None) == (rc != 0)
        return rc, handle

    def sample_n(self, law, surface, d, v, a, u):
        n = len(d)
        arrays = [np.ascontiguousarray(x, dtype=float) for x in (d, v, a, u)]
        vel = np.zeros((n, 3))
        status = np.zeros(n, np.intc)
        flags = np.zeros(n, np.intc)
        dp = ctypes.POINTER(ctypes.c_double)
        ip = ctypes.POINTER(ctypes.c_int)
        rc = self.lib.swl_sample_n(
            law,
            surface,
            n,
            *(x.ctypes.data_as(dp) for x in (*arrays, vel)),
            status.ctypes.data_as(ip),
            flags.ctypes.data_as(ip),
        )
        assert rc == 0
        return status, flags, vel

    def sample(self, law, surface, d, v, a, u):
        vel = (ctypes.c_double * 3)()
        flags = ctypes.c_int(-1)
        rc = self.lib.swl_sample(
            law, surface, d, v, a, (ctypes.c_double * 5)(*u), vel, ctypes.byref(flags)
        )
        return rc, flags.value, np.array(vel[:])

    def rebound(self, law, surface, d, v_in, normal, u):
        out = (ctypes.c_double * 3)()
        flags = ctypes.c_int(-1)
        rc = self.lib.swl_rebound_velocity(
            law,
            surface,
            d,
            (ctypes.c_double * 3)(*v_in),
            (ctypes.c_double * 3)(*normal),
            (ctypes.c_double * 5)(*u),
            out,
            ctypes.byref(flags),
        )
        return rc, flags.value, np.array(out[:])


@pytest.fixture(scope="module")
def swl(tmp_path_factory):
    out = tmp_path_factory.mktemp("swl") / "libswl.so"
    return Swl(compile_shared([C_DIR / "swl.c", TRAPS], out))


@pytest.fixture(scope="module")
def dataset():
    return synthetic_dataset()


@pytest.fixture(scope="module")
def table(dataset, tmp_path_factory):
    return write_binary(dataset, tmp_path_factory.mktemp("table") / "wall_law.swl")


@pytest.fixture
def law(swl, table):
    rc, handle = swl.load(table)
    assert rc == 0, swl.lib.swl_strerror(rc)
    yield handle
    swl.lib.swl_free(handle)


def python_law(dataset):
    """microimpact's WallLaw on `dataset`, or None where it is not importable."""
    try:
        from microimpact.wall_law.law import WallLaw
    except ImportError:
        return None
    return WallLaw(dataset)


def assert_agree(got, want, u, t, speed, *, what, max_flips=10):
    """C results `got` against Python results `want` (status, flags, velocity):
    equal, velocities to TOL of the speed, except corners flipped where a
    uniform lay within TOL of its fraction t."""
    (s1, f1, v1), (s2, f2, v2) = got, want
    close = np.all(np.abs(v1 - v2) <= TOL * speed[:, None], axis=1) | (
        np.isnan(v1).all(1) & np.isnan(v2).all(1)
    )
    ok = (s1 == s2) & (f1 == f2) & close
    bad = np.flatnonzero(~ok)
    near = np.min(np.abs(u[:, :3] - t), axis=1) < TOL
    unexplained = bad[~near[bad]]
    assert unexplained.size == 0, (
        f"{what}: {unexplained.size} disagreements, e.g. row {unexplained[0]}: "
        f"C {s1[unexplained[0]], f1[unexplained[0]], v1[unexplained[0]]} vs "
        f"Python {s2[unexplained[0]], f2[unexplained[0]], v2[unexplained[0]]}"
    )
    assert bad.size <= max_flips, f"{what}: {bad.size} corner flips near u = t"
    return bad.size


def compare_with_wall_law(got, wall_law, surface, d, v, a, u, *, what):
    """assert_agree of C results `got` against ``wall_law.sample_uniform`` (C's
    three clamped bits compared as one, as Python has one flag)."""
    py = wall_law.sample_uniform(d, v, a, u, surface=surface)
    status = np.where(~py.valid, NO_DATA, np.where(py.captured, CAPTURED, REBOUND))
    flags = np.where(py.clamped, CLAMPED, 0) | np.where(py.reimpact, REIMPACT, 0)
    flags |= np.where(py.resuspended, RESUSPENDED, 0)
    c_flags = np.where(got[1] & CLAMPED, CLAMPED, 0) | (
        got[1] & (REIMPACT | RESUSPENDED)
    )
    t = reference_sample(wall_law.dataset, surface, d, v, a, u)[3]
    return assert_agree(
        (got[0], c_flags, got[2]), (status, flags, py.velocity), u, t, v, what=what
    )


# ------------------------------------------------------------------- tests
#: The tables of both speed axes in every format version: (kind, version);
#: version 3 with the stay_probability section.
FORMATS = [("absolute", 1), ("absolute", 2), ("reduced", 2), ("absolute", 3),
           ("reduced", 3)]  # fmt: skip


@pytest.fixture(scope="module")
def reduced():
    return reduced_dataset()


@pytest.fixture(scope="module", params=FORMATS, ids=lambda f: f"{f[0]}-v{f[1]}")
def any_table(request, dataset, reduced, tmp_path_factory):
    """(dataset, path) of each of :data:`FORMATS`."""
    kind, version = request.param
    ds = reduced if kind == "reduced" else dataset
    if version == 3:
        ds = with_stay(ds)
    path = tmp_path_factory.mktemp("tables") / f"{kind}-{version}.swl"
    return ds, write_binary(ds, path, version=version)


def test_binary_round_trip(any_table):
    dataset, table = any_table
    data = table.read_bytes()
    n = 2 * 3 * 4 * 3
    reduced = "reduced_speed" in dataset.dims
    size = 64 + 2 * 64 + 8 * (3 + 4 + 3) + 8 * n * (1 + 4 * K) + 4 * n
    stay = "stay_probability" in dataset
    assert len(data) == size + (8 * 3 if reduced else 0) + (8 * n if stay else 0)
    magic, version, *dims = struct.unpack_from("<8s8I", data)
    want_version = int(table.stem[-1])
    assert (magic, version, dims) == (
        b"SWLTABL\0",
        want_version,
        [2, 3, 4, 3, K, 64, int(reduced)],
    )
    back = read_binary(table)
    assert back.attrs["format_version"] == want_version
    assert struct.unpack_from("<I", data, 52) == (int(stay),)  # sections word
    if stay:
        np.testing.assert_array_equal(
            back["stay_probability"].values, dataset["stay_probability"].values
        )
    if reduced:
        np.testing.assert_array_equal(back["reduced_speed"].values, RATIOS)
        np.testing.assert_array_equal(back["critical_speed_m_s"].values, CRITICAL)
        np.testing.assert_array_equal(
            back["speed_m_s"].values, CRITICAL[:, None] * RATIOS[None, :]
        )
        return
    assert list(back["surface"].values) == list(SURFACES)
    for name in (
        "capture_probability",
        "reservoir_count",
        *(f"reservoir_{q}" for q in export_c.RESERVOIRS),
    ):
        np.testing.assert_array_equal(
            back[name].values, dataset[name].values, err_msg=name
        )
    # the writer takes any dimension order (and a WallLaw's dataset)
    shuffled = dataset.transpose(
        "sample", "angle_deg", "surface", "speed_m_s", "diameter_um"
    )
    assert export_c.encode(shuffled, want_version) == data


def test_version_1_is_version_2_with_an_absolute_axis(dataset, reduced):
    # the old format: the same payload, version 1 and speed axis code 0
    v1, v2 = export_c.encode(dataset, 1), export_c.encode(dataset, 2)
    assert v1[:8] + v1[12:] == v2[:8] + v2[12:]
    assert struct.unpack_from("<I", v1, 8) == (1,)
    with pytest.raises(ValueError, match="version 2"):
        export_c.encode(reduced, 1)
    with pytest.raises(ValueError, match="version"):
        export_c.encode(dataset, 4)


def test_c_agrees_with_python_on_both_axes_and_versions(swl, any_table):
    # the reference and WallLaw.sample_uniform, on each kind of table; queries
    # exactly on the nodes (speeds r v_c(d) on the reduced axis) included
    dataset, table = any_table
    rc, handle = swl.load(table)
    assert rc == 0, swl.lib.swl_strerror(rc)
    reduced = "reduced_speed" in dataset.dims
    assert swl.lib.swl_speed_axis(handle) == int(reduced)
    rng = np.random.default_rng(31)
    s, d, v, a, u = queries(40_000, rng)
    if reduced:  # on the nodes in (d, r): v = r v_c(d)
        on = rng.random(d.size) < 0.3
        j = rng.integers(0, DIAMETERS.size, on.sum())
        d[on] = DIAMETERS[j]
        v[on] = rng.choice(RATIOS, on.sum()) * CRITICAL[j]
    wall_law = python_law(dataset)
    try:
        for surface in (0, 1):
            m = s == surface
            got = swl.sample_n(handle, surface, d[m], v[m], a[m], u[m])
            *want, t = reference_sample(dataset, surface, d[m], v[m], a[m], u[m])
            assert_agree(got, want, u[m], t, v[m], what=f"reference {surface}")
            if wall_law is not None:
                compare_with_wall_law(
                    got, wall_law, surface, d[m], v[m], a[m], u[m], what="WallLaw"
                )
            assert {REBOUND, CAPTURED} <= set(got[0])
            assert np.any(got[1] & CLAMPED) and not np.all(got[1] & CLAMPED)
            resuspended = (got[1] & RESUSPENDED) != 0
            stays = (got[0] == CAPTURED) & ~resuspended
            if "stay_probability" in dataset:  # both outcomes of a capture occur
                assert resuspended.any() and stays.any()
            else:
                assert not resuspended.any()
    finally:
        swl.lib.swl_free(handle)


def test_reduced_axis_follows_v_c(swl, reduced, tmp_path):
    # a query at r v_c(d) between two diameter nodes, with v_c a power law between
    # them (log-linear), lands exactly on the ratio node r: the speed corner is r
    # whatever u[1], and no speed flag
    rc, handle = swl.load(write_binary(reduced, tmp_path / "r.swl"))
    assert rc == 0
    try:
        for f in (0.1, 0.5, 0.9):
            d = np.exp(np.log(5.0) + f * (np.log(20.0) - np.log(5.0)))
            v_c = np.exp(np.log(0.8) + f * (np.log(0.5) - np.log(0.8)))
            for r_index in (1, 2):
                v = RATIOS[r_index] * v_c
                for u1 in (0.0, 0.999999):
                    u = [0.99, u1, 0.99, 0.99, 0.5]  # lower diameter, angle nodes
                    got = swl.sample(handle, 0, d, v, 50.0, u)
                    want = reference_sample(
                        reduced,
                        0,
                        *(np.array([x]) for x in (d, v, 50.0)),
                        np.array([u]),
                    )
                    assert got[0] == want[0][0] and got[1] == want[1][0]
                    assert abs(want[3][0, 1]) < 1e-9 or abs(want[3][0, 1] - 1) < 1e-9
    finally:
        swl.lib.swl_free(handle)


@pytest.mark.parametrize("kind", ["absolute", "reduced"])
def test_round_off_at_the_end_nodes_is_not_clamping(
    swl, dataset, reduced, kind, tmp_path
):
    # a query an ulp (or 1e-12 relative) outside an end node is not clamped, in C
    # and in Python; 1e-7 outside is
    ds = reduced if kind == "reduced" else dataset
    rc, handle = swl.load(write_binary(ds, tmp_path / "t.swl"))
    assert rc == 0
    wall_law = python_law(ds)
    u = [0.5, 0.5, 0.5, 0.9, 0.5]

    def speed(j, r_or_v):
        return r_or_v * (CRITICAL[j] if kind == "reduced" else 1.0)

    ends = (RATIOS if kind == "reduced" else SPEEDS)[[0, -1]]
    try:
        for rel, clamped in ((1e-15, False), (1e-12, False), (1e-7, True)):
            below, above = 1 - rel, 1 + rel
            cases = [  # each axis in turn just outside an end node
                (DIAMETERS[0] * below, speed(0, 2.0), 50.0),
                (DIAMETERS[-1] * above, speed(-1, 2.0), 50.0),
                (5.0, speed(1, ends[0]) * below, 50.0),
                (5.0, speed(1, ends[-1]) * above, 50.0),
                (5.0, speed(1, 2.0), ANGLES[0] * below),
            ]
            for d, v, a in cases:
                got = swl.sample(handle, 0, d, v, a, u)
                assert bool(got[1] & CLAMPED) == clamped, (rel, d, v, a)
                if wall_law is not None:
                    py = wall_law.sample_uniform(d, v, a, [u])
                    assert bool(py.clamped[0]) == clamped, (rel, d, v, a)
        # an ulp off the end nodes on every axis at once
        d = np.nextafter(DIAMETERS[-1], np.inf)
        v = np.nextafter(speed(-1, ends[-1]), np.inf)
        a = np.nextafter(ANGLES[0], 0.0)
        assert swl.sample(handle, 0, d, v, a, u)[1] & CLAMPED == 0
    finally:
        swl.lib.swl_free(handle)


def test_c_matches_the_reference_sampler(swl, law, dataset):
    rng = np.random.default_rng(2024)
    s, d, v, a, u = queries(100_000, rng)
    flips = 0
    for surface in (0, 1):
        m = s == surface
        got = swl.sample_n(law, surface, d[m], v[m], a[m], u[m])
        *want, t = reference_sample(dataset, surface, d[m], v[m], a[m], u[m])
        flips += assert_agree(got, want, u[m], t, v[m], what=f"surface {surface}")
    # every outcome and flag occurs
    status, flags, _ = swl.sample_n(law, 0, d, v, a, u)
    assert {REBOUND, CAPTURED} <= set(status)
    assert np.any(flags & CLAMPED) and np.any(flags & REIMPACT)
    assert (
        NO_DATA
        in swl.sample_n(
            law,
            1,
            np.full(50, 1.0),
            np.full(50, 0.5),
            np.full(50, 15.0),
            rng.random((50, 5)),
        )[0]
    )


def test_c_matches_wall_law_sample_uniform(swl, law, dataset):
    wall_law = python_law(dataset)
    if wall_law is None:
        pytest.skip("microimpact.wall_law.law.WallLaw is not available")
    rng = np.random.default_rng(99)
    s, d, v, a, u = queries(100_000, rng)
    for surface in (0, 1):
        m = s == surface
        got = swl.sample_n(law, surface, d[m], v[m], a[m], u[m])
        compare_with_wall_law(
            got, wall_law, surface, d[m], v[m], a[m], u[m], what=f"surface {surface}"
        )


def test_a_built_wall_law_samples_the_same_in_c(swl, tmp_path):
    # a real table from build_wall_law (smooth and rough surfaces), through
    # write_c, against its own sample_uniform
    try:
        import microimpact as mi
        from microimpact.wall_law import WallLawSpec, build_wall_law
    except ImportError:
        pytest.skip("microimpact.wall_law.build_wall_law is not available")
    coefficients = mi.ImpactCoefficients(
        k1=4.0,
        k2=mi.PowerLaw(a=0.05, b=-1.5, d_ref=10e-6),
        v_c=mi.PowerLaw(a=0.5, b=-1.0, d_ref=10e-6),
        friction=0.2,
    )
    scenario = mi.Scenario(
        name="c",
        particles=mi.lognormal_diameters(10.0, 1.5),
        coefficients=coefficients,
        surfaces=(
            mi.SurfaceVariant("smooth"),
            mi.SurfaceVariant("rough", mi.normal_angles(8.0)),
        ),
        seed=3,
        samples=400,
    )
    spec = WallLawSpec(
        diameters_um=(3.0, 30.0),
        speeds_m_s=(0.3, 3.0),
        angles_deg=(20.0, 90.0),
        reservoir=16,
    )
    wall_law = build_wall_law(scenario, spec)
    write_c(wall_law, tmp_path)
    rc, handle = swl.load(tmp_path / "c" / "wall_law.swl")
    assert rc == 0
    rng = np.random.default_rng(1)
    n = 20_000
    d = np.exp(rng.uniform(np.log(1.0), np.log(50.0), n))
    v = np.exp(rng.uniform(np.log(0.1), np.log(10.0), n))
    a = rng.uniform(5.0, 90.0, n)
    u = rng.random((n, 5))
    try:
        for surface in (0, 1):
            got = swl.sample_n(handle, surface, d, v, a, u)
            name = wall_law.surfaces[surface]
            compare_with_wall_law(got, wall_law, surface, d, v, a, u, what=name)
            assert {REBOUND, CAPTURED} <= set(got[0])
    finally:
        swl.lib.swl_free(handle)


def test_an_axis_with_one_node(swl, dataset, tmp_path):
    # one diameter and one angle (90 deg): t = 0 on those axes, and a query off
    # the single node is clamped to it and flagged
    one = dataset.isel(diameter_um=[1], angle_deg=[2])
    rc, handle = swl.load(write_binary(one, tmp_path / "one.swl"))
    assert rc == 0
    rng = np.random.default_rng(4)
    _, d, v, a, u = queries(5000, rng)
    wall_law = python_law(one)
    try:
        for surface in (0, 1):
            got = swl.sample_n(handle, surface, d, v, a, u)
            *want, t = reference_sample(one, surface, d, v, a, u)
            assert_agree(got, want, u, t, v, what="reference")
            assert np.array_equal(
                got[1] & CLAMPED != 0, (d != 5.0) | (a != 90.0) | (v < 0.5) | (v > 30)
            )
            if wall_law is not None:
                compare_with_wall_law(got, wall_law, surface, d, v, a, u, what="one")
    finally:
        swl.lib.swl_free(handle)


def test_scalar_calls_and_table_queries(swl, law):
    rng = np.random.default_rng(5)
    _, d, v, a, u = queries(300, rng, surfaces=1)
    status, flags, vel = swl.sample_n(law, 1, d, v, a, u)
    for j in range(300):
        rc, f, w = swl.sample(law, 1, d[j], v[j], a[j], u[j])
        assert (rc, f) == (status[j], flags[j])
        np.testing.assert_array_equal(w, vel[j])
    lib = swl.lib
    assert [lib.swl_size(law, k) for k in range(5)] == [2, 3, 4, 3, K]
    assert lib.swl_size(law, 5) == E_ARG
    assert lib.swl_surface_index(law, b"grit-blasted") == 1
    assert lib.swl_surface_index(law, b"grit") == E_ARG
    assert lib.swl_surface_name(law, 0) == b"polished"
    assert lib.swl_surface_name(law, 2) is None
    assert lib.swl_strerror(E_CHECKSUM) == b"the table is corrupt (CRC-32 mismatch)"


@pytest.mark.parametrize(
    ("surface", "d", "v", "a", "u"),
    [
        (2, 5.0, 2.0, 40.0, 0.5),  # no such surface
        (-1, 5.0, 2.0, 40.0, 0.5),
        (0, 0.0, 2.0, 40.0, 0.5),  # diameter not > 0
        (0, 5.0, -1.0, 40.0, 0.5),  # speed not > 0
        (0, 5.0, 2.0, 0.0, 0.5),  # angle outside (0, 90]
        (0, 5.0, 2.0, 90.5, 0.5),
        (0, float("nan"), 2.0, 40.0, 0.5),
        (0, 5.0, float("inf"), 40.0, 0.5),
        (0, 5.0, 2.0, 40.0, 1.0),  # u outside [0, 1)
        (0, 5.0, 2.0, 40.0, -0.1),
        (0, 5.0, 2.0, 40.0, float("nan")),
    ],
)
def test_bad_queries_are_refused(swl, law, dataset, surface, d, v, a, u):
    rc, flags, vel = swl.sample(law, surface, d, v, a, [0.3, 0.3, 0.3, 0.3, u])
    assert rc == E_ARG and flags == 0 and np.isnan(vel).all()
    wall_law = python_law(dataset)
    if wall_law is not None:  # Python refuses the same queries
        with pytest.raises(ValueError):
            wall_law.sample_uniform(d, v, a, [[0.3, 0.3, 0.3, 0.3, u]], surface=surface)


def _patched(data, offset, fmt, *values, crc=False):
    """`data` with struct `fmt` packed at `offset`; with `crc`, the header's
    CRC-32 recomputed, so that the reader's value checks are reached."""
    out = bytearray(data)
    struct.pack_into(fmt, out, offset, *values)
    if crc:
        struct.pack_into("<I", out, 48, zlib.crc32(bytes(out[64:])))
    return bytes(out)


def test_truncated_and_corrupt_files_give_error_codes(swl, table, tmp_path):
    data = table.read_bytes()
    n = 2 * 3 * 4 * 3
    axes = 64 + 2 * 64  # after the header and the two names
    p_at = axes + 8 * (3 + 4 + 3)
    count_at = len(data) - 4 * n
    cases = {
        "empty": (b"", E_TRUNCATED),
        "text": (b"hello, world\n" * 10, E_MAGIC),
        "magic only": (data[:8], E_TRUNCATED),
        "short header": (data[:40], E_TRUNCATED),
        "header only": (data[:64], E_TRUNCATED),
        "half": (data[: len(data) // 2], E_TRUNCATED),
        "one byte short": (data[:-1], E_TRUNCATED),
        "one byte more": (data + b"\0", E_SIZE),
        "version 4": (_patched(data, 8, "<I", 4), E_VERSION),
        "version 0": (_patched(data, 8, "<I", 0), E_VERSION),
        "speed axis 2": (_patched(data, 36, "<I", 2), E_SIZE),
        "reduced, no v_c": (_patched(data, 36, "<I", 1), E_SIZE),
        "zero angles": (_patched(data, 24, "<I", 0), E_SIZE),
        "huge diameters": (_patched(data, 16, "<I", 0xFFFFFFFF), E_SIZE),
        "size disagrees": (_patched(data, 16, "<I", 4), E_SIZE),
        "name width": (_patched(data, 32, "<I", 32), E_SIZE),
        "reserved": (_patched(data, 60, "<B", 1), E_SIZE),
        "bit flip": (_patched(data, p_at + 3, "<B", data[p_at + 3] ^ 0x10), E_CHECKSUM),
        "unsorted speeds": (_patched(data, axes + 8 * 3, "<d", 3.0, crc=True), E_VALUE),
        "zero diameter": (_patched(data, axes, "<d", 0.0, crc=True), E_VALUE),
        "capture > 1": (_patched(data, p_at, "<d", 1.5, crc=True), E_VALUE),
        "count > K": (_patched(data, count_at, "<i", K + 1, crc=True), E_VALUE),
        "negative count": (_patched(data, count_at, "<i", -1, crc=True), E_VALUE),
        "name without NUL": (_patched(data, 64, "64s", b"x" * 64, crc=True), E_VALUE),
    }
    for name, (content, code) in cases.items():
        path = tmp_path / "bad.swl"
        path.write_bytes(content)
        assert swl.load(path)[0] == code, name
    assert swl.load(tmp_path / "missing.swl")[0] == E_IO
    assert swl.load(tmp_path)[0] == E_IO  # a folder
    # every truncation and every single-byte change is caught, none crashes
    rng = np.random.default_rng(3)
    for cut in sorted({*range(0, 80), *rng.integers(80, len(data), 60).tolist()}):
        path.write_bytes(data[:cut])
        assert swl.load(path)[0] in (E_TRUNCATED, E_SIZE), cut
    for at in [*range(64), *rng.integers(64, len(data), 150).tolist()]:
        path.write_bytes(_patched(data, at, "<B", data[at] ^ int(rng.integers(1, 256))))
        assert swl.load(path)[0] < 0, at


#: A table in format version 1 (the layout of export_c.encode at commit 8fc8bd7,
#: before the reduced speed axis) of
#: ``synthetic_dataset().isel(diameter_um=[1], angle_deg=[1, 2])``; re-encoded
#: when the synthetic table was brought inside swl.h's value ranges (issue 34:
#: its speed ratios reached 1.46). The version-1 layout itself is unchanged.
OLD_TABLE = Path(__file__).with_name("data") / "format_v1.swl"


def test_a_table_of_format_version_1_is_still_read(swl, dataset):
    data = OLD_TABLE.read_bytes()
    assert struct.unpack_from("<8sI", data) == (b"SWLTABL\0", 1)
    want = dataset.isel(diameter_um=[1], angle_deg=[1, 2])
    back = read_binary(OLD_TABLE)
    assert back.attrs["speed_axis"] == "absolute" and "speed_m_s" in back.dims
    for name in ("capture_probability", "reservoir_count", "reservoir_e_n"):
        np.testing.assert_array_equal(back[name].values, want[name].values)
    assert export_c.encode(want, 1) == data  # and it is still written so
    rc, handle = swl.load(OLD_TABLE)
    assert rc == 0
    try:
        assert swl.lib.swl_speed_axis(handle) == 0
        rng = np.random.default_rng(12)
        s, d, v, a, u = queries(5000, rng)
        wall_law = python_law(want)
        for surface in (0, 1):
            m = s == surface
            got = swl.sample_n(handle, surface, d[m], v[m], a[m], u[m])
            *ref, t = reference_sample(want, surface, d[m], v[m], a[m], u[m])
            assert_agree(got, ref, u[m], t, v[m], what="reference")
            if wall_law is not None:
                compare_with_wall_law(
                    got, wall_law, surface, d[m], v[m], a[m], u[m], what="v1"
                )
    finally:
        swl.lib.swl_free(handle)


def test_a_reduced_table_needs_positive_critical_speeds(swl, reduced, tmp_path):
    data = export_c.encode(reduced)
    at = 64 + 2 * 64 + 8 * (3 + 4 + 3)  # v_c follows the three axes
    assert struct.unpack_from("<3d", data, at) == tuple(CRITICAL)
    path = tmp_path / "bad.swl"
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        path.write_bytes(_patched(data, at + 8, "<d", bad, crc=True))
        assert swl.load(path)[0] == E_VALUE, bad
    path.write_bytes(_patched(data, 36, "<I", 0, crc=True))  # v_c unannounced
    assert swl.load(path)[0] == E_SIZE
    path.write_bytes(_patched(data, 8, "<I", 1, crc=True))  # version 1: no axis code
    assert swl.load(path)[0] == E_SIZE
    bad = reduced.copy(deep=True)
    bad["critical_speed_m_s"][1] = 0.0
    with pytest.raises(ValueError, match="critical"):
        write_binary(bad, tmp_path / "bad2.swl")


def test_writer_refuses_what_the_reader_refuses(dataset, tmp_path):
    long_name = dataset.assign_coords(surface=np.array(["x" * 64, "y"], dtype=object))
    too_many = dataset.copy(deep=True)
    too_many["reservoir_count"][0, 0, 0, 0] = K + 1
    no_sample = dataset.copy(deep=True)
    no_sample["reservoir_count"][0, 0, 0, 0] = 0
    for bad in (long_name, too_many, no_sample):
        with pytest.raises(ValueError):
            write_binary(bad, tmp_path / "bad.swl")
        assert not (tmp_path / "bad.swl").exists()


def _frame(v_in, normal):
    """Speed, angle [deg] and wall axes (x, y, z) of docs/wall-law.md, in NumPy."""
    z = normal / np.linalg.norm(normal)
    vn = v_in @ z
    vt = v_in - vn * z
    tmag = np.linalg.norm(vt)
    if tmag > 0:
        x = vt / tmag
    else:
        k = int(np.argmin(np.abs(z)))
        x = np.eye(3)[k] - z[k] * z
        x /= np.linalg.norm(x)
    return (
        np.linalg.norm(v_in),
        min(np.degrees(np.arctan2(-vn, tmag)), 90.0),
        (x, np.cross(z, x), z),
    )


def test_rebound_velocity_rotates_sample_uniform(swl, law, dataset):
    # random walls and incoming velocities in the caller's frame: the C rebound is
    # sample_uniform's wall-frame velocity turned back with the same axes
    wall_law = python_law(dataset)
    rng = np.random.default_rng(11)
    n, rows = 3000, []
    for j in range(n):
        if j % 10 == 0:  # exactly normal incidence (no rounding in the frame)
            normal = np.zeros(3)
            normal[j % 3] = rng.choice([-1, 1]) * rng.uniform(0.1, 10)
            v_in = -rng.uniform(0.2, 50) * np.sign(normal)
        else:
            normal = rng.normal(size=3) * rng.uniform(0.1, 10)
            z = normal / np.linalg.norm(normal)
            v_in = rng.normal(size=3) * rng.uniform(0.1, 20)
            if v_in @ z > 0:
                v_in = v_in - 2 * (v_in @ z) * z
        if v_in @ normal >= 0:
            continue
        d = float(np.exp(rng.uniform(np.log(0.5), np.log(40))))
        u = rng.random(5)
        speed, theta, axes = _frame(v_in, normal)
        rc, flags, out = swl.rebound(law, 0, d, v_in, normal, u)
        rows.append((rc, flags, out, speed, theta, axes, d, u))
    d, speed, theta = (np.array([r[k] for r in rows]) for k in (6, 3, 4))
    u = np.array([r[7] for r in rows])
    basis = np.array([np.stack(r[5]) for r in rows])  # rows x (x, y, z) x 3
    got = (
        np.array([r[0] for r in rows]),
        np.array([r[1] for r in rows]),
        np.array([r[2] for r in rows]),
    )
    status, flags, wall, t = reference_sample(dataset, 0, d, speed, theta, u)
    want = (status, flags, np.einsum("na,nak->nk", wall, basis))
    assert_agree(got, want, u, t, speed, what="reference")
    if wall_law is not None:
        py = wall_law.sample_uniform(d, speed, theta, u)
        np.testing.assert_array_equal(py.captured, status == CAPTURED)
        want = (status, flags, np.einsum("na,nak->nk", py.velocity, basis))
        assert_agree(got, want, u, t, speed, what="WallLaw")
    # the speed is kept by the frame change, and the axes are orthonormal
    rebound = got[0] == REBOUND
    np.testing.assert_allclose(
        np.linalg.norm(got[2][rebound], axis=1),
        np.linalg.norm(wall[rebound], axis=1),
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        np.einsum("nak,nbk->nab", basis, basis),
        np.broadcast_to(np.eye(3), (len(rows), 3, 3)),
        atol=1e-12,
    )
    # a particle moving along or away from the wall is refused
    for v_in in ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]):
        assert swl.rebound(law, 0, 5.0, v_in, [0.0, 0.0, 1.0], [0.5] * 5)[0] == E_ARG


# ------------------------------------------------------------------- Fluent
@pytest.mark.parametrize(
    "variant", [[], ["-DRP_2D=1"], ["-DMOCK_UDF_SINGLE", '-DSWL_TABLE_PATH="x.swl"']]
)
def test_fluent_wrapper_compiles_against_a_mock_udf_h(variant, tmp_path):
    # 3-D, 2-D (with the axisymmetric-swirl branch) and single precision
    src = C_DIR / "fluent_udf.c"
    cmd = [CC, "-std=c99", "-Wall", "-Werror", *variant, "-c", str(src)]
    cmd += [f"-I{MOCK_UDF}", "-o", str(tmp_path / "udf.o")]
    run = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr


HARNESS = r"""
#include <stdarg.h>
#include <stdio.h>
#include "udf.h"

int microimpact_wall(Tracked_Particle *tp, Thread *t, face_t f, real n[], int dim);
void microimpact_wall_report(void);

int rp_axi_swirl = 0;
static double queue[5];
static int next = 0;
static char last_message[512];

float uniform_random(void) { return (float)queue[next++ % 5]; }

void Message(const char *format, ...)
{
    va_list ap;
    va_start(ap, format);
    vsnprintf(last_message, sizeof last_message, format, ap);
    va_end(ap);
}

const char *message(void) { return last_message; }

/* one wall hit: returns the Path_Status, the new velocity in v_out, TP_VEL0 in v0 */
int hit(const double v[3], const double f_normal[3], double diam_m, const double u[5],
        double v_out[3], double v0[3])
{
    Tracked_Particle tp = {{{0, 0, 0}, {0, 0, 0}, 0}, {{0, 0, 0}, {0, 0, 0}, 0}};
    real n[3];
    int i, rc;
    for (i = 0; i < 3; i++) {
        tp.state.V[i] = tp.state0.V[i] = v[i];
        n[i] = f_normal[i];
    }
    for (i = 0; i < 5; i++)
        queue[i] = u[i];
    next = 0;
    tp.state.diam = diam_m;
    rc = microimpact_wall(&tp, NULL, 0, n, 3);
    for (i = 0; i < 3; i++) {
        v_out[i] = tp.state.V[i];
        v0[i] = tp.state0.V[i];
    }
    return rc;
}
"""


def fluent_udf(tmp_path, table, monkeypatch, surface=None):
    """The Fluent wrapper built with the mock udf.h and the scripted harness,
    reading `table` (and `surface`, if given) from its environment variables;
    ``hit`` and ``message`` typed for ctypes."""
    (tmp_path / "harness.c").write_text(HARNESS)
    lib_path = compile_shared(
        [C_DIR / "fluent_udf.c", C_DIR / "swl.c", tmp_path / "harness.c"],
        tmp_path / "libudf.so",
        f"-I{MOCK_UDF}",
        f"-I{C_DIR}",
    )
    monkeypatch.setenv("MICROIMPACT_SWL_TABLE", str(table))
    if surface is not None:
        monkeypatch.setenv("MICROIMPACT_SWL_SURFACE", surface)
    udf = ctypes.CDLL(str(lib_path))
    d3 = ctypes.c_double * 3
    udf.hit.argtypes = [d3, d3, ctypes.c_double, ctypes.c_double * 5, d3, d3]
    udf.message.restype = ctypes.c_char_p
    return udf


@pytest.mark.parametrize("kind", ["absolute", "reduced"])
def test_fluent_wrapper_rebounds_like_swl_rebound_velocity(
    swl, dataset, reduced, kind, tmp_path, monkeypatch
):
    # the wrapper, built with the mock udf.h and a scripted uniform_random, turns
    # Fluent's face normal (out of the fluid) into the wall's outward normal,
    # converts the diameter from m to um and draws u[0..4] in order; on either
    # speed axis (the sampler handles it)
    table = write_binary(reduced if kind == "reduced" else dataset, tmp_path / "t.swl")
    rc, law = swl.load(table)
    assert rc == 0
    udf = fluent_udf(tmp_path, table, monkeypatch, "grit-blasted")
    d3 = ctypes.c_double * 3
    path_active, path_abort = 1, 3
    rng = np.random.default_rng(8)
    seen = set()
    for _ in range(400):
        f_normal = rng.normal(size=3)
        f_normal /= np.linalg.norm(f_normal)
        v = rng.normal(size=3) * 5
        if abs(v @ f_normal) < 1e-3:
            continue
        u = rng.random(5).astype(np.float32).astype(float)  # Fluent's floats
        diam = float(np.exp(rng.uniform(np.log(0.5e-6), np.log(40e-6))))
        out, v0 = d3(), d3()
        status = udf.hit(
            d3(*v), d3(*f_normal), diam, (ctypes.c_double * 5)(*u), out, v0
        )
        outward = -f_normal if v @ f_normal > 0 else f_normal
        rc, _, want = swl.rebound(law, 1, diam * 1e6, v, outward, u)
        seen.add(rc)
        if rc == CAPTURED:
            assert status == path_abort and out[:] == [0.0] * 3
        elif rc == NO_DATA:  # specular reflection
            assert status == path_active
            np.testing.assert_allclose(
                out[:], v - 2 * (v @ outward) * outward, atol=1e-12
            )
        else:
            assert rc == REBOUND and status == path_active
            np.testing.assert_array_equal(out[:], want)
        assert v0[:] == out[:]
    assert {REBOUND, CAPTURED} <= seen
    udf.microimpact_wall_report()
    assert b"captured" in udf.message()
    swl.lib.swl_free(law)


def test_write_c_writes_the_sampler_the_table_and_a_readme(swl, dataset, tmp_path):
    paths = write_c(dataset, tmp_path)
    c = tmp_path / "c"
    assert sorted(p.name for p in paths) == sorted(
        ["swl.h", "swl.c", "fluent_udf.c", "wall_law.swl", "README.md"]
    )
    for name in ("swl.h", "swl.c", "fluent_udf.c"):
        assert (c / name).read_bytes() == (C_DIR / name).read_bytes()
    assert sorted(os.listdir(c)) == sorted(
        p.name for p in paths
    )  # no temporary files left
    readme = (c / "README.md").read_text()
    assert "u[4]" in readme and "'grit-blasted'" in readme and "K = 8" in readme
    rc, handle = swl.load(c / "wall_law.swl")
    assert rc == 0
    swl.lib.swl_free(handle)
