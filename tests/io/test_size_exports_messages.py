"""What the size readers tell a user who must choose or correct something: each
message names the file, the field, the bad value and every allowed choice, and
each choice is spelt as the user passes it (docs/populations.md).

Oracles: the value kinds and sample choices docs/populations.md lists, the
export's own cells, and the bins read by hand."""

from __future__ import annotations

from pathlib import Path

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


def test_a_plain_wide_export_says_how_it_was_read(write_file):
    bins, meta = read_size_bins(write_file("w.csv", WIDE), values="count")
    assert bins.notes[0] == (
        "wide export (utf-8, one sample per row, the 3 bin midpoints in um as "
        "column headers), sample 1 of 1; bin edges derived from the midpoints as "
        "geometric (log) midpoints"
    )
    # it names no diameter type: taken as geometric, never as mobility
    assert meta["diameter"] is None and bins.diameter is None
    assert not any("mobility" in n for n in bins.notes)


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


def test_a_channel_off_the_stated_grid_names_its_channel(write_file):
    # bounds 0.8 and 6.4 um over 3 printed channels: edges 0.8, 1.6, 3.2, 6.4
    # (a factor 2 each); the printed 0.7 um lies below its channel [0.8, 1.6]
    text = (
        "Lower Channel Bound,0.8\nUpper Channel Bound,6.4\n"
        "Sample #,0.7 um,1.4 um,2.8 um\n1,5,6,5\n"
    )
    exc, msg = _error(write_file, "grid.csv", text, values="count")
    assert exc.field == "Lower Channel Bound"
    assert msg.endswith(
        "grid.csv: Lower Channel Bound: the printed channel 0.7 um lies outside its "
        "channel [0.8, 1.6] um of the grid the export states (Lower Channel Bound "
        "0.8, Upper Channel Bound 6.4, 3 channels printed); allowed: an export "
        "whose channels lie on its stated grid"
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


@pytest.mark.parametrize(
    ("text", "end"),
    [
        (
            "lower_um,upper_um,count\n1,2,5\n2.5,4,7\n",
            "g.csv:3: lower edge: lower edge 2.5 um does not equal the previous upper "
            "edge 2 um (a gap); allowed: contiguous bins in increasing order",
        ),
        (
            "Dp (um),count\n1,5\n0.5,6\n",
            "g.csv:3: column 'Dp (um)': the midpoints must be strictly increasing; "
            "allowed: one row per bin, in increasing order",
        ),
    ],
)
def test_bins_out_of_order_name_the_line(write_file, text, end):
    _, msg = _error(write_file, "g.csv", text)
    assert msg.endswith(end)


def test_midpoints_say_how_their_edges_were_derived(write_file):
    # log-spaced midpoints 1, 2, 4, 8: the edges sqrt(2), 2 sqrt(2), ... rebuild
    # them exactly (0 %)
    text = "Dp (um),dN/dlogDp\n1,5\n2,6\n4,2\n8,1\n"
    bins, meta = read_size_bins(write_file("d.csv", text))
    np.testing.assert_allclose(bins.edges_um, 2.0 ** np.arange(-0.5, 4), rtol=1e-12)
    assert bins.notes[-1] == (
        "bin edges derived from the 4 midpoints as geometric (log) midpoints "
        "(interior edges the geometric means of neighbours); the rebuilt bins' "
        "midpoints match the file's within 0 %"
    )
    # a file without a header: its value column is named by its 0-based index
    bare = write_file("h.csv", "1,5\n2,6\n4,2\n8,1\n")
    _, meta = read_size_bins(bare, unit="um", values="count", layout="midpoints")
    assert meta["header"] is None and meta["value_column"] == 1


def test_a_sampled_volume_that_is_no_volume_says_what_is_allowed(write_file):
    text = "Dp (um),dN/dlogDp\n1,5\n2,6\n4,2\n"
    exc, msg = _error(write_file, "v.csv", text, sampled_volume_cm3=0)
    assert exc.field == "sampled_volume_cm3"
    assert msg == (
        f"{write_file('v.csv', text)}: sampled_volume_cm3: sampled_volume_cm3 0 is "
        "not a volume; allowed: a number > 0 (cm^3 of air in which one sample's "
        "particles were counted)"
    )


def test_values_for_raw_diameters_are_refused_by_name(write_file):
    path = write_file("r.csv", "diameter_um\n1\n2\n3\n")
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, layout="diameters", values="count")
    assert info.value.field == "values"
    assert str(info.value).endswith(
        "r.csv: values: values 'count' is for size bins, not raw diameters; leave "
        "it out or choose the edges or midpoints layout"
    )


def test_a_unit_slip_is_suggested_only_where_every_bin_then_fits(write_file):
    # an SMPS measures 0.001 to 1.5 um; bins headed 0.5 to 1024 um are outside it.
    # Read as nm they would span 0.0005 to 1.024 um: the first bin still below
    # the range, so no unit is suggested
    mids = [0.5 * 2**k for k in range(12)]
    text = (
        "Instrument,SMPS 3938\nSample #,"
        + ",".join(f"{m:g} um" for m in mids)
        + "\n1,"
        + ",".join("5" for _ in mids)
        + "\n"
    )
    exc, msg = _error(write_file, "smps.csv", text, values="count")
    assert exc.field == "unit"
    assert msg.endswith(
        "smps.csv: unit: an SMPS measures 0.001 to 1.5 um, but the bins read in um "
        "span 0.5 to 1024 um; the header names it: correct the header"
    )


def test_a_trailing_comment_on_a_first_data_row_is_cut(write_file):
    # no header: the first row is data, and its '# ...' is a comment, as on
    # every other row (only a header keeps its '#')
    path = write_file("c.csv", "1,5 # first channel\n2,6\n4,2\n8,1\n")
    bins, _ = read_size_bins(path, unit="um", values="count", layout="midpoints")
    np.testing.assert_array_equal(bins.number, [5, 6, 2, 1])


AIM_COLUMNS = Path(__file__).parents[1] / "data/size_exports/aim_smps_column_pysmps.txt"


def test_an_aim_column_export_refuses_edges_and_reads_as_midpoints():
    with pytest.raises(DataFormatError) as info:
        read_size_bins(AIM_COLUMNS, sample="1", edges_um=[1, 2])
    assert info.value.field == "edges_um"
    assert str(info.value).endswith(
        "edges_um: edges_um is for wide exports whose bin columns do not give sizes "
        "(bin0, bin1, ...); a TSI AIM column export gives its midpoints"
    )
    # its bins are midpoints: layout='midpoints' reads it as the default does
    given, meta = read_size_bins(AIM_COLUMNS, sample="1", layout="midpoints")
    plain, _ = read_size_bins(AIM_COLUMNS, sample="1")
    assert meta["layout"] == "aim-columns"
    np.testing.assert_array_equal(given.number, plain.number)
    # a sample it does not hold: the samples it does, without time ranges
    with pytest.raises(DataFormatError) as info:
        read_size_bins(AIM_COLUMNS, sample="zz")
    assert str(info.value).endswith(
        "sample: sample 'zz' is not in the AIM column export; allowed: a Sample # "
        "(1..15), 'mean', 'sum', 'A..B' or 'sum A..B'"
    )


@pytest.mark.parametrize(
    ("header", "layout", "values"),
    [
        ("Dp (um),dW/dlogDp\n1,5\n2,6\n4,2\n", "midpoints", "dM/dlogDp"),  # W: weight
        # min/max edges beside a midpoint column: the edges are read
        ("Dp_min,Dp_max,Dp,count\n1,2,1.4,5\n2,4,2.8,6\n", "edges", "count"),
    ],
)
def test_header_aliases_name_their_columns(write_file, header, layout, values):
    _, meta = read_size_bins(write_file("a.csv", header), unit="um")
    assert (meta["layout"], meta["values"]) == (layout, values)


def test_a_sampled_volume_for_raw_diameters_is_refused_by_name(write_file):
    path = write_file("r.csv", "diameter_um\n1\n2\n3\n")
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, layout="diameters", sampled_volume_cm3=1.0)
    assert info.value.field == "sampled_volume_cm3"


def test_a_negative_aim_midpoint_is_refused_naming_line_and_column(tmp_path):
    # the real AIM column export with its first Diameter Midpoint made negative
    lines = AIM_COLUMNS.read_text(encoding="cp1252").splitlines()
    i = next(k for k, t in enumerate(lines) if t.startswith("Diameter Midpoint")) + 1
    assert lines[i].startswith(" 21.7,")
    lines[i] = "-" + lines[i][1:]
    path = tmp_path / "neg.txt"
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("cp1252"))
    with pytest.raises(DataFormatError) as info:
        read_size_bins(path, sample="1")
    assert str(info.value) == (
        f"{path}:{i + 1}: column 0 (Diameter Midpoint): bad value '-21.7'; "
        "allowed: a diameter > 0"
    )
