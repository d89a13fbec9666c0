"""``microimpact compare RESULTS EXPERIMENT``: simulation against experiment."""

from __future__ import annotations

from pathlib import Path

from . import _common as c

HELP = "compare a run with experimental means at the 95 %% level"


def cli_parse(sp):
    sp.add_argument("results", type=Path, help="summary.csv, results.nc or run folder")
    sp.add_argument("experiment", type=Path, help="experimental CSV")
    sp.add_argument("--out", type=c.out_dir, default=None)
    sp.add_argument("--confidence", type=c.fraction, default=0.95)


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..analysis.compare import compare

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..io.experiments import read_experiments

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..plotting.comparison import plot_comparison

    summary = _read_results(args.results)
    exp = read_experiments(args.experiment)
    table = compare(summary, exp, confidence=args.confidence)
    print(table.to_string(index=False))
    compared = table["compared"]
    n_agree = int((table["agree"] & compared).sum())
    n_compared = int(compared.sum())
    if n_compared:
        print(
            f"{n_agree} of {n_compared} compared points agree at the "
            f"{args.confidence:.0%} confidence level"
        )
    for _, row in table[~compared].iterrows():
        print(
            f"line {row['line']} ({row['statistic']}, {row['surface']}, "
            f"{row['speed_m_s']:g} m/s, {row['angle_deg']:g} deg): "
            f"{row['note']}"
        )
    if not n_compared:
        print(f"none of the {len(table)} points was compared: no figure is drawn")
    if args.out is not None:
        figures = {"comparison": lambda: plot_comparison(table)} if n_compared else {}
        c.write_outputs(args.out, tables={"comparison.csv": table}, figures=figures)
    return c.EXIT_OK


def _read_results(path: Path):
    """The summary table of a run folder, results.nc or summary.csv."""
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..engine.result import open_result

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..errors import InputError

    if path.is_dir() or path.suffix == ".nc":
        return open_result(path).summary
    if not path.exists():
        raise InputError(
            "no such results file (give summary.csv, results.nc or a run folder)",
            source=path,
        )
    try:
        return pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise InputError(f"cannot read results: {err}", source=path) from None
