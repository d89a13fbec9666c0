"""TSI AIM exports and wide size exports (one sample per row): finding the
header, the bins' edges (AIM's ``Channels/Decade`` grid, the header's midpoints or
the ``edges_um`` given for ``bin0, bin1, ...`` columns), the unit, the samples and
the statistics the export states; rules in ``docs/populations.md``."""

from __future__ import annotations

import math
import re

import numpy as np

from .._core.files import (
    SNIFF,
    data_lines,
    is_number,
    sniff_delimiter,
    split_rows,
)
from ..errors import DataFormatError
from ..population.binned import edges_from_midpoints
from ..units import length_factor
from ._size_common import (
    _ask,
    _bin_value,
    _bins,
    _key,
    _option,
    _text_lines,
    _values_choices,
)
from ._size_select import _aggregate, _iso_time, _sample_key, _select, _total_conc
from ._size_stated import (
    _BIN_NAME,
    _DIAMETER_NOTES,
    _check_class,
    _cut_points,
    _diameter_type,
    _grimm_thresholds,
    _instrument_class,
    _mid_cell,
    _one_export,
    _shown,
    _stated_grid,
    _values_in_rows,
)
from .diameters import (
    _check_plausible,
    _number,
    _one_unit,
    _unit_agreed,
)
from .profiles import header_unit

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


#: The choices of the error asking for the unit of an export's midpoints.
_UNIT_CHOICES = [("unit", "nm", "e.g. an SMPS"), ("unit", "um", "e.g. an APS or OPC")]


def _sized(name):
    """True if header `name` is a diameter whose unit is the midpoints'."""
    return re.sub(r"\s*[\(\[].*$", "", name).strip().lower() in _SIZED


def _longest_run(items, follows):
    """[a, b): the longest run (>= 3; the first of equal length) of items not None
    in which each follows the one before (``follows(before, item)``), else None."""
    best, k = None, 0
    while k < len(items):
        if items[k] is None:
            k += 1
            continue
        j = k + 1
        while (
            j < len(items) and items[j] is not None and follows(items[j - 1], items[j])
        ):
            j += 1
        if j - k >= 3 and (best is None or j - k > best[1] - best[0]):
            best = (k, j)
        k = j
    return best


def _numeric_run(cells):
    """[a, b): the longest run (>= 3) of increasing midpoint cells, else None."""
    return _longest_run([_mid_cell(c) for c in cells], lambda u, v: v[0] > u[0])


def _named_run(cells):
    """[a, b): the longest run (>= 3) of bin names with consecutive numbers
    (``bin0, bin1, ...``, ``Bin 1, Bin 2, ...``), else None."""
    nums = [_BIN_NAME.match(c) for c in cells]
    nums = [int(m.group(1)) if m else None for m in nums]
    return _longest_run(nums, lambda u, v: v == u + 1)


def _filled(cells) -> int:
    """Number of cells up to the last non-empty one (AIM 11 pads every row of its
    CSV export with empty cells to the width of the table)."""
    n = len(cells)
    while n and not cells[n - 1].strip():
        n -= 1
    return n


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
            all(_filled(r) < b for _, r in whole[:i])
            and others
            and not any(is_number(c) for c in others)
            and numbers_below(i, a, b)
        ):
            return found(i, run, True)
    return None if named is None else found(*named, False)


def _aim_edges(path, meta, mids_um, hint=""):
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
        raise DataFormatError(f"{exc}{hint}", source=path, field="edges_um") from None
    return edges, "bin edges derived from the midpoints as geometric (log) midpoints"


def _header_edges(path, meta, header, names, run, unit, what, syntax, edges_um):
    """(edges [µm], unit, unit_from, note) of a wide header of bin sizes: derived
    from them as midpoints, or the `edges_um` given (each header size inside its
    bin: a midpoint, or the lower boundary of an OPC's channel)."""
    a, b = run
    mids = np.array([_mid_cell(header[k])[0] for k in range(a, b)])
    stated = [(h, header_unit(h)[0]) for h in names if _sized(h)]
    stated += [(header[k].strip(), _mid_cell(header[k])[1]) for k in range(a, b)]
    stated = _one_unit(path, [(h, u) for h, u in stated if u is not None])
    unit, unit_from = _unit_agreed(path, unit, stated, default=None)
    if unit is None:
        raise _ask(
            path,
            f"the {what} does not say the unit of its bin midpoints "
            f"({header[a].strip()}..{header[b - 1].strip()})",
            _UNIT_CHOICES,
            syntax,
            field="unit",
        )
    mids_um = mids * (length_factor(unit) / 1e-6)
    k = b - a
    if edges_um is None:
        example = "0.3,0.4,..." if syntax == "cli" else "[0.3, 0.4, ...]"
        hint = (
            f"; give the {k + 1} bin boundaries in um: "
            f"{_option('edges_um', example, syntax)} (each header size inside its "
            "bin; a header of lower boundaries, as an OPC's channel thresholds, "
            "fits)"
        )
        edges, note = _aim_edges(path, meta, mids_um, hint)
        return edges, unit, unit_from, note
    edges = _given_edges(path, edges_um, header, run, None, syntax)
    tol = 1e-9
    inside = (mids_um >= edges[:-1] * (1 - tol)) & (mids_um < edges[1:] * (1 - tol))
    if not np.all(inside):
        i = int(np.flatnonzero(~inside)[0])
        raise DataFormatError(
            f"the bin column {header[a + i].strip()} ({mids_um[i]:g} um) lies outside "
            f"its bin [{edges[i]:g}, {edges[i + 1]:g}) um of edges_um; allowed: "
            f"{k + 1} increasing boundaries in um with each header size inside its "
            "bin (a midpoint, or the bin's lower boundary)",
            source=path,
            field="edges_um",
        )
    lower = bool(np.allclose(mids_um, edges[:-1], rtol=1e-6))
    what_sizes = (
        "the header sizes are the bins' lower boundaries (channel thresholds)"
        if lower
        else "each header size lies inside its bin"
    )
    return (
        edges,
        unit,
        unit_from,
        f"bin edges as given ({k + 1} edges_um); {what_sizes}",
    )


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
            f"edges_um {_shown(edges_um)} do not bound the {k} bin "
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
        if re.sub(r"[\s_.]", "", h.lower()) in (
            "sample#",
            "sampleno",
            "samplenumber",
            "scan#",
            "scanno",
            "scannumber",
        ):
            return k
    return None


def _read_wide(path, found, *, values, sample, unit, edges_um, syntax):
    rows, i, (a, b), encoding, sized = found
    header = rows[i][1]
    meta = {c[0].strip().lower(): c[1:] for _, c in rows[:i] if c}
    data = [(line, cells) for line, cells in rows[i + 1 :] if any(cells)]
    aim = "units" in meta and "weight" in meta
    what = "AIM row export" if aim else "wide export"
    _one_export(path, header, meta, data, rows[i][0], what)
    in_rows = _values_in_rows(path, header, data, (a, b))
    if aim:
        kind = _aim_values(path, meta, values)
    elif values is not None:
        kind = values
    elif in_rows is not None:
        kind = in_rows
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
            table[k - a, c] = _bin_value(
                cells[k], path=path, line=line, field=f"column {names[k]!r}", kind=kind
            )
    oversize = []
    grimm = None if edges_um is not None else _grimm_thresholds(header, (a, b), unit)
    if grimm is not None:
        edges, unit, unit_from, how_edges = grimm
        keep = edges.size - 1
        held = float(np.sum(_aggregate(table[keep:], how)))
        whole = float(np.sum(_aggregate(table, how)))
        oversize.append(
            f"the last channel {names[a + keep]} (at or above {edges[-1]:g} um, no "
            f"upper edge) held {held:g} of {whole:g} ({kind}, "
            f"{100 * held / whole if whole else 0:.3g} %) and is left out; give its "
            f"upper edge with edges_um (all {b - a + 1} boundaries) to include it"
        )
        table = table[:keep]
    elif sized:
        edges, unit, unit_from, how_edges = _header_edges(
            path, meta, header, names, (a, b), unit, what, syntax, edges_um
        )
        klass = _instrument_class(names, meta)
        _check_class(path, klass, np.sqrt(edges[:-1] * edges[1:]), unit, unit_from)
        if edges_um is None:
            stated = _stated_grid(path, meta, header, (a, b), unit)
            if stated is not None:
                edges, how_edges = stated
    else:
        cut = None if edges_um is not None else _cut_points(path, meta, header, (a, b))
        if cut is not None:
            edges, unit, how_edges = cut
            unit_from = "header"
            keep = edges.size - 1
            if keep < b - a:  # the oversize bin(s): no upper edge
                held = float(np.sum(_aggregate(table[keep:], how)))
                whole = float(np.sum(_aggregate(table, how)))
                oversize.append(
                    f"the oversize bin {names[a + keep]} (above {edges[-1]:g} um, no "
                    f"upper edge) held {held:g} of {whole:g} ({kind}, "
                    f"{100 * held / whole if whole else 0:.3g} %) and is left out; "
                    "give its upper edge with edges_um (all "
                    f"{b - a + 1} boundaries) to include it"
                )
                table = table[:keep]
        else:
            edges = _given_edges(path, edges_um, header, (a, b), unit, syntax)
            unit, unit_from = "um", "argument"
            how_edges = f"bin edges as given ({edges.size} edges_um)"
    mids_um = np.sqrt(edges[:-1] * edges[1:])
    _check_plausible(path, "bin midpoints", mids_um * 1e-6, unit, unit_from)
    _check_class(path, _instrument_class(names, meta), mids_um, unit, unit_from)
    if grimm is not None:
        shown = f"the {b - a} channel thresholds in {unit}"
    elif sized:
        what_sizes = "sizes" if edges_um is not None else "midpoints"
        shown = f"the {mids_um.size} bin {what_sizes} in {unit}"
    else:
        shown = f"the {b - a} bins {header[a].strip()}..{header[b - 1].strip()}"
    notes = [
        f"{'TSI AIM row' if aim else 'wide'} export ({encoding}, one sample per row, "
        f"{shown} as column headers), {chosen} of {len(labels)}; {how_edges}",
        *numbered,
    ]
    notes += oversize
    if in_rows is not None and values is None and not aim:
        notes.append(f"the values are {kind}, as every row says")
    diameter = _diameter_type(names, meta)
    if diameter is not None:
        notes.append(_DIAMETER_NOTES[diameter])
    skipped = [h for h in names[:a] if h.startswith("<")] + [
        h for h in names[b:] if h.startswith(">")
    ]
    if skipped:
        notes.append(
            f"the open-ended bins {skipped} (outside the sized range) are not read"
        )
    bins = _bins(path, edges, _aggregate(table, how), kind, notes, diameter)
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
        "diameter": diameter,
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


_AIM_WEIGHT = {"number": "N", "mass": "M", "volume": "V"}
_AIM_UNITS = {"dw/dlogdp": "d{}/dlogDp", "dw/ddp": "d{}/dDp", "dw": "d{}"}


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
    keys = {k for k in meta if k and not is_number(k)} | {"diameter midpoint"}
    for line, cells in rows[i + 1 :]:
        if cells and cells[0].strip().lower() in keys:
            raise DataFormatError(
                "the file holds more than one AIM column export: a second one starts "
                f"here (the first's 'Diameter Midpoint' row is line {rows[i][0]}); "
                "samples are numbered within one export, so it is not read as one; "
                "split the file into one export each",
                source=path,
                line=line,
            )
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
            table[r, c] = _bin_value(
                cell, path=path, line=line, field=f"sample {labels[k]}", kind=kind
            )
    stated = [(name, header_unit(name)[0]) for name in stats_rows]
    stated = next(((name, u) for name, u in stated if u is not None), None)
    unit, unit_from = _unit_agreed(
        path, unit, stated, where="statistics row", default=None
    )
    if unit is None:
        raise _ask(
            path,
            "the AIM export does not say the unit of its midpoints",
            _UNIT_CHOICES,
            syntax,
            field="unit",
        )
    mids_um = mids * (length_factor(unit) / 1e-6)
    edges, how_edges = _aim_edges(path, meta, mids_um)
    _check_plausible(path, "Diameter Midpoint", mids_um * 1e-6, unit, unit_from)
    _check_class(path, _instrument_class([], meta), mids_um, unit, unit_from)
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
