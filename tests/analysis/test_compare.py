"""Tests for microimpact.analysis.compare: simulated vs experimental means.

The oracle is a summary table built by hand with known means and standard errors,
so the z statistics, agreement flags and interpolated values are computed here on
paper, independently of the code.
"""

from __future__ import annotations

import math

import matplotlib
import numpy as np
import pandas as pd
import pytest
from engine_helpers import scenario
from numpy.testing import assert_allclose

import microimpact as mi
from microimpact.analysis.compare import compare
from microimpact.io.experiments import read_experiments
from microimpact.plotting.comparison import plot_comparison

matplotlib.use("Agg")

#: The columns of the hand-made summaries (each row's fields in this order).
SUMMARY_COLUMNS = [
    "surface",
    "speed_m_s",
    "angle_deg",
    "e_rebound_mean",
    "e_rebound_se",
    "mu_mean",
    "mu_se",
    "capture_fraction",
    "capture_ci_low",
    "capture_ci_high",
]
Z95 = 1.959963984540054
Z99 = 2.5758293035489004


@pytest.fixture
def summary():
    """Rough surface at 1 m/s and 10, 30, 85 deg; smooth at 85 deg only."""
    rows = [
        # surface, speed, angle, e_reb, e_se, mu, mu_se, capture, lo, hi
        ("rough", 1.0, 10.0, 0.80, 0.03, 0.40, 0.02, 0.10, 0.08, 0.12),
        ("rough", 1.0, 30.0, 0.60, 0.04, 0.20, 0.01, 0.05, 0.04, 0.06),
        ("rough", 1.0, 85.0, 0.50, 0.03, 0.01, 0.01, 0.02, 0.01, 0.03),
        ("smooth", 1.0, 85.0, 0.55, 0.02, 0.00, 0.001, 0.02, 0.01, 0.03),
    ]
    cols = SUMMARY_COLUMNS
    return pd.DataFrame(rows, columns=cols)


def exp_table(rows):
    """Experiments with a given SE: interval = mean +- 1.96 SE."""
    out = []
    for surface, speed, angle, stat, mean, se in rows:
        out.append(
            {
                "surface": surface,
                "speed_m_s": speed,
                "angle_deg": angle,
                "statistic": stat,
                "mean": mean,
                "ci_low": mean - Z95 * se,
                "ci_high": mean + Z95 * se,
                "se": se,
            }
        )
    return pd.DataFrame(out)


def test_z_and_agree_by_hand(summary):
    exp = exp_table(
        [
            # sim 0.50 +- 0.03, exp 0.45 +- 0.04 -> d 0.05, s 0.05, z 1
            ("rough", 1.0, 85.0, "e", 0.45, 0.04),
            # d 0.11 -> z 2.2 -> disagree at 95 %
            ("rough", 1.0, 85.0, "e", 0.39, 0.04),
            # z = -1.95 exactly inside, -1.97 outside
            ("rough", 1.0, 85.0, "e", 0.50 + 1.95 * 0.05, 0.04),
            ("rough", 1.0, 85.0, "e", 0.50 + 1.97 * 0.05, 0.04),
            # mu: sim 0.40 +- 0.02, exp 0.30 +- 0.0 -> z = 5
            ("rough", 1.0, 10.0, "mu", 0.30, 0.0),
        ]
    )
    t = compare(summary, exp)
    assert_allclose(t["combined_se"], [0.05, 0.05, 0.05, 0.05, 0.02], rtol=1e-12)
    assert_allclose(t["z"], [1.0, 2.2, -1.95, -1.97, 5.0], rtol=1e-9)
    assert list(t["agree"]) == [True, False, True, False, False]
    assert_allclose(t["difference"], [0.05, 0.11, -0.0975, -0.0985, 0.10], rtol=1e-9)
    assert not t["interpolated"].any()
    assert_allclose(t["sim_ci_high"] - t["sim_mean"], Z95 * t["sim_se"], rtol=1e-12)
    # at 99 % the z = 2.2 point agrees (z_c = 2.576)
    t99 = compare(summary, exp, confidence=0.99)
    assert list(t99["agree"]) == [True, True, True, True, False]
    assert_allclose(
        t99["sim_ci_high"] - t99["sim_mean"],
        Z99 * 0.03 * np.array([1, 1, 1, 1, 0.02 / 0.03]),
        rtol=1e-9,
    )


def test_interpolation_in_angle_by_hand(summary):
    # 15 deg: weight 0.75 on 10 deg (0.80 +- 0.03), 0.25 on 30 deg (0.60 +- 0.04)
    exp = exp_table([("rough", 1.0, 15.0, "e", 0.70, 0.05)])
    t = compare(summary, exp)
    assert_allclose(t.loc[0, "sim_mean"], 0.75, rtol=1e-12)
    assert_allclose(
        t.loc[0, "sim_se"], math.sqrt(0.75**2 * 0.03**2 + 0.25**2 * 0.04**2), rtol=1e-12
    )
    assert bool(t.loc[0, "interpolated"])
    assert "interpolated in angle_deg between 10 and 30" in t.loc[0, "note"]
    # the speed was not given: filled in from the single simulated speed
    exp2 = exp_table([("rough", np.nan, 20.0, "e", 0.70, 0.05)])
    t2 = compare(summary, exp2)
    assert_allclose(t2.loc[0, "sim_mean"], 0.70, rtol=1e-12)
    assert_allclose(t2.loc[0, "speed_m_s"], 1.0, rtol=0)


def test_outside_range_is_not_extrapolated(summary):
    exp = exp_table([("rough", 1.0, 5.0, "e", 0.9, 0.05)])
    t = compare(summary, exp)
    assert np.isnan(t.loc[0, "sim_mean"])
    assert not t.loc[0, "agree"]
    assert "outside the simulated range [10, 85]" in t.loc[0, "note"]


def test_interpolation_beside_a_point_without_a_value_says_why(summary):
    # found by a user: e between a fully captured speed (no rebounds, e NaN) and
    # a rebounding one came out NaN with the note "interpolated in ... between"
    summary.loc[0, ["e_rebound_mean", "e_rebound_se"]] = math.nan  # 10 deg
    exp = exp_table(
        [
            ("rough", 1.0, 15.0, "e", 0.70, 0.05),  # between 10 (NaN) and 30
            ("rough", 1.0, 50.0, "e", 0.55, 0.05),  # between 30 and 85: fine
        ]
    )
    t = compare(summary, exp)
    assert np.isnan(t.loc[0, "sim_mean"]) and not t.loc[0, "interpolated"]
    note = t.loc[0, "note"]
    assert "interpolated in" not in note
    assert "angle_deg = 10" in note and "e_rebound_mean" in note
    assert "no rebounds" in note
    # the neighbouring interval still interpolates: 50 deg is 20/55 of 30 -> 85
    w = 35 / 55
    assert_allclose(t.loc[1, "sim_mean"], w * 0.60 + (1 - w) * 0.50, rtol=1e-12)
    assert bool(t.loc[1, "interpolated"])


def test_capture_fraction_se_from_wilson_width(summary):
    exp = exp_table([("rough", 1.0, 30.0, "capture_fraction", 0.05, 0.0)])
    t = compare(summary, exp)
    assert_allclose(t.loc[0, "sim_se"], 0.02 / (2 * Z95), rtol=1e-12)
    assert t.loc[0, "agree"]


def test_surface_rules_and_errors(summary):
    exp = exp_table([(None, 1.0, 85.0, "e", 0.5, 0.01)])
    with pytest.raises(ValueError, match="add a `surface` column"):
        compare(summary, exp)
    one = summary[summary["surface"] == "rough"]
    assert compare(one, exp).loc[0, "surface"] == "rough"
    with pytest.raises(ValueError, match="surface 'glass' is not simulated"):
        compare(summary, exp_table([("glass", 1.0, 85.0, "e", 0.5, 0.01)]))
    with pytest.raises(ValueError, match="e_relative"):
        compare(summary, exp_table([("rough", 1.0, 10.0, "e_relative", 0.5, 0.01)]))
    with pytest.raises(ValueError, match="confidence"):
        compare(summary, exp, confidence=95)
    with pytest.raises(TypeError, match="summary_or_result"):
        compare([1, 2], exp)
    two_speeds = pd.concat([summary, summary.assign(speed_m_s=2.0)], ignore_index=True)
    with pytest.raises(ValueError, match="add a `speed_m_s` column"):
        compare(two_speeds, exp_table([("rough", np.nan, 85.0, "e", 0.5, 0.01)]))


def test_path_input_and_plot(summary, tmp_path):
    p = tmp_path / "exp.csv"
    p.write_text(
        "surface,angle_deg,statistic,mean,half_width\n"
        f"rough,85,e,0.45,{Z95 * 0.04}\n"
        f"rough,85,e,0.39,{Z95 * 0.04}\n"
    )
    t = compare(summary, p)
    assert_allclose(t["z"], [1.0, 2.2], rtol=1e-9)
    assert list(t["line"]) == [2, 3]
    ax = plot_comparison(t)
    assert "1 of 2 compared points agree" in ax.get_title()
    assert "[–]" in ax.get_xlabel() and "[–]" in ax.get_ylabel()
    with pytest.raises(ValueError, match="compare"):
        plot_comparison(pd.DataFrame({"a": [1]}))
    import matplotlib.pyplot as plt

    plt.close("all")


def test_mc_summary_capture_se_is_the_wilson_width_over_2z():
    from engine_helpers import scenario

    from microimpact.engine.montecarlo import run

    res = run(scenario(speeds_m_s=(0.15, 0.3), confidence=0.99), samples=3000)
    s = res.summary
    width = s["capture_ci_high"] - s["capture_ci_low"]
    assert_allclose(s["capture_se"], width / (2 * Z99), rtol=1e-12)
    assert (s["capture_se"] > 0).all()
    exp = exp_table([("smooth", 0.15, 90.0, "capture_fraction", 0.5, 0.01)])
    with_col = compare(res, exp)
    older = s.drop(columns="capture_se")  # e.g. an older summary.csv
    assert_allclose(
        compare(older, exp)["sim_se"], width.iloc[:1] / (2 * Z99), rtol=1e-12
    )  # the summary knows its confidence level
    older.attrs = {}
    without = compare(older, exp)
    assert_allclose(with_col["sim_se"], s["capture_se"].iloc[:1], rtol=1e-12)
    # a table without attrs is taken at 95 %
    assert_allclose(without["sim_se"], width.iloc[:1] / (2 * Z95), rtol=1e-12)


# ------------------------------------------------ experiments that do not match
def _exp_file(
    tmp_path, rows, header="statistic,speed_m_s,angle_deg,mean,ci_low,ci_high"
):
    path = tmp_path / "exp.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize(
    "header, row, expected",
    [
        (
            "surface,statistic,speed_m_s,angle_deg,mean,ci_low,ci_high",
            "glass,e,1.0,90,0.5,0.4,0.6",
            "exp.csv:2: surface 'glass' is not simulated; choose one of silicon",
        ),
        (
            "statistic,speed_m_s,angle_deg,mean,ci_low,ci_high",
            "e_relative,1.0,90,0.5,0.4,0.6",
            "exp.csv:2: the simulation has no 'e_relative' column; relative "
            "coefficients need the reference angle",
        ),
        (
            "statistic,speed_m_s,angle_deg,mean,ci_low,ci_high",
            "e,5.0,90,0.5,0.4,0.6",
            "exp.csv:2: speed_m_s = 5 is outside the simulated range [0.2, 1]",
        ),
    ],
)
def test_mismatched_experiments_are_the_users_error_before_any_impact(
    tmp_path, monkeypatch, header, row, expected
):
    """Issue 22: exit 2 naming the file and the row, before the simulation (the
    engine is never called), in run, compare and report alike."""
    import microimpact.pipeline.study as study_module
    from microimpact.analysis.compare import check_experiments
    from microimpact.cli import main
    from microimpact.errors import InputError

    sc = scenario(
        surfaces=(mi.SurfaceVariant("silicon"),),
        speeds_m_s=(0.2, 0.6, 1.0),
        angles_deg=(90.0,),
        reference_angle_deg=None,
    )
    path = _exp_file(tmp_path, [row], header)
    with pytest.raises(InputError) as err:
        check_experiments(sc, read_experiments(path))
    assert expected in str(err.value)

    def no_run(*a, **k):  # the check must come before any impact
        raise AssertionError("the engine ran")

    monkeypatch.setattr(study_module, "run", no_run)
    study = mi.Study(sc, outputs=mi.Outputs(figures=(), experiments=(str(path),)))
    with pytest.raises(InputError, match=r"exp\.csv:2"):
        study.execute(tmp_path / "out", samples=100)
    monkeypatch.undo()
    res = mi.run(sc, samples=200, seed=1, progress=False)
    if "outside" in expected:  # compare itself reports the point, z undefined
        table = mi.compare(res, path)
        assert np.isnan(table["z"].iloc[0]) and not table["agree"].iloc[0]
    else:
        with pytest.raises(InputError, match=r"exp\.csv:2"):
            mi.compare(res, path)
        out = tmp_path / "r"
        res_dir = tmp_path / "res"
        mi.Study.from_result(res, outputs=mi.Outputs(figures=())).write(res_dir)
        assert main(["compare", str(res_dir), str(path)]) == 2
        assert main(["report", str(res_dir), "--experiments", str(path)]) == 2
        assert not out.exists()


# ------------------------------------------------ issue 33: only what was compared
def _grid(values, se=0.02, speeds=(1.0, 2.0, 3.0), angles=(10.0, 30.0, 50.0)):
    """A one-surface summary on speeds x angles with e = values(v, a)."""
    rows = [
        ("g", v, a, values(v, a), se, 0.1, 0.01, 0.5, 0.4, 0.6)
        for v in speeds
        for a in angles
    ]
    cols = SUMMARY_COLUMNS
    return pd.DataFrame(rows, columns=cols)


def test_between_nodes_in_speed_and_angle_is_interpolated_bilinearly():
    # e = 0.1 v + 0.01 a + 0.002 v a is bilinear: reproduced exactly, and every
    # second difference along an axis is 0, so the error bound is exactly 0.
    # At (1.5 m/s, 20 deg): 0.15 + 0.20 + 0.06 = 0.41; four corners of weight
    # 1/4 with SE 0.02 each: sqrt(4 (0.25 * 0.02)^2) = 0.01.
    summary = _grid(lambda v, a: 0.1 * v + 0.01 * a + 0.002 * v * a)
    t = compare(summary, exp_table([("g", 1.5, 20.0, "e", 0.41, 0.01)]))
    assert_allclose(t.loc[0, "sim_mean"], 0.41, rtol=1e-12)
    assert_allclose(t.loc[0, "sim_se"], 0.01, rtol=1e-12)
    assert_allclose(t.loc[0, "interpolation_error"], 0.0, atol=1e-15)
    assert t.loc[0, "compared"] and t.loc[0, "interpolated"] and t.loc[0, "agree"]
    note = t.loc[0, "note"]
    assert "speed_m_s between 1 and 2 and in angle_deg between 10 and 30" in note
    # an off-centre point: weights 0.75 x 0.25 etc. (1.25 m/s, 45 deg)
    # e = 0.125 + 0.45 + 0.1125 = 0.6875
    t = compare(summary, exp_table([("g", 1.25, 45.0, "e", 0.6875, 0.01)]))
    assert_allclose(t.loc[0, "sim_mean"], 0.6875, rtol=1e-12)
    w = np.array([0.75 * 0.25, 0.75 * 0.75, 0.25 * 0.25, 0.25 * 0.75])
    assert_allclose(t.loc[0, "sim_se"], 0.02 * math.sqrt((w**2).sum()), rtol=1e-12)


def test_the_interpolation_error_bound_by_hand():
    # e = v^2 along speed (1, 4, 9 at 1, 2, 3 m/s): at 1.5 m/s linear gives 2.5,
    # the truth is 2.25; f[1, 2, 3] = 1 so the bound is 1 * 0.5 * 0.5 = 0.25,
    # here exactly the error (a quadratic's remainder).
    summary = _grid(lambda v, a: v**2, se=0.001, angles=(30.0,))
    exp = exp_table(
        [
            ("g", 1.5, 30.0, "e", 2.25, 0.001),  # d = 0.25: within the bound
            ("g", 1.5, 30.0, "e", 2.00, 0.001),  # d = 0.50: beyond noise + bound
        ]
    )
    t = compare(summary, exp)
    assert_allclose(t["sim_mean"], [2.5, 2.5], rtol=1e-12)
    assert_allclose(t["interpolation_error"], [0.25, 0.25], rtol=1e-12)
    assert list(t["agree"]) == [True, False]
    assert list(t["compared"]) == [True, True]
    assert "interpolation error at most about 0.25" in t.loc[0, "note"]
    # at a sweep point there is nothing to interpolate: bound 0
    t = compare(summary, exp_table([("g", 2.0, 30.0, "e", 4.0, 0.001)]))
    assert t.loc[0, "interpolation_error"] == 0.0 and not t.loc[0, "interpolated"]


def test_with_two_sweep_points_the_bound_is_unknown_and_said():
    summary = _grid(lambda v, a: v, speeds=(1.0, 2.0), angles=(30.0,))
    t = compare(summary, exp_table([("g", 1.5, 30.0, "e", 1.5, 0.01)]))
    assert math.isnan(t.loc[0, "interpolation_error"]) and t.loc[0, "compared"]
    assert "interpolation error unknown" in t.loc[0, "note"]


def test_points_outside_the_sweep_are_not_compared_and_not_disagreeing():
    summary = _grid(lambda v, a: 0.5)
    exp = exp_table(
        [
            ("g", 5.0, 30.0, "e", 0.5, 0.01),  # beyond the fastest speed
            ("g", 2.0, 70.0, "e", 0.5, 0.01),  # beyond the largest angle
            ("g", 2.0, 30.0, "e", 0.9, 0.01),  # compared, disagrees
        ]
    )
    t = compare(summary, exp)
    assert list(t["compared"]) == [False, False, True]
    assert list(t["agree"]) == [False, False, False]
    disagree = t["compared"] & ~t["agree"]
    assert int(disagree.sum()) == 1
    assert t.loc[0, "note"].startswith("not compared: speed_m_s = 5 is outside")
    assert "angle_deg = 70 is outside the simulated range [10, 50]" in t.loc[1, "note"]


def test_nothing_compared_draws_no_empty_legend_and_warns_nothing():
    import warnings

    import matplotlib.pyplot as plt

    t = compare(_grid(lambda v, a: 0.5), exp_table([("g", 9.0, 30.0, "e", 0.5, 0.1)]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any library warning fails the test
        ax = plot_comparison(t)
    assert "0 of 0 compared points agree" in ax.get_title()
    assert "1 not compared" in ax.get_title()
    assert ax.get_legend() is None
    assert any(x.get_text() == "no point was compared" for x in ax.texts)
    plt.close("all")


def test_cli_compare_counts_only_what_it_compared(tmp_path, capsys):
    """The issue's case: both points outside the sweep."""
    from microimpact.cli import main

    summary = _grid(lambda v, a: 0.5)
    summary.to_csv(tmp_path / "summary.csv", index=False)
    (tmp_path / "exp.csv").write_text(
        "surface,speed_m_s,angle_deg,statistic,mean,half_width\n"
        "g,9,30,e,0.5,0.1\n"
        "g,2,80,e,0.5,0.1\n"
    )
    out = tmp_path / "out"
    args = ["compare", str(tmp_path / "summary.csv"), str(tmp_path / "exp.csv")]
    assert main([*args, "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "agree" not in captured.out.splitlines()[-1]
    assert "none of the 2 points was compared: no figure is drawn" in captured.out
    assert "line 2 (e, g, 9 m/s, 30 deg): not compared: speed_m_s = 9" in captured.out
    assert "warning" not in captured.err.lower()
    assert (out / "comparison.csv").exists() and not (out / "comparison.png").exists()


# ------------------------------------------------------------ the point recipe
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from microimpact.analysis.compare import PointRecipe  # noqa: E402


def _random_summary(rng, speeds, angles, nan_share):
    rows = []
    for v in speeds:
        for a in angles:
            e = rng.uniform(0.2, 0.9)
            mu = rng.uniform(0.0, 0.5)
            cap = rng.uniform(0.0, 1.0)
            rows.append(
                (
                    "rough",
                    v,
                    a,
                    math.nan if rng.random() < nan_share else e,
                    rng.uniform(0.001, 0.05),
                    mu,
                    rng.uniform(0.001, 0.05),
                    cap,
                    max(0.0, cap - 0.05),
                    min(1.0, cap + 0.05),
                )
            )
    cols = SUMMARY_COLUMNS
    return pd.DataFrame(rows, columns=cols)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n_speeds=st.integers(1, 4),
    n_angles=st.integers(1, 4),
    seed=st.integers(0, 2**31),
    nan_share=st.sampled_from([0.0, 0.2]),
    data=st.data(),
)
def test_point_recipe_is_compare(n_speeds, n_angles, seed, nan_share, data):
    """PointRecipe against compare (the oracle), bit for bit: exact sweep
    points, points between them in speed, in angle or in both, points outside
    the sweep, corners without a value, every statistic kind, and summaries of
    other values of the same sweep (a calibration's runs)."""
    rng = np.random.default_rng(seed)
    speeds = np.sort(rng.choice(np.arange(1, 40) * 0.25, n_speeds, replace=False))
    angles = np.sort(rng.choice(np.arange(1, 18) * 5.0, n_angles, replace=False))
    s0 = _random_summary(rng, speeds, angles, nan_share)
    rows = []
    for _ in range(data.draw(st.integers(1, 8))):
        # a sweep value, or one between (or beside) them, on each axis
        v = data.draw(st.sampled_from([*speeds.tolist(), float(speeds.mean()) + 0.01]))
        a = data.draw(st.sampled_from([*angles.tolist(), float(angles.mean()) + 0.3]))
        stat = data.draw(st.sampled_from(["e", "mu", "capture_fraction"]))
        rows.append(("rough", v, a, stat, 0.5, 0.02))
    exp = exp_table(rows)
    recipe = PointRecipe(s0, exp)
    for s in (s0, _random_summary(rng, speeds, angles, nan_share)):
        want = compare(s, exp)
        m, se = recipe(s)
        np.testing.assert_array_equal(m, want["sim_mean"].to_numpy(float))
        np.testing.assert_array_equal(se, want["sim_se"].to_numpy(float))


def test_point_recipe_refuses_another_sweep(summary):
    exp = exp_table([("rough", 1.0, 20.0, "e", 0.7, 0.02)])
    recipe = PointRecipe(summary, exp)
    m, _ = recipe(summary)
    assert m[0] == pytest.approx(0.70)  # halfway between 0.80 and 0.60
    with pytest.raises(ValueError, match="another sweep"):
        recipe(summary.iloc[::-1])
    with pytest.raises(ValueError):  # compare's own refusal
        PointRecipe(summary, exp_table([("glass", 1.0, 20.0, "e", 0.7, 0.02)]))


def test_point_recipe_between_speeds_and_angles():
    """A point inside a cell of the speed-angle grid: the bilinear mean of its
    four corners, written out here."""
    rows = [
        ("rough", v, a, e, 0.01, 0.1, 0.01, 0.5, 0.4, 0.6)
        for (v, a, e) in [
            (1.0, 10.0, 0.8),
            (1.0, 30.0, 0.6),
            (2.0, 10.0, 0.7),
            (2.0, 30.0, 0.4),
        ]
    ]
    cols = SUMMARY_COLUMNS
    s = pd.DataFrame(rows, columns=cols)
    exp = exp_table([("rough", 1.25, 25.0, "e", 0.6, 0.02)])
    m, se = PointRecipe(s, exp)(s)
    ws, wa = 0.75, 0.25  # weights of speed 1 and of angle 10
    want = ws * wa * 0.8 + ws * (1 - wa) * 0.6 + (1 - ws) * wa * 0.7
    want += (1 - ws) * (1 - wa) * 0.4
    assert m[0] == pytest.approx(want, rel=1e-14)
    assert se[0] == pytest.approx(
        0.01
        * math.sqrt(
            (ws * wa) ** 2
            + (ws * (1 - wa)) ** 2
            + ((1 - ws) * wa) ** 2
            + ((1 - ws) * (1 - wa)) ** 2
        ),
        rel=1e-14,
    )
