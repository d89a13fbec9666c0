"""Tests for microimpact.surface.angles: roughness-angle distributions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate, stats

from microimpact._core.tables import QuantileTable
from microimpact.surface.angles import (
    AngleDistribution,
    angles_from_file,
    angles_from_profile,
    angles_from_sample,
    normal_angles,
    scipy_angles,
    smooth_surface,
)
from microimpact.surface.roughness import surface_angles, write_angle_file
from microimpact.surface.synthetic import gaussian_profile

HALF_PI = math.pi / 2


def _truncnorm(mean_deg, std_deg):
    m, s = math.radians(mean_deg), math.radians(std_deg)
    return stats.truncnorm((-HALF_PI - m) / s, (HALF_PI - m) / s, loc=m, scale=s)


# ------------------------------------------------------------------ normal


@pytest.mark.parametrize(("std", "mean"), [(20.0, 0.0), (60.0, 10.0)])
def test_normal_matches_scipy_truncnorm(std, mean):
    d = normal_angles(std, mean_deg=mean)
    ref = _truncnorm(mean, std)
    q = np.linspace(0.001, 0.999, 57)
    assert_allclose(d.ppf(q), ref.ppf(q), rtol=1e-9, atol=1e-12)
    x = np.linspace(-1.5, 1.5, 31)
    assert_allclose(d.cdf(x), ref.cdf(x), rtol=1e-9, atol=1e-12)
    assert_allclose(d.pdf(x), ref.pdf(x), rtol=1e-9, atol=1e-12)
    assert_allclose(d.mean(), ref.mean(), rtol=1e-7, atol=1e-10)
    assert_allclose(d.std(), ref.std(), rtol=1e-7)
    cut = stats.norm.cdf(-90, mean, std) + stats.norm.sf(90, mean, std)
    assert_allclose(d.cut_mass, cut, rtol=1e-9, atol=1e-15)
    assert d.kind == "normal" and d.params == {"mean_deg": mean, "std_deg": std}
    assert d.truncated_mass == d.cut_mass and not d.is_discrete
    assert_allclose(d.describe()["median_deg"], np.degrees(ref.median()), rtol=1e-9)


def test_normal_sampler_ks(rng):
    d = normal_angles(25.0, mean_deg=-5.0)
    sample = d.rvs(20000, rng=rng)
    assert np.all(np.abs(sample) < HALF_PI)
    assert stats.kstest(sample, _truncnorm(-5.0, 25.0).cdf).pvalue > 1e-3


def test_pdf_integrates_to_one():
    d = normal_angles(70.0)  # heavily truncated
    total, _ = integrate.quad(d.pdf, -HALF_PI, HALF_PI)
    assert_allclose(total, 1.0, rtol=1e-9)
    assert d.pdf(2.0) == 0.0


def test_table_is_equiprobable_atoms(rng):
    d = normal_angles(20.0)
    t = d.table()
    assert isinstance(t, QuantileTable) and t.size == 2**16
    mid = (np.arange(t.size) + 0.5) / t.size
    assert_allclose(t.values, _truncnorm(0.0, 20.0).ppf(mid), rtol=1e-9, atol=1e-12)
    assert stats.kstest(t.sample(20000, rng=rng), _truncnorm(0, 20).cdf).pvalue > 1e-3


def test_ppf_input_matrix():
    d = normal_angles(20.0)
    assert np.ndim(d.ppf(0.5)) == 0
    assert_allclose(d.ppf(0.5), 0.0, atol=1e-15)
    assert d.ppf(np.ones((2, 3)) * 0.3).shape == (2, 3)
    assert np.isnan(d.ppf(np.nan))
    assert d.ppf(1.0) < HALF_PI and d.ppf(0.0) > -HALF_PI
    assert np.isnan(d.ppf(1.5)) and np.isnan(d.ppf(-0.1))  # as SizeDistribution


def test_normal_validation_and_zero_std():
    with pytest.raises(ValueError, match="`std_deg`"):
        normal_angles(-1.0)
    with pytest.raises(ValueError, match="`mean_deg`"):
        normal_angles(1.0, mean_deg=95.0)
    d = normal_angles(0.0, mean_deg=10.0)
    assert_allclose(d.rvs(5, rng=0), math.radians(10.0), rtol=1e-15)
    assert d.std() == 0.0


# ------------------------------------------------------------------ empirical


def test_empirical_ppf_cdf_against_numpy(rng):
    a = rng.normal(0, 20, 999)
    d = angles_from_sample(a)
    rad = np.radians(a)
    q = rng.random(500)
    assert_allclose(
        d.ppf(q), np.quantile(rad, q, method="inverted_cdf"), rtol=0, atol=0
    )
    x = np.radians(np.linspace(-60, 60, 41))
    ecdf = (rad[None, :] <= x[:, None]).mean(axis=1)
    assert_allclose(d.cdf(x), ecdf, rtol=0, atol=1e-15)
    assert_allclose(d.mean(), rad.mean(), rtol=1e-12)
    assert_allclose(d.std(), rad.std(), rtol=1e-12)
    # discrete: a Dirac delta at each atom, as SizeDistribution.pdf
    assert d.pdf(0.0) == 0.0 and d.pdf(rad[3]) == np.inf
    assert d.is_discrete is True
    assert d.support() == (rad.min(), rad.max())


def test_empirical_sampler_and_table_use_measured_atoms(rng):
    a = np.array([-30.0, -10.0, 0.0, 5.0, 40.0])
    d = angles_from_sample(a)
    draws = d.rvs(50000, rng=rng)
    values, counts = np.unique(draws, return_counts=True)
    assert_allclose(values, np.radians(np.sort(a)), rtol=1e-15)
    # each atom has probability 1/5: chi-square goodness of fit
    assert stats.chisquare(counts).pvalue > 1e-3
    t = d.table(size=1024)
    assert np.isin(t.values, np.radians(a)).all()
    assert_allclose(np.unique(t.values, return_counts=True)[1], 1024 / 5, atol=1)


def test_empirical_truncation_reports_cut_mass():
    d = angles_from_sample([10.0, -20.0, 90.0, -95.0])
    assert_allclose(d.cut_mass, 0.5, rtol=0)
    assert d.params["n"] == 2
    desc = d.describe()
    assert desc["truncated_mass"] == 0.5 and desc["n_atoms"] == 2
    assert_allclose(desc["support_deg"], (-20.0, 10.0), rtol=1e-12)
    with pytest.raises(ValueError, match="NaN"):
        angles_from_sample([1.0, np.nan])
    with pytest.raises(ValueError, match="no angle inside"):
        angles_from_sample([90.0])


def test_angles_from_file_and_profile(tmp_path, rng):
    path = tmp_path / "phi.txt"
    written = write_angle_file(path, rng.uniform(-40, 40, 300), n=1000, rng=rng)
    d = angles_from_file(path)
    assert d.params["source"] == "phi.txt"  # the name, no folders (issue 21)
    import hashlib

    assert d.params["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    # the atoms are the written angles (to the file's 6 decimals): each of the n
    # sorted angles is the ppf at its mid-probability, and the table holds every
    # distinct angle and nothing else
    n = written.size
    ppf = np.degrees(d.ppf((np.arange(n) + 0.5) / n))
    assert_allclose(ppf, np.sort(written), rtol=0, atol=1e-6)
    atoms = np.unique(np.degrees(d.table(1024).values))
    assert_allclose(atoms, np.unique(written), rtol=0, atol=1e-6)
    p = gaussian_profile(
        4000, 0.5e-6, rms_height=5e-6, correlation_length=40e-6, rng=rng
    )
    dp = angles_from_profile(p, contact_length_um=20.0)
    ref = np.sort(surface_angles(p, contact_length=20e-6))
    assert_allclose(dp.ppf((np.arange(ref.size) + 0.5) / ref.size), ref, rtol=1e-12)
    assert dp.params["method"] == "slope" and dp.params["contact_length_um"] == 20.0


# ------------------------------------------------------------------ scipy, smooth


@pytest.mark.parametrize(
    ("dist", "unit"),
    [
        (stats.uniform(-30, 60), "deg"),
        (stats.uniform(-math.pi / 6, math.pi / 3), "rad"),
    ],
)
def test_scipy_uniform(dist, unit, rng):
    d = scipy_angles(dist, unit=unit)
    ref = stats.uniform(-math.pi / 6, math.pi / 3)
    assert d.cut_mass == 0.0
    assert stats.kstest(d.rvs(20000, rng=rng), ref.cdf).pvalue > 1e-3
    assert_allclose(d.pdf(0.1), ref.pdf(0.1), rtol=1e-12)
    assert_allclose(d.mean(), 0.0, atol=1e-10)
    assert_allclose(d.std(), ref.std(), rtol=1e-8)


def test_scipy_truncation():
    d = scipy_angles(stats.uniform(-120, 240))  # degrees
    assert_allclose(d.cut_mass, 0.25, rtol=1e-12)
    assert_allclose(d.ppf([0.0, 0.5]), [-HALF_PI, 0.0], atol=1e-12)
    assert_allclose(d.pdf(0.0), 1 / math.pi, rtol=1e-12)  # uniform on (-pi/2, pi/2)
    with pytest.raises(TypeError, match="frozen continuous"):
        scipy_angles(np.array([1.0]))
    with pytest.raises(ValueError, match="`unit` must be one of"):
        scipy_angles(stats.norm(), unit="grad")


def test_smooth_surface(rng):
    d = smooth_surface()
    assert isinstance(d, AngleDistribution) and d.kind == "smooth"
    assert np.all(d.rvs(100, rng=rng) == 0.0)
    assert np.all(d.ppf([0.0, 0.3, 1.0]) == 0.0)
    assert_allclose(d.cdf([-1e-9, 0.0]), [0.0, 1.0])
    assert np.all(d.table(64).values == 0.0)
    assert d.mean() == 0.0 and d.std() == 0.0
    assert d.describe()["kind"] == "smooth" and d.median() == 0.0
    assert d.pdf(0.0) == np.inf and d.pdf(0.1) == 0.0
    # recognised by structure: a single atom at 0 (the engine samples its atoms)
    assert d.is_smooth and d.is_discrete and d.describe()["n_atoms"] == 1
    assert d.atoms.tolist() == [0.0] and d.weights.tolist() == [1.0]
    assert d.isf(1e-9) == 0.0 and d.sf(0.0) == 0.0
    assert not normal_angles(5.0).is_smooth


def test_scalar_arguments_are_validated():
    with pytest.raises(TypeError, match="`std_deg` must be numeric"):
        normal_angles("x")
    with pytest.raises(TypeError, match="`mean_deg` must be a scalar"):
        normal_angles(10.0, mean_deg=[1.0, 2.0])
    with pytest.raises(ValueError, match="`std_deg` must be a number >= 0"):
        normal_angles(np.inf)
    with pytest.raises(ValueError, match="`mean_deg`"):
        normal_angles(10.0, mean_deg=np.nan)
    with pytest.raises(TypeError, match=r"`std_deg` must be numeric.*'10'"):
        normal_angles("10")  # numeric strings are refused


def test_angle_file_decimal_comma(tmp_path):
    from microimpact.errors import DataFormatError

    path = tmp_path / "phi.txt"
    path.write_text("# angles\n1.5\n2,5\n", encoding="utf-8")
    with pytest.raises(DataFormatError, match=r"decimal separator must be '\.'") as ei:
        angles_from_file(path)
    assert str(ei.value).startswith(f"{path}:3: ")
    path.write_text("1.5 # a note\n-2.25\n", encoding="utf-8")
    assert_allclose(angles_from_file(path).params["n"], 2)
