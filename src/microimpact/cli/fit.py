"""``microimpact fit DATA``: least-squares k1, k2, v_c from impact data.

Refuses (exit 2, one line) when the data cannot identify the coefficients (e.g.
every impact at one speed); a coefficient not identified at some diameters is
reported as NaN with a ``*_identified`` flag and a warning, and its law is fitted
on the other diameters. With ``--out`` writes ``coefficients_by_diameter.csv``,
``coefficient_laws.json`` (standard JSON, schema in docs/adhesion.md) and
``coefficients.toml`` (the ``[coefficients]`` table, ready to paste into a
scenario).
"""

from __future__ import annotations

from pathlib import Path

from ..errors import DataFormatError
from . import _common as c
from .sizes import _data_of

HELP = "least-squares k1, k2, v_c against diameter from impact data"

#: Impacts a diameter needs for its own k1, k2, v_c fit.
MIN_IMPACTS = 5


def cli_parse(sp):
    sp.add_argument("data", type=Path, help="CSV: diameter_um, v_n_m_s, e")
    sp.add_argument("--out", type=c.out_dir, default=None)
    sp.add_argument(
        "--form", choices=("power", "polynomial", "constant"), default="power"
    )


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..io.impact_data import read_impact_data

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..physics.fitting import (
        IdentifiabilityError,
        coefficient_laws_fit,
        fit_impact_coefficients,
    )

    data = read_impact_data(args.data)
    try:
        with _data_of(args.data):
            table = fit_impact_coefficients(
                data["diameter"].to_numpy(),
                data["v_n"].to_numpy(),
                data["e"].to_numpy(),
                min_points=MIN_IMPACTS,
            )
            if len(table) == 0:
                raise DataFormatError(_too_few(data["diameter"]), source=args.data)
            result = coefficient_laws_fit(table, form=args.form)
    except IdentifiabilityError as exc:
        raise IdentifiabilityError(
            exc.message, source=args.data, field=exc.field
        ) from None
    print(table.to_string(index=False, na_rep="not identified"))
    print()
    print(result.toml(), end="")
    if args.out is not None:
        c.write_outputs(
            args.out,
            tables={"coefficients_by_diameter.csv": table},
            texts={
                "coefficient_laws.json": result.to_json(),
                "coefficients.toml": result.toml(),
            },
        )
    return c.EXIT_OK


def _too_few(diameter_m) -> str:
    """Why no diameter could be fitted: the impacts each diameter has."""
    counts = diameter_m.value_counts().sort_index()
    shown = ", ".join(f"{d * 1e6:g} um: {n}" for d, n in counts.iloc[:8].items())
    more = f" and {len(counts) - 8} more" if len(counts) > 8 else ""
    return (
        f"no diameter has the {MIN_IMPACTS} or more impacts (rows) its k1, k2, v_c "
        f"fit needs; impacts per diameter_um: {shown}{more}; allowed: at least "
        f"{MIN_IMPACTS} impacts at several speeds for each diameter"
    )
