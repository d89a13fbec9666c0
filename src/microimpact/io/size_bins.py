"""Reading size data of any layout: raw diameters, or the bins of an APS, SMPS or
OPC export (edges or midpoints with counts, dN/dlogDp, dM/dlogDp, ...).

:func:`read_size_data` detects the layout from the header names (rules in
``docs/populations.md``):

* a column named like ``Lower``/``Upper`` (``Lower Size (nm)``, ``lower_um``) and a
  value column: **edges** (one row per bin);
* a diameter column (``Dp``, ``Midpoint``, ``Diameter Midpoint``, ``diameter_um``,
  ``Aerodynamic Diameter``) and a value column: **midpoints**; the bin edges are
  derived geometrically (:func:`~microimpact.population.binned.edges_from_midpoints`)
  and the derivation is checked;
* no value column: **diameters**, raw values one per row
  (:func:`~microimpact.io.diameters.read_diameters`);
* the two-row layout (edges row, counts row) of
  :func:`~microimpact.io.diameters.read_histogram`: edges with counts;
* a TSI AIM **column export** (metadata rows, then a ``Diameter Midpoint`` row and
  one row per channel with one column per sample, then AIM's statistics rows):
  the values from its ``Units`` and ``Weight`` rows (``dw/dlogDp`` + ``Number`` is
  dN/dlogDp), the unit from its statistics rows (``Lower Size(nm)``), the samples
  chosen by `sample`. Windows-1252 text (AIM's ``cm³``) is read;
* a **wide** export, one sample per row: a TSI AIM *row* export or an
  instrument's time series, whose header row holds >= 3 increasing bin midpoints
  (``Sample #, Date, ..., 21.7, 22.5, ..., Total Conc.``; ``timestamp, 0.35,
  0.46, ...``), or bin names without sizes (``bin0, bin1, ...``: the boundaries
  are then given as `edges_um`). The other columns are metadata.

An AIM export's edges lie on its ``Channels/Decade`` grid (each channel ``1/c``
wide in log10 d). `sample` chooses among several samples: a Sample # (else the
row number), ``"A..B"`` (their mean), ``"sum A..B"``, ``"mean"``, ``"sum"``; A and
B may be ISO 8601 times in a log with a ``timestamp`` column.
`sampled_volume_cm3` turns number concentrations into counted particles (Poisson
counting in that volume per sample, no coincidence or efficiency correction), for
the standard errors and the chi-squared test.

Value columns are recognised by name: ``dN/dlogDp``, ``dN/dlnDp``, ``dN/dDp``,
``dM/dlogDp`` (also ``dW/dlogDp``), ``dV/dlogDp`` and the ``/dDp``, ``/dlnDp``
forms; ``count``/``counts``/``frequency`` (counted particles; ``n`` and
``number`` are not taken: they often name a particle index);
``dN``/``concentration`` (number per bin); ``mass``/``dM``, ``volume``/``dV``. Units
in the header (``Dp (nm)``, ``Lower [µm]``, ``diameter_um``) are honoured; an
explicit unit that contradicts them is an error. A headerless file with more than
one column, a file with several value columns and a value column of unknown meaning
are ambiguous: the error lists the choices and says how to pass one (``syntax``
chooses the spelling: ``--layout edges`` for the command line, ``layout =
"edges"`` for a scenario file, ``layout='edges'`` for Python). A headerless value
column holds counts unless `values` says otherwise. A ``#`` in the header row is
part of a name (``dN/dlogDp (#/cm3)``, ``Sample #``); below it, ``#`` starts a
comment.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import replace
from datetime import datetime

import numpy as np

from .._core.files import (
    SNIFF,
    data_lines,
    delimiter_name,
    is_number,
    looks_like_header,
    read_lines,
    resolve_column,
    sniff_delimiter,
    split_rows,
)
from .._core.validation import check_choice, check_scalar
from ..errors import DataFormatError
from ..population.binned import (
    BIN_VALUES,
    BinnedSizes,
    edges_from_midpoints,
    number_per_bin,
)
from ..units import length_factor
from .diameters import (
    _check_plausible,
    _number,
    _rows_layout,
    _split_header,
    read_diameters,
    read_histogram,
)
from .profiles import header_unit

__all__ = ["SIZE_LAYOUTS", "read_size_bins", "read_size_data"]

#: How a size file may be laid out.
SIZE_LAYOUTS = ("diameters", "edges", "midpoints")
_SYNTAX = ("python", "cli", "toml")
_HINT = "; expected delimited text"

_DENSITY = re.compile(r"^d([nmvw])/?d(log10|log|ln)?(dp|d)$")
_PER_BIN = {
    "count": "count",
    "counts": "count",
    "numbercount": "count",
    "frequency": "count",
    "freq": "count",
    "dn": "dN",
    "conc": "dN",
    "concentration": "dN",
    "numberconcentration": "dN",
    "mass": "mass",
    "dm": "dM",
    "dw": "dM",
    "volume": "volume",
    "dv": "dV",
}
_LOWER = {"lo", "dplo", "dlo", "dmin", "dpmin", "min", "from"}
_UPPER = {"hi", "dphi", "dhi", "dmax", "dpmax", "max", "to"}
_MID = {"dp", "d", "size", "dg", "dpmid"}
_UNIT_SUFFIX = re.compile(r"[_\s/]+(um|µm|μm|nm|mm|cm|m)$", re.IGNORECASE)


def _rows(path):
    """(rows, delimiter) of a delimited text file: UTF-8 or Windows-1252, a ``#``
    in the first row (a header such as ``dN/dlogDp (#/cm3)`` or ``Sample #``) kept,
    trailing ``# ...`` comments cut from the rows below it."""
    lines, _ = _text_lines(path)
    rows, delimiter = split_rows(lines, source=path, delimiter=SNIFF)
    head = lines[: rows[0][0]] if rows else []  # up to the first data row
    whole, _ = split_rows(
        head, source=path, delimiter=delimiter or "", trailing_comments=False
    )
    if rows and whole and whole[0][0] == rows[0][0] and looks_like_header(whole[0][1]):
        rows[0] = whole[0]
    return rows, delimiter


def _option(name, value, syntax):
    """How the user passes option `name` = `value` in `syntax`."""
    if syntax == "cli":
        shown = value if re.fullmatch(r"[\w./-]+", str(value)) else f"'{value}'"
        return f"--{name.replace('_', '-')} {shown}"
    if syntax == "toml":
        raw = isinstance(value, int) or str(value).startswith("[")
        shown = value if raw else f'"{value}"'
        return f"{name} = {shown}"
    return f"{name}={value!r}"


def _key(name: str) -> str:
    """A header name folded for matching: no bracketed unit, no unit suffix, lower
    case, no spaces, underscores, dashes or dots."""
    s = re.sub(r"[\(\[\{].*?[\)\]\}]", "", name)
    s = _UNIT_SUFFIX.sub("", s.strip())
    return re.sub(r"[\s_\-.]", "", s.lower())


def _column_role(name: str):
    """``("value", kind)``, ``("lower", None)``, ``("upper", None)``,
    ``("mid", None)`` or ``(None, None)`` for a header name."""
    s = _key(name)
    m = _DENSITY.match(s)
    if m:
        w = {"n": "N", "m": "M", "w": "M", "v": "V"}[m.group(1)]
        var = {"log10": "logDp", "log": "logDp", "ln": "lnDp", None: "Dp"}[m.group(2)]
        return "value", f"d{w}/d{var}"
    if s in _PER_BIN:
        return "value", _PER_BIN[s]
    if "lower" in s or "left" in s or s in _LOWER:
        return "lower", None
    if "upper" in s or "right" in s or s in _UPPER:
        return "upper", None
    if "mid" in s or "diam" in s or "center" in s or "centre" in s or s in _MID:
        return "mid", None
    return None, None


def _ask(path, what, choices, syntax, *, field):
    """The asking error: `what` is ambiguous; `choices` are (option, value, meaning)."""
    listing = "; ".join(
        f"{_option(opt, val, syntax)} ({meaning})" for opt, val, meaning in choices
    )
    return DataFormatError(f"{what}; choose one: {listing}", source=path, field=field)


def _value_choices(header, cols):
    return [("column", header[j], f"the values {header[j]!r}") for j in cols]


def _values_choices():
    return [
        ("values", v, f"{w} per bin" if per == "bin" else f"{w} density over {per}")
        for v, (w, per) in BIN_VALUES.items()
        if v in ("count", "dN", "dN/dlogDp", "dN/dDp", "dM/dlogDp", "dV/dlogDp")
    ]


def _layout(path, header, width, layout, syntax):
    """The layout of a file with `header` (None: no header) and `width` columns."""
    if layout is not None:
        return layout
    if header is None:
        if width == 1:
            return "diameters"
        raise _ask(
            path,
            f"the file has {width} columns and no header, so what they hold is "
            "ambiguous",
            [
                ("layout", "edges", "columns lower edge, upper edge, value per bin"),
                ("layout", "midpoints", "columns bin midpoint, value per bin"),
                ("layout", "diameters", "raw diameters, one per row; with --column"),
            ],
            syntax,
            field="layout",
        )
    roles = [_column_role(h)[0] for h in header]
    if "value" not in roles:
        return "diameters"
    if "lower" in roles and "upper" in roles:
        return "edges"
    if "mid" in roles:
        return "midpoints"
    raise _ask(
        path,
        f"the header {header} has a value column but no bin edges (lower, upper) "
        "nor midpoints (Dp, midpoint, diameter)",
        [
            ("layout", "edges", "the first two columns are the lower and upper edges"),
            ("layout", "midpoints", "the first column is the bin midpoint"),
        ],
        syntax,
        field="layout",
    )


def _one(path, header, role, syntax, what):
    """The single column of `role` (lower/upper/mid) in `header`."""
    hits = [j for j, h in enumerate(header) if _column_role(h)[0] == role]
    if len(hits) == 1:
        return hits[0]
    raise DataFormatError(
        f"the header has {len(hits)} {what} columns "
        f"({', '.join(repr(header[j]) for j in hits)}); expected exactly one",
        source=path,
        field="header",
    )


def _value_column(path, header, width, used, column, values, syntax):
    """(column index, kind) of the values."""
    if column is not None:
        j = resolve_column(column, header, width, name="column", source=path)
        kind = _column_role(header[j])[1] if header else None
    elif header is None:
        j, kind = width - 1, None
    else:
        cols = [j for j, h in enumerate(header) if _column_role(h)[0] == "value"]
        if values is not None and len(cols) > 1:
            cols = [j for j in cols if _column_role(header[j])[1] == values] or cols
        if len(cols) > 1:
            raise _ask(
                path,
                f"the file has {len(cols)} value columns "
                f"({', '.join(repr(header[j]) for j in cols)})",
                _value_choices(header, cols),
                syntax,
                field="column",
            )
        if cols:
            j = cols[0]
        else:
            rest = [k for k in range(width) if k not in used]
            if len(rest) != 1:
                raise _ask(
                    path,
                    f"no column of the header {header} is a known value column",
                    _value_choices(header, rest),
                    syntax,
                    field="column",
                )
            j = rest[0]
        kind = _column_role(header[j])[1]
    if values is not None:
        if kind is not None and kind != values:
            raise DataFormatError(
                f"the header {header[j]!r} says the values are {kind} but the values "
                f"given are {values!r}; allowed: the same, or leave it out to use "
                "the header's",
                source=path,
                field="values",
            )
        return j, values
    if kind is None:
        if header is None:
            return j, "count"
        raise _ask(
            path,
            f"the column {header[j]!r} holds the values but its name does not say "
            "what they are",
            _values_choices(),
            syntax,
            field="values",
        )
    return j, kind


def _unit_of(path, header, cols, unit):
    """(unit, where from) of the diameter columns `cols`; header units must agree
    with each other and with an explicit `unit`."""
    found = {header[j]: header_unit(header[j])[0] for j in cols} if header else {}
    named = {h: u for h, u in found.items() if u is not None}
    factors = {length_factor(u) for u in named.values()}
    if len(factors) > 1:
        raise DataFormatError(
            f"the diameter columns name different units ({named}); allowed: one unit",
            source=path,
            field="unit",
        )
    from_header = next(iter(named.values()), None)
    if unit is not None:
        if from_header is not None and length_factor(from_header) != length_factor(
            unit
        ):
            raise DataFormatError(
                f"the header {next(iter(named))!r} gives the unit {from_header!r} but "
                f"the unit given is {unit!r}; allowed: the same unit, or leave the "
                "unit out to use the header's",
                source=path,
                field="unit",
            )
        return unit, "argument"
    if from_header is not None:
        return from_header, "header"
    return "um", "default"


def read_size_bins(
    path,
    *,
    layout=None,
    values=None,
    column=None,
    unit=None,
    sample=None,
    sampled_volume_cm3=None,
    edges_um=None,
    syntax="python",
):
    """Read a binned size distribution (an instrument export).

    Parameters
    ----------
    path : str or path-like
        Delimited text (see :mod:`microimpact.io.diameters` for the text rules).
    layout : {"edges", "midpoints"}, optional
        Default: detected from the header (module notes).
    values : str, optional
        What the values are, a key of
        :data:`~microimpact.population.binned.BIN_VALUES` (``"dN/dlogDp"``,
        ``"count"``, ``"dM/dlogDp"``...). Default: from the value column's name; a
        headerless file's are counts.
    column : str or int, optional
        The value column (header name or 0-based index) when there are several.
    unit : str, optional
        Length unit of the diameters (default: the header's, else µm).
    sample : int or str, optional
        For an export holding several samples (a TSI AIM column or row export, a
        wide time series; needed when there are several): a Sample # (else the
        1-based row number), ``"A..B"`` (the mean of samples A to B inclusive),
        ``"sum A..B"``, ``"mean A..B"``, ``"mean"`` or ``"sum"`` (of all); A and B
        may be ISO 8601 times in a log with a ``timestamp`` column.
    sampled_volume_cm3 : float, optional
        The air volume [cm³] in which one sample's particles were counted: the
        number concentrations (per cm³ unless the value column names ``/L`` or
        ``/m3``) times it are taken as counted particles (``counted=True``),
        summed over the samples read. Assumes Poisson counting of every particle
        in that volume; not for counts (already counted) nor mass or volume
        weightings.
    edges_um : array_like, optional
        The bin boundaries [µm] of a wide export whose bin columns are named
        without sizes (``bin0, bin1, ...``), one more than the bins.
    syntax : {"python", "cli", "toml"}
        How the asking errors spell an option.

    Returns
    -------
    bins : BinnedSizes
        Edges [µm] and number per bin, with notes on what was derived.
    metadata : dict
        ``source``, ``layout`` (``"edges"``, ``"midpoints"``, ``"aim-columns"``,
        ``"aim-rows"``, ``"wide"``), ``header``, ``value_column``, ``values``,
        ``unit``, ``unit_from``, ``n_bins`` and ``delimiter``; for an export of
        several samples also ``samples`` (their labels), ``sample`` (the choice),
        ``selection`` (in words), ``n_samples_used``, ``aggregate`` (``"one"``,
        ``"mean"``, ``"sum"``) and ``instrument_statistics`` (the numbers the
        export states of one sample: AIM's Total Conc., flows, ...).

    Raises
    ------
    DataFormatError
        Ambiguous columns (listing the choices and how to pass one), bad cells,
        edges not increasing or not contiguous, midpoints not log-spaced, all
        values zero, a unit mistake.
    """
    path = os.fspath(path)
    check_choice(syntax, "syntax", _SYNTAX)
    if layout is not None and layout not in ("edges", "midpoints"):
        raise DataFormatError(
            f"layout {layout!r} is not a binned layout; allowed: edges, midpoints",
            source=path,
            field="layout",
        )
    if values is not None and values not in BIN_VALUES:
        raise DataFormatError(
            f"values {values!r} unknown; allowed: {', '.join(BIN_VALUES)}",
            source=path,
            field="values",
        )
    if sampled_volume_cm3 is not None:
        try:
            sampled_volume_cm3 = check_scalar(
                sampled_volume_cm3, "sampled_volume_cm3", minimum=0, strict=True
            )
        except (TypeError, ValueError):
            raise DataFormatError(
                f"sampled_volume_cm3 {sampled_volume_cm3!r} is not a volume; "
                "allowed: a number > 0 (cm^3 of air in which one sample's particles "
                "were counted)",
                source=path,
                field="sampled_volume_cm3",
            ) from None
    bins, meta = _read_bins(
        path, layout, values, column, unit, sample, edges_um, syntax
    )
    if sampled_volume_cm3 is not None:
        bins = _counted(path, bins, meta, sampled_volume_cm3, syntax)
    return bins, meta


def _read_bins(path, layout, values, column, unit, sample, edges_um, syntax):
    aim = _aim_rows(path) if layout in (None, "midpoints") else None
    if aim is not None and edges_um is not None:
        raise DataFormatError(
            "edges_um is for wide exports whose bin columns do not give sizes "
            "(bin0, bin1, ...); a TSI AIM column export gives its midpoints",
            source=path,
            field="edges_um",
        )
    if aim is not None:
        return _read_aim(
            path, aim, values=values, sample=sample, unit=unit, syntax=syntax
        )
    wide = _wide_rows(path) if layout in (None, "midpoints") else None
    if wide is not None and column is None:
        return _read_wide(
            path,
            wide,
            values=values,
            sample=sample,
            unit=unit,
            edges_um=edges_um,
            syntax=syntax,
        )
    if edges_um is not None:
        raise DataFormatError(
            "edges_um is for wide exports whose bin columns do not give sizes "
            "(bin0, bin1, ...); this file is not one",
            source=path,
            field="edges_um",
        )
    if sample is not None:
        raise DataFormatError(
            "sample is for exports holding several samples (a TSI AIM column or row "
            "export, a wide time series with the bin midpoints as column headers); "
            "this file is not one",
            source=path,
            field="sample",
        )
    rows, delimiter = _rows(path)
    if not rows:
        raise DataFormatError("the file is empty; expected size bins", source=path)
    if layout in (None, "edges") and column is None and _rows_layout(rows):
        edges_m, counts, meta = read_histogram(path)
        kind = values or "count"
        return _bins(path, edges_m * 1e6, counts, kind, []), meta | {
            "values": kind,
            "delimiter": delimiter_name(delimiter),
        }
    header, data = _split_header(rows)
    if not data:
        raise DataFormatError("no bins found (only a header)", source=path)
    width = len(header) if header else len(data[0][1])
    if layout is None and width == 3 and _legacy(header):
        # the columns layout of read_histogram: lower edge, upper edge, count
        layout, header = "edges", None
    layout = _layout(path, header, width, layout, syntax)
    if layout == "diameters":
        raise DataFormatError(
            "the file holds raw diameters (no value column), not size bins; "
            f"allowed: a value column such as {', '.join(list(BIN_VALUES)[:5])}",
            source=path,
        )
    if layout == "edges":
        if header is None:
            cols = [0, 1]
        else:
            cols = [_one(path, header, r, syntax, r) for r in ("lower", "upper")]
    else:
        cols = (
            [0] if header is None else [_one(path, header, "mid", syntax, "midpoint")]
        )
    need = len(cols) + 1
    if width < need:
        raise DataFormatError(
            f"the {layout} layout needs {need} columns; the file has {width}",
            source=path,
        )
    j, kind = _value_column(path, header, width, cols, column, values, syntax)
    unit, unit_from = _unit_of(path, header, cols, unit)
    try:
        um = length_factor(unit) / 1e-6
    except ValueError as exc:
        raise DataFormatError(str(exc), source=path, field="unit") from None
    names = header or [f"column {k}" for k in range(width)]
    table = np.empty((len(data), len(cols) + 1))
    for r, (line, cells) in enumerate(data):
        for c, k in enumerate([*cols, j]):
            cell = cells[k] if k < len(cells) else ""
            is_value = k == j
            table[r, c] = _number(
                cell,
                path=path,
                line=line,
                field=f"column {names[k]!r}" if header else f"column {k}",
                allowed=f"a value >= 0 ({kind})"
                if is_value
                else f"a diameter > 0 in {unit}",
                minimum=0.0,
                strict=not is_value,
            )
    notes = []
    if unit_from == "header":
        notes.append(f"diameters read in {unit}, the unit the header names")
    if layout == "edges":
        edges = _check_edges(path, data, table[:, 0] * um, table[:, 1] * um)
    else:
        mids = table[:, 0] * um
        bad = np.flatnonzero(np.diff(mids) <= 0)
        if bad.size:
            line = data[int(bad[0]) + 1][0]
            raise DataFormatError(
                "the midpoints must be strictly increasing; allowed: one row per "
                "bin, in increasing order",
                source=path,
                line=line,
                field=f"column {names[cols[0]]!r}",
            )
        try:
            edges = edges_from_midpoints(mids)
        except ValueError as exc:
            raise DataFormatError(str(exc), source=path) from None
        back = np.sqrt(edges[:-1] * edges[1:])
        notes.append(
            f"bin edges derived from the {mids.size} midpoints as geometric (log) "
            "midpoints (interior edges the geometric means of neighbours); the "
            "rebuilt bins' midpoints match the file's within "
            f"{100 * float(np.max(np.abs(back / mids - 1))):.2g} %"
        )
    mids_m = np.sqrt(edges[:-1] * edges[1:]) * 1e-6
    _check_plausible(path, f"column {names[cols[0]]!r}", mids_m, unit, unit_from)
    bins = _bins(path, edges, table[:, -1], kind, notes)
    return bins, {
        "source": path,
        "layout": layout,
        "header": header,
        "value_column": names[j] if header else j,
        "values": kind,
        "unit": unit,
        "unit_from": unit_from,
        "n_bins": int(edges.size - 1),
        "delimiter": delimiter_name(delimiter),
    }


# -- choosing samples (AIM exports, wide time series) -------------------------------
_RANGE = re.compile(r"^(?:(mean|sum)\s+)?(.+?)\s*\.\.\s*(.+)$", re.IGNORECASE)


def _iso_time(text):
    """A datetime of ISO 8601 `text` (``2022-02-15T21:20:30Z``), else None."""
    try:
        return datetime.fromisoformat(text.strip())
    except ValueError:
        return None


def _select(path, labels, sample, syntax, what, times=None):
    """(indices, how, text) of the samples `sample` chooses among `labels`.

    `sample` is a label (a Sample #, else the 1-based row number), ``"mean"`` or
    ``"sum"`` (of all), ``"A..B"`` (the mean of samples A to B, inclusive) or
    ``"sum A..B"``/``"mean A..B"``; with `times` (the ISO 8601 timestamps of the
    samples, else None) A and B may also be times: the samples from A to B
    inclusive, in any file order. `how` is ``"one"``, ``"mean"`` or ``"sum"``."""
    first = int(labels[0]) if labels[0].isdigit() else labels[0]
    if sample is None:
        if len(labels) == 1:
            return [0], "one", f"sample {labels[0]}"
        choices = [
            ("sample", first, "one sample: its Sample #, else its row number"),
            ("sample", "mean", "the mean of all samples"),
            ("sample", "sum", "the sum of all samples"),
            ("sample", f"{labels[0]}..{labels[-1]}", "the mean of a range"),
        ]
        if times is not None:
            span = f"{min(times).isoformat()}..{max(times).isoformat()}"
            choices.append(("sample", span, "the mean of a time range"))
        raise _ask(
            path,
            f"the {what} holds {len(labels)} samples ({labels[0]}..{labels[-1]})",
            choices,
            syntax,
            field="sample",
        )
    text = str(sample).strip()
    low = text.lower()
    allowed = (
        f"allowed: a Sample # ({labels[0]}..{labels[-1]}), 'mean', 'sum', 'A..B' or "
        "'sum A..B'" + (" (A, B Sample #s or ISO 8601 times)" if times else "")
    )
    if low in ("mean", "sum"):
        idx, how = list(range(len(labels))), low
    else:
        m = _RANGE.match(text)
        if m:
            how = (m.group(1) or "mean").lower()
            ends = [m.group(2), m.group(3)]
        else:
            how, ends = "one", [text, text]
        if m and times is not None and not all(e in labels for e in ends):
            return _select_times(path, times, ends, how, what, allowed)
        missing = [e for e in ends if e not in labels]
        if missing:
            raise DataFormatError(
                f"sample {missing[0]!r} is not in the {what}; {allowed}",
                source=path,
                field="sample",
            )
        a, b = (labels.index(e) for e in ends)
        if a > b:
            raise DataFormatError(
                f"sample range {text!r} runs backwards; allowed: A..B with A before "
                "B in the file",
                source=path,
                field="sample",
            )
        idx = list(range(a, b + 1))
    if len(idx) == 1:
        return idx, "one", f"sample {labels[idx[0]]}"
    span = f"samples {labels[idx[0]]}..{labels[idx[-1]]}"
    return idx, how, f"the {how} of {span} ({len(idx)} samples)"


def _select_times(path, times, ends, how, what, allowed):
    """:func:`_select` of the samples timed from ``ends[0]`` to ``ends[1]``."""
    lo, hi = (_iso_time(e) for e in ends)
    if lo is None or hi is None:
        bad = ends[0] if lo is None else ends[1]
        raise DataFormatError(
            f"sample range end {bad!r} is neither a Sample # nor an ISO 8601 time; "
            f"{allowed}",
            source=path,
            field="sample",
        )
    aware = {t.tzinfo is not None for t in (*times, lo, hi)}
    if len(aware) > 1:
        raise DataFormatError(
            f"the times {ends[0]!r}..{ends[1]!r} and the {what}'s timestamps do not "
            "both name a time zone; allowed: both with (e.g. Z, +02:00) or both "
            "without",
            source=path,
            field="sample",
        )
    if lo > hi:
        raise DataFormatError(
            f"sample range {ends[0]}..{ends[1]} runs backwards; allowed: A..B with "
            "A not after B",
            source=path,
            field="sample",
        )
    idx = [r for r, t in enumerate(times) if lo <= t <= hi]
    if not idx:
        raise DataFormatError(
            f"no sample of the {what} is timed from {ends[0]} to {ends[1]}; its "
            f"samples run from {min(times).isoformat()} to {max(times).isoformat()}",
            source=path,
            field="sample",
        )
    if len(idx) == 1:
        return idx, "one", f"the sample at {times[idx[0]].isoformat()}"
    return idx, how, (f"the {how} of the {len(idx)} samples timed {ends[0]}..{ends[1]}")


def _sample_key(labels, idx, how, sample):
    """The samples read, as the metadata's ``sample``: the Sample # of one, else
    ``"mean"``, ``"sum"`` or the range as given."""
    if how == "one":
        return labels[idx[0]]
    text = str(sample).strip()
    return text.lower() if text.lower() in ("mean", "sum") else text


def _aggregate(table, how):
    """The chosen samples' values (columns of `table`) combined by `how`."""
    return table.sum(axis=1) if how == "sum" else table.mean(axis=1)


# -- wide exports: one sample per row, the bin midpoints as column headers ----------
_MID_CELL = re.compile(
    r"^\s*(\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s*(um|µm|μm|nm)?\s*$", re.IGNORECASE
)
#: Header names (without their unit) of a wide export whose unit is the
#: midpoints': AIM's marker column ``Diameter Midpoint (nm)``, the sized range
#: ``Lower Size(nm)`` and its statistics ``Median(µm)``, ``Geo. Mean(nm)``, ...
_SIZED = {
    "diameter midpoint",
    "aerodynamic diameter",
    "lower size",
    "upper size",
    "median",
    "mean",
    "geo. mean",
    "mode",
    "d50",
}


def _sized(name):
    """True if header `name` is a diameter whose unit is the midpoints'."""
    return re.sub(r"\s*[\(\[].*$", "", name).strip().lower() in _SIZED


def _mid_cell(cell):
    """(value, unit or None) of a header cell naming a bin midpoint, else None."""
    m = _MID_CELL.match(cell)
    if not m or not float(m.group(1)) > 0:
        return None
    return float(m.group(1)), m.group(2)


def _numeric_run(cells):
    """[a, b): the longest run (>= 3) of increasing midpoint cells, else None."""
    vals = [_mid_cell(c) for c in cells]
    best, k = None, 0
    while k < len(cells):
        if vals[k] is None:
            k += 1
            continue
        j = k + 1
        while j < len(cells) and vals[j] is not None and vals[j][0] > vals[j - 1][0]:
            j += 1
        if j - k >= 3 and (best is None or j - k > best[1] - best[0]):
            best = (k, j)
        k = j
    return best


_BIN_NAME = re.compile(r"^\s*bin\s*[_#]?\s*(\d+)\s*$", re.IGNORECASE)


def _named_run(cells):
    """[a, b): the longest run (>= 3) of bin names with consecutive numbers
    (``bin0, bin1, ...``, ``Bin 1, Bin 2, ...``), else None."""
    nums = [_BIN_NAME.match(c) for c in cells]
    nums = [int(m.group(1)) if m else None for m in nums]
    best, k = None, 0
    while k < len(cells):
        if nums[k] is None:
            k += 1
            continue
        j = k + 1
        while j < len(cells) and nums[j] is not None and nums[j] == nums[j - 1] + 1:
            j += 1
        if j - k >= 3 and (best is None or j - k > best[1] - best[0]):
            best = (k, j)
        k = j
    return best


def _wide_rows(path):
    """The header of a wide export (a TSI AIM *row* export, an OPC or SMPS time
    series): a row whose cells include >= 3 increasing bin midpoints and names
    (no other numbers), followed by a row with numbers under the midpoints; else
    the last row (of the first 200) naming >= 3 bins ``bin0, bin1, ...`` followed
    by a row of numbers under them (their sizes are then given as `edges_um`).
    Returns (rows, header index, (a, b), encoding, sized) or None."""
    lines, encoding = _text_lines(path)
    sniffed = [sniff_delimiter(t) for _, t in data_lines(lines[:200])]
    sniffed = [d for d in sniffed if d]  # a preamble line may have no delimiter
    delimiter = max(set(sniffed), key=sniffed.count) if sniffed else SNIFF
    whole, delimiter = split_rows(  # the head only: a long file is split once
        lines[:400], source=path, delimiter=delimiter, trailing_comments=False
    )

    def numbers_below(i, a, b):
        nxt = whole[i + 1][1] if i + 1 < len(whole) else []
        return len(nxt) >= b and all(is_number(c) for c in nxt[a:b])

    def found(i, run, sized):
        cut, _ = split_rows(lines, source=path, delimiter=delimiter or "")
        body = [r for r in cut if r[0] > whole[i][0]]
        return whole[: i + 1] + body, i, run, encoding, sized

    named = None
    for i, (_, cells) in enumerate(whole[:200]):
        run = _named_run(cells)
        if run is not None and numbers_below(i, *run):
            named = (i, run)
        run = _numeric_run(cells)
        if run is None:
            continue
        a, b = run
        others = [c for k, c in enumerate(cells) if not a <= k < b and c.strip()]
        if (
            all(len(r) < b for _, r in whole[:i])
            and others
            and not any(is_number(c) for c in others)
            and numbers_below(i, a, b)
        ):
            return found(i, run, True)
    return None if named is None else found(*named, False)


def _aim_edges(path, meta, mids_um):
    """(edges [µm], note) of an AIM export's channels: on the grid of the export's
    ``Channels/Decade`` (every channel ``1/c`` wide in ``log10 d``, the grid placed
    by least squares through the printed midpoints) when the midpoints lie on it
    within 1 %, else the geometric edges of :func:`edges_from_midpoints`."""
    cells = meta.get("channels/decade") or [""]
    c = float(cells[0]) if is_number(cells[0]) else math.nan
    k = np.arange(mids_um.size)
    if c > 0:
        offset = float(np.mean(np.log10(mids_um) - k / c))
        grid = 10 ** (offset + k / c)
        worst = float(np.max(np.abs(grid / mids_um - 1)))
        if worst < 0.01:
            edges = 10 ** (offset + (np.arange(mids_um.size + 1) - 0.5) / c)
            return edges, (
                f"bin edges on the export's grid of {c:g} channels per decade (each "
                f"1/{c:g} wide in log10 d; the printed midpoints lie on it within "
                f"{100 * worst:.2g} %)"
            )
    try:
        edges = edges_from_midpoints(mids_um)
    except ValueError as exc:
        raise DataFormatError(str(exc), source=path) from None
    return edges, "bin edges derived from the midpoints as geometric (log) midpoints"


def _header_edges(path, meta, header, names, run, unit, what, syntax):
    """(edges [µm], unit, unit_from, note) of a wide header of bin midpoints."""
    a, b = run
    mids = np.array([_mid_cell(header[k])[0] for k in range(a, b)])
    cell_units = {_mid_cell(header[k])[1] for k in range(a, b)} - {None}
    sized = [h for h in names if _sized(h)]
    named = [u for u in (header_unit(h)[0] for h in sized) if u is not None]
    named += list(cell_units)
    if len({length_factor(u) for u in named}) > 1:
        raise DataFormatError(
            f"the header names different length units ({sorted(set(named))}); "
            "allowed: one unit",
            source=path,
            field="unit",
        )
    from_file = named[0] if named else None
    if unit is None and from_file is None:
        raise _ask(
            path,
            f"the {what} does not say the unit of its bin midpoints "
            f"({header[a].strip()}..{header[b - 1].strip()})",
            [("unit", "nm", "e.g. an SMPS"), ("unit", "um", "e.g. an APS or OPC")],
            syntax,
            field="unit",
        )
    if (
        unit is not None
        and from_file is not None
        and length_factor(unit) != length_factor(from_file)
    ):
        raise DataFormatError(
            f"the header gives the unit {from_file!r} but the unit given is "
            f"{unit!r}; allowed: the same unit, or leave it out",
            source=path,
            field="unit",
        )
    unit_from = "argument" if unit is not None else "header"
    unit = unit or from_file
    edges, note = _aim_edges(path, meta, mids * (length_factor(unit) / 1e-6))
    return edges, unit, unit_from, note


def _given_edges(path, edges_um, header, run, unit, syntax):
    """The `edges_um` given for the bin columns ``bin0, bin1, ...`` (run)."""
    a, b = run
    k = b - a
    if edges_um is None:
        example = "0.35,0.46,..." if syntax == "cli" else "[0.35, 0.46, ...]"
        raise _ask(
            path,
            f"the bin columns {header[a].strip()}..{header[b - 1].strip()} do not "
            f"give their sizes; give the {k + 1} bin boundaries in um (from the "
            "instrument's manual or calibration)",
            [("edges_um", example, f"{k + 1} increasing boundaries")],
            syntax,
            field="edges_um",
        )
    if unit is not None:
        raise DataFormatError(
            f"unit {unit!r} is for diameters in the file; edges_um are in "
            "micrometres; leave the unit out",
            source=path,
            field="unit",
        )
    try:
        edges = np.asarray(edges_um, float).ravel()
    except (TypeError, ValueError):
        edges = np.array([math.nan])
    if (
        edges.size != k + 1
        or not np.all(np.isfinite(edges) & (edges > 0))
        or np.any(np.diff(edges) <= 0)
    ):
        raise DataFormatError(
            f"edges_um {list(np.atleast_1d(edges_um))} do not bound the {k} bin "
            f"columns {header[a].strip()}..{header[b - 1].strip()}; allowed: "
            f"{k + 1} increasing boundaries > 0 in um",
            source=path,
            field="edges_um",
        )
    return edges


#: Names (folded) of a wide export's timestamp column.
_TIME_NAMES = {
    "timestamp",
    "time",
    "datetime",
    "timestamputc",
    "timeutc",
    "datetimeutc",
}


def _timestamps(header, data):
    """The ISO 8601 times of the samples (the column named ``timestamp``,
    ``time`` or ``datetime``), else None (no such column, or a cell that is not
    one)."""
    cols = [k for k, h in enumerate(header) if _key(h) in _TIME_NAMES]
    if not cols:
        return None
    k = cols[0]
    times = [_iso_time(c[k]) if k < len(c) else None for _, c in data]
    return None if not times or any(t is None for t in times) else times


def _label_column(header):
    """Index of the Sample # column of a wide header, else None."""
    for k, h in enumerate(header):
        if re.sub(r"[\s_.]", "", h.lower()) in ("sample#", "sampleno", "samplenumber"):
            return k
    return None


def _read_wide(path, found, *, values, sample, unit, edges_um, syntax):
    rows, i, (a, b), encoding, sized = found
    header = rows[i][1]
    meta = {c[0].strip().lower(): c[1:] for _, c in rows[:i] if c}
    data = [(line, cells) for line, cells in rows[i + 1 :] if any(cells)]
    aim = "units" in meta and "weight" in meta
    what = "AIM row export" if aim else "wide export"
    if aim:
        kind = _aim_values(path, meta, values)
    elif values is not None:
        kind = values
    else:
        raise _ask(
            path,
            f"the {what} (one sample per row, the bins {header[a].strip()}.."
            f"{header[b - 1].strip()} as column headers) does not say what its "
            "values are",
            _values_choices(),
            syntax,
            field="values",
        )
    label_col = _label_column(header)
    numbered = []
    if label_col is None:
        labels = [str(r + 1) for r in range(len(data))]
    else:
        labels = [c[label_col].strip() if label_col < len(c) else "" for _, c in data]
        if len(set(labels)) != len(labels) or "" in labels:
            labels = [str(r + 1) for r in range(len(data))]
            numbered = [
                f"the {header[label_col].strip()!r} column repeats or misses "
                "numbers: samples are numbered by their row (1, 2, ...) instead"
            ]
    idx, how, chosen = _select(
        path, labels, sample, syntax, what, _timestamps(header, data)
    )
    names = [h.strip() for h in header]
    table = np.empty((b - a, len(idx)))
    for c, r in enumerate(idx):
        line, cells = data[r]
        if len(cells) < b:
            raise DataFormatError(
                f"the row has {len(cells)} cells, fewer than the {b} of the header; "
                "allowed: one value per bin",
                source=path,
                line=line,
            )
        for k in range(a, b):
            table[k - a, c] = _number(
                cells[k],
                path=path,
                line=line,
                field=f"column {names[k]!r}",
                allowed=f"a value >= 0 ({kind})",
                minimum=0.0,
                strict=False,
            )
    if sized:
        if edges_um is not None:
            raise DataFormatError(
                "edges_um is for wide exports whose bin columns do not give sizes "
                f"(bin0, bin1, ...); this one's headers are the midpoints "
                f"{header[a].strip()}..{header[b - 1].strip()}; leave it out",
                source=path,
                field="edges_um",
            )
        edges, unit, unit_from, how_edges = _header_edges(
            path, meta, header, names, (a, b), unit, what, syntax
        )
    else:
        edges = _given_edges(path, edges_um, header, (a, b), unit, syntax)
        unit, unit_from = "um", "argument"
        how_edges = f"bin edges as given ({edges.size} edges_um)"
    mids_um = np.sqrt(edges[:-1] * edges[1:])
    _check_plausible(path, "bin midpoints", mids_um * 1e-6, unit, unit_from)
    shown = (
        f"the {mids_um.size} bin midpoints in {unit}"
        if sized
        else (f"the {mids_um.size} bins {header[a].strip()}..{header[b - 1].strip()}")
    )
    notes = [
        f"{'TSI AIM row' if aim else 'wide'} export ({encoding}, one sample per row, "
        f"{shown} as column headers), {chosen} of {len(labels)}; {how_edges}",
        *numbered,
    ]
    skipped = [h for h in names[:a] if h.startswith("<")] + [
        h for h in names[b:] if h.startswith(">")
    ]
    if skipped:
        notes.append(
            f"the open-ended bins {skipped} (outside the sized range) are not read"
        )
    bins = _bins(path, edges, _aggregate(table, how), kind, notes)
    statistics = {}
    if len(idx) == 1:
        cells = data[idx[0]][1]
        for k, h in enumerate(names):
            if (a <= k < b) or k == label_col or not h or k >= len(cells):
                continue
            if is_number(cells[k]):
                statistics[h] = float(cells[k])
    return bins, {
        "source": path,
        "layout": "aim-rows" if aim else "wide",
        "header": names,
        "values": kind,
        "value_column": None,
        "unit": unit,
        "unit_from": unit_from,
        "n_bins": int(mids_um.size),
        "samples": labels,
        "sample": _sample_key(labels, idx, how, sample),
        "selection": chosen,
        "n_samples_used": len(idx),
        "aggregate": how,
        "instrument_statistics": statistics,
        "concentration_header": _total_conc(names),
        "encoding": encoding,
        "delimiter": None,
    }


# -- TSI AIM "column" exports -------------------------------------------------------
_AIM_WEIGHT = {"number": "N", "mass": "M", "volume": "V"}
_AIM_UNITS = {"dw/dlogdp": "d{}/dlogDp", "dw/ddp": "d{}/dDp", "dw": "d{}"}


def _text_lines(path):
    """(lines, encoding): UTF-8, else Windows-1252 (as AIM writes ``cm³``)."""
    try:
        return read_lines(path, hint=_HINT), "utf-8"
    except DataFormatError as exc:
        if "not a UTF-8" not in str(exc):
            raise
    with open(path, encoding="cp1252", errors="replace") as fh:
        return fh.read().splitlines(), "cp1252"


def _aim_rows(path):
    """(rows, index of the ``Diameter Midpoint`` row, encoding) of a TSI AIM
    column export (one row per channel, one column per sample), else None."""
    lines, encoding = _text_lines(path)
    head = [t for t in lines[:80] if t.strip()]
    if not any(
        t.lower().lstrip().startswith("diameter midpoint") for t in head + lines
    ):
        return None
    rows, _ = split_rows(lines, source=path, trailing_comments=False)
    for i, (_, cells) in enumerate(rows):
        first = cells[0].strip().lower() if cells else ""
        if first.startswith("diameter midpoint"):
            if any(c.strip() for c in cells[1:]):
                return None  # the "row" export: one row per sample (not read)
            return rows, i, encoding
    return None


def _aim_values(path, meta, values):
    units = (meta.get("units") or [""])[0].strip().lower()
    weight = (meta.get("weight") or [""])[0].strip().lower()
    if values is not None:
        return values
    if units in _AIM_UNITS and weight in _AIM_WEIGHT:
        return _AIM_UNITS[units].format(_AIM_WEIGHT[weight])
    raise DataFormatError(
        f"the export's Units {units or '(missing)'!r} and Weight "
        f"{weight or '(missing)'!r} are not a number, mass or volume weighting this "
        "reader knows; export with Weight Number (or Mass, Volume), or give the "
        "values",
        source=path,
        field="values",
    )


def _read_aim(path, found, *, values, sample, unit, syntax):
    rows, i, encoding = found
    meta = {c[0].strip().lower(): c[1:] for _, c in rows[:i] if c}
    stats_rows = {}
    data = []
    for line, cells in rows[i + 1 :]:
        if data and not is_number(cells[0]):
            stats_rows[cells[0].strip()] = cells[1:]
        elif is_number(cells[0]):
            if stats_rows:
                raise DataFormatError(
                    "a channel row after the statistics rows",
                    source=path,
                    line=line,
                )
            data.append((line, cells))
    if len(data) < 2:
        raise DataFormatError(
            "the AIM export has fewer than 2 channel rows under 'Diameter Midpoint'",
            source=path,
        )
    labels = [c.strip() for c in meta.get("sample #", [])]
    n_samples = max(len(c) for _, c in data) - 1
    labels = (labels + [str(k + 1) for k in range(len(labels), n_samples)])[:n_samples]
    kind = _aim_values(path, meta, values)
    cols, how, chosen = _select(path, labels, sample, syntax, "AIM column export")
    mids = np.empty(len(data))
    table = np.empty((len(data), len(cols)))
    for r, (line, cells) in enumerate(data):
        mids[r] = _number(
            cells[0],
            path=path,
            line=line,
            field="column 0 (Diameter Midpoint)",
            allowed="a diameter > 0",
            minimum=0.0,
        )
        for c, k in enumerate(cols):
            cell = cells[k + 1] if k + 1 < len(cells) else ""
            table[r, c] = _number(
                cell,
                path=path,
                line=line,
                field=f"sample {labels[k]}",
                allowed=f"a value >= 0 ({kind})",
                minimum=0.0,
                strict=False,
            )
    named = [header_unit(name)[0] for name in stats_rows]
    named = [u for u in named if u is not None]
    from_file = named[0] if named else None
    if unit is None and from_file is None:
        raise _ask(
            path,
            "the AIM export does not say the unit of its midpoints",
            [("unit", "nm", "an SMPS export"), ("unit", "um", "an APS export")],
            syntax,
            field="unit",
        )
    if (
        unit is not None
        and from_file is not None
        and length_factor(unit) != length_factor(from_file)
    ):
        raise DataFormatError(
            f"the export's statistics rows give the unit {from_file!r} but the unit "
            f"given is {unit!r}; allowed: the same unit, or leave it out",
            source=path,
            field="unit",
        )
    unit_from = "argument" if unit is not None else "header"
    unit = unit or from_file
    mids_um = mids * (length_factor(unit) / 1e-6)
    edges, how_edges = _aim_edges(path, meta, mids_um)
    _check_plausible(path, "Diameter Midpoint", mids_um * 1e-6, unit, unit_from)
    notes = [
        f"TSI AIM column export ({encoding}), {chosen} of {n_samples}; "
        f"{mids.size} midpoints in {unit}; {how_edges}",
    ]
    bins = _bins(path, edges, _aggregate(table, how), kind, notes)
    instrument = {}
    if len(cols) == 1:
        for name, cells in stats_rows.items():
            k = cols[0]
            if k < len(cells) and is_number(cells[k]):
                instrument[name] = float(cells[k])
    return bins, {
        "source": path,
        "layout": "aim-columns",
        "header": None,
        "values": kind,
        "unit": unit,
        "unit_from": unit_from,
        "n_bins": int(mids_um.size),
        "samples": labels,
        "sample": _sample_key(labels, cols, how, sample),
        "selection": chosen,
        "n_samples_used": len(cols),
        "aggregate": how,
        "instrument_statistics": instrument,
        "concentration_header": _total_conc(stats_rows),
        "encoding": encoding,
        "delimiter": None,
    }


# -- concentrations to counted particles ---------------------------------------------
_PER = (
    (re.compile(r"/\s*(cm3|cm³|cm\^3|cc)\b", re.IGNORECASE), 1.0, "cm^3"),
    (re.compile(r"/\s*(l|litre|liter)\b", re.IGNORECASE), 1e-3, "L"),
    (re.compile(r"/\s*(m3|m³|m\^3)\b", re.IGNORECASE), 1e-6, "m^3"),
)


def _per_cm3(name):
    """(factor to number per cm³, unit) of a value column's name, else None."""
    for pattern, factor, per in _PER:
        if pattern.search(name or ""):
            return factor, per
    return None


def _total_conc(names):
    """The name of an AIM export's ``Total Conc.(#/cm³)`` statistic, else None."""
    return next((h for h in names if h.lower().startswith("total conc")), None)


def _counted(path, bins, meta, volume_cm3, syntax):
    """`bins` of number concentrations as the particles counted in `volume_cm3`
    per sample (summed over the samples read): Poisson counts for the standard
    errors and the chi-squared test."""
    kind = bins.values
    weighting = BIN_VALUES[kind][0]
    option = _option("sampled_volume_cm3", volume_cm3, syntax)
    if kind == "count":
        raise DataFormatError(
            f"the values are counted particles already; {option} is for number "
            "concentrations (dN, dN/dlogDp, ...); leave it out",
            source=path,
            field="sampled_volume_cm3",
        )
    if weighting != "number":
        raise DataFormatError(
            f"the values are {kind} (a {weighting} weighting): no sampled volume "
            "turns them into counted particles; allowed with number concentrations "
            "(dN, dN/dlogDp, dN/dlnDp, dN/dDp)",
            source=path,
            field="sampled_volume_cm3",
        )
    named = meta.get("concentration_header") or meta.get("value_column")
    per = _per_cm3(str(named or ""))
    factor, unit = per if per is not None else (1.0, "cm^3")
    said = "" if per is not None else ", assumed: the file does not say"
    n_used = int(meta.get("n_samples_used", 1))
    samples = n_used if meta.get("aggregate") == "mean" else 1
    number = bins.number * factor * volume_cm3 * samples
    times = f" x {samples} samples" if samples > 1 else ""
    note = (
        f"number concentrations (per {unit}{said}) turned into counted particles: "
        f"x the sampled volume {volume_cm3:g} cm^3{times} = {float(number.sum()):.6g} "
        "particles; the standard errors and the chi-squared test assume Poisson "
        "counting of every particle in that volume (no coincidence, "
        "counting-efficiency, charging or inversion correction)"
    )
    return replace(bins, number=number, counted=True, notes=(*bins.notes, note))


def _legacy(header) -> bool:
    """A 3-column file that is read_histogram's columns layout: no header, or a
    header that names no bins (then its columns are lower, upper, count)."""
    if header is None:
        return True
    roles = [_column_role(h)[0] for h in header]
    return not ({"lower", "upper"} <= set(roles) or "mid" in roles)


def _check_edges(path, data, lower, upper):
    for r in range(lower.size):
        line = data[r][0]
        if not upper[r] > lower[r]:
            raise DataFormatError(
                f"upper edge {upper[r]:g} um is not above lower edge {lower[r]:g} um; "
                "allowed: upper > lower",
                source=path,
                line=line,
                field="upper edge",
            )
        if r and not math.isclose(lower[r], upper[r - 1], rel_tol=1e-6):
            what = "a gap" if lower[r] > upper[r - 1] else "an overlap or unsorted bins"
            raise DataFormatError(
                f"lower edge {lower[r]:g} um does not equal the previous upper edge "
                f"{upper[r - 1]:g} um ({what}); allowed: contiguous bins in "
                "increasing order",
                source=path,
                line=line,
                field="lower edge",
            )
    return np.append(lower, upper[-1])


def _bins(path, edges_um, values, kind, notes) -> BinnedSizes:
    if not np.sum(values) > 0:
        raise DataFormatError(
            "all values are zero; allowed: values >= 0 with a positive total",
            source=path,
            field="values",
        )
    number = number_per_bin(edges_um, values, kind)
    weighting = BIN_VALUES[kind][0]
    if weighting != "number":
        notes.append(
            f"{kind} converted to number per bin by dividing by d^3 of each bin's "
            "geometric midpoint (the d^3 moment)"
        )
    counted = kind == "count" and bool(np.all(values == np.round(values)))
    if kind == "count" and not counted:
        notes.append("the counts are not whole numbers: taken as relative frequencies")
    return BinnedSizes(
        edges_um=np.asarray(edges_um, float),
        number=number,
        values=kind,
        counted=counted,
        notes=tuple(notes),
    )


def read_size_data(
    path,
    *,
    layout=None,
    values=None,
    column=None,
    unit=None,
    sample=None,
    sampled_volume_cm3=None,
    edges_um=None,
    syntax="python",
):
    """Read size data of any layout: raw diameters or size bins.

    Parameters are those of :func:`read_size_bins`, with `layout` also
    ``"diameters"`` (then `column` chooses the diameter column and `values` is not
    allowed).

    Returns
    -------
    data : ndarray or BinnedSizes
        Raw diameters [m] (layout ``"diameters"``), else the bins.
    metadata : dict
        Of :func:`~microimpact.io.diameters.read_diameters` or
        :func:`read_size_bins`, with ``layout``.
    """
    path = os.fspath(path)
    check_choice(syntax, "syntax", _SYNTAX)
    if layout is not None and layout not in SIZE_LAYOUTS:
        raise DataFormatError(
            f"layout {layout!r} unknown; allowed: {', '.join(SIZE_LAYOUTS)}",
            source=path,
            field="layout",
        )
    if (
        layout is None
        and values is None
        and _aim_rows(path) is None
        and _wide_rows(path) is None
    ):
        rows, _ = _rows(path)
        header, data = _split_header(rows)
        if rows and not _rows_layout(rows):
            width = len(header) if header else len(data[0][1]) if data else 1
            layout = _layout(path, header, width, None, syntax)
    if layout == "diameters":
        if edges_um is not None:
            raise DataFormatError(
                "edges_um is for wide exports of size bins named bin0, bin1, ...; "
                "the file holds raw diameters; leave it out",
                source=path,
                field="edges_um",
            )
        if sample is not None:
            raise DataFormatError(
                "sample is for exports holding several samples of size bins; the "
                "file holds raw diameters; leave it out",
                source=path,
                field="sample",
            )
        if sampled_volume_cm3 is not None:
            raise DataFormatError(
                "sampled_volume_cm3 is for size bins of number concentrations, not "
                "raw diameters (each one a counted particle already); leave it out",
                source=path,
                field="sampled_volume_cm3",
            )
        if values is not None:
            raise DataFormatError(
                f"values {values!r} is for size bins, not raw diameters; leave it "
                "out or choose the edges or midpoints layout",
                source=path,
                field="values",
            )
        d, meta = read_diameters(path, column=column, unit=unit, syntax=syntax)
        return d, meta | {"layout": "diameters"}
    return read_size_bins(
        path,
        layout=layout,
        values=values,
        column=column,
        unit=unit,
        sample=sample,
        sampled_volume_cm3=sampled_volume_cm3,
        edges_um=edges_um,
        syntax=syntax,
    )
