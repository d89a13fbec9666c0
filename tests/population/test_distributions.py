"""Tests for microimpact.population.distributions (size distributions and fits)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import special, stats

from microimpact._core.tables import TABLE_SIZE, mid_probabilities
from microimpact.population.distributions import (
    CUT_WARN_THRESHOLD,
    SizeDistribution,
    empirical_diameters,
    fit_lognormal,
    fit_normal,
    histogram_diameters,
    lognormal_diameters,
    monodisperse,
    normal_diameters,
    scipy_diameters,
    uniform_diameters,
)

UM = 1e-6  # metres per micrometre, for building test oracles only
KS_P_MIN = 1e-3  # fixed seeds: a correct sampler passes; a wrong one fails by far


def _tn_cdf(d, mu, sigma, lo, hi):
    """Truncated-normal CDF from special.ndtr (independent of truncnorm)."""
    za, zb = (lo - mu) / sigma, (hi - mu) / sigma
    z = (np.clip(d, lo, hi) - mu) / sigma
    return (special.ndtr(z) - special.ndtr(za)) / (special.ndtr(zb) - special.ndtr(za))


def _ln_trunc_mean(median, gsd, lo, hi):
    """Closed-form mean of a log-normal truncated to [lo, hi]."""
    mu, s = math.log(median), math.log(gsd)
    la = (math.log(lo) - mu) / s if lo > 0 else -np.inf
    lb = (math.log(hi) - mu) / s
    num = special.ndtr(lb - s) - special.ndtr(la - s)
    return math.exp(mu + s * s / 2) * num / (special.ndtr(lb) - special.ndtr(la))


# -- normal --------------------------------------------------------------------
def test_normal_truncated_at_zero_matches_closed_form():
    mu, sigma = 52.8 * UM, 15.3 * UM  # SST65 fit [1]
    dist = normal_diameters(52.8, 15.3)
    d = np.linspace(0, 120, 25) * UM
    assert_allclose(dist.cdf(d), _tn_cdf(d, mu, sigma, 0.0, np.inf), rtol=1e-10)
    assert_allclose(dist.truncated_mass, special.ndtr(-mu / sigma), rtol=1e-12)
    alpha = -mu / sigma
    lam = special.ndtr(-alpha)
    mean = mu + sigma * math.exp(-alpha * alpha / 2) / math.sqrt(2 * math.pi) / lam
    assert_allclose(dist.mean(), mean, rtol=1e-12)
    pdf = stats.norm.pdf(d, mu, sigma) / lam
    assert_allclose(dist.pdf(d), pdf, rtol=1e-10)
    assert dist.kind == "normal"
    assert dist.params["mean_um"] == 52.8


def test_normal_with_limits_and_ppf_roundtrip():
    with pytest.warns(UserWarning, match="0.0776"):
        dist = normal_diameters(30, 1.7, min_um=27, max_um=33)  # Lycopodium [1]
    q = np.linspace(0, 1, 101)
    d = dist.ppf(q)
    assert_allclose(_tn_cdf(d, 30 * UM, 1.7 * UM, 27 * UM, 33 * UM), q, atol=1e-12)
    assert_allclose(dist.support(), (27 * UM, 33 * UM), rtol=1e-15)
    cut = 2 * special.ndtr(-3 / 1.7)
    assert_allclose(dist.truncated_mass, cut, rtol=1e-12)


def test_normal_sampler_and_table_match(rng):
    dist = normal_diameters(52.8, 15.3)
    cdf = lambda d: _tn_cdf(d, 52.8 * UM, 15.3 * UM, 0.0, np.inf)  # noqa: E731
    assert stats.kstest(dist.rvs(5000, rng=rng), cdf).pvalue > KS_P_MIN
    table = dist.table()
    assert stats.kstest(table.sample(5000, rng=rng), cdf).pvalue > KS_P_MIN
    # independent of how the table is built: the closed-form CDF at the atoms is the
    # mid-probability grid (j + 1/2)/M, so the table's KS distance is <= 1/(2M)
    m = table.size
    f = _tn_cdf(table.values, 52.8 * UM, 15.3 * UM, 0.0, np.inf)
    assert_allclose(f, (np.arange(m) + 0.5) / m, rtol=0, atol=1e-9)
    j = np.arange(m)
    assert max(np.max((j + 1) / m - f), np.max(f - j / m)) <= 0.5 / m + 1e-9


# -- log-normal ----------------------------------------------------------------
def test_lognormal_untruncated_closed_forms():
    dist = lognormal_diameters(30, 1.5)
    q = np.array([0.01, 0.25, 0.5, 0.9, 0.999])
    expect = 30 * UM * np.exp(math.log(1.5) * special.ndtri(q))
    assert_allclose(dist.ppf(q), expect, rtol=1e-12)
    assert dist.truncated_mass == 0.0
    s = math.log(1.5)
    assert_allclose(dist.mean(), 30 * UM * math.exp(s * s / 2), rtol=1e-12)
    sd = 30 * UM * math.sqrt((math.exp(s * s) - 1) * math.exp(s * s))
    assert_allclose(dist.std(), sd, rtol=1e-12)


def test_lognormal_truncation_moments_and_cdf():
    with pytest.warns(UserWarning, match="cuts away"):
        dist = lognormal_diameters(30, 1.5, min_um=10, max_um=60)
    lo, hi, s = 10 * UM, 60 * UM, math.log(1.5)
    z = lambda d: (np.log(d) - math.log(30 * UM)) / s  # noqa: E731
    kept = special.ndtr(z(hi)) - special.ndtr(z(lo))
    assert_allclose(dist.truncated_mass, 1 - kept, rtol=1e-12)
    d = np.linspace(10, 60, 11) * UM
    assert_allclose(
        dist.cdf(d), (special.ndtr(z(d)) - special.ndtr(z(lo))) / kept, atol=1e-13
    )
    assert_allclose(dist.mean(), _ln_trunc_mean(30 * UM, 1.5, lo, hi), rtol=1e-8)
    assert_allclose(dist.cdf([5 * UM, 70 * UM]), [0.0, 1.0], atol=0)
    assert_allclose(dist.pdf([5 * UM, 70 * UM]), [0.0, 0.0], atol=0)
    # the density integrates to one over the kept interval
    from scipy.integrate import quad

    assert_allclose(quad(dist.pdf, lo, hi, points=[30 * UM])[0], 1.0, rtol=1e-9)


def test_lognormal_far_upper_tail_truncation_is_accurate():
    """Keeping only d >= median * gsd**6 (mass 1e-9): ppf through isf stays exact."""
    with pytest.warns(UserWarning):
        dist = lognormal_diameters(30, 1.5, min_um=30 * 1.5**6)
    s = math.log(1.5)
    q = np.array([0.0, 0.1, 0.5, 0.9])
    tail = special.ndtr(-6.0)  # P(z > 6)
    expect = 30 * UM * np.exp(-s * special.ndtri(tail * (1 - q)))
    assert_allclose(dist.ppf(q), expect, rtol=1e-10)
    assert_allclose(dist.cdf(dist.ppf(q)), q, atol=1e-9)


def test_lognormal_sampler(rng):
    with pytest.warns(UserWarning):
        dist = lognormal_diameters(30, 1.5, max_um=80)
    lo, hi = 0.0, 80 * UM
    base = stats.lognorm(math.log(1.5), scale=30 * UM)
    cdf = lambda d: np.clip(base.cdf(d), 0, base.cdf(hi)) / base.cdf(hi)  # noqa: E731
    assert stats.kstest(dist.rvs(4000, rng=rng), cdf).pvalue > KS_P_MIN
    assert stats.kstest(dist.table().sample(4000, rng=rng), cdf).pvalue > KS_P_MIN
    x = dist.rvs(20000, rng=rng)
    se = dist.std() / math.sqrt(x.size)
    assert abs(x.mean() - _ln_trunc_mean(30 * UM, 1.5, lo, hi)) < 4 * se


# -- uniform, monodisperse -----------------------------------------------------
def test_uniform(rng):
    dist = uniform_diameters(10, 65)  # SST65 nominal range [1]
    assert_allclose(dist.mean(), 37.5 * UM, rtol=1e-14)
    assert_allclose(dist.std(), 55 * UM / math.sqrt(12), rtol=1e-14)
    assert_allclose(dist.ppf([0, 0.5, 1]), [10 * UM, 37.5 * UM, 65 * UM], rtol=1e-14)
    assert_allclose(dist.pdf(20 * UM), 1 / (55 * UM), rtol=1e-12)
    cdf = stats.uniform(10 * UM, 55 * UM).cdf
    assert stats.kstest(dist.rvs(3000, rng=rng), cdf).pvalue > KS_P_MIN


def test_monodisperse_collapses(rng):
    dist = monodisperse(40)
    assert_allclose(dist.ppf(np.linspace(0, 1, 7)), 40 * UM, rtol=0)
    assert_allclose(dist.table().values, 40 * UM, rtol=0)
    assert_allclose(dist.rvs(100, rng=rng), 40 * UM, rtol=0)
    assert dist.std() == 0.0 and dist.truncated_mass == 0.0
    assert_allclose(dist.cdf([39 * UM, 40 * UM, 41 * UM]), [0, 1, 1], atol=0)
    assert_allclose(dist.pdf([39 * UM, 40 * UM]), [0, np.inf])
    assert dist.support() == (40 * UM, 40 * UM)


# -- empirical -----------------------------------------------------------------
def test_empirical_quantiles_are_measured_values(rng):
    x_um = np.round(rng.normal(52.8, 15.3, 777).clip(1), 2)
    dist = empirical_diameters(x_um)
    q = rng.random(1000)
    d = dist.ppf(q)
    # left-continuous inverse of the ECDF: F(d) >= q > F(d-)
    ecdf = lambda v, side: np.searchsorted(np.sort(x_um) * UM, v, side) / 777  # noqa: E731
    assert np.all(ecdf(d, "right") >= q)
    assert np.all(ecdf(d, "left") < q)
    table = dist.table()
    assert np.all(np.isin(table.values, x_um * UM))
    # the table reproduces the sample: every value with probability 1/n (up to 1/M)
    _, counts = np.unique(table.values, return_counts=True)
    expect = np.unique(x_um * UM, return_counts=True)[1] / 777
    assert_allclose(counts / TABLE_SIZE, expect, atol=1.0 / TABLE_SIZE)
    assert_allclose(dist.mean(), np.mean(x_um) * UM, rtol=1e-12)
    sample = dist.rvs(5000, rng=rng)
    assert np.all(np.isin(sample, x_um * UM))
    assert abs(sample.mean() - dist.mean()) < 4 * dist.std() / math.sqrt(5000)


def test_empirical_table_ppf_agrees_with_distribution(rng):
    dist = empirical_diameters(rng.lognormal(3.5, 0.4, 1000))
    table = dist.table()
    q = mid_probabilities()
    agree = np.isclose(table.ppf(q), dist.ppf(q), rtol=0, atol=0)
    assert agree.mean() > 0.999  # differ only where q * n lands on an integer


def test_empirical_truncation_reports_cut(rng):
    x = rng.normal(50, 10, 1000)
    n_out = int(np.sum((x < 30) | (x > 75)))
    with pytest.warns(UserWarning) as rec:
        dist = empirical_diameters(x, min_um=30, max_um=75)
    assert rec[0].filename == __file__  # stacklevel points at the caller
    assert_allclose(dist.truncated_mass, n_out / 1000, rtol=1e-12)
    assert dist.atoms.size == 1000 - n_out
    assert dist.support()[0] >= 30 * UM and dist.support()[1] <= 75 * UM


# -- histogram -----------------------------------------------------------------
EDGES_UM = np.array([10.0, 20.0, 30.0, 40.0, 50.0, 65.0, 80.0])
COUNTS = np.array([12.0, 40.0, 95.0, 120.0, 60.0, 8.0])


def test_histogram_reproduces_counts(rng):
    dist = histogram_diameters(EDGES_UM, COUNTS)
    p = COUNTS / COUNTS.sum()
    assert_allclose(dist.cdf(EDGES_UM * UM), np.r_[0, np.cumsum(p)], atol=1e-14)
    n = 20000
    for sample in (dist.rvs(n, rng=rng), dist.table().sample(n, rng=rng)):
        observed = np.histogram(sample, bins=EDGES_UM * UM)[0]
        _, pvalue = stats.chisquare(observed, n * p)
        assert pvalue > KS_P_MIN
        assert_allclose(observed, n * p, atol=5 * np.sqrt(n * p * (1 - p)).max())
    # uniform within a bin
    assert_allclose(dist.pdf(25 * UM), p[1] / (10 * UM), rtol=1e-12)
    assert_allclose(dist.ppf([0, 1]), [10 * UM, 80 * UM], rtol=1e-12)


def test_histogram_frequencies_equal_counts():
    a = histogram_diameters(EDGES_UM, COUNTS)
    b = histogram_diameters(EDGES_UM, COUNTS / COUNTS.sum())
    q = np.linspace(0, 1, 17)
    assert_allclose(a.ppf(q), b.ppf(q), rtol=1e-12)


# -- scipy ---------------------------------------------------------------------
def test_scipy_gamma_in_micrometres_and_millimetres(rng):
    a = scipy_diameters(stats.gamma(4, scale=12))
    assert_allclose(a.mean(), 48 * UM, rtol=1e-12)
    assert_allclose(a.std(), 24 * UM, rtol=1e-12)
    b = scipy_diameters(stats.gamma(a=4, loc=0.001, scale=0.012), unit="mm")
    assert_allclose(b.mean(), 49 * UM, rtol=1e-12)
    assert_allclose(b.ppf(0.3), stats.gamma(4, loc=1, scale=12).ppf(0.3) * UM, 1e-12)
    assert (
        stats.kstest(a.rvs(3000, rng=rng), stats.gamma(4, scale=12 * UM).cdf).pvalue
        > KS_P_MIN
    )


def test_scipy_norm_is_cut_at_zero():
    with pytest.warns(UserWarning, match="0.159"):
        dist = scipy_diameters(stats.norm(10, 10))
    assert_allclose(dist.truncated_mass, special.ndtr(-1.0), rtol=1e-12)
    assert_allclose(
        dist.cdf(10 * UM), (0.5 - special.ndtr(-1)) / special.ndtr(1), 1e-12
    )
    assert dist.ppf(0.0) == 0.0


def test_scipy_accepts_rv_histogram_and_rejects_others():
    h = stats.rv_histogram((COUNTS, EDGES_UM), density=False)
    dist = scipy_diameters(h)
    ref = histogram_diameters(EDGES_UM, COUNTS)
    q = np.linspace(0, 1, 11)
    assert_allclose(dist.ppf(q), ref.ppf(q), rtol=1e-12)
    with pytest.raises(TypeError, match="frozen"):
        scipy_diameters(stats.poisson(3))
    with pytest.raises(TypeError, match="frozen"):
        scipy_diameters([1, 2, 3])
    with pytest.raises(ValueError, match="unknown length unit"):
        scipy_diameters(stats.gamma(4), unit="furlong")


# -- truncation ----------------------------------------------------------------
def test_small_cut_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dist = normal_diameters(52.8, 15.3)
    assert 0 < dist.truncated_mass < CUT_WARN_THRESHOLD


def test_large_cut_warns_at_caller():
    with pytest.warns(UserWarning, match="cuts away") as rec:
        normal_diameters(10, 10)
    assert rec[0].filename == __file__
    with pytest.warns(UserWarning) as rec:
        lognormal_diameters(30, 2, max_um=40)
    assert rec[0].filename == __file__


def test_all_mass_cut_raises():
    with pytest.raises(ValueError, match="all of the probability"):
        normal_diameters(-1000, 1)
    with pytest.raises(ValueError, match="all of the probability"):
        lognormal_diameters(30, 1.1, min_um=1e9)
    with pytest.raises(ValueError, match="no measured diameter"):
        empirical_diameters([10, 20, 30], min_um=40)


# -- common interface ----------------------------------------------------------
ALL = {
    "normal": lambda: normal_diameters(52.8, 15.3),
    "lognormal": lambda: lognormal_diameters(30, 1.4, min_um=5),
    "uniform": lambda: uniform_diameters(10, 65),
    "empirical": lambda: empirical_diameters(np.linspace(10, 90, 101)),
    "histogram": lambda: histogram_diameters(EDGES_UM, COUNTS),
    "monodisperse": lambda: monodisperse(40),
    "scipy": lambda: scipy_diameters(stats.gamma(4, scale=12)),
}


@pytest.mark.parametrize("kind", list(ALL))
def test_interface(kind, rng):
    dist = ALL[kind]()
    assert isinstance(dist, SizeDistribution) and dist.kind == kind
    # input matrix: scalar, 1-d, 2-d, NaN, out-of-range q
    assert np.ndim(dist.ppf(0.5)) == 0
    assert dist.ppf(np.full((2, 3), 0.5)).shape == (2, 3)
    assert np.isnan(dist.ppf(np.nan)) and np.isnan(dist.ppf(1.5))
    assert np.isnan(dist.ppf(-0.1))
    assert np.isnan(dist.cdf(np.nan)) and np.isnan(dist.pdf(np.nan))
    q = np.linspace(0.01, 0.99, 50)
    d = dist.ppf(q)
    assert np.all(np.diff(d) >= 0) and np.all(d > 0)
    assert np.all(dist.cdf(d) >= q - 1e-12)  # F(F^-1(q)) >= q
    lo, hi = dist.support()
    assert 0 <= lo <= d.min() and d.max() <= hi
    x = dist.rvs(2000, rng=np.random.default_rng(5))
    assert x.shape == (2000,) and np.all((x >= lo) & (x <= hi))
    assert_allclose(x, dist.rvs(2000, rng=np.random.default_rng(5)), rtol=0)
    if dist.std() > 0:
        assert abs(x.mean() - dist.mean()) < 4 * dist.std() / math.sqrt(x.size)
    table = dist.table(size=1024)
    assert table.size == 1024
    # table quantiles bracket the distribution's on the probability grid
    qs = rng.random(500)
    tq = table.ppf(qs)
    assert np.all(tq >= dist.ppf(np.floor(qs * 1024) / 1024) - 1e-18)
    assert np.all(tq <= dist.ppf(np.ceil(qs * 1024) / 1024) + 1e-18)
    info = dist.describe()
    assert info["kind"] == kind and info["truncated_mass"] == dist.truncated_mass
    assert_allclose(info["mean_um"], dist.mean() / UM, rtol=1e-12)
    assert kind in repr(dist)


# -- validation ----------------------------------------------------------------
@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (lambda: normal_diameters(50, 0), "`std_um` must be a number > 0"),
        (lambda: normal_diameters(np.nan, 1), "`mean_um`"),
        (lambda: normal_diameters([50, 60], 1), "`mean_um` must be a scalar"),
        (lambda: normal_diameters(50, 5, min_um=-1), "`min_um` must be a number >= 0"),
        (lambda: normal_diameters(50, 5, min_um=60, max_um=40), "`max_um` must be >"),
        (lambda: lognormal_diameters(30, 1.0), "`geometric_std` must be > 1"),
        (lambda: lognormal_diameters(-30, 1.5), "`median_um`"),
        (lambda: uniform_diameters(65, 10), "`max_um` must be >"),
        (lambda: uniform_diameters(10, np.inf), "`max_um`"),
        (lambda: monodisperse(0), "`diameter_um` must be a number > 0"),
        (lambda: empirical_diameters([10, -1, 3]), "got -1.0 at index 1"),
        (lambda: empirical_diameters([]), "at least 1"),
        (lambda: histogram_diameters([10, 20, 30], [1]), "needs len"),
        (lambda: histogram_diameters([10, 30, 20], [1, 1]), "strictly increasing"),
        (lambda: histogram_diameters([10, 20, 30], [1, -1]), "`counts` must be"),
        (lambda: histogram_diameters([10, 20, 30], [0, 0]), "not all 0"),
        (lambda: histogram_diameters([-10, 20], [1]), "`edges_um`"),
    ],
)
def test_validation(factory, match):
    with pytest.raises((ValueError, TypeError), match=match):
        factory()


@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (lambda: normal_diameters("52.8", 15.3), "`mean_um` must be numeric.*'52.8'"),
        (lambda: lognormal_diameters(30, "1.5"), "`geometric_std` must be numeric"),
        (lambda: monodisperse(True), "`diameter_um` must be numeric.*True"),
        (lambda: uniform_diameters(10, b"65"), "`max_um` must be numeric"),
        (lambda: normal_diameters(50, 5, min_um="1"), "`min_um` must be numeric"),
    ],
)
def test_strings_and_bools_are_refused(factory, match):
    """Numeric strings were accepted before 0.x; every factory now refuses them."""
    with pytest.raises(TypeError, match=match):
        factory()


def test_numpy_scalars_and_0d_arrays_are_accepted():
    a = normal_diameters(np.float32(52.8), np.array(15.3), max_um=np.int64(200))
    b = normal_diameters(52.8, 15.3, max_um=200)
    assert_allclose(a.ppf([0.1, 0.9]), b.ppf([0.1, 0.9]), rtol=1e-7)
    assert a.params["max_um"] == 200


# -- fits ----------------------------------------------------------------------
def _numerical_se(nll, theta, rel=1e-4):
    """Standard errors from a central-difference Hessian of the negative log-lik."""
    theta = np.asarray(theta, dtype=float)
    h = rel * np.abs(theta)
    k = theta.size
    hess = np.empty((k, k))
    for i in range(k):
        for j in range(k):
            ei, ej = np.eye(k)[i] * h[i], np.eye(k)[j] * h[j]
            hess[i, j] = (
                nll(theta + ei + ej)
                - nll(theta + ei - ej)
                - nll(theta - ei + ej)
                + nll(theta - ei - ej)
            ) / (4 * h[i] * h[j])
    return np.sqrt(np.diag(np.linalg.inv(hess)))


def test_fit_normal_mle_and_standard_errors(rng):
    x = rng.normal(52.8, 15.3, 800)
    res = fit_normal(x)
    assert_allclose(res.params["mean_um"], np.mean(x), rtol=1e-12)
    assert_allclose(res.params["std_um"], np.std(x), rtol=1e-12)
    nll = lambda t: -stats.norm.logpdf(x, t[0], t[1]).sum()  # noqa: E731
    se = _numerical_se(nll, [res.params["mean_um"], res.params["std_um"]])
    assert_allclose([res.stderr["mean_um"], res.stderr["std_um"]], se, rtol=1e-4)
    assert_allclose(res.log_likelihood, -nll([np.mean(x), np.std(x)]), rtol=1e-12)
    assert res.n == 800 and res.distribution.kind == "normal"
    assert_allclose(res.distribution.params["mean_um"], np.mean(x), rtol=1e-12)


def test_fit_lognormal_mle_and_standard_errors(rng):
    x = rng.lognormal(math.log(30), math.log(1.4), 600)
    res = fit_lognormal(x)
    assert_allclose(res.params["median_um"], np.exp(np.log(x).mean()), rtol=1e-9)
    assert_allclose(res.params["geometric_std"], np.exp(np.log(x).std()), rtol=1e-9)
    nll = lambda t: -stats.lognorm.logpdf(x, np.log(t[1]), scale=t[0]).sum()  # noqa: E731
    se = _numerical_se(nll, [res.params["median_um"], res.params["geometric_std"]])
    assert_allclose(
        [res.stderr["median_um"], res.stderr["geometric_std"]], se, rtol=1e-3
    )
    assert res.distribution.kind == "lognormal"


def test_fit_errors():
    with pytest.raises(ValueError, match="at least 2"):
        fit_normal([50.0])
    with pytest.raises(ValueError, match="all equal"):
        fit_normal([50.0, 50.0, 50.0])
    with pytest.raises(ValueError, match="all equal"):
        fit_lognormal([50.0, 50.0])
    with pytest.raises(ValueError, match="diameters > 0"):
        fit_lognormal([50.0, 0.0])


@pytest.mark.parametrize(
    ("min_um", "max_um"), [(5, None), (None, 80), (10, 60), (100, None)]
)
def test_lognormal_truncated_moments_closed_form(min_um, max_um):
    """Quadrature moments against the closed-form truncated log-normal mean/E[d^2]."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        dist = lognormal_diameters(30, 1.4, min_um=min_um, max_um=max_um)
    lo = (min_um or 0) * UM
    hi = max_um * UM if max_um else np.inf
    mean = _ln_trunc_mean(30 * UM, 1.4, lo, hi)
    # E[d^2] of a log-normal truncated to [lo, hi]: shift the Gaussian by 2 s^2
    mu, s = math.log(30 * UM), math.log(1.4)
    la = (math.log(lo) - mu) / s if lo > 0 else -np.inf
    lb = (math.log(hi) - mu) / s
    kept = special.ndtr(lb) - special.ndtr(la)
    m2 = (
        math.exp(2 * mu + 2 * s * s)
        * (special.ndtr(lb - 2 * s) - special.ndtr(la - 2 * s))
        / kept
    )
    assert_allclose(dist.mean(), mean, rtol=1e-9)
    assert_allclose(dist.std(), math.sqrt(m2 - mean**2), rtol=1e-7)


def test_table_is_evaluated_in_slices_with_unchanged_values():
    # from_ppf calls the quantile function on slices (small temporaries); the
    # atoms must be the values of one whole-array call
    from scipy import stats

    from microimpact._core.tables import (
        PPF_SLICE,
        TABLE_SIZE,
        QuantileTable,
        mid_probabilities,
    )

    dist = stats.truncnorm(-2.0, np.inf, loc=5e-6, scale=2e-6)
    sizes = []

    def ppf(q):
        sizes.append(q.size)
        return dist.ppf(q)

    table = QuantileTable.from_ppf(ppf)
    assert max(sizes) == PPF_SLICE and sum(sizes) == TABLE_SIZE
    np.testing.assert_array_equal(table.values, dist.ppf(mid_probabilities()))


@pytest.mark.parametrize("median", [0.0, -5.0])
def test_a_lognormal_median_must_be_positive(median):
    with pytest.raises(ValueError, match=r"`median_um` must be a number > 0"):
        lognormal_diameters(median, 1.5)


def test_a_normal_population_keeps_its_truncation_limits_by_name():
    # the limits the user gave are the population's parameters, under the names
    # of the [particles] table (min_um, max_um)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the truncated mass
        dist = normal_diameters(50.0, 5.0, min_um=30.0, max_um=70.0)
    assert dist.params == {
        "mean_um": 50.0,
        "std_um": 5.0,
        "min_um": 30.0,
        "max_um": 70.0,
    }


def test_a_histogram_with_the_wrong_number_of_counts_says_how_many():
    with pytest.raises(ValueError) as info:
        histogram_diameters([1.0, 2.0, 4.0, 8.0], [1.0, 2.0])
    assert str(info.value) == "`counts` needs len(edges_um) - 1 = 3 values; got 2."
