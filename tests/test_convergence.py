"""The paper's convergence study against binomial theory."""

import math

import numpy as np
import pytest
from engine_helpers import PowerCoefficients, scenario
from numpy.testing import assert_allclose
from scipy import stats

from microimpact import convergence_study, sample_point
from microimpact.engine.statistics import wilson_interval


def test_running_fraction_is_the_cumulative_mean_of_the_run_draws():
    sc = scenario(speeds_m_s=(0.2,))
    res = convergence_study(sc, n_max=5000, tolerance=0.03)
    flags = sample_point(sc, 0, 5000)["captured"]
    running = np.cumsum(flags) / np.arange(1, 5001)
    assert_allclose(res.table["capture_fraction"], running[res.table["n"] - 1])
    assert_allclose(res.final, flags.mean())
    # settled: inside the band from n_settled on, outside just before
    inside = np.abs(running - res.final) <= 0.03
    assert inside[res.n_settled - 1 :].all()
    assert res.n_settled == 1 or not inside[res.n_settled - 2]


def test_required_n_matches_the_wilson_half_width():
    sc = scenario(speeds_m_s=(0.2,), coefficients=PowerCoefficients(vc_ref=0.2))
    res = convergence_study(sc, n_max=3000, tolerance=0.03)
    z = stats.norm.ppf(0.975)
    assert res.n_required_worst_case == math.ceil(z * z / (4 * 0.03**2))
    lo, hi = wilson_interval(res.final * res.n_required, res.n_required)
    assert (hi - lo) / 2 <= 0.03 + 1e-12
    lo, hi = wilson_interval(res.final * (res.n_required - 1), res.n_required - 1)
    assert (hi - lo) / 2 > 0.03


def test_band_covers_the_closed_form():
    """The Wilson band at the end contains F_D(v_c^-1(v)) (normal incidence)."""
    coeffs = PowerCoefficients(vc_ref=0.2, b=-1.0)
    sc = scenario(coefficients=coeffs, speeds_m_s=(0.22,))
    res = convergence_study(sc, n_max=20_000)
    d_star = coeffs.d_ref * (0.22 / 0.2) ** (1 / coeffs.b)
    mean, std = 52.8e-6, 15.3e-6
    exact = stats.truncnorm(-mean / std, np.inf, loc=mean, scale=std).cdf(d_star)
    last = res.table.iloc[-1]
    assert last["ci_low"] <= exact <= last["ci_high"]


def test_bad_arguments():
    with pytest.raises(ValueError, match="`tolerance`"):
        convergence_study(scenario(), tolerance=0.7)
    with pytest.raises(ValueError, match="`n_max`"):
        convergence_study(scenario(), n_max=3)
