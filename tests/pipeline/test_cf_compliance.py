"""results.nc and wall_law.nc pass the IOOS compliance checker (cf:1.10) with no
error and no warning, and hold no absolute path of the machine that wrote them
(issue 21)."""

from __future__ import annotations

import contextlib
import io
import json

import netCDF4
import pytest

from microimpact.cli import main

pytest.importorskip("compliance_checker")

SCENARIO = """name = "cf"
seed = 3
samples = 300
[particles]
distribution = "monodisperse"
diameter_um = 10
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.4
friction = 0.2
[[surfaces]]
name = "measured"
kind = "profile"
file = "scan.csv"
contact_length_um = 20
[[surfaces]]
name = "flat"
kind = "smooth"
[sweep]
speed_m_s = [1.0, 2.0]
angle_deg = [30, 90]
[wall_law]
diameter_um = [5, 20]
reservoir = 16

[resuspension]  # wall_law.nc carries the stay probability too
friction_velocity_m_s = [0.5, 1.0]
exposure_s = 2.0
surface_energy_j_m2 = 0.56
fluid = { name = "air", temperature_k = 293.15, pressure_pa = 101325 }
"""


def _cf_messages(path, tmp_path):
    """The checker's errors (high priority) and warnings (medium priority); fails
    when the checker did not pass or a check raised an exception (what makes the
    ``cchecker.py`` command exit 1 or 2: a check that raises is not in the error
    and warning lists at all, issue 33)."""
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    CheckSuite.load_all_available_checkers()
    out = tmp_path / f"{path.name}.json"
    printed = io.StringIO()  # where the checker names the checks that raised
    with contextlib.redirect_stderr(printed):
        passed, exceptions = ComplianceChecker.run_checker(
            str(path),
            ["cf:1.10"],
            0,
            "normal",
            output_filename=str(out),
            output_format="json",
        )
    printed = printed.getvalue()
    assert not exceptions, f"a checker check raised: {printed}"
    assert passed, f"the checker did not pass: {out.read_text()[:2000]}"
    report = json.loads(out.read_text())["cf:1.10"]

    def msgs(level):
        return [
            f"{r['name']}: {m}"
            for r in report[f"{level}_priorities"]
            for m in r["msgs"]
        ]

    return msgs("high"), msgs("medium")


def _all_text(path) -> str:
    """Every attribute and string value of a NetCDF file, and its raw bytes."""
    parts = []
    with netCDF4.Dataset(path) as ds:
        parts += [str(ds.getncattr(a)) for a in ds.ncattrs()]
        for v in ds.variables.values():
            parts += [str(v.getncattr(a)) for a in v.ncattrs()]
    return "\n".join(parts) + path.read_bytes().decode("latin-1")


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cf")
    (tmp / "scan.csv").write_text(
        "x_um,z_nm\n"
        + "".join(f"{i * 0.5},{(i * 37) % 101 - 50}\n" for i in range(800))
    )
    (tmp / "study.toml").write_text(SCENARIO)
    run, law = tmp / "run", tmp / "law"
    # absolute paths on the command line: none of them may reach the files
    assert main(["run", str(tmp / "study.toml"), "--out", str(run), "--quiet"]) == 0
    args = ["wall-law", str(tmp / "study.toml"), "--out", str(law), "--quiet"]
    assert main([*args, "--no-c", "--no-openfoam"]) == 0
    return tmp, run / "results.nc", law / "wall_law.nc"


@pytest.mark.parametrize("which", [1, 2], ids=["results.nc", "wall_law.nc"])
def test_cf_checker_reports_no_error_and_no_warning(outputs, tmp_path, which):
    path = outputs[which]
    if which == 2:
        with netCDF4.Dataset(path) as ds:
            assert "stay_probability" in ds.variables
    errors, warnings = _cf_messages(path, tmp_path)
    assert errors == []
    assert warnings == []


@pytest.mark.parametrize("which", [1, 2], ids=["results.nc", "wall_law.nc"])
def test_no_absolute_path_in_the_files_but_names_and_hashes(outputs, which):
    import hashlib

    tmp, path = outputs[0], outputs[which]
    text = _all_text(path)
    assert str(tmp) not in text
    digest = hashlib.sha256((tmp / "study.toml").read_bytes()).hexdigest()
    assert "study.toml" in text and digest in text


def test_every_variable_has_units_and_long_name(outputs):
    for path in outputs[1:]:
        with netCDF4.Dataset(path) as ds:
            bounds = {
                v.getncattr("bounds")
                for v in ds.variables.values()
                if "bounds" in v.ncattrs()
            }
            for name, var in ds.variables.items():
                attrs = var.ncattrs()
                if name in bounds:  # CF 7.1: a bounds variable takes its parent's
                    continue
                if var.dtype is str:
                    assert "long_name" in attrs, (path.name, name)
                    continue
                assert "units" in attrs and "long_name" in attrs, (path.name, name)
            assert ds.getncattr("history")
            assert "institution" not in ds.ncattrs() or ds.getncattr("institution")


def test_the_profile_units_and_their_origin_are_recorded(outputs):
    tmp, results = outputs[0], outputs[1]
    with netCDF4.Dataset(results) as ds:
        scenario = json.loads(ds.getncattr("scenario"))
    measured = scenario["surfaces"][0]["params"]
    assert measured["x_unit"] == "um (header)" and measured["z_unit"] == "nm (header)"
    assert measured["files"] == "scan.csv"
    digest = __import__("hashlib").sha256((tmp / "scan.csv").read_bytes()).hexdigest()
    assert measured["sha256"] == digest
    assert measured["masked_fraction"] == 0.0
    report = (results.parent / "report.html").read_text()
    assert "nm (header)" in report and str(tmp) not in report


def test_the_wall_law_reads_both_surface_forms_and_selects_by_name(outputs, tmp_path):
    """wall_law.nc keeps the names in `surface_name` (CF); a file of the old form
    (the names as the coordinate) is read the same, and a surface is chosen by
    name in either (issue 33)."""
    import numpy as np
    import xarray as xr

    from microimpact.engine.dataset import encoding
    from microimpact.wall_law.law import WallLaw

    new = outputs[2]
    with netCDF4.Dataset(new) as nc:
        assert nc["surface"].dtype.kind == "i"
        assert list(nc["surface_name"][:]) == ["measured", "flat"]
    with xr.open_dataset(new) as ds:  # the old form, written by hand
        ds = ds.load()
    old = ds.assign_coords(surface=ds["surface_name"].values).drop_vars("surface_name")
    old_path = tmp_path / "old.nc"
    old.to_netcdf(old_path, encoding=encoding(old))
    with netCDF4.Dataset(old_path) as nc:
        assert nc["surface"].dtype is str
    laws = [WallLaw.open(new), WallLaw.open(old_path)]
    u = np.random.default_rng(1).random((50, 5))
    draws = [law.sample_uniform(10.0, 1.5, 60.0, u, surface="flat") for law in laws]
    assert laws[0].surfaces == laws[1].surfaces == ("measured", "flat")
    np.testing.assert_array_equal(draws[0].captured, draws[1].captured)
    np.testing.assert_array_equal(draws[0].velocity, draws[1].velocity)
    other = laws[0].sample_uniform(10.0, 1.5, 60.0, u, surface="measured")
    assert not np.array_equal(other.velocity, draws[0].velocity, equal_nan=True)
