"""Read impact measurements (diameter, normal impact speed, restitution) from CSV.

File format: UTF-8 CSV, comma-separated, with one header row naming at least the
columns ``diameter_um`` (particle diameter [µm]), ``v_n_m_s`` (normal impact
speed [m s⁻¹], a positive magnitude) and ``e`` (coefficient of restitution [-],
0 for a captured particle). Other columns are ignored. Blank lines and lines
whose first non-blank character is ``#`` are skipped::

    # SST65 on silicon, Li et al. (1999)
    diameter_um,v_n_m_s,e,run
    52.8,1.20,0.81,a
    52.8,0.15,0.00,a
"""

from __future__ import annotations

import math
import os

import numpy as np

from .._files import csv_cells, data_lines, read_lines
from .._validation import did_you_mean
from ..errors import DataFormatError
from ..units import um_to_m

__all__ = ["E_MAX", "REQUIRED_COLUMNS", "read_impact_data"]

#: Columns that must be present in the header.
REQUIRED_COLUMNS = ("diameter_um", "v_n_m_s", "e")
#: Largest accepted restitution coefficient; values a little above 1 occur on
#: rough surfaces (apparent e, [1] Eq. 8), larger ones are taken as typos.
E_MAX = 1.5


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
        required column is absent, or a cell is missing, non-numeric or not
        finite, a diameter is <= 0, a speed is negative, or ``e`` lies outside
        ``[0, 1.5]``.
    """
    import pandas as pd

    source = os.fspath(path)
    lines = data_lines(read_lines(source, error=DataFormatError))
    if not lines:
        raise DataFormatError(
            "no header found; expected a header with columns "
            f"{', '.join(REQUIRED_COLUMNS)}.",
            source=source,
        )
    (header_line, header_text), body = lines[0], lines[1:]
    cells = csv_cells(header_text, source=source, line=header_line)
    header = [h.strip() for h in cells]
    index = {}
    for col in REQUIRED_COLUMNS:
        if col not in header:
            raise DataFormatError(
                f"required column missing; header has {header}, required "
                f"{list(REQUIRED_COLUMNS)}{did_you_mean(col, header)}.",
                source=source,
                line=header_line,
                field=col,
            )
        index[col] = header.index(col)
    if not body:
        raise DataFormatError(
            "no data rows after the header.", source=source, line=header_line
        )

    out = np.empty((len(body), 3))
    for row_no, (lineno, text) in enumerate(body):
        cells = csv_cells(text, source=source, line=lineno)
        for j, col in enumerate(REQUIRED_COLUMNS):
            k = index[col]
            cell = cells[k].strip() if k < len(cells) else ""
            if cell == "":
                raise DataFormatError(
                    "missing value; a number is required.",
                    source=source,
                    line=lineno,
                    field=col,
                )
            try:
                value = float(cell)
            except ValueError:
                raise DataFormatError(
                    f"non-numeric value {cell!r}; a number is required.",
                    source=source,
                    line=lineno,
                    field=col,
                ) from None
            if not math.isfinite(value):
                problem = "a finite number is required"
            elif col == "diameter_um" and value <= 0:
                problem = "a diameter > 0 [um] is required"
            elif col == "v_n_m_s" and value < 0:
                problem = "the normal impact speed must be a magnitude >= 0 [m/s]"
            elif col == "e" and not 0 <= value <= E_MAX:
                problem = f"e must lie in [0, {E_MAX}]"
            else:
                out[row_no, j] = value
                continue
            raise DataFormatError(
                f"bad value {cell!r}; {problem}.", source=source, line=lineno, field=col
            )
    table = pd.DataFrame(
        {"diameter": um_to_m(out[:, 0]), "v_n": out[:, 1], "e": out[:, 2]}
    )
    table.attrs["source"] = source
    return table
