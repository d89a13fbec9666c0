"""``microimpact run SCENARIO --out DIR``: one study, every output."""

from __future__ import annotations

import sys
import time
from dataclasses import replace

from . import _common as c

HELP = "run a scenario file (or a preset) and write every output"


def cli_parse(sp):
    sp.add_argument("scenario", help="scenario TOML file or preset name")
    sp.add_argument("--out", required=True, type=c.out_dir, help="output folder")
    sp.add_argument("--samples", type=c.count, help="impacts per sweep point")
    sp.add_argument(
        "--precision",
        type=c.positive_float,
        metavar="X",
        help="stop each point at this CI half-width of the scenario's "
        "precision statistic (default capture_fraction)",
    )
    sp.add_argument("--no-figures", action="store_true", help="write no figures")
    sp.add_argument(
        "--distribution-speed-m-s",
        type=c.positive_float,
        metavar="V",
        help="the swept speed of the distribution figures (default: the slowest "
        "swept speed at which particles rebound)",
    )
    c.add_run_options(sp)


def cli_action(args) -> int:
    t0 = time.perf_counter()
    # a sweep too big for the machine is refused from the file's text, before
    # the reader loads SciPy (the full check below covers the rest)
    c.precheck_cost(args, args.scenario, samples=args.samples, out=args.out)

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.scenario import read_scenario

    file = read_scenario(args.scenario)  # read once, here
    scenario, outputs = _apply_flags(args, file)
    # the cost is checked before the pipeline (xarray, matplotlib) is even loaded
    c.check_cost(args, scenario, samples=args.samples, out=args.out)

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..pipeline.study import Study

    study = Study(scenario, outputs=outputs)
    c.announce(args, study.scenario, samples=args.samples)
    study.execute(
        args.out,
        samples=args.samples,
        checkpoint=c.resume_reporter(args.out),
        **c.run_options(args),
    )
    result = study.result
    c.say(
        args,
        f"{study.scenario.name}: {len(result.summary)} sweep points, "
        f"seed entropy {result.seed_entropy}, "
        f"{time.perf_counter() - t0:.1f} s -> {args.out}",
    )
    if not args.quiet:
        c.print_capture(result)
        c.print_heavy_tails(result)
        sys.stdout.flush()
    return c.EXIT_OK


def _apply_flags(args, study):
    """The scenario and outputs (of a study or a scenario file) after
    --precision, --formats, --no-figures."""

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..errors import InputError

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.scenario import Precision

    scenario, outputs = study.scenario, study.outputs
    if args.precision is not None:
        if args.samples is not None:
            raise InputError(
                "give either --samples or --precision, not both", field="--precision"
            )
        precision = scenario.precision or Precision()
        scenario = scenario.with_options(
            precision=replace(precision, half_width=args.precision), sampling="mc"
        )
    if args.formats is not None:
        outputs = replace(outputs, figures=args.formats)
    if args.no_figures:
        outputs = replace(outputs, figures=())
    if args.distribution_speed_m_s is not None:
        outputs = replace(outputs, distribution_speed_m_s=args.distribution_speed_m_s)
    return scenario, outputs
