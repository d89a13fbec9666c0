"""Where the time of a threaded run goes, worker count by worker count (issue 31:
why 16 threads give less than the GIL share's Amdahl projection).

Each path of ``benchmarks/scaling.py`` (``run``, ``grid``, ``wall_law``) is run
at each worker count with its tasks timed from outside (the engine's
``parallel.run_task`` and the wall law's node groups, wrapped), and the
compiled kernel's own count of the time it ran with the GIL released
(``_ckernel.released_ns``, summed over all threads). Per run it reports:

* ``wall``: the call, and beside it ``summary`` (the result's table, serial);
* ``head``: from the call to the first task's start (the plan, the tasks);
* ``tail``: from the last task's end to the call's return (the result);
* ``busy``: the tasks' summed time over ``workers x (last end - first start)``,
  the share of the worker threads' time spent inside tasks;
* ``kernel``: the summed GIL-free kernel time, and its ratio to one worker's
  (``inflation``: above 1 where the cores slow each other down, from shared
  caches, memory bandwidth or a lower all-core clock, not from the GIL);
* ``task``: the tasks' number and mean time, and their mean time outside the
  kernel (``task - kernel``: argument parsing, copies and waits for the GIL).
  Where the kernel runs a run's tasks itself (``kernel.KernelTasks``), a
  "task" is one worker thread's loop over them.

    python benchmarks/timeline.py --workers 1 2 4 8 16 [--json PATH]
    python benchmarks/timeline.py --knob TASKS_PER_WORKER=2,4,8,16 --paths grid
"""

from __future__ import annotations

import argparse
import functools
import json
import statistics
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from scaling import PATHS, machine, table

_LOG: list = []


def _timed(fn):
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            _LOG.append((threading.get_ident(), t, time.perf_counter()))

    return wrapper


def _instrument() -> None:
    from microimpact.engine import kernel, parallel
    from microimpact.wall_law import build

    parallel.run_task = _timed(parallel.run_task)
    # a fresh run of whole streams runs its tasks inside the kernel: each worker
    # thread's one loop over them is its "task" here
    kernel.KernelTasks.run = _timed(kernel.KernelTasks.run)
    build._node_rows = _timed(build._node_rows)


def _released() -> float:
    from microimpact.engine import _compiled

    return _compiled.ckernel.released_ns() / 1e9


def one(fn, workers: int) -> dict:
    _LOG.clear()
    r0, t0 = _released(), time.perf_counter()
    out = fn(workers=workers)
    t1 = time.perf_counter()
    released = _released() - r0
    t = time.perf_counter()
    table(out)
    summary = time.perf_counter() - t
    log = list(_LOG)
    first = min(s for _, s, _ in log)
    last = max(e for _, _, e in log)
    work = sum(e - s for _, s, e in log)
    return {
        "wall": t1 - t0,
        "summary": summary,
        "head": first - t0,
        "tail": t1 - last,
        "busy": work / (workers * (last - first)),
        "kernel": released,
        "tasks": len(log),
        "task_mean": work / len(log),
        "task_outside": (work - released) / len(log),
        "threads": len({i for i, _, _ in log}),
    }


def measure(name: str, workers: list[int], repeats: int) -> list[dict]:
    make, _ = PATHS[name]
    fn = make()
    rows, base = [], None
    for w in workers:
        one(fn, w)  # warm-up
        runs = [one(fn, w) for _ in range(repeats)]
        row = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
        row.update(path=name, workers=w)
        base = base or row
        row["inflation"] = row["kernel"] / base["kernel"]
        row["speedup"] = base["wall"] / row["wall"]
        rows.append(row)
        print(_line(row), flush=True)
    return rows


def _line(r) -> str:
    ms = lambda x: f"{1e3 * x:.1f}"  # noqa: E731
    return (
        f"| `{r['path']}` | {r['workers']} | {ms(r['wall'])} | {r['speedup']:.2f}x | "
        f"{ms(r['summary'])} | {ms(r['head'])} | {ms(r['tail'])} | "
        f"{r['busy']:.2f} | {ms(r['kernel'])} | {r['inflation']:.2f} | "
        f"{int(r['tasks'])} | {ms(r['task_mean'])} | {1e3 * r['task_outside']:.2f} |"
    )


HEADER = (
    "| path | workers | wall [ms] | speed-up | summary [ms] | head [ms] | "
    "tail [ms] | busy | kernel [ms] | inflation | tasks | task [ms] | "
    "outside kernel per task [ms] |\n|---|---|---|---|---|---|---|---|---|---|---|"
    "---|---|"
)


def _knob_settings(ap, knob: str) -> list:
    """``[(module, (NAME, value)), ...]`` for ``--knob NAME=v1,v2``: an integer
    constant of ``microimpact.engine.montecarlo`` or ``wall_law.build``; a usage
    error names what is wrong."""
    import microimpact.engine.montecarlo as mc
    from microimpact.wall_law import build

    name, eq, values = knob.partition("=")
    owner = next(
        (m for m in (mc, build) if isinstance(getattr(m, name, None), int)), None
    )
    if not eq or owner is None:
        ap.error(
            f"--knob {knob!r}: give NAME=v1,v2,... with NAME an integer constant of "
            "microimpact.engine.montecarlo or microimpact.wall_law.build (e.g. "
            "TASKS_PER_WORKER, TAIL_SPLIT, MIN_GROUP_IMPACTS)"
        )
    try:
        picked = [int(v) for v in values.split(",")]
    except ValueError:
        ap.error(f"--knob {knob!r}: the values of {name} must be integers")
    if min(picked) < 1:
        ap.error(f"--knob {knob!r}: the values of {name} must be at least 1")
    return [(owner, (name, v)) for v in picked]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--paths", nargs="+", default=["run", "grid", "wall_law"], choices=list(PATHS)
    )
    ap.add_argument("--workers", nargs="+", type=int, default=[1, 2])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument(
        "--knob",
        help="NAME=v1,v2,...: a constant of microimpact.engine.montecarlo (or "
        "wall_law.build) set to each value in turn",
    )
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    if args.workers[0] != 1 or args.repeats < 1:
        ap.error("--workers must start at 1; --repeats at least 1")
    settings = _knob_settings(ap, args.knob) if args.knob else [(None, None)]
    _instrument()
    print(f"machine: {json.dumps(machine())}")
    print(HEADER, flush=True)
    rows = []
    for owner, kv in settings:
        if kv is not None:
            setattr(owner, *kv)
            print(f"{kv[0]} = {kv[1]}", flush=True)
        for name in args.paths:
            for r in measure(name, args.workers, args.repeats):
                rows.append({**r, "knob": kv})
        if args.json:
            args.json.write_text(json.dumps({"machine": machine(), "rows": rows}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
