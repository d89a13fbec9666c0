"""Tests for microimpact.io.impact_data.read_impact_data (files written to tmp_path)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from microimpact.errors import DataFormatError
from microimpact.io.impact_data import read_impact_data


def test_reads_si_units_ignores_comments_and_extra_columns(write_file):
    path = write_file(
        "impacts.csv",
        "# SST65 on silicon\n"
        "run,diameter_um,v_n_m_s,e\n"
        "a,52.8,1.20,0.81\n"
        "\n"
        "# captured\n"
        "b, 40 ,0.15,0\n",
    )
    table = read_impact_data(path)
    assert list(table.columns) == ["diameter", "v_n", "e"]
    assert_allclose(table["diameter"], [52.8e-6, 40e-6], rtol=1e-14)
    assert_allclose(table["v_n"], [1.20, 0.15], rtol=1e-14)
    assert_allclose(table["e"], [0.81, 0.0], rtol=1e-14)
    assert table.attrs["source"] == str(path)


def test_utf8_bom_header(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes("\ufeffdiameter_um,v_n_m_s,e\n50,1,0.5\n".encode())
    assert_allclose(read_impact_data(path)["e"], [0.5])


@pytest.mark.parametrize(
    ("row", "column", "match"),
    [
        ("abc,1.0,0.5", "diameter_um", "non-numeric value 'abc'"),
        ("50,,0.5", "v_n_m_s", "missing value"),
        ("50,1.0", "e", "missing value"),
        ("50,-1.0,0.5", "v_n_m_s", "'-1.0'.*>= 0"),
        ("50,1.0,1.6", "e", r"'1.6'.*\[0, 1.5\]"),
        ("50,1.0,-0.1", "e", r"\[0, 1.5\]"),
        ("0,1.0,0.5", "diameter_um", "diameter > 0"),
        ("50,nan,0.5", "v_n_m_s", "finite"),
    ],
)
def test_bad_cells_name_file_line_column_value(write_file, row, column, match):
    path = write_file("impacts.csv", f"diameter_um,v_n_m_s,e\n50,1.0,0.5\n{row}\n")
    with pytest.raises(DataFormatError, match=match) as info:
        read_impact_data(path)
    err = info.value
    assert (err.line, err.field) == (3, column)
    assert str(err).startswith(f"{path}:3: {column}: ")


def test_missing_column_suggests_close_name(write_file):
    path = write_file("impacts.csv", "diameter_um,vn_m_s,e\n50,1.0,0.5\n")
    with pytest.raises(DataFormatError, match="did you mean 'vn_m_s'") as info:
        read_impact_data(path)
    assert (info.value.line, info.value.field) == (1, "v_n_m_s")


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "no header"),
        ("# only a comment\n", "no header"),
        ("diameter_um,v_n_m_s,e\n", "no data rows"),
    ],
)
def test_empty_files(write_file, text, match):
    with pytest.raises(DataFormatError, match=match):
        read_impact_data(write_file("impacts.csv", text))


def test_missing_file(tmp_path):
    with pytest.raises(DataFormatError, match="file not found"):
        read_impact_data(tmp_path / "nope.csv")


def test_round_trip_into_fit(write_file):
    # the reader's SI output feeds the per-diameter fit directly
    from microimpact.physics.fitting import fit_impact_coefficients

    v = np.linspace(0.3, 3.0, 12)
    e = 4.0 / (4.0 + v) * (1 - 0.05 / (0.05 + v - 0.2))  # Li et al. (2000), Eq. 6
    lines = "".join(f"50,{a:.17g},{b:.17g}\n" for a, b in zip(v, e, strict=True))
    table = read_impact_data(
        write_file("impacts.csv", "diameter_um,v_n_m_s,e\n" + lines)
    )
    fit = fit_impact_coefficients(table["diameter"], table["v_n"], table["e"])
    assert_allclose(
        fit[["k1_m_s", "k2_m_s", "v_c_m_s"]].iloc[0], [4.0, 0.05, 0.2], rtol=1e-4
    )


@pytest.mark.parametrize(
    ("text", "line", "match"),
    [
        # decimal commas: never silently cut to the first cells
        (
            "diameter_um,v_n_m_s,e\n52,8,1,2,0,5\n",
            2,
            r"row has 6 cells, header has 3; the decimal separator must be '\.'",
        ),
        ("diameter_um,v_n_m_s,e\n50,1.0,0.5,x\n", 2, "row has 4 cells, header has 3"),
        (
            "diameter_um,v_n_m_s,e,E\n50,1,0.5,0.5\n",
            1,
            r"duplicate column\(s\) \['e'\]",
        ),
        ("diameter_um,v_n_m_s,e,e\n50,1,0.5,0.5\n", 1, "duplicate column"),
        # a semicolon file is read as one (as by every reader); its decimal comma
        # is then named
        (
            "diameter_um;v_n_m_s;e\n50;1;0,5\n",
            2,
            r"e: non-numeric value '0,5'.*the decimal separator must be '\.'",
        ),
        ('diameter_um,v_n_m_s,e\n50,1,"0.5\n', 2, "cannot parse line"),
    ],
)
def test_malformed_tables_one_line_error(write_file, text, line, match):
    path = write_file("impacts.csv", text)
    with pytest.raises(DataFormatError, match=match) as info:
        read_impact_data(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}:{line}: ") and "\n" not in msg


def test_column_names_are_case_insensitive_and_cells_may_be_quoted(write_file):
    text = 'Diameter_UM,V_N_M_S,E,note\n"52.8", 1.2 ,0.5,"a, b"\n40,0.1,0,\n'
    table = read_impact_data(write_file("impacts.csv", text))
    assert_allclose(table["diameter"], [52.8e-6, 40e-6], rtol=1e-14)
    assert_allclose(table["e"], [0.5, 0.0], rtol=0)


def test_did_you_mean_never_suggests_the_users_own_column(write_file):
    # only the case differs: the column is found, no "did you mean" round trip
    path = write_file("impacts.csv", "DIAMETER_UM,V_N_M_S,e\n50,1,0.5\n")
    assert_allclose(read_impact_data(path)["v_n"], [1.0])
    path = write_file("impacts.csv", "diameter_um,Vn_m_s,e\n50,1,0.5\n")
    with pytest.raises(DataFormatError, match="did you mean 'Vn_m_s'"):
        read_impact_data(path)
