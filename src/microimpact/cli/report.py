"""``microimpact report OUT``: figures and report.html again, from results.nc."""

from __future__ import annotations

from pathlib import Path

from . import _common as c

HELP = "rebuild the figures and report.html of a run folder from its results.nc"


def cli_parse(sp):
    sp.add_argument("out", type=Path, help="run folder (holding results.nc)")
    sp.add_argument(
        "--formats", type=c.formats, default=None, help="figure formats (png,pdf)"
    )
    sp.add_argument("--no-figures", action="store_true", help="report only")
    sp.add_argument(
        "--experiments",
        type=Path,
        nargs="+",
        default=(),
        metavar="CSV",
        help="experiment files to draw and compare with (default: those the run "
        "compared with, kept in its folder as experiments.csv)",
    )


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from .._core.formats import DEFAULT_FIGURE_FORMATS

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..pipeline.study import Study

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.outputs import Outputs

    study = Study.from_folder(args.out)  # the run's settings and experiments
    o = study.outputs
    figures = (
        () if args.no_figures else (args.formats or o.figures or DEFAULT_FIGURE_FORMATS)
    )
    study.outputs = Outputs(
        figures=figures,
        report=True,
        experiments=tuple(args.experiments) or o.experiments,
        distribution_speed_m_s=o.distribution_speed_m_s,
    )
    folder = args.out if args.out.is_dir() else args.out.parent
    study.write(folder, parts=("figures", "report"))
    print(f"-> {folder / 'report.html'}")
    return c.EXIT_OK
