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
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from scaling import PATHS as ALL_PATHS
from scaling import machine, same_bits, table

#: The three paths of the issue's target (``scaling.py`` has them all).
PATHS = ("run", "grid", "wall_law")


def measure(name, repeats):
    call = ALL_PATHS[name][0]()

    def fn(workers):
        return table(call(workers=workers))

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
        "same_bits": same_bits(out[1], out[2]),
        "times": {str(w): [round(t, 4) for t in ts] for w, ts in times.items()},
    }


def _cpu() -> str:
    m = machine()
    return f"{m['cpu']}, AVX-512 {'avx512f' in m.get('vector', ())}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--paths", nargs="+", default=list(PATHS), choices=PATHS)
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
