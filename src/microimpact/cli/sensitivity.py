"""``microimpact sensitivity SCENARIO --out DIR``: Sobol' indices of the statistics.

Writes ``DIR/sensitivity.csv`` (see :data:`microimpact.analysis.sensitivity.COLUMNS`)
and ``DIR/sensitivity_ST.png`` (total indices against speed, or angle when the sweep has
one speed), each atomically. The uncertain inputs come from the scenario's
``[sensitivity]`` table or from ``--parameter KEY=LOW:HIGH`` flags (uniform ranges;
they replace the table's parameters). See ``docs/sensitivity.md``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

from . import _common as c

HELP = "Sobol' sensitivity indices of capture, e and mu to uncertain scenario inputs"


def _parameter(text):
    """``KEY=LOW:HIGH`` -> (key, {"low": LOW, "high": HIGH}): the calibration's
    parser (:func:`microimpact.analysis.calibration.parse_parameter`), with both limits
    required (a uniform range) and LOW < HIGH."""
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..analysis.calibration import parse_parameter

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..errors import InputError

    try:
        key, bounds = parse_parameter(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(exc.message) from None
    lo, hi = bounds if bounds is not None else (None, None)
    if lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)):
        raise argparse.ArgumentTypeError(
            f"expected KEY=LOW:HIGH with both limits finite (a uniform range), "
            f"e.g. particles.median_um=8:12; got {text!r}"
        )
    if not hi > lo:
        raise argparse.ArgumentTypeError(f"needs LOW < HIGH; got {text!r}")
    return key, {"low": lo, "high": hi}


def _power_of_two(text):
    v = c.positive_int(text)
    if v < 2 or v & (v - 1):
        raise argparse.ArgumentTypeError(
            f"must be a power of 2 (the balance of Sobol' points), e.g. 256 or "
            f"1024; got {text}"
        )
    return v


def _statistics(text):
    return tuple(s.strip() for s in text.split(",") if s.strip())


def cli_parse(sp):
    sp.add_argument("scenario", help="scenario TOML file (with a [sensitivity] table)")
    sp.add_argument("--out", required=True, type=c.out_dir, help="output folder")
    sp.add_argument(
        "--parameter",
        type=_parameter,
        action="append",
        metavar="KEY=LOW:HIGH",
        help="an uncertain input, uniform on [LOW, HIGH] (repeatable; replaces "
        "the [sensitivity.parameters] table)",
    )
    sp.add_argument(
        "--base-size",
        type=_power_of_two,
        help="base size n of the Sobol' design, a power of 2 (default: the "
        "file's, else 1024); the engine runs n * (parameters + 2) times",
    )
    sp.add_argument(
        "--statistics",
        type=_statistics,
        metavar="A,B",
        help="statistics to analyse (default capture_fraction,e_rebound_mean,mu_mean)",
    )
    sp.add_argument(
        "--samples",
        type=c.count,
        help="impacts per sweep point in each run (default: the scenario's samples)",
    )
    sp.add_argument(
        "--resamples", type=c.int_at_least(10), help="bootstrap resamples (999)"
    )
    sp.add_argument(
        "--confidence",
        type=c.fraction,
        default=0.95,
        help="level of the bootstrap intervals (0.95)",
    )
    c.add_run_options(sp, seed_help="root seed (default: the file's seed)")


def write_sensitivity(result, out, formats=("png",)):
    """Write ``out/sensitivity.csv`` and ``out/sensitivity_ST.<format>``, each
    atomically; return the paths."""
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..plotting._style import use_agg

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..plotting.results import save_figures

    out.mkdir(parents=True, exist_ok=True)
    paths = [result.to_csv(out / "sensitivity.csv")]
    use_agg()
    paths += save_figures(
        [("sensitivity_ST", lambda: result.plot()[0].figure)], out, formats
    )
    return paths


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..analysis.sensitivity import sobol_sensitivity

    parameters = dict(args.parameter) if args.parameter else None
    _check_cost(args, parameters)
    t0 = time.perf_counter()
    last = [0.0]

    def progress(done, total):
        now = time.perf_counter()
        if not args.quiet and (now - last[0] > 5 or done == total):
            last[0] = now
            print(f"  {done}/{total} design rows", file=sys.stderr)

    with c.executor_of(args) as executor:
        result = sobol_sensitivity(
            args.scenario,
            parameters,
            base_size=args.base_size,
            samples=args.samples,
            statistics=args.statistics,
            workers=args.workers,
            executor=executor,
            seed=args.seed,
            confidence=args.confidence,
            n_resamples=args.resamples,
            progress=progress,
        )
    write_sensitivity(result, args.out, args.formats or ("png",))
    c.say(
        args,
        f"{len(result.parameters)} parameters, n = {result.base_size}, "
        f"{result.evaluations} engine runs, seed {result.seed}, "
        f"{time.perf_counter() - t0:.1f} s -> {args.out}",
    )
    if not args.quiet:
        _print_top(result)
    return c.EXIT_OK


def _check_cost(args, parameters):
    """The study's cost before any run: the sweep, n * (d + 2) times."""
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.scenario import read_scenario
    from ..scenario.sensitivity import DEFAULT_BASE_SIZE

    file = read_scenario(args.scenario)
    settings = file.sensitivity
    n = args.base_size or (settings.base_size if settings else DEFAULT_BASE_SIZE)
    d = len(parameters or (settings.parameters if settings else {}))
    runs = n * (d + 2) if d else 1
    c.check_cost(args, file.scenario, samples=args.samples, runs=runs, outputs=False)


def _print_top(result):
    """Per statistic, the parameters ranked by their aggregated total index (the
    share of the statistic's variance over the sweep they explain; see
    SensitivityResult.aggregated): never above 1, and points where the statistic
    hardly varies do not count."""
    agg = result.aggregated()
    for stat, sub in agg.groupby("statistic", sort=False):
        ranked = ", ".join(
            f"{p} {v:.2f}" if math.isfinite(v) else f"{p} -"
            for p, v in zip(sub["parameter"], sub["ST"], strict=True)
        )
        points = int(sub["points"].max()) if len(sub) else 0
        if points == 0:  # S1, ST undefined everywhere (docs/sensitivity.md, Output)
            print(
                f"  {stat}: does not vary over the design at any sweep point "
                "(or is not finite there): no index (empty in sensitivity.csv)"
            )
            continue
        print(f"  {stat}: ST over {points} sweep point(s)  {ranked}")
