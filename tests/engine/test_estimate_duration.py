"""Issue 22 (item 4): the announced duration comes from a measured rate.

Before, the per-point cost was one cold single-point kernel call (its tables
built, its call overhead unshared) times every point: a 10^6-point sweep at 100
impacts was announced at 35 min and simulated in 1.5. Now a calibration batch of
points spread over the sweep is timed as the run's tasks run them, and a (surface,
angle) pair's tables are charged once per pair."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from engine_helpers import rough, scenario

from microimpact.engine import montecarlo
from microimpact.engine.montecarlo import estimate_duration, run
from microimpact.engine.plan import BLOCK_SIZE


def test_tables_are_charged_once_per_surface_and_angle(monkeypatch):
    """A fake clock: a kernel call costs `call`, a block `c + r n`, and the tables
    of a (surface, angle) pair not seen before `u`: the estimate is the run's
    cost, but for the calibration call's overhead shared by its points."""
    call, c, r, u = 5e-5, 5e-4, 2e-8, 4e-3
    clock = [0.0]
    seen = set()

    def fake(plan, specs):
        clock[0] += call  # once per call: shared by a batch's blocks
        for point, _rep, _b, n in specs:
            p = plan.points[point]
            clock[0] += c + r * n
            if (p.surface, p.angle_deg) not in seen:
                clock[0] += u
                seen.add((p.surface, p.angle_deg))
        return [None] * len(specs)

    monkeypatch.setattr(montecarlo, "_simulate", fake)
    monkeypatch.setattr(montecarlo, "_calibration_batch", fake)
    monkeypatch.setattr(montecarlo.time, "perf_counter", lambda: clock[0])
    sc = scenario(
        surfaces=(rough(8.0), rough(12.0, name="rougher")),
        speeds_m_s=tuple(np.geomspace(0.1, 3.0, 40)),
        angles_deg=tuple(np.linspace(10, 90, 30)),
        samples=100,
    )
    points, pairs = 2 * 40 * 30, 2 * 30
    exact = points * (c + r * 100) + pairs * u
    est = estimate_duration(sc)
    # the batch's call overhead is spread over its 256 points: within 5 %
    assert est == pytest.approx(exact, rel=0.05)
    seen.clear()
    more = estimate_duration(sc, samples=3 * BLOCK_SIZE + 5)
    blocks = math.ceil((3 * BLOCK_SIZE + 5) / BLOCK_SIZE)
    want = points * (blocks * c + r * (3 * BLOCK_SIZE + 5)) + pairs * u
    assert more == pytest.approx(want, rel=0.05)


def test_the_estimate_of_a_grid_of_small_points_is_its_run_time():
    """Measured: a 2 x 60 x 50 grid at 100 impacts per point (6,000 points), the
    estimate within a factor 3 of the run (the estimate before was ~150x over)."""
    sc = scenario(
        surfaces=(rough(8.0), rough(12.0, name="rougher")),
        speeds_m_s=tuple(np.geomspace(0.1, 3.0, 60)),
        angles_deg=tuple(np.linspace(10, 90, 50)),
        samples=100,
    )
    run(sc, samples=10, progress=False)  # one-time costs (imports) first
    est = estimate_duration(sc)
    t = time.perf_counter()
    run(sc, progress=False)
    actual = time.perf_counter() - t
    assert actual / 3 < est < actual * 3, (est, actual)
