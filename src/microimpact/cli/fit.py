"""``microimpact fit DATA``: least-squares k1, k2, v_c from impact data."""

from __future__ import annotations

import json
from pathlib import Path

from . import _common as c
from .sizes import _data_of

HELP = "least-squares k1, k2, v_c against diameter from impact data"


def cli_parse(sp):
    sp.add_argument("data", type=Path, help="CSV: diameter_um, v_n_m_s, e")
    sp.add_argument("--out", type=c.out_dir, default=None)
    sp.add_argument(
        "--form", choices=("power", "polynomial", "constant"), default="power"
    )


def cli_action(args) -> int:
    from ..io.impact_data import read_impact_data
    from ..physics.fitting import fit_coefficient_laws, fit_impact_coefficients

    data = read_impact_data(args.data)
    with _data_of(args.data):
        table = fit_impact_coefficients(
            data["diameter"].to_numpy(), data["v_n"].to_numpy(), data["e"].to_numpy()
        )
        laws = fit_coefficient_laws(table, form=args.form)
    print(table.to_string(index=False))
    print(json.dumps(laws.describe(), indent=2, default=str))
    if args.out is not None:
        c.write_outputs(
            args.out,
            tables={"coefficients_by_diameter.csv": table},
            texts={
                "coefficient_laws.json": json.dumps(
                    laws.describe(), indent=2, default=str
                )
            },
        )
    return c.EXIT_OK
