"""The refusals of real instrument files, word for word (SurfaceTopography's test
data, MIT: tests/data/instruments/README.md).

Each case reads a real file the way a user would get it wrong (a map asked of a
line scan, units or spacings that disagree with the file, no units at all) and
compares the error's field and whole message with the reader's contract: the
argument to give or leave out, the file's own value (the NanoFocus spacing
312.49999 nm, read by hand in the README's second reading), what is allowed.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from microimpact.errors import ProfileFormatError
from microimpact.io.areal import read_height_map
from microimpact.io.profiles import read_profile

pytest.importorskip("SurfaceTopography")

DATA = Path(__file__).resolve().parents[1] / "data" / "instruments"
MAP_UNITS = "`dx_um`, `dy_um` (default: dx_um) and `z_unit`"

CASES = [
    # (reader, file, arguments, field, message)
    (
        read_height_map,
        "10x10-one_channel_without_name.ibw",
        {},
        "unit",
        f"the file gives no length unit; give {MAP_UNITS}",
    ),
    (
        read_height_map,
        "example-2d.npy",
        {},
        "unit",
        f"the file gives no length unit; give {MAP_UNITS}",
    ),
    (
        read_height_map,
        "dektak-1.csv",
        {},
        None,
        "the file holds a line scan; allowed: an areal topography (read a profile "
        "with read_profiles, or `microimpact roughness`)",
    ),
    (
        read_profile,
        "dektak-1.csv",
        {"dx_um": 1.0},
        "dx_um",
        "the file stores the position of every point (a non-uniform scan); leave "
        "`dx_um` out",
    ),
    (
        read_profile,
        "dektak-1.csv",
        {"z_unit": "nm"},
        "z_unit",
        "the file gives the unit 'µm' but `z_unit` is 'nm'; allowed: the same unit, "
        "or leave `z_unit` out to use the file's",
    ),
    (
        read_height_map,
        "nms-1.nms",
        {"dx_um": 1.0},
        "dx_um",
        "the file gives dx = 0.312499991 µm but `dx_um` is 1.0; allowed: the same "
        "value, or leave `dx_um` out",
    ),
    (read_height_map, "absent.sdf", {}, None, "file not found"),
]


@pytest.mark.parametrize(
    ("reader", "name", "kw", "field", "message"),
    CASES,
    ids=[f"{c[1]}-{','.join(c[2])}" for c in CASES],
)
def test_each_refusal_of_a_real_file_in_full(reader, name, kw, field, message):
    path = DATA / name
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ProfileFormatError) as info:
            reader(path, **kw)
    err = info.value
    assert (err.source, err.field, err.message) == (str(path), field, message)


@pytest.mark.parametrize(
    ("unit", "metres"),
    [("km", 1e3), ("pm", 1e-12), ("mm", 1e-3), ("µm", 1e-6), ("Å", 1e-10)],
    ids=["km", "pm", "mm", "micrometre", "angstrom"],  # ASCII ids (mutmut)
)
def test_surfacetopography_units_in_metres(unit, metres):
    """Units SurfaceTopography names, in metres by definition (km and pm are not
    among microimpact's own names: SurfaceTopography's table answers)."""
    from microimpact.io.instruments import surfacetopography_unit_factor

    assert surfacetopography_unit_factor(unit) == pytest.approx(metres, rel=1e-15)


@pytest.mark.parametrize("unit", ["V", "deg", "", None])
def test_a_unit_that_is_not_a_length_has_no_factor(unit):
    from microimpact.io.instruments import surfacetopography_unit_factor

    assert surfacetopography_unit_factor(unit) is None
