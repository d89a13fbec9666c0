"""Tests for microimpact.surface.synthetic: Gaussian and fractal profiles, and the
shipped synthetic Formica profile."""

from __future__ import annotations

import importlib.util
import math
from importlib import resources

import numpy as np
import pytest
from numpy.testing import assert_allclose

from microimpact.io.profiles import ProfileSet
from microimpact.surface.roughness import characterise, profile_parameters
from microimpact.surface.synthetic import (
    formica_profile,
    gaussian_profile,
    ripple_profile,
    weierstrass_mandelbrot_profile,
)


def _within_k_se(values, expected, k=4.0):
    values = np.asarray(values)
    se = values.std(ddof=1) / math.sqrt(values.size)
    assert abs(values.mean() - expected) < k * se, (values.mean(), expected, se)


def test_gaussian_profile_rms_height_and_slope(rng):
    sigma, ell, dx, n = 2e-6, 20e-6, 0.5e-6, 2**13
    rq, rdq = [], []
    for _ in range(24):
        p = gaussian_profile(n, dx, rms_height=sigma, correlation_length=ell, rng=rng)
        par = profile_parameters(p, detrend=None)
        rq.append(np.sqrt(np.mean(p.z**2)))  # about the true mean 0
        rdq.append(par.Rdq)
    # E[z^2] = sigma^2 exactly (circulant construction)
    _within_k_se(np.square(rq), sigma**2)
    # analytic RMS slope of a Gaussian ACF: sqrt(2) sigma / ell
    _within_k_se(np.square(rdq), (math.sqrt(2) * sigma / ell) ** 2)
    assert_allclose(np.mean(rdq), math.sqrt(2) * sigma / ell, rtol=0.03)


def test_gaussian_profile_autocorrelation(rng):
    sigma, ell, dx, n = 1.0, 10.0, 0.5, 2**14
    lag = int(ell / dx)
    acf = []
    for _ in range(16):
        z = gaussian_profile(n, dx, rms_height=sigma, correlation_length=ell, rng=rng).z
        acf.append(np.mean(z * np.roll(z, lag)))  # periodic construction
    _within_k_se(acf, sigma**2 * math.exp(-1.0))


def test_gaussian_profile_from_psd(rng):
    sigma, ell, dx, n = 1.0, 10.0, 0.5, 2**13

    def gaussian_psd(k):  # Fourier transform of sigma^2 exp(-tau^2 / ell^2)
        return sigma**2 * ell * math.sqrt(math.pi) * np.exp(-((k * ell) ** 2) / 4)

    var = [
        np.mean(gaussian_profile(n, dx, psd=gaussian_psd, rng=rng).z ** 2)
        for _ in range(16)
    ]
    _within_k_se(var, sigma**2)


def test_gaussian_profile_reproducible_and_validated():
    a = gaussian_profile(256, 1.0, rms_height=1.0, correlation_length=5.0, rng=3)
    b = gaussian_profile(256, 1.0, rms_height=1.0, correlation_length=5.0, rng=3)
    assert_allclose(a.z, b.z, rtol=0, atol=0)
    with pytest.raises(ValueError, match="`rms_height` and `correlation_length`"):
        gaussian_profile(256, 1.0, rms_height=1.0)
    with pytest.raises(ValueError, match="either `psd`"):
        gaussian_profile(256, 1.0, rms_height=1.0, psd=lambda k: k)
    with pytest.raises(ValueError, match="`n` must be an integer"):
        gaussian_profile(1.5, 1.0, rms_height=1.0, correlation_length=5.0)


@pytest.mark.parametrize("dimension", [1.3, 1.5, 1.7])
def test_wm_structure_function_slope(dimension):
    rng = np.random.default_rng(1)
    x = np.arange(2**14) * 0.5e-6
    lags = 2 ** np.arange(4, 10)
    s = np.zeros(lags.size)
    for _ in range(8):
        z = weierstrass_mandelbrot_profile(
            x, fractal_dimension=dimension, G=1e-9, rng=rng
        )
        s += [np.mean((z[k:] - z[:-k]) ** 2) for k in lags]
    slope = np.polyfit(np.log(lags), np.log(s), 1)[0]
    # Majumdar & Bhushan (1991): structure function ∝ tau^(4 - 2D)
    assert_allclose(slope, 4 - 2 * dimension, atol=0.06)


def test_wm_single_term_is_cosine():
    x = np.linspace(0, 1, 101)
    z = weierstrass_mandelbrot_profile(
        x, fractal_dimension=1.5, G=4.0, gamma=2.0, n_low=1, n_high=1, rng=0
    )
    # one term: G^(D-1) gamma^(-(2-D)) cos(2 pi gamma x + phi)
    amp = 4.0**0.5 * 2.0**-0.5
    assert_allclose(np.ptp(z), 2 * amp, rtol=1e-3)
    assert_allclose(np.mean(z[:-1]), 0.0, atol=1e-12)  # two whole periods
    with pytest.raises(ValueError, match="`fractal_dimension` must lie in"):
        weierstrass_mandelbrot_profile(x, fractal_dimension=2.0, G=1.0)
    with pytest.raises(ValueError, match="`gamma` must be > 1"):
        weierstrass_mandelbrot_profile(x, fractal_dimension=1.5, G=1.0, gamma=1.0)


# ------------------------------------------------------------------ shipped data


def test_formica_profile_layout():
    ps = formica_profile()
    assert isinstance(ps, ProfileSet)
    assert len(ps) == 10
    assert all(p.n_points == 8000 for p in ps)
    assert_allclose([p.dx for p in ps], 0.5e-6, rtol=1e-9)
    assert_allclose([p.length for p in ps], 4e-3, rtol=1e-9)
    z = np.concatenate([p.z - p.z.mean() for p in ps])
    # the first realization of the Formica family: its drawn height std (40-50 µm,
    # the paper's "approximately 45 µm"), to the 1 nm rounding of the file
    from microimpact.surface.formica import formica_ensemble

    first = formica_ensemble(1)[0]
    assert 40e-6 <= np.sqrt(np.mean(z**2)) <= 50e-6
    assert_allclose(
        np.sqrt(np.mean(z**2)), first.parameters["height_std_um"] * 1e-6, rtol=1e-5
    )
    ref = resources.files("microimpact").joinpath(
        "surface", "data", "formica_synthetic_profile.csv"
    )
    head = ref.read_text(encoding="utf-8")[:200]
    assert "SYNTHETIC" in head
    assert len(ref.read_bytes()) < 2_000_000


def test_formica_file_matches_generator():
    ref = resources.files("microimpact").joinpath(
        "surface", "data", "make_formica_profile.py"
    )
    with resources.as_file(ref) as path:
        spec = importlib.util.spec_from_file_location("_make_formica", path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    r = mod.formica_ensemble(1)[0]  # what the generator writes
    z_um = np.array([p.z for p in r.profiles.profiles]) * 1e6
    ps = formica_profile()
    stored = np.array([p.z for p in ps]) * 1e6
    assert_allclose(stored, z_um, rtol=0, atol=5.1e-4)  # rounded to 1 nm


def test_formica_slope_angles_asymmetric():
    """The shipped profile (the Formica family's first realization, texture
    orientation +1): its 20 µm slope angles, characterised independently, are
    significantly right-skewed (the paper's "asymmetry in the local surface
    roughness angle distribution"), centred near 0 (detrended scans)."""
    res = characterise(formica_profile(), contact_length=20e-6)
    assert res.n_segments == 10 * 199
    se = math.sqrt(6.0 / res.n_segments)
    assert res.skewness_angle > 5 * se
    assert abs(math.degrees(res.mean_angle)) < 2
    assert 3 < math.degrees(res.std_angle) < 20
    # the texture's steep faces: a tail of facets beyond +20 deg, thinner below
    a = res.angles_deg
    assert np.mean(a > 20) > 2 * np.mean(a < -20)


def test_ripple_profile_slopes():
    """Closed form: slopes tan(alpha) on a fraction w of the length, and
    -tan(alpha) w / (1 - w) on the rest; the profile is continuous."""
    w, alpha, dx = 0.2, math.radians(30.0), 0.5e-6
    p = ripple_profile(
        200_000, dx, period=100e-6, rise_fraction=w, rise_angle=alpha, rng=4
    )
    s = np.diff(p.z) / dx
    up, down = math.tan(alpha), -math.tan(alpha) * w / (1 - w)
    on_up = np.isclose(s, up, rtol=1e-9)
    on_down = np.isclose(s, down, rtol=1e-9)
    kinks = ~(on_up | on_down)
    assert kinks.mean() < 0.02  # only the steps that straddle a corner
    assert_allclose(on_up.mean(), w, atol=0.01)
    # continuous: no step larger than the steep slope allows
    assert np.max(np.abs(np.diff(p.z))) <= up * dx * (1 + 1e-9)
    # mean slope zero over whole periods: the ends differ by at most one amplitude
    assert abs(p.z[-1] - p.z[0]) <= up * w * 100e-6 * 5
    with pytest.raises(ValueError, match="`rise_fraction` must lie in"):
        ripple_profile(10, dx, period=1e-4, rise_fraction=1.0, rise_angle=alpha)
    with pytest.raises(ValueError, match="`rise_angle` must lie in"):
        ripple_profile(10, dx, period=1e-4, rise_fraction=0.5, rise_angle=2.0)


def test_weierstrass_mandelbrot_scalar_arguments():
    x = np.linspace(0, 1e-3, 64)
    with pytest.raises(TypeError, match="`fractal_dimension` must be numeric"):
        weierstrass_mandelbrot_profile(x, fractal_dimension="x", G=1e-9)
    with pytest.raises(TypeError, match="`G` must be a scalar"):
        weierstrass_mandelbrot_profile(x, fractal_dimension=1.5, G=[1e-9, 2e-9])
    with pytest.raises(ValueError, match="`gamma` must be a number > 0"):
        weierstrass_mandelbrot_profile(x, fractal_dimension=1.5, G=1e-9, gamma=np.nan)
    with pytest.raises(ValueError, match="`fractal_dimension` must be a number"):
        weierstrass_mandelbrot_profile(x, fractal_dimension=np.inf, G=1e-9)


def test_gaussian_profile_metadata_has_no_derivable_keys():
    p = gaussian_profile(64, 0.5e-6, rms_height=1e-6, correlation_length=5e-6, rng=1)
    assert p.metadata == {
        "rms_height": 1e-6,
        "correlation_length": 5e-6,
        "synthetic": "gaussian_profile",
    }
    assert p.n_points == 64
    assert_allclose(p.dx, 0.5e-6, rtol=1e-12)
