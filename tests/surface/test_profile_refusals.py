"""Every refusal of a text or x3p profile file, whole: message, file, field, line.

As for height maps (test_areal_refusals.py): each case writes a small profile
file and compares the error's ``source``, ``field``, ``line`` and message with
the reader's contract written out here (what is wrong, the value, what is
allowed), and the one line users see. The x3p cases need no x3p file: the
arguments are refused before the file is opened.
"""

from __future__ import annotations

import pytest
from ids import ascii_id

from microimpact.errors import ProfileFormatError
from microimpact.io.profiles import read_profile

DECIMAL = "; the decimal separator must be '.'"

CASES = [
    # (file name, text, arguments, message, field, line)
    (
        "p.csv",
        "x_um,z_nm\n1,2,3\n2,3,4\n",
        {},
        "header has 2 columns but the first data row has 3" + DECIMAL,
        None,
        2,
    ),
    (
        "p.csv",
        "x_um,z_nm\n0,1\n1,2\n",
        {"x_column": "x_um", "dx_um": 1.0},
        "give either `x_column` or `dx_um`, not both",
        None,
        None,
    ),
    (
        "p.csv",
        "z_nm\n1\n2\n3\n",
        {},
        "only one numeric column: heights alone need the sampling interval `dx_um`",
        None,
        2,
    ),
    (
        "p.csv",
        "x_um,z_nm\n0,1\n1\n",
        {},
        "expected 2 columns, found 1",
        None,
        3,
    ),
    (
        "p.csv",
        "x_um,z_nm\n0,1\n1,2,5\n",
        {},
        "expected 2 columns, found 3" + DECIMAL,
        None,
        3,
    ),
    (
        "p.csv",
        "x_um,z_nm\n0,1\n2,2\n1,3\n",
        {},
        "positions are not strictly monotonic: x = 1.0 follows 2.0",
        None,
        4,
    ),
    (
        "p.csv",
        "x,z\n0,1\n1,2\n2,3\n",
        {},
        "the file gives no length unit for x and z; give `unit` (both columns) or "
        "`x_unit` and `z_unit`, or name it in the header (e.g. x_um, z_nm)",
        "unit",
        None,
    ),
    (
        "p.csv",
        "x_um,z\n0,1\n1,2\n2,3\n",
        {},
        "the file gives no length unit for z; give `unit` (both columns) or "
        "`z_unit`, or name it in the header (e.g. x_um, z_nm)",
        "unit",
        None,
    ),
    (
        "p.txt",
        "0 1\n1 2\n2 3\n",
        {},
        "the file gives no length unit for x and z; give `unit` (both columns) or "
        "`x_unit` and `z_unit`, or name it in the header (e.g. x_um, z_nm)",
        "unit",
        None,
    ),
    (
        "p.csv",
        "x_um,z_nm\n0,1\n1,2\n",
        {"dx_um": -1},
        "bad value -1; allowed: a number > 0 (µm)",
        "dx_um",
        None,
    ),
    (
        "p.csv",
        "x_um,z_nm\n0,1\n1,2\n",
        {"dx_um": "a"},
        "bad value 'a'; allowed: a number > 0 (µm)",
        "dx_um",
        None,
    ),
    (
        "p.x3p",
        "",
        {"unit": "um"},
        "an x3p file stores metres but `unit` is 'um'; allowed: leave `unit` out",
        "unit",
        None,
    ),
    (
        "p.x3p",
        "",
        {"z_unit": "nm"},
        "an x3p file stores metres but `z_unit` is 'nm'; allowed: leave `z_unit` out",
        "z_unit",
        None,
    ),
    (
        "p.x3p",
        "",
        {"dx_um": 1.0},
        "an x3p file stores its own spacing; leave `dx_um` out",
        "dx_um",
        None,
    ),
]


@pytest.mark.parametrize(
    ("name", "text", "kw", "message", "field", "line"),
    CASES,
    ids=[ascii_id(c[3][:40]) for c in CASES],
)
def test_each_refusal_names_file_field_line_and_what_is_allowed(
    tmp_path, name, text, kw, message, field, line
):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ProfileFormatError) as info:
        read_profile(path, **kw)
    err = info.value
    assert (err.message, err.field, err.line) == (message, field, line)
    assert err.source == str(path)
    where = str(path) + ("" if line is None else f":{line}") + ": "
    assert str(err) == where + (f"{field}: " if field else "") + message


def test_a_file_of_several_scans_is_refused_by_read_profile(tmp_path):
    path = tmp_path / "two.csv"
    path.write_text("scan,x_um,z_nm\na,0,1\na,1,2\nb,0,3\nb,1,4\n", encoding="utf-8")
    with pytest.raises(ProfileFormatError) as info:
        read_profile(path)
    assert info.value.source == str(path)
    assert info.value.message == "the file holds 2 scans; read it with read_profiles()"


def test_a_missing_x3p_file_is_named(tmp_path):
    pytest.importorskip("x3pio")
    path = tmp_path / "absent.x3p"
    with pytest.raises(ProfileFormatError) as info:
        read_profile(path)
    assert (info.value.source, info.value.message) == (str(path), "file not found")


# ---------------------------------------------------------------- plausibility
ALLOWED = "allowed: a spacing of 1 Å to 1 mm and a field under 1 m"
SCAN_OVERRIDE = (
    "x_unit=... (or unit=...) where the file names none, or dx_um=... for heights "
    "alone; a unit the file names is corrected in the file"
)


def test_an_implausible_scan_names_its_scan_the_unit_read_and_the_likely_slip():
    """2 mm per point read as mm: the message names the scan, the number as read,
    the likely unit (the one giving a spacing nearest 1 µm) and the overrides."""
    import numpy as np

    from microimpact.io.plausibility import check_scan

    x = np.arange(5) * 2e-3
    with pytest.raises(ProfileFormatError) as info:
        check_scan(x, np.zeros(5), source="s.csv", x_unit="mm", scan="b")
    err = info.value
    assert (err.source, err.field) == ("s.csv", "dx")
    assert err.message == (
        "implausible lateral spacing dx = 2 mm (2 read as mm: was it µm?) (scan b): "
        f"outside 1 Å to 1 mm per point; {ALLOWED}; if the unit is wrong, give the "
        f"spacing with {SCAN_OVERRIDE}"
    )


def test_a_field_of_view_over_a_metre_is_refused_with_the_field():
    import numpy as np

    from microimpact.io.plausibility import check_scan

    x = np.arange(4001) * 5e-4  # 0.5 mm per point (allowed), 2 m in all
    with pytest.raises(ProfileFormatError) as info:
        check_scan(x, np.zeros(x.size))
    assert info.value.source is None
    assert info.value.message == (
        "implausible lateral spacing dx = 500 µm: a field of view of 2 m, over 1 m; "
        f"{ALLOWED}; if the unit is wrong, give the spacing with {SCAN_OVERRIDE}"
    )


def test_implausible_heights_name_the_range_the_field_and_the_slip():
    """Heights of 0..5 read as mm over a 100 µm scan (50 times the field): the
    largest unit that fits is named (µm: a range of 5 µm)."""
    import numpy as np

    from microimpact.io.plausibility import check_map, check_scan

    x = np.arange(101) * 1e-6
    z = np.linspace(0.0, 5e-3, 101)
    with pytest.raises(ProfileFormatError) as info:
        check_scan(x, z, source="s.csv", z_unit="mm", scan=3)
    assert info.value.field == "z"
    assert info.value.message == (
        "implausible heights: a range of 5 mm (5 read as mm: was it µm?) over a "
        "field of 100 µm (scan 3); allowed: a height range up to 10 times the "
        "field; if the file's height unit is wrong, give it with z_unit=..."
    )
    zz = np.zeros((3, 4))
    with pytest.raises(ProfileFormatError) as info:
        check_map(zz, 1e-6, 2e-3, source="m.txt", xy_unit="um")
    assert info.value.field == "dy"
    assert info.value.message == (
        "implausible lateral spacing dy = 2 mm (2,000 read as µm: was it nm?): "
        f"outside 1 Å to 1 mm per point; {ALLOWED}; if the unit is wrong, give the "
        "spacing with dy_um=..."
    )


def test_the_height_check_uses_the_scans_length_not_its_end_position():
    """A 100 um scan that starts 5 mm along its axis: heights of 5 mm are 50
    times its length (refused), whatever the positions' origin."""
    import numpy as np

    from microimpact.io.plausibility import check_scan

    x = 5e-3 + np.arange(101) * 1e-6
    with pytest.raises(ProfileFormatError) as info:
        check_scan(x, np.linspace(0.0, 5e-3, 101))
    assert "over a field of 100 µm" in info.value.message
