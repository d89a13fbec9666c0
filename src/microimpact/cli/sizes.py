"""``microimpact sizes DATA``: fit diameters, the chi-squared test, Fig. 2."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path

from ..errors import DataFormatError
from . import _common as c

HELP = "fit measured diameters (normal, log-normal), chi-squared test, plot"


def cli_parse(sp):
    from ..units import LENGTH_UNITS

    units = tuple(LENGTH_UNITS)
    sp.add_argument("data", type=Path)
    sp.add_argument("--out", type=c.out_dir, default=None)
    sp.add_argument("--column", default=None, help="column name or 0-based index")
    sp.add_argument(
        "--unit",
        default="um",
        choices=units,
        metavar="UNIT",
        help=f"length unit of the data, one of {', '.join(units)} (default um)",
    )
    sp.add_argument("--alpha", type=c.fraction, default=0.05)


@contextlib.contextmanager
def _data_of(path):
    """Report a ``ValueError`` raised while analysing the data of file `path` (too
    few values, all equal, ...) as an error of that file."""
    try:
        yield
    except ValueError as exc:
        raise DataFormatError(str(exc), source=path) from None


def cli_action(args) -> int:
    from ..io.diameters import read_diameters
    from ..population.distributions import chi2_normality, fit_lognormal, fit_normal
    from ..units import m_to_um

    column = args.column
    with contextlib.suppress(TypeError, ValueError):
        column = int(column)  # a 0-based index (negative from the end), else a name
    diameters, _meta = read_diameters(args.data, column=column, unit=args.unit)
    d_um = m_to_um(diameters)
    with _data_of(args.data):
        normal, lognormal = fit_normal(d_um), fit_lognormal(d_um)
        chi = chi2_normality(d_um, alpha=args.alpha)
    print(f"{args.data}: n = {d_um.size}")
    print(f"  normal fit     : {normal}")
    print(f"  log-normal fit : {lognormal}")
    print(
        f"  chi-squared    : statistic {chi.statistic:.3f}, dof {chi.dof}, "
        f"p = {chi.pvalue:.4g} -> {chi.decision} (alpha {args.alpha})"
    )
    if args.out is not None:
        from ..plotting.sizes import plot_size_distribution

        report = {
            "n": int(d_um.size),
            "normal": str(normal),
            "lognormal": str(lognormal),
            "chi2": {
                "statistic": chi.statistic,
                "dof": chi.dof,
                "pvalue": chi.pvalue,
                "reject": bool(chi.reject),
                "decision": chi.decision,
                "alpha": args.alpha,
            },
        }
        c.write_outputs(
            args.out,
            texts={"sizes.json": json.dumps(report, indent=2, default=str)},
            figures={
                "size_distribution": lambda: plot_size_distribution(
                    d_um, fit=getattr(normal, "distribution", None)
                )
            },
        )
    return c.EXIT_OK
