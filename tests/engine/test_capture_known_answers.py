"""Deterministic known answers for the capture-speed interval's critical value and
ends (issue 34, item 3), beside the coverage tests.

The coverage tests over hundreds of seeds caught a one-sided quantile in the
interval only by a margin of 0.040 against a tolerance of 0.038. Here the critical
values are literals from statistical tables, not computed by the same SciPy call
as the code: two-sided z_{0.975}^2 = 1.959963985^2 = chi2_1(0.95), z_{0.95}^2 for
90 %, z_{0.995}^2 for 99 %, and t_{10, 0.975}^2 = F_{1,10}(0.95) for a QMC standard
error with 10 degrees of freedom. A one-sided quantile (z_{0.95}^2 = 2.7055 at
95 %) moves each end of the two-speed case below by 0.15 %, against a tolerance of
1e-9.

Two speeds make the ends closed forms: the isotonic interval's limits solve the
Fieller quadratic [d0 + l (d1 - d0)]^2 = c [(1 - l)^2 s0 + l^2 s1] on the probit
scale (docs/capture-speed.md). The probit interval's ends are found here by brute
force on the binomial profile likelihood (SciPy's binomial log-pmf and a bounded
scalar minimiser), at the literal critical value.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import optimize, special, stats

from microimpact.engine.capture import estimate_capture_speed

#: Two-sided critical values of the squared statistic, from tables.
CRIT = {
    0.90: 1.6448536269514722**2,  # z_{0.95}
    0.95: 1.959963984540054**2,  # z_{0.975}
    0.99: 2.5758293035489004**2,  # z_{0.995}
}
F_1_10_95 = 2.2281388519649385**2  # t_{10, 0.975}^2


def _fieller_ends(v, y, n, crit):
    """The isotonic interval of two speeds in closed form [m/s]."""
    p = y / n
    d = special.ndtri(p) - special.ndtri(0.5)
    s = p * (1 - p) / (n * stats.norm.pdf(special.ndtri(p)) ** 2)
    a = (d[1] - d[0]) ** 2 - crit * (s[0] + s[1])
    b = 2 * d[0] * (d[1] - d[0]) + 2 * crit * s[0]
    c = d[0] ** 2 - crit * s[0]
    roots = np.sort((-b + np.array([-1, 1]) * math.sqrt(b * b - 4 * a * c)) / (2 * a))
    assert np.all((roots > 0) & (roots < 1))
    x = np.log(v)
    estimate = math.exp(x[0] + d[0] / (d[0] - d[1]) * (x[1] - x[0]))
    return estimate, np.exp(x[0] + roots * (x[1] - x[0]))


V = np.array([0.4, 0.6])
N = np.array([10_000.0, 30_000.0])
Y = np.array([6_300.0, 11_400.0])


@pytest.mark.parametrize("confidence", [0.90, 0.95, 0.99])
def test_isotonic_ends_at_the_tabulated_critical_value(confidence):
    r = estimate_capture_speed(V, Y, N, confidence=confidence, estimator="monotone")
    estimate, ends = _fieller_ends(V, Y, N, CRIT[confidence])
    assert_allclose(r.speed_m_s, estimate, rtol=1e-12)
    assert_allclose([r.ci_low, r.ci_high], ends, rtol=1e-9)


def test_the_one_sided_value_would_be_visibly_narrower():
    # the size of the mutant's error at 95 %: each end moves by about 0.15 %,
    # 10^5 times the tolerance of the tests above
    _, right = _fieller_ends(V, Y, N, CRIT[0.95])
    _, one_sided = _fieller_ends(V, Y, N, CRIT[0.90])
    assert np.all(np.abs(one_sided / right - 1) > 1e-3)


def test_an_estimated_standard_error_uses_f_1_nu():
    """QMC: capture_se with 10 degrees of freedom; the effective counts are
    n = p (1 - p) / SE^2, y = p n, and the critical value F_{1,10}(0.95)."""
    p = Y / N
    se = np.sqrt(p * (1 - p) / N) / 3.0  # QMC: three times tighter than binomial
    r = estimate_capture_speed(
        V, Y, N, capture_se=se, capture_se_df=10, estimator="monotone"
    )
    n_eff = p * (1 - p) / se**2
    estimate, ends = _fieller_ends(V, p * n_eff, n_eff, F_1_10_95)
    assert_allclose(r.speed_m_s, estimate, rtol=1e-12)
    assert_allclose([r.ci_low, r.ci_high], ends, rtol=1e-9)


def test_probit_profile_ends_at_the_tabulated_critical_value():
    """Four speeds that fit a probit: the ends are where twice the drop of the
    binomial profile log-likelihood (slope maximised, SciPy) reaches z_{0.95}^2
    (90 %)."""
    v = np.array([0.35, 0.5, 0.7, 1.0])
    y = np.array([3400, 2500, 1500, 700])
    n = np.full(4, 4000)
    q, x, z_q = 0.5, np.log(v), special.ndtri(0.5)

    def profile(theta):
        def neg_ll(beta):
            p = np.clip(special.ndtr(z_q + beta * (x - theta)), 1e-300, 1 - 1e-16)
            return -stats.binom.logpmf(y, n, p).sum()

        res = optimize.minimize_scalar(
            neg_ll, bounds=(-20, 0), method="bounded", options={"xatol": 1e-12}
        )
        return -res.fun

    best = optimize.minimize_scalar(
        lambda t: -profile(t),
        bounds=(math.log(0.5), math.log(0.8)),
        method="bounded",
        options={"xatol": 1e-10},
    )
    theta, ll_max = best.x, -best.fun

    def excess(t):
        return 2 * (ll_max - profile(t)) - CRIT[0.90]

    lo = optimize.brentq(excess, math.log(0.4), theta, xtol=1e-10)
    hi = optimize.brentq(excess, theta, math.log(0.9), xtol=1e-10)
    r = estimate_capture_speed(v, y, n, q, confidence=0.90, estimator="probit")
    assert r.method == "probit-profile"
    assert_allclose(math.log(r.speed_m_s), theta, atol=2e-6)
    assert_allclose(np.log([r.ci_low, r.ci_high]), [lo, hi], atol=2e-6)


def test_the_curvature_error_is_the_larger_of_the_two_neighbours_readings():
    """_curvature_error on a probit curve with a quadratic on one side of the
    cell and a cubic kink on the other: each neighbouring triple's Newton term
    written out by hand, and the larger one returned (the docstring's rule), not
    the last one computed."""
    import math

    import numpy as np

    from microimpact.engine.capture_monotone import _curvature_error

    xf = np.array([0.0, 1.0, 2.0, 3.0])
    z = np.array([0.0, 1.0, 1.5, 3.5])  # f[0,1]=1, f[1,2]=0.5, f[2,3]=2
    k, theta = 1, 1.5
    slope = 0.5
    left = abs((0.5 - 1.0) / 2.0 * (theta - 1.0) * (theta - 2.0) / slope)  # 0.125
    right = abs((2.0 - 0.5) / 2.0 * (theta - 1.0) * (theta - 2.0) / slope)  # 0.375
    assert _curvature_error(xf, z, k, theta) == pytest.approx(max(left, right))
    # the larger reading first (the triple on the left): still the larger one
    z2 = np.array([0.0, 3.0, 3.5, 4.0])  # f[0,1]=3, f[1,2]=0.5, f[2,3]=0.5
    left2 = abs((0.5 - 3.0) / 2.0 * (theta - 1.0) * (theta - 2.0) / slope)  # 0.625
    assert _curvature_error(xf, z2, k, theta) == pytest.approx(left2)
    # no neighbour on either side: NaN
    assert math.isnan(_curvature_error(xf[:2], z[:2], 0, 0.5))
