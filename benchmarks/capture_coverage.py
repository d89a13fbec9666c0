"""Coverage, width and time of the capture-speed estimators (docs/capture-speed.md).

Binomial counts are drawn from two closed forms of normal incidence on a smooth
surface, where a particle is captured iff v <= v_c(d) = A (d / D_REF)^B:

* ``lognormal``: log-normal diameters (median 40 um, g = 1.6): a probit in ln v;
* ``normal``: the issue-22 case, normal diameters 52.8 +- 15.3 um truncated at 0:
  not a probit in ln v.

Each seed shifts a sweep of ``k`` log-spaced speeds over a factor ``span`` by a
random fraction of its step. Per row and estimator (``auto``, ``probit``): coverage
of the true v_q and of v_grid (the probit-scale interpolation of the true node
probabilities, the estimand of the isotonic estimate), mean width, the methods
chosen, the fraction of ``grid-limited`` notes (and of those, the fraction caused by
a bracketing speed with no or full capture), the coverage of the unflagged curves
and the time per curve.

Usage::

    python benchmarks/capture_coverage.py [--seeds 2000]
"""

from __future__ import annotations

import argparse
import math
import time
from collections import Counter

import numpy as np
from scipy import special, stats

from microimpact.engine.capture import estimate_capture_speed

A, B, D_REF = 0.5, -1.58, 52.8e-6
DISTS = {
    "normal": stats.truncnorm(-52.8 / 15.3, np.inf, loc=52.8e-6, scale=15.3e-6),
    "lognormal": stats.lognorm(math.log(1.6), scale=40e-6),
}
#: (population, k speeds, span, impacts per speed, q)
ROWS = (
    ("normal", 15, 3.0, 4_000, 0.5),
    ("normal", 15, 3.0, 40_000, 0.5),
    ("normal", 15, 3.0, 400_000, 0.5),
    ("normal", 15, 3.0, 4_000, 0.1),
    ("normal", 6, 3.0, 4_000, 0.5),
    ("normal", 6, 3.0, 40_000, 0.5),
    ("lognormal", 30, 10.0, 4_000, 0.5),
    ("lognormal", 5, 10.0, 4_000, 0.5),
    ("lognormal", 5, 10.0, 4_000, 0.1),
    ("lognormal", 5, 10.0, 4_000, 0.8),
)


def capture(v, dist):
    return dist.cdf(D_REF * (np.asarray(v, dtype=float) / A) ** (1.0 / B))


def v_q(q, dist):
    return A * (dist.ppf(q) / D_REF) ** B


def v_grid(v, q, dist):
    z, z_q, x = special.ndtri(capture(v, dist)), special.ndtri(q), np.log(v)
    k = np.flatnonzero((z[:-1] - z_q) * (z[1:] - z_q) <= 0)[0]
    return math.exp(x[k] + (x[k + 1] - x[k]) * (z_q - z[k]) / (z[k + 1] - z[k]))


def row(pop, k, span, n, q, estimator, seeds):
    dist = DISTS[pop]
    rng = np.random.default_rng(99)
    half = math.log(span) / 2
    step = 2 * half / (k - 1)
    truth = v_q(q, dist)
    hit, hit_grid, widths, unflagged, methods = [], [], [], [], Counter()
    flagged = extreme = 0
    elapsed = 0.0
    for _ in range(seeds):
        v = truth * np.exp(np.linspace(-half, half, k) + rng.uniform(-0.5, 0.5) * step)
        y = rng.binomial(np.full(k, n), capture(v, dist))
        t0 = time.perf_counter()
        r = estimate_capture_speed(v, y, np.full(k, n), q, estimator=estimator)
        elapsed += time.perf_counter() - t0
        hit.append(r.ci_low <= truth <= r.ci_high)
        hit_grid.append(r.ci_low <= v_grid(v, q, dist) <= r.ci_high)
        widths.append(r.ci_high - r.ci_low)
        methods[r.method] += 1
        if "grid-limited" in r.note:
            flagged += 1
            extreme += "no or full capture" in r.note
        else:
            unflagged.append(hit[-1])
    return {
        "coverage_v_q": np.mean(hit),
        "coverage_v_grid": np.mean(hit_grid),
        "mean_width": np.nanmean(widths),
        "open": np.mean(np.isnan(widths)),
        "grid_limited": flagged / seeds,
        "of_which_extreme": extreme / flagged if flagged else math.nan,
        "coverage_unflagged": np.mean(unflagged) if unflagged else math.nan,
        "methods": dict(methods),
        "ms_per_curve": 1e3 * elapsed / seeds,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=2000)
    args = ap.parse_args(argv)
    for pop, k, span, n, q in ROWS:
        for est in ("auto", "probit"):
            out = row(pop, k, span, n, q, est, args.seeds)
            text = " ".join(
                f"{key}={val:.4g}" if isinstance(val, float) else f"{key}={val}"
                for key, val in out.items()
            )
            print(f"{pop} k={k} span={span:g} n={n} q={q:g} {est}: {text}", flush=True)


if __name__ == "__main__":
    main()
