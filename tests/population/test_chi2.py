"""Tests for the paper's chi-squared normality test (microimpact.population)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import special, stats

from microimpact.population.distributions import MIN_EXPECTED, chi2_normality

# A tiny fixed dataset [µm] for the hand computation (32 values -> Sturges k = 6).
TINY_UM = [
    50.0, 53.6, 46.7, 39.3, 44.5, 38.1, 50.7, 66.1, 44.1, 42.6, 55.9,
    54.3, 51.3, 38.8, 49.6, 58.3, 33.9, 44.5, 27.2, 34.5, 27.9, 47.2,
    34.8, 53.3, 51.9, 47.8, 19.8, 43.5, 49.4, 51.4, 31.6, 44.3,
]  # fmt: skip


def test_hand_computation_tiny_dataset():
    """Statistic from a pure-Python computation (math.erf), classes merged by hand."""
    x = TINY_UM
    n = len(x)
    mean = sum(x) / n
    std = math.sqrt(sum((v - mean) ** 2 for v in x) / n)  # MLE, ddof = 0
    k = 6  # 1 + log2(32) = 6 exactly
    width = (max(x) - min(x)) / k
    inner = [min(x) + i * width for i in range(1, k)]
    bounds = [-math.inf, *inner, math.inf]

    def phi(z):
        return 0.5 * (1 + math.erf(z / math.sqrt(2)))

    exp6 = [
        n * (phi((bounds[i + 1] - mean) / std) - phi((bounds[i] - mean) / std))
        for i in range(k)
    ]
    obs6 = [sum(bounds[i] <= v < bounds[i + 1] for v in x) for i in range(k)]
    # by hand: class 0 is below 5 and joins class 1; class 5 is below 5 and joins 4
    assert exp6[0] < 5 <= exp6[0] + exp6[1]
    assert exp6[5] < 5 <= exp6[4] + exp6[5]
    assert min(exp6[2], exp6[3]) >= 5
    groups = [(0, 1), (2,), (3,), (4, 5)]
    expected = [sum(exp6[i] for i in g) for g in groups]
    observed = [sum(obs6[i] for i in g) for g in groups]
    statistic = sum((o - e) ** 2 / e for o, e in zip(observed, expected, strict=True))

    res = chi2_normality(x)
    assert res.n_classes_initial == k
    assert res.dof == 4 - 1 - 2
    assert_allclose(res.observed, observed, rtol=0, atol=0)
    assert_allclose(res.expected, expected, rtol=1e-12)
    assert_allclose(res.statistic, statistic, rtol=1e-12)
    assert_allclose(res.mean_um, mean, rtol=1e-14)
    assert_allclose(res.std_um, std, rtol=1e-14)
    assert_allclose(res.edges_um[1:-1], [inner[1], inner[2], inner[3]], rtol=1e-14)


def test_gaussian_sample_passes(rng):
    res = chi2_normality(rng.normal(52.8, 15.3, 2000))  # SST65-like [1]
    assert not res.reject
    assert res.decision == "gaussian"
    assert res.pvalue > 0.05


def test_rejection_rate_under_null_is_plausible():
    """Over 200 Gaussian samples the rejection rate is near alpha = 0.05.

    With raw-data MLE the test is slightly liberal (Chernoff-Lehmann), so the upper
    bound allows for that: 0.05 + 4 SE, SE = sqrt(0.05 * 0.95 / 200) = 0.0154.
    """
    stats_, dofs, rejects = [], [], []
    for seed in range(200):
        res = chi2_normality(np.random.default_rng(seed).normal(50, 10, 400))
        stats_.append(res.statistic)
        dofs.append(res.dof)
        rejects.append(res.reject)
    rate = np.mean(rejects)
    assert 0.005 <= rate <= 0.05 + 4 * 0.0154
    # E[statistic] lies between dof and dof + 2 (chi2(k-3) .. chi2(k-1))
    se = np.std(stats_) / np.sqrt(len(stats_))
    assert np.mean(dofs) - 3 * se <= np.mean(stats_) <= np.mean(dofs) + 2 + 3 * se


def test_bimodal_sample_fails(rng):
    x = np.concatenate([rng.normal(30, 3, 600), rng.normal(60, 4, 400)])
    res = chi2_normality(x)
    assert res.reject
    assert res.decision == "empirical"
    assert res.pvalue < 1e-6


def test_pvalue_is_chi2_sf(rng):
    for x in (rng.normal(50, 10, 300), rng.lognormal(3.5, 0.5, 300)):
        res = chi2_normality(x)
        # independent of scipy.stats.chi2: the regularised upper incomplete gamma
        assert_allclose(
            res.pvalue, special.gammaincc(res.dof / 2, res.statistic / 2), rtol=1e-10
        )
        assert_allclose(res.pvalue, stats.chi2.sf(res.statistic, res.dof), rtol=1e-12)
        assert res.reject == (res.pvalue < res.alpha)


@pytest.mark.parametrize("classes", ["equal-width", "equiprobable"])
@pytest.mark.parametrize("n", [40, 123, 1000, 5000])
def test_invariants(rng, n, classes):
    x = rng.normal(50, 10, n)
    res = chi2_normality(x, classes=classes)
    assert np.all(res.expected >= MIN_EXPECTED)
    assert res.observed.sum() == n
    assert_allclose(res.expected.sum(), n, rtol=1e-12)
    assert res.dof == res.expected.size - 3
    assert res.edges_um.size == res.expected.size + 1
    assert res.edges_um[0] == -np.inf and res.edges_um[-1] == np.inf
    assert np.all(np.diff(res.edges_um) > 0)
    assert res.n_classes_initial == math.ceil(1 + math.log2(n))
    # observed counts agree with an independent binning on the reported edges
    e = res.edges_um
    counts = [np.sum((x >= lo) & (x < hi)) for lo, hi in itertools.pairwise(e)]
    assert_allclose(res.observed, counts, rtol=0, atol=0)


def test_equiprobable_classes_have_equal_expected_counts(rng):
    n = 1024  # k = 11, n / k = 93 > 5: nothing is merged
    res = chi2_normality(rng.normal(50, 10, n), classes="equiprobable")
    assert res.expected.size == 11
    assert_allclose(res.expected, n / 11, rtol=1e-9)


def test_paper_decision_for_sst65_like_gaussian(rng):
    """SST65 is represented by N(52.8, 15.3) µm [1]: the test keeps the Gaussian."""
    x = rng.normal(52.8, 15.3, 1500)
    x = x[x > 0]
    res = chi2_normality(x)
    assert res.decision == "gaussian"
    assert_allclose(res.mean_um, 52.8, atol=4 * 15.3 / math.sqrt(x.size))


def test_errors():
    with pytest.raises(ValueError, match="too few diameters") as info:
        chi2_normality([10.0, 11.0, 12.0, 13.0, 14.0, 15.0])
    # the count given and the documented remedy (docs/populations.md)
    assert str(info.value).startswith("too few diameters for the chi-squared test: n=6")
    assert str(info.value).endswith("need at least 4 (about 30 or more diameters).")
    with pytest.raises(ValueError, match="`alpha`"):
        chi2_normality(TINY_UM, alpha=1.5)
    with pytest.raises(ValueError, match="`classes`"):
        chi2_normality(TINY_UM, classes="quantile")
    with pytest.raises(ValueError, match="all equal"):
        chi2_normality([5.0] * 40)
    with pytest.raises(ValueError, match="diameters > 0"):
        chi2_normality([*TINY_UM, -1.0])


def test_classes_merge_tails_inward_then_the_smallest_class():
    """Hand-worked: expected [10, 3, 10, 1, 1, 1] (MIN_EXPECTED 5). The tail
    merges inward until the last class holds 5 or more: [10, 3, 10, 3], then
    [10, 3, 13]; then the interior 3 joins its smaller neighbour (10, on its
    left): [13, 13]."""
    from microimpact.population.distributions import _merge

    edges = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    observed = [9, 4, 11, 2, 0, 1]
    expected = [10.0, 3.0, 10.0, 1.0, 1.0, 1.0]
    e, o, x = _merge(edges, observed, expected)
    np.testing.assert_array_equal(e, [0.0, 2.0, 6.0])
    np.testing.assert_array_equal(x, [13.0, 13.0])
    np.testing.assert_array_equal(o, [13, 14])
    # the head merges first, outward-in: [1, 1, 8, 10] -> [2, 8, 10] -> [10, 10]
    e, o, x = _merge([0, 1, 2, 3, 4], [1, 2, 7, 9], [1.0, 1.0, 8.0, 10.0])
    np.testing.assert_array_equal(e, [0, 3, 4])
    np.testing.assert_array_equal(x, [10.0, 10.0])
    np.testing.assert_array_equal(o, [10, 9])
    # two classes, the first too small: one class is left
    e, o, x = _merge([0, 1, 2], [1, 8], [1.0, 9.0])
    np.testing.assert_array_equal(e, [0, 2])
    np.testing.assert_array_equal(x, [10.0])


@pytest.mark.parametrize("alpha", [-0.1, 0.0, 1.0, float("nan")])
def test_a_significance_level_outside_0_1_is_refused(alpha):
    x = np.random.default_rng(1).normal(50.0, 5.0, 200)
    with pytest.raises(ValueError, match="`alpha`"):
        chi2_normality(x, alpha=alpha)
