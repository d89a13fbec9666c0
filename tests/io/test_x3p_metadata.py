"""What the x3p readers say about what they read and refuse (ISO 5436-2, read by
x3pio): an x3p file states its coordinates in metres (ISO 5436-2, Record1 axes),
so every profile and map read from one says so, with the file as the unit's
source; a point cloud, an empty cloud, a map of invalid points and a crash inside
x3pio are each named by the file and the record at fault.

Files are written with x3pio itself (its writer is the format's second reading)."""

from __future__ import annotations

import numpy as np
import pytest

from microimpact.errors import ProfileFormatError
from microimpact.io.areal import read_height_map
from microimpact.io.profiles import read_profile, read_profiles

x3pio = pytest.importorskip("x3pio")

#: what every profile read from an x3p file states about its units
UNITS = {"x_unit": "m", "z_unit": "m", "x_unit_from": "file", "z_unit_from": "file"}


def _line(n=50):
    """n points along x (1 mm), heights of a sine [m]."""
    return np.column_stack(
        [np.linspace(0, 1e-3, n), np.zeros(n), 1e-6 * np.sin(np.arange(n))]
    )


def test_a_point_cloud_along_a_line_is_a_profile_in_metres(tmp_path):
    path = tmp_path / "line.x3p"
    x3pio.PointCloud.from_points(_line()).save(path)
    meta = read_profile(path).metadata
    assert {k: meta[k] for k in UNITS} == UNITS
    assert meta["source"] == str(path) and meta["format"] == "x3p"
    assert meta["feature_type"] == "PointCloud" and meta["scan"] is None


def test_the_rows_of_an_x3p_surface_are_profiles_in_metres(tmp_path):
    path = tmp_path / "s.x3p"
    z = np.random.default_rng(3).normal(0, 1e-6, (5, 7))
    x3pio.write(path, z, x_scale=0.5e-6, y_scale=0.25e-6)
    profiles = read_profiles(path)
    assert len({p.metadata["scan"] for p in profiles}) == len(profiles) == 5
    for p in profiles:
        assert {key: p.metadata[key] for key in UNITS} == UNITS
    meta = read_height_map(path).metadata
    assert (meta["xy_unit"], meta["z_unit"]) == ("m", "m")
    assert (meta["dx_from"], meta["dy_from"]) == ("file", "file")


def test_a_point_cloud_of_one_point_is_refused(tmp_path):
    path = tmp_path / "one.x3p"
    x3pio.PointCloud.from_points(_line()[:1]).save(path)
    with pytest.raises(ProfileFormatError) as info:
        read_profile(path)
    assert info.value.field == "Record3"
    assert (
        str(info.value) == f"{path}: Record3: the point cloud has fewer than 2 points"
    )


def test_a_map_of_invalid_points_names_the_record(tmp_path):
    path = tmp_path / "nan.x3p"
    x3pio.write(path, np.full((4, 5), np.nan), x_scale=0.5e-6, y_scale=0.25e-6)
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(path)
    assert info.value.field == "Record3"
    assert str(info.value) == f"{path}: Record3: every point is invalid"


def test_a_crash_inside_x3pio_is_one_line_naming_the_format(tmp_path, monkeypatch):
    path = tmp_path / "line.x3p"
    x3pio.PointCloud.from_points(_line()).save(path)

    def crash(*args, **kwargs):
        raise KeyError("no\nsuch record")

    monkeypatch.setattr(x3pio, "read", crash)
    with pytest.raises(ProfileFormatError) as info:
        read_profile(path)
    assert info.value.field == "format"
    assert str(info.value) == (
        f"{path}: format: the x3pio reader failed on this x3p file (KeyError: "
        "'no\\nsuch record'); microimpact cannot read it"
    )


@pytest.mark.parametrize("shape", [(1, 7), (7, 1)])
def test_a_surface_of_one_row_or_column_is_not_a_map(tmp_path, shape):
    path = tmp_path / "thin.x3p"
    x3pio.write(path, np.full(shape, 1e-6), x_scale=0.5e-6, y_scale=0.5e-6)
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(path)
    assert str(info.value) == (
        f"{path}: Record3: the surface is {shape}; allowed: at least 2 x 2 points"
    )


def test_a_profile_of_one_valid_point_names_the_record(tmp_path):
    path = tmp_path / "p1.x3p"
    x3pio.write(path, np.array([1e-6, np.nan, np.nan, np.nan]), x_scale=0.5e-6)
    with pytest.raises(ProfileFormatError) as info:
        read_profile(path)
    assert str(info.value) == f"{path}: Record3: fewer than 2 valid points"
