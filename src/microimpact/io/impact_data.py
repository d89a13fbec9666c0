"""Read impact measurements (diameter, normal impact speed, restitution) from CSV.

File format: UTF-8 delimited text with one header row naming at least the
columns ``diameter_um`` (particle diameter [µm]), ``v_n_m_s`` (normal impact
speed [m s⁻¹], a positive magnitude) and ``e`` (coefficient of restitution [-],
0 for a captured particle); column names are matched case-insensitively and may
appear once. Other columns are ignored. The delimiter rules are those of every reader
of the package (:mod:`microimpact._core.files`): ``;``, tab, ``,`` or whitespace,
sniffed from the header line outside quotes. Cells may be quoted; the decimal separator
is
``.`` (a row with more cells than the header is an error). Blank lines, lines whose
first non-blank character is ``#`` and trailing ``# ...`` comments are skipped::

    # SST65 on silicon, Li et al. (1999)
    diameter_um,v_n_m_s,e,run
    52.8,1.20,0.81,a
    52.8,0.15,0.00,a
"""

from __future__ import annotations

import numpy as np

from .._core.files import parse_number, read_table
from ..errors import DataFormatError
from ..units import um_to_m

__all__ = ["E_MAX", "REQUIRED_COLUMNS", "read_impact_data"]

#: Columns that must be present in the header.
REQUIRED_COLUMNS = ("diameter_um", "v_n_m_s", "e")
#: Largest accepted restitution coefficient; values a little above 1 occur on
#: rough surfaces (apparent e, [1] Eq. 8), larger ones are taken as typos.
E_MAX = 1.5
#: (allowed, test) per column, for the error messages.
_RULES = {
    "diameter_um": ("a finite diameter > 0 [um]", lambda v: v > 0),
    "v_n_m_s": (
        "a finite normal impact speed >= 0 [m/s] (a magnitude)",
        lambda v: v >= 0,
    ),
    "e": (f"a finite e in [0, {E_MAX}]", lambda v: 0 <= v <= E_MAX),
}


def read_impact_data(path):
    """Read a CSV of impact measurements into SI units.

    Parameters
    ----------
    path : str or path-like
        The CSV file (format in the module docstring).

    Returns
    -------
    pandas.DataFrame
        Columns ``diameter`` [m], ``v_n`` [m s⁻¹] and ``e`` [-], one row per data
        line, in file order; ``attrs["source"]`` is the path.

    Raises
    ------
    DataFormatError
        Naming file, line, column and value, if the file is missing or empty, a
        required column is absent or a column duplicated, a row has more cells
        than the header, or a cell is missing, non-numeric or not
        finite, a diameter is <= 0, a speed is negative, or ``e`` lies outside
        ``[0, 1.5]``.
    """
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    table = read_table(path, REQUIRED_COLUMNS, error=DataFormatError)
    out = np.empty((len(table.rows), 3))
    for row_no, (lineno, cells) in enumerate(table.rows):
        for j, col in enumerate(REQUIRED_COLUMNS):
            allowed, ok = _RULES[col]
            out[row_no, j] = parse_number(
                table.cell(cells, table.index[col]),
                source=table.source,
                line=lineno,
                field=col,
                allowed=allowed,
                ok=ok,
            )
    frame = pd.DataFrame(
        {"diameter": um_to_m(out[:, 0]), "v_n": out[:, 1], "e": out[:, 2]}
    )
    frame.attrs["source"] = table.source
    return frame
