"""Real instrument size exports read with what the instrument states (issue 30): a
TSI APS 3321 row export (its stated channel bounds, its 'Aerodynamic Diameter',
its rows' 'dN/dlogDp') and a TSI AIM 11.5 SMPS CSV export (padded rows, a 'Scan
Number' header), both from AeroViz's public test data (MIT), checked against the
vendor's own statistics columns of every sample; two exports in one file refused
saying so.

Oracles: the vendor's Median, Geo. Mean, Geo. Std. Dev. and Total Concentration
columns, read here with the csv module, and the APS total recomputed by hand from
the export's dN/dlogDp and its stated 1/32-decade channels."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_size_exports import DATA

from microimpact.cli import main
from microimpact.errors import DataFormatError
from microimpact.io.size_bins import read_size_data
from microimpact.population.binned import binned_median
from microimpact.population.binned_report import describe_binned_sizes

APS = DATA / "aps3321_rows_aeroviz.txt"
APS2 = DATA / "aps3321_rows_aeroviz_2.txt"
AIM11 = DATA / "aim11_smps_csv_aeroviz.csv"


def _vendor_rows(path, delimiter, header_starts, encoding):
    """{sample: {column: cell}} of an export's data rows, read with csv."""
    with open(path, encoding=encoding, newline="") as fh:
        rows = list(csv.reader(fh, delimiter=delimiter))
    i = next(k for k, r in enumerate(rows) if r and r[0].strip() == header_starts)
    header = [h.strip() for h in rows[i]]
    out = {}
    for r in rows[i + 1 :]:
        if r and r[0].strip():
            out[r[0].strip()] = dict(zip(header, (c.strip() for c in r), strict=False))
    return header, out


def _geo(bins):
    """Geometric mean and GSD [µm] of the bins' number (AIM's definitions)."""
    mid = bins.midpoints_um
    w = bins.number / bins.total
    gm = np.exp(np.sum(w * np.log(mid)))
    return gm, np.exp(np.sqrt(np.sum(w * np.log(mid / gm) ** 2)))


APS_HEADER, APS_ROWS = _vendor_rows(APS, "\t", "Sample #", "cp1252")


@pytest.mark.parametrize("sample", sorted(APS_ROWS, key=int))
def test_aps_rows_match_the_vendors_statistics_on_the_stated_grid(sample):
    row = APS_ROWS[sample]
    bins, meta = read_size_data(APS, sample=sample)  # no values: the rows say
    assert meta["values"] == "dN/dlogDp" and meta["diameter"] == "aerodynamic"
    # the stated grid: 0.486968 .. 20.5353 µm in 52 channels of 1/32 decade, the
    # first (<0.523) open-ended and left out
    # (the bounds are printed to 6 digits: 52 channels of 1/32 decade to 1e-7)
    assert bins.edges_um[0] == pytest.approx(0.486968 * 10 ** (1 / 32), rel=1e-6)
    assert bins.edges_um[-1] == pytest.approx(20.5353, rel=1e-12)
    assert np.diff(np.log10(bins.edges_um)) == pytest.approx(1 / 32, rel=1e-5)
    # the total by hand: dN = dN/dlogDp x 1/32 over the 51 sized channels
    sized = APS_HEADER[APS_HEADER.index("<0.523") + 1 : APS_HEADER.index("Event 1")]
    total = sum(float(row[h]) for h in sized) / 32
    assert bins.total == pytest.approx(total, rel=1e-3)
    gm, gsd = _geo(bins)
    assert gm == pytest.approx(float(row["Geo. Mean(µm)"]), rel=0.02)
    assert gsd == pytest.approx(float(row["Geo. Std. Dev."]), rel=0.02)
    median = binned_median(bins.edges_um, bins.number)
    assert median == pytest.approx(float(row["Median(µm)"]), rel=0.02)


def test_aps_geometric_mean_agrees_to_the_vendors_digits():
    # AIM's geometric mean is over the sized channels at their geometric
    # midpoints: on the stated grid it agrees to its 6 printed digits
    bins, _ = read_size_data(APS, sample="1")
    gm, gsd = _geo(bins)
    assert gm == pytest.approx(0.702629, rel=2e-6)
    assert gsd == pytest.approx(1.3979, rel=1e-4)


def test_aps_is_never_converted_to_aerodynamic_again_nor_recommended_at_a_bound(
    tmp_path, capsys
):
    bins, _ = read_size_data(APS, sample="1")
    plain = describe_binned_sizes(bins)
    dense = describe_binned_sizes(bins, density_kg_m3=1500.0)
    a = dense.aerosol
    assert a["aerodynamic_count_median_um"] == plain.aerosol["count_median_bins_um"]
    assert a["aerodynamic_mass_median_um"] == plain.aerosol["mass_median_bins_um"]
    assert any("not used" in t and "aerodynamic already" in t for t in dense.notes)
    # the bins are the tail of a population below 0.5 µm: both fits sit at a
    # bound of their search, so the measured bins are recommended, saying why
    assert plain.recommended == "histogram"
    assert any("held at a bound of its search" in t for t in plain.notes)
    out = tmp_path / "o"
    code = main(["sizes", str(APS), "--sample", "1", "--out", str(out)])
    capsys.readouterr()
    assert code == 0
    assert 'distribution = "histogram"' in (out / "particles.toml").read_text()
    sizes = json.loads((out / "sizes.json").read_text())
    assert sizes["recommended"] == "histogram"


AIM_HEADER, AIM_ROWS = _vendor_rows(AIM11, ",", "Scan Number", "utf-8-sig")


@pytest.mark.parametrize("scan", ["1", "2", "17", "40", "62"])
def test_aim11_csv_matches_the_vendors_statistics(scan):
    row = AIM_ROWS[scan]
    bins, meta = read_size_data(AIM11, sample=scan)
    assert meta["layout"] == "aim-rows" and meta["unit"] == "nm"
    assert meta["diameter"] == "mobility"
    assert len(meta["samples"]) == 62
    total = float(row["Total Concentration (#/cm³)"])
    assert bins.total == pytest.approx(total, rel=1e-3)
    gm, gsd = _geo(bins)
    assert gm * 1e3 == pytest.approx(float(row["Geo. Mean (nm)"]), rel=0.02)
    assert gsd == pytest.approx(float(row["Geo. Std. Dev"]), rel=0.02)
    median = binned_median(bins.edges_um, bins.number) * 1e3
    assert median == pytest.approx(float(row["Median (nm)"]), rel=0.02)


def test_two_exports_in_one_file_are_refused_saying_so(tmp_path, capsys):
    both = tmp_path / "two.txt"
    both.write_bytes(APS.read_bytes() + APS2.read_bytes())
    with pytest.raises(DataFormatError) as info:
        read_size_data(both, sample="mean")
    msg = str(info.value)
    assert "more than one" in msg and ":20:" in msg and "split the file" in msg
    code = main(["sizes", str(both), "--sample", "21"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "more than one" in err


OPS = DATA / "ops3330_tsitools.csv"
OPS_CUTS = [0.3, 0.374, 0.465, 0.579, 0.721, 0.897, 1.117, 1.391, 1.732, 2.156]
OPS_CUTS += [2.685, 3.343, 4.162, 5.182, 6.451, 8.031, 10.0]


def test_ops_cut_points_are_its_edges_and_the_oversize_bin_is_counted_out():
    # tayebcodes/tsitools' data/2024_01_27-19_02_15-TEST_123.csv (MIT): 17 bins,
    # 17 cut points; Bin 17 lies above 10 µm with no upper edge
    with open(OPS, newline="") as fh:
        rows = list(csv.reader(fh))
    i = next(k for k, r in enumerate(rows) if r and r[0].startswith("Elapsed"))
    counts = np.array([[float(c) for c in r[1:18]] for r in rows[i + 1 :] if r])
    bins, _ = read_size_data(OPS, sample="sum", values="count")
    np.testing.assert_allclose(bins.edges_um, OPS_CUTS, rtol=1e-12)
    np.testing.assert_array_equal(bins.number, counts[:, :16].sum(axis=0))
    assert bins.total == 10105 and bins.counted
    oversize = [t for t in bins.notes if "oversize bin Bin 17" in t]
    assert len(oversize) == 1 and "held 18 of 10123" in oversize[0]
    assert "held 18 of 10123 (count, 0.178 %) and is left out" in oversize[0]
    # 17 bins have 18 boundaries: the hint asks for all of them, as followed below
    assert oversize[0].endswith("give its upper edge with edges_um (all 18 "
                                "boundaries) to include it")  # fmt: skip
    assert "np.float64" not in " ".join(bins.notes)
    # its upper edge given: all 17 bins
    bins, _ = read_size_data(
        OPS, sample="sum", values="count", edges_um=[*OPS_CUTS, 16.6]
    )
    assert bins.total == 10123


def test_ops_wrong_edges_are_listed_as_typed(capsys):
    edges = ",".join(str(c) for c in OPS_CUTS)  # 17: one short
    args = ["sizes", str(OPS), "--sample", "1", "--values", "count"]
    code = main([*args, "--edges-um", edges])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "np.float64" not in err and "[0.3, 0.374, 0.465," in err


_REPRS = ("np.float64", "np.int64", "array(", "None", "{'", "dtype")


@settings(max_examples=60, deadline=None)
@given(
    path=st.sampled_from([APS, AIM11, OPS]),
    sample=st.one_of(st.none(), st.text(max_size=12), st.integers(-3, 80)),
    values=st.sampled_from([None, "count", "dN/dlogDp", "dM/dlogDp", "bogus"]),
    unit=st.sampled_from([None, "um", "nm", "m", "furlong"]),
    edges=st.one_of(
        st.none(),
        st.lists(st.one_of(st.floats(-1, 30), st.just(float("nan"))), max_size=20),
    ),
)
def test_every_error_path_speaks_in_the_users_numbers(
    path, sample, values, unit, edges
):
    """A property over the error paths of the real exports: whatever a user types,
    the bins, or one line naming the file with no Python or NumPy repr."""
    try:
        read_size_data(path, sample=sample, values=values, unit=unit, edges_um=edges)
    except DataFormatError as exc:
        msg = str(exc)
        assert path.name in msg and "\n" not in msg
        if isinstance(sample, str) and sample:  # the user's own text, as typed
            msg = msg.replace(repr(sample), "").replace(sample, "")
        assert not any(r in msg for r in _REPRS), msg


def test_two_aim_column_exports_in_one_file_are_refused(tmp_path):
    col = DATA / "aim_smps_column_pysmps.txt"
    both = tmp_path / "two_columns.txt"
    both.write_bytes(col.read_bytes() + col.read_bytes())
    n_lines = len(col.read_bytes().splitlines())
    with pytest.raises(DataFormatError) as info:
        read_size_data(both, sample="1")
    msg = str(info.value)
    assert "more than one AIM column export" in msg and f":{n_lines + 1}:" in msg
    read_size_data(col, sample="1")  # one export alone still reads


def test_bins_in_nm_under_a_unitless_header_ask_for_the_unit(write_file, capsys):
    # an SMPS table typed without its unit: 100 .. 200 nm read as µm would give a
    # 150 µm median (the issue), so the unit is asked for in the caller's syntax
    rows = "".join(
        f"{lo},{lo + 10},{c}\n"
        for lo, c in zip(range(100, 200, 10), range(1, 11), strict=True)
    )
    p = write_file("smps.csv", "lower,upper,count\n" + rows)
    with pytest.raises(DataFormatError) as info:
        read_size_data(p)
    msg = str(info.value)
    assert "median midpoint is 149.9 um" in msg and "unit='nm'" in msg
    code = main(["sizes", str(p)])
    assert code == 2 and "--unit nm" in capsys.readouterr().err
    bins, meta = read_size_data(p, unit="nm")  # the answer, followed
    assert bins.edges_um[0] == pytest.approx(0.1) and meta["unit_from"] == "argument"
    named = write_file("smps_nm.csv", "lower_nm,upper_nm,count\n" + rows)
    assert read_size_data(named)[1]["unit"] == "nm"


def test_bins_outside_the_instruments_class_are_refused_naming_the_slip(tmp_path):
    # the real APS export with its statistics columns' '(µm)' taken out: no unit
    # stated, so the user's unit is used, and nm would put an APS's channels at
    # 0.5-20 nm, outside what an APS measures
    text = APS.read_bytes().decode("cp1252").replace("(µm)", "")
    bare = tmp_path / "aps_no_unit.txt"
    bare.write_text(text, encoding="cp1252")
    with pytest.raises(DataFormatError, match="does not say the unit"):
        read_size_data(bare, sample="1")
    with pytest.raises(DataFormatError) as info:
        read_size_data(bare, sample="1", unit="nm")
    msg = str(info.value)
    assert "an APS measures 0.3 to 30 um" in msg and "(was it um?)" in msg
    bins, _ = read_size_data(bare, sample="1", unit="um")  # the answer, followed
    assert bins.total == pytest.approx(read_size_data(APS, sample="1")[0].total)


GRIMM = (0.25, 0.28, 0.3, 0.35, 0.4, 0.45, 0.5, 0.58, 0.65, 0.7, 0.8, 1, 1.3, 1.6, 2)
GRIMM += (2.5, 3, 3.5, 4, 5, 6.5, 7.5, 8.5, 10, 12.5, 15, 17.5, 20, 25, 30, 32)


def test_grimm_channel_thresholds_are_lower_edges_not_midpoints(write_file):
    # a file laid out as a Grimm 1.109 export is documented (DateTime, the 31
    # channel thresholds in µm as headers, N, A; the last channel open above
    # 32 µm), its counts the expected ones of a log-normal (CMD 0.9 µm, GSD 1.6)
    # over the threshold bins: no real Grimm export with a licence was found
    from scipy import stats

    dist = stats.lognorm(np.log(1.6), scale=0.9)
    per = np.diff(dist.cdf([*GRIMM, np.inf]))
    counts = np.round(1e6 * per)
    head = "DateTime," + ",".join(f"{t:g}" for t in GRIMM) + ",N,A\n"
    row = "01/06/2024 10:00:00," + ",".join(f"{c:.0f}" for c in counts)
    p = write_file("grimm.csv", head + row + f",{counts.sum():.0f},0\n")
    bins, meta = read_size_data(p, values="count")
    np.testing.assert_allclose(bins.edges_um, GRIMM, rtol=1e-12)
    assert meta["unit_from"] == "Grimm channel set"
    # the closed form's median, not the 0.83 µm of thresholds read as midpoints
    median = binned_median(bins.edges_um, bins.number)
    assert median == pytest.approx(0.9, rel=0.02)
    assert any("channel thresholds" in t for t in bins.notes)
    assert any("last channel 32" in t and "left out" in t for t in bins.notes)
    # another header is still read as midpoints
    other = write_file("opc.csv", head.replace("0.25,", "0.26,"))
    other.write_text(other.read_text() + row + ",0,0\n")
    assert read_size_data(other, values="count", unit="um")[1]["unit_from"] != (
        "Grimm channel set"
    )


AIM103 = DATA / "aim10_3_smps_txt_aeroviz.txt"
AIM103_HEADER, AIM103_ROWS = _vendor_rows(AIM103, "\t", "Sample #", "cp1252")


@pytest.mark.parametrize("sample", sorted(AIM103_ROWS, key=int))
def test_aim10_3_txt_matches_the_vendors_statistics(sample):
    # an AIM 10.3 tab-delimited TXT row export (AeroViz, MIT), every sample
    row = AIM103_ROWS[sample]
    bins, meta = read_size_data(AIM103, sample=sample)
    assert meta["layout"] == "aim-rows" and meta["diameter"] == "mobility"
    assert bins.notes[0].startswith("TSI AIM row export (cp1252, ")  # not UTF-8
    total = float(row["Total Conc. (#/cm³)"])
    assert bins.total == pytest.approx(total, rel=1e-3)
    gm, gsd = _geo(bins)
    assert gm * 1e3 == pytest.approx(float(row["Geo. Mean (nm)"]), rel=0.02)
    assert gsd == pytest.approx(float(row["Geo. Std. Dev."]), rel=0.02)
    median = binned_median(bins.edges_um, bins.number) * 1e3
    assert median == pytest.approx(float(row["Median (nm)"]), rel=0.02)


def _grimm_file(write_file, sizes, name="grimm8.csv"):
    """A wide export whose bin headers are `sizes` (strings), one row of counts."""
    head = "DateTime," + ",".join(sizes) + "\n"
    counts = ",".join(str(10 * (k + 1)) for k in range(len(sizes)))
    row = "01/06/2024 10:00:00," + counts
    return write_file(name, head + row + "\n")


def test_eight_consecutive_grimm_thresholds_are_a_channel_set(write_file):
    # docs/populations.md: a run of at least 8 consecutive Grimm channel
    # thresholds is read as lower channel boundaries; 8 is the fewest accepted
    eight = [f"{t:g}" for t in GRIMM[:8]]
    bins, meta = read_size_data(_grimm_file(write_file, eight), values="count")
    assert meta["unit_from"] == "Grimm channel set"
    np.testing.assert_array_equal(bins.edges_um, GRIMM[:8])
    # the 8th channel (0.58 um) has no upper edge: 7 bins of counts 10..70
    np.testing.assert_array_equal(bins.number, [10, 20, 30, 40, 50, 60, 70])
    # 7 thresholds are not enough: read as midpoints, here in the unit given
    seven = _grimm_file(write_file, eight[:7], name="grimm7.csv")
    bins7, meta7 = read_size_data(seven, values="count", unit="um")
    assert meta7["unit_from"] != "Grimm channel set"
    assert bins7.number.size == 7


def test_grimm_thresholds_headed_in_nm_are_a_channel_set(write_file):
    # the header cells state their unit (250 nm = 0.25 um): the set is still
    # recognised, its edges given in um
    nm = [f"{1000 * t:g} nm" for t in GRIMM[2:12]]
    bins, meta = read_size_data(_grimm_file(write_file, nm), values="count")
    assert meta["unit_from"] == "Grimm channel set"
    np.testing.assert_allclose(bins.edges_um, GRIMM[2:12], rtol=1e-12)
