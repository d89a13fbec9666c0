"""Two threads against one on the three paths of issue 31 (its target: at least
1.9x on each, on 2 cores, with the same bits).

The paths and sizes are those of ``benchmarks/gil_share.py``: ``run()`` over 64
points of 10^6 impacts, a 60 x 60 speed-angle grid at 8,000 impacts per point and
a 16^3 wall law at 2,000 impacts per node (the sst76-formica-oblique physics, one
surface). Each path runs once to warm up, then ``--repeats`` times with 1 and 2
workers, alternating; the speed-up is the ratio of the medians (the ratio of the
minima is printed too). The outputs of 1 and 2 workers are compared bit for bit.

    python benchmarks/two_threads.py [--repeats 7] [--paths run grid wall_law]
                                     [--json PATH]

Other work on the machine moves the 2-worker times most: pause it while this runs.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import time

import numpy as np


def _base():
    from microimpact.scenario import load_preset

    base = load_preset("sst76-formica-oblique")
    return base.with_options(surfaces=base.surfaces[:1])


def _run(workers):
    from microimpact.engine.montecarlo import run

    sc = _base().with_options(
        speeds_m_s=(0.5, 1.0, 2.0, 5.0), angles_deg=tuple(range(10, 90, 5))[:16]
    )
    return run(sc, samples=1_000_000, workers=workers).summary


def _grid(workers):
    from microimpact.engine.montecarlo import run

    sc = _base().with_options(
        speeds_m_s=tuple(np.linspace(0.2, 5.0, 60)),
        angles_deg=tuple(np.linspace(5.0, 90.0, 60)),
    )
    return run(sc, samples=8000, workers=workers).summary


def _wall_law(workers):
    from microimpact.wall_law import WallLawSpec, build_wall_law

    spec = WallLawSpec(
        diameters_um=tuple(np.geomspace(10, 80, 16)),
        speeds_m_s=tuple(np.geomspace(0.2, 10, 16)),
        angles_deg=tuple(np.linspace(6, 90, 16)),
        samples=2000,
        reservoir=64,
    )
    return build_wall_law(_base(), spec, workers=workers, seed=1).dataset


PATHS = {"run": _run, "grid": _grid, "wall_law": _wall_law}


def _same(a, b) -> bool:
    if hasattr(a, "data_vars"):  # a wall-law Dataset
        return all(
            np.array_equal(a[k].values, b[k].values, equal_nan=a[k].dtype.kind == "f")
            for k in a.data_vars
        )
    cols = [c for c in a.columns if c != "surface"]
    return bool(np.array_equal(a[cols].to_numpy(), b[cols].to_numpy(), equal_nan=True))


def measure(name, repeats):
    fn = PATHS[name]
    fn(1), fn(2)  # warm-up: imports, lazy set-up
    times = {1: [], 2: []}
    out = {}
    for _ in range(repeats):
        for w in (1, 2):
            t = time.perf_counter()
            out[w] = fn(w)
            times[w].append(time.perf_counter() - t)
    m1, m2 = statistics.median(times[1]), statistics.median(times[2])
    return {
        "path": name,
        "one_s": round(m1, 4),
        "two_s": round(m2, 4),
        "speedup": round(m1 / m2, 3),
        "speedup_of_minima": round(min(times[1]) / min(times[2]), 3),
        "same_bits": _same(out[1], out[2]),
        "times": {str(w): [round(t, 4) for t in ts] for w, ts in times.items()},
    }


def _cpu() -> str:
    try:
        info = open("/proc/cpuinfo").read()
    except OSError:
        return platform.processor()
    model = next((x for x in info.splitlines() if x.startswith("model name")), "")
    flags = next((x for x in info.splitlines() if x.startswith("flags")), "")
    return f"{model.split(':')[-1].strip()}, AVX-512 {'avx512f' in flags}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--paths", nargs="+", default=list(PATHS), choices=list(PATHS))
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    rows = [measure(p, args.repeats) for p in args.paths]
    print(f"CPU: {_cpu()}")
    print("| path | 1 worker [s] | 2 workers [s] | speed-up | (minima) | same bits |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| `{r['path']}` | {r['one_s']} | {r['two_s']} | {r['speedup']}x | "
            f"{r['speedup_of_minima']}x | {r['same_bits']} |"
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"cpu": _cpu(), "rows": rows}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
