"""``microimpact sizes DATA``: fit diameters, the chi-squared tests, Fig. 2.

Prints which of the normal and log-normal populations fits better (AIC) and what
the paper's chi-squared test says of each; with ``--out`` writes ``sizes.json``
(standard JSON, schema in docs/populations.md), ``particles.toml`` (the recommended
``[particles]`` table, ready to paste into a scenario) and the figure.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from ..errors import DataFormatError
from . import _common as c

HELP = "fit measured diameters (normal, log-normal), chi-squared test, plot"


def cli_parse(sp):
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..units import LENGTH_UNITS

    units = tuple(LENGTH_UNITS)
    sp.add_argument("data", type=Path)
    sp.add_argument("--out", type=c.out_dir, default=None)
    sp.add_argument("--column", default=None, help="column name or 0-based index")
    sp.add_argument(
        "--unit",
        default=None,
        choices=units,
        metavar="UNIT",
        help=f"length unit of the data, one of {', '.join(units)} (default: the "
        "unit the column's header names, e.g. diameter_um, else um)",
    )
    sp.add_argument("--alpha", type=c.fraction, default=0.05)


def column_arg(text):
    """A ``--column`` value: a 0-based index (negative from the end), else a name."""
    with contextlib.suppress(TypeError, ValueError):
        return int(text)
    return text


@contextlib.contextmanager
def _data_of(path):
    """Report a ``ValueError`` raised while analysing the data of file `path` (too
    few values, all equal, ...) as an error of that file."""
    try:
        yield
    except DataFormatError:
        raise
    except ValueError as exc:
        raise DataFormatError(str(exc), source=path) from None


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..io.diameters import read_diameters

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..population.sizes_report import describe_sizes

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..units import m_to_um

    column = column_arg(args.column) if args.column is not None else None
    diameters, meta = read_diameters(args.data, column=column, unit=args.unit)
    d_um = m_to_um(diameters)
    with _data_of(args.data):
        report = describe_sizes(d_um, alpha=args.alpha, source=args.data)
    print(f"{args.data}: {report.summary()}")
    if args.out is not None:
        # deferred: the verb's library loads only when the verb runs (fast --help)
        from ..plotting.sizes import plot_size_distribution

        ref = {"file": str(Path(args.data).resolve()), "unit": meta["unit"]}
        if column is not None:
            ref["column"] = meta["column"]
        snippet = report.particles_toml(**ref)
        c.write_outputs(
            args.out,
            texts={
                "sizes.json": report.to_json(**ref),
                "particles.toml": snippet,
            },
            figures={
                "size_distribution": lambda: plot_size_distribution(
                    d_um,
                    fit=report.better_fit
                    if report.recommended == "empirical"
                    else report.recommended,
                )
            },
        )
    return c.EXIT_OK
