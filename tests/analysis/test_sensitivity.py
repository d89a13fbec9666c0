"""Sobol' sensitivity (issue 15): dotted scenario keys, the [sensitivity] table, the
indices on cases with known answers, the CSV and the figure."""

from __future__ import annotations

import argparse
import copy
import re
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest

from microimpact.analysis.sensitivity import COLUMNS, sobol_analysis, sobol_sensitivity
from microimpact.errors import ScenarioError
from microimpact.scenario.parameters import get_value, numeric_keys, with_values
from microimpact.scenario.sensitivity import sensitivity_from_dict

BASE = {
    "seed": 11,
    "samples": 1500,
    "particles": {"distribution": "lognormal", "median_um": 10, "geometric_std": 1.3},
    "coefficients": {
        "k1": 4.0,
        "k2": {"law": "power", "a_m_s": 0.05, "b": -1.5, "d_ref_um": 10},
        "v_c": {"law": "power", "a_m_s": 0.5, "b": -1.5, "d_ref_um": 10},
        "friction": 0.15,
    },
    "surfaces": [{"name": "silicon", "kind": "smooth"}],
    "sweep": {"speed_m_s": [0.3, 0.6], "angle_deg": [90]},
}


def scenario(**changes):
    data = copy.deepcopy(BASE)
    data.update(changes)
    return data


# ---------------------------------------------------------------- dotted keys
def test_get_and_replace_values_by_dotted_key():
    data = scenario(
        surfaces=[
            {"name": "formica", "kind": "normal", "std_deg": 10},
            {"kind": "smooth"},
        ],
        confidence=0.9,
    )
    assert get_value(data, "particles.median_um") == 10
    assert get_value(data, "coefficients.k1") == 4.0
    assert get_value(data, "coefficients.v_c.a_m_s") == 0.5
    assert get_value(data, "surfaces.formica.std_deg") == 10
    assert get_value(data, "confidence") == 0.9
    new = with_values(
        data, {"surfaces.formica.std_deg": 5.5, "particles.median_um": 12.0}
    )
    assert new["surfaces"][0]["std_deg"] == 5.5
    assert new["particles"]["median_um"] == 12 and isinstance(
        new["particles"]["median_um"], int
    )  # a whole number replacing an integer stays one
    assert data["surfaces"][0]["std_deg"] == 10  # the input is not changed
    assert "surfaces.formica.std_deg" in numeric_keys(data)
    assert "particles.distribution" not in numeric_keys(data)


@pytest.mark.parametrize(
    "key, expected",
    [
        (
            "particles.median",
            "particles.median: no such number in the scenario "
            "(did you mean 'particles.median_um'?)",
        ),
        ("surfaces.silcon.std_deg", "surfaces.silcon.std_deg: no such number"),
        (
            "coefficients.v_c",
            "coefficients.v_c: is a table, not a number; name one "
            "of its numbers: coefficients.v_c.a_m_s",
        ),
        ("particles.distribution", "particles.distribution: is not a number"),
        ("sweep.speed_m_s", "sweep.speed_m_s: is an array, not a number"),
    ],
)
def test_dotted_key_errors_are_one_line_naming_the_key(key, expected):
    data = scenario(surfaces=[{"name": "silicon", "kind": "normal", "std_deg": 3}])
    with pytest.raises(ScenarioError) as err:
        get_value(data, key, source="s.toml")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("s.toml: ")
    assert expected in msg
    with pytest.raises(ScenarioError, match=key.replace(".", r"\.")):
        with_values(data, {key: 1.0}, source="s.toml")


def test_surface_typo_suggests_the_surface():
    data = scenario(surfaces=[{"name": "formica", "kind": "normal", "std_deg": 3}])
    with pytest.raises(
        ScenarioError, match=r"did you mean 'surfaces\.formica\.std_deg'"
    ):
        get_value(data, "surfaces.formca.std_deg")


def test_a_bad_value_gets_the_scenario_error_naming_the_key():
    from microimpact.scenario.scenario import scenario_from_dict

    with pytest.raises(ScenarioError, match=r"particles\.median_um: must be > 0"):
        scenario_from_dict(with_values(BASE, {"particles.median_um": -1.0}))


# ---------------------------------------------------------------- [sensitivity]
def test_sensitivity_table():
    data = scenario(
        sensitivity={
            "base_size": 64,
            "statistics": ["capture_fraction"],
            "parameters": {
                "particles.median_um": {"low": 8, "high": 12},
                "coefficients.k1": {
                    "distribution": "normal",
                    "mean": 4,
                    "std": 1,
                    "low": 0,
                },
                "coefficients.v_c.a_m_s": {
                    "distribution": "lognormal",
                    "median": 0.5,
                    "geometric_std": 1.2,
                },
            },
        }
    )
    s = sensitivity_from_dict(data, source="s.toml")
    assert s.base_size == 64 and s.statistics == ("capture_fraction",)
    assert s.parameters["particles.median_um"].ppf(0.5) == pytest.approx(10)
    assert s.parameters["coefficients.k1"].ppf(1e-9) >= 0
    assert s.parameters["coefficients.v_c.a_m_s"].median() == pytest.approx(0.5)


@pytest.mark.parametrize(
    "table, expected",
    [
        (
            {
                "base_size": 100,
                "parameters": {"coefficients.k1": {"low": 1, "high": 2}},
            },
            "sensitivity.base_size: must be a power of 2",
        ),
        (
            {"samples": 64, "parameters": {"coefficients.k1": {"low": 1, "high": 2}}},
            "sensitivity.samples: renamed: the Sobol' design's base size is "
            "`base_size`",
        ),
        (
            {"parameters": {"coefficients.kk1": {"low": 1, "high": 2}}},
            'sensitivity.parameters."coefficients.kk1": no such number in the '
            "scenario (did you mean 'coefficients.k1'?)",
        ),
        (
            {"parameters": {"coefficients.k1": {"low": 2, "high": 1}}},
            'sensitivity.parameters."coefficients.k1".high: must be > low',
        ),
        (
            {"parameters": {"coefficients.k1": {"distribution": "gamma"}}},
            "must be one of 'uniform', 'normal', 'lognormal', 'triangular'",
        ),
        ({"parameters": {"seed": {"low": 1, "high": 2}}}, "cannot be a parameter"),
        ({"parameters": {}}, "must name at least one parameter"),
        (
            {"parameters": {"coefficients.k1": {"low": 1, "high": 2}}, "base": 4},
            "(did you mean 'base_size'?)",
        ),
    ],
)
def test_sensitivity_table_errors(table, expected):
    with pytest.raises(ScenarioError) as err:
        sensitivity_from_dict(scenario(sensitivity=table), source="s.toml")
    assert expected in str(err.value) and "\n" not in str(err.value)


# ---------------------------------------------------------------- known answers
class Ishigami:
    """The Ishigami function (a = 7, b = 0.1) as a stand-in model: the same
    interface as :class:`microimpact.analysis.sensitivity.EngineModel`."""

    outputs = pd.DataFrame(
        {"statistic": ["y"], "speed_m_s": [np.nan], "angle_deg": [np.nan]}
    )

    def __init__(self, mutate=False):
        self.mutate = mutate

    def __call__(self, rows):
        x = np.asarray(rows, dtype=float)
        if self.mutate:  # the values of x3 not applied (stuck at its mean)
            x = x.copy()
            x[:, 2] = 0.0
        y = np.sin(x[:, 0]) + 7 * np.sin(x[:, 1]) ** 2
        return (y + 0.1 * x[:, 2] ** 4 * np.sin(x[:, 0]))[:, None]


ISHIGAMI_S1 = (0.3139, 0.4424, 0.0)
ISHIGAMI_ST = (0.5576, 0.4424, 0.2437)
U = {"low": -np.pi, "high": np.pi}


def ishigami_indices(model, executor=None):
    res = sobol_analysis(
        model, {"x1": U, "x2": U, "x3": U}, base_size=2048, seed=4, executor=executor
    )
    return res.table


def check_ishigami(t):
    for i, name in enumerate(("x1", "x2", "x3")):
        row = t[t["parameter"] == name].iloc[0]
        for col, truth in (("S1", ISHIGAMI_S1[i]), ("ST", ISHIGAMI_ST[i])):
            lo, hi = row[f"{col}_ci_low"], row[f"{col}_ci_high"]
            assert lo - 0.01 <= truth <= hi + 0.01, (name, col, lo, truth, hi)
            assert abs(row[col] - truth) < 0.06, (name, col, row[col], truth)
            assert hi - lo < 0.2


def test_ishigami_through_the_engine_code_path():
    """The stand-in goes through the design, the executor batching, the indices,
    the bootstrap and the table exactly as the engine does."""
    with ThreadPoolExecutor(2) as ex:
        t = ishigami_indices(Ishigami(), executor=ex)
    assert list(t.columns) == list(COLUMNS)
    check_ishigami(t)
    # same seed, same table, serial or on an executor (intervals included)
    pd.testing.assert_frame_equal(ishigami_indices(Ishigami()), t)


def test_ishigami_check_catches_mutations():
    t = ishigami_indices(Ishigami())
    swapped = t.rename(columns={"S1": "ST", "ST": "S1"})
    swapped = swapped.rename(
        columns={
            "S1_ci_low": "ST_ci_low",
            "ST_ci_low": "S1_ci_low",
            "S1_ci_high": "ST_ci_high",
            "ST_ci_high": "S1_ci_high",
        }
    )
    with pytest.raises(AssertionError):
        check_ishigami(swapped)
    with pytest.raises(AssertionError):
        check_ishigami(ishigami_indices(Ishigami(mutate=True)))


def test_normal_incidence_smooth_capture_ignores_friction_and_k1():
    """On a smooth surface at normal incidence a particle is captured iff its
    normal speed is below v_c(d): the diameters and the v_c law decide, friction
    and k1 cannot matter."""
    res = sobol_sensitivity(
        scenario(),
        {
            "particles.median_um": {"low": 8, "high": 12},
            "coefficients.v_c.a_m_s": {"low": 0.4, "high": 0.6},
            "coefficients.friction": {"low": 0.1, "high": 0.4},
            "coefficients.k1": {"low": 2, "high": 6},
        },
        base_size=32,
        statistics=("capture_fraction",),
        seed=2,
        n_resamples=200,
    )
    t = res.table
    assert res.evaluations == 32 * 6
    for p in ("coefficients.friction", "coefficients.k1"):
        sub = t[t["parameter"] == p]
        for col in ("S1", "ST"):
            assert (sub[f"{col}_ci_low"] <= 0).all() and (
                sub[f"{col}_ci_high"] >= 0
            ).all()
            assert np.allclose(sub[col], 0, atol=1e-12)
    for p in ("particles.median_um", "coefficients.v_c.a_m_s"):
        sub = t[t["parameter"] == p]
        assert (sub["ST"] > 0.1).all() and (sub["ST_ci_low"] > 0).all(), sub
    assert t[t["parameter"] == "particles.median_um"]["ST"].sum() > 0.5


def test_an_input_without_effect_has_zero_total_index():
    """One surface's roughness never changes another surface's statistics (each
    sweep point has its own keyed stream): ST = 0 there, and > 0 on its own."""
    res = sobol_sensitivity(
        scenario(
            surfaces=[
                {"name": "rough", "kind": "normal", "std_deg": 8},
                {"name": "other", "kind": "normal", "std_deg": 5},
            ],
            sweep={"speed_m_s": [0.5, 1.0], "angle_deg": [30, 90]},
        ),
        {
            "surfaces.other.std_deg": {"low": 2, "high": 10},
            "surfaces.rough.std_deg": {"low": 4, "high": 12},
        },
        base_size=16,
        seed=5,
        n_resamples=100,
    )
    t = res.table
    none = t[(t["parameter"] == "surfaces.other.std_deg") & (t["surface"] == "rough")]
    assert len(none) and np.allclose(none["ST"], 0, atol=1e-12)
    assert (none["ST_ci_low"] <= 1e-12).all() and (none["ST_ci_high"] >= -1e-12).all()
    rough = t[
        (t["parameter"] == "surfaces.rough.std_deg")
        & (t["surface"] == "rough")
        & (t["statistic"] == "mu_mean")
        & (t["angle_deg"] == 30)
    ]
    assert (rough["ST"] > 0.5).all()


def test_undefined_indices_are_nan_and_surface_column():
    """Where every particle is captured e_rebound_mean is undefined; with two
    surfaces the table has a surface column after statistic."""
    res = sobol_sensitivity(
        scenario(
            surfaces=[
                {"name": "a", "kind": "smooth"},
                {"name": "b", "kind": "normal", "std_deg": 5},
            ],
            sweep={"speed_m_s": [0.01, 0.6], "angle_deg": [90]},
        ),
        {"particles.median_um": {"low": 8, "high": 12}},
        base_size=8,
        statistics=("capture_fraction", "e_rebound_mean"),
        seed=1,
        n_resamples=50,
    )
    t = res.table
    assert list(t.columns[:5]) == [
        "parameter",
        "statistic",
        "surface",
        "speed_m_s",
        "angle_deg",
    ]
    slow = t[(t["speed_m_s"] == 0.01)]
    assert slow["ST"].isna().all()  # all captured: no rebound, constant capture
    fast = t[(t["speed_m_s"] == 0.6) & (t["statistic"] == "capture_fraction")]
    assert fast["ST"].notna().all()


def test_design_values_the_scenario_refuses_fail_before_any_run():
    with pytest.raises(ScenarioError, match=r"particles\.median_um: must be > 0"):
        sobol_sensitivity(
            scenario(), {"particles.median_um": {"low": -12, "high": -1}}, base_size=4
        )
    with pytest.raises(ScenarioError, match=r"did you mean 'coefficients\.k1'"):
        sobol_sensitivity(scenario(), {"coefficients.kk1": {"low": 1, "high": 2}})


# ---------------------------------------------------------------- CLI and files
def _toml(data) -> str:
    """A small TOML writer for these flat test scenarios."""
    import json

    def val(v):
        if isinstance(v, dict):
            return (
                "{"
                + ", ".join(f"{json.dumps(k)} = {val(x)}" for k, x in v.items())
                + "}"
            )
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return json.dumps(v)

    lines = []
    tables = []
    for k, v in data.items():
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for entry in v:
                tables.append((f"[{k}]", entry))
        else:
            lines.append(f"{k} = {val(v)}")
    for name, t in tables:
        lines.append(f"[{name}]")
        sub = []
        for k, v in t.items():
            if (
                isinstance(v, dict)
                and all(isinstance(x, dict) for x in v.values())
                and v
            ):
                sub.append((f"{name}.{k}", v))
            else:
                lines.append(f"{json.dumps(k)} = {val(v)}")
        for sname, st in sub:
            lines.append(f"[{sname}]")
            lines += [f"{json.dumps(k)} = {val(v)}" for k, v in st.items()]
    return "\n".join(lines) + "\n"


def test_cli_action_writes_csv_and_figure(tmp_path, capsys):
    from microimpact.cli import sensitivity as verb

    data = scenario(
        sweep={"speed_m_s": [0.6], "angle_deg": [45, 90]},
        sensitivity={
            "base_size": 4,
            "resamples": 20,
            "parameters": {"particles.median_um": {"low": 8, "high": 12}},
        },
    )
    path = tmp_path / "s.toml"
    path.write_text(_toml(data))
    parser = argparse.ArgumentParser()
    verb.cli_parse(parser)
    args = parser.parse_args(
        [
            str(path),
            "--out",
            str(tmp_path / "out"),
            "--quiet",
            "--parameter",
            "coefficients.k1=2:6",
            "--parameter",
            "particles.median_um=9:11",
        ]
    )
    assert verb.cli_action(args) == 0
    t = pd.read_csv(tmp_path / "out" / "sensitivity.csv")
    assert list(t.columns) == list(COLUMNS)
    assert set(t["parameter"]) == {"coefficients.k1", "particles.median_um"}
    assert (tmp_path / "out" / "sensitivity_ST.png").stat().st_size > 1000
    assert not list((tmp_path / "out").glob(".*.tmp"))
    with pytest.raises(SystemExit):
        parser.parse_args([str(path), "--out", "x", "--parameter", "k1=3"])
    with pytest.raises(SystemExit):
        parser.parse_args([str(path), "--out", "x", "--base-size", "100"])


def test_cli_sensitivity_through_main(tmp_path, capsys):
    """The registered verb end to end: the file's [sensitivity] table, exit 0 with
    the CSV and figure; a misspelt --parameter key is the user's error (exit 2)."""
    from pathlib import Path

    from microimpact.cli import main

    scenario = Path(__file__).parents[1] / "data" / "sensitivity_small.toml"
    out = tmp_path / "out"
    assert main(["sensitivity", str(scenario), "--out", str(out), "--quiet"]) == 0
    import pandas as pd

    table = pd.read_csv(out / "sensitivity.csv")
    assert list(table.columns)[:10] == [
        "parameter",
        "statistic",
        "speed_m_s",
        "angle_deg",
        "S1",
        "S1_ci_low",
        "S1_ci_high",
        "ST",
        "ST_ci_low",
        "ST_ci_high",
    ]
    assert (out / "sensitivity_ST.png").is_file()
    # the scenario with its [sensitivity] table is a valid scenario for `run` too
    assert (
        main(
            [
                "run",
                str(scenario),
                "--out",
                str(tmp_path / "run"),
                "--quiet",
                "--no-figures",
            ]
        )
        == 0
    )
    rc = main(
        [
            "sensitivity",
            str(scenario),
            "--out",
            str(out),
            "--quiet",
            "--parameter",
            "coefficients.frictoin=0.1:0.4",
        ]
    )
    assert rc == 2
    assert "coefficients.frictoin" in capsys.readouterr().err


def test_a_misspelt_preset_name_is_a_did_you_mean_error():
    """The scenario is named as for `run` (scenario.scenario_file): a misspelt
    preset gets the same did-you-mean line, not 'file not found'."""
    import pytest

    from microimpact.analysis.calibration import calibrate
    from microimpact.analysis.sensitivity import sobol_sensitivity
    from microimpact.errors import InputError

    with pytest.raises(InputError, match="did you mean 'sst65-silicon-normal'"):
        sobol_sensitivity(
            "sst65-silicon-normall", {"particles.mean_um": {"low": 1, "high": 2}}
        )
    with pytest.raises(InputError, match="did you mean 'sst65-silicon-normal'"):
        calibrate("sst65-silicon-normall", "x.csv", ["coefficients.friction"])


def test_parameter_flag_shares_the_calibration_parser():
    """``--parameter KEY=LOW:HIGH`` is read by the calibration's parser (one reader
    of the syntax, one set of messages) and then needs both limits, finite, with
    LOW < HIGH (a uniform range)."""
    import argparse

    from microimpact.cli.sensitivity import _parameter

    assert _parameter(" particles.median_um = 8 : 12 ") == (
        "particles.median_um",
        {"low": 8.0, "high": 12.0},
    )
    for bad, says in [
        ("k1=x:2", "lower bound 'x' is not a number"),  # the calibration's message
        ("k1=nan:2", "NaN"),
        ("k1=:2", "both limits finite"),
        ("k1", "both limits finite"),
        ("k1=1:inf", "both limits finite"),
        ("k1=2:1", "LOW < HIGH"),
        ("=1:2", "KEY=LOW:HIGH"),
    ]:
        with pytest.raises(argparse.ArgumentTypeError, match=says):
            _parameter(bad)


def test_cli_unreachable_scheduler_is_the_users_error(tmp_path, capsys, monkeypatch):
    """``--backend dask --scheduler ADDRESS`` goes through the engine's Dask
    connection: an unreachable scheduler is exit 2 with one line naming it."""
    from pathlib import Path

    from microimpact.cli import main
    from microimpact.engine import parallel

    pytest.importorskip("dask.distributed")
    monkeypatch.setattr(parallel, "DASK_CONNECT_TIMEOUT", 1)
    path = Path(__file__).parents[1] / "data" / "sensitivity_small.toml"
    argv = ["sensitivity", str(path), "--out", str(tmp_path / "o"), "--quiet"]
    assert main([*argv, "--backend", "dask", "--scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "127.0.0.1:9" in err
    # the flag, not the library's argument name (found by a user: "address: ...")
    assert "error: --scheduler: cannot connect" in err, err
    assert main([*argv, "--scheduler", "tcp://127.0.0.1:9"]) == 2
    assert "needs --backend dask" in capsys.readouterr().err


class TwoOutputs:
    """Two outputs with known indices: y1 = x1 (variance 1/12) at one sweep
    point, y2 = 10 x2 (variance 100/12) at another, y3 = 1e-9 x1 (hardly varies)."""

    outputs = pd.DataFrame(
        {
            "statistic": ["y", "y", "y"],
            "speed_m_s": [1.0, 2.0, 3.0],
            "angle_deg": [90.0, 90.0, 90.0],
        }
    )

    def __call__(self, rows):
        x = np.asarray(rows, dtype=float)
        return np.column_stack([x[:, 0], 10 * x[:, 1], 1e-9 * x[:, 0]])


def test_aggregated_indices_weigh_points_by_their_variance():
    """Issue 22: the headline ranks by the variance-weighted index over the sweep
    (Gamboa et al. 2014), in [0, 1], ignoring points that hardly vary: here the
    closed form is ST(x2) = 100/101, ST(x1) = 1/101, whatever the third point."""
    res = sobol_analysis(
        TwoOutputs(),
        {"x1": {"low": 0, "high": 1}, "x2": {"low": 0, "high": 1}},
        base_size=1024,
        seed=3,
        n_resamples=20,
    )
    agg = res.aggregated("y").set_index("parameter")
    assert list(agg.index) == ["x2", "x1"]
    assert agg.loc["x2", "ST"] == pytest.approx(100 / 101, abs=0.01)
    assert agg.loc["x1", "ST"] == pytest.approx(1 / 101, abs=0.01)
    assert (agg["points"] == 2).all()  # the third point carries no weight
    assert ((agg["ST"] >= 0) & (agg["ST"] <= 1)).all()


def test_the_cli_headline_never_prints_an_index_above_one(tmp_path, capsys):
    from microimpact.cli import sensitivity as verb

    res = sobol_analysis(
        TwoOutputs(),
        {"x1": {"low": 0, "high": 1}, "x2": {"low": 0, "high": 1}},
        base_size=4,  # tiny: the pointwise estimates stray far beyond [0, 1]
        seed=3,
        n_resamples=20,
    )
    verb._print_top(res)
    line = capsys.readouterr().out
    values = [float(v) for v in re.findall(r" (-?\d+\.\d+)", line)]
    assert values and all(0.0 <= v <= 1.0 for v in values), line


class ConstantOutput:
    """A statistic that does not vary over the design (e.g. capture 0 everywhere)."""

    outputs = pd.DataFrame(
        {"statistic": ["y", "y"], "speed_m_s": [1.0, 2.0], "angle_deg": [90.0, 90.0]}
    )

    def __call__(self, rows):
        return np.zeros((len(rows), 2))


def test_the_cli_headline_says_when_a_statistic_varies_nowhere(capsys):
    # found by a user: "capture_fraction: ST over 0 sweep point(s)  a -, b -"
    from microimpact.cli import sensitivity as verb

    res = sobol_analysis(
        ConstantOutput(),
        {"a": {"low": 0, "high": 1}, "b": {"low": 0, "high": 1}},
        base_size=4,
        seed=1,
        n_resamples=10,
    )
    verb._print_top(res)
    line = capsys.readouterr().out
    assert "over 0 sweep point" not in line and " -" not in line, line
    assert "y: does not vary over the design at any sweep point" in line
    assert "no index" in line
