"""The recommendation shared by describe_sizes and describe_binned_sizes
(population/_compare.py), against the rule of docs/populations.md written out case
by case: of the fits the test does not reject the lower AIC (the normal on a tie),
else the measured distribution; without a test the lower AIC."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from microimpact.population._compare import recommend


def _test(reject):
    return SimpleNamespace(reject=reject, pvalue=0.01 if reject else 0.5)


@pytest.mark.parametrize(
    ("aics", "rejects", "wants"),
    [
        ((10.0, 5.0), (False, False), ("lognormal", "lognormal")),
        ((5.0, 10.0), (False, False), ("normal", "normal")),
        ((7.0, 7.0), (False, False), ("normal", "normal")),  # a tie: the normal
        ((10.0, 5.0), (False, True), ("lognormal", "normal")),  # the better rejected
        ((5.0, 10.0), (True, False), ("normal", "lognormal")),
        ((10.0, 5.0), (True, True), ("lognormal", "measured")),
        ((5.0, 10.0), (True, True), ("normal", "measured")),
    ],
)
def test_the_better_fit_the_test_keeps_else_the_measured(aics, rejects, wants):
    chi_n, chi_ln = (_test(r) for r in rejects)
    delta, better, recommended = recommend(*aics, chi_n, chi_ln, "measured")
    assert delta == aics[0] - aics[1]
    assert (better, recommended) == wants


@pytest.mark.parametrize(("aics", "wants"), [((10.0, 5.0), "lognormal"),
                                             ((5.0, 10.0), "normal")])  # fmt: skip
def test_without_a_test_the_better_fit_is_recommended(aics, wants):
    assert recommend(*aics, None, None, "measured")[1:] == (wants, wants)


def test_a_chi2_summary_line_says_the_outcome():
    import types

    from microimpact.population._compare import chi2_line

    c = types.SimpleNamespace(statistic=3.14159, dof=4, pvalue=0.53219, reject=False)
    assert chi2_line(c) == "chi2 3.142, dof 4, p = 0.5322: not rejected"
    c.reject, c.pvalue = True, 0.0012345
    assert chi2_line(c) == "chi2 3.142, dof 4, p = 0.001234: rejected"
