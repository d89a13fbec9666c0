"""The height-map reader's refusals name the file, the line, the field, the bad
value and what is allowed (docs/roughness.md), and a HeightMap holds plain
floats (its documented types, which JSON writes)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from microimpact.errors import ProfileFormatError
from microimpact.io.areal import HeightMap, read_height_map

DATA = Path(__file__).parents[1] / "data" / "instruments"
GRID = "1 2 3\n4 5 6\n"


def _refusal(path, **kw):
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(path, **kw)
    return info.value, str(info.value)


def test_a_delimiter_for_an_instrument_file_is_refused_by_name():
    exc, msg = _refusal(DATA / "sdf-1.sdf", delimiter=",")
    assert exc.field == "delimiter"
    assert msg == (
        f"{DATA / 'sdf-1.sdf'}: delimiter: `delimiter` applies to plain-text height "
        "maps only; leave it out"
    )


def test_a_text_map_without_rows_says_so(write_file):
    path = write_file("h.txt", "# dx_um = 1\n# z_unit = um\n")
    assert _refusal(path)[1] == f"{path}: no data rows"


@pytest.mark.parametrize(
    ("header", "kw", "where", "end"),
    [
        (
            "# dy_um = -2\n",
            {},
            ":2: dy",
            "bad value '-2'; allowed: a finite number > 0",
        ),
        (
            "# dy_um = 2\n",
            {"dy_um": 3},
            ":2: dy_um",
            "the header gives dy = 2 µm but `dy_um` is 3; allowed: the same value, "
            "or leave `dy_um` out",
        ),
    ],
)
def test_a_bad_dy_names_the_file_and_line(write_file, header, kw, where, end):
    path = write_file("d.txt", "# dx_um = 1\n" + header + "# z_unit = um\n" + GRID)
    _, msg = _refusal(path, **kw)
    assert msg == f"{path}{where}: {end}"


def test_a_height_map_holds_plain_float_spacings():
    hm = HeightMap(np.zeros((2, 3)), 1, np.float32(2.0))
    assert type(hm.dx) is float and type(hm.dy) is float
    assert json.loads(json.dumps({"dx": hm.dx, "dy": hm.dy})) == {"dx": 1.0, "dy": 2.0}
