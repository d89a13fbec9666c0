"""Readers for measured particle diameters and diameter histograms.

Accepted text formats
---------------------
Both readers take plain text: comma-, tab-, semicolon- or whitespace-separated
columns (the separator is detected from the first data row; the decimal separator is
``.``), blank lines and lines starting with ``#`` are ignored, and cells may be quoted
(``"5,2"`` is one cell). A row with more cells than the header (or than the first row)
is an error, never cut short: it is usually a decimal comma.

:func:`read_diameters` -- raw diameters, one per row (e.g. a Phase Doppler export).
    An optional header row (any non-numeric cell makes the first row a header). With
    several columns choose one by header name or 0-based index (``column=``); without
    ``column`` a single column is used, or the one header name containing "diam".

:func:`read_histogram` -- a histogram, in one of two layouts:

* **columns**: one row per bin, ``lower edge, upper edge, count``, with an optional
  header; bins must be contiguous (each lower edge equals the previous upper edge);
* **rows**: exactly two rows, the ``k + 1`` bin edges then the ``k`` counts, each row
  optionally starting with a text label (``edges_um, 10, 20, 30`` /
  ``counts, 4, 9``).

Counts may be integer counts or relative frequencies. Every problem raises
:class:`~microimpact.errors.DataFormatError` naming the file, the line, the column,
the bad value and what is allowed.
"""

from __future__ import annotations

import math
import os

import numpy as np

from .._core.files import (
    SNIFF,
    delimiter_name,
    is_number,
    looks_like_header,
    parse_number,
    read_rows,
    read_table,
    resolve_column,
)
from ..errors import DataFormatError
from ..units import length_factor
from .profiles import header_unit

__all__ = ["read_diameters", "read_histogram"]

_LAYOUTS = (
    "columns 'lower, upper, count' (one row per bin) or two rows "
    "'edges' (k + 1 values) and 'counts' (k values)"
)
_HINT = "; expected delimited text"


def _factor(unit, path) -> float:
    """Metres per `unit`; an unknown unit raises DataFormatError naming the file."""
    try:
        return length_factor(unit)
    except ValueError as exc:
        raise DataFormatError(str(exc), source=path, field="unit") from None


def _number(cell, *, path, line, field, allowed, minimum=None, strict=True) -> float:
    """Parse one cell; DataFormatError naming file, line, column, value, allowed."""
    ok = None
    if minimum is not None:
        ok = (lambda v: v > minimum) if strict else (lambda v: v >= minimum)
    return parse_number(
        cell, source=path, line=line, field=field, allowed=allowed, ok=ok
    )


def _split_header(rows):
    """(header or None, data rows); the first row is a header if any cell is text."""
    if rows and looks_like_header(rows[0][1]):
        return rows[0][1], rows[1:]
    return None, rows


_HOW_COLUMN = {
    "python": "pass `column=`",
    "cli": "pass --column with",
    "toml": "set the key column = to",
}


def _choose_column(path, header, n_columns, column, syntax) -> tuple[int, str]:
    """Resolve `column` to (0-based index, display name)."""
    names = header or [str(j) for j in range(n_columns)]
    if column is None:
        if n_columns == 1:
            return 0, names[0]
        hits = [j for j, h in enumerate(header or []) if "diam" in h.lower()]
        if len(hits) == 1:
            return hits[0], names[hits[0]]
        listing = (
            ", ".join(repr(h) for h in header) if header else f"0..{n_columns - 1}"
        )
        raise DataFormatError(
            f"the file has {n_columns} columns; {_HOW_COLUMN[syntax]} one of {listing} "
            "(a header name or a 0-based index)",
            source=path,
            field="column",
        )
    j = resolve_column(column, header, n_columns, name="column", source=path)
    return j, names[j]


def read_diameters(path, *, column=None, unit=None, syntax="python"):
    """Read raw measured diameters, one per row.

    Parameters
    ----------
    path : str or path-like
        Delimited text file (see the module notes for the accepted format).
    column : str or int, optional
        Header name (exact, else case-insensitive) or 0-based index of the diameter
        column; needed when there are several columns and no header name containing
        "diam".
    unit : str, optional
        Length unit of the values in the file (``"um"``, ``"mm"``, ``"m"``, ...).
        Default: the unit the column's header names (``diameter_um``,
        ``d [mm]``), else µm. A unit that contradicts the header's is an error.
    syntax : {"python", "cli", "toml"}
        How the error asking for a column spells the option (``column=``,
        ``--column``, ``column =``).

    Returns
    -------
    diameters : ndarray
        The diameters [m], in file order.
    metadata : dict
        ``source``, ``column`` (name or index), ``column_index``, ``header``,
        ``delimiter``, ``unit``, ``unit_from`` (``"header"``, ``"argument"`` or
        ``"default"``) and ``n``.

    Raises
    ------
    DataFormatError
        Empty file; several columns and no `column`; unknown column; missing,
        non-numeric, non-finite, zero or negative diameters (naming file, line and
        column); a unit that contradicts the header's; diameters whose median is
        not a particle diameter in the unit used (below 10 nm or above 10 mm: a
        probable unit mistake).
    """
    path = os.fspath(path)
    if syntax not in _HOW_COLUMN:
        raise ValueError(
            f"`syntax` must be one of {tuple(_HOW_COLUMN)}; got {syntax!r}."
        )
    if unit is not None:
        _factor(unit, path)
    table = read_table(
        path,
        header=None,
        delimiter=SNIFF,
        hint=_HINT,
        empty="no diameters found (the file is empty or has only a header); "
        "expected one diameter per row",
    )
    header, data = table.header, table.rows
    j, name = _choose_column(path, header, table.width, column, syntax)
    field = f"column {name!r}" if header else f"column {j}"
    unit, unit_from = _diameter_unit(path, header, j, name, unit)
    factor = _factor(unit, path)
    allowed = f"a diameter > 0 in {unit}"
    values = np.empty(len(data))
    for k, (line, cells) in enumerate(data):
        cell = table.cell(cells, j)
        values[k] = _number(
            cell, path=path, line=line, field=field, allowed=allowed, minimum=0.0
        )
    metadata = {
        "source": path,
        "column": name if header else j,
        "column_index": j,
        "header": header,
        "delimiter": delimiter_name(table.delimiter),
        "unit": unit,
        "unit_from": unit_from,
        "n": int(values.size),
    }
    _check_plausible(path, field, values * factor, unit, unit_from)
    return values * factor, metadata


def _diameter_unit(path, header, j, name, unit):
    """``(unit, where it came from)``: the header's unit is honoured, an explicit
    one must agree with it, else µm."""
    stated = header_unit(header[j])[0] if header else None
    return _unit_agreed(path, unit, None if stated is None else (name, stated))


def _one_unit(path, stated):
    """The first of the ``(name, unit)`` pairs `stated` by a file's header (None
    if there are none); DataFormatError where they name different lengths."""
    if len({length_factor(u) for _, u in stated}) > 1:
        listing = ", ".join(f"{u!r} in {name!r}" for name, u in stated)
        raise DataFormatError(
            f"the header names different length units ({listing}); allowed: one unit",
            source=path,
            field="unit",
        )
    return stated[0] if stated else None


def _unit_agreed(path, unit, stated, *, where="header", default="um"):
    """``(unit, unit_from)`` of the diameters of a file: an explicit `unit` must
    name the same length as the one the file states, ``stated = (name, unit)`` (the
    header cell or row `where` that names it; None: the file states none).

    Returns ``(unit, "argument")``, else ``(stated unit, "header")``, else
    ``(default, "default")``; ``(None, None)`` if `default` is None and neither
    says a unit.
    """
    if unit is not None:
        if stated is not None and length_factor(stated[1]) != length_factor(unit):
            raise DataFormatError(
                f"the {where} {stated[0]!r} gives the unit {stated[1]!r} but the "
                f"unit given is {unit!r}; allowed: the same unit, or leave the unit "
                "out to use the file's",
                source=path,
                field="unit",
            )
        return unit, "argument"
    if stated is not None:
        return stated[1], "header"
    return (default, "default") if default is not None else (None, None)


def _check_plausible(path, field, diameters_m, unit, unit_from):
    """DataFormatError where the median diameter is not a particle's (10 nm to
    10 mm): the file probably holds another unit than the one used."""
    median_um = float(np.median(diameters_m)) * 1e6
    if 0.01 <= median_um <= 10_000.0:
        return
    side = "below 10 nm" if median_um < 0.01 else "above 10 mm"
    if unit_from == "header":
        fix = (
            f"the header names {unit!r}; if the file holds another unit, correct the "
            "header (e.g. diameter_m, diameter_mm)"
        )
    else:
        fix = "give the unit the file holds (unit='m', 'mm', 'nm'; --unit on the CLI)"
    raise DataFormatError(
        f"the median diameter read as {unit!r} is {median_um:g} um, {side}, which is "
        f"not a particle diameter: the values are probably in another unit; {fix}",
        source=path,
        field=field,
    )


def read_histogram(path, *, unit="um"):
    """Read a diameter histogram (bin edges and counts).

    Parameters
    ----------
    path : str or path-like
        Delimited text file in the *columns* or *rows* layout (module notes).
    unit : str
        Length unit of the bin edges in the file.

    Returns
    -------
    edges : ndarray, shape (k + 1,)
        Strictly increasing bin edges [m].
    counts : ndarray, shape (k,)
        Counts or frequencies per bin (>= 0, not all zero).
    metadata : dict
        ``source``, ``layout`` (``"columns"`` or ``"rows"``), ``header``, ``unit``,
        ``n_bins`` and ``total``.

    Raises
    ------
    DataFormatError
        Empty file, unknown layout, missing or non-numeric cells, negative edges,
        non-increasing or non-contiguous edges, negative or all-zero counts.
    """
    path = os.fspath(path)
    factor = _factor(unit, path)
    rows, _ = read_rows(path, delimiter=SNIFF, hint=_HINT)
    if not rows:
        raise DataFormatError(f"the file is empty; expected {_LAYOUTS}", source=path)
    as_rows = _rows_layout(rows)
    if as_rows is not None:
        edges, counts, header = _parse_rows_layout(path, *as_rows)
        layout = "rows"
    else:
        edges, counts, header = _parse_columns_layout(path, rows, unit)
        layout = "columns"
    if not counts.sum() > 0:
        raise DataFormatError(
            "all counts are zero; allowed: counts >= 0 with a positive total",
            source=path,
            field="count",
        )
    metadata = {
        "source": path,
        "layout": layout,
        "header": header,
        "unit": unit,
        "n_bins": int(counts.size),
        "total": float(counts.sum()),
    }
    return edges * factor, counts, metadata


def _rows_layout(rows):
    """The two rows (without labels) if `rows` is the rows layout, else None."""
    if len(rows) != 2:
        return None
    (l0, c0), (l1, c1) = rows
    labels = []
    if c0 and c1 and not is_number(c0[0]) and not is_number(c1[0]):
        labels = [c0[0], c1[0]]
        c0, c1 = c0[1:], c1[1:]
    if len(c1) >= 1 and len(c0) == len(c1) + 1:
        return (l0, c0), (l1, c1), labels or None
    return None


def _parse_rows_layout(path, row_edges, row_counts, labels):
    (le, ce), (lc, cc) = row_edges, row_counts
    shift = 1 if labels else 0

    def row(line, cells, allowed):
        return np.array(
            [
                _number(
                    c,
                    path=path,
                    line=line,
                    field=f"column {j + shift}",
                    allowed=allowed,
                    minimum=0.0,
                    strict=False,
                )
                for j, c in enumerate(cells)
            ]
        )

    edges = row(le, ce, "a bin edge >= 0")
    bad = np.flatnonzero(np.diff(edges) <= 0)
    if bad.size:
        j = int(bad[0]) + 1
        raise DataFormatError(
            f"bin edges must be strictly increasing; got {ce[j]!r} after {ce[j - 1]!r}",
            source=path,
            line=le,
            field=f"column {j + shift}",
        )
    return edges, row(lc, cc, "a count >= 0"), labels


def _parse_columns_layout(path, rows, unit):
    header, data = _split_header(rows)
    if header is not None and len(header) != 3:
        raise DataFormatError(
            f"header has {len(header)} columns; expected {_LAYOUTS}",
            source=path,
            line=rows[0][0],
        )
    if not data:
        raise DataFormatError(
            f"no bins found (only a header); expected {_LAYOUTS}", source=path
        )
    names = ("lower edge", "upper edge", "count")
    lower, upper, counts = (np.empty(len(data)) for _ in range(3))
    for k, (line, cells) in enumerate(data):
        if len(cells) != 3:
            decimal = "; the decimal separator must be '.'" if len(cells) > 3 else ""
            raise DataFormatError(
                f"row has {len(cells)} cells; expected {_LAYOUTS}{decimal}",
                source=path,
                line=line,
            )
        lo, hi, n = (
            _number(
                c,
                path=path,
                line=line,
                field=f"column {j} ({names[j]})",
                allowed="a number >= 0" + (f" in {unit}" if j < 2 else ""),
                minimum=0.0,
                strict=False,
            )
            for j, c in enumerate(cells)
        )
        if not hi > lo:
            raise DataFormatError(
                f"upper edge {cells[1]!r} is not above lower edge {cells[0]!r}; "
                "allowed: upper > lower",
                source=path,
                line=line,
                field="column 1 (upper edge)",
            )
        if k and not math.isclose(lo, upper[k - 1], rel_tol=1e-9, abs_tol=0.0):
            what = "a gap" if lo > upper[k - 1] else "an overlap or unsorted bins"
            raise DataFormatError(
                f"lower edge {cells[0]!r} does not equal the previous upper edge "
                f"{upper[k - 1]:g} ({what}); allowed: contiguous bins in increasing "
                "order",
                source=path,
                line=line,
                field="column 0 (lower edge)",
            )
        lower[k], upper[k], counts[k] = lo, hi, n
    return np.append(lower, upper[-1]), counts, header
