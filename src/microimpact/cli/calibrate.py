"""``microimpact calibrate SCENARIO EXPERIMENTS --parameter KEY[=LOW:HIGH] --out DIR``:
fit scenario parameters to measured rebound statistics (docs/calibration.md)."""

from __future__ import annotations

import time

from . import _common as c

HELP = "fit scenario parameters (dotted keys) to measured e, mu or capture"


def cli_parse(sp):
    sp.add_argument("scenario", help="scenario TOML file or preset name")
    sp.add_argument(
        "experiments",
        nargs="+",
        help="experiment CSV (speed_m_s/angle_deg, statistic, mean, interval); "
        "with --method bayes also capture counts (captured, n) or per-impact "
        "rebounds (e), several files allowed",
    )
    sp.add_argument(
        "--parameter",
        action="append",
        required=True,
        metavar="KEY[=LOW:HIGH]",
        help="a number of the scenario by its dotted key, e.g. "
        "surfaces.formica.std_deg or coefficients.v_c.a_m_s=0.05:1 (repeat the "
        "flag for several; default bounds: docs/calibration.md)",
    )
    sp.add_argument("--out", required=True, type=c.out_dir, help="output folder")
    sp.add_argument(
        "--samples", type=c.count, help="impacts per sweep point of every model run"
    )
    sp.add_argument(
        "--bootstrap",
        type=c.nonneg_int,
        default=100,
        help="parametric bootstrap refits (default 100; 0: none)",
    )
    sp.add_argument(
        "--confidence",
        type=c.fraction,
        default=0.95,
        help="level of the intervals (default 0.95)",
    )
    sp.add_argument("--seed", type=c.nonneg_int, help="engine seed of every model run")
    sp.add_argument(
        "--workers",
        type=c.positive_int,
        default=1,
        help="workers for the model runs (default 1; capped at the cores)",
    )
    c.add_backend_options(sp)
    c.add_yes_option(sp)
    sp.add_argument(
        "--method",
        choices=("lsq", "bayes"),
        default="lsq",
        help="lsq: least squares (default); bayes: the posterior by MCMC (emcee), "
        "priors uniform over the bounds or from the scenario's [calibration] table",
    )
    sp.add_argument(
        "--walkers",
        type=c.positive_int,
        help="bayes: ensemble walkers (default max(8, 4 x parameters))",
    )
    sp.add_argument(
        "--steps",
        type=c.positive_int,
        default=5000,
        help="bayes: the most MCMC steps; the run stops once converged (default 5000)",
    )
    sp.add_argument("--no-figures", action="store_true", help="write no figure")
    sp.add_argument("--quiet", action="store_true", help="print nothing but errors")


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..analysis.calibration import parse_parameter

    parameters = {}
    for text in args.parameter:
        key, bounds = parse_parameter(text)
        if key in parameters:
            # deferred: the verb's library loads only when the verb runs (fast --help)
            from ..errors import InputError

            raise InputError(f"{key!r} is given twice", field="--parameter")
        parameters[key] = bounds
    _check_cost(args)
    t0 = time.perf_counter()
    if args.method == "bayes":
        return _bayes(args, parameters, t0)
    if len(args.experiments) > 1:
        # deferred: the verb's library loads only when the verb runs (fast --help)
        from ..errors import InputError

        raise InputError(
            "least squares takes one experiment file; several need --method bayes",
            field="experiments",
        )
    if args.walkers is not None or args.steps != 5000:
        # deferred: the verb's library loads only when the verb runs (fast --help)
        from ..errors import InputError

        raise InputError("only with --method bayes", field="--walkers/--steps")
    args.experiments = args.experiments[0]
    result = _calibrate(args, parameters, bootstrap=args.bootstrap)
    result.write(args.out, figure=not args.no_figures)
    if not args.quiet:
        for k, key in enumerate(result.keys):
            if result.identifiable[k]:
                print(
                    f"  {key} = {result.estimate[k]:.5g} "
                    f"[{result.ci_low[k]:.4g}, {result.ci_high[k]:.4g}]"
                )
            else:
                print(f"  {key}: not identifiable ({result.reasons[k]})")
        p = result.p_value
        print(
            f"  chi2 = {result.chi2:.4g}, dof = {result.dof}"
            + (f", p = {p:.3g}" if p == p else "")
            + f"; {time.perf_counter() - t0:.1f} s -> {args.out}"
        )
    return c.EXIT_OK


def _calibrate(args, parameters, **method):
    """The library call both methods share, with the method's own keywords."""
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..analysis.calibration import calibrate

    with c.executor_of(args) as executor:
        return calibrate(
            args.scenario,
            args.experiments,
            parameters,
            samples=args.samples,
            seed=args.seed,
            workers=args.workers,
            executor=executor,
            confidence=args.confidence,
            progress=False if args.quiet else None,
            **method,
        )


def _check_cost(args):
    """One model run's cost before any (the search runs the model many times; each
    run is checked for memory and files, the search's length is its own)."""
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..errors import InputError
    from ..scenario.scenario import read_scenario

    try:
        scenario = read_scenario(args.scenario).scenario
    except InputError:
        return  # calibrate reads the file again and says what is wrong with it
    c.check_cost(args, scenario, samples=args.samples, outputs=False)


def _bayes(args, parameters, t0) -> int:
    """``--method bayes``: the posterior, its files and the terminal summary."""
    # deferred: the verb's library loads only when the verb runs (fast --help)

    result = _calibrate(
        args, parameters, method="bayes", walkers=args.walkers, steps=args.steps
    )
    result.write(args.out, figure=not args.no_figures)
    # deferred: the pipeline (matplotlib) loads only for the Bayesian report page
    from ..pipeline.report import write_section_page

    write_section_page(
        args.out / "report.html",
        "microimpact report: Bayesian calibration",
        result.report_html(figures_dir=""),
    )
    if not args.quiet:
        for line in result.summary_lines():
            print(line)
        print(f"  {time.perf_counter() - t0:.1f} s -> {args.out}")
    return c.EXIT_OK
