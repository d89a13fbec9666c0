"""The results contract and the pipeline: Dataset-first results, open_result,
Study (run -> files -> figures -> report), the output folder's lock and manifest."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from engine_helpers import scenario
from numpy.testing import assert_allclose, assert_array_equal

import microimpact as mi
from microimpact.engine.dataset import SUMMARY_COLUMNS, VARIABLES
from microimpact.engine.result import open_result
from microimpact.engine.statistics import point_row
from microimpact.pipeline.folder import (
    LOCK_NAME,
    MANIFEST_NAME,
    OutputFolder,
    OutputFolderBusy,
)
from microimpact.pipeline.study import Outputs, Study
from microimpact.scenario.grid import SweepGrid


@pytest.fixture(scope="module")
def rough_result():
    sc = scenario(
        speeds_m_s=(0.3, 1.0, 2.0),
        angles_deg=(20.0, 45.0, 85.0),
        reference_angle_deg=85.0,
    )
    return mi.run(sc, samples=3000, seed=5)


# ------------------------------------------------------------------ the grid
def test_grid_numbering_is_c_order_of_its_dims():
    g = SweepGrid(("a", "b"), (0.1, 0.2, 0.3), (10.0, 90.0))
    assert g.shape == (2, 3, 2) and g.size == 12
    # an independent oracle: nested loops in the order of the dims
    expected = [
        (s, v, a) for s in g.surfaces for v in g.speeds_m_s for a in g.angles_deg
    ]
    got = [(p.surface_name, p.speed, p.angle_deg) for p in g.points()]
    assert got == expected
    values = np.arange(12) * 10
    assert g.reshape(values)[1, 2, 0] == values[expected.index(("b", 0.3, 10.0))]
    assert g.coords(5) == {"surface": "a", "speed_m_s": 0.3, "angle_deg": 90.0}


# ------------------------------------------------------------------ the Dataset
def test_dataset_is_cf_and_summary_derives_from_it(rough_result):
    ds = rough_result.dataset
    assert ds.attrs["Conventions"] == "CF-1.10"
    for name, var in ds.data_vars.items():
        assert "long_name" in var.attrs, name
        if name not in ("surface_is_smooth", "surface_is_areal"):
            assert "units" in var.attrs, name
    for name in ("n", "n_impacts", "n_rebounds", "e_hist", "mu_hist", "n_captured"):
        assert np.issubdtype(ds[name].dtype, np.integer), name
    assert ds["capture_fraction"].dims == ("surface", "speed_m_s", "angle_deg")
    s = rough_result.summary
    assert list(s.columns[: len(SUMMARY_COLUMNS)]) == list(SUMMARY_COLUMNS)
    # each summary row is the Dataset value at that point's coordinates
    for i, row in s.iterrows():
        c = rough_result.grid.coords(i)
        sel = ds.sel(
            surface=c["surface"], speed_m_s=c["speed_m_s"], angle_deg=c["angle_deg"]
        )
        assert_allclose(row["e_rebound_mean"], float(sel["e_rebound_mean"]), rtol=0)
        assert row["speed_m_s"] == c["speed_m_s"] and row["angle_deg"] == c["angle_deg"]


def test_statistics_equal_the_per_point_oracle(rough_result):
    """The vectorised statistics equal the scalar per-point implementation (an
    independent code path) bit for bit."""
    s = rough_result.summary
    conf = rough_result.confidence
    for i, acc in rough_result.accumulators.items():
        for key, value in point_row(acc, conf).items():
            if key == "shadowed_fraction":
                continue  # replaced by the exact table mass ('reject' shadowing)
            assert np.array_equal(
                np.float64(value), np.float64(s.loc[i, key]), equal_nan=True
            ), key


def test_relative_coefficients_at_the_reference_are_exactly_zero(rough_result):
    s = rough_result.summary
    at_ref = s[np.isclose(s["angle_deg"], 85.0)]
    assert (at_ref["e_relative"] == 0).all() and (at_ref["e_relative_se"] == 0).all()
    assert (at_ref["mu_relative_se"] == 0).all()
    other = s[~np.isclose(s["angle_deg"], 85.0)].iloc[0]
    ref = s[
        np.isclose(s["angle_deg"], 85.0)
        & (s["surface"] == other["surface"])
        & np.isclose(s["speed_m_s"], other["speed_m_s"])
    ].iloc[0]
    assert_allclose(
        other["e_relative"], other["e_rebound_mean"] - ref["e_rebound_mean"]
    )
    assert_allclose(
        other["e_relative_se"], np.hypot(other["e_rebound_se"], ref["e_rebound_se"])
    )


def test_repr_is_short(rough_result):
    text = repr(rough_result)
    assert len(text) < 200 and "SimulationResult" in text


# ------------------------------------------------------------------ open_result
def test_open_result_round_trip(rough_result, tmp_path):
    rough_result.to_files(tmp_path)
    back = open_result(tmp_path)
    assert back.accumulators is None
    assert back.seed_entropy == rough_result.seed_entropy
    assert back.scenario.name == rough_result.scenario.name
    assert back.confidence == rough_result.confidence
    assert [s.smooth for s in back.scenario.surfaces] == [
        s.smooth for s in rough_result.scenario.surfaces
    ]
    a, b = rough_result.summary, back.summary
    assert list(a.columns) == list(b.columns)
    for col in a.columns:
        if col == "surface":
            assert list(a[col]) == list(b[col])
        else:
            assert_array_equal(a[col].to_numpy(), b[col].to_numpy())
    ca, cb = rough_result.capture_speed(), back.capture_speed()
    assert_allclose(
        ca["speed_m_s"].to_numpy(dtype=float), cb["speed_m_s"].to_numpy(dtype=float)
    )
    counts_a, _ = rough_result.histogram(4, "mu")
    counts_b, _ = back.histogram(4, "mu")
    assert_array_equal(counts_a, counts_b)
    assert back.provenance["scenario"]["name"] == rough_result.scenario.name


def test_open_result_rejects_what_is_not_a_result(tmp_path):
    with pytest.raises(mi.InputError, match="no results file"):
        open_result(tmp_path)
    (tmp_path / "x.nc").write_text("not netcdf")
    with pytest.raises(mi.InputError, match=r"x\.nc"):
        open_result(tmp_path / "x.nc")
    xr.Dataset({"a": ("x", [1.0])}).to_netcdf(tmp_path / "y.nc")
    with pytest.raises(mi.InputError, match="not a microimpact results file"):
        open_result(tmp_path / "y.nc")


def test_histograms_of_the_dataset_are_the_accumulators(rough_result):
    for point, acc in rough_result.accumulators.items():
        counts, edges = rough_result.histogram(point, "e")
        assert_array_equal(counts, acc.e_hist[1:-1])
        assert edges.size == counts.size + 1


# ------------------------------------------------------------------ run(...) input
def test_run_accepts_a_path_and_a_preset_name(tmp_path):
    path = tmp_path / "study.toml"
    path.write_text(
        textwrap.dedent(
            """
            name = "mine"
            [particles]
            distribution = "lognormal"
            median_um = 10
            geometric_std = 1.5
            [coefficients]
            k1 = 4.0
            k2 = 0.05
            v_c = {law = "power", a_m_s = 0.5, b = -1.0, d_ref_um = 10}
            [sweep]
            speed_m_s = [0.3, 1.0]
            """
        )
    )
    from_path = mi.run(path, samples=500, seed=2)
    from_str = mi.run(str(path), samples=500, seed=2)
    assert from_path.scenario.name == "mine"
    assert_array_equal(
        from_path.summary["capture_fraction"], from_str.summary["capture_fraction"]
    )
    preset = mi.run("sst65-silicon-normal", samples=100, seed=1)
    assert preset.scenario.name == "sst65-silicon-normal"
    with pytest.raises(mi.ScenarioError, match="did you mean 'sst65-silicon-normal'"):
        mi.run("sst65-silicon", samples=10)


# ------------------------------------------------------------------ validation
def test_python_edits_are_validated_and_never_blame_a_file():
    sc = mi.Scenario.from_preset("sst65-silicon-normal")
    assert sc.source is not None
    with pytest.raises(mi.ScenarioError) as err:
        sc.with_options(confidence=1)
    assert sc.source not in str(err.value) and "confidence" in str(err.value)
    with pytest.raises(mi.ScenarioError, match="reference_angle_deg"):
        sc.with_options(reference_angle_deg="x")
    with pytest.raises(mi.ScenarioError, match="reference_angle_deg"):
        sc.with_options(reference_angle_deg=120.0)
    with pytest.raises(mi.ScenarioError, match="capture_quantiles"):
        sc.with_options(capture_quantiles=(0.5, 1.0))
    with pytest.raises(mi.ScenarioError, match="samples"):
        sc.with_options(samples=2.5)


def test_misspelt_key_is_unknown_before_missing(tmp_path):
    data = {
        "particles": {"distrbution": "normal", "mean_um": 50, "std_um": 10},
        "coefficients": {"k1": 4.0, "k2": 0.05, "v_c": 0.2},
        "sweep": {"speed_m_s": [1.0]},
    }
    with pytest.raises(mi.ScenarioError) as err:
        mi.scenario_from_dict(data, source="s.toml")
    msg = str(err.value)
    assert "unknown key 'distrbution'" in msg and "did you mean 'distribution'" in msg
    assert "missing" not in msg


# ------------------------------------------------------------------ Study
def _small_study(**outputs):
    sc = scenario(speeds_m_s=(0.2, 0.5), angles_deg=(30.0, 85.0))
    return Study(sc, outputs=Outputs(**outputs))


def test_study_writes_every_output_and_chains(tmp_path):
    study = _small_study(figures=("png",)).run(samples=800, seed=3).write(tmp_path)
    names = {p.name for p in study.files}
    assert {"summary.csv", "results.nc", "capture_speed.csv", "report.html"} <= names
    assert any(n.endswith(".png") for n in names)
    manifest = json.loads((tmp_path / MANIFEST_NAME).read_text())
    assert set(manifest["parts"]["tables"]) == {
        "summary.csv",
        "results.nc",
        "capture_speed.csv",
    }
    listed = [name for files in manifest["parts"].values() for name in files]
    assert sorted(listed) == sorted(names)
    report = study.report(tmp_path / "again.html")
    assert report.read_text().startswith("<!DOCTYPE html>")


def test_report_only_rebuild_from_results_nc(tmp_path):
    study = _small_study(figures=("png",)).run(samples=800, seed=3).write(tmp_path)
    first = {p.name for p in study.files if p.suffix == ".png"}
    for p in tmp_path.glob("*.png"):
        p.unlink()
    (tmp_path / "report.html").unlink()
    again = Study.from_result(open_result(tmp_path), outputs=Outputs(figures=("png",)))
    again.write(tmp_path, parts=("figures", "report"))
    assert {p.name for p in tmp_path.glob("*.png")} == first
    assert (tmp_path / "report.html").exists()
    assert (tmp_path / "summary.csv").exists()  # the tables were not touched


def test_manifest_removes_stale_outputs_but_never_user_files(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    (tmp_path / "my_plot.png").write_bytes(b"mine")
    _small_study(figures=("png", "svg")).run(samples=500, seed=1).write(tmp_path)
    assert list(tmp_path.glob("*.svg"))
    _small_study(figures=("png",)).run(samples=500, seed=1).write(tmp_path)
    assert not list(tmp_path.glob("*.svg"))  # the earlier study's SVGs are gone
    assert (tmp_path / "notes.txt").read_text() == "mine"
    assert (tmp_path / "my_plot.png").read_bytes() == b"mine"


def test_stale_temporary_files_are_removed(tmp_path):
    stale = tmp_path / ".summary.csv.abcd1234.tmp"
    stale.write_text("half")
    mine = tmp_path / ".notes.txt.abcd1234.tmp"
    mine.write_text("mine")
    with OutputFolder(tmp_path):
        pass
    assert not stale.exists()
    assert mine.exists()


def test_a_second_run_into_a_locked_folder_is_refused(tmp_path):
    code = textwrap.dedent(
        f"""
        import sys, time
        from microimpact.pipeline.folder import OutputFolder
        with OutputFolder({str(tmp_path)!r}):
            print("locked", flush=True)
            time.sleep(30)
        """
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "locked"
        with pytest.raises(OutputFolderBusy, match=f"process {proc.pid}"):
            with OutputFolder(tmp_path):
                pass
    finally:
        proc.kill()
        proc.wait()
    with OutputFolder(tmp_path):  # the lock died with its process
        assert (tmp_path / LOCK_NAME).exists()


def test_execute_removes_its_checkpoint(tmp_path):
    study = _small_study(figures=()).execute(tmp_path, samples=300, seed=1)
    assert study.result is not None
    assert not (tmp_path / ".microimpact-checkpoint.npz").exists()
    assert (tmp_path / "summary.csv").exists()


def test_outputs_validate():
    with pytest.raises(ValueError, match="figures"):
        Outputs(figures=("gif",))
    with pytest.raises(TypeError, match="report"):
        Outputs(report="yes")
    assert Outputs(figures="png").figures == ("png",)


def test_every_summary_variable_is_documented():
    text = (Path(__file__).resolve().parents[2] / "docs" / "outputs.md").read_text()
    for name in VARIABLES:
        if name.startswith(("e_relative", "mu_relative")):
            name = name.split("_se")[0]
        assert f"`{name}" in text, name


def test_public_api_is_curated():
    import inspect
    import typing

    names = set(mi.__all__) - {"__version__"}
    for name in names:
        obj = getattr(mi, name)
        assert not isinstance(obj, dict | list | set), f"{name}: a mutable registry"
    # every type a public function or method returns is public too
    for name in sorted(names):
        obj = getattr(mi, name)
        funcs = [obj] if inspect.isfunction(obj) else []
        if inspect.isclass(obj):
            funcs += [
                f
                for k, f in vars(obj).items()
                if not k.startswith("_") and inspect.isfunction(f)
            ]
        for f in funcs:
            try:
                hints = typing.get_type_hints(f)
            except Exception:  # annotations naming optional packages
                continue
            ret = hints.get("return")
            for t in typing.get_args(ret) or (ret,):
                if inspect.isclass(t) and t.__module__.startswith("microimpact"):
                    assert t.__name__ in names, f"{name} returns {t.__name__}"


def test_relative_function_agrees_with_the_dataset(rough_result):
    """`result.relative(ref)` (a DataFrame computation) and the Dataset's relative
    coefficients (a grid computation) agree, including 0 +- 0 at the reference."""
    table = rough_result.relative(85.0)
    s = rough_result.summary
    for col in ("e_relative", "e_relative_se", "mu_relative", "mu_relative_se"):
        assert_allclose(table[col].to_numpy(), s[col].to_numpy(), rtol=1e-12)


def test_big_sweeps_keep_ragged_histograms(rough_result, tmp_path, monkeypatch):
    """Beyond DENSE_HISTOGRAM_CELLS the Dataset keeps only the occupied bins (a CF
    contiguous ragged array); every histogram, quantile and figure input is the
    same as with dense histograms, also after a round trip through results.nc."""
    import microimpact.engine.dataset as dataset
    from microimpact.engine.result import SimulationResult

    dense = rough_result.dataset  # built (lazily) before the threshold is lowered
    monkeypatch.setattr(dataset, "DENSE_HISTOGRAM_CELLS", 10)
    sc, plan = rough_result.scenario, None
    from microimpact.engine.plan import build_plan

    plan = build_plan(sc, seed=rough_result.seed_entropy)
    totals = {(p, 0): a for p, a in rough_result.accumulators.items()}
    ragged = SimulationResult.from_accumulators(sc, plan, totals, elapsed=0.0)
    ds = ragged.dataset
    assert ds.attrs["histograms"] == "ragged" and "e_hist" not in ds
    assert ds["e_hist_length"].attrs["sample_dimension"] == "e_hist_obs"
    stored = ds["e_hist_counts"].size + ds["mu_hist_counts"].size
    dense_cells = dense["e_hist"].size + dense["mu_hist"].size
    assert stored < dense_cells / 5  # proportional to the occupied bins
    ragged.to_files(tmp_path)
    back = open_result(tmp_path)
    for point in range(len(rough_result.summary)):
        for name in ("e", "mu"):
            want = rough_result.histogram(point, name)[0]
            assert_array_equal(ragged.histogram(point, name)[0], want)
            assert_array_equal(back.histogram(point, name)[0], want)
    for col in ("e_p05", "e_p50", "mu_p95", "e_hist_underflow", "mu_hist_overflow"):
        if col in rough_result.summary:
            assert_array_equal(ragged.summary[col], rough_result.summary[col])
    assert_array_equal(
        ds["mu_hist_overflow"].values, rough_result.dataset["mu_hist_overflow"].values
    )
