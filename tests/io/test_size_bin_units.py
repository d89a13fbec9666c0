"""Unit plausibility of size-bin files, on both sides (issue 34, item 3).

A bin file whose diameters, read in the unit its header names (or the unit
given), put the median bin midpoint below 10 nm or above 10 mm holds another
unit: metres written under a µm header, nanometres read as µm. The reader
refuses it with a message naming the file, the column and what to do; a file
just inside the limits is read. Both layouts (edges, midpoints) and both sources
of the unit (header, argument).
"""

from __future__ import annotations

import itertools

import pytest

from microimpact.errors import DataFormatError
from microimpact.io.size_bins import read_size_bins


def _edges_file(unit, edges):
    head = (
        "lower,upper,count" if unit is None else f"lower ({unit}),upper ({unit}),count"
    )
    rows = "".join(f"{a!r},{b!r},5\n" for a, b in itertools.pairwise(edges))
    return f"{head}\n{rows}"


def _mids_file(unit, mids):
    head = "Dp,count" if unit is None else f"Dp ({unit}),count"
    return f"{head}\n" + "".join(f"{m!r},5\n" for m in mids)


#: (case, file text, unit argument, "below"/"above"/None, where the unit came from)
CASES = [
    (
        "metres under a um header, edges",
        _edges_file("um", [1e-6, 2e-6, 4e-6]),
        None,
        "below",
        "header",
    ),
    (
        "metres under a um header, midpoints",
        _mids_file("um", [1e-6, 2e-6, 4e-6]),
        None,
        "below",
        "header",
    ),
    (
        "nm read as um by argument, edges",
        _edges_file(None, [20000.0, 40000.0, 80000.0]),
        "um",
        "above",
        "argument",
    ),
    (
        "nm read as um by argument, midpoints",
        _mids_file(None, [20000.0, 40000.0, 80000.0]),
        "um",
        "above",
        "argument",
    ),
    (
        "mm header holding um",
        _mids_file("mm", [20.0, 40.0, 80.0]),
        None,
        "above",
        "header",
    ),
    (
        "just above 10 nm",
        _mids_file("nm", [10.0, 10.0001, 10.0002]),
        None,
        None,
        "header",
    ),
    (
        "just below 10 mm",
        _mids_file("mm", [9.9998, 9.9999, 10.0]),
        None,
        None,
        "header",
    ),
    (
        "a wide but plausible spread",
        _edges_file("nm", [5.0, 20.0, 1e6]),
        None,
        None,
        "header",
    ),
]


@pytest.mark.parametrize(
    ("case", "text", "unit", "side", "unit_from"), CASES, ids=[c[0] for c in CASES]
)
def test_implausible_units_are_refused_on_both_sides(
    write_file, case, text, unit, side, unit_from
):
    path = write_file("bins.csv", text)
    if side is None:
        bins, meta = read_size_bins(path, unit=unit)
        assert meta["unit_from"] == unit_from
        assert bins.edges_um.size >= 3
        return
    with pytest.raises(DataFormatError) as err:
        read_size_bins(path, unit=unit)
    msg = str(err.value)
    assert "bins.csv" in msg and "\n" not in msg
    assert ("below 10 nm" if side == "below" else "above 10 mm") in msg, msg
    # what to do: correct the header, or give the unit
    assert ("header" in msg) if unit_from == "header" else ("unit=" in msg), msg
