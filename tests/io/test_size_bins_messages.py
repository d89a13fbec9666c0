"""The refusals of a size-bins file, word for word.

Each case writes a small binned export (midpoints or edges) and compares the
error's source, line, field and whole message with the reader's contract: the
argument or column named, the bad value, what is allowed (the binned layouts,
the value kinds of ``BIN_VALUES``, contiguous increasing bins) and how to choose.
"""

from __future__ import annotations

import pytest
from ids import ascii_id

from microimpact.errors import DataFormatError
from microimpact.io.size_bins import read_size_bins
from microimpact.population.binned import BIN_VALUES

MIDS = "midpoint_um,dN/dlogDp\n1,5\n2,6\n4,3\n"

CASES = [
    # (text, arguments, line, field, message)
    (
        MIDS,
        {"layout": "counts"},
        None,
        "layout",
        "layout 'counts' is not a binned layout; allowed: edges, midpoints",
    ),
    (
        MIDS,
        {"values": "dX"},
        None,
        "values",
        f"values 'dX' unknown; allowed: {', '.join(BIN_VALUES)}",
    ),
    (
        MIDS,
        {"sampled_volume_cm3": -1},
        None,
        "sampled_volume_cm3",
        "sampled_volume_cm3 -1 is not a volume; allowed: a number > 0 (cm^3 of air "
        "in which one sample's particles were counted)",
    ),
    (
        MIDS,
        {"sample": 2},
        None,
        "sample",
        "sample is for exports holding several samples (a TSI AIM column or row "
        "export, a wide time series with the bin midpoints as column headers); "
        "this file is not one",
    ),
    (
        MIDS,
        {"edges_um": [1, 2, 3, 4]},
        None,
        "edges_um",
        "edges_um is for wide exports whose bin columns do not give sizes (bin0, "
        "bin1, ...); this file is not one",
    ),
    (
        MIDS,
        {"values": "dM/dlogDp"},
        None,
        "values",
        "the header 'dN/dlogDp' says the values are dN/dlogDp but the values given "
        "are 'dM/dlogDp'; allowed: the same, or leave it out to use the header's",
    ),
    ("midpoint_um,dN/dlogDp\n", {}, None, None, "no bins found (only a header)"),
    ("", {}, None, None, "the file is empty; expected size bins"),
    (
        "midpoint_um,dN/dlogDp\n1,5\n4,6\n2,3\n",
        {},
        4,
        "column 'midpoint_um'",
        "the midpoints must be strictly increasing; allowed: one row per bin, in "
        "increasing order",
    ),
    (
        "lower_um,upper_um,count\n1,2,5\n2,1.5,6\n",
        {},
        3,
        "upper edge",
        "upper edge 1.5 um is not above lower edge 2 um; allowed: upper > lower",
    ),
    (
        "lower_um,upper_um,count\n1,2,5\n3,4,6\n",
        {},
        3,
        "lower edge",
        "lower edge 3 um does not equal the previous upper edge 2 um (a gap); "
        "allowed: contiguous bins in increasing order",
    ),
    (
        "diameter_um\n1\n2\n",
        {},
        None,
        None,
        "the file holds raw diameters (no value column), not size bins; allowed: a "
        "value column such as count, dN, dN/dlogDp, dN/dlnDp, dN/dDp",
    ),
    (
        "midpoint_um,dN/dlogDp,dM/dlogDp\n1,5,1\n2,6,2\n4,3,3\n",
        {},
        None,
        "column",
        "the file has 2 value columns ('dN/dlogDp', 'dM/dlogDp'); choose one: "
        "column='dN/dlogDp' (the values 'dN/dlogDp'); column='dM/dlogDp' (the "
        "values 'dM/dlogDp')",
    ),
]


@pytest.mark.parametrize(
    ("text", "kw", "line", "field", "message"),
    CASES,
    ids=[ascii_id(c[4][:40]) for c in CASES],
)
def test_each_size_bins_refusal_in_full(tmp_path, text, kw, line, field, message):
    path = tmp_path / "bins.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_size_bins(path, **kw)
    err = info.value
    assert (err.source, err.line, err.field, err.message) == (
        str(path),
        line,
        field,
        message,
    )


# ---------------------------------------------------------------- read_size_data
DIAMETERS = "diameter_um\n12\n15\n18\n"
DATA_CASES = [
    # (text, arguments, field, message)
    (
        MIDS,
        {"layout": "bins"},
        "layout",
        "layout 'bins' unknown; allowed: diameters, edges, midpoints",
    ),
    (
        DIAMETERS,
        {"layout": "diameters", "edges_um": [1, 2]},
        "edges_um",
        "edges_um is for wide exports of size bins named bin0, bin1, ...; the file "
        "holds raw diameters; leave it out",
    ),
    (
        DIAMETERS,
        {"layout": "diameters", "sample": 1},
        "sample",
        "sample is for exports holding several samples of size bins; the file holds "
        "raw diameters; leave it out",
    ),
    (
        DIAMETERS,
        {"layout": "diameters", "sampled_volume_cm3": 1.0},
        "sampled_volume_cm3",
        "sampled_volume_cm3 is for size bins of number concentrations, not raw "
        "diameters (each one a counted particle already); leave it out",
    ),
    (
        DIAMETERS,
        {"layout": "diameters", "values": "count"},
        "values",
        "values 'count' is for size bins, not raw diameters; leave it out or choose "
        "the edges or midpoints layout",
    ),
]


@pytest.mark.parametrize(
    ("text", "kw", "field", "message"),
    DATA_CASES,
    ids=[ascii_id(c[3][:40]) for c in DATA_CASES],
)
def test_each_size_data_refusal_in_full(tmp_path, text, kw, field, message):
    """read_size_data (raw diameters or bins): the options that do not apply to
    the file refused, naming the option and saying what to do."""
    from microimpact.io.size_bins import read_size_data

    path = tmp_path / "data.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, **kw)
    err = info.value
    assert (err.source, err.field, err.message) == (str(path), field, message)


def test_a_sampled_volume_for_counted_particles_is_refused_by_name(tmp_path):
    path = tmp_path / "bins.csv"
    path.write_text("midpoint_um,count\n1,5\n2,6\n4,3\n", encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_size_bins(path, sampled_volume_cm3=2.0)
    assert (info.value.field, info.value.message) == (
        "sampled_volume_cm3",
        "the values are counted particles already; sampled_volume_cm3=2.0 is for "
        "number concentrations (dN, dN/dlogDp, ...); leave it out",
    )
