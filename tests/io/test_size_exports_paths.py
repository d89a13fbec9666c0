"""Paths of the instrument-export readers that the sampled mutation run of issue 34
found unguarded (benchmarks/mutation_score.py), each on a real export changed the
way an instrument or a user changes it:

* a TSI OPS 3330 export with its oversize channel disabled: 17 cut points bound
  16 bins, so the last cut point is the last bin's upper edge;
* an OPS export missing one bin's cut point, or stating them in an unknown unit:
  one-line errors naming the bin and the unit;
* an AIM column export averaged over its scans then turned into counted particles
  with a sampled volume: the particles counted over all scans, the same number as
  from the sum of the scans (the oracle: a second aggregation of the same file);
* time ranges that are not times, or that mix time zones: the error names what the
  user typed and the allowed forms.
"""

from __future__ import annotations

import csv

import numpy as np
import pytest
from test_size_exports import DATA
from test_size_exports_rows import OPCN3, OPCN3_EDGES

from microimpact.errors import DataFormatError
from microimpact.io.size_bins import read_size_bins, read_size_data

OPS = DATA / "ops3330_tsitools.csv"
AIM_COLUMNS = DATA / "aim_smps_column_pysmps.txt"
OPS_CUTS = [0.3, 0.374, 0.465, 0.579, 0.721, 0.897, 1.117, 1.391, 1.732, 2.156]
OPS_CUTS += [2.685, 3.343, 4.162, 5.182, 6.451, 8.031, 10.0]


def _ops_rows():
    with open(OPS, newline="") as fh:
        return list(csv.reader(fh))


def _write(path, rows):
    with open(path, "w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    return path


def test_ops_without_its_oversize_channel_takes_the_last_cut_point_as_an_edge(
    tmp_path,
):
    # the export as the OPS writes it with channel 17 disabled: its column gone
    rows = _ops_rows()
    i = next(k for k, r in enumerate(rows) if r and r[0].startswith("Elapsed"))
    col = rows[i].index("Bin 17")
    cut = [r[:col] + r[col + 1 :] if k >= i and r else r for k, r in enumerate(rows)]
    path = _write(tmp_path / "ops_16.csv", cut)
    counts = np.array([[float(c) for c in r[1:17]] for r in rows[i + 1 :] if r])
    bins, _ = read_size_data(path, sample="sum", values="count")
    np.testing.assert_allclose(bins.edges_um, OPS_CUTS, rtol=1e-12)
    np.testing.assert_array_equal(bins.number, counts.sum(axis=0))
    assert not any("oversize" in t for t in bins.notes)


def test_ops_missing_one_cut_point_names_that_bin(tmp_path):
    rows = [r for r in _ops_rows() if not (r and r[0] == "Bin 5 Cut Point (um)")]
    path = _write(tmp_path / "ops_no_bin5.csv", rows)
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, sample="sum", values="count")
    msg = str(info.value)
    assert "cut points for bins 1..17 but not for its bin column Bin 5" in msg
    assert "ops_no_bin5.csv" in msg and "edges_um" in msg


def test_ops_cut_points_in_an_unknown_unit_say_the_unit(tmp_path):
    rows = [
        [r[0].replace("(um)", "(furlong)"), *r[1:]] if r and "Cut Point" in r[0] else r
        for r in _ops_rows()
    ]
    path = _write(tmp_path / "ops_furlong.csv", rows)
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, sample="sum", values="count")
    msg = str(info.value)
    assert "unknown length unit 'furlong'" in msg and "Bin 1 Cut Point" in msg


def test_aim_column_mean_turned_into_counts_counts_every_scan():
    # 15 scans of dN/dlogDp: the mean x 15 scans and the sum count alike
    v = 0.05
    mean, meta = read_size_data(AIM_COLUMNS, sample="mean", sampled_volume_cm3=v)
    total, _ = read_size_data(AIM_COLUMNS, sample="sum", sampled_volume_cm3=v)
    assert meta["aggregate"] == "mean" and meta["n_samples_used"] == 15
    assert meta["layout"] == "aim-columns"
    np.testing.assert_allclose(mean.number, total.number, rtol=1e-12)
    note = next(t for t in mean.notes if "counted particles" in t)
    assert f"x the sampled volume {v:g} cm^3 x 15 samples" in note
    assert note.endswith(
        "particles; the standard errors and the chi-squared test assume Poisson "
        "counting of every particle in that volume (no coincidence, "
        "counting-efficiency, charging or inversion correction)"
    )
    one, _ = read_size_data(AIM_COLUMNS, sample="3", sampled_volume_cm3=v)
    note = next(t for t in one.notes if "counted particles" in t)
    assert "samples" not in note.split("cm^3", 1)[1].split("=")[0]


def test_a_time_range_end_that_is_not_a_time_is_named():
    # the MODULAIR-PM log of test_size_exports_rows: timestamps with a zone
    kw = {"values": "dN", "edges_um": OPCN3_EDGES}
    for sample, bad in (
        ("noon..2022-02-15T21:25Z", "'noon'"),
        ("2022-02-15T21:20Z..teatime", "'teatime'"),
    ):
        with pytest.raises(DataFormatError) as info:
            read_size_bins(OPCN3, sample=sample, **kw)
        assert f"sample range end {bad} is neither a Sample # nor an ISO 8601" in str(
            info.value
        )
        assert info.value.field == "sample"


def test_a_time_range_without_a_zone_says_the_allowed_forms():
    kw = {"values": "dN", "edges_um": OPCN3_EDGES}
    with pytest.raises(DataFormatError) as info:
        read_size_bins(OPCN3, sample="2022-02-15T21:20..2022-02-15T21:25", **kw)
    msg = str(info.value)
    assert "'2022-02-15T21:20'..'2022-02-15T21:25'" in msg
    assert "allowed: both with (e.g. Z, +02:00) or both without" in msg


def _wide(tmp_path, header="0.5,0.7,2,2.2"):
    # a wide OPC-style table: sizes in the header, one row of counts
    path = tmp_path / "wide.csv"
    path.write_text(f"Time,{header}\n10:00,1,2,3,4\n")
    return path


def test_given_edges_must_hold_each_header_size_in_its_own_bin(tmp_path):
    path = _wide(tmp_path)
    kw = {"values": "count", "unit": "um"}
    bins, _ = read_size_data(path, edges_um=[0.4, 0.6, 1.5, 2.15, 5], **kw)
    assert any("each header size lies inside its bin" in t for t in bins.notes)
    # size 2 lies above the first edge but below its own bin [2.1, 3)
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, edges_um=[0.4, 0.6, 2.1, 3, 5], **kw)
    assert (
        "the bin column 2 (2 um) lies outside its bin [2.1, 3) um of edges_um; "
        "allowed: 5 increasing boundaries in um with each header size inside its "
        "bin (a midpoint, or the bin's lower boundary)"
    ) in str(info.value)


def test_header_sizes_on_the_lower_edges_are_channel_thresholds(tmp_path):
    path = _wide(tmp_path, "0.5,1,2,4")
    kw = {"values": "count", "unit": "um"}
    bins, _ = read_size_data(path, edges_um=[0.5, 1, 2, 4, 8], **kw)
    assert any("lower boundaries (channel thresholds)" in t for t in bins.notes)
    # 5e-6 below the header sizes: inside the bins, not on their edges (rtol 1e-6)
    near = [0.5 * (1 - 5e-6), 1 * (1 - 5e-6), 2 * (1 - 5e-6), 4 * (1 - 5e-6), 8]
    bins, _ = read_size_data(path, edges_um=near, **kw)
    assert any("each header size lies inside its bin" in t for t in bins.notes)


def test_underivable_edges_ask_in_the_callers_syntax(tmp_path, capsys):
    from microimpact.cli import main

    path = _wide(tmp_path)
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, values="count", unit="um")
    msg = str(info.value)
    assert msg.startswith(f"{path}: edges_um: the midpoints are not log-spaced")
    assert "give the 5 bin boundaries in um: edges_um='[0.3, 0.4, ...]'" in msg
    code = main(["sizes", str(path), "--values", "count", "--unit", "um"])
    err = capsys.readouterr().err
    assert code == 2 and "--edges-um '0.3,0.4,...'" in err


def test_an_aim_weighting_it_does_not_know_asks_for_the_values(tmp_path):
    text = AIM_COLUMNS.read_text(encoding="latin-1")
    path = tmp_path / "aim_surface.txt"
    path.write_text(text.replace("Weight,Number", "Weight,Surface"), "latin-1")
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, sample="1")
    assert str(info.value) == (
        f"{path}: values: the export's Units 'dw/dlogdp' and Weight 'surface' are "
        "not a number, mass or volume weighting this reader knows; export with "
        "Weight Number (or Mass, Volume), or give the values"
    )
    bins, meta = read_size_data(path, sample="1", values="dN/dlogDp")  # given
    assert meta["values"] == "dN/dlogDp" and bins.number.sum() > 0


def test_an_export_of_zeros_is_refused_naming_the_file(tmp_path):
    rows = _ops_rows()
    i = next(k for k, r in enumerate(rows) if r and r[0].startswith("Elapsed"))
    zero = [
        [r[0], *["0"] * 17, *r[18:]] if k > i and r else r for k, r in enumerate(rows)
    ]
    path = _write(tmp_path / "ops_0.csv", zero)
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, sample="sum", values="count")
    assert str(info.value) == (
        f"{path}: values: all values are zero; allowed: values >= 0 with a "
        "positive total"
    )


def test_mean_and_sum_are_named_alike_however_typed():
    for typed in ("Sum", " SUM "):
        _, meta = read_size_data(AIM_COLUMNS, sample=typed)
        assert meta["sample"] == "sum" and meta["aggregate"] == "sum"
    _, meta = read_size_data(AIM_COLUMNS, sample="Mean")
    assert meta["sample"] == "mean"


@pytest.mark.parametrize("name", ["Optical Particle Sizer", "Particle counter"])
def test_an_ops_known_by_name_or_model_number_refuses_sizes_it_cannot_measure(
    tmp_path, name
):
    # cut points typed in mm: 335-8962 um, outside what an OPS 3330 measures;
    # the export says it is one by its name, or (renamed) by Model Number 3330
    rows = [
        [r[0].replace("(um)", "(mm)"), *r[1:]] if r and "Cut Point" in r[0] else r
        for r in _ops_rows()
    ]
    rows = [[r[0], name] if r and r[0] == "Instrument Name" else r for r in rows]
    path = _write(tmp_path / "ops_mm.csv", rows)
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, sample="sum", values="count")
    assert "an OPS measures 0.2 to 15 um, but the bins read in mm span 335" in str(
        info.value
    )


def test_edges_for_a_file_of_raw_diameters_are_refused_saying_why(tmp_path):
    path = tmp_path / "d.csv"
    path.write_text("diameter_um\n10\n12\n15\n")
    with pytest.raises(DataFormatError) as info:
        read_size_data(path, edges_um=[1.0, 2.0, 3.0])
    assert str(info.value) == (
        f"{path}: edges_um: edges_um is for wide exports of size bins named bin0, "
        "bin1, ...; the file holds raw diameters; leave it out"
    )
    with pytest.raises(DataFormatError) as info:
        read_size_bins(path, layout="bogus")
    assert str(info.value).startswith(f"{path}: layout: layout 'bogus'")
