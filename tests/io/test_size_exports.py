"""Reading binned size exports (issue 22): real instrument exports against their
software's own numbers, the APS export of the issue, layouts, units and the
asking errors."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import stats
from size_exports import aps_issue_export

from microimpact.errors import DataFormatError
from microimpact.io.size_bins import read_size_bins, read_size_data
from microimpact.population.binned import binned_median, fit_binned_lognormal

DATA = Path(__file__).parents[1] / "data" / "size_exports"
AIM = DATA / "aim_smps_column_pysmps.txt"
OPC_BOUNDS_UM = [0.38, 0.54, 0.78, 1.05, 1.34, 1.59, 2.07, 3.0, 4.0, 5.0, 6.5, 8.0,
                 10.0, 12.0, 14.0, 16.0, 17.5]  # fmt: skip


# -- a real TSI AIM column export (SMPS), against AIM's own statistics ---------------
@pytest.mark.parametrize("sample", ["1", "2", "13"])
def test_aim_export_matches_aims_own_statistics(sample):
    bins, meta = read_size_bins(AIM, sample=sample)
    aim = meta["instrument_statistics"]
    assert meta["values"] == "dN/dlogDp" and meta["unit"] == "nm"
    assert bins.number.size == 107 and len(meta["samples"]) == 15
    assert meta["layout"] == "aim-columns" and meta["header"] is None  # no header row
    total = next(v for k, v in aim.items() if k.startswith("Total Conc"))
    assert_allclose(bins.total, total, rtol=1e-5)  # dN/dlogDp x dlogDp summed
    mid_nm = bins.midpoints_um * 1e3
    w = bins.number / bins.total
    gm = np.exp(np.sum(w * np.log(mid_nm)))
    gsd = np.exp(np.sqrt(np.sum(w * np.log(mid_nm / gm) ** 2)))
    assert_allclose(gm, aim["Geo. Mean(nm)"], rtol=5e-4)
    assert_allclose(gsd, aim["Geo. Std. Dev."], rtol=5e-4)
    # AIM's median interpolates within a channel (64 per decade: 3.7 % wide)
    assert_allclose(binned_median(bins.edges_um, bins.number) * 1e3,
                    aim["Median(nm)"], rtol=0.01)  # fmt: skip


def test_aim_export_with_several_samples_asks_which(tmp_path):
    for syntax, spelled in (("cli", "--sample 1"), ("toml", "sample = 1")):
        with pytest.raises(DataFormatError, match="15 samples") as exc:
            read_size_bins(AIM, syntax=syntax)
        assert spelled in str(exc.value) and AIM.name in str(exc.value)
    mean, meta = read_size_bins(AIM, sample="mean")
    each = [read_size_bins(AIM, sample=str(k))[0].number for k in range(1, 16)]
    assert_allclose(mean.number, np.mean(each, axis=0), rtol=1e-12)
    assert meta["sample"] == "mean"
    with pytest.raises(
        DataFormatError, match="sample '99' is not in the AIM column export"
    ):
        read_size_bins(AIM, sample="99")


def test_aim_export_unit_contradiction_is_an_error():
    with pytest.raises(DataFormatError, match="unit 'nm' but the unit given is 'um'"):
        read_size_bins(AIM, sample=1, unit="um")


@pytest.mark.parametrize(
    ("text", "names"),
    [
        ("Lower (nm),Upper (um),count\n100,200,5\n200,400,9\n400,800,4\n", "nm"),
        ("Sample #,Median(nm),0.5 um,1 um,2 um\n1,900,5,9,4\n", "0.5 um"),
    ],
)
def test_a_header_naming_two_length_units_is_an_error(write_file, text, names):
    """The header's units are checked against each other before any is used (the
    edges and the wide layouts share the check): the error names both."""
    path = write_file("u.csv", text)
    with pytest.raises(DataFormatError, match="different length units") as exc:
        read_size_bins(path, values="count")
    assert "u.csv" in str(exc.value) and "'um'" in str(exc.value)
    assert names in str(exc.value)


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("Dp (um),count\n1,5\n2,-6\n4,2\n", ":3: column 'count': bad value '-6'"),
        ("lower,upper,count\n1,2,5\n2,4,-6\n", ":3: column 'count': bad value"),
        ("Sample #,0.5 um,0.7 um,1 um\n1,5,-6,5\n", ":2: column '0.7 um': bad"),
    ],
)
def test_a_negative_bin_value_names_its_line_and_column(write_file, text, where):
    """The midpoints, edges and wide layouts read a bin's value alike (one shared
    check): >= 0, else the error says where."""
    with pytest.raises(DataFormatError, match="allowed: a value >= 0") as exc:
        read_size_bins(write_file("neg.csv", text), values="count")
    assert "neg.csv" + where in str(exc.value)


# -- a real OPC-N2 file (py-smps sample data): counts per bin -------------------------
def test_opcn2_total_counts_are_the_sum_of_the_real_file():
    rows = list(csv.reader((DATA / "opcn2_pysmps.csv").open()))
    start = next(i for i, r in enumerate(rows) if r and r[0] == "Data:") + 2
    sums = np.sum([[int(c) for c in r[:16]] for r in rows[start:] if r], axis=0)
    bins, meta = read_size_bins(DATA / "opcn2_total_counts.csv")
    assert meta["layout"] == "edges" and bins.counted
    assert_allclose(bins.edges_um, OPC_BOUNDS_UM)
    assert_allclose(bins.number, sums)
    assert bins.total == 34047


# -- the APS export of the issue -------------------------------------------------------
def test_the_stored_aps_export_is_the_documented_one():
    text = (DATA / "aps3321_issue22.txt").read_text(encoding="utf-8")
    assert text == aps_issue_export()


def test_aps_export_of_the_issue_gives_its_median_and_gsd():
    """Done-when of issue 22: 3.49 um and 1.69 (main reported 3.16 and 2.90)."""
    bins, meta = read_size_bins(DATA / "aps3321_issue22.txt")
    assert bins.number.size == 32 and meta["unit"] == "µm"
    assert bins.edges_um[0] == pytest.approx(0.523 * 10 ** (10 / 32), rel=1e-3)
    fit = fit_binned_lognormal(bins.edges_um, bins.number)
    assert abs(fit.params["median_um"] - 3.49) < 0.2
    assert abs(fit.params["geometric_std"] - 1.69) < 0.1


# -- layouts, units, values ---------------------------------------------------------
def _lognormal_bins(edges, cmd=0.15, gsd=1.6, total=1e4):
    cdf = stats.lognorm(np.log(gsd), scale=cmd).cdf(edges)
    return total * np.diff(cdf)


def test_lower_upper_count_in_nm_fits_in_the_right_unit(write_file):
    edges_nm = 20.0 * 1.25 ** np.arange(26)
    counts = np.round(_lognormal_bins(edges_nm / 1e3))
    text = "Lower Size (nm),Upper Size (nm),count\n" + "".join(
        f"{a:.6g},{b:.6g},{int(c)}\n"
        for a, b, c in zip(edges_nm[:-1], edges_nm[1:], counts, strict=True)
    )
    bins, meta = read_size_bins(write_file("lu.csv", text))
    assert meta["unit"] == "nm" and meta["layout"] == "edges" and bins.counted
    fit = fit_binned_lognormal(bins.edges_um, bins.number)
    assert fit.params["median_um"] == pytest.approx(0.15, rel=0.02)
    assert fit.params["geometric_std"] == pytest.approx(1.6, rel=0.02)
    with pytest.raises(DataFormatError, match="gives the unit 'nm'"):
        read_size_bins(write_file("lu2.csv", text), unit="um")


@settings(max_examples=25, deadline=None)
@given(
    unit=st.sampled_from([("um", 1.0), ("nm", 1e3), ("mm", 1e-3)]),
    values=st.sampled_from(["dN/dlogDp", "dN/dlnDp", "dN/dDp", "dN"]),
    cmd=st.floats(0.3, 30.0),
    gsd=st.floats(1.3, 2.2),
)
def test_any_number_density_in_any_header_unit_gives_the_median(
    tmp_path_factory, unit, values, cmd, gsd
):
    name, per_um = unit
    mids = cmd * 10.0 ** (np.arange(-40, 41) / 32)  # log midpoints, 32 per decade
    dist = stats.lognorm(np.log(gsd), scale=cmd)
    dens = {
        "dN/dlogDp": dist.pdf(mids) * mids * np.log(10),
        "dN/dlnDp": dist.pdf(mids) * mids,
        "dN/dDp": dist.pdf(mids) / per_um,  # per unit of the file's diameters
        "dN": dist.pdf(mids) * mids * np.log(10) / 32,
    }[values]
    path = tmp_path_factory.mktemp("u") / "m.csv"
    path.write_text(
        f"Dp ({name}),{values}\n"
        + "".join(
            f"{m * per_um:.9g},{v:.9g}\n" for m, v in zip(mids, dens, strict=True)
        )
    )
    bins, meta = read_size_bins(path)
    assert meta["layout"] == "midpoints" and meta["values"] == values
    fit = fit_binned_lognormal(bins.edges_um, bins.number)
    assert fit.params["median_um"] == pytest.approx(cmd, rel=5e-3)
    assert fit.params["geometric_std"] == pytest.approx(gsd, rel=5e-3)


@pytest.mark.parametrize(
    "text",
    [
        "diameter_um\n10\n20\n30\n",
        "n,time_s,diameter_um\n1,0.1,10\n2,0.2,20\n3,0.3,30\n",  # a PDPA index
    ],
)
def test_a_diameter_column_without_values_stays_raw_diameters(write_file, text):
    data, meta = read_size_data(write_file("d.csv", text))
    assert meta["layout"] == "diameters"
    assert_allclose(data, [10e-6, 20e-6, 30e-6])


def test_midpoints_that_are_not_log_spaced_are_refused(write_file):
    text = "Dp (um),dN/dlogDp\n1,5\n1.1,5\n3,5\n3.05,5\n"
    with pytest.raises(DataFormatError, match="not log-spaced"):
        read_size_bins(write_file("m.csv", text))


@pytest.mark.parametrize(
    ("text", "syntax", "wants"),
    [
        (
            "Dp (um),dN/dlogDp,dM/dlogDp\n1,5,5\n2,6,6\n4,2,2\n",
            "cli",
            ["2 value columns", "--column dN/dlogDp", "--column dM/dlogDp"],
        ),
        (
            "Dp (um),dN/dlogDp,dM/dlogDp\n1,5,5\n2,6,6\n4,2,2\n",
            "toml",
            ['column = "dN/dlogDp"', 'column = "dM/dlogDp"'],
        ),
        (
            "1,5\n2,6\n4,2\n",
            "cli",
            ["no header", "--layout edges", "--layout midpoints"],
        ),
        (
            "Dp (um),signal\n1,5\n2,6\n4,2\n",
            "cli",
            ["'signal'", "--values count", "--values dN/dlogDp"],
        ),
        (
            "Dp (um),signal\n1,5\n2,6\n4,2\n",
            "toml",
            ["'signal'", 'values = "count"', 'values = "dN/dlogDp"'],
        ),
    ],
)
def test_ambiguous_columns_ask_in_the_callers_syntax(write_file, text, syntax, wants):
    path = write_file("amb.csv", text)
    layout = "midpoints" if "signal" in text else None  # else: raw diameters
    with pytest.raises(DataFormatError) as exc:
        read_size_data(path, layout=layout, syntax=syntax)
    msg = str(exc.value)
    assert "amb.csv" in msg
    for w in wants:
        assert w in msg, (w, msg)
    assert "column=" not in msg and "values=" not in msg


def test_a_value_kind_contradicting_the_header_is_an_error(write_file):
    path = write_file("m.csv", "Dp (um),dN/dlogDp\n1,5\n2,6\n4,2\n")
    with pytest.raises(DataFormatError, match="says the values are dN/dlogDp"):
        read_size_bins(path, values="dM/dlogDp")
