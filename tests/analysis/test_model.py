"""The ScenarioModel (analysis/model.py): one model for sensitivity and calibration;
the file read once, each table built once per content; its runs are plain runs."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import microimpact
from microimpact._core.toml import to_toml
from microimpact.analysis.model import ScenarioModel
from microimpact.errors import ScenarioError
from microimpact.scenario.parameters import with_values
from microimpact.scenario.scenario import scenario_from_dict

BASE = {
    "seed": 3,
    "samples": 600,
    "particles": {"distribution": "normal", "mean_um": 40, "std_um": 5},
    "coefficients": {
        "k1": 4.0,
        "k2": {"law": "power", "a_m_s": 0.05, "b": -1.5, "d_ref_um": 40},
        "v_c": {"law": "power", "a_m_s": 0.3, "b": -1.5, "d_ref_um": 40},
        "friction": 0.15,
    },
    "surfaces": [
        {"name": "a", "kind": "normal", "std_deg": 8},
        {"name": "b", "kind": "normal", "std_deg": 12},
    ],
    "sweep": {"speed_m_s": [0.5, 1.0], "angle_deg": [30, 60]},
}


def test_unchanged_tables_are_the_same_objects():
    """A parameter rebuilds only its own table: the other tables are the objects
    built when the file was read (identity, not equality)."""
    m = ScenarioModel(
        copy.deepcopy(BASE), ["coefficients.friction", "surfaces.b.std_deg"]
    )
    base = m.base
    s = m.scenario([0.3, 12.0])
    assert s.particles is base.particles
    assert s.surfaces[0].angles is base.surfaces[0].angles
    assert s.surfaces[1].angles is base.surfaces[1].angles  # 12 is the file's value
    assert s.coefficients is not base.coefficients
    assert s.coefficients.friction == 0.3
    t = m.scenario([0.15, 5.0])
    assert t.surfaces[0].angles is base.surfaces[0].angles
    assert t.surfaces[1].angles is not base.surfaces[1].angles
    assert t.surfaces[1].angles.describe()["std_deg"] == pytest.approx(5.0)
    assert t.coefficients is base.coefficients  # back at the file's values


def test_a_row_gives_the_scenario_built_from_the_file_with_those_values():
    """Oracle: the scenario parsed afresh from the substituted data (no cache)
    describes itself identically, and runs to the same bits."""
    keys = ["coefficients.friction", "surfaces.a.std_deg", "particles.mean_um"]
    m = ScenarioModel(copy.deepcopy(BASE), keys)
    values = {
        "coefficients.friction": 0.4,
        "surfaces.a.std_deg": 3.0,
        "particles.mean_um": 30.0,
    }
    fresh = scenario_from_dict(with_values(BASE, values))
    assert m.scenario(values).describe() == fresh.describe()
    a = m.run(values).summary
    b = microimpact.run(fresh, samples=600, seed=3, workers=1, progress=False).summary
    assert a.equals(b)


def test_the_file_is_read_once_and_keys_are_checked(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(to_toml(BASE))
    opened = []

    def hook(event, args):
        if event == "open" and str(args[0]) == str(path):
            opened.append(args[0])

    import sys

    sys.addaudithook(hook)
    m = ScenarioModel(path, ["coefficients.friction"], samples=200)
    for v in (0.1, 0.2, 0.3):
        m.summary([v])
    assert len(opened) == 1
    with pytest.raises(ScenarioError, match="seed: cannot be a parameter"):
        ScenarioModel(path, ["seed"])
    with pytest.raises(ScenarioError, match="did you mean"):
        ScenarioModel(path, ["coefficients.frict"])


def test_common_random_numbers_across_rows():
    """The same seed at every row: a parameter without effect on a point leaves its
    statistics bit for bit (surface b's roughness never changes surface a's)."""
    m = ScenarioModel(copy.deepcopy(BASE), ["surfaces.b.std_deg"], samples=400)
    s1 = m.summary([4.0])
    s2 = m.summary([20.0])
    a1 = s1[s1["surface"] == "a"].reset_index(drop=True)
    a2 = s2[s2["surface"] == "a"].reset_index(drop=True)
    assert a1.equals(a2)
    b1 = s1[s1["surface"] == "b"]["e_mean"].to_numpy()
    b2 = s2[s2["surface"] == "b"]["e_mean"].to_numpy()
    assert not np.array_equal(b1, b2)


def _mu_measured():
    """Two measured mu means of surface a (the calibrations below)."""
    import pandas as pd

    return pd.DataFrame(
        {
            "surface": ["a", "a"],
            "statistic": ["mu", "mu"],
            "speed_m_s": [1.0, 1.0],
            "angle_deg": [30.0, 60.0],
            "mean": [0.2, 0.1],
            "ci_low": [0.15, 0.05],
            "ci_high": [0.25, 0.15],
        }
    )


def test_sensitivity_and_calibration_are_the_same_on_any_workers():
    """map_tasks spreads the rows (threads for the compiled kernel, else
    processes): the indices and the calibration are bit for bit those of one
    worker."""
    data = copy.deepcopy(BASE)
    params = {"coefficients.friction": {"low": 0.1, "high": 0.3}}
    kw = dict(base_size=4, samples=200, seed=7, n_resamples=20, progress=False)
    one = microimpact.sobol_sensitivity(data, params, workers=1, **kw).table
    two = microimpact.sobol_sensitivity(data, params, workers=2, **kw).table
    assert one.equals(two)
    exp = _mu_measured()
    ckw = dict(samples=200, bootstrap=2, band_draws=0, progress=False)
    a = microimpact.calibrate(data, exp, ["coefficients.friction"], workers=1, **ckw)
    b = microimpact.calibrate(data, exp, ["coefficients.friction"], workers=2, **ckw)
    assert np.array_equal(a.estimate, b.estimate)
    assert np.array_equal(a.bootstrap, b.bootstrap)


def test_design_rows_and_bootstrap_refits_run_in_forked_processes(monkeypatch):
    """On 2 workers the design rows and the bootstrap refits go to worker
    processes forked from this one (parallel.fork_pool: they hold the GIL for
    much of their time), with the one-worker bits."""
    import pandas as pd

    from microimpact.analysis import calibration, sensitivity
    from microimpact.engine import parallel

    # a thread another test left running (a Dask client's IO loop) would make
    # the pools refuse to fork; this test is about what happens when they can
    monkeypatch.setattr(parallel, "start_method", lambda: "fork")
    monkeypatch.setattr(sensitivity, "cap_workers", lambda w: w)
    monkeypatch.setattr(parallel, "cap_workers", lambda w: w)
    used = []

    def spy(module):
        real = module.map_held

        def held(pool, items, **kw):
            for value in real(pool, items, **kw):
                used.append(module.__name__)
                yield value

        monkeypatch.setattr(module, "map_held", held)

    spy(sensitivity)
    spy(calibration)
    data = copy.deepcopy(BASE)
    params = {"coefficients.friction": {"low": 0.1, "high": 0.3}}
    kw = dict(base_size=4, samples=200, seed=7, n_resamples=20, progress=False)
    one = microimpact.sobol_sensitivity(data, params, workers=1, **kw).table
    assert not used
    two = microimpact.sobol_sensitivity(data, params, workers=2, **kw).table
    assert used and set(used) == {sensitivity.__name__}
    pd.testing.assert_frame_equal(one, two, check_exact=True)
    exp = _mu_measured()
    ckw = dict(samples=200, bootstrap=3, band_draws=0, progress=False)
    a = microimpact.calibrate(data, exp, ["coefficients.friction"], workers=1, **ckw)
    used.clear()
    b = microimpact.calibrate(data, exp, ["coefficients.friction"], workers=2, **ckw)
    assert used == [calibration.__name__] * 3  # one value per refit
    np.testing.assert_array_equal(a.estimate, b.estimate)
    np.testing.assert_array_equal(a.bootstrap, b.bootstrap)
    assert a.to_dict()["parameters"] == b.to_dict()["parameters"]


def test_where_the_process_cannot_fork_the_rows_go_to_threads(monkeypatch):
    """Another thread running (a notebook's kernel, a Dask client): no fork, the
    rows go to threads as before, with the one-worker bits."""
    import threading

    from microimpact.analysis import sensitivity

    monkeypatch.setattr(sensitivity, "cap_workers", lambda w: w)
    monkeypatch.setattr(
        sensitivity, "map_held", lambda *a, **k: pytest.fail("forked with a thread")
    )
    data = copy.deepcopy(BASE)
    params = {"coefficients.friction": {"low": 0.1, "high": 0.3}}
    kw = dict(base_size=4, samples=200, seed=7, n_resamples=20, progress=False)
    one = microimpact.sobol_sensitivity(data, params, workers=1, **kw).table
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        two = microimpact.sobol_sensitivity(data, params, workers=2, **kw).table
    finally:
        stop.set()
        other.join()
    assert one.equals(two)


def test_a_refit_in_a_worker_runs_its_model_runs_in_that_process(monkeypatch):
    """A forked worker's refit runs its model one run after the other
    (calibration._serial), not on a copy of the parent's pool: a pool in each
    worker would oversubscribe the cores (no result would show it)."""
    from microimpact.analysis import calibration

    seen = []

    class Model:
        def __init__(self):
            self.map = object()  # the parent's mapper, as the fork left it
            self.runs = 0
            self.cache = {}

        def summaries(self, xs):
            seen.append(self.map)
            return ["summary"]

    refit = calibration._Refit(Model(), None, None, None, np.zeros(1), None, None, None)
    monkeypatch.setattr(refit, "fit", lambda model, yb: (seen.append(model.map), 1)[1])
    assert refit([0.0])[1] == "summary"
    assert seen == [calibration._serial, calibration._serial]
