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

import numpy as np

from .._core.files import (
    SNIFF,
    delimiter_name,
    looks_like_header,
    resolve_column,
    split_rows,
)
from .._core.validation import check_choice, check_scalar
from ..errors import DataFormatError
from ..population.binned import (
    BIN_VALUES,
    edges_from_midpoints,
)
from ..units import length_factor
from ._size_common import (
    _SYNTAX,
    _ask,
    _bin_value,
    _bins,
    _key,
    _text_lines,
    _values_choices,
)
from ._size_exports import (
    _UNIT_CHOICES,
    _aim_rows,
    _read_aim,
    _read_wide,
    _wide_rows,
)
from ._size_select import _counted
from .diameters import (
    _check_plausible,
    _factor,
    _number,
    _one_unit,
    _rows_layout,
    _split_header,
    _unit_agreed,
    read_diameters,
    read_histogram,
)
from .profiles import header_unit

__all__ = ["SIZE_LAYOUTS", "read_size_bins", "read_size_data"]

#: Bins without a stated unit whose median midpoint, read as µm, lies above this
#: [µm] are not taken as µm: beyond every optical or aerodynamic sizer (an APS
#: ends at 20 µm, OPCs near 40 µm) and where an SMPS's nanometres land. The unit
#: is asked for.
NM_LIKELY_UM = 50.0

#: How a size file may be laid out.
SIZE_LAYOUTS = ("diameters", "edges", "midpoints")


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


def _rows(path):
    """(rows, delimiter) of a delimited text file: UTF-8 or Windows-1252, a ``#``
    in the first row (a header such as ``dN/dlogDp (#/cm3)`` or ``Sample #``) kept,
    trailing ``# ...`` comments cut from the rows below it."""
    lines, _ = _text_lines(path)
    lines = _without_preamble(lines)
    rows, delimiter = split_rows(lines, source=path, delimiter=SNIFF)
    head = lines[: rows[0][0]] if rows else []  # up to the first data row
    whole, _ = split_rows(
        head, source=path, delimiter=delimiter or "", trailing_comments=False
    )
    if rows and whole and whole[0][0] == rows[0][0] and looks_like_header(whole[0][1]):
        rows[0] = whole[0]
    return rows, delimiter


def _without_preamble(lines):
    """`lines` with an instrument's key/value preamble (``Sample File,...``,
    ``Instrument,APS 3321``: lines of at most 2 cells) blanked, when a later line
    (of the first 50) is the real header: it names a size column (lower, upper or
    midpoint) and a value column. Blanked, not cut: line numbers stay the file's."""
    for i, text in enumerate(lines[:50]):
        cells = [c.strip().strip('"') for c in re.split(r"[,;\t]", text)]
        roles = {_column_role(c)[0] for c in cells if c}
        if "value" in roles and roles & {"lower", "upper", "mid"}:
            head = [t for t in lines[:i] if t.strip() and t.lstrip()[0] != "#"]
            if head and all(len(re.split(r"[,;\t]", t)) <= 2 for t in head):
                return [""] * i + list(lines[i:])
            return lines
    return lines


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


def _value_choices(header, cols):
    return [("column", header[j], f"the values {header[j]!r}") for j in cols]


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
    found = [(header[j], header_unit(header[j])[0]) for j in cols] if header else []
    stated = _one_unit(path, [(h, u) for h, u in found if u is not None])
    return _unit_agreed(path, unit, stated)


def _check_unit(path, unit):
    """DataFormatError naming the file where `unit` is not a length unit."""
    if unit is None:
        return
    try:
        length_factor(unit)
    except ValueError as exc:
        raise DataFormatError(str(exc), source=path, field="unit") from None


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
    _check_unit(path, unit)
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
    um = _factor(unit, path) / 1e-6
    names = header or [f"column {k}" for k in range(width)]
    table = np.empty((len(data), len(cols) + 1))
    for r, (line, cells) in enumerate(data):
        for c, k in enumerate(cols):
            table[r, c] = _number(
                cells[k] if k < len(cells) else "",
                path=path,
                line=line,
                field=f"column {names[k]!r}" if header else f"column {k}",
                allowed=f"a diameter > 0 in {unit}",
                minimum=0.0,
            )
        table[r, -1] = _bin_value(
            cells[j] if j < len(cells) else "",
            path=path,
            line=line,
            field=f"column {names[j]!r}" if header else f"column {j}",
            kind=kind,
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
            raise DataFormatError(
                f"{exc}; give the bin edges instead (lower and upper columns)",
                source=path,
            ) from None
        back = np.sqrt(edges[:-1] * edges[1:])
        notes.append(
            f"bin edges derived from the {mids.size} midpoints as geometric (log) "
            "midpoints (interior edges the geometric means of neighbours); the "
            "rebuilt bins' midpoints match the file's within "
            f"{100 * float(np.max(np.abs(back / mids - 1))):.2g} %"
        )
    mids_m = np.sqrt(edges[:-1] * edges[1:]) * 1e-6
    _check_plausible(path, f"column {names[cols[0]]!r}", mids_m, unit, unit_from)
    median_um = float(np.median(mids_m)) * 1e6
    if unit_from == "default" and median_um > NM_LIKELY_UM:
        raise _ask(
            path,
            f"the file does not say the unit of its bin sizes, and read as um their "
            f"median midpoint is {median_um:.4g} um, beyond every optical or "
            f"aerodynamic sizer (read as nm: {median_um / 1e3:.4g} um)",
            _UNIT_CHOICES,
            syntax,
            field="unit",
        )
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
    _check_unit(path, unit)
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
