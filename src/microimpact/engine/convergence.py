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
They are streamed block by block, so memory does not grow with N: one pass keeps the
counts at the table's N and, per block of 32,768 draws, the extremes of the running
fraction; the block holding the last N outside the band is then simulated again to
find that N exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._core.validation import check_int
from ..scenario.grid import SweepGrid
from ..scenario.scenario import as_scenario
from .kernel import simulate_block
from .montecarlo import build_plan, iter_point_samples
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

    table: pandas.DataFrame  # noqa: F821 (pandas loads where a table is made)
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

    scenario = as_scenario(scenario)
    n_max = check_int(n_max, "n_max", minimum=10)
    if not 0 < tolerance < 0.5:
        raise ValueError(f"`tolerance` must be in (0, 0.5); got {tolerance!r}.")
    confidence = scenario.confidence if confidence is None else confidence
    plan = build_plan(scenario, seed=seed)
    if not 0 <= point < len(plan.points):
        raise ValueError(f"`point` must be in [0, {len(plan.points)}); got {point!r}.")
    ns = np.unique(np.geomspace(1, n_max, grid).astype(int))
    run = _stream_running_fraction(plan, point, n_max, ns)
    final = run.final
    n_settled = _settled(plan, point, n_max, run, tolerance)
    lo, hi = wilson_interval(run.captured_at, run.impacts_at, confidence)
    with np.errstate(invalid="ignore", divide="ignore"):
        fraction = run.captured_at / run.impacts_at
    # deferred: pandas (~30 MiB) loads only where a table is made, not with the
    # engine (a run's peak memory: docs/performance.md)
    import pandas as pd

    table = pd.DataFrame(
        {"n": ns, "capture_fraction": fraction, "ci_low": lo, "ci_high": hi}
    )
    z = z_value(confidence)
    p = min(max(final, 1e-12), 1 - 1e-12)
    n_req = _wilson_n(p, tolerance, z)
    return ConvergenceResult(
        table,
        final,
        tolerance,
        confidence,
        n_settled,
        n_req,
        math.ceil(z * z / (4 * tolerance * tolerance)),
        SweepGrid.from_scenario(scenario).coords(point),
    )


@dataclass
class _Running:
    """What one pass over the draws keeps: counts at the table's N, per block the
    extremes of the running fraction and the counts before it."""

    captured_at: np.ndarray
    impacts_at: np.ndarray
    block_min: list
    block_max: list
    before: list  # (captured, impacts) before each block
    final: float


def _block_running(block, captured0, impacts0):
    """Cumulative captured and impacts counts, and the running fraction, over one
    block of per-impact arrays, continuing from the counts before it."""
    hit = ~block["shadowed"]
    captured = np.cumsum(block["captured"] & hit) + captured0
    impacts = np.cumsum(hit) + impacts0
    with np.errstate(invalid="ignore", divide="ignore"):
        running = captured / impacts
    return captured, impacts, running


def _stream_running_fraction(plan, point, n_max, ns) -> _Running:
    """One pass over the first `n_max` draws at `point`, block by block (memory
    flat in `n_max`)."""
    out = _Running(np.zeros(ns.size), np.zeros(ns.size), [], [], [], math.nan)
    captured0 = impacts0 = 0
    start = 0
    for block in iter_point_samples(plan, point, n_max):
        captured, impacts, running = _block_running(block, captured0, impacts0)
        stop = start + running.size
        sel = (ns > start) & (ns <= stop)
        idx = ns[sel] - 1 - start
        out.captured_at[sel] = captured[idx]
        out.impacts_at[sel] = impacts[idx]
        out.before.append((captured0, impacts0))
        finite = running[~np.isnan(running)]
        out.block_min.append(finite.min() if finite.size else math.nan)
        out.block_max.append(finite.max() if finite.size else math.nan)
        captured0, impacts0 = int(captured[-1]), int(impacts[-1])
        out.final = float(running[-1])
        start = stop
    return out


def _settled(plan, point, n_max, run: _Running, tolerance):
    """Smallest N after which the running fraction stays within `tolerance` of the
    final value: the last N outside, plus one (None if outside at the end).

    The block extremes tell which blocks hold an N outside the band exactly
    (``|x - final|`` rounds monotonically in x on either side of `final`); the last
    such block is simulated again to find the N.
    """
    final = run.final
    B = plan.block_size
    for b in range(len(run.before) - 1, -1, -1):
        lo, hi = run.block_min[b], run.block_max[b]
        if not (abs(hi - final) > tolerance or abs(lo - final) > tolerance):
            continue
        m = min(B, n_max - b * B)
        block = simulate_block(plan, point, 0, b, m, store=True)
        _c, _i, running = _block_running(block, *run.before[b])
        outside = np.abs(running - final) > tolerance
        if outside[-1] and b == len(run.before) - 1:
            return None
        return b * B + int(np.flatnonzero(outside)[-1]) + 2
    return 1


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
