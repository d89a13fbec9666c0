"""x and z units that differ, on uniform and non-uniform scans (issue 34, item 3).

Every test file elsewhere gives x and z the same unit, where a reader that scales
positions by the z unit (or heights by the x unit) gives the right numbers. Here
x is in mm and z in nm (a factor 10⁶ apart), on a uniform and a non-uniform scan,
through microimpact's own text reader and through SurfaceTopography (an instrument
file without units, ``nonuniform.asc`` from SurfaceTopography's test data, MIT
licence, tests/data/instruments/LICENSE-SurfaceTopography.md). The expected
values come from a second reading of the same file with ``numpy.loadtxt`` and the
SI definitions of the units.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from microimpact.io.instruments import read_instrument
from microimpact.io.profiles import read_profiles

DATA = Path(__file__).resolve().parents[1] / "data" / "instruments"
MM, NM, UM = 1e-3, 1e-9, 1e-6


def _write(path, x, z, header):
    np.savetxt(path, np.column_stack([x, z]), delimiter=",", header=header, comments="")
    return path


@pytest.mark.parametrize("spacing", ["uniform", "non-uniform"])
@pytest.mark.parametrize("how", ["arguments", "header"])
def test_text_scan_with_x_in_mm_and_z_in_nm(tmp_path, spacing, how):
    rng = np.random.default_rng(34)
    n = 200
    if spacing == "uniform":
        x_mm = np.arange(n) * 0.5
    else:
        x_mm = np.cumsum(rng.uniform(0.1, 0.9, n))
    z_nm = rng.normal(0.0, 50.0, n)
    header, kw = ("x,z", {"x_unit": "mm", "z_unit": "nm"})
    if how == "header":
        header, kw = "x_mm,z_nm", {}
    path = _write(tmp_path / "scan.csv", x_mm, z_nm, header)
    (p,) = read_profiles(path, **kw)
    raw = np.loadtxt(path, delimiter=",", skiprows=1)  # the second reading
    np.testing.assert_allclose(p.x, raw[:, 0] * MM, rtol=1e-15)
    np.testing.assert_allclose(p.z, raw[:, 1] * NM, rtol=1e-15)
    assert p.metadata["spacing"] == spacing
    assert (p.metadata["x_unit"], p.metadata["z_unit"]) == ("mm", "nm")


def test_heights_alone_with_dx_um_and_z_in_nm(tmp_path):
    """A uniform scan of heights alone: x from `dx_um` (µm), z in nm."""
    z_nm = np.sin(np.arange(64) * 0.3) * 100.0
    path = tmp_path / "heights.txt"
    np.savetxt(path, z_nm)
    (p,) = read_profiles(path, dx_um=0.25, z_unit="nm")
    np.testing.assert_allclose(p.x, np.arange(64) * 0.25 * UM, rtol=1e-15)
    np.testing.assert_allclose(p.z, np.loadtxt(path) * NM, rtol=1e-15)
    assert p.metadata["spacing"] == "uniform"


@pytest.mark.parametrize(("x_unit", "z_unit"), [("mm", "nm"), ("nm", "mm")])
def test_instrument_non_uniform_scan_without_units(x_unit, z_unit):
    """A non-uniform line scan without a unit, read by SurfaceTopography (the
    path of an instrument export that microimpact's text reader does not take):
    positions by the x unit, heights by the z unit, whichever way round."""
    path = DATA / "nonuniform.asc"
    (scan,) = read_instrument(
        path, want="profiles", x_unit=(x_unit, "x_unit"), z_unit=(z_unit, "z_unit")
    )
    raw = np.loadtxt(path)
    order = np.argsort(raw[:, 0], kind="stable")
    factor = {"mm": MM, "nm": NM}
    assert scan.metadata["reader"] == "SurfaceTopography"
    assert scan.metadata["spacing"] == "non-uniform"
    # SurfaceTopography starts the positions at 0: the spacing is what counts
    x = raw[order, 0] - raw[order[0], 0]
    np.testing.assert_allclose(scan.x - scan.x[0], x * factor[x_unit], rtol=1e-12)
    np.testing.assert_allclose(scan.z, raw[order, 1] * factor[z_unit], rtol=1e-12)
    assert (scan.metadata["x_unit"], scan.metadata["z_unit"]) == (x_unit, z_unit)


@pytest.mark.parametrize(("x_unit", "z_unit"), [("um", "nm")])
def test_the_same_file_through_read_profiles(x_unit, z_unit):
    """The same file through the public reader (microimpact's text reader takes
    it): the same numbers. (x in mm or z in mm makes this file implausible, a
    12.7 mm spacing or 61 mm of height over 1.7 mm, which the reader refuses:
    tests/io/test_plausibility.py.)"""
    path = DATA / "nonuniform.asc"
    (p,) = read_profiles(path, x_unit=x_unit, z_unit=z_unit)
    (scan,) = read_instrument(
        path, want="profiles", x_unit=(x_unit, "x_unit"), z_unit=(z_unit, "z_unit")
    )
    np.testing.assert_allclose(p.x - p.x[0], scan.x - scan.x[0], rtol=1e-12)
    np.testing.assert_allclose(p.z, scan.z, rtol=1e-12)
    assert p.metadata["spacing"] == "non-uniform"
