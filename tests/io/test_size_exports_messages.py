"""What the size readers tell a user who must choose or correct something: each
message names the file, the field, the bad value and every allowed choice, and
each choice is spelt as the user passes it (docs/populations.md).

Oracles: the value kinds and sample choices docs/populations.md lists, the
export's own cells, and the bins read by hand."""

from __future__ import annotations

import numpy as np
import pytest

from microimpact.errors import DataFormatError
from microimpact.io.size_bins import read_size_bins, read_size_data

WIDE = "Sample #,0.5 um,0.7 um,1 um\n1,5,6,5\n"


def _error(write_file, name, text, **kw):
    path = write_file(name, text)
    with pytest.raises(DataFormatError) as info:
        read_size_bins(path, **kw)
    return info.value, str(info.value)


def test_a_wide_export_without_a_value_kind_lists_the_six_kinds(write_file):
    exc, msg = _error(write_file, "w.csv", WIDE)
    assert exc.field == "values"
    assert (
        "w.csv: values: the wide export (one sample per row, the bins 0.5 um..1 um "
        "as column headers) does not say what its values are" in msg
    )
    choices = msg.split("; choose one: ")[1]
    assert choices == (
        "values='count' (number per bin); values='dN' (number per bin); "
        "values='dN/dlogDp' (number density over log10); "
        "values='dN/dDp' (number density over d); "
        "values='dM/dlogDp' (mass density over log10); "
        "values='dV/dlogDp' (volume density over log10)"
    )


def test_several_samples_without_a_choice_list_how_to_choose(write_file):
    exc, msg = _error(write_file, "w2.csv", WIDE + "2,1,2,3\n", values="count")
    assert exc.field == "sample"
    assert "w2.csv: sample: the wide export holds 2 samples (1..2); choose one: " in msg
    assert msg.endswith(
        "sample=1 (one sample: its Sample #, else its row number); "
        "sample='mean' (the mean of all samples); "
        "sample='sum' (the sum of all samples); "
        "sample='1..2' (the mean of a range)"
    )


def test_a_negative_value_names_the_value_kind_it_is_read_as(write_file):
    text = "Sample #,0.5 um,0.7 um,1 um\n1,5,-6,5\n"
    exc, msg = _error(write_file, "neg.csv", text, values="dN/dlogDp")
    assert exc.field == "column '0.7 um'"
    assert msg.endswith(
        "neg.csv:2: column '0.7 um': bad value '-6'; allowed: a value >= 0 (dN/dlogDp)"
    )


def test_a_sample_number_missing_from_a_short_row_numbers_rows_instead(write_file):
    # the Sample # column last, and the second row cut short of it: the rows are
    # numbered 1, 2 and said to be, never an internal error
    text = "0.5 um,0.7 um,1 um,Sample #\n5,6,5,1\n1,2,3\n"
    bins, meta = read_size_bins(write_file("s.csv", text), values="count", sample="2")
    np.testing.assert_array_equal(bins.number, [1, 2, 3])
    assert meta["samples"] == ["1", "2"]
    assert any("'Sample #' column repeats or misses numbers" in n for n in bins.notes)


def test_stated_channel_bounds_not_increasing_name_the_bound(write_file):
    text = (
        "Lower Channel Bound,0.9\nUpper Channel Bound,0.5\n"
        "Sample #,0.6 um,0.7 um,0.8 um\n1,5,6,5\n"
    )
    exc, msg = _error(write_file, "grid.csv", text, values="count")
    assert exc.field == "Lower Channel Bound"
    assert msg.endswith(
        "grid.csv: Lower Channel Bound: the export's channel bounds 0.9..0.5 are "
        "not increasing positive sizes"
    )


def test_raw_diameters_read_as_bins_name_the_value_columns_allowed(write_file):
    exc, msg = _error(write_file, "raw.csv", "diameter_um\n1\n2\n3\n")
    assert exc.field is None
    assert msg.endswith(
        "raw.csv: the file holds raw diameters (no value column), not size bins; "
        "allowed: a value column such as count, dN, dN/dlogDp, dN/dlnDp, dN/dDp"
    )
    # read_size_data reads the same file as diameters
    assert read_size_data(write_file("raw2.csv", "diameter_um\n1\n2\n3\n"))


def test_a_layout_that_is_not_binned_is_refused_by_its_field(write_file):
    exc, msg = _error(
        write_file, "lay.csv", "Dp (um),count\n1,5\n2,6\n", layout="diameters"
    )
    assert exc.field == "layout"
    assert msg.endswith(
        "lay.csv: layout: layout 'diameters' is not a binned layout; "
        "allowed: edges, midpoints"
    )
