"""Issue 20: a scenario file is read once per command or Study, and every long
public call takes ``progress`` as True, False, None or a callable (done, total)."""

from __future__ import annotations

import sys

import pandas as pd
import pytest

import microimpact as mi
from microimpact._core.toml import to_toml
from microimpact.cli import main

DATA = {
    "name": "once",
    "seed": 2,
    "samples": 300,
    "particles": {"distribution": "normal", "mean_um": 50.0, "std_um": 5.0},
    "coefficients": {
        "k1": 4.0,
        "k2": {"law": "power", "a_m_s": 0.05, "b": -1.58, "d_ref_um": 52.8},
        "v_c": {"law": "power", "a_m_s": 0.2, "b": -1.58, "d_ref_um": 52.8},
        "friction": 0.15,
    },
    "surfaces": [{"name": "rough", "kind": "normal", "std_deg": 10.0}],
    "sweep": {"speed_m_s": [0.5, 1.0], "angle_deg": [45, 85]},
    "outputs": {"figures": []},
    "wall_law": {
        "diameter_um": [40.0, 60.0],
        "speed_m_s": [1.0],
        "angle_deg": [45.0],
        "samples": 200,
        "reservoir": 16,
    },
    "sensitivity": {
        "base_size": 4,
        "resamples": 20,
        "statistics": ["capture_fraction"],
        "parameters": {"coefficients.friction": {"low": 0.1, "high": 0.3}},
    },
}


def _experiments():
    return pd.DataFrame(
        {
            "statistic": ["e"],
            "speed_m_s": [1.0],
            "angle_deg": [45.0],
            "mean": [0.5],
            "ci_low": [0.45],
            "ci_high": [0.55],
        }
    )


_OPENED: list = []
_WATCHED: set = set()


def _hook(event, args):
    if event == "open" and args and str(args[0]) in _WATCHED:
        _OPENED.append(str(args[0]))


sys.addaudithook(_hook)  # audit hooks cannot be removed: it watches only _WATCHED


@pytest.fixture
def scenario_path(tmp_path):
    path = tmp_path / "once.toml"
    path.write_text(to_toml(DATA))
    _WATCHED.add(str(path))
    _OPENED.clear()
    yield path
    _WATCHED.discard(str(path))


def test_study_opens_the_scenario_file_once(scenario_path):
    study = mi.Study(scenario_path)
    study.run(samples=200, progress=False)
    assert study.outputs.figures == ()
    assert _OPENED == [str(scenario_path)]


def test_wall_law_verb_opens_the_scenario_file_once(scenario_path, tmp_path):
    out = tmp_path / "wl"
    assert main(["wall-law", str(scenario_path), "--out", str(out), "--quiet"]) == 0
    assert _OPENED == [str(scenario_path)]


def test_sensitivity_opens_the_scenario_file_once(scenario_path):
    res = mi.sobol_sensitivity(scenario_path, samples=100, progress=False)
    assert res.base_size == 4 and res.info["samples"] == 100
    assert _OPENED == [str(scenario_path)]


def test_calibration_opens_the_scenario_file_once(scenario_path):
    exp = _experiments()
    mi.calibrate(
        scenario_path,
        exp,
        ["coefficients.friction"],
        samples=200,
        bootstrap=0,
        band_draws=0,
        progress=False,
    )
    assert _OPENED == [str(scenario_path)]


class _Calls:
    def __init__(self):
        self.calls = []

    def __call__(self, done, total):
        self.calls.append((done, total))


@pytest.mark.parametrize("progress", [False, True, None, "callable"])
def test_progress_in_every_long_call(scenario_path, progress, capsys):
    cb = _Calls() if progress == "callable" else progress
    file = mi.scenario.read_scenario(scenario_path)
    mi.run(file.scenario, samples=200, progress=cb)
    mi.build_wall_law(file, progress=cb)
    mi.sobol_sensitivity(file, samples=50, progress=cb)
    exp = _experiments()
    mi.calibrate(
        file,
        exp,
        ["coefficients.friction"],
        samples=100,
        bootstrap=2,
        band_draws=0,
        progress=cb,
    )
    if progress == "callable":
        totals = {}
        for done, total in cb.calls:
            assert 0 < done <= total
            totals.setdefault(total, []).append(done)
        # every call reached its total: impacts, diameters, design rows, steps
        assert 4 * 200 in totals and 2 in totals and 12 in totals and 4 in totals
        for total, dones in totals.items():
            assert dones[-1] == total and dones == sorted(dones)


def test_progress_of_a_wrong_type_names_the_argument(scenario_path):
    with pytest.raises(TypeError, match="`progress` must be True, False, None or a"):
        mi.run(mi.Scenario.from_toml(scenario_path), samples=10, progress="yes")
