"""Binned size distributions: conversions, the binned likelihood, chi-squared on
the bins (issue 22). Oracles: exact bin probabilities of scipy's CDFs,
Hatch-Choate, the chi-squared law of the statistic under the null."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import stats

from microimpact.population.aerosol import hatch_choate_mass_median
from microimpact.population.binned import (
    binned_median,
    chi2_binned,
    edges_from_midpoints,
    fit_binned_lognormal,
    fit_binned_normal,
    number_per_bin,
)


def _log_edges(centre, gsd, lo=-3.5, hi=3.0, per_decade=16):
    """Log-spaced edges from centre*gsd**lo to centre*gsd**hi (a truncated range)."""
    a, b = math.log10(centre * gsd**lo), math.log10(centre * gsd**hi)
    n = max(12, int((b - a) * per_decade))
    return np.logspace(a, b, n + 1)


@settings(max_examples=20, deadline=None)
@given(
    cmd=st.floats(0.05, 50.0),
    gsd=st.floats(1.2, 2.5),
)
def test_binned_lognormal_fit_recovers_parameters_within_5_se(cmd, gsd):
    """Hypothesis draws the population, not the random seed: a search over seeds
    would find the rare sample that any k-SE bound fails on."""
    edges = _log_edges(cmd, gsd)
    dist = stats.lognorm(math.log(gsd), scale=cmd)
    p = np.diff(dist.cdf(edges))
    counts = np.random.default_rng(2026).multinomial(3000, p / p.sum())
    fit = fit_binned_lognormal(edges, counts)
    for key, true in (("median_um", cmd), ("geometric_std", gsd)):
        se = fit.stderr[key]
        assert 0 < se < 0.1 * true
        assert abs(fit.params[key] - true) < 5 * se, (key, fit.params, fit.stderr)


@settings(max_examples=15, deadline=None)
@given(
    mean=st.floats(5.0, 100.0),
    rel=st.floats(0.1, 0.4),
)
def test_binned_normal_fit_recovers_parameters_within_5_se(mean, rel):
    std = rel * mean
    edges = np.linspace(max(mean - 2.5 * std, 0.01), mean + 3 * std, 25)
    dist = stats.norm(mean, std)
    p = np.diff(dist.cdf(edges))
    counts = np.random.default_rng(2026).multinomial(3000, p / p.sum())
    fit = fit_binned_normal(edges, counts)
    for key, true in (("mean_um", mean), ("std_um", std)):
        assert abs(fit.params[key] - true) < 5 * fit.stderr[key], (key, fit.params)


def test_binned_se_match_the_spread_of_refits():
    """The observed-information SE against the empirical spread of 200 refits."""
    edges = _log_edges(3.0, 1.7)
    dist = stats.lognorm(math.log(1.7), scale=3.0)
    p = np.diff(dist.cdf(edges))
    rng = np.random.default_rng(5)
    fits = [fit_binned_lognormal(edges, rng.multinomial(2000, p / p.sum()))
            for _ in range(200)]  # fmt: skip
    med = np.array([f.params["median_um"] for f in fits])
    se = np.mean([f.stderr["median_um"] for f in fits])
    # the sd of 200 values is known to about 1/sqrt(2*199) = 5 %: allow 4 of those
    assert med.std(ddof=1) == pytest.approx(se, rel=0.2)


def test_exact_bin_probabilities_give_the_exact_parameters():
    edges = np.logspace(np.log10(0.5), np.log10(12.0), 30)
    dist = stats.lognorm(math.log(1.69), scale=3.49)
    fit = fit_binned_lognormal(edges, 1e4 * np.diff(dist.cdf(edges)))
    assert_allclose(
        [fit.params["median_um"], fit.params["geometric_std"]], [3.49, 1.69], rtol=1e-5
    )


@pytest.mark.parametrize("values", ["dN/dlogDp", "dN/dlnDp", "dN/dDp", "count"])
def test_number_per_bin_of_densities_matches_bin_integrals(values):
    edges = 2.0 * 10 ** (np.arange(0, 33) / 32)  # narrow log bins
    mid = np.sqrt(edges[:-1] * edges[1:])
    dist = stats.lognorm(math.log(1.5), scale=4.0)
    v = {
        "dN/dlogDp": dist.pdf(mid) * mid * math.log(10),
        "dN/dlnDp": dist.pdf(mid) * mid,
        "dN/dDp": dist.pdf(mid),
        "count": np.diff(dist.cdf(edges)),
    }[values]
    exact = np.diff(dist.cdf(edges))
    got = number_per_bin(edges, v, values)
    # a density sampled at the midpoint times the width: the midpoint rule, whose
    # error is (h^2/24) g''/g, below 2 % for these bins (h = ln(10)/32)
    assert_allclose(got, exact, rtol=0.02)
    assert got.sum() == pytest.approx(exact.sum(), rel=2e-3)


@pytest.mark.parametrize("values", ["dM/dlogDp", "dV/dlogDp", "mass", "dM/dDp"])
def test_mass_weighted_export_gives_the_hatch_choate_count_median(values):
    """A mass distribution log-normal with MMD and GSD is the number distribution
    with CMD = MMD exp(-3 ln^2 GSD) (Hatch-Choate): fit the converted bins."""
    cmd, gsd = 1.2, 1.8
    mmd = hatch_choate_mass_median(cmd, gsd)
    mass = stats.lognorm(math.log(gsd), scale=mmd)
    edges = 0.05 * 10 ** (np.arange(0, 97) / 32)  # 0.05 to 50 um, 32 per decade
    mid = np.sqrt(edges[:-1] * edges[1:])
    v = {
        "dM/dlogDp": mass.pdf(mid) * mid * math.log(10),
        "dV/dlogDp": mass.pdf(mid) * mid * math.log(10),
        "mass": np.diff(mass.cdf(edges)),
        "dM/dDp": mass.pdf(mid),
    }[values]
    fit = fit_binned_lognormal(edges, number_per_bin(edges, v, values))
    assert fit.params["median_um"] == pytest.approx(cmd, rel=0.01)
    assert fit.params["geometric_std"] == pytest.approx(gsd, rel=0.01)
    n = number_per_bin(edges, v, values)
    assert binned_median(edges, n * mid**3) == pytest.approx(mmd, rel=0.02)


def test_binned_median_of_exact_bins():
    edges = np.logspace(-1, 2, 49)
    dist = stats.lognorm(0.6, scale=3.3)
    assert binned_median(edges, np.diff(dist.cdf(edges))) == pytest.approx(
        3.3, rel=2e-3
    )


def test_edges_from_log_midpoints_are_exact_and_irregular_ones_refused():
    edges = 0.523 * 10 ** (np.arange(0, 33) / 32)
    mids = np.sqrt(edges[:-1] * edges[1:])
    assert_allclose(edges_from_midpoints(mids), edges, rtol=1e-12)
    with pytest.raises(ValueError, match="not log-spaced"):
        edges_from_midpoints([1.0, 1.1, 3.0, 3.05])


def test_tail_like_bins_hold_the_fit_at_its_bound_and_say_so():
    edges = np.array([0.38, 0.54, 0.78, 1.05, 1.34, 1.59, 2.07, 3.0, 4.0])
    counts = 1e4 * edges[:-1] ** -3.0  # a power law: no finite maximum
    for fit in (fit_binned_lognormal(edges, counts), fit_binned_normal(edges, counts)):
        assert len(fit.notes) == 1 and "held at its bound" in fit.notes[0]
    exact = fit_binned_lognormal(edges, np.diff(stats.lognorm(0.5, scale=1).cdf(edges)))
    assert exact.notes == ()


def test_chi2_on_bins_counts_dof_after_merging():
    edges = _log_edges(3.0, 1.7)
    dist = stats.lognorm(math.log(1.7), scale=3.0)
    p = np.diff(dist.cdf(edges))
    counts = np.random.default_rng(3).multinomial(500, p / p.sum())
    fit = fit_binned_lognormal(edges, counts)
    res = chi2_binned(edges, counts, fit)
    assert res.expected.min() >= 5 and res.observed.sum() == 500
    assert res.dof == res.expected.size - 3
    assert res.expected.sum() == pytest.approx(500)


def _rejection_rate(n_sets, n, alpha, seed, truth):
    edges = _log_edges(3.0, 1.7)
    p = np.diff(truth.cdf(edges))
    rng = np.random.default_rng(seed)
    rejected = 0
    for _ in range(n_sets):
        counts = rng.multinomial(n, p / p.sum())
        fit = fit_binned_lognormal(edges, counts)
        rejected += chi2_binned(edges, counts, fit, alpha=alpha).reject
    return rejected / n_sets


@pytest.mark.slow
def test_chi2_on_bins_has_nominal_size():
    """Under the null, the rejection rate is alpha within 3 binomial SE."""
    alpha, n_sets = 0.05, 1000
    rate = _rejection_rate(n_sets, 2000, alpha, 11, stats.lognorm(0.53, scale=3.0))
    se = math.sqrt(alpha * (1 - alpha) / n_sets)
    assert abs(rate - alpha) < 3 * se, rate


def test_chi2_on_bins_rejects_a_normal_population_fitted_as_lognormal():
    rate = _rejection_rate(20, 3000, 0.05, 12, stats.norm(3.0, 0.9))
    assert rate > 0.9


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_chi2_of_a_fit_with_no_probability_on_the_bins_rejects_it():
    """A diverged fit that puts no probability on the measured range (found by the
    property test: NaN expected counts and NumPy's 'invalid value' warning): the
    counts contradict it with certainty."""
    from scipy import stats as st_

    edges = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    counts = np.array([10, 20, 30, 20, 10])
    far = st_.norm(loc=1.0, scale=1e-9)  # metres: all of it at 1 m
    r = chi2_binned(edges, counts, far)
    assert r.reject and r.pvalue == 0.0 and r.statistic == math.inf
    assert r.dof == 5 - 1 - 2
    np.testing.assert_array_equal(r.observed, counts)  # the bins as measured
    np.testing.assert_array_equal(r.expected, np.zeros(5))
    np.testing.assert_array_equal(r.edges_um, edges)


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ([1.0, 2.0], "`counts` needs 3 values (one per bin); got 2."),
        ([1.0, -1.0, 2.0], "`counts` must be finite, >= 0 and not all 0."),
        ([1.0, np.nan, 2.0], "`counts` must be finite, >= 0 and not all 0."),
        ([0.0, 0.0, 0.0], "`counts` must be finite, >= 0 and not all 0."),
    ],
)
def test_bad_bin_values_are_refused_saying_what_is_allowed(values, message):
    with pytest.raises(ValueError) as info:
        number_per_bin([1.0, 2.0, 4.0, 8.0], values, "count")
    assert str(info.value) == message


def test_a_log_normal_fit_to_rising_bins_is_clipped_and_says_so():
    # counts that rise to the top of the range have no log-normal maximum: the
    # median runs off to infinity. Shown clipped at the documented limits
    # (median 1e300 um, GSD 1000) with no standard errors, and the note says why
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        fit = fit_binned_lognormal([1.0, 2.0, 4.0, 8.0], [1, 1, 1000])
    assert fit.params["median_um"] == pytest.approx(1e300, rel=1e-9)
    assert fit.params["geometric_std"] == pytest.approx(1000.0, rel=1e-12)
    assert np.isnan(fit.stderr["median_um"]) and np.isnan(fit.stderr["geometric_std"])
    assert fit.notes == (
        "the log-normal fit diverges (GSD beyond 1000 or median beyond 1e300 um; "
        "shown clipped there): the bins have no log-normal shape (they rise to the "
        "top of the range, or are split in separate modes), and its parameters are "
        "not estimates",
    )


def test_binned_inputs_are_refused_by_name():
    edges, counts = [1.0, 2.0, 4.0, 8.0, 16.0, 32.0], [10, 20, 30, 20, 10]
    fit = fit_binned_lognormal(edges, counts)
    for alpha in (0.0, -0.1, 1.0):  # a significance level lies in (0, 1)
        with pytest.raises(ValueError, match="`alpha`"):
            chi2_binned(edges, counts, fit, alpha=alpha)
    with pytest.raises(TypeError, match="`edges_um` must be numeric"):
        fit_binned_lognormal(["a", "b"], [1])


def test_number_per_bin_names_a_value_kind_it_does_not_know():
    with pytest.raises(ValueError, match=r"^`kind` must be one of 'count', 'dN',"):
        number_per_bin([1.0, 2.0, 4.0], [1.0, 2.0], "bogus")
