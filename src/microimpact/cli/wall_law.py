"""``microimpact wall-law SCENARIO --out DIR``: a stochastic wall law for CFD."""

from __future__ import annotations

import dataclasses
import sys
import time

from . import _common as c

HELP = "tabulate a stochastic wall law (NetCDF, CSV, C sampler, OpenFOAM)"

#: The families of --demo-family (wall_law.openfoam_stochastic.DEMO_FAMILIES's
#: keys, written out so that --help loads no library).
DEMO_FAMILIES = ("kinematic", "mppic", "reacting")
#: Folder (in --out) keeping finished diameters of an interrupted build.
CHECKPOINT_DIR = ".microimpact-wall-law-checkpoint"


def cli_parse(sp):
    sp.add_argument("scenario", help="scenario TOML file with a [wall_law] table")
    sp.add_argument("--out", required=True, type=c.out_dir, help="output folder")
    sp.add_argument("--samples", type=c.count, help="draws per node")
    sp.add_argument("--reservoir", type=c.count, help="rebound samples kept per node")
    sp.add_argument("--seed", type=c.nonneg_int, help="root seed (overrides the file)")
    sp.add_argument(
        "--workers",
        type=c.positive_int,
        default=1,
        help="worker processes (default 1; capped at the number of cores)",
    )
    c.add_backend_options(sp)  # --scheduler alone implies --backend dask
    for flag, what in (
        ("--diameter-um", "diameter [um]"),
        ("--speed-m-s", "speed [m/s]"),
        ("--angle-deg", "incidence angle from the wall [deg]"),
    ):
        sp.add_argument(
            flag,
            type=c.positive_float,
            help=f"{what} of the OpenFOAM constant e and mu (default: mid-table)",
        )
    # ---- issue 36: the wall law of a calibration's posterior ----
    sp.add_argument(
        "--posterior",
        help="posterior.nc of calibrate --method bayes: build the table averaged "
        "over posterior draws of its parameters (docs/calibration.md)",
    )
    sp.add_argument(
        "--draws",
        type=c.positive_int,
        default=20,
        help="posterior draws with --posterior (default 20; one build each)",
    )
    # ---- end issue 36 ----
    sp.add_argument("--no-c", action="store_true", help="write no C sampler")
    sp.add_argument("--no-openfoam", action="store_true", help="no OpenFOAM files")
    sp.add_argument(
        "--demo-family",
        choices=DEMO_FAMILIES,
        help="the solvers of openfoam/demoCase: kinematic "
        "(icoUncoupledKinematicParcelFoam, the default), mppic (MPPICFoam) or "
        "reacting (reactingParcelFoam)",
    )
    sp.add_argument("--quiet", action="store_true", help="no progress")


def cli_action(args) -> int:

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..errors import ScenarioError

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..pipeline.folder import OutputFolder

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.scenario import read_scenario

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..wall_law import build_wall_law

    t0 = time.perf_counter()
    file = read_scenario(args.scenario)  # read once: physics and [wall_law]
    scenario, spec = file.scenario, file.wall_law
    if spec is None:
        raise ScenarioError(
            "has no [wall_law] table (give diameter_um, and optionally speed_m_s, "
            "angle_deg, reservoir, samples; see docs/wall-law.md)",
            source=file.source,
            field="wall_law",
        )
    changes = {k: getattr(args, k) for k in ("samples", "reservoir")}
    spec = dataclasses.replace(spec, **{k: v for k, v in changes.items() if v})
    flags = {
        k: getattr(args, k)
        for k in ("diameter_um", "speed_m_s", "angle_deg")
        if getattr(args, k) is not None
    }
    # the flags win over the file's [wall_law] fallback_at, key by key
    condition = {**(spec.fallback_at or {}), **flags}
    where = {k: f"wall_law.fallback_at.{k}" for k in spec.fallback_at or {}}
    where.update({k: "--" + k.replace("_", "-") for k in flags})
    if flags and args.no_openfoam:
        raise ScenarioError(
            "the condition flags set the OpenFOAM coefficients; drop --no-openfoam",
            field="--no-openfoam",
        )
    if args.demo_family is not None and args.no_openfoam:
        raise ScenarioError(
            "--demo-family sets the OpenFOAM demo case; drop --no-openfoam",
            field="--no-openfoam",
        )
    if condition:
        _check_condition(spec, condition, scenario, where)
    if args.scheduler is not None:  # as before --backend existed here
        args.backend = "dask"

    def progress(done, total):
        if not args.quiet:
            print(f"\r  diameters {done}/{total}", end="", file=sys.stderr, flush=True)

    with OutputFolder(args.out) as folder, c.executor_of(args) as executor:
        if args.posterior is not None:  # issue 36: the posterior mixture
            # deferred: the verb's library loads only when the verb runs (fast --help)
            from ..analysis.wall_law_posterior import posterior_wall_law

            law = posterior_wall_law(
                args.scenario,
                args.posterior,
                draws=args.draws,
                spec=spec,
                seed=args.seed,
                workers=args.workers,
                executor=executor,
            )
        else:
            law = build_wall_law(
                file,
                spec,
                workers=args.workers,
                seed=args.seed,
                executor=executor,
                progress=progress,
                checkpoint=folder.path / CHECKPOINT_DIR,
            )
        if not args.quiet:
            print(file=sys.stderr)
        law.write(
            folder.path,
            c=not args.no_c,
            openfoam=not args.no_openfoam,
            condition=condition or None,
            demo_family=args.demo_family or "kinematic",
        )
    c.say(
        args,
        f"{scenario.name}: wall law {law!r}, seed entropy {law.dataset.attrs['seed']}, "
        f"{time.perf_counter() - t0:.1f} s -> {args.out}",
    )
    c.say(args, _accuracy_line(law))
    return c.EXIT_OK


def _accuracy_line(law) -> str:
    """What the node spacing costs at the capture edge (wall_law/accuracy.py)."""
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..wall_law.accuracy import capture_steps

    steps = [s for s in capture_steps(law) if s.step == s.step]  # not NaN
    if not steps:
        return "capture between nodes: the table has one node on every axis"
    return (
        "capture between nodes may be off by up to "
        + "; ".join(s.describe() for s in steps)
        + ": the largest capture change between neighbouring nodes, which bounds "
        "the interpolation where capture is monotone (plus the nodes' Monte Carlo "
        'noise); add nodes there for less (docs/wall-law.md, "Accuracy between '
        'nodes")'
    )


def _check_condition(spec, condition, scenario, where):
    """Refuse condition flags the table cannot serve, before it is built (on a
    reduced speed axis the speeds are r v_c(d), from the scenario's v_c law)."""
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..errors import InputError

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..wall_law import critical_speed_m_s

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..wall_law.openfoam import fallback_condition

    speeds = spec.speeds_m_s
    if spec.speed_axis == "reduced":
        v_c = critical_speed_m_s(scenario, spec.diameters_um)
        speeds = [[r * float(c) for r in spec.reduced_speeds] for c in v_c]
    coords = {
        "diameter_um": spec.diameters_um,
        "speed_m_s": speeds,
        "angle_deg": spec.angles_deg,
    }
    flag = where
    try:
        chosen = fallback_condition(coords, **condition)
    except ValueError as err:
        bad = next((k for k in condition if f"`{k}`" in str(err)), None)
        raise InputError(
            str(err), field=flag.get(bad, flag.get("angle_deg", "--angle-deg"))
        ) from None
    if "angle_deg" in condition and chosen["angle_deg"][1] >= 90.0:
        raise InputError(
            f"{condition['angle_deg']:g} is nearest the 90 deg node, where the "
            "tangential restitution (OpenFOAM's mu) is undefined; choose an oblique "
            "angle",
            field=flag.get("angle_deg", "--angle-deg"),
        )
