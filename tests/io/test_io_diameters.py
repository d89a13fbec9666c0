"""Tests for microimpact.io.diameters (raw-diameter and histogram readers)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from microimpact.errors import DataFormatError
from microimpact.io.diameters import read_diameters, read_histogram
from microimpact.population.distributions import histogram_diameters
from microimpact.units import m_to_um

UM = 1e-6


# -- read_diameters ----------------------------------------------------------------
def test_single_column_no_header(write_file):
    path = write_file("d.txt", "52.1\n48.0\n\n# a comment\n61.5\n")
    d, meta = read_diameters(path)
    assert_allclose(d, np.array([52.1, 48.0, 61.5]) * UM, rtol=1e-15)
    assert meta["n"] == 3 and meta["header"] is None and meta["unit"] == "um"
    assert meta["source"] == str(path)


def test_header_and_auto_diameter_column(write_file):
    text = "# PDPA export\ntime_s,velocity_m_s,Diameter_um\n0.1,2.0,50.5\n0.2,2.1,48\n"
    d, meta = read_diameters(write_file("pdpa.csv", text))
    assert_allclose(d, [50.5 * UM, 48 * UM], rtol=1e-15)
    assert meta["column"] == "Diameter_um" and meta["column_index"] == 2
    assert meta["delimiter"] == ","


@pytest.mark.parametrize(
    ("sep", "column"), [("\t", "size"), (";", 1), (" ", -1), ("\t", "SIZE")]
)
def test_choose_column_by_name_or_index(write_file, sep, column):
    text = sep.join(["t", "size"]) + "\n" + sep.join(["1", "30"]) + "\n"
    text += sep.join(["2", "40.5"]) + "\n"
    d, meta = read_diameters(write_file("d.txt", text), column=column)
    assert_allclose(d, [30 * UM, 40.5 * UM], rtol=1e-15)
    assert meta["column_index"] == 1


def test_unit_conversion_and_quotes(write_file):
    path = write_file("mm.csv", '"d_mm"\n"0.05"\n0.0625\n')
    d, _ = read_diameters(path, unit="mm")
    assert_allclose(d, [50 * UM, 62.5 * UM], rtol=1e-14)
    with pytest.raises(ValueError, match="unknown length unit"):
        read_diameters(path, unit="inch")


def test_whitespace_columns_without_header_by_index(write_file):
    d, meta = read_diameters(write_file("w.dat", "1 2 3\n4 5 6\n"), column=2)
    assert_allclose(d, [3 * UM, 6 * UM], rtol=1e-15)
    assert meta["column"] == 2 and meta["delimiter"] == "whitespace"


@pytest.mark.parametrize(
    ("text", "kwargs", "match"),
    [
        ("10\n0\n", {}, r"d\.txt:2: column 0: bad value '0'; allowed: a diameter > 0"),
        ("10\n-3.5\n", {}, r":2: column 0: bad value '-3.5'"),
        ("10\nabc\n", {}, r":2: column 0: non-numeric value 'abc'"),
        ("d\n10\nNaN\n", {}, r":3: column 'd': missing value 'NaN'"),
        ("a,d\n1,10\n2,\n", {"column": "d"}, r":3: column 'd': missing value ''"),
        ("a,d\n1,10\n2\n", {"column": 1}, r":3: column 'd': missing value"),
        ("10\ninf\n", {}, r":2: column 0: bad value 'inf'"),
        ("", {}, r"d\.txt: no diameters found"),
        ("# only comments\n\n", {}, "no diameters found"),
        ("diameter_um\n", {}, "only a header"),
        ("a,b\n1,2\n", {}, r"column: the file has 2 columns; pass `column=` one of"),
        ("a,b\n1,2\n", {"column": "c"}, r"no column named 'c'; allowed: 'a', 'b'"),
        ("1,2\n3,4\n", {"column": 5}, r"column index 5 out of range; allowed: 0\.\.1"),
    ],
)
def test_read_diameters_errors(write_file, text, kwargs, match):
    path = write_file("d.txt", text)
    with pytest.raises(DataFormatError, match=match):
        read_diameters(path, **kwargs)


def test_read_diameters_missing_file_and_bad_column_type(tmp_path, write_file):
    with pytest.raises(DataFormatError, match="cannot read file"):
        read_diameters(tmp_path / "nope.csv")
    path = write_file("d.txt", "1\n")
    with pytest.raises(TypeError, match="`column`"):
        read_diameters(path, column=1.5)


def test_error_carries_fields(write_file):
    path = write_file("d.txt", "d\n10\n-1\n")
    with pytest.raises(DataFormatError) as info:
        read_diameters(path)
    err = info.value
    assert err.source == str(path) and err.line == 3 and err.field == "column 'd'"
    assert "-1" in err.message and "allowed" in err.message


def test_roundtrip_large_sample(tmp_path):
    rng = np.random.default_rng(3)
    x = np.round(rng.normal(52.8, 15.3, 5000).clip(1), 3)
    path = tmp_path / "big.csv"
    np.savetxt(path, x, header="diameter_um", comments="", fmt="%.3f")
    d, meta = read_diameters(path)
    assert meta["n"] == 5000
    assert_allclose(m_to_um(d), x, rtol=1e-12)


# -- read_histogram ------------------------------------------------------------------
COLUMNS = "lower_um,upper_um,count\n10,20,12\n20,30,40\n30,40,95\n40,55,33\n"


def test_histogram_columns_layout(write_file):
    edges, counts, meta = read_histogram(write_file("h.csv", COLUMNS))
    assert_allclose(edges, np.array([10, 20, 30, 40, 55]) * UM, rtol=1e-15)
    assert_allclose(counts, [12, 40, 95, 33], rtol=0)
    assert meta["layout"] == "columns" and meta["n_bins"] == 4
    assert meta["header"] == ["lower_um", "upper_um", "count"]
    assert_allclose(meta["total"], 180, rtol=0)


@pytest.mark.parametrize(
    ("row", "said"),
    [
        ("x,20,12", "column 0 (lower edge): non-numeric value 'x'; allowed: a number"),
        ("10,x,12", "column 1 (upper edge): non-numeric value 'x'; allowed: a number"),
        ("10,20,x", "column 2 (count): non-numeric value 'x'; allowed: a number >= 0"),
    ],
)
def test_histogram_cells_name_their_column(write_file, row, said):
    path = write_file("bad.csv", "lower_um,upper_um,count\n" + row + "\n")
    with pytest.raises(DataFormatError) as info:
        read_histogram(path)
    assert f"bad.csv:2: {said}" in str(info.value)


@pytest.mark.parametrize(
    "text",
    [
        "10 20 30 40\n0.1 0.5 0.4\n",
        "edges_um;10;20;30;40\ncounts;0.1;0.5;0.4\n",
    ],
)
def test_histogram_rows_layout(write_file, text):
    edges, counts, meta = read_histogram(write_file("h.txt", text))
    assert_allclose(edges, np.array([10, 20, 30, 40]) * UM, rtol=1e-15)
    assert_allclose(counts, [0.1, 0.5, 0.4], rtol=1e-15)
    assert meta["layout"] == "rows"
    # the same file through the general size-data reader: the same bins
    from microimpact.io.size_bins import read_size_bins

    bins, meta2 = read_size_bins(write_file("h2.txt", text), values="count")
    assert_allclose(bins.edges_um, [10, 20, 30, 40], rtol=1e-15)
    assert_allclose(bins.number, [0.1, 0.5, 0.4], rtol=1e-15)
    assert meta2["layout"] == "rows" and bins.values == "count"


def test_histogram_file_to_distribution_reproduces_counts(write_file):
    edges, counts, _ = read_histogram(write_file("h.csv", COLUMNS))
    dist = histogram_diameters(m_to_um(edges), counts)
    n = 20000
    sample = dist.table().sample(n, rng=np.random.default_rng(11))
    observed = np.histogram(sample, bins=edges)[0]
    p = counts / counts.sum()
    assert stats.chisquare(observed, n * p).pvalue > 1e-3


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "the file is empty; expected columns"),
        ("lower,upper,count\n", "no bins found"),
        ("10,20,5\n25,30,7\n31,40,1\n", r":2: column 0 \(lower edge\): .* \(a gap\)"),
        ("10,20,5\n15,30,7\n30,40,1\n", r":2: .*an overlap or unsorted bins"),
        ("10,20,5\n20,20,7\n20,40,1\n", r":2: column 1 \(upper edge\): upper edge"),
        ("10,20,5\n20,30,-7\n30,40,1\n", r":2: column 2 \(count\): bad value '-7'"),
        ("10,20,5\n20,30,x\n30,40,1\n", r":2: column 2 \(count\): non-numeric"),
        # too few cells: no hint at a decimal comma
        (
            "10,20,5\n20,30\n30,40,1\n",
            r":2: row has 2 cells; expected columns.*values\)$",
        ),
        # a decimal comma splits a cell: 4 cells, and the hint says why
        (
            "10,20,5\n20,30,0,5\n",
            r":2: row has 4 cells; .*the decimal separator must be",
        ),
        ("10,20,0\n20,30,0\n30,40,0\n", r"count: all counts are zero"),
        ("-10,20,5\n20,30,7\n30,40,1\n", r":1: column 0 \(lower edge\): bad value"),
        ("a,b\n10,20\n", "header has 2 columns"),
        ("10 30 20\n1 1\n", r":1: column 2: bin edges must be strictly increasing"),
        ("edges 10 20 30\ncounts 1 -1\n", r":2: column 2: bad value '-1'"),
    ],
)
def test_read_histogram_errors(write_file, text, match):
    path = write_file("h.csv", text)
    with pytest.raises(DataFormatError, match=match) as info:
        read_histogram(path)
    assert str(info.value).startswith(f"{path}")  # every refusal names the file


# -- delimited text: decimal commas, quotes, extra cells, duplicates, units ---------
@pytest.mark.parametrize(
    ("text", "kwargs", "match"),
    [
        # a decimal comma is never read as two cells (the old reader gave 52, 48)
        ("diameter_um\n52,8\n48,1\n", {}, r":2: .*non-numeric value '52,8'.*'\.'"),
        ("t,diameter\n1,52,8\n", {}, r":2: row has 3 cells, header has 2; the decimal"),
        ("t,d\n1,50\n2,52,8\n", {"column": 1}, r":3: row has 3 cells, header has 2"),
        ("1,50\n2,52,8\n", {"column": 1}, r":2: row has 3 cells, the first row has 2"),
        ("t;d\n1;52,8\n", {"column": "d"}, r":2: column 'd': non-numeric .*'\.'"),
        # a quoted cell is one cell: "5,2" is not 5
        ('x,d\n1,"5,2"\n', {"column": "d"}, r"non-numeric value '5,2'"),
        ("d,D\n1,2\n", {"column": 0}, r":1: duplicate column\(s\) \['d'\]"),
        ("t,d\n1,5\n", {"column": "D "}, None),
        ('x,d\n1,"5.2\n', {"column": "d"}, r":2: cannot parse line"),
    ],
)
def test_read_diameters_delimited_text(write_file, text, kwargs, match):
    path = write_file("d.csv", text)
    if match is None:
        read_diameters(path, **kwargs)  # well-formed
        return
    with pytest.raises(DataFormatError, match=match) as info:
        read_diameters(path, **kwargs)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_headerless_decimal_commas_are_two_columns_not_a_misread(write_file):
    # "52,8" in a headerless file is two columns: without `column` it is refused
    with pytest.raises(DataFormatError, match="the file has 2 columns"):
        read_diameters(write_file("d.csv", "52,8\n48,1\n"))


def test_quoted_cells_and_sniffing_from_the_first_row(write_file):
    d, meta = read_diameters(write_file("q.csv", 'x,d\n1,"5.25"\n2," 6"\n'), column=1)
    assert_allclose(d, [5.25 * UM, 6 * UM], rtol=1e-15)
    # the delimiter comes from the first row: a ',' inside a later cell does not win
    text = 'd;note\n5.5;"a, b"\n7;c,d\n'
    d, meta = read_diameters(write_file("s.csv", text), column="d")
    assert meta["delimiter"] == ";"
    assert_allclose(d, [5.5 * UM, 7 * UM], rtol=1e-15)
    # trailing empty cells (a trailing delimiter) are not extra cells
    d, _ = read_diameters(write_file("t.csv", "d,\n5,\n6,\n"), column="d")
    assert_allclose(d, [5 * UM, 6 * UM], rtol=1e-15)


def test_unknown_unit_names_the_file(write_file):
    for reader in (read_diameters, read_histogram):
        path = write_file("d.csv", "10\n20\n")
        with pytest.raises(DataFormatError, match="unknown length unit") as info:
            reader(path, unit="inch")
        msg = str(info.value)
        assert msg.startswith(f"{path}: unit: unknown length unit 'inch'; allowed:")
        assert msg.count("µm") + msg.count("μm") == 1  # each spelling shown once


def test_histogram_decimal_comma_hint(write_file):
    with pytest.raises(DataFormatError, match=r":1: row has 5 cells.*'\.'"):
        read_histogram(write_file("h.csv", "10,5,20,5,12\n20,5,30,5,3\n30,5,40,0,1\n"))


# ------------------------------------------------- one file, every reader, same rules

#: A messy export: byte-order mark, comment lines, a trailing comment, quoted header
#: and text cells (one holding ';' and '#'), ';' delimiters padded with tabs.
MESSY = (
    "\ufeff# exported by PDA v2; units in the header\n"
    "\n"
    '"speed_m_s";\t"diameter_um";\t"v_n_m_s";\t"e";\t"statistic";\t"mean";'
    '\t"ci_low";\t"ci_high";\t"note"\n'
    '0.5;\t40.0;\t0.5;\t0.60;\t"e";\t0.60;\t0.50;\t0.70;\t"run #1; a"  # first\n'
    "# a comment between rows\n"
    '1.0;\t50.0;\t1.0;\t0.70;\t"e";\t0.70;\t0.60;\t0.80;\t"b"\n'
    '2.0;\t60.0;\t2.0;\t0.80;\t"e";\t0.80;\t0.70;\t0.90;\t"c"\n'
)


def test_every_reader_reads_the_same_messy_file(write_file):
    from microimpact.io.experiments import read_experiments
    from microimpact.io.impact_data import read_impact_data
    from microimpact.io.profiles import read_profile

    path = write_file("messy.csv", MESSY)
    d, meta = read_diameters(path, column="diameter_um")
    assert_allclose(d, [40e-6, 50e-6, 60e-6], rtol=1e-12)
    assert meta["delimiter"] == ";"
    impacts = read_impact_data(path)
    assert_allclose(impacts["v_n"], [0.5, 1.0, 2.0], rtol=0)
    assert_allclose(impacts["e"], [0.6, 0.7, 0.8], rtol=0)
    exp = read_experiments(path)
    assert_allclose(exp["mean"], [0.6, 0.7, 0.8], rtol=0)
    # (positions in mm: heights of 40-60 µm over a 1.5 µm scan are implausible)
    prof = read_profile(path, x_column="speed_m_s", z_column="diameter_um", x_unit="mm")
    assert_allclose(prof.z, [40e-6, 50e-6, 60e-6], rtol=1e-12)  # header unit: um
    assert prof.metadata["z_unit_from"] == "header"


def test_histogram_reads_the_same_messy_style(write_file):
    text = (
        "\ufeff# bins\n"
        '"lower_um";\t"upper_um";\t"count"\n'
        "10;\t20;\t4  # first bin\n"
        "# between\n"
        '20;\t30;\t"9"\n'
    )
    edges, counts, _ = read_histogram(write_file("h.csv", text))
    assert_allclose(edges, [10e-6, 20e-6, 30e-6], rtol=1e-12)
    assert_allclose(counts, [4, 9], rtol=0)


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("a,b,c", ","),
        ("a\tb\tc", "\t"),
        ("a;b;c", ";"),
        ("a b c", None),
        ("a;\tb;\tc", ";"),  # tabs padding a ';' are not the delimiter
        ("1,5;2,5", ";"),  # ';' with decimal commas
        ('"a;b",c', ","),  # quoted text is ignored
        ('"x, um"\t"z"', "\t"),
    ],
)
def test_sniff_delimiter(line, expected):
    from microimpact._core.files import sniff_delimiter

    assert sniff_delimiter(line) == expected


def test_semicolon_file_with_decimal_commas_names_the_cell(write_file):
    path = write_file("d.csv", "diameter_um\n52,8\n")
    with pytest.raises(DataFormatError, match=r"d\.csv:2: .*decimal separator"):
        read_diameters(path)
    path = write_file("d2.csv", "diameter_um;n\n52,8;1\n")
    with pytest.raises(DataFormatError, match=r"d2\.csv:2: .*'52,8'.*decimal"):
        read_diameters(path, column="diameter_um")


@pytest.mark.parametrize(
    ("text", "delimiter", "cells"),
    [
        ("a\t\tb", "\t", ["a", "", "b"]),  # an empty tab-separated cell stays
        ('1;\t"x;y" ;2', ";", ["1", "x;y", "2"]),  # padding around a quoted cell
        ("1 ; ; 2", ";", ["1", "", "2"]),
    ],
)
def test_csv_cells_padding(text, delimiter, cells):
    from microimpact._core.files import csv_cells

    assert csv_cells(text, source="f", line=1, delimiter=delimiter) == cells


# ---------------------------------------------------------- units (issue 22, item 2)
def test_header_unit_is_honoured_and_a_contradiction_is_an_error(tmp_path):
    from microimpact.errors import DataFormatError

    p = tmp_path / "d.csv"
    p.write_text("diameter_mm\n0.041\n0.039\n0.050\n")
    d, meta = read_diameters(p)
    assert meta["unit"] == "mm" and meta["unit_from"] == "header"
    np.testing.assert_allclose(d, [41e-6, 39e-6, 50e-6])
    with pytest.raises(DataFormatError, match="gives the unit 'mm' but the unit given"):
        read_diameters(p, unit="um")
    assert read_diameters(p, unit="mm")[1]["unit_from"] == "argument"


def test_metres_under_a_micrometre_header_are_refused_and_the_hints_work(tmp_path):
    """A diameter file holding metres under ``diameter_um`` was accepted; now it is
    refused with a hint, and following the hint reads the right diameters."""
    from microimpact.errors import DataFormatError

    p = tmp_path / "d.csv"
    p.write_text("diameter_um\n4.1e-05\n3.9e-05\n5.0e-05\n")
    with pytest.raises(DataFormatError, match="correct the header"):
        read_diameters(p)
    p.write_text("diameter_m\n4.1e-05\n3.9e-05\n5.0e-05\n")  # the hint, followed
    np.testing.assert_allclose(read_diameters(p)[0], [41e-6, 39e-6, 50e-6])
    q = tmp_path / "plain.csv"
    q.write_text("4.1e-05\n3.9e-05\n5.0e-05\n")
    with pytest.raises(
        DataFormatError, match=r"give the unit the file holds \(unit='m'"
    ):
        read_diameters(q)
    np.testing.assert_allclose(read_diameters(q, unit="m")[0], [41e-6, 39e-6, 50e-6])


@pytest.mark.parametrize(
    "particles, key",
    [
        ({"distribution": "normal", "mean_um": 40e-6, "std_um": 5e-6}, "mean_um"),
        (
            {"distribution": "lognormal", "median_um": 3e-6, "geometric_std": 1.5},
            "median_um",
        ),
        ({"distribution": "monodisperse", "diameter_um": 40000.0}, "diameter_um"),
        ({"distribution": "uniform", "min_um": 1e-6, "max_um": 5e-6}, "max_um"),
    ],
)
def test_implausible_diameters_in_a_scenario_are_refused(particles, key):
    """``mean_um = 40e-6`` (metres typed as um) ran and reported 100 % capture."""
    from microimpact.errors import ScenarioError
    from microimpact.scenario import scenario_from_dict

    data = {
        "particles": particles,
        "coefficients": {"k1": 4.0, "k2": 0.05, "v_c": 0.2},
        "sweep": {"speed_m_s": [1.0]},
    }
    with pytest.raises(ScenarioError, match=rf"particles\.{key}: .* not a particle"):
        scenario_from_dict(data)


@pytest.mark.parametrize(
    ("header", "kw", "fix"),
    [
        (
            "diameter",
            {"unit": "um"},
            "give the unit the file holds (unit='m', 'mm', 'nm'; --unit on the CLI)",
        ),
        (
            "diameter_um",
            {},
            "the header names 'um'; if the file holds another unit, correct the "
            "header (e.g. diameter_m, diameter_mm)",
        ),
    ],
)
def test_diameters_in_metres_read_as_um_say_how_to_fix_it(write_file, header, kw, fix):
    # 40 um particles written in metres: a median of 4e-05 um, below 10 nm
    path = write_file("d.csv", header + "\n4e-5\n5e-5\n3e-5\n")
    with pytest.raises(DataFormatError) as info:
        read_diameters(path, **kw)
    assert str(info.value).endswith(
        "the median diameter read as 'um' is 4e-05 um, below 10 nm, which is not a "
        f"particle diameter: the values are probably in another unit; {fix}"
    )
