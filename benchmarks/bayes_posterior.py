"""Bayesian calibration: wall time of a posterior to convergence (docs/calibration.md).

    python benchmarks/bayes_posterior.py two   # roughness spread + v_c coefficient
    python benchmarks/bayes_posterior.py one   # the issue's case: 1 parameter, 7
                                               # points x 4,000 impacts
    python benchmarks/bayes_posterior.py two --smoke   # a few steps, end to end
    python benchmarks/bayes_posterior.py coverage --reps 50 --out cov.jsonl
                                               # the coverage study, resumable

``coverage`` is the slow test's study (tests/analysis/test_bayes.py): replication
``r`` draws its data with seed 1000 + r, runs the model with seed 5000 + r and the
sampler with seed r, and appends one JSON line to ``--out`` as soon as it is done,
so an interrupted study resumes where it stopped (replications already in the file
are skipped). At the end it prints the hits of the 90 % credible intervals per
parameter with a 95 % Wilson interval on the coverage.

Measurements are synthetic: the engine at a known truth with another seed. ``two``
fits the spread of a normal-rough surface (truth 12 deg) and the v_c law's
coefficient (truth 0.2 m/s) to e and mu at 30 and 60 deg (1 m/s, 300 measured
impacts each) and capture counts at 0.235 m/s (300 particles each), with 3,000
simulated impacts per point (the Monte Carlo variance ratio 0.1 of
docs/calibration.md). ``one`` fits the spread alone to e at 7 angles (15-85 deg,
4,000 measured rebounds each) with 4,000 simulated impacts per point. Each prints
one JSON line: wall seconds, steps, walkers, model runs, seconds per run, R-hat,
ESS, autocorrelation times, convergence, the estimates and the truth.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

import microimpact as mi
from microimpact.analysis.calibration import calibrate
from microimpact.analysis.compare import experiments_from_summary
from microimpact.engine.statistics import wilson_interval
from microimpact.scenario.parameters import with_values
from microimpact.scenario.scenario import scenario_from_dict

STD = "surfaces.rough.std_deg"
VC = "coefficients.v_c.a_m_s"


def scenario(angles, speeds, samples):
    return {
        "name": "bench",
        "seed": 1,
        "samples": samples,
        "particles": {"distribution": "monodisperse", "diameter_um": 50.0},
        "coefficients": {
            "k1": 4.0,
            "k2": {"law": "power", "a_m_s": 0.05, "b": -1.58, "d_ref_um": 52.8},
            "v_c": {"law": "power", "a_m_s": 0.2, "b": -1.58, "d_ref_um": 52.8},
            "p": 1.0,
            "q": 1.0,
            "friction": 0.15,
        },
        "surfaces": [{"name": "rough", "kind": "normal", "std_deg": 10.0}],
        "sweep": {"speed_m_s": list(speeds), "angle_deg": list(angles)},
    }


def _summary(data, truth, samples, seed):
    sc = scenario_from_dict(with_values(data, truth))
    return mi.run(sc, samples=samples, seed=seed, progress=False).summary


def _means(s, stats):
    return experiments_from_summary(s, stats, by_surface=False)


def two(workers, steps, *, data_seed=101, seed=None, sampler_seed=None):
    truth = {STD: 12.0, VC: 0.2}
    data = scenario((30.0, 60.0), (0.235, 1.0), 3000)
    s = _summary(data, truth, 300, seed=data_seed)
    means = _means(s[s["speed_m_s"] == 1.0], ("e", "mu"))
    c = s[s["speed_m_s"] == 0.235]
    counts = pd.DataFrame(
        {
            "speed_m_s": c["speed_m_s"],
            "angle_deg": c["angle_deg"],
            "captured": np.rint(c["capture_fraction"] * c["n"]).astype(int),
            "n": c["n"].astype(int),
        }
    )
    bounds = {STD: (2.0, 30.0), VC: (0.1, 0.4)}
    return _timed(
        [means, counts], data, bounds, truth, workers, steps, seed, sampler_seed
    )


def one(workers, steps):
    truth = {STD: 12.0}
    data = scenario((15.0, 30.0, 45.0, 60.0, 70.0, 80.0, 85.0), (1.0,), 4000)
    means = _means(_summary(data, truth, 4000, seed=102), ("e",))
    return _timed(means, data, {STD: (2.0, 30.0)}, truth, workers, steps)


def _timed(exp, data, bounds, truth, workers, steps, seed=None, sampler_seed=None):
    t0 = time.perf_counter()
    seeds = {} if seed is None else {"seed": seed, "sampler_seed": sampler_seed}
    res = calibrate(
        data,
        exp,
        bounds,
        method="bayes",
        workers=workers,
        steps=steps,
        confidence=0.9,
        progress=False,
        **seeds,
    )
    wall = time.perf_counter() - t0
    d = res.diagnostics
    lo, hi = res.credible()
    runs = res.info["model_runs"]
    return {
        "wall_s": round(wall, 1),
        "workers": workers,
        "steps": d.steps,
        "walkers": res.walkers,
        "burn_in": d.burn_in,
        "model_runs": runs,
        "s_per_run_per_worker": round(wall * workers / runs, 4),
        "converged": d.converged,
        "r_hat": d.r_hat.round(4).tolist(),
        "ess": d.ess.round(0).tolist(),
        "tau": d.tau.round(2).tolist(),
        "median": dict(
            zip(res.keys, res.posterior_median.round(4).tolist(), strict=True)
        ),
        "credible_90": {
            k: [round(float(lo[j]), 4), round(float(hi[j]), 4)]
            for j, k in enumerate(res.keys)
        },
        "truth": truth,
    }


def _read_reps(path):
    done = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                row = json.loads(line)
                done[row["rep"]] = row
    return done


def coverage(workers, steps, reps, out, shard=(0, 1)):
    """Run replications 0..reps-1 not yet in `out` (JSON lines), then tally.

    ``shard=(k, n)`` runs only the replications ``r`` with ``r % n == k``, so that
    ``n`` processes (one worker each) can share one file; the tally counts every
    replication in the file."""
    path = Path(out)
    done = _read_reps(path)
    for rep in range(reps):
        if rep in done or rep % shard[1] != shard[0]:
            continue
        row = two(
            workers, steps, data_seed=1000 + rep, seed=5000 + rep, sampler_seed=rep
        )
        row["rep"] = rep
        with path.open("a") as f:  # one whole line per replication, one write
            f.write(json.dumps(row) + "\n")
        done[rep] = row
        print(json.dumps(row), flush=True)
    done = _read_reps(path)  # with the other shards' replications
    rows = [done[r] for r in sorted(done) if r < reps]
    tally = {"replications": len(rows)}
    tally["converged"] = sum(bool(r["converged"]) for r in rows)
    for key in (STD, VC):
        hits = sum(
            r["credible_90"][key][0] <= r["truth"][key] <= r["credible_90"][key][1]
            for r in rows
        )
        lo, hi = (float(x) for x in wilson_interval(hits, len(rows)))
        tally[key] = {"hits": hits, "coverage_95ci": [round(lo, 3), round(hi, 3)]}
    return tally


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=("two", "one", "coverage"))
    p.add_argument("--reps", type=int, default=50, help="coverage: replications")
    p.add_argument("--out", default="bayes_coverage.jsonl", help="coverage: file")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--steps", type=int, default=5000)
    p.add_argument("--smoke", action="store_true", help="20 steps: end to end only")
    p.add_argument(
        "--shard",
        default="0/1",
        help="coverage: K/N runs the replications r with r %% N == K (N processes)",
    )
    args = p.parse_args()
    steps = 20 if args.smoke else args.steps
    if args.what == "coverage":
        k, n = (int(x) for x in args.shard.split("/"))
        if not 0 <= k < n:
            p.error(f"--shard {args.shard!r}: K/N with 0 <= K < N")
        print(json.dumps(coverage(args.workers, steps, args.reps, args.out, (k, n))))
        return
    run = two if args.what == "two" else one
    print(json.dumps(run(args.workers, steps)))


if __name__ == "__main__":
    main()
