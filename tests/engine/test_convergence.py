"""The paper's convergence study against binomial theory."""

import math

import numpy as np
import pytest
from engine_helpers import PowerCoefficients, rough, scenario
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


def _stored_sample_study(sc, n_max, tolerance, grid=200, point=0):
    """The study computed from every draw held in memory (the implementation before
    streaming): the oracle of the streamed one."""
    s = sample_point(sc, point, n_max)
    hit = ~s["shadowed"]
    captured = np.cumsum(s["captured"] & hit)
    impacts = np.cumsum(hit)
    with np.errstate(invalid="ignore", divide="ignore"):
        running = captured / impacts
    final = float(running[-1])
    outside = np.abs(running - final) > tolerance
    bad = np.flatnonzero(outside)
    n_settled = None if outside[-1] else (int(bad[-1]) + 2 if bad.size else 1)
    ns = np.unique(np.geomspace(1, n_max, grid).astype(int))
    lo, hi = wilson_interval(captured[ns - 1], impacts[ns - 1])
    return final, n_settled, ns, running[ns - 1], lo, hi


@pytest.mark.parametrize(
    "kw, n_max, tolerance",
    [
        (dict(speeds_m_s=(0.2,)), 5000, 0.03),
        # several blocks, the last one partial; a tight band settles late
        (dict(speeds_m_s=(0.21,)), 100_001, 0.002),
        # shadowed draws (impacts < n, running fraction NaN at first) on a rough
        # surface, second sweep point
        (
            dict(
                surfaces=(rough(15.0),),
                speeds_m_s=(0.1, 0.3),
                angles_deg=(12.0,),
                shadowing="none",
            ),
            70_000,
            0.01,
        ),
    ],
)
def test_streamed_study_equals_the_stored_sample_study(kw, n_max, tolerance):
    sc = scenario(**kw)
    point = len(kw.get("speeds_m_s", (0,))) - 1
    res = convergence_study(
        sc, point=point, n_max=n_max, tolerance=tolerance, confidence=0.95
    )
    final, n_settled, ns, running, lo, hi = _stored_sample_study(
        sc, n_max, tolerance, point=point
    )
    assert res.final == final
    assert res.n_settled == n_settled
    assert n_settled is not None and n_settled > 1
    np.testing.assert_array_equal(res.table["n"], ns)
    np.testing.assert_array_equal(res.table["capture_fraction"], running)
    np.testing.assert_array_equal(res.table["ci_low"], lo)
    np.testing.assert_array_equal(res.table["ci_high"], hi)


def test_streamed_study_keeps_no_per_draw_arrays(monkeypatch):
    """Memory flat in N: the study never asks for more than one block of draws at
    once (the kernel is called block by block)."""
    from microimpact.engine import convergence, plan

    sizes = []
    real = convergence.simulate_block

    def spy(*args, **kw):
        sizes.append(args[4])
        return real(*args, **kw)

    monkeypatch.setattr(convergence, "simulate_block", spy)
    from microimpact.engine import kernel

    monkeypatch.setattr(kernel, "simulate_block", spy)
    convergence_study(scenario(speeds_m_s=(0.2,)), n_max=200_000, tolerance=0.001)
    assert sizes and max(sizes) <= plan.BLOCK_SIZE
    assert sum(sizes) <= 200_000 + plan.BLOCK_SIZE  # one pass plus one block
