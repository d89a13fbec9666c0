"""The paper's convergence study: the running capture percentage against N.

Li, Dunn & Brach (2000) chose their sample size by watching the capture percentage
as the number of simulated impacts grew: "beyond 4,000 simulations [it] was constant
to within +-3 %". :func:`convergence_study` computes that curve for one sweep point,
with its Wilson confidence band at every N, and two answers to "how many samples?":

* ``n_settled``: the smallest N after which the running estimate never leaves
  ``final +- tolerance`` (the paper's empirical criterion, on this run);
* ``n_required``: the N whose 95 % Wilson half-width is at most `tolerance` for the
  estimated capture fraction (a property of the binomial, not of one run), and the
  worst case over all fractions, ``z^2 / (4 tolerance^2)``.

The draws are exactly those of :func:`microimpact.run` for the same seed and point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .._validation import check_int
from .montecarlo import sample_point
from .statistics import wilson_interval, z_value


@dataclass(frozen=True)
class ConvergenceResult:
    """Outcome of :func:`convergence_study`.

    Attributes
    ----------
    table : pandas.DataFrame
        ``n``, ``capture_fraction``, ``ci_low``, ``ci_high`` on a log-spaced grid.
    final : float
        Capture fraction after all samples.
    tolerance : float
        The band half-width asked for (a fraction, 0.03 = 3 percentage points).
    n_settled : int or None
        Smallest N after which the running estimate stays within the band around
        `final` (None if it never settles before the end).
    n_required : int
        N at which the Wilson half-width at `final` falls to `tolerance`.
    n_required_worst_case : int
        The same for the least favourable fraction, 1/2.
    """

    table: pd.DataFrame
    final: float
    tolerance: float
    confidence: float
    n_settled: int | None
    n_required: int
    n_required_worst_case: int
    point: dict


def convergence_study(
    scenario,
    *,
    point=0,
    n_max=20_000,
    tolerance=0.03,
    confidence=None,
    seed=None,
    grid=200,
) -> ConvergenceResult:
    """Running capture fraction at sweep point `point` for N = 1 ... `n_max`.

    Parameters
    ----------
    scenario : Scenario
    point : int
        Index of the sweep point (surfaces x speeds x angles, in that order).
    n_max : int
        Largest N.
    tolerance : float
        Half-width of the band, as a fraction (the paper: 0.03).
    confidence : float, optional
        Default: the scenario's.
    seed : int, optional
        Overrides the scenario's seed.
    grid : int
        Number of log-spaced N values in the returned table.
    """
    n_max = check_int(n_max, "n_max", minimum=10)
    if not 0 < tolerance < 0.5:
        raise ValueError(f"`tolerance` must be in (0, 0.5); got {tolerance!r}.")
    confidence = scenario.confidence if confidence is None else confidence
    s = sample_point(scenario, point, n_max, seed=seed)
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
    lo, hi = wilson_interval(captured[ns - 1], impacts[ns - 1], confidence)
    table = pd.DataFrame(
        {"n": ns, "capture_fraction": running[ns - 1], "ci_low": lo, "ci_high": hi}
    )
    z = z_value(confidence)
    p = min(max(final, 1e-12), 1 - 1e-12)
    n_req = _wilson_n(p, tolerance, z)
    sp = _point_info(scenario, point)
    return ConvergenceResult(
        table,
        final,
        tolerance,
        confidence,
        n_settled,
        n_req,
        math.ceil(z * z / (4 * tolerance * tolerance)),
        sp,
    )


def _wilson_n(p, tol, z):
    """Smallest n whose Wilson half-width at proportion p is <= tol."""
    lo, hi = 1, 1
    while _half(p, hi, z) > tol:
        hi *= 2
    while lo < hi:
        mid = (lo + hi) // 2
        if _half(p, mid, z) <= tol:
            hi = mid
        else:
            lo = mid + 1
    return lo


def _half(p, n, z):
    low, high = wilson_interval(p * n, n, 1 - 2 * (1 - _phi(z)))
    return (float(high) - float(low)) / 2


def _phi(z):
    return 0.5 * (1 + math.erf(z / math.sqrt(2)))


def _point_info(scenario, point):
    import itertools

    combos = list(
        itertools.product(
            [s.name for s in scenario.surfaces],
            scenario.speeds_m_s,
            scenario.angles_deg,
        )
    )
    surface, speed, angle = combos[point]
    return {"surface": surface, "speed_m_s": speed, "angle_deg": angle}
