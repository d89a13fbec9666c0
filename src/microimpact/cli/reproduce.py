"""``microimpact reproduce --out DIR``: the paper's four cases and one report."""

from __future__ import annotations

import time

from . import _common as c

HELP = "run the paper's four presets and write one report (what `make demo` runs)"


def cli_parse(sp):
    sp.add_argument("--out", type=c.out_dir, default="out")
    sp.add_argument("--quick", action="store_true", help="1,000 samples per point")
    sp.add_argument(
        "--samples",
        type=c.count,
        help="impacts per sweep point (default: each preset's, 4,000)",
    )
    c.add_run_options(sp)


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..pipeline.study import reproduce

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.file import PAPER_PRESETS
    from ..scenario.scenario import Scenario

    t0 = time.perf_counter()
    samples = args.samples or (1000 if args.quick else None)
    for name in PAPER_PRESETS:  # each preset's cost before any runs
        c.check_cost(
            args,
            Scenario.from_preset(name),
            samples=samples,
            out=args.out,
            field=f"preset {name}",
        )
    studies = reproduce(
        args.out, samples=samples, figures=args.formats, **c.run_options(args)
    )
    for study in studies:
        c.say(
            args,
            f"{study.scenario.name}: {len(study.result.summary)} points, "
            f"{study.result.elapsed_s:.1f} s -> {args.out / study.scenario.name}",
        )
        if not args.quiet:
            c.print_capture(study.result)
            c.print_heavy_tails(study.result)
    c.say(
        args,
        f"report: {args.out / 'report.html'} ({time.perf_counter() - t0:.1f} s in all)",
    )
    return c.EXIT_OK
