"""Every refusal of a plain-text height map, whole: message, file, field, line.

A user's height map that cannot be read must come back naming the file, the
line or header key, the bad value and what is allowed (docs/conventions.md, "Bad
input"). Each case writes a small file, reads it, and compares the error's
``source``, ``field``, ``line`` and message with what is written out here from
that rule, so that a message that loses its value, its line or its field, or a
check that moves, turns a case red.
"""

from __future__ import annotations

import numpy as np
import pytest
from ids import ascii_id

from microimpact.errors import ProfileFormatError
from microimpact.io.areal import read_height_map

GRID = "1 2 3\n4 5 6\n7 8 9\n"


def _read(tmp_path, text, name="map.txt", **kw):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(path, **kw)
    return path, info.value


CASES = [
    # (file text, arguments, message, field, line)
    (
        "# dx_um = 1\n# dx_um = 2\n# z_unit = um\n" + GRID,
        {},
        "'dx' is given twice (first on line 1); allowed: once",
        "dx_um",
        2,
    ),
    (
        "# z_unit = um\n" + GRID,
        {},
        "no grid spacing 'dx': give a '# dx_um = ...' header line or the "
        "argument `dx_um`",
        "dx",
        None,
    ),
    (
        "# dx = 1\n# z_unit = um\n" + GRID,
        {},
        "the header gives dx = '1' without a unit; allowed: a unit in the key "
        "('dx_um', 'dx [nm]') or an 'xy_unit' line",
        "dx",
        1,
    ),
    (
        "# dx_um = 1\n# dy = 1\n# z_unit = um\n" + GRID,
        {},
        "the header gives dy = '1' without a unit; allowed: a unit in the key "
        "('dy_um', 'dy [nm]') or an 'xy_unit' line",
        "dy",
        2,
    ),
    (
        "# dx_um = 2\n# z_unit = um\n" + GRID,
        {"dx_um": 3.0},
        "the header gives dx = 2 µm but `dx_um` is 3; allowed: the same value, "
        "or leave `dx_um` out",
        "dx_um",
        1,
    ),
    (
        "# dx_um = 1\n# z_unit = um\n1 2 3\n4 five 6\n",
        {},
        "non-numeric height 'five'; allowed: a finite number, or nan for a "
        "missing point",
        "column 1",
        4,
    ),
    (
        "# dx_um = 1\n# z_unit = um\n1 2 3\n4 5 inf\n",
        {},
        "bad height 'inf'; allowed: a finite number, or nan for a missing point",
        "column 2",
        4,
    ),
    (
        "# dx_um = 1\n# z_unit = nm\n" + GRID,
        {"z_unit": "um"},
        "the header gives the height unit 'nm' but `z_unit` is 'um'; allowed: the "
        "same unit, or leave `z_unit` out",
        "z_unit",
        2,
    ),
    ("# dx_um = 1\n# z_unit = um\n", {}, "no data rows", None, None),
    (
        "# dx_um = 1\n# z_unit = um\n1 2 3\n4 5\n",
        {},
        "row has 2 heights, the first row has 3; allowed: the same number in every "
        "row (write nan for a missing point; the decimal separator must be '.')",
        None,
        4,
    ),
    (
        "# dx_um = 1\n# z_unit = um\n1 2 3\n",
        {},
        "the grid is 1 x 3; allowed: at least 2 x 2 heights (for a line scan use "
        "read_profile)",
        None,
        None,
    ),
    (
        "# dx_um = 1\n# z_unit = um\nnan nan\nnan nan\n",
        {},
        "every height is missing (nan)",
        None,
        None,
    ),
    (
        "# dx_um = 1\n" + GRID,
        {},
        "the file gives no height unit; give a '# z_unit = ...' header line or the "
        "argument `z_unit` (µm, nm, ...)",
        "z_unit",
        None,
    ),
    (
        "# z_unit = um\n" + GRID,
        {"dx_um": -1.0},
        None,  # the allowed wording is the module's own: checked by its parts
        "dx_um",
        None,
    ),
]


@pytest.mark.parametrize(
    ("text", "kw", "message", "field", "line"),
    CASES,
    ids=[ascii_id((c[2] or c[3])[:40]) for c in CASES],
)
def test_each_refusal_names_file_field_line_and_what_is_allowed(
    tmp_path, text, kw, message, field, line
):
    path, err = _read(tmp_path, text, **kw)
    assert err.source == str(path)
    assert err.field == field
    assert err.line == line
    if message is not None:
        assert err.message == message
    else:
        assert err.message.startswith("bad value -1.0; allowed: ")
        assert err.message.endswith(" (µm)")
    # the one line a user sees: file[:line]: [field: ]message
    where = str(path) + ("" if line is None else f":{line}") + ": "
    assert str(err).startswith(where + (f"{field}: " if field else ""))


def test_x3p_only_arguments_are_refused_for_text_and_text_ones_for_x3p(tmp_path):
    path = tmp_path / "map.x3p"
    path.write_bytes(b"not read")
    for name, value in (("dx_um", 1.0), ("z_unit", "um")):
        with pytest.raises(ProfileFormatError) as info:
            read_height_map(path, format="x3p", **{name: value})
        assert info.value.field == name
        assert info.value.message == (
            f"`{name}` applies to plain-text height maps only; an x3p file carries "
            f"its own grid and units: leave `{name}` out"
        )
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(tmp_path / "map.sur", format="surfacetopography", delimiter=",")
    assert info.value.field == "delimiter"
    assert info.value.message == (
        "`delimiter` applies to plain-text height maps only; leave it out"
    )


def test_a_readable_map_keeps_its_spacing_and_says_where_it_came_from(tmp_path):
    """The metadata users rely on: dx and dy from the header (dy defaults to
    dx), heights in metres."""
    path = tmp_path / "ok.txt"
    path.write_text("# dx_um = 2\n# z_unit = nm\n" + GRID, encoding="utf-8")
    m = read_height_map(path)
    assert m.dx == pytest.approx(2e-6, rel=1e-15)
    assert m.dy == pytest.approx(2e-6, rel=1e-15)
    np.testing.assert_allclose(m.z, np.arange(1.0, 10.0).reshape(3, 3) * 1e-9)
