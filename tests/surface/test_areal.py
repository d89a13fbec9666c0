"""Tests for areal surfaces: ``microimpact.io.areal`` (height-map readers) and
``microimpact.surface.areal`` (levelling, ISO 25178 parameters, contact-scale facet
angles, synthetic Gaussian surfaces). Issue 14, "Surfaces"."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import microimpact as mi
from microimpact.errors import ProfileFormatError
from microimpact.io.areal import HeightMap, read_height_map
from microimpact.surface.areal import (
    _patch_kernel,
    areal_parameters,
    autocorrelation,
    contact_patch_means,
    facet_angle_statistics,
    facet_angles,
    gaussian_areal_surface,
    level_plane,
    plane_fit,
)

DATA = Path(__file__).parents[1] / "data"


def _write(tmp_path, text, name="map.txt"):
    p = tmp_path / name
    p.write_text(text)
    return p


# ----------------------------------------------------------------- text reader
def test_read_text_height_map_with_header():
    hm = read_height_map(DATA / "areal_small.txt")
    assert hm.shape == (3, 4) and (hm.nx, hm.ny) == (4, 3)
    assert hm.dx == pytest.approx(0.5e-6) and hm.dy == pytest.approx(0.25e-6)
    assert_allclose(hm.z[0], [10e-9, 20e-9, 30e-9, 40e-9])
    assert np.isnan(hm.z[1, 1]) and hm.valid.sum() == 11
    assert hm.metadata["z_unit"] == "nm" and hm.metadata["dx_from"] == "header"
    assert_allclose(hm.x, [0, 0.5e-6, 1e-6, 1.5e-6])
    assert hm.source.endswith("areal_small.txt")


def test_read_text_arguments_xy_unit_and_delimiters(tmp_path):
    p = _write(tmp_path, "1,2,3\n4,,6\n7,8,9\n")  # empty cell = missing point
    with pytest.raises(ProfileFormatError, match=r"no height unit.*`z_unit`"):
        read_height_map(p, dx_um=2.0)  # units are never guessed
    hm = read_height_map(p, dx_um=2.0, z_unit="um")  # the hint, followed
    assert hm.dx == pytest.approx(2e-6) and hm.dy == pytest.approx(2e-6)
    assert np.isnan(hm.z[1, 1]) and hm.z[2, 2] == pytest.approx(9e-6)
    assert hm.metadata["z_unit_from"] == "argument"
    assert hm.metadata["masked_fraction"] == pytest.approx(1 / 9)
    q = _write(tmp_path, "# xy_unit: nm\n# dx: 100\n# dy: 200\n1\t2\n3\t4\n", "b.tsv")
    hm = read_height_map(q, z_unit="A")
    assert (hm.dx, hm.dy) == pytest.approx((1e-7, 2e-7))
    assert hm.z[1, 1] == pytest.approx(4e-10)
    same = read_height_map(DATA / "areal_small.txt", dx_um=0.5, z_unit="nm")
    assert_array_equal(same.z, read_height_map(DATA / "areal_small.txt").z)
    # no dy anywhere: square pixels, and the metadata says where dy came from
    r = _write(tmp_path, "# dx_um: 2\n# z_unit: nm\n1\t2\n3\t4\n", "c.tsv")
    hm = read_height_map(r)
    assert hm.dy == hm.dx == pytest.approx(2e-6)
    assert hm.metadata["dy_from"] == "dx" and hm.metadata["dx_from"] == "header"


@pytest.mark.parametrize(
    ("text", "kwargs", "match"),
    [
        ("1 2\n3 4\n", {}, r"map\.txt: dx: no grid spacing 'dx'"),
        ("# dx = 1\n# dy_um = 1\n1 2\n3 4\n", {}, r"map\.txt:1: dx: .*without a unit"),
        ("# dx_um = 1\n1 2\n3 4\n", {"dx_um": 2.0}, r":1: dx_um: the header gives"),
        ("# dx_um = -1\n1 2\n3 4\n", {}, r":1: dx: bad value '-1'; allowed: a finite"),
        ("# dx_inch = 1\n1 2\n3 4\n", {}, r"unknown length unit 'inch'"),
        ("1 2 3\n4 5\n", {"dx_um": 1}, r"map\.txt:2: row has 2 heights"),
        ("# dx_um = 1\n1 2\n3 4\n", {}, r"map\.txt: z_unit: .*no height unit"),
        ("1 2\n3 abc\n", {"dx_um": 1}, r":2: column 1: non-numeric height 'abc'"),
        ("1;2\n3;4,5\n", {"dx_um": 1}, r"decimal separator must be '\.'"),
        ("1 2\n3 inf\n", {"dx_um": 1}, r":2: column 1: bad height 'inf'"),
        ("1 2 3\n", {"dx_um": 1}, r"1 x 3; allowed: at least 2 x 2"),
        ("nan nan\nnan nan\n", {"dx_um": 1}, r"every height is missing"),
        ("# only a comment\n", {"dx_um": 1}, r"no data rows"),
        ("# z_unit = furlong\n1 2\n3 4\n", {"dx_um": 1}, r":1: z_unit: unknown"),
        ("# z_unit = nm\n1 2\n3 4\n", {"dx_um": 1, "z_unit": "um"}, r"height unit"),
        ("# dx_um = 1\n# dx_um = 2\n1 2\n3 4\n", {}, r":2: dx_um: 'dx' is given twice"),
    ],
)
def test_text_reader_errors_name_file_line_value(tmp_path, text, kwargs, match):
    p = _write(tmp_path, text)
    with pytest.raises(ProfileFormatError, match=match):
        read_height_map(p, **kwargs)


def test_reader_refuses_text_options_for_binary_formats(tmp_path):
    with pytest.raises(ProfileFormatError, match="`dx_um` applies to plain-text"):
        read_height_map(tmp_path / "a.x3p", dx_um=1.0)
    with pytest.raises(ValueError, match="`format`"):
        read_height_map(DATA / "areal_small.txt", format="sur")
    with pytest.raises(ProfileFormatError, match="file not found"):
        read_height_map(tmp_path / "absent.txt", dx_um=1.0)


@pytest.mark.parametrize("delimiter", [";;", '"', "#", 3])
def test_reader_refuses_a_bad_delimiter_as_the_profile_reader_does(delimiter):
    with pytest.raises(ValueError, match="`delimiter` must be one character") as e:
        read_height_map(DATA / "areal_small.txt", delimiter=delimiter)
    assert repr(delimiter) in str(e.value)


# ------------------------------------------------------------------ x3p reader
def test_read_x3p_surface_round_trip(tmp_path):
    x3pio = pytest.importorskip("x3pio")
    rng = np.random.default_rng(3)
    z = rng.normal(0.0, 1e-6, (5, 7))
    z[2, 3] = np.nan
    p = tmp_path / "s.x3p"
    x3pio.write(p, z, x_scale=0.5e-6, y_scale=0.25e-6)
    hm = read_height_map(p)
    assert hm.shape == (5, 7)
    assert (hm.dx, hm.dy) == pytest.approx((0.5e-6, 0.25e-6))
    assert_allclose(hm.z, z, rtol=1e-12, atol=1e-18, equal_nan=True)
    assert hm.metadata["format"] == "x3p"
    prof = tmp_path / "p.x3p"
    x3pio.write(prof, z[0], x_scale=0.5e-6)
    with pytest.raises(ProfileFormatError, match=r"p\.x3p: .*Profile.*read_profile"):
        read_height_map(prof)
    bad = _write(tmp_path, "not a zip", "bad.x3p")
    with pytest.raises(ProfileFormatError, match=r"bad\.x3p: not a readable x3p"):
        read_height_map(bad)


def test_missing_optional_packages_name_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "x3pio", None)
    with pytest.raises(ProfileFormatError, match=r"microimpact\[x3p\]"):
        read_height_map(tmp_path / "s.x3p")
    monkeypatch.setitem(sys.modules, "SurfaceTopography", None)
    with pytest.raises(ProfileFormatError, match=r"s\.sur: .*SurfaceTopography"):
        read_height_map(tmp_path / "s.sur")


def test_surfacetopography_reader_orientation(tmp_path):
    """Through SurfaceTopography (indexed [x, y]) the map keeps rows = y."""
    st = pytest.importorskip("SurfaceTopography")
    pytest.importorskip("netCDF4")
    z = np.arange(12.0).reshape(3, 4)  # (ny, nx)
    topo = st.Topography(z.T, physical_sizes=(4 * 0.5, 3 * 0.25), unit="µm")
    p = tmp_path / "t.nc"
    topo.to_netcdf(p)
    hm = read_height_map(p)
    assert hm.shape == (3, 4)
    assert_allclose(hm.z, z * 1e-6)
    assert (hm.dx, hm.dy) == pytest.approx((0.5e-6, 0.25e-6))


# -------------------------------------------------------------------- HeightMap
def test_height_map_validation():
    with pytest.raises(ValueError, match="2 x 2"):
        HeightMap(np.zeros(5), 1e-6, 1e-6)
    with pytest.raises(ValueError, match="`dy`"):
        HeightMap(np.zeros((3, 3)), 1e-6, 0.0)
    with pytest.raises(ValueError, match="inf"):
        HeightMap(np.array([[0.0, np.inf], [0.0, 0.0]]), 1e-6, 1e-6)
    hm = HeightMap(np.zeros((3, 3)), 1e-6, 2e-6)
    with pytest.raises(ValueError):
        hm.z[0, 0] = 1.0  # read-only
    assert "nx=3" in repr(hm)


# -------------------------------------------------------------------- levelling
def test_level_removes_plane_with_missing_points():
    rng = np.random.default_rng(5)
    ny, nx, d = 40, 60, 1e-6
    x, y = np.arange(nx) * d, np.arange(ny) * d
    rough = rng.normal(0.0, 1e-8, (ny, nx))
    z = 3e-6 + 0.02 * x[None, :] - 0.05 * y[:, None] + rough
    z[rng.random(z.shape) < 0.1] = np.nan
    hm = HeightMap(z, d, d)
    _, cx, cy = plane_fit(hm)
    assert (cx, cy) == pytest.approx((0.02, -0.05), abs=1e-4)
    lv = level_plane(hm)
    assert np.isnan(lv.z).sum() == np.isnan(z).sum()
    assert abs(np.nanmean(lv.z)) < 1e-20
    _, cx2, cy2 = plane_fit(lv)
    assert abs(cx2) < 1e-12 and abs(cy2) < 1e-12
    assert np.nanstd(lv.z) == pytest.approx(1e-8, rel=0.1)


# ------------------------------------------------------------------ parameters
def test_parameters_of_a_sinusoidal_surface():
    """z = A sin(k x): Sq = A/sqrt2; central differences give the slope
    A sin(k dx)/dx cos(kx), so Sdq_x = A sin(k dx)/(dx sqrt2), Sdq_y = 0; Sdr is
    the mean of sqrt(1 + g^2) - 1; the ACF never decays along y: Str undefined."""
    nx, ny, d, lam, amp = 400, 64, 0.5e-6, 20e-6, 1e-6
    k = 2 * np.pi / lam
    x = np.arange(nx) * d
    z = np.tile(amp * np.sin(k * x), (ny, 1))
    p = areal_parameters(HeightMap(z, d, d), level_first=False)
    assert p.Sq == pytest.approx(amp / math.sqrt(2), rel=1e-3)
    g = amp * math.sin(k * d) / d
    inner = g * np.cos(k * x[1:-1])  # the gradient at the interior points
    assert p.Sdq_x == pytest.approx(np.sqrt(np.mean(inner**2)), rel=1e-9)
    assert p.Sdq_x == pytest.approx(g / math.sqrt(2), rel=5e-3)
    assert p.Sdq_y == 0.0 and p.Sdq == pytest.approx(p.Sdq_x)
    sdr = np.mean(np.sqrt(1 + (g * np.cos(k * x[1:-1])) ** 2)) - 1
    assert p.Sdr == pytest.approx(sdr, rel=1e-6)
    assert math.isnan(p.Str)
    # the ACF along x of a sinusoid: cos(k tau) falls to 0.2 at acos(0.2)/k
    assert p.Sal == pytest.approx(math.acos(0.2) / k, rel=0.03)


def test_parameters_agree_with_surfacetopography():
    """Sq and Sdq against the maintained SurfaceTopography (when installed): Sq to
    rounding; Sdq to its different finite-difference stencil."""
    st = pytest.importorskip("SurfaceTopography")
    hm = level_plane(
        gaussian_areal_surface(256, 200, dx_um=1, dy_um=0.5, rms_um=1, corr_x_um=12,
                               corr_y_um=6, seed=1)
    )  # fmt: skip
    p = areal_parameters(hm)
    t = st.Topography(hm.z.T, physical_sizes=(hm.nx * hm.dx, hm.ny * hm.dy),
                      periodic=False)  # fmt: skip
    assert p.Sq == pytest.approx(t.rms_height_from_area(), rel=1e-12)
    assert p.Sdq == pytest.approx(t.rms_gradient(), rel=0.02)


def test_autocorrelation_is_one_at_the_origin_and_handles_missing_points():
    hm = gaussian_areal_surface(64, 48, dx_um=1, rms_um=1, corr_x_um=5, seed=1)
    z = hm.z.copy()
    z[10:20, 10:20] = np.nan
    acf = autocorrelation(hm.with_heights(z))
    assert acf.shape == (95, 127)
    assert acf[47, 63] == 1.0
    assert_allclose(acf, acf[::-1, ::-1], rtol=1e-9, atol=1e-12)  # C(-r) = C(r)
    # near the origin (many pairs) it is a correlation, |C| <= 1
    assert np.all(np.abs(acf[47 - 10 : 47 + 11, 63 - 10 : 63 + 11]) <= 1.0 + 1e-12)
    assert np.isfinite(acf).all()


# ---------------------------------------------------------- synthetic surfaces
def test_gaussian_surface_is_seeded_and_has_its_rms_height():
    kw = {"dx_um": 1.0, "rms_um": 2.0, "corr_x_um": 8.0}
    a = gaussian_areal_surface(128, 96, seed=7, **kw)
    b = gaussian_areal_surface(128, 96, seed=7, **kw)
    c = gaussian_areal_surface(128, 96, seed=8, **kw)
    assert_array_equal(a.z, b.z)
    assert not np.array_equal(a.z, c.z)
    assert a.shape == (96, 128)
    rms = [np.std(gaussian_areal_surface(256, 256, seed=s, **kw).z) for s in range(6)]
    se = np.std(rms, ddof=1) / math.sqrt(len(rms))
    assert abs(np.mean(rms) - 2e-6) < 4 * se + 0.02e-6


@pytest.mark.parametrize(("lx", "ly"), [(12.0, 12.0), (8.0, 24.0)])
def test_gaussian_surface_rms_slopes_match_theory(lx, ly):
    """ACF C = s^2 exp(-tx^2/lx^2 - ty^2/ly^2): the slope variance along x is
    -d2C/dtx2(0) = 2 s^2/lx^2, so the RMS slope is sqrt(2) s/lx (and sqrt(2) s/ly
    along y). Forward differences over h have variance 2 (C(0) - C(h))/h^2, which
    differs from it by 0.3 % here (h = 1 µm, l >= 8 µm), far below the standard
    error; the standard error comes from 8 independent realisations."""
    sigma, d, n = 1.5, 1.0, 256
    sx, sy = [], []
    for seed in range(8):
        hm = gaussian_areal_surface(
            n, n, dx_um=d, rms_um=sigma, corr_x_um=lx, corr_y_um=ly, seed=seed
        )
        z = hm.z
        sx.append(np.sqrt(np.mean((np.diff(z, axis=1) / hm.dx) ** 2)))
        sy.append(np.sqrt(np.mean((np.diff(z, axis=0) / hm.dy) ** 2)))
    for got, ell in ((sx, lx), (sy, ly)):
        theory = math.sqrt(2.0) * sigma / ell
        discrete = math.sqrt(2 * sigma**2 * (1 - math.exp(-((d / ell) ** 2)))) / d
        assert abs(discrete / theory - 1) < 4e-3
        se = np.std(got, ddof=1) / math.sqrt(len(got))
        assert abs(np.mean(got) - theory) < 4 * se, (np.mean(got), theory, se)
        assert se < 0.03 * theory  # the test has power
    # the ISO parameters see the same anisotropy
    p = areal_parameters(hm)
    assert p.Sdq_x / p.Sdq_y == pytest.approx(ly / lx, rel=0.15)


def test_texture_aspect_ratio_and_autocorrelation_length():
    """Str = l_min/l_max and Sal = l_min sqrt(ln 5) for a Gaussian ACF; the lay is
    along the longer correlation length (y here: 90 deg)."""
    strs, sals, lays = [], [], []
    for seed in range(4):
        hm = gaussian_areal_surface(
            256, 256, dx_um=1.0, rms_um=1.0, corr_x_um=6.0, corr_y_um=18.0, seed=seed
        )
        p = areal_parameters(hm)
        strs.append(p.Str)
        sals.append(p.Sal)
        lays.append(p.texture_direction_deg)
    assert np.mean(strs) == pytest.approx(1 / 3, rel=0.15)
    assert np.mean(sals) == pytest.approx(6e-6 * math.sqrt(math.log(5)), rel=0.15)
    assert all(abs(a - 90.0) <= 10.0 for a in lays)
    iso = areal_parameters(
        gaussian_areal_surface(256, 256, dx_um=1, rms_um=1, corr_x_um=8, seed=9)
    )
    assert iso.Str > 0.7


# ---------------------------------------------------------------- facet angles
def test_patch_kernels():
    sq = _patch_kernel(10e-6, 1e-6, 1e-6, "square")
    assert sq.shape == (10, 10) and sq.sum() == pytest.approx(1.0)
    disc = _patch_kernel(20e-6, 1e-6, 1e-6, "disc")
    assert disc.shape == (20, 20)
    # the disc covers pi/4 of the square, to the pixel
    assert np.count_nonzero(disc) == pytest.approx(math.pi * 100, rel=0.03)


def test_contact_patch_means_of_a_plane_and_coverage():
    d = 1e-6
    x = np.arange(50) * d
    z = np.tile(0.1 * x, (40, 1))
    hm = HeightMap(z, d, d)
    m = contact_patch_means(hm, contact_diameter=9e-6, patch="disc")
    ok = np.isfinite(m)
    assert ok.sum() == (50 - 8) * (40 - 8)
    assert_allclose(m[ok], np.broadcast_to(0.1 * x, m.shape)[ok], rtol=1e-9)
    z2 = z.copy()
    z2[:, 20:30] = np.nan
    m2 = contact_patch_means(hm.with_heights(z2), contact_diameter=9e-6)
    assert np.isnan(m2[:, 25]).all()  # a patch of only missing points


def test_profile_surface_reduces_to_profile_slope_method():
    """A surface constant along y gives phi_perp = 0 and, with square patches and
    azimuth 0, exactly the profile 'slope' angles of one row."""
    rng = np.random.default_rng(11)
    row = np.cumsum(rng.normal(0.0, 0.1, 400))  # µm
    z = np.tile(row, (30, 1)) * 1e-6
    hm = HeightMap(z, 0.5e-6, 0.5e-6)
    fa = facet_angles(hm, contact_diameter_um=5.0, patch="square", level_first=False)
    assert np.all(np.abs(fa.phi_perp) < 1e-15)  # 0 up to FFT round-off
    x_um = np.arange(400) * 0.5
    want = mi.profile_angles(x_um, row, contact_length_um=5.0, method="slope")
    assert want.size == 39  # 40 segments of 10 points
    per_row = fa.phi_par.reshape(-1, 39)  # lattice rows of 39 slopes each
    assert_allclose(np.rad2deg(per_row[0]), want, rtol=1e-9, atol=1e-12)
    assert_allclose(per_row, np.tile(per_row[0], (2, 1)), rtol=0, atol=1e-15)


def test_facet_slope_variance_matches_the_patch_averaged_acf():
    """For a stationary field with ACF C, the patch mean has the ACF
    Cbar = C * (k autocorrelated), so the slope between patches L apart has the
    variance 2 (Cbar(0) - Cbar(L))/L^2, computed here on the grid by FFT."""
    n, d, sigma, ell, L = 256, 1.0, 1.0, 10.0, 8.0
    kernel = _patch_kernel(L * 1e-6, 1e-6, 1e-6, "disc")
    j = np.arange(n)
    lag = np.minimum(j, n - j) * d
    C = sigma**2 * np.exp(-(lag[None, :] ** 2 + lag[:, None] ** 2) / ell**2)
    kk = np.zeros((n, n))
    kk[: kernel.shape[0], : kernel.shape[1]] = kernel
    Kf = np.fft.fft2(kk)
    Cbar = np.fft.ifft2(np.fft.fft2(C) * Kf * np.conj(Kf)).real
    var_theory = 2 * (Cbar[0, 0] - Cbar[0, int(L)]) / L**2  # (µm/µm)^2
    vx, vy = [], []
    for seed in range(8):
        hm = gaussian_areal_surface(n, n, dx_um=d, rms_um=sigma, corr_x_um=ell,
                                    seed=seed)  # fmt: skip
        fa = facet_angles(hm, contact_diameter_um=L, level_first=False, step_um=4)
        vx.append(np.mean(fa.slope_x**2))
        vy.append(np.mean(fa.slope_y**2))
    for v in (vx, vy):
        se = np.std(v, ddof=1) / math.sqrt(len(v))
        assert abs(np.mean(v) - var_theory) < 4 * se, (np.mean(v), var_theory, se)
        assert se < 0.05 * var_theory
    # patch averaging smooths: the facet slopes are gentler than the point slopes
    assert var_theory < 2 * sigma**2 / ell**2


def test_azimuth_rotates_the_slope_vector():
    hm = gaussian_areal_surface(128, 128, dx_um=1, rms_um=1, corr_x_um=6,
                                corr_y_um=15, seed=4)  # fmt: skip
    a0 = facet_angles(hm, contact_diameter_um=6)
    assert_allclose(np.tan(a0.phi_par), a0.slope_x, rtol=1e-12)
    assert_allclose(np.tan(a0.phi_perp), a0.slope_y, rtol=1e-12)
    a90 = facet_angles(hm, contact_diameter_um=6, azimuth_deg=90.0)
    assert_allclose(np.tan(a90.phi_par), a0.slope_y, rtol=1e-9, atol=1e-15)
    assert_allclose(np.tan(a90.phi_perp), -a0.slope_x, rtol=1e-9, atol=1e-15)
    a30 = facet_angles(hm, contact_diameter_um=6, azimuth_deg=30.0)
    # the slope magnitude is invariant
    assert_allclose(np.hypot(np.tan(a30.phi_par), np.tan(a30.phi_perp)),
                    np.hypot(a0.slope_x, a0.slope_y), rtol=1e-12)  # fmt: skip
    per = facet_angles(hm, contact_diameter_um=6, azimuth_deg=np.arange(len(a0)))
    assert_allclose(per.azimuth, np.deg2rad(np.arange(len(a0))))


def test_random_azimuths_isotropise_an_anisotropic_surface():
    hm = gaussian_areal_surface(256, 256, dx_um=1, rms_um=1, corr_x_um=5,
                                corr_y_um=20, seed=6)  # fmt: skip
    fixed = facet_angles(hm, contact_diameter_um=4, step_um=2).statistics()
    assert fixed.anisotropy < 0.5  # slopes steeper along x (shorter correlation)
    assert abs(fixed.principal_direction_deg) < 10.0
    rnd = facet_angles(hm, contact_diameter_um=4, step_um=2, azimuth_deg=None, rng=1)
    st = rnd.statistics()
    assert st.anisotropy > 0.9 and abs(st.correlation) < 0.05
    # same seed, same samples
    again = facet_angles(hm, contact_diameter_um=4, step_um=2, azimuth_deg=None, rng=1)
    assert_array_equal(again.phi_par, rnd.phi_par)
    # the mean squared slope is the average of the two axes
    t2 = np.mean(np.tan(rnd.phi_par) ** 2 + np.tan(rnd.phi_perp) ** 2)
    assert t2 == pytest.approx(np.mean(rnd.slope_x**2 + rnd.slope_y**2), rel=1e-12)


def test_facet_angle_statistics_closed_form():
    rng = np.random.default_rng(2)
    cov = np.array([[4.0, 1.2], [1.2, 1.0]]) * 1e-2
    a, b = rng.multivariate_normal([0.01, -0.02], cov, 200_000).T
    st = facet_angle_statistics(a, b)
    assert_allclose(st.covariance, cov, rtol=0.02)
    w = np.linalg.eigvalsh(cov)
    assert st.anisotropy == pytest.approx(math.sqrt(w[0] / w[1]), rel=0.01)
    assert st.correlation == pytest.approx(1.2 / 2.0, rel=0.02)
    major = np.linalg.eigh(cov)[1][:, 1]
    want = math.degrees(math.atan(major[1] / major[0]))
    assert st.principal_direction_deg == pytest.approx(want, abs=1.0)


def test_contact_diameter_from_hertz_and_errors():
    hm = gaussian_areal_surface(128, 128, dx_um=1, rms_um=1, corr_x_um=6, seed=4)
    hertz = {"diameter": 70e-6, "density": 7900.0, "contact_modulus": 10e9,
             "normal_speed": 5.0}  # fmt: skip
    L = float(mi.hertz_contact_diameter(**hertz))
    a = facet_angles(hm, hertz=hertz)
    b = facet_angles(hm, contact_diameter_um=L * 1e6)
    assert a.contact_diameter == pytest.approx(L)
    assert_array_equal(a.phi_par, b.phi_par)
    with pytest.raises(ValueError, match="either `contact_diameter_um` or `hertz`"):
        facet_angles(hm)
    with pytest.raises(ValueError, match="keys"):
        facet_angles(hm, hertz={"diameter": 1e-5})
    with pytest.raises(ValueError, match="`patch`"):
        facet_angles(hm, contact_diameter_um=5, patch="hexagon")
    with pytest.raises(ValueError, match="larger than the map"):
        facet_angles(hm, contact_diameter_um=500)
    with pytest.raises(TypeError, match="HeightMap"):
        facet_angles(np.zeros((5, 5)), contact_diameter_um=1)


def test_facet_angles_feed_apparent_rebound():
    """The joint angles go straight into the 3-D impact model."""
    hm = gaussian_areal_surface(128, 128, dx_um=1, rms_um=1, corr_x_um=10, seed=3)
    fa = facet_angles(hm, contact_diameter_um=5, azimuth_deg=None, rng=2)
    r = mi.apparent_rebound(1.0, 30.0, fa.phi_par_deg,
                            out_of_plane_angle_deg=fa.phi_perp_deg,
                            k1=3.0, k2=0.05, v_c=0.1)  # fmt: skip
    live = np.isfinite(r.lateral_angle_deg)
    assert live.sum() > 0.5 * len(fa)
    assert np.std(r.lateral_angle_deg[live]) > 1.0  # there is lateral scatter


@pytest.mark.parametrize(
    ("fill", "diameter", "match"),
    [
        (
            np.s_[5:7, 5:7],
            4.0,
            r"no contact patch \(4 µm\) is measured over at least min_coverage = "
            r"0\.5 of its area on the map \(20 x 20 µm, 0\.01 of it measured\); "
            r"allowed: a smaller contact diameter",
        ),
        (
            np.s_[0:3, 0:3],
            4.0,
            r"no pair of neighbouring contact patches \(4 µm\) is each measured .* "
            r"\(20 x 20 µm, 0\.0225 of it measured\); allowed: a smaller contact",
        ),
        (
            np.s_[:, :],
            12.0,
            r"the map \(20 x 20 µm\) is smaller than two contact patches \(12 µm\) "
            r"along x or y; allowed: a contact diameter below half",
        ),
    ],
)
def test_facet_angles_errors_give_sizes_coverage_and_remedy(fill, diameter, match):
    z = np.full((20, 20), np.nan)
    z[fill] = 1.0
    with pytest.raises(ValueError, match=match):
        mi.facet_angles(HeightMap(z, 1e-6, 1e-6), contact_diameter_um=diameter)


def test_a_synthetic_surface_too_large_for_memory_is_refused_before_the_fft():
    """nx x ny beyond MAX_SYNTHETIC_POINTS is a clear error (it was an out-of-memory
    failure, exit 3, from a scenario's synthetic = {...})."""
    import pytest

    from microimpact.surface.areal import gaussian_areal_surface

    with pytest.raises(ValueError, match=r"`nx` x `ny` = 10,000,000,000 points"):
        gaussian_areal_surface(
            100_000, 100_000, dx_um=1.0, rms_um=1.0, corr_x_um=5.0, seed=1
        )
