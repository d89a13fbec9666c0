"""Tests for microimpact.io.profiles: text and x3p profile readers."""

from __future__ import annotations

import sys
import zipfile

import numpy as np
import pytest
from numpy.testing import assert_allclose

from microimpact.errors import ProfileFormatError
from microimpact.io.profiles import Profile, ProfileSet, read_profile, read_profiles


def _one_line_error(excinfo, path, line=None):
    msg = str(excinfo.value)
    assert "\n" not in msg
    assert str(path) in msg
    if line is not None:
        assert f"{path}:{line}:" in msg
    return msg


# ------------------------------------------------------------------ good input


def test_csv_with_header_in_um(write_file):
    p = write_file("a.csv", "# a comment\nx,z\n0,1.5\n0.5,-2\n1.0,3 # note\n")
    prof = read_profile(p, unit="um")
    assert isinstance(prof, Profile)
    assert_allclose(prof.x, [0.0, 0.5e-6, 1.0e-6], rtol=0, atol=1e-18)
    assert_allclose(prof.z, [1.5e-6, -2e-6, 3e-6], rtol=1e-15)
    assert prof.metadata["source"] == str(p)
    assert prof.n_points == 3
    assert_allclose(prof.dx, 0.5e-6, rtol=1e-12)
    assert "n_points" not in prof.metadata and "dx" not in prof.metadata
    assert prof.metadata["z_unit"] == "um"


@pytest.mark.parametrize(
    ("text", "delimiter"),
    [
        ("0\t10\n1\t20\n2\t30\n", None),
        ("0 10\n1   20\n2 30\n", None),
        ("0;10\n1;20\n2;30\n", None),
        ("0|10\n1|20\n2|30\n", "|"),
    ],
)
def test_delimiters(write_file, text, delimiter):
    p = write_file("a.txt", text)
    prof = read_profile(p, unit="mm", delimiter=delimiter)
    assert_allclose(prof.x, [0.0, 1e-3, 2e-3], rtol=1e-15)
    assert_allclose(prof.z, [10e-3, 20e-3, 30e-3], rtol=1e-15)


@pytest.mark.parametrize(
    ("unit", "factor"),
    [("m", 1.0), ("mm", 1e-3), ("um", 1e-6), ("µm", 1e-6), ("nm", 1e-9), ("A", 1e-10)],
)
def test_units(write_file, unit, factor):
    # 4 µm and 0.2 / 0.6 µm written in `unit` (plausible in every unit)
    p = write_file(
        "a.csv", f"0,{2e-7 / factor!r}\n{4e-6 / factor!r},{6e-7 / factor!r}\n"
    )
    prof = read_profile(p, unit=unit)
    assert_allclose(prof.x, [0.0, 4e-6], rtol=1e-12)
    assert_allclose(prof.z, [2e-7, 6e-7], rtol=1e-12)


def test_separate_units_paper_angstrom(write_file):
    # positions in µm, heights in Å as in the paper's H_bar [Å]
    p = write_file("a.csv", "x,z\n0,200000\n5,-100000\n")
    prof = read_profile(p, x_unit="um", z_unit="Å")
    assert_allclose(prof.x, [0.0, 5e-6], rtol=1e-15)
    assert_allclose(prof.z, [20e-6, -10e-6], rtol=1e-15)


def test_heights_only_with_dx(write_file):
    p = write_file("h.txt", "# heights only\n1\n2\n3\n4\n")
    prof = read_profile(p, dx_um=0.5, z_unit="um")
    assert_allclose(prof.x, np.arange(4) * 0.5e-6, rtol=1e-15)
    assert_allclose(prof.z, [1e-6, 2e-6, 3e-6, 4e-6], rtol=1e-15)


def test_named_columns(write_file):
    p = write_file("a.csv", "t,height,pos\n9,1,0\n9,2,1\n9,3,2\n")
    prof = read_profile(p, x_column="pos", z_column="Height", unit="um")
    assert_allclose(prof.x, [0, 1e-6, 2e-6], rtol=1e-15)
    assert_allclose(prof.z, [1e-6, 2e-6, 3e-6], rtol=1e-15)
    prof2 = read_profile(p, x_column=2, z_column=1, unit="um")
    assert_allclose(prof2.z, prof.z, rtol=0)


def test_decreasing_positions_are_reversed(write_file):
    p = write_file("a.csv", "2,30\n1,20\n0,10\n")
    prof = read_profile(p, unit="um")
    assert_allclose(prof.x, [0, 1e-6, 2e-6], rtol=1e-15)
    # (x, z) pairs are kept, so slopes keep their sign
    assert_allclose(prof.z, [10e-6, 20e-6, 30e-6], rtol=1e-15)


def test_scan_column_gives_separate_scans(write_file):
    rows = ["scan,x_um,z_um"]
    rows += [f"A,{i * 0.5},{i}" for i in range(5)]
    rows += [f"B,{i * 0.5},{-i}" for i in range(6)]
    p = write_file("s.csv", "\n".join(rows) + "\n")
    ps = read_profiles(p)
    assert isinstance(ps, ProfileSet)
    assert len(ps) == 2
    assert [q.scan for q in ps] == ["A", "B"]
    assert [q.n_points for q in ps] == [5, 6]
    assert ps.n_points == 11
    assert_allclose(ps[1].z, -np.arange(6) * 1e-6, rtol=1e-15)
    with pytest.raises(ProfileFormatError, match="holds 2 scans"):
        read_profile(p)


def test_several_files(write_file):
    p1 = write_file("1.csv", "0,1\n1,2\n2,3\n")
    p2 = write_file("2.csv", "0,4\n1,5\n")
    ps = read_profiles([p1, p2], unit="um")
    assert len(ps) == 2
    assert ps.sources == [str(p1), str(p2)]
    assert ps.n_points == 5


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    ("text", "line", "match"),
    [
        ("x,z\n0,1\n1,abc\n", 3, "non-numeric value 'abc'"),
        ("x,z\n0,1\n,2\n", 3, "column 'x': missing value ''"),
        ("0,1\nNaN,2\n", 2, "missing value 'NaN'.*every point needs a position"),
        ("0,1\n1,NA\n2,\n", 1, "1 measured point"),
        ("0,1\n2,2\n1,3\n", 3, "not strictly monotonic"),
        ("0,1\n1,2\n1,3\n", 3, "not strictly monotonic"),
        ("0,1\n1,2,3\n", 2, "expected 2 columns, found 3"),
    ],
)
def test_bad_cells_one_line_error(write_file, text, line, match):
    p = write_file("bad.csv", text)
    with pytest.raises(ProfileFormatError, match=match) as excinfo:
        read_profile(p, unit="um")
    _one_line_error(excinfo, p, line)


def test_unknown_unit(write_file):
    p = write_file("a.csv", "0,1\n1,2\n")
    with pytest.raises(ProfileFormatError, match="unknown length unit 'inch'") as ei:
        read_profile(p, unit="inch")
    _one_line_error(ei, p)
    with pytest.raises(ProfileFormatError, match="z_unit"):
        read_profile(p, z_unit="furlong")


@pytest.mark.parametrize(
    ("text", "kwargs", "match"),
    [
        ("# only comments\n", {}, "no data rows"),
        ("1\n2\n3\n", {}, "heights alone need"),
        ("x,z\n0,1\n1,2\n", {"z_column": "h"}, "no column named 'h'"),
        ("0,1\n1,2\n", {"z_column": "h"}, "no header row"),
        ("0,1\n1,2\n", {"z_column": 5}, "out of range"),
        ("0,1\n", {}, "at least 2 are needed"),
        ("0,1\n1,2\n", {"dx_um": 0.5, "x_column": 0}, "not both"),
    ],
)
def test_structural_errors(write_file, text, kwargs, match):
    p = write_file("bad.csv", text)
    with pytest.raises(ProfileFormatError, match=match) as excinfo:
        read_profile(p, **kwargs)
    _one_line_error(excinfo, p)


def test_too_few_points_names_the_scan_only_when_there_are_scans(write_file):
    # found by a user: a one-point file said "scan None has 1 measured point(s)"
    p = write_file("one.csv", "x,z\n0,1\n")
    with pytest.raises(ProfileFormatError, match="at least 2 are needed") as ei:
        read_profile(p, unit="um")
    assert "None" not in str(ei.value)
    assert "the profile has 1 measured point(s) of 1" in str(ei.value)
    p = write_file("scans.csv", "scan,x,z\na,0,1\na,1,2\nb,0,3\n")
    with pytest.raises(ProfileFormatError, match="scan 'b' has 1 measured point"):
        read_profiles(p, unit="um", scan_column="scan")


def test_missing_file_and_binary(tmp_path):
    with pytest.raises(ProfileFormatError, match="file not found"):
        read_profile(tmp_path / "nope.csv")
    p = tmp_path / "bin.csv"
    p.write_bytes(b"\xff\xfe\x00\x81" * 10)
    with pytest.raises(ProfileFormatError, match="not a UTF-8 text file"):
        read_profile(p)


def test_bad_dx(write_file):
    p = write_file("h.txt", "1\n2\n")
    with pytest.raises(ProfileFormatError, match="dx_um: bad value -1"):
        read_profile(p, dx_um=-1, z_unit="um")


# ------------------------------------------------------------------ x3p


def _make_x3p(path, z, dx, *, dtype="D", z_increment=1.0, feature="PRF", rows=1):
    """A minimal ISO 5436-2 x3p container built by hand (zipfile + XML text)."""
    code = {"D": "<f8", "F": "<f4", "I": "<i2", "L": "<i4"}[dtype]
    z = np.asarray(z, dtype=float)
    nx = z.shape[-1]
    xml = f"""<?xml version="1.0" encoding="UTF-8"?>
<p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2">
 <Record1><Revision>ISO5436 - 2000</Revision><FeatureType>{feature}</FeatureType>
  <Axes>
   <CX><AxisType>I</AxisType><DataType>D</DataType><Increment>{dx!r}</Increment>
       <Offset>0</Offset></CX>
   <CY><AxisType>I</AxisType><DataType>D</DataType><Increment>{dx!r}</Increment>
       <Offset>0</Offset></CY>
   <CZ><AxisType>A</AxisType><DataType>{dtype}</DataType>
       <Increment>{z_increment!r}</Increment><Offset>0</Offset></CZ>
  </Axes></Record1>
 <Record3><MatrixDimension><SizeX>{nx}</SizeX><SizeY>{rows}</SizeY><SizeZ>1</SizeZ>
  </MatrixDimension>
  <DataLink><PointDataLink>bindata/data.bin</PointDataLink></DataLink></Record3>
 <Record4><ChecksumFile>md5checksum.hex</ChecksumFile></Record4>
</p:ISO5436_2>"""
    raw = np.round(z / z_increment) if dtype in "IL" else z / z_increment
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("main.xml", xml)
        zf.writestr("bindata/data.bin", raw.astype(code).tobytes())
    return path


@pytest.mark.parametrize(
    ("dtype", "inc", "rtol"), [("D", 1.0, 1e-15), ("F", 1.0, 1e-7), ("I", 1e-9, 1e-12)]
)
def test_x3p_profile(tmp_path, dtype, inc, rtol):
    pytest.importorskip("x3pio")
    z = np.array([1e-6, 2e-6, -1e-6, 0.5e-6, 3e-6])
    p = _make_x3p(tmp_path / "p.x3p", z, 0.5e-6, dtype=dtype, z_increment=inc)
    prof = read_profile(p)
    assert_allclose(prof.x, np.arange(5) * 0.5e-6, rtol=1e-12, atol=1e-18)
    assert_allclose(prof.z, z, rtol=rtol, atol=1e-18)
    assert prof.metadata["format"] == "x3p"


def test_x3p_surface_rows_are_scans(tmp_path):
    pytest.importorskip("x3pio")
    z = np.arange(12.0).reshape(3, 4) * 1e-6
    p = _make_x3p(tmp_path / "s.x3p", z, 1e-6, feature="SUR", rows=3)
    ps = read_profiles(p)
    assert len(ps) == 3
    assert_allclose(ps[2].z, z[2], rtol=1e-15)
    with pytest.raises(ProfileFormatError, match="holds 3 scans") as info:
        read_profile(p)
    assert str(info.value) == (
        f"{p}: the file holds 3 scans; read it with read_profiles()"
    )


def test_x3p_damaged(tmp_path):
    pytest.importorskip("x3pio")
    p = tmp_path / "bad.x3p"
    with zipfile.ZipFile(p, "w") as zf:
        zf.writestr("readme.txt", "not an x3p")
    with pytest.raises(ProfileFormatError, match="not a readable x3p file") as ei:
        read_profile(p)
    _one_line_error(ei, p)


def test_x3p_without_x3pio(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "x3pio", None)  # import fails
    p = _make_x3p(tmp_path / "p.x3p", [0.0, 1e-6], 1e-6)
    with pytest.raises(ProfileFormatError, match="pip install x3pio") as ei:
        read_profile(p)
    _one_line_error(ei, p)


def test_profile_validation():
    with pytest.raises(ValueError, match="strictly increasing"):
        Profile([0.0, 0.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="same length"):
        Profile([0.0, 1.0], [1.0])
    with pytest.raises(ValueError, match="at least 2 measured"):
        Profile([0.0, 1.0], [1.0, np.nan])
    with pytest.raises(ValueError, match="inf"):
        Profile([0.0, 1.0, 2.0], [1.0, np.inf, 0.0])
    with pytest.raises(ValueError, match="positions"):
        Profile([0.0, np.nan, 2.0], [1.0, 2.0, 0.0])
    masked = Profile([0.0, 1.0, 2.0, 3.0], [1.0, np.nan, 0.0, 2.0])
    assert masked.masked_fraction == 0.25 and masked.valid.sum() == 3
    p = Profile([0.0, 1.0, 2.0], [0.0, 1.0, 0.0])
    with pytest.raises(ValueError):
        p.z[0] = 5.0  # read-only


# ------------------------------------------------------------------ shared text rules


def test_quoted_numbers_and_case_insensitive_names(write_file):
    p = write_file("q.csv", '"X","Z"\n"0","1.5"\n"0.5", "-2"\n')
    prof = read_profile(p, x_column="x", z_column="z", unit="um")
    assert_allclose(prof.z, [1.5e-6, -2e-6], rtol=1e-15)
    assert prof.metadata["x_column"] == "X"


@pytest.mark.parametrize(
    ("text", "kwargs", "line", "match"),
    [
        ("x;z\n0,5;1,5\n1,0;2\n", {}, 2, r"column 'x': non-numeric .*'\.'"),
        ("x,z\n0,5,1,5\n", {}, 2, r"first data row has 4; the decimal separator"),
        ("x,z\n0,1\n1,2,5\n", {}, 3, r"expected 2 columns, found 3; the decimal"),
        ("x,z\n0,1\n1,abc\n", {}, 3, r"column 'z': non-numeric value 'abc'; allowed"),
        ("0,1\n1,inf\n", {}, 2, r"column 1: bad value 'inf'"),
        ('x,z\n0,"1\n', {}, 2, "cannot parse line"),
    ],
)
def test_bad_text_names_line_and_column(write_file, text, kwargs, line, match):
    p = write_file("bad.csv", text)
    with pytest.raises(ProfileFormatError, match=match) as excinfo:
        read_profile(p, **kwargs)
    _one_line_error(excinfo, p, line)


@pytest.mark.parametrize(
    ("text", "kwargs", "match"),
    [
        ("x,z\n0,1\n1,2\n", {"x_column": "z", "z_column": 1}, "are the same column"),
        ("x,z\n0,1\n1,2\n", {"x_column": 0, "z_column": -2}, "are the same column"),
        ("scan,x,z\na,0,1\na,1,2\n", {"z_column": "scan"}, "are the same column"),
        ("x,X\n0,1\n1,2\n", {"z_column": "X"}, None),
        ("x,X\n0,1\n1,2\n", {"x_column": 0, "z_column": "x"}, "are the same column"),
        ("a,b\n0,1\n1,2\n", {"z_column": "B"}, None),
    ],
)
def test_column_choice(write_file, text, kwargs, match):
    p = write_file("c.csv", text)
    if match is None:
        read_profile(p, **{"x_column": 0, "unit": "um", **kwargs})
        return
    with pytest.raises(ProfileFormatError, match=match) as excinfo:
        read_profile(p, **kwargs)
    _one_line_error(excinfo, p)


def test_ambiguous_column_name(write_file):
    p = write_file("c.csv", "t,Z,z\n0,1,2\n1,2,3\n")
    with pytest.raises(ProfileFormatError, match="ambiguous") as excinfo:
        read_profile(p, x_column=0, z_column="Z ")
    _one_line_error(excinfo, p)


def test_unknown_unit_lists_each_spelling_once(write_file):
    p = write_file("a.csv", "0,1\n1,2\n")
    with pytest.raises(ProfileFormatError, match="unknown length unit") as ei:
        read_profile(p, x_unit="inch")
    msg = _one_line_error(ei, p)
    assert msg.startswith(f"{p}: x_unit: ")
    assert msg.count("µm") + msg.count("μm") == 1


def test_bad_delimiter_argument(write_file):
    p = write_file("a.csv", "0|1\n1|2\n")
    with pytest.raises(ValueError, match="`delimiter` must be one character"):
        read_profile(p, delimiter="||")


def test_profile_set_metadata_is_not_duplicated(write_file):
    p1 = write_file("1.csv", "0,1\n1,2\n2,3\n")
    ps = read_profiles([p1, p1], unit="um")
    assert ps.sources == [str(p1)] and ps.n_points == 6 and len(ps) == 2
    assert ps.metadata == {}
    assert ProfileSet((Profile([0.0, 1.0], [0.0, 1.0]),)).sources == []
    with pytest.raises(ValueError, match=r"^a ProfileSet needs at least one profile"):
        ProfileSet(())


# ------------------------------------------------------------------ header units


@pytest.mark.parametrize(
    ("cell", "unit"),
    [
        ("x_um", "um"),
        ("z_nm", "nm"),
        ("height [nm]", "nm"),
        ("x (mm)", "mm"),
        ("z_A", "A"),
        ("height_µm", "µm"),
        ("z / nm", "nm"),
        ("Z_NM", "nm"),
        ("x_m", "m"),
        ("x", None),
        ("scan_id", None),
        ("speed_m_s", None),  # a suffix that is no length unit is part of the name
        ("z_a", None),  # only the capital A is the angstrom
    ],
)
def test_header_unit(cell, unit):
    from microimpact.io.profiles import header_unit

    assert header_unit(cell) == (unit, None)


def test_nm_heights_give_ra_in_metres_from_a_sine(write_file):
    # z = A sin(2 pi x / lam) over whole periods: Ra = 2 A / pi (independent of the
    # reader); read as um (the old behaviour) it would be 1000 times too large
    from microimpact.surface.roughness import profile_parameters

    amp_nm, lam_um, n = 150.0, 40.0, 4000
    x_um = np.arange(n) * (4 * lam_um / n)  # 4 whole periods
    z_nm = amp_nm * np.sin(2 * np.pi * x_um / lam_um)
    text = "x_um,z_nm\n" + "".join(
        f"{a:.17g},{b:.17g}\n" for a, b in zip(x_um, z_nm, strict=True)
    )
    prof = read_profile(write_file("sine.csv", text))
    ra = profile_parameters(prof, detrend=None).Ra
    assert_allclose(ra, 2 * amp_nm * 1e-9 / np.pi, rtol=1e-3)
    assert prof.metadata["z_unit"] == "nm"
    assert prof.metadata["z_unit_from"] == "header"
    assert prof.metadata["x_unit_from"] == "header"


def test_hand_computed_ra_of_a_bracketed_nm_header(write_file):
    # heights 0, 10, -10, 20 nm: mean 5, |deviations| 5, 5, 15, 15 -> Ra = 10 nm
    from microimpact.surface.roughness import profile_parameters

    p = write_file("h.csv", "x (mm);height [nm]\n0;0\n0.001;10\n0.002;-10\n0.003;20\n")
    prof = read_profile(p)
    assert_allclose(prof.x, [0.0, 1e-6, 2e-6, 3e-6], rtol=1e-12, atol=1e-20)
    assert_allclose(profile_parameters(prof, detrend=None).Ra, 10e-9, rtol=1e-12)


def test_header_unit_and_a_different_explicit_unit_is_an_error(write_file):
    p = write_file("a.csv", "x_um,z_nm\n0,1\n1,2\n2,3\n")
    for kw, arg in (({"z_unit": "um"}, "z_unit"), ({"unit": "um"}, "unit")):
        with pytest.raises(ProfileFormatError) as info:
            read_profile(p, **kw)
        msg = _one_line_error(info, p)
        assert f"{arg}:" in msg and "'z_nm'" in msg
        assert "'nm'" in msg and "'um'" in msg
    # the same unit, however spelt, is no conflict
    prof = read_profile(p, x_unit="µm", z_unit="nm")
    assert prof.metadata["z_unit_from"] == "argument"
    assert_allclose(prof.z, [1e-9, 2e-9, 3e-9], rtol=1e-12)


def test_unknown_bracketed_unit_needs_an_explicit_one(write_file):
    p = write_file("a.csv", "x_um,z [au]\n0,1\n1,2\n2,3\n")
    with pytest.raises(ProfileFormatError, match=r"unknown length unit 'au'.*z_unit"):
        read_profile(p)
    assert_allclose(read_profile(p, z_unit="nm").z, [1e-9, 2e-9, 3e-9], rtol=1e-12)


def test_without_any_unit_the_error_names_the_arguments_and_following_it_works(
    write_file,
):
    p = write_file("a.csv", "x,z\n0,1\n1,2\n")
    with pytest.raises(ProfileFormatError) as info:
        read_profile(p)
    msg = _one_line_error(info, p)
    assert "no length unit" in msg and "`unit`" in msg and "`x_unit`" in msg
    prof = read_profile(p, unit="um")  # the hint, followed
    assert prof.metadata["x_unit"] == "um" and prof.metadata["z_unit"] == "um"
    assert prof.metadata["x_unit_from"] == prof.metadata["z_unit_from"] == "argument"
    assert_allclose(prof.z, [1e-6, 2e-6], rtol=1e-12)
    prof = read_profile(p, x_unit="mm", z_unit="nm")  # the other hint
    assert_allclose(prof.x, [0.0, 1e-3], rtol=1e-12)
    prof = read_profile(write_file("b.csv", "z_nm\n1\n2\n"), dx_um=0.5)
    assert prof.metadata["x_unit_from"] == "dx_um"
    assert_allclose(prof.z, [1e-9, 2e-9], rtol=1e-12)
    h = write_file("h.txt", "1\n2\n3\n")
    with pytest.raises(ProfileFormatError, match=r"no length unit for z.*`z_unit`"):
        read_profile(h, dx_um=0.5)
    assert_allclose(read_profile(h, dx_um=0.5, z_unit="nm").z[-1], 3e-9, rtol=1e-12)


@pytest.mark.parametrize(
    ("header", "missing", "give"),
    [
        ("x,z_nm", "x", "`unit` (both columns) or `x_unit`"),
        ("x_um,z", "z", "`unit` (both columns) or `z_unit`"),
        ("x,z", "x and z", "`unit` (both columns) or `x_unit` and `z_unit`"),
    ],
)
def test_a_missing_unit_is_named_with_exactly_the_arguments_that_give_it(
    write_file, header, missing, give
):
    # only the axes without a unit are named, and only the arguments for them
    p = write_file("u.csv", header + "\n0,1\n0.5,2\n1,3\n")
    with pytest.raises(ProfileFormatError) as info:
        read_profile(p)
    assert info.value.field == "unit"
    assert str(info.value) == (
        f"{p}: unit: the file gives no length unit for {missing}; give {give}, "
        "or name it in the header (e.g. x_um, z_nm)"
    )


def test_scan_column_file_with_header_units_through_read_profiles(write_file):
    text = "scan,x_um,z_nm\n" + "".join(
        f"{s},{i * 0.5},{(-1) ** i * 10 * s}\n" for s in (1, 2) for i in range(6)
    )
    ps = read_profiles(write_file("scans.csv", text))
    assert len(ps) == 2 and [p.scan for p in ps] == ["1", "2"]
    assert_allclose(np.abs(ps[1].z), 20e-9, rtol=1e-12)
    assert ps[0].metadata["scan_column"] == "scan"


def test_a_decreasing_scan_that_turns_back_names_the_turn(write_file):
    # positions 3, 2, 2.5: decreasing (read reversed) until 2.5 follows 2
    p = write_file("dec.csv", "x_um,z_um\n3,1\n2,2\n2.5,3\n")
    with pytest.raises(ProfileFormatError) as info:
        read_profile(p)
    assert str(info.value) == (
        f"{p}:4: positions are not strictly monotonic: x = 2.5 follows 2.0"
    )


def test_a_file_without_a_position_column_is_named(write_file):
    # the scan and height columns named, none left for the positions
    p = write_file("np.csv", "s,z\n1,2\n1,4\n")
    with pytest.raises(ProfileFormatError) as info:
        read_profiles(p, z_column="z", scan_column="s", unit="um")
    assert str(info.value) == (
        f"{p}:2: no position column: give `x_column`, or `dx_um` for heights alone"
    )


def test_check_xz_names_the_array_that_is_not_numeric():
    from microimpact.io.profiles import check_xz

    with pytest.raises(TypeError, match=r"^`z` must be numeric"):
        check_xz([0.0, 1e-6], ["a", "b"])


def test_a_profile_is_read_only():
    # a Profile is immutable: its arrays too, so a caller cannot change a scan
    # that a cached result was computed from
    p = Profile([0.0, 1e-6, 2e-6], [0.0, 1e-9, 0.0])
    for a in (p.x, p.z):
        with pytest.raises(ValueError, match="read-only"):
            a[0] = 1.0
