"""Where each unit of a surface file came from, as docs/roughness.md promises.

"Every unit used is recorded with where it came from": a profile's ``x_unit``,
``z_unit``, ``x_unit_from``, ``z_unit_from`` (``"header"`` or ``"file"``,
``"argument"``, ``"dx_um"``); a height map's ``z_unit``, ``xy_unit``, ``dx_from``,
``dy_from``, ``z_unit_from``. Each case below reads a file whose units come from
one known place (a text header, the instrument's own file, an argument) and
checks the record against the docs' words; the real instrument files are
SurfaceTopography's test data (MIT, tests/data/instruments/README.md).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from microimpact.io.areal import read_height_map
from microimpact.io.profiles import read_profile

DATA = Path(__file__).resolve().parents[1] / "data"
INSTRUMENTS = DATA / "instruments"
DOCUMENTED = {"header", "file", "argument", "dx_um"}


def _units(meta, keys):
    return {k: meta[k] for k in keys}


def test_a_text_map_whose_header_names_every_unit(tmp_path):
    path = tmp_path / "m.txt"
    path.write_text("# dx_um = 0.5\n# z_unit = nm\n1 2\n3 4\n", encoding="utf-8")
    meta = read_height_map(path).metadata
    keys = ("xy_unit", "xy_unit_from", "dx_from", "dy_from", "z_unit", "z_unit_from")
    assert _units(meta, keys) == {
        "xy_unit": "um",
        "xy_unit_from": "header",
        "dx_from": "header",
        "dy_from": "dx",  # dy defaults to dx
        "z_unit": "nm",
        "z_unit_from": "header",
    }


def test_a_text_map_whose_units_are_the_arguments(tmp_path):
    path = tmp_path / "m.txt"
    path.write_text("1 2\n3 4\n", encoding="utf-8")
    meta = read_height_map(path, dx_um=0.5, z_unit="nm").metadata
    keys = ("xy_unit", "xy_unit_from", "dx_from", "dy_from", "z_unit", "z_unit_from")
    assert _units(meta, keys) == {
        "xy_unit": "um",
        "xy_unit_from": "dx_um",
        "dx_from": "argument",
        "dy_from": "dx",
        "z_unit": "nm",
        "z_unit_from": "argument",
    }


def test_an_instrument_map_without_units_takes_the_arguments():
    pytest.importorskip("SurfaceTopography")
    path = INSTRUMENTS / "10x10-one_channel_without_name.ibw"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        meta = read_height_map(path, dx_um=1.0, z_unit="nm").metadata
    keys = ("xy_unit", "xy_unit_from", "dx_from", "dy_from", "z_unit", "z_unit_from")
    assert _units(meta, keys) == {
        "xy_unit": "um",
        "xy_unit_from": "dx_um",
        "dx_from": "argument",
        "dy_from": "argument",
        "z_unit": "nm",
        "z_unit_from": "argument",
    }
    assert meta["reader"] == "SurfaceTopography"


def test_a_dektak_scan_keeps_the_files_own_micrometres():
    pytest.importorskip("SurfaceTopography")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        meta = read_profile(INSTRUMENTS / "dektak-1.csv").metadata
    keys = ("x_unit", "x_unit_from", "z_unit", "z_unit_from")
    assert _units(meta, keys) == {
        "x_unit": "µm",
        "x_unit_from": "file",
        "z_unit": "µm",
        "z_unit_from": "file",
    }


@pytest.mark.parametrize(
    ("text", "kw", "expect"),
    [
        (
            "x_um,z_nm\n0,1\n1,2\n2,3\n",
            {},
            ("um", "header", "nm", "header"),
        ),
        (
            "0 1\n1 2\n2 3\n",
            {"unit": "um"},
            ("um", "argument", "um", "argument"),
        ),
        (
            "0 1\n1 2\n2 3\n",
            {"x_unit": "mm", "z_unit": "nm"},
            ("mm", "argument", "nm", "argument"),
        ),
        (
            "z_nm\n1\n2\n3\n",
            {"dx_um": 0.5},
            ("um", "dx_um", "nm", "header"),
        ),
    ],
)
def test_a_text_scan_records_where_each_unit_came_from(tmp_path, text, kw, expect):
    path = tmp_path / "p.csv"
    path.write_text(text, encoding="utf-8")
    meta = read_profile(path, **kw).metadata
    got = tuple(meta[k] for k in ("x_unit", "x_unit_from", "z_unit", "z_unit_from"))
    assert got == expect
    assert {meta["x_unit_from"], meta["z_unit_from"]} <= DOCUMENTED
