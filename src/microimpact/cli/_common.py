"""What every verb shares: argument types, run options, output helpers.

Exit codes (documented in docs/cli.md):

==== ===========================================================================
0    success
1    an internal error (a bug of ours): one line, the traceback saved to a file
2    the user's input: a bad flag, file, scenario key or value (one line naming
     the file, key or line); also a folder another run is writing to
3    the environment: an output folder that cannot be written (permissions, disk
     full, read-only), a closed output pipe, out of memory
130  interrupted (Ctrl-C); finished work is kept in the checkpoint
143  terminated (SIGTERM); finished work is kept in the checkpoint
==== ===========================================================================
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import tomllib
from pathlib import Path
from types import SimpleNamespace

from .._core.footprint import check_footprint, footprint, machine

EXIT_OK, EXIT_INTERNAL, EXIT_USER, EXIT_ENVIRONMENT = 0, 1, 2, 3
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143


def int_at_least(minimum):
    """An argparse type: a whole number >= `minimum`."""

    def parse(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"must be an integer >= {minimum}; got {text!r}"
            ) from None
        if v < minimum:
            raise argparse.ArgumentTypeError(
                f"must be an integer >= {minimum}; got {v}"
            )
        return v

    return parse


positive_int = int_at_least(1)
nonneg_int = int_at_least(0)


def count(text):
    """A positive whole number, also written as 1e7 or 10_000_000."""
    try:
        v = float(text.replace("_", ""))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be an integer >= 1 (1e7 and 10_000_000 allowed); got {text!r}"
        ) from None
    if not (math.isfinite(v) and v >= 1 and v == int(v)):
        raise argparse.ArgumentTypeError(f"must be an integer >= 1; got {text}")
    return int(v)


def positive_float(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number; got {text!r}") from None
    if not (v > 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0; got {text}")
    return v


def fraction(text):
    v = positive_float(text)
    if not v < 1:
        raise argparse.ArgumentTypeError(f"must be in (0, 1); got {text}")
    return v


def formats(text):
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from .._core.formats import FIGURE_FORMATS

    fmts = [f.strip().lower() for f in text.split(",") if f.strip()]
    bad = [f for f in fmts if f not in FIGURE_FORMATS]
    if bad or not fmts:
        what = f"{bad[0]!r} is not a figure format" if bad else "no format given"
        raise argparse.ArgumentTypeError(
            f"{what}; give a comma list of {', '.join(FIGURE_FORMATS)} (got {text!r})"
        )
    return tuple(dict.fromkeys(fmts))


def out_dir(text):
    """An output folder: new (created when needed) or existing, never a file."""
    path = Path(text)
    for p in (path, *path.parents):  # the first part that exists must be a folder
        if p.exists():
            if not p.is_dir():
                what = repr(text) if p == path else f"{str(p)!r} (in {text!r})"
                raise argparse.ArgumentTypeError(
                    f"{what} is a file, not a folder; give a new or existing folder"
                )
            break
    return path


def add_run_options(sp, *, seed_help="root seed (overrides the file)"):
    """The options of the verbs that run simulations."""
    sp.add_argument("--seed", type=nonneg_int, help=seed_help)
    sp.add_argument(
        "--workers",
        type=positive_int,
        default=1,
        help="workers (default 1; capped at the number of cores): threads of this "
        "process for the compiled kernel, else processes",
    )
    add_backend_options(sp)
    add_yes_option(sp)
    sp.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    sp.add_argument(
        "--formats",
        type=formats,
        default=None,
        help="figure formats, e.g. png,pdf (default: the scenario's "
        "[outputs] figures, else png,pdf)",
    )


def add_yes_option(sp):
    """``--yes``: start a run too big for this machine (see :func:`check_cost`)."""
    sp.add_argument(
        "--yes",
        action="store_true",
        help="start even a run whose memory, files or time exceed what this machine "
        "has (it is refused otherwise, with the numbers)",
    )


def check_cost(
    args,
    scenario,
    *,
    samples=None,
    out=None,
    runs=1,
    outputs=True,
    simulated=None,
    samples_flag="--samples",
    field="sweep",
):
    """Refuse a run too big for this machine before any work (unless ``--yes``),
    with the numbers and how to cut it; say what a big one will cost on stderr
    (:func:`~microimpact.engine.footprint.footprint` for the keywords)."""
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..engine.parallel import available_cores

    fp = footprint(
        scenario, samples=samples, runs=runs, outputs=outputs, simulated=simulated
    )
    workers = min(getattr(args, "workers", 1) or 1, available_cores())
    note = check_footprint(
        fp,
        machine(out),
        workers=workers,
        yes=getattr(args, "yes", False),
        samples_flag=samples_flag,
        workers_flag="--workers" if hasattr(args, "workers") else None,
        field=field,
    )
    if note is not None and not getattr(args, "quiet", False):
        print(f"microimpact: {note}", file=sys.stderr)


def _count(value) -> int | None:
    """How many sweep values a [sweep] entry gives, as the scenario reader would:
    a number, a list, or a range table with ``num`` or ``step``; None where the
    entry is anything else (the full reader then says what is wrong)."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int | float):
        return 1
    if isinstance(value, list):
        return len(value)
    if isinstance(value, dict):
        num, step = value.get("num"), value.get("step")
        if isinstance(num, int) and not isinstance(num, bool) and num > 0:
            return num
        start, stop = value.get("start"), value.get("stop")
        numbers = (start, stop, step)
        if all(isinstance(x, int | float) and not isinstance(x, bool) for x in numbers):
            if step > 0 and stop >= start:
                return math.floor((stop - start) / step + 1e-9) + 1
    return None


def precheck_cost(args, path, *, samples=None, out=None):
    """Refuse a sweep too big for this machine from the scenario file's text
    alone, before the scenario reader (and SciPy) load: a 10^8-point sweep is
    refused in a fraction of a second. Anything this light reading cannot count
    is left to :func:`check_cost` after the full read."""
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return  # not a readable TOML file (a preset name, a typo): the reader says
    sweep = data.get("sweep", {})
    if not isinstance(sweep, dict):
        return
    speeds = _count(sweep.get("speed_m_s", 1.0))
    angles = _count(sweep.get("angle_deg", 90.0))
    surfaces = data.get("surfaces", [{}])
    n_surfaces = len(surfaces) if isinstance(surfaces, list) and surfaces else 1
    precision = (
        data.get("precision") if isinstance(data.get("precision"), dict) else None
    )
    n = samples or (precision or {}).get("max_samples") or data.get("samples", 4000)
    if speeds is None or angles is None or not isinstance(n, int) or n < 1:
        return
    scenario = SimpleNamespace(
        surfaces=[None] * n_surfaces,
        speeds_m_s=range(speeds),
        angles_deg=range(angles),
        samples=n,
        precision=None,
        sampling=data.get("sampling", "mc"),
        qmc_replicates=int(data.get("qmc_replicates", 8) or 8),
    )
    check_footprint(
        footprint(scenario, samples=n),
        machine(out),
        workers=max(1, getattr(args, "workers", 1) or 1),
        yes=getattr(args, "yes", False),
        samples_flag="--samples",
        workers_flag="--workers" if hasattr(args, "workers") else None,
        field="sweep",
    )


def add_backend_options(sp):
    """``--backend {process,dask}`` and ``--scheduler ADDRESS``."""
    sp.add_argument(
        "--backend",
        choices=("process", "dask"),
        default="process",
        help="process: this machine (default); dask: a Dask cluster",
    )
    sp.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="Dask scheduler address (default: a LocalCluster of --workers workers)",
    )


def _check_scheduler(args) -> None:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..errors import InputError

    if args.scheduler is not None and args.backend != "dask":
        raise InputError(
            f"{args.scheduler!r} needs --backend dask", field="--scheduler"
        )


@contextlib.contextmanager
def executor_of(args):
    """The executor that ``--backend``/``--scheduler`` ask for: None for
    ``process`` (the library's own pool of ``--workers``), else a Dask client's
    executor (the scheduler at ``--scheduler``, or a local cluster of
    ``--workers`` single-threaded workers), closed on exit."""
    _check_scheduler(args)
    if args.backend != "dask":
        yield None
        return
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..engine.parallel import dask_client

    with dask_client(address=args.scheduler, workers=args.workers) as client:
        yield client.get_executor()


def run_options(args) -> dict:
    """Keyword arguments of :func:`microimpact.run` from the common options."""
    _check_scheduler(args)
    return {
        "seed": args.seed,
        "workers": args.workers,
        "backend": args.backend,
        "address": args.scheduler,
        "progress": False if args.quiet else None,
    }


def say(args, msg):
    """Print `msg` unless ``--quiet``."""
    if not getattr(args, "quiet", False):
        print(msg)


def write_outputs(out, *, tables=None, texts=None, figures=None):
    """Write tables (CSV), texts and figures (PNG + PDF) to `out`, each atomically.

    `figures` maps a file stem to a zero-argument function that draws and returns
    an Axes; matplotlib is imported (with the Agg backend) only when needed.
    """
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from .._core.files import atomic_write

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from .._core.formats import DEFAULT_FIGURE_FORMATS

    out.mkdir(parents=True, exist_ok=True)
    for name, table in (tables or {}).items():
        atomic_write(out / name, lambda t, df=table: df.to_csv(t, index=False))
    for name, text in (texts or {}).items():
        atomic_write(out / name, lambda t, x=text: Path(t).write_text(x))
    if figures:
        # deferred: the verb's library loads only when the verb runs (fast --help)
        from ..plotting._style import use_agg

        # deferred: the verb's library loads only when the verb runs (fast --help)
        from ..plotting.results import save_figures

        use_agg()
        save_figures(figures.items(), out, DEFAULT_FIGURE_FORMATS)
    print(f"-> {out}")


#: Capture-speed rows at most printed by :func:`print_capture`.
TERMINAL_ROWS = 20


def print_capture(result, limit=TERMINAL_ROWS):
    """The capture-speed rows, estimated or not (a refused estimate says why):
    all, or `limit` evenly spaced ones and where the rest are; with a single
    speed, one line saying that there is none."""
    if result.summary["speed_m_s"].nunique() < 2:
        print("  capture speed: one speed was simulated, so none is estimated")
        return
    cs = result.capture_speed()
    total = len(cs)
    if total > limit:
        # deferred: the verb's library loads only when the verb runs (fast --help)
        from ..pipeline.rows import capture_rows

        cs = cs.iloc[capture_rows(cs, limit)]

    def num(x):
        return "open" if x is None or not math.isfinite(float(x)) else f"{float(x):.3f}"

    for _, r in cs.iterrows():
        where = f"  {r['surface']}, {r['angle_deg']:g} deg: {r['quantile']:.0%} capture"
        note = str(r.get("note", "") or "")
        if math.isfinite(float(r["speed_m_s"])):
            print(
                f"{where} at {float(r['speed_m_s']):.3f} m/s "
                f"[{num(r['speed_ci_low'])}, {num(r['speed_ci_high'])}]"
                + (f" ({note})" if note else "")
            )
        else:
            print(f"{where}: not estimated ({note or 'no estimate'})")
    if len(cs) < total:
        print(
            f"  ... {len(cs)} of {total:,} capture curves shown (evenly spaced); "
            "all in capture_speed.csv"
        )


def print_heavy_tails(result, limit=6):
    """The points flagged by the heavy-tail rule (``heavy_tail == 1``,
    docs/outputs.md), at most `limit` named; nothing when none is."""
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..pipeline.report import heavy_tail_points

    bad = heavy_tail_points(result.summary, limit)  # copies `limit` rows at most
    flagged = bad.attrs["flagged"]
    if not flagged:
        return
    names = [
        f"{r['surface']} {r['speed_m_s']:g} m/s {r['angle_deg']:g} deg"
        for _, r in bad.iterrows()
    ]
    more = f" and {flagged - limit} more" if flagged > limit else ""
    print(
        f"  heavy tails: the mean of {flagged} point(s) rests on a few impacts "
        f"(summary.csv column heavy_tail; docs/outputs.md): {', '.join(names)}{more}"
    )


#: A run expected to take longer than this [s] says so at the start.
ANNOUNCE_AFTER_S = 120.0
#: Runs at most this big are not timed for the announcement (they take well under
#: ANNOUNCE_AFTER_S even on the NumPy kernel): the pilot would cost a plan build.
QUICK_IMPACTS = 10**8
QUICK_POINTS = 10_000


def announce(args, scenario, *, samples=None):
    """Say at the start when the simulation is expected to take more than a few
    minutes (:func:`~microimpact.engine.montecarlo.estimate_duration`: the rate
    measured on a calibration batch of the scenario's points)."""

    try:
        # deferred: the verb's library loads only when the verb runs (fast --help)
        from ..engine.montecarlo import estimate_duration
    except ImportError:  # pragma: no cover - older engine
        return
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..engine.parallel import available_cores

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.grid import SweepGrid

    workers = min(args.workers, available_cores())
    points = SweepGrid.from_scenario(scenario).size
    per_point = samples or (
        scenario.precision.max_samples if scenario.precision else scenario.samples
    )
    if points * per_point <= QUICK_IMPACTS and points <= QUICK_POINTS:
        return  # surely well under the announcement threshold: no pilot timing
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from .._core.progress import stage

    with stage("timing a calibration batch"):  # plans the sweep: ~4 s at 10^6
        seconds = estimate_duration(scenario, samples=samples, workers=workers)
    if seconds is not None and seconds > ANNOUNCE_AFTER_S:
        print(
            "microimpact: the simulation is expected to take about "
            f"{seconds / 60:.0f} min on {workers} worker(s) (measured on a "
            "calibration batch), then the outputs are written; progress is kept in "
            "the output folder, so an interrupted run resumes",
            file=sys.stderr,
        )


def resume_reporter(out):
    """A ``checkpoint=`` callback for :meth:`Study.execute` that says on stderr how
    much was restored, before any block runs."""

    def report(checkpoint):
        if checkpoint.resumed:
            print(
                f"microimpact: resumed {checkpoint.restored_blocks} of "
                f"{checkpoint.total_blocks} blocks from the checkpoint in {out}",
                file=sys.stderr,
            )

    return report
