"""A 2-worker Dask ``LocalCluster`` against 2 threads on ``run()`` over 64 points
of 10^6 impacts (issue 31, item 2: the cluster should reach 0.8 of the threads,
with the same bits).

Both run the ``run`` path of ``benchmarks/gil_share.py`` (the
sst76-formica-oblique physics, one surface, 4 speeds x 16 angles). The threads
are ``run(..., workers=2)``; the cluster is started once (2 single-threaded
worker processes) and ``run(..., backend="dask", address=...)`` is timed on it,
its results reduced on the workers. One run of ``backend="dask", workers=2``,
which starts and closes its own cluster, is timed too. Each rate is the median
of ``--repeats`` runs after a warm-up; the summaries are compared bit for bit.

    python benchmarks/dask_threads.py [--repeats 3] [--samples 1e6] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import time

import numpy as np


def scenario():
    from microimpact.scenario import load_preset

    base = load_preset("sst76-formica-oblique")
    return base.with_options(
        surfaces=base.surfaces[:1],
        speeds_m_s=(0.5, 1.0, 2.0, 5.0),
        angles_deg=tuple(range(10, 90, 5))[:16],
    )


def _timed(fn, repeats):
    fn()  # warm-up: tables built, workers' imports done
    times, result = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), times, result


def _same_bits(a, b) -> bool:
    cols = [c for c in a.summary.columns if c != "surface"]
    x, y = a.summary[cols].to_numpy(), b.summary[cols].to_numpy()
    return bool(np.array_equal(x, y, equal_nan=True))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--samples", type=float, default=1e6)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    from dask.distributed import LocalCluster

    from microimpact.engine.montecarlo import run

    sc = scenario()
    n = int(args.samples)
    impacts = n * len(sc.speeds_m_s) * len(sc.angles_deg)

    def threads():
        return run(sc, samples=n, seed=1, workers=2, progress=False)

    t_threads, all_threads, ref = _timed(threads, args.repeats)
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        address = cluster.scheduler_address

        def dask():
            return run(
                sc, samples=n, seed=1, backend="dask", address=address, progress=False
            )

        t_dask, all_dask, res = _timed(dask, args.repeats)
    t = time.perf_counter()
    own = run(sc, samples=n, seed=1, backend="dask", workers=2, progress=False)
    t_own = time.perf_counter() - t
    out = {
        "python": platform.python_version(),
        "impacts": impacts,
        "threads_s": t_threads,
        "threads_runs_s": all_threads,
        "dask_s": t_dask,
        "dask_runs_s": all_dask,
        "dask_own_cluster_s": t_own,
        "threads_per_s": impacts / t_threads,
        "dask_per_s": impacts / t_dask,
        "ratio": t_threads / t_dask,
        "ratio_own_cluster": t_threads / t_own,
        "same_bits": _same_bits(ref, res) and _same_bits(ref, own),
    }
    print(
        f"2 threads: {impacts / t_threads / 1e6:.1f} M impacts/s ({t_threads:.2f} s); "
        f"Dask LocalCluster of 2: {impacts / t_dask / 1e6:.1f} M/s ({t_dask:.2f} s), "
        f"{out['ratio']:.2f} of the threads; with its own cluster's start: "
        f"{t_own:.2f} s ({out['ratio_own_cluster']:.2f}); same bits: "
        f"{out['same_bits']}"
    )
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(out, fh, indent=1)
    return 0 if out["same_bits"] else 1


if __name__ == "__main__":
    sys.exit(main())
