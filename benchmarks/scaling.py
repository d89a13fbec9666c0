"""Scaling with the number of workers, on one machine (issue 31, item 5).

For each path, the median wall time of ``--repeats`` calls at each worker count
(threads, the engine's default), after a warm-up call at that count, and whether
the results are the same bits as with one worker:

* ``run``: ``run()`` over 64 points (4 speeds x 16 angles) of 10^6 impacts;
* ``run4``: the same at 4 * 10^6 impacts per point;
* ``grid``: a 60 x 60 speed-angle grid at 8,000 impacts per point;
* ``wall_law``: a 16^3 wall law at 2,000 impacts per node;
* ``sensitivity``: the Sobol design of ``benchmarks/gil_share.py`` (24 rows of
  the preset at 20,000 impacts);
* ``sensitivity32``: the same design at base size 32 (192 rows);
* ``calibration``: its least-squares calibration (two parameters, 8 points at
  20,000 impacts per model run);
* ``bootstrap``: the same with 20 parametric bootstrap refits (the default is
  100), which run at once on forked worker processes.

The paths are those of ``benchmarks/gil_share.py`` (the sst76-formica-oblique
physics, one surface; ``two_threads.py`` runs three of them from here), so the
measured speed-ups stand beside the Amdahl projections of the GIL share.
``--dask N`` also times ``run`` and ``grid`` on a ``LocalCluster`` of N
single-threaded worker processes, started once, with its results reduced on the
workers.

    python benchmarks/scaling.py --workers 1 2 4 8 16 --dask 16 --json out.json

The machine is recorded with the figures: CPU model, core count and vector
extensions (AVX2-only machines are 2-4x slower per core).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bayes_posterior import STD, VC
from bayes_posterior import scenario as bench_scenario


def _base():
    from microimpact.scenario import load_preset

    base = load_preset("sst76-formica-oblique")
    return base.with_options(surfaces=base.surfaces[:1])


def _points(samples):
    from microimpact.engine.montecarlo import run

    sc = _base().with_options(
        speeds_m_s=(0.5, 1.0, 2.0, 5.0), angles_deg=tuple(range(10, 90, 5))[:16]
    )
    return lambda **kw: run(sc, samples=samples, progress=False, **kw)


def _grid():
    from microimpact.engine.montecarlo import run

    sc = _base().with_options(
        speeds_m_s=tuple(np.linspace(0.2, 5.0, 60)),
        angles_deg=tuple(np.linspace(5.0, 90.0, 60)),
    )
    return lambda **kw: run(sc, samples=8000, progress=False, **kw)


def _wall_law():
    from microimpact.wall_law import WallLawSpec, build_wall_law

    spec = WallLawSpec(
        diameters_um=tuple(np.geomspace(10, 80, 16)),
        speeds_m_s=tuple(np.geomspace(0.2, 10, 16)),
        angles_deg=tuple(np.linspace(6, 90, 16)),
        samples=2000,
        reservoir=64,
    )
    base = _base()
    return lambda **kw: build_wall_law(base, spec, seed=1, **kw)


def _sensitivity(base_size=4):
    import microimpact as mi

    parameters = {
        "coefficients.friction": {"low": 0.1, "high": 0.3},
        "coefficients.k1": {"low": 3.0, "high": 5.0},
        "coefficients.v_c.a_m_s": {"low": 0.15, "high": 0.25},
        "coefficients.k2.a_m_s": {"low": 0.04, "high": 0.06},
    }

    def go(**kw):
        return mi.sobol_sensitivity(
            "sst76-formica-oblique",
            parameters,
            base_size=base_size,
            samples=20000,
            seed=1,
            n_resamples=10,
            progress=False,
            **kw,
        )

    return go


def _calibration(bootstrap=0):
    import microimpact as mi
    from microimpact.analysis.calibration import calibrate
    from microimpact.analysis.compare import experiments_from_summary
    from microimpact.scenario.parameters import with_values
    from microimpact.scenario.scenario import scenario_from_dict

    data = bench_scenario([20.0, 40.0, 60.0, 80.0], [1.0, 3.0], 20000)
    truth = with_values(data, {STD: 12.0, VC: 0.22})
    summary = mi.run(scenario_from_dict(truth), seed=7, progress=False).summary
    exp = experiments_from_summary(summary, ("e", "mu"), by_surface=False)

    def go(**kw):
        return calibrate(
            data,
            exp,
            {STD: (2.0, 30.0), VC: (0.1, 0.4)},
            samples=20000,
            bootstrap=bootstrap,
            progress=False,
            **kw,
        )

    return go


PATHS = {
    "run": (lambda: _points(1_000_000), 64_000_000),
    "run4": (lambda: _points(4_000_000), 256_000_000),
    "grid": (_grid, 3600 * 8000),
    "wall_law": (_wall_law, 16**3 * 2000),
    "sensitivity": (_sensitivity, None),
    "sensitivity32": (lambda: _sensitivity(base_size=32), None),
    "calibration": (_calibration, None),
    "bootstrap": (lambda: _calibration(bootstrap=20), None),
}


def table(result):
    """What a user reads of a path's result (timed with the call): a run's
    summary, a wall law's Dataset, a sensitivity table, a calibration's
    estimate."""
    for name in ("summary", "dataset", "table", "estimate"):
        if hasattr(result, name):
            return getattr(result, name)
    raise TypeError(f"no table in {type(result).__name__}")


def same_bits(a, b) -> bool:
    """Two tables of one path (:func:`table`) equal bit for bit, NaN as NaN: a
    wall law's Dataset variable by variable, a table (a summary, a sensitivity
    table) by its numeric columns, an estimate as an array."""
    if isinstance(a, np.ndarray):
        return bool(np.array_equal(a, b, equal_nan=True))
    if hasattr(a, "data_vars"):  # a wall-law Dataset
        return all(
            np.array_equal(a[k].values, b[k].values, equal_nan=a[k].dtype.kind == "f")
            for k in a.data_vars
        )
    cols = [c for c in a.columns if a[c].dtype.kind in "biuf"]  # not the names
    return bool(np.array_equal(a[cols].to_numpy(), b[cols].to_numpy(), equal_nan=True))


def _timed(fn, repeats):
    fn()  # warm-up at this worker count: pools started, tables built
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return times, out


def _row(name, backend, workers, times, t1, impacts, same) -> dict:
    med = statistics.median(times)
    row = {
        "path": name,
        "backend": backend,
        "workers": workers,
        "median_s": med,
        "times_s": times,
        "speedup": t1 / med,
        "efficiency": t1 / med / workers,
        "impacts_per_s": impacts / med if impacts else None,
        "same_bits": same,
    }
    print(_line(row), flush=True)
    return row


#: Paths whose workers are processes forked from this one where it can fork
#: (parallel.fork_pool): the design rows; the bootstrap refits (the fit itself
#: stays on threads).
FORKED = {
    "sensitivity": "processes",
    "sensitivity32": "processes",
    "bootstrap": "threads + processes",
}


def measure(name, workers, repeats, dask=None):
    make, impacts = PATHS[name]
    fn = make()
    rows, ref, t1 = [], None, None
    for w in workers:
        times, out = _timed(lambda w=w: table(fn(workers=w)), repeats)
        if ref is None:
            ref, t1 = out, statistics.median(times)
        kind = FORKED.get(name, "threads") if w > 1 else "threads"
        rows.append(_row(name, kind, w, times, t1, impacts, same_bits(ref, out)))
    if dask and name in ("run", "run4", "grid"):
        from dask.distributed import LocalCluster

        with LocalCluster(
            n_workers=dask, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster:
            address = cluster.scheduler_address
            times, out = _timed(
                lambda: table(fn(backend="dask", address=address)), max(repeats, 2)
            )
        rows.append(_row(name, "dask", dask, times, t1, impacts, same_bits(ref, out)))
    return rows


def _line(r) -> str:
    rate = f"{r['impacts_per_s'] / 1e6:.1f}" if r["impacts_per_s"] else "-"
    return (
        f"| `{r['path']}` | {r['backend']} | {r['workers']} | {r['median_s']:.3f} | "
        f"{rate} | {r['speedup']:.2f}x | {r['efficiency']:.2f} | {r['same_bits']} |"
    )


def machine() -> dict:
    info = {"python": platform.python_version(), "numpy": np.__version__}
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return {**info, "cpu": platform.processor(), "cpus": os.cpu_count()}
    lines = text.splitlines()
    model = next((x.split(":", 1)[1].strip() for x in lines if "model name" in x), "?")
    flags = next(x.split(":", 1)[1].split() for x in lines if x.startswith("flags"))
    vector = [f for f in flags if f.startswith(("avx", "fma", "sse4"))]
    return {
        **info,
        "cpu": model,
        "cpus": os.cpu_count(),
        "affinity": len(os.sched_getaffinity(0)),
        "vector": vector,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", nargs="+", default=list(PATHS), choices=list(PATHS))
    ap.add_argument("--workers", nargs="+", type=int, default=[1, 2])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument(
        "--dask", type=int, default=0, help="LocalCluster workers (0: none)"
    )
    ap.add_argument("--json", type=Path)
    ap.add_argument(
        "--no-fork",
        action="store_true",
        help="design rows and bootstrap refits on threads, as before forked "
        "workers (parallel.fork_pool): the comparison in one run",
    )
    args = ap.parse_args(argv)
    if args.no_fork:
        from microimpact.analysis import calibration, sensitivity

        for module in (calibration, sensitivity):
            module.fork_pool = lambda workers, func: None
        FORKED.clear()
    if args.repeats < 1 or min(args.workers) < 1 or args.dask < 0:
        ap.error("--repeats and --workers must be at least 1, --dask at least 0")
    if args.workers[0] != 1:
        ap.error("--workers must start at 1 (the speed-ups are against one worker)")
    info = machine()
    print(f"machine: {json.dumps(info)}", flush=True)
    print(
        "| path | backend | workers | median [s] | M impacts/s | speed-up | "
        "efficiency | same bits |"
    )
    print("|---|---|---|---|---|---|---|---|", flush=True)
    rows = []
    for name in args.paths:
        rows += measure(name, args.workers, args.repeats, args.dask)
        if args.json:  # after each path, so that a cut-off run keeps what it did
            args.json.write_text(json.dumps({"machine": info, "rows": rows}, indent=1))
    return 0 if all(r["same_bits"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
