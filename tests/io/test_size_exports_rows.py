"""Wide size exports (issue 22, round two): TSI AIM *row* exports and time series
with the bin midpoints as column headers, choosing samples, a ``#`` in a header,
and number concentrations turned into counted particles (``sampled_volume_cm3``).

Oracles: AIM's own statistics columns of each row (real exports from py-smps),
the per-sample reads combined independently, closed-form bins, and the
chi-squared test's size on Poisson-counted bins."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import stats
from test_size_exports import DATA, OPC_BOUNDS_UM

from microimpact.errors import DataFormatError
from microimpact.io.size_bins import read_size_bins, read_size_data
from microimpact.population.binned import (
    binned_median,
    chi2_binned,
    fit_binned_lognormal,
)

ROW = DATA / "aim_smps_row_pysmps.txt"
ROW10 = DATA / "aim10_smps_row_pysmps.txt"


def _aim_stats(bins):
    """Geometric mean and GSD of the bins' number, in nm (AIM's definitions)."""
    mid_nm = bins.midpoints_um * 1e3
    w = bins.number / bins.total
    gm = np.exp(np.sum(w * np.log(mid_nm)))
    gsd = np.exp(np.sqrt(np.sum(w * np.log(mid_nm / gm) ** 2)))
    return gm, gsd


# -- real TSI AIM row exports, against AIM's own statistics columns --------------------
@pytest.mark.parametrize(
    ("path", "n_bins", "n_samples"), [(ROW, 107, 6), (ROW10, 95, 20)]
)
def test_aim_row_export_matches_aims_own_statistics(path, n_bins, n_samples):
    """Every sample: AIM's Total Conc. within 1e-5 (AIM's channels are 1/64 wide
    in log10 d exactly: edges derived from the printed 3-digit midpoints miss it by
    up to 0.6 %), its geometric mean and GSD within 5e-4, its median within the
    channel it interpolates in."""
    for k in range(1, n_samples + 1):
        bins, meta = read_size_bins(path, sample=k)
        aim = meta["instrument_statistics"]
        assert meta["layout"] == "aim-rows" and meta["values"] == "dN/dlogDp"
        assert meta["unit"] == "nm" and meta["sample"] == str(k)
        assert bins.number.size == n_bins and len(meta["samples"]) == n_samples
        total = next(v for key, v in aim.items() if key.startswith("Total Conc"))
        assert_allclose(bins.total, total, rtol=1e-5)  # dN/dlogDp x dlogDp summed
        gm, gsd = _aim_stats(bins)
        geo = next(v for key, v in aim.items() if key.startswith("Geo. Mean"))
        assert_allclose(gm, geo, rtol=5e-4)
        assert_allclose(gsd, aim["Geo. Std. Dev."], rtol=5e-4)
        median = next(v for key, v in aim.items() if key.startswith("Median"))
        # AIM's median interpolates within a channel (64 per decade: 3.7 % wide)
        got = binned_median(bins.edges_um, bins.number) * 1e3
        assert_allclose(got, median, rtol=0.02)
        # the metadata columns are not bins: AIM's flows and sizes are statistics
        assert not any(key.startswith(("Diameter", "Sample #")) for key in aim)


def test_aim_row_export_edges_are_the_channel_grid():
    bins, _ = read_size_bins(ROW, sample=1)
    mids_nm = bins.midpoints_um * 1e3
    # the printed midpoints are rounded to 0.1 nm (21.7 +- 0.05: 0.23 %)
    assert mids_nm[0] == pytest.approx(21.7, rel=3e-3)
    assert mids_nm[-1] == pytest.approx(982.2, rel=3e-3)
    # 64 channels per decade (the export's Channels/Decade)
    assert_allclose(np.log10(bins.edges_um[1:] / bins.edges_um[:-1]), 1 / 64)
    assert "grid of 64 channels per decade" in bins.notes[0]


#: The channel midpoints [um] an APS 3321 row export names (32 per decade).
APS_MIDS_UM = [0.542, 0.583, 0.626, 0.673, 0.723, 0.777, 0.835, 0.898, 0.965, 1.037,
               1.114, 1.197, 1.286, 1.382, 1.486, 1.596, 1.715, 1.843, 1.981, 2.129,
               2.288, 2.458, 2.642, 2.839, 3.051, 3.278, 3.523, 3.786, 4.068, 4.371,
               4.698, 5.048, 5.425, 5.829, 6.264, 6.732, 7.234, 7.774, 8.354, 8.977,
               9.647, 10.37, 11.14, 11.97, 12.86, 13.82, 14.86, 15.96, 17.15, 18.43,
               19.81]  # fmt: skip


def _aps_row_export(dens_rows):
    """An APS row export laid out as AIM writes one: the preamble, the header with
    the open-ended ``<0.523`` channel, the 51 channels, instrument columns and the
    statistics (``Median(µm)`` names the unit), one row per sample."""
    head = ["Sample #", "Date", "Start Time", "Aerodynamic Diameter", "<0.523"]
    head += [f"{m:g}" for m in APS_MIDS_UM]
    head += ["Event 1", "Total Flow", "Median(µm)", "Geo. Std. Dev.", "Total Conc."]
    lines = ["Instrument,3321 APS", "Channels/Decade,32", "Units,dw/dlogDp",
             "Weight,Number", ",".join(head)]  # fmt: skip
    for k, dens in enumerate(dens_rows):
        cells = [str(k + 1), "06/12/26", f"10:{k:02d}:00", "", "9999"]
        cells += [f"{v:.8g}" for v in dens] + ["12", "5.0", "2.0", "1.7", "850"]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def test_aps_row_export_skips_the_open_ended_channel(write_file):
    edges = 10 ** (np.log10(APS_MIDS_UM[0]) + (np.arange(52) - 0.5) / 32)
    cdf = stats.lognorm(np.log(1.7), scale=2.0).cdf(edges)
    conc = 500.0 * np.diff(cdf)  # per cm3 in each channel
    dens = conc * 32  # dN/dlogDp on 1/32-decade channels
    path = write_file("aps_rows.txt", _aps_row_export([dens, 2 * dens]))
    bins, meta = read_size_bins(path, sample="mean")
    assert meta["layout"] == "aim-rows" and meta["unit"] == "µm"
    assert bins.number.size == 51 and bins.values == "dN/dlogDp"
    assert_allclose(bins.edges_um, edges, rtol=3e-3)  # midpoints printed to 4 digits
    assert_allclose(bins.number, 1.5 * conc, rtol=1e-6)  # '<0.523' (9999) not read
    assert any("'<0.523'" in n and "not read" in n for n in bins.notes)
    # an APS counts every particle: 1 L/min for 20 s is 333.3 cm3 per sample
    counted, _ = read_size_bins(path, sample="sum", sampled_volume_cm3=1000 / 3)
    assert_allclose(counted.total, 3 * 500 * np.ptp(cdf) * 1000 / 3, rtol=1e-6)


def test_tab_delimited_aim_row_export_reads_the_same(tmp_path):
    """AIM also exports tab-delimited text; the preamble's lines hold one cell."""
    tabbed = tmp_path / "rows_tab.txt"
    tabbed.write_bytes(ROW10.read_bytes().replace(b",", b"\t"))
    for sample in ("1", "sum 2..9"):
        want, _ = read_size_bins(ROW10, sample=sample)
        got, meta = read_size_bins(tabbed, sample=sample)
        assert meta["layout"] == "aim-rows"
        assert_allclose(got.number, want.number)
        assert_allclose(got.edges_um, want.edges_um)


# -- choosing samples ------------------------------------------------------------------
def test_sample_mean_sum_and_ranges_combine_the_single_samples():
    each = np.array([read_size_bins(ROW10, sample=k)[0].number for k in range(1, 21)])
    assert_allclose(read_size_bins(ROW10, sample="mean")[0].number, each.mean(0))
    assert_allclose(read_size_bins(ROW10, sample="sum")[0].number, each.sum(0))
    assert_allclose(read_size_bins(ROW10, sample="3..7")[0].number, each[2:7].mean(0))
    bins, meta = read_size_bins(ROW10, sample="sum 3..7")
    assert_allclose(bins.number, each[2:7].sum(0))
    assert meta["n_samples_used"] == 5 and meta["aggregate"] == "sum"
    assert "the sum of samples 3..7 (5 samples)" in bins.notes[0]


@pytest.mark.parametrize(
    ("sample", "match"),
    [
        ("99", "sample '99' is not in the AIM row export"),
        ("7..3", "runs backwards"),
        ("1..99", "sample '99' is not in"),
    ],
)
def test_bad_samples_name_the_file_and_what_is_allowed(sample, match):
    with pytest.raises(DataFormatError, match=match) as exc:
        read_size_bins(ROW10, sample=sample)
    assert ROW10.name in str(exc.value) and "field" not in str(exc.value)


def test_several_samples_ask_which_in_each_syntax():
    for syntax, spelled in (("cli", "--sample 'sum'"), ("toml", 'sample = "sum"')):
        with pytest.raises(DataFormatError, match="holds 6 samples") as exc:
            read_size_bins(ROW, syntax=syntax)
        text = str(exc.value)
        assert ROW.name in text and ("--sample sum" in text or spelled in text)
        assert ("--sample 1..6" in text) == (syntax == "cli")


# -- wide time series: a timestamp column and one column per bin midpoint --------------
EDGES_UM = 0.3 * 10 ** (np.arange(17) / 8)  # 16 log-spaced bins, 0.3 to 30 um
MIDS_UM = np.sqrt(EDGES_UM[:-1] * EDGES_UM[1:])


def _wide(rows, *, head="timestamp", cells=None, comment=""):
    names = cells or [f"{m:.6g}" for m in MIDS_UM]
    lines = [",".join([head, *names]) + comment]
    for k, r in enumerate(rows):
        lines.append(f"2024-05-01T10:{k:02d}:00Z," + ",".join(f"{v:.10g}" for v in r))
    return "\n".join(lines) + "\n"


def _lognormal_counts(total, cmd=2.0, gsd=1.7):
    return total * np.diff(stats.lognorm(np.log(gsd), scale=cmd).cdf(EDGES_UM))


def test_wide_time_series_asks_for_values_and_unit_then_reads(write_file):
    rows = np.array([_lognormal_counts(1000 * (k + 1)) for k in range(4)])
    path = write_file("opc.csv", _wide(np.round(rows)))
    with pytest.raises(DataFormatError, match="does not say what its values are"):
        read_size_bins(path, sample=1)
    with pytest.raises(DataFormatError, match="does not say the unit") as exc:
        read_size_bins(path, sample=1, values="count", syntax="cli")
    assert "--unit nm" in str(exc.value) and "--unit um" in str(exc.value)
    bins, meta = read_size_data(path, sample="sum", values="count", unit="um")
    assert meta["layout"] == "wide" and meta["samples"] == ["1", "2", "3", "4"]
    assert_allclose(bins.edges_um, EDGES_UM, rtol=1e-5)
    assert_allclose(bins.number, np.round(rows).sum(0))
    assert bins.counted  # a sum of whole counts is counts
    bins, _ = read_size_bins(path, sample=3, values="count", unit="um")
    assert_allclose(bins.number, np.round(rows[2]))


def test_wide_header_with_units_in_the_cells(write_file):
    names = [f"{m * 1e3:.6g} nm" for m in MIDS_UM]
    path = write_file("w.csv", _wide([_lognormal_counts(5e4)], cells=names))
    bins, meta = read_size_bins(path, values="dN")
    assert meta["unit"] == "nm" and meta["unit_from"] == "header"
    assert_allclose(bins.edges_um, EDGES_UM, rtol=1e-5)
    with pytest.raises(DataFormatError, match="gives the unit 'nm'"):
        read_size_bins(path, values="dN", unit="um")


def test_the_longest_run_of_midpoints_is_the_bins(write_file):
    """A header with two runs of increasing sizes: the longer one is read as the
    bins (_longest_run, shared with the bin-name runs ``bin0, bin1, ...``)."""
    text = "Sample #,1 um,2 um,3 um,Median(um),0.5,0.7,1,1.4\n1,5,5,5,0.9,1,2,3,4\n"
    bins, meta = read_size_bins(write_file("two.csv", text), values="count")
    assert meta["n_bins"] == 4
    assert_allclose(bins.midpoints_um, [0.5, 0.7, 1.0, 1.4], rtol=0.02)
    assert_allclose(bins.number, [1, 2, 3, 4])


def test_bin_names_take_the_edges_given(write_file):
    """``bin0, bin1, ...`` headers give no sizes: the edges are asked for (in the
    caller's syntax); a data row of increasing counts under them is not taken for
    a header of midpoints."""
    text = "timestamp,bin0,bin1,bin2,bin3\nt1,1,2,3,4\nt2,5,6,7,9\n"
    path = write_file("bins.csv", text)
    with pytest.raises(DataFormatError, match="do not give their sizes") as exc:
        read_size_bins(path, values="count", sample="sum", syntax="cli")
    assert "--edges-um '0.35,0.46,...'" in str(exc.value) and "5 " in str(exc.value)
    with pytest.raises(
        DataFormatError, match=re.escape("edges_um = [0.35, 0.46, ...]")
    ):
        read_size_bins(path, values="count", sample="sum", syntax="toml")
    edges = [0.3, 0.5, 1.0, 2.0, 5.0]
    bins, meta = read_size_bins(path, values="count", sample="sum", edges_um=edges)
    assert meta["layout"] == "wide" and meta["n_bins"] == 4
    assert_allclose(bins.edges_um, edges)
    assert_allclose(bins.number, [6, 8, 10, 13])
    for bad in ([0.3, 0.5, 1.0, 2.0], [0.3, 0.5, 0.4, 2.0, 5.0], [0, 1, 2, 3, 4]):
        with pytest.raises(DataFormatError, match="do not bound the 4 bin columns"):
            read_size_bins(path, values="count", sample=1, edges_um=bad)
    with pytest.raises(DataFormatError, match="edges_um are in micrometres"):
        read_size_bins(path, values="count", sample=1, edges_um=edges, unit="nm")
    with pytest.raises(DataFormatError, match="this file is not one"):
        read_size_bins(write_file("lu.csv", "lower,upper,count\n1,2,3\n2,3,4\n"),
                       edges_um=edges)  # fmt: skip


def test_real_opcn2_log_summed_over_its_samples_is_its_total(write_file):
    """The raw OPC-N2 log (preamble, ``Bin0..Bin15`` counts, 180 samples): summed
    with py-smps's bin boundaries, the totals the csv module sums (the stored
    ``opcn2_total_counts.csv``, checked against the log in test_size_exports)."""
    total, _ = read_size_bins(DATA / "opcn2_total_counts.csv")
    bins, meta = read_size_bins(
        DATA / "opcn2_pysmps.csv", values="count", sample="sum", edges_um=OPC_BOUNDS_UM
    )
    assert meta["layout"] == "wide" and len(meta["samples"]) == 180
    assert bins.counted and bins.total == 34047
    assert_allclose(bins.number, total.number)
    _, meta = read_size_bins(
        DATA / "opcn2_pysmps.csv", values="count", sample=1, edges_um=OPC_BOUNDS_UM
    )
    # the instrument's own per-sample columns are kept, not taken for bins
    assert meta["instrument_statistics"]["SFR(ml/s)"] == pytest.approx(3.083)
    assert meta["instrument_statistics"]["SamplingPeriod(s)"] == pytest.approx(1.398)


OPCN3 = DATA / "modulair_pm_opcn3_pysmps.csv"
#: py-smps's OPC-N3 (and MODULAIR-PM) bin boundaries [um]
OPCN3_EDGES = [0.35, 0.46, 0.66, 1.0, 1.3, 1.7, 2.3, 3.0, 4.0, 5.2, 6.5, 8.0, 10.0,
               12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 25.0, 28.0, 31.0, 34.0, 37.0,
               40.0]  # fmt: skip


def test_opcn3_log_matches_py_smps_statistics():
    """A real MODULAIR-PM (OPC-N3) log, ``bin0..bin23`` concentrations: each of its
    30 samples read with py-smps's boundaries gives py-smps's own number total,
    geometric mean and GSD (py-smps weights the *arithmetic* bin midpoints; with
    the geometric midpoints used here the GM differs by at most 1.1 %)."""
    want = np.genfromtxt(
        DATA / "modulair_pm_opcn3_pysmps_stats.csv",
        delimiter=",",
        names=True,
        skip_header=1,
    )
    assert want.size == 30
    for row in want:
        bins, meta = read_size_bins(
            OPCN3, values="dN", sample=int(row["sample"]), edges_um=OPCN3_EDGES
        )
        assert meta["layout"] == "wide" and bins.number.size == 24
        assert_allclose(bins.total, row["number"], rtol=1e-9)
        w = bins.number / bins.total
        arith = 0.5 * (bins.edges_um[:-1] + bins.edges_um[1:])
        gm = np.exp(np.sum(w * np.log(arith)))
        gsd = np.exp(np.sqrt(np.sum(w * np.log(arith / gm) ** 2)))
        assert_allclose(gm * 1e3, row["GM_nm"], rtol=1e-9)
        assert_allclose(gsd, row["GSD"], rtol=1e-9)
        gm_geo = np.exp(np.sum(w * np.log(bins.midpoints_um)))
        assert abs(gm_geo * 1e3 / row["GM_nm"] - 1) < 0.011


def test_a_time_range_of_a_log_selects_its_samples_in_any_order():
    """The MODULAIR-PM log runs newest first, one sample a minute from 21:27:30Z
    (row 1): 21:20:30Z..21:25:30Z are rows 3 to 8."""
    kw = {"values": "dN", "edges_um": OPCN3_EDGES}
    want, _ = read_size_bins(OPCN3, sample="3..8", **kw)
    got, meta = read_size_bins(
        OPCN3, sample="2022-02-15T21:20:30Z..2022-02-15T21:25:30Z", **kw
    )
    assert_allclose(got.number, want.number)
    assert meta["n_samples_used"] == 6 and "timed" in meta["selection"]
    summed, _ = read_size_bins(
        OPCN3, sample="sum 2022-02-15T21:20Z..2022-02-15T21:25:59+00:00", **kw
    )
    assert_allclose(summed.number, 6 * want.number)
    with pytest.raises(DataFormatError, match="--sample '2022-02-15T20:58:30"):
        read_size_bins(OPCN3, syntax="cli", **kw)
    for sample, words in (
        ("2022-02-15T21:20..2022-02-15T21:25", "do not both name a time zone"),
        ("2023-01-01T00:00Z..2023-01-02T00:00Z", "its samples run from"),
        ("2022-02-15T21:25Z..2022-02-15T21:20Z", "runs backwards"),
        ("noon..2022-02-15T21:25Z", "neither a Sample # nor an ISO 8601 time"),
    ):
        with pytest.raises(DataFormatError, match=re.escape(words)):
            read_size_bins(OPCN3, sample=sample, **kw)


def test_repeated_sample_numbers_fall_back_to_rows_and_say_so(tmp_path):
    """Two AIM row exports pasted together repeat their Sample #s."""
    lines = ROW.read_bytes().splitlines(keepends=True)
    twice = tmp_path / "twice.txt"
    twice.write_bytes(b"".join(lines + lines[16:]))  # the 6 samples once more
    bins, meta = read_size_bins(twice, sample="7..12")
    want, _ = read_size_bins(ROW, sample="mean")
    assert_allclose(bins.number, want.number)
    assert meta["samples"] == [str(k) for k in range(1, 13)]
    assert any("numbered by their row" in n for n in bins.notes)


def test_bin_center_names_a_midpoint_column(write_file):
    text = "Bin Center (um),dN/dlogDp\n1,5\n2,6\n4,2\n8,1\n"
    bins, meta = read_size_bins(write_file("c.csv", text))
    assert meta["layout"] == "midpoints" and bins.number.size == 4


# -- a '#' in a header -----------------------------------------------------------------
def test_hash_in_a_header_is_not_a_comment(write_file):
    counts = _lognormal_counts(1e4)
    dens = counts / np.log10(EDGES_UM[1:] / EDGES_UM[:-1])
    text = "Dp (um),dN/dlogDp (#/cm3)\n" + "".join(
        f"{m:.8g},{v:.10g} # channel {k}\n"
        for k, (m, v) in enumerate(zip(MIDS_UM, dens, strict=True))
    )
    bins, meta = read_size_bins(write_file("hash.csv", text))
    assert meta["value_column"] == "dN/dlogDp (#/cm3)" and meta["values"] == "dN/dlogDp"
    assert_allclose(bins.number, counts, rtol=1e-6)
    # and the wide layout: AIM's "Sample #" header
    bins, meta = read_size_bins(ROW, sample=2)
    assert meta["samples"] == ["1", "2", "3", "4", "5", "6"]


# -- concentrations to counted particles -----------------------------------------------
def test_sampled_volume_turns_concentrations_into_counts(write_file):
    conc = _lognormal_counts(250.0)  # particles per cm3 in each bin
    dens = conc / np.log10(EDGES_UM[1:] / EDGES_UM[:-1])
    body = "".join(f"{m:.8g},{v:.10g}\n" for m, v in zip(MIDS_UM, dens, strict=True))
    for header, per_cm3 in (("dN/dlogDp (#/cm3)", 1.0), ("dN/dlogDp (#/L)", 1e-3)):
        path = write_file("c.csv", f"Dp (um),{header}\n" + body)
        plain, _ = read_size_bins(path)
        assert not plain.counted
        bins, _ = read_size_bins(path, sampled_volume_cm3=40.0)
        assert bins.counted and bins.values == "dN/dlogDp"
        assert_allclose(bins.number, conc * per_cm3 * 40.0, rtol=1e-6)
        assert "sampled volume 40 cm^3" in bins.notes[-1]
        assert "Poisson" in bins.notes[-1]
    # the mean of n samples was counted in n volumes
    one, _ = read_size_bins(ROW10, sample="mean")
    counted, _ = read_size_bins(ROW10, sample="mean", sampled_volume_cm3=2.0)
    assert_allclose(counted.number, one.number * 2.0 * 20)
    assert "x 20 samples" in counted.notes[-1] and "per cm^3," not in counted.notes[-1]


@pytest.mark.parametrize(
    ("text", "kw", "match"),
    [
        ("lower_um,upper_um,count\n1,2,5\n2,4,7\n", {}, "counted particles already"),
        ("Dp (um),dM/dlogDp\n1,5\n2,6\n4,2\n", {}, "mass weighting"),
        ("Dp (um),dN/dlogDp\n1,5\n2,6\n4,2\n", {"v": 0}, "not a volume"),
        ("Dp (um),dN/dlogDp\n1,5\n2,6\n4,2\n", {"v": "x"}, "not a volume"),
        ("diameter_um\n1\n2\n3\n", {}, "not raw diameters"),
    ],
)
def test_sampled_volume_refused_where_it_makes_no_counts(write_file, text, kw, match):
    path = write_file("v.csv", text)
    with pytest.raises(DataFormatError, match=match) as exc:
        read_size_data(path, sampled_volume_cm3=kw.get("v", 10.0))
    assert "v.csv" in str(exc.value)


@pytest.mark.parametrize(
    ("reps", "alpha"),
    [(200, 0.2), pytest.param(1000, 0.05, marks=pytest.mark.slow)],
)
def test_chi2_on_poisson_counted_concentrations_has_its_size(write_file, reps, alpha):
    """Bins counted as Poisson in V = 50 cm3 from a log-normal, written as
    dN/dlogDp concentrations: read back with the sampled volume, the log-normal's
    chi-squared test rejects at about alpha (its size), and the count median lies
    within 2 standard errors about 95 % of the time (docs/populations.md quotes
    the slow row)."""
    rng = np.random.default_rng(7)
    volume = 50.0
    expected = _lognormal_counts(40.0) * volume  # 2000 particles
    dlog = np.log10(EDGES_UM[1:] / EDGES_UM[:-1])
    rejects = covered = 0
    for _ in range(reps):
        n = rng.poisson(expected)
        dens = n / volume / dlog
        text = "Dp (um),dN/dlogDp (#/cm3)\n" + "".join(
            f"{m:.10g},{v:.12g}\n" for m, v in zip(MIDS_UM, dens, strict=True)
        )
        bins, _ = read_size_bins(write_file("p.csv", text), sampled_volume_cm3=volume)
        assert_allclose(bins.number, n, rtol=1e-9)
        fit = fit_binned_lognormal(bins.edges_um, bins.number)
        rejects += chi2_binned(bins.edges_um, bins.number, fit, alpha=alpha).reject
        se = fit.stderr["median_um"]
        covered += abs(fit.params["median_um"] - 2.0) < 2 * se
    se_rate = np.sqrt(alpha * (1 - alpha) / reps)
    assert abs(rejects / reps - alpha) < 3.5 * se_rate
    assert abs(covered / reps - 0.954) < 3.5 * np.sqrt(0.954 * 0.046 / reps) + 0.02


# -- property: any wide table, any sample choice ---------------------------------------
@settings(max_examples=30, deadline=None)
@given(
    k=st.integers(3, 12),
    n=st.integers(1, 6),
    first=st.integers(1, 6),
    last=st.integers(1, 6),
    how=st.sampled_from(["", "mean ", "sum "]),
    seed=st.integers(0, 2**16),
)
def test_any_wide_table_reads_the_chosen_rows(
    tmp_path_factory, k, n, first, last, how, seed
):
    rng = np.random.default_rng(seed)
    first, last = sorted((min(first, n), min(last, n)))
    mids = 0.5 * 1.3 ** np.arange(k)
    table = rng.integers(0, 50, size=(n, k)).astype(float)
    table[:, 0] += 1  # never all zero
    text = "time," + ",".join(f"{m:.10g}" for m in mids) + "\n"
    text += "".join(
        f"t{r}," + ",".join(f"{v:g}" for v in table[r]) + "\n" for r in range(n)
    )
    path = tmp_path_factory.mktemp("w") / "wide.csv"
    path.write_text(text)
    bins, meta = read_size_bins(
        path, values="count", unit="um", sample=f"{how}{first}..{last}"
    )
    chosen = table[first - 1 : last]
    want = chosen.sum(0) if how == "sum " else chosen.mean(0)
    assert_allclose(bins.number, want)
    assert_allclose(bins.midpoints_um, mids, rtol=1e-9)
    assert meta["n_samples_used"] == last - first + 1


@settings(max_examples=40, deadline=None)
@given(
    sample=st.one_of(
        st.text(max_size=30),
        st.integers(-5, 30),
        st.from_regex(
            r"(sum |mean )?[0-9T:Z.-]{0,22}\.\.[0-9T:Z.-]{0,22}", fullmatch=True
        ),
    ),
    edges=st.one_of(
        st.none(), st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=30)
    ),
)
def test_any_sample_or_edges_a_user_types_reads_or_says_why(sample, edges):
    """Whatever `sample` and `edges_um` a user gives: the bins, or a DataFormatError
    naming the file (never another exception)."""
    for path, kw in ((ROW10, {}), (OPCN3, {"values": "dN", "edges_um": edges})):
        try:
            bins, meta = read_size_bins(path, sample=sample, **kw)
        except DataFormatError as exc:
            assert path.name in str(exc)
        else:
            assert bins.number.size > 0 and meta["n_samples_used"] >= 1
