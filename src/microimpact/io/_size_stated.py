"""What a size export states about its instrument, read and checked: the bin
midpoints and bin names of its header, its stated channel grid (an APS's channel
bounds), its cut points (an OPS), Grimm channel thresholds, the instrument's
class and diameter type, the values its rows state, and a second export in the
same file. Rules in ``docs/populations.md``; used by :mod:`._size_exports`."""

from __future__ import annotations

import math
import re

import numpy as np

from .._core.files import is_number
from ..errors import DataFormatError
from ..population.binned import BIN_VALUES
from ..units import length_factor

_MID_CELL = re.compile(
    r"^\s*(\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s*(um|µm|μm|nm)?\s*$", re.IGNORECASE
)


def _mid_cell(cell):
    """(value, unit or None) of a header cell naming a bin midpoint, else None."""
    m = _MID_CELL.match(cell)
    if not m or not float(m.group(1)) > 0:
        return None
    return float(m.group(1)), m.group(2)


_BIN_NAME = re.compile(r"^\s*bin\s*[_#]?\s*(\d+)\s*$", re.IGNORECASE)


def _shown(values) -> str:
    """`values` as the user typed them: ``[0.3, 0.374]``, never a NumPy repr."""

    def one(v):
        try:
            return f"{float(v):g}"
        except (TypeError, ValueError):
            return str(v)

    try:
        items = list(np.atleast_1d(np.asarray(values, dtype=object)).ravel())
    except (TypeError, ValueError):
        return str(values)
    return "[" + ", ".join(one(v) for v in items) + "]"


#: Metadata rows of an export that state its channel grid: the lower bound of its
#: first channel and the upper bound of its last (a TSI APS: ``Lower Channel
#: Bound 0.486968``, ``Upper Channel Bound 20.5353``).
_GRID_BOUNDS = ("lower channel bound", "upper channel bound")


def _stated_grid(path, meta, header, run, unit):
    """(edges [µm], note) of the sized channels from the grid the export states
    (its lower and upper channel bounds, with its ``Channels/Decade`` or else the
    number of channels it prints, the open-ended ``<0.523`` included), or None if
    it states none. Each printed midpoint must lie in its channel."""
    cells = [(meta.get(k) or [""])[0].strip() for k in _GRID_BOUNDS]
    if not all(is_number(c) for c in cells):
        return None
    lo, hi = (float(c) for c in cells)
    if not 0 < lo < hi:
        raise DataFormatError(
            f"the export's channel bounds {cells[0]}..{cells[1]} are not increasing "
            "positive sizes",
            source=path,
            field="Lower Channel Bound",
        )
    a, b = run
    factor = length_factor(unit) / 1e-6
    mids_um = np.array([_mid_cell(header[k])[0] for k in range(a, b)]) * factor
    below = int(a > 0 and header[a - 1].strip().startswith("<"))
    above = int(b < len(header) and header[b].strip().startswith(">"))
    per = (meta.get("channels/decade") or [""])[0].strip()
    span = math.log10(hi / lo)
    if is_number(per) and float(per) > 0:
        n = round(span * float(per))
        how = f"{float(per):g} channels per decade"
    else:
        n = below + (b - a) + above
        how = f"{n} channels printed"
    step = span / n
    first = below
    edges = lo * 10.0 ** ((first + np.arange(b - a + 1)) * step)
    inside = (mids_um > edges[:-1]) & (mids_um < edges[1:])
    if not np.all(inside):
        k = int(np.flatnonzero(~inside)[0])
        raise DataFormatError(
            f"the printed channel {header[a + k].strip()} lies outside its channel "
            f"[{edges[k]:.6g}, {edges[k + 1]:.6g}] um of the grid the export states "
            f"(Lower Channel Bound {cells[0]}, Upper Channel Bound {cells[1]}, {how}); "
            "allowed: an export whose channels lie on its stated grid",
            source=path,
            field="Lower Channel Bound",
        )
    return edges, (
        f"bin edges on the grid the export states: {cells[0]} to {cells[1]} um in "
        f"{n} channels of 1/{1 / step:.6g} decade; the {b - a} sized channels "
        f"are channels {first + 1}..{first + b - a} of them"
    )


_CUT_POINT = re.compile(
    r"^bin\s*(\d+)\s*cut\s*point\s*(?:[\(\[]\s*(\S+?)\s*[\)\]])?$", re.IGNORECASE
)


def _cut_points(path, meta, header, run):
    """(edges [µm], unit, note) of bin columns ``Bin 1 .. Bin k`` whose export
    states each bin's cut point (a TSI OPS 3330: ``Bin 1 Cut Point (um),0.300``):
    bin i spans its cut point to the next one; a last bin without a next cut
    point (the oversize bin) is not in the edges. None if the export states none."""
    cuts = {}
    unit = None
    for key, cells in meta.items():
        m = _CUT_POINT.match(key.strip())
        if m and cells and is_number(cells[0].strip()):
            cuts[int(m.group(1))] = float(cells[0])
            unit = m.group(2) or unit
    if not cuts:
        return None
    a, b = run
    numbers = [int(_BIN_NAME.match(header[k]).group(1)) for k in range(a, b)]
    if any(n not in cuts for n in numbers):
        missing = next(n for n in numbers if n not in cuts)
        raise DataFormatError(
            f"the export states cut points for bins {min(cuts)}..{max(cuts)} but not "
            f"for its bin column {header[a + numbers.index(missing)].strip()}; "
            "allowed: a cut point for every bin (or give edges_um)",
            source=path,
            field="edges_um",
        )
    unit = unit or "um"
    try:
        factor = length_factor(unit) / 1e-6
    except ValueError as exc:
        raise DataFormatError(str(exc), source=path, field="Bin 1 Cut Point") from None
    edges = [cuts[n] for n in numbers]
    if numbers[-1] + 1 in cuts:
        edges.append(cuts[numbers[-1] + 1])
    edges = np.asarray(edges) * factor
    if edges.size < 3 or np.any(np.diff(edges) <= 0) or edges[0] <= 0:
        raise DataFormatError(
            f"the export's cut points {_shown(edges / factor)} ({unit}) are not "
            "increasing sizes > 0 bounding 2 bins or more; allowed: increasing cut "
            "points (or give edges_um)",
            source=path,
            field="Bin 1 Cut Point",
        )
    return (
        edges,
        unit,
        f"bin edges are the export's {len(cuts)} cut points (each bin from its cut "
        "point to the next)",
    )


#: The sizes each class of instrument measures [µm], with a margin: an APS
#: 0.5-20 µm, an SMPS a few nm to about 1 µm, an OPS 3330 0.3-10 µm.
CLASS_RANGES_UM = {
    "APS": (0.3, 30.0),
    "SMPS": (0.001, 1.5),
    "OPS": (0.2, 15.0),
}


def _instrument_class(names, meta):
    """'APS', 'SMPS' or 'OPS' where the export says which instrument wrote it,
    else None."""
    instrument = " ".join(
        " ".join(meta.get(k) or []) for k in ("instrument", "instrument name")
    ).lower()
    model = " ".join(meta.get("model number") or []).strip()
    if (
        "aps" in instrument.split()
        or "3321" in instrument
        or any("aerodynamic diameter" in n.lower() for n in names)
    ):
        return "APS"
    if "classifier model" in meta or "dma model" in meta or "smps" in instrument:
        return "SMPS"
    if model == "3330" or "optical particle sizer" in instrument:
        return "OPS"
    return None


def _check_class(path, kind, mids_um, unit, unit_from):
    """DataFormatError where the bins lie outside what the export's instrument
    measures (:data:`CLASS_RANGES_UM`), naming the unit that would fit."""
    if kind is None:
        return
    lo, hi = CLASS_RANGES_UM[kind]
    first, last = float(mids_um[0]), float(mids_um[-1])
    if lo <= first and last <= hi:
        return
    raw = mids_um / (length_factor(unit) / 1e-6)
    fits = [
        u
        for u in ("nm", "um", "mm")
        if u != unit
        and lo <= raw[0] * length_factor(u) / 1e-6
        and raw[-1] * length_factor(u) / 1e-6 <= hi
    ]
    slip = f" (was it {fits[0]}?)" if fits else ""
    fix = (
        "the header names it: correct the header"
        if unit_from == "header"
        else "give the unit the file holds (unit='nm', 'um'; --unit on the CLI)"
    )
    raise DataFormatError(
        f"an {kind} measures {lo:g} to {hi:g} um, but the bins read in {unit} span "
        f"{first:.4g} to {last:.4g} um{slip}; {fix}",
        source=path,
        field="unit",
    )


#: The channel thresholds (lower channel boundaries) [µm] of a Grimm aerosol
#: spectrometer (models 1.108/1.109/11-D: 31 channels, the last open above 32 µm),
#: which its exports print as the channels' column headers. As published with the
#: instrument and used by the readers of pysmps-style and Matlab analyses.
GRIMM_THRESHOLDS_UM = (
    0.25, 0.28, 0.3, 0.35, 0.4, 0.45, 0.5, 0.58, 0.65, 0.7, 0.8, 1.0, 1.3, 1.6,
    2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.5, 7.5, 8.5, 10.0, 12.5, 15.0, 17.5, 20.0,
    25.0, 30.0, 32.0,
)  # fmt: skip


def _grimm_thresholds(header, run, unit):
    """(edges [µm], unit, unit_from, note) where the header's bin sizes are a run
    of at least 8 consecutive Grimm channel thresholds (:data:`GRIMM_THRESHOLDS_UM`,
    in µm, or in the `unit` given): they are the channels' lower boundaries, not
    midpoints. The last channel has no upper boundary in the file and is not in the
    edges. None for any other header."""
    a, b = run
    cells = [_mid_cell(header[k]) for k in range(a, b)]
    if any(c is None for c in cells) or b - a < 8:
        return None
    stated = {u for _, u in cells if u is not None}
    factor = length_factor(unit or (stated.pop() if len(stated) == 1 else "um")) / 1e-6
    sizes = [round(v * factor, 6) for v, _ in cells]
    grid = [round(t, 6) for t in GRIMM_THRESHOLDS_UM]
    if sizes[0] not in grid:
        return None
    i = grid.index(sizes[0])
    if grid[i : i + len(sizes)] != sizes:
        return None
    return (
        np.asarray(sizes, dtype=float),
        "um" if unit is None else unit,
        "Grimm channel set" if unit is None else "argument",
        f"the header sizes {header[a].strip()}..{header[b - 1].strip()} are a Grimm "
        "spectrometer's channel thresholds: each channel's lower boundary, the next "
        "threshold its upper one (not midpoints)",
    )


#: How the diameter type an export states is noted.
_DIAMETER_NOTES = {
    "aerodynamic": "the diameters are aerodynamic (the export's 'Aerodynamic "
    "Diameter'): never converted to aerodynamic diameters again",
    "mobility": "the diameters are electrical mobility diameters (the export's "
    "'Mobility Diameter' or a DMA classifier)",
}


def _diameter_type(names, meta):
    """'aerodynamic' or 'mobility' where the export says which diameter it
    measures, else None."""
    folded = " ".join(n.lower() for n in names)
    if "aerodynamic diameter" in folded:
        return "aerodynamic"
    if (
        "mobility diameter" in folded
        or "classifier model" in meta
        or "dma model" in meta
    ):
        return "mobility"
    return None


def _values_in_rows(path, header, data, run):
    """The value kind every data row states in a cell outside the bins (an APS
    row's ``dN/dlogDp`` under its ``Aerodynamic Diameter`` column), else None."""
    a, b = run
    folded = {k.lower(): k for k in BIN_VALUES}
    found = set()
    for _, cells in data:
        kinds = {
            folded[c.strip().lower()]
            for k, c in enumerate(cells)
            if not a <= k < b and c.strip().lower() in folded
        }
        if len(kinds) != 1:
            return None
        found |= kinds
    return found.pop() if len(found) == 1 else None


def _one_export(path, header, meta, data, header_line, what):
    """DataFormatError where the file holds a second export below the first (a
    repeated header row, or a row of the first export's preamble): its samples
    would be numbered on from the first's."""
    names = [c.strip() for c in header if c.strip()]
    keys = {k for k in meta if k and not is_number(k)}
    for line, cells in data:
        first = cells[0].strip().lower() if cells else ""
        if [c.strip() for c in cells if c.strip()] == names or first in keys:
            raise DataFormatError(
                f"the file holds more than one {what}: a second one starts here "
                f"(the first's header row is line {header_line}); samples are "
                "numbered within one export, so it is not read as one; split the "
                "file into one export each",
                source=path,
                line=line,
            )
