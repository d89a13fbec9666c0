"""Surfaces in the files, CF's way (issue 33, item 6): the ``surface`` coordinate
variable is the numeric index 0 .. n-1 and the names are the auxiliary coordinate
``surface_name`` (CF 1.10 §1.3 and §5). ``open_result`` and ``WallLaw.open`` read
this form and the older one (string ``surface``), and select a surface by name;
plain xarray does the same with the one line of docs/outputs.md. Checked against
netCDF4 (a second reader of the file)."""

from __future__ import annotations

import netCDF4
import numpy as np
import pytest
import xarray as xr

from microimpact import open_result, run
from microimpact.engine.dataset import encoding
from microimpact.scenario.scenario import read_scenario

SCENARIO = """
name = "cf-surfaces"
seed = 5
samples = 200
[particles]
distribution = "monodisperse"
diameter_um = 20
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.4
friction = 0.2
[[surfaces]]
name = "smooth"
kind = "smooth"
[[surfaces]]
name = "bumpy"
kind = "normal"
std_deg = 10.0
[sweep]
speed_m_s = [0.5, 2.0]
angle_deg = [30, 90]
"""


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    path = tmp_path_factory.mktemp("cf") / "s.toml"
    path.write_text(SCENARIO)
    return run(read_scenario(path).scenario, progress=False)


def _old_form(res, path):
    """The file as written before issue 33: the names as the coordinate."""
    ds = res.dataset
    ds.to_netcdf(path, engine="netcdf4", encoding=encoding(ds))
    return path


def test_results_nc_has_a_numeric_surface_and_the_names_beside(result, tmp_path):
    path = result.to_netcdf(tmp_path / "results.nc")
    with netCDF4.Dataset(path) as nc:
        surface, names = nc["surface"], nc["surface_name"]
        assert surface.dimensions == ("surface",) == names.dimensions
        assert surface.dtype.kind == "i"
        np.testing.assert_array_equal(surface[:], [0, 1])
        assert list(names[:]) == ["smooth", "bumpy"]
        assert "surface_name" in nc["capture_fraction"].getncattr("coordinates")
        assert names.getncattr("long_name") == "surface variant name"


@pytest.mark.parametrize("form", ["new", "old"])
def test_open_result_reads_both_forms_and_selects_by_name(result, tmp_path, form):
    path = tmp_path / "results.nc"
    if form == "new":
        result.to_netcdf(path)
    else:
        _old_form(result, path)
    back = open_result(path)
    assert list(back.dataset["surface"].values) == ["smooth", "bumpy"]
    assert "surface_name" not in back.dataset.variables
    fresh = result.dataset["capture_fraction"].sel(surface="bumpy")
    again = back.dataset["capture_fraction"].sel(surface="bumpy")
    np.testing.assert_array_equal(again.values, fresh.values)
    assert back.summary.equals(result.summary)


def test_the_plain_xarray_line_of_the_docs_selects_by_name(result, tmp_path):
    path = result.to_netcdf(tmp_path / "results.nc")
    # docs/outputs.md, "Surfaces": the one line
    ds = xr.open_dataset(path).swap_dims(surface="surface_name")
    bumpy = ds["capture_fraction"].sel(surface_name="bumpy")
    np.testing.assert_array_equal(
        bumpy.values, result.dataset["capture_fraction"].sel(surface="bumpy").values
    )
    ds.close()


def test_from_dataset_takes_a_plainly_opened_file(result, tmp_path):
    from microimpact.engine.result import SimulationResult

    path = result.to_netcdf(tmp_path / "results.nc")
    with xr.open_dataset(path) as ds:
        back = SimulationResult.from_dataset(ds.load())
    assert list(back.summary["surface"].unique()) == ["smooth", "bumpy"]


def test_a_rewritten_result_is_the_same_file(result, tmp_path):
    """write -> open -> write gives the same variables and values (round trip)."""
    a = result.to_netcdf(tmp_path / "a.nc")
    b = open_result(a).to_netcdf(tmp_path / "b.nc")
    with xr.open_dataset(a) as da, xr.open_dataset(b) as db:
        xr.testing.assert_identical(da.drop_attrs(), db.drop_attrs())
