"""``microimpact convergence SCENARIO``: the paper's convergence study."""

from __future__ import annotations

import warnings

from . import _common as c

HELP = "the paper's convergence study: running capture fraction against N"


def cli_parse(sp):
    sp.add_argument("scenario", help="scenario TOML file or preset name")
    sp.add_argument("--out", type=c.out_dir, default=None)
    sp.add_argument(
        "--point",
        type=c.nonneg_int,
        default=None,
        help="sweep-point index (default: the one nearest 50 %% capture)",
    )
    sp.add_argument("--n-max", type=c.count, default=20_000)
    sp.add_argument("--tolerance", type=c.fraction, default=0.03)
    sp.add_argument("--seed", type=c.nonneg_int)
    c.add_yes_option(sp)


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..engine.convergence import convergence_study

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..engine.montecarlo import run

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..errors import InputError

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.grid import SweepGrid

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.scenario import as_scenario

    scenario = as_scenario(args.scenario)
    point = args.point
    n_points = SweepGrid.from_scenario(scenario).size
    if point is None:  # the point nearest 50 % capture in a quick pilot
        c.check_cost(args, scenario, samples=1000, outputs=False, samples_flag=None)
        pilot = run(scenario, samples=1000, seed=args.seed, progress=False).summary
        frac = pilot["capture_fraction"]
        point = int((frac - 0.5).abs().to_numpy().argmin())
        if frac.isin((0.0, 1.0)).all():
            warnings.warn(
                "capture is 0 or 1 at every sweep point of a 1,000-impact pilot, so "
                f"point {point} has nothing to converge (its fraction never varies); "
                "sweep the capture transition, or choose a point with --point",
                stacklevel=1,
            )
    elif point >= n_points:
        raise InputError(
            f"must be < {n_points} (the number of sweep points)", field="--point"
        )
    # the study plans the whole sweep and runs one point
    c.check_cost(
        args,
        scenario,
        samples=args.n_max,
        outputs=False,
        simulated=1,
        samples_flag="--n-max",
    )
    res = convergence_study(
        scenario,
        point=point,
        n_max=args.n_max,
        tolerance=args.tolerance,
        seed=args.seed,
    )
    pt = res.point
    print(
        f"{scenario.name}: point {point} ({pt['surface']}, {pt['speed_m_s']} m/s, "
        f"{pt['angle_deg']} deg)"
    )
    print(f"  capture fraction after {args.n_max} impacts: {res.final:.4f}")
    print(f"  settled within +-{res.tolerance:.3f} after N = {res.n_settled}")
    print(
        f"  N for a {res.confidence:.0%} half-width of {res.tolerance:.3f}: "
        f"{res.n_required} (worst case {res.n_required_worst_case})"
    )
    if args.out is not None:
        # deferred: the verb's library loads only when the verb runs (fast --help)
        from ..plotting.results import plot_convergence

        c.write_outputs(
            args.out,
            tables={"convergence.csv": res.table},
            figures={"convergence": lambda: plot_convergence(res)},
        )
    return c.EXIT_OK
