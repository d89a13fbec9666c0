"""``microimpact sizes DATA``: fit diameters or size bins, the chi-squared tests,
Fig. 2.

DATA is raw diameters or a binned export (APS, SMPS, OPC: edges or midpoints with
counts, dN/dlogDp, dM/dlogDp, ...; a TSI AIM column or row export; a wide time
series), detected from the header (:func:`microimpact.io.read_size_data`;
``--layout``/``--values``/``--column``/``--unit``/``--sample``/``--edges-um``
settle what is ambiguous; ``--sampled-volume-cm3`` turns number concentrations
into counted particles for the standard errors and the chi-squared test). Prints
which of the normal and log-normal populations fits better (AIC) and what the
chi-squared test says of each; for bins also the count and mass median diameters
and, with ``--density-kg-m3``, the aerodynamic ones.
``--json`` prints the report as JSON instead. With ``--out`` writes ``sizes.json``
(standard JSON, schema in docs/populations.md), ``particles.toml`` (the recommended
``[particles]`` table, ready to paste into a scenario) and the figure.
"""

from __future__ import annotations

import argparse
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
    sp.add_argument(
        "--column",
        default=None,
        help="column name or 0-based index: the diameters, or for size bins the "
        "value column when there are several",
    )
    sp.add_argument(
        "--layout",
        default=None,
        choices=("diameters", "edges", "midpoints"),
        help="raw diameters, bins given by lower/upper edges, or bins given by "
        "midpoints (default: detected from the header)",
    )
    sp.add_argument(
        "--values",
        default=None,
        metavar="KIND",
        help="what the bin values are: count, dN, dN/dlogDp, dN/dlnDp, dN/dDp, "
        "mass, dM/dlogDp, dM/dDp, volume, dV/dlogDp, dV/dDp, ... (default: the "
        "value column's name)",
    )
    sp.add_argument(
        "--sample",
        default=None,
        metavar="N|A..B|mean|sum",
        help="an export holding several samples (TSI AIM column or row export, a "
        "wide time series): the Sample # (else the row number) to read, 'A..B' for "
        "the mean of samples A to B (A, B also ISO 8601 times for a log with a "
        "timestamp column), 'sum A..B', or 'mean'/'sum' of all",
    )
    sp.add_argument(
        "--edges-um",
        type=edges_arg,
        default=None,
        metavar="B0,B1,...",
        help="the bin boundaries [um] of a wide export whose bin columns do not give "
        "sizes (bin0, bin1, ...): one more than the bins",
    )
    sp.add_argument(
        "--sampled-volume-cm3",
        type=c.positive_float,
        default=None,
        metavar="V",
        help="air volume [cm3] in which one sample's particles were counted: turns "
        "number concentrations into counted particles, for standard errors and the "
        "chi-squared test (assumes Poisson counting; see docs/populations.md)",
    )
    sp.add_argument(
        "--density-kg-m3",
        type=c.positive_float,
        default=None,
        help="particle density: also report aerodynamic diameters (size bins)",
    )
    sp.add_argument(
        "--shape-factor",
        type=c.positive_float,
        default=1.0,
        help="dynamic shape factor for the aerodynamic diameter (default 1: spheres)",
    )
    sp.add_argument(
        "--json", action="store_true", help="print the report as JSON, not text"
    )
    sp.add_argument(
        "--unit",
        default=None,
        choices=units,
        metavar="UNIT",
        help=f"length unit of the data, one of {', '.join(units)} (default: the "
        "unit the column's header names, e.g. diameter_um, else um)",
    )
    sp.add_argument("--alpha", type=c.fraction, default=0.05)


def edges_arg(text):
    """An ``--edges-um`` value: comma-separated numbers (checked by the reader)."""
    cells = [t.strip() for t in text.replace(";", ",").split(",") if t.strip()]
    try:
        return [float(t) for t in cells]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a list of numbers; allowed: comma-separated bin "
            "boundaries in um, e.g. 0.35,0.46,0.66"
        ) from None


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
    from ..io.size_bins import read_size_data

    column = column_arg(args.column) if args.column is not None else None
    data, meta = read_size_data(
        args.data,
        layout=args.layout,
        values=args.values,
        column=column,
        unit=args.unit,
        sample=args.sample,
        sampled_volume_cm3=args.sampled_volume_cm3,
        edges_um=args.edges_um,
        syntax="cli",
    )
    if meta["layout"] == "diameters":
        if args.density_kg_m3 is not None:
            raise DataFormatError(
                "--density-kg-m3 needs size bins (an APS/SMPS/OPC export); the "
                "file holds raw diameters",
                source=args.data,
                field="--density-kg-m3",
            )
        return _diameters(args, data, meta, column)
    return _bins(args, data)


def _print(args, report, **ref):
    if args.json:
        print(report.to_json(**ref))
    else:
        print(f"{args.data}: {report.summary()}")


def _diameters(args, diameters, meta, column) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..population.sizes_report import describe_sizes

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..units import m_to_um

    d_um = m_to_um(diameters)
    with _data_of(args.data):
        report = describe_sizes(d_um, alpha=args.alpha, source=args.data)
    ref = {"file": str(Path(args.data).resolve()), "unit": meta["unit"]}
    if column is not None:
        ref["column"] = meta["column"]
    _print(args, report, **ref)
    if args.out is not None:
        fit = report.better_fit if report.recommended == "empirical" else None
        _write(args, report, d_um, fit or report.recommended, ref)
    return c.EXIT_OK


def _bins(args, bins) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..population.binned_report import describe_binned_sizes

    with _data_of(args.data):
        report = describe_binned_sizes(
            bins,
            alpha=args.alpha,
            density_kg_m3=args.density_kg_m3,
            shape_factor=args.shape_factor,
            source=args.data,
        )
    _print(args, report)
    if args.out is not None:
        fit = report.lognormal if report.better_fit == "lognormal" else report.normal
        _write(args, report, bins.histogram(), fit.distribution, {})
    return c.EXIT_OK


def _write(args, report, data, fit, ref) -> None:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..plotting.sizes import plot_size_distribution

    c.write_outputs(
        args.out,
        texts={
            "sizes.json": report.to_json(**ref),
            "particles.toml": report.particles_toml(**ref),
        },
        figures={"size_distribution": lambda: plot_size_distribution(data, fit=fit)},
    )
