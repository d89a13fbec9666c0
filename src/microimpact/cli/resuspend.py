"""``microimpact resuspend SCENARIO --out DIR``: what stays stuck after capture."""

from __future__ import annotations

from . import _common as c

HELP = "resuspend the deposited particles by a friction-velocity ramp (Rock'n'Roll)"


def cli_parse(sp):
    sp.add_argument(
        "scenario", help="scenario TOML file (or preset) with a [resuspension] table"
    )
    sp.add_argument("--out", required=True, type=c.out_dir, help="output folder")
    sp.add_argument(
        "--samples", type=c.count, help="impacts per point and diameter class"
    )
    sp.add_argument("--seed", type=c.nonneg_int, help="root seed (overrides the file)")


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..analysis.resuspension import resuspend

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..pipeline.folder import OutputFolder

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..pipeline.resuspension import write_resuspension

    result = resuspend(args.scenario, samples=args.samples, seed=args.seed)
    with OutputFolder(args.out) as folder:
        write_resuspension(result, folder.path)
    c.say(args, f"{result!r} -> {args.out}")
    return c.EXIT_OK
