"""Tests for microimpact.io.experiments (experimental means with intervals)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from microimpact.errors import DataFormatError
from microimpact.io.experiments import (
    combine_experiments,
    read_experiments,
    write_experiments,
)

# Two-sided 95 % quantiles from printed tables (not recomputed by the code's path):
Z95 = 1.959963984540054  # standard normal
T95_DF9 = 2.262157162740992  # Student t, 9 degrees of freedom


def write(tmp_path, text, name="exp.csv"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_three_interval_forms(tmp_path):
    p = write(
        tmp_path,
        "# comment line\n"
        "\n"
        "speed_m_s,statistic,mean,ci_low,ci_high,half_width,std,n\n"
        "0.5,e,0.60,0.55,0.67,,,\n"
        "1.0,e,0.70,,,0.05,,\n"
        "1.5,e,0.75,,,,0.1,10\n",
    )
    t = read_experiments(p)
    assert list(t["line"]) == [4, 5, 6]
    assert_allclose(t["speed_m_s"], [0.5, 1.0, 1.5], rtol=0, atol=0)
    assert t["angle_deg"].isna().all()
    assert t["surface"].isna().all()
    # ci given: SE = width / (2 z)
    assert_allclose(t.loc[0, "se"], 0.12 / (2 * Z95), rtol=1e-12)
    assert_allclose([t.loc[0, "ci_low"], t.loc[0, "ci_high"]], [0.55, 0.67], rtol=0)
    # half-width: symmetric interval, SE = h / z
    assert_allclose([t.loc[1, "ci_low"], t.loc[1, "ci_high"]], [0.65, 0.75], rtol=1e-12)
    assert_allclose(t.loc[1, "se"], 0.05 / Z95, rtol=1e-12)
    # std and n: Student-t interval
    se = 0.1 / math.sqrt(10)
    assert_allclose(t.loc[2, "se"], se, rtol=1e-12)
    assert_allclose(t.loc[2, "ci_high"] - 0.75, T95_DF9 * se, rtol=1e-9)
    assert_allclose(t["confidence"], 0.95, rtol=0)
    assert t.attrs["source"] == str(p)


def test_n_with_ci_uses_t_and_confidence_column(tmp_path):
    p = write(
        tmp_path,
        "angle_deg,surface,statistic,mean,ci_low,ci_high,n,confidence\n"
        "45,rough,mu_relative,0.1,0.0,0.2,10,0.95\n"
        "30,rough,mu,0.2,0.1,0.3,,0.6826894921370859\n",
    )
    t = read_experiments(p)
    assert list(t["surface"]) == ["rough", "rough"]
    assert_allclose(t.loc[0, "se"], 0.1 / T95_DF9, rtol=1e-9)
    # a 68.27 % normal interval is +- 1 SE
    assert_allclose(t.loc[1, "se"], 0.1, rtol=1e-9)


@pytest.mark.parametrize(
    ("text", "line", "field", "match"),
    [
        ("statistic,mean,ci_low,ci_high\ne,1,0,2\n", 1, "speed_m_s", "speed_m_s"),
        ("speed_m_s,mean,ci_low,ci_high\n1,1,0,2\n", 1, "statistic", "required"),
        ("speed_m_s,statistic,mean\n1,e,0.5\n", 1, "ci_low", "interval needs"),
        (
            "speed_m_s,statistic,mean,half_width\n1,ee,0.5,0.1\n",
            2,
            "statistic",
            "did you mean 'e'",
        ),
        (
            "speed_m_s,statistic,mean,half_width\nfast,e,0.5,0.1\n",
            2,
            "speed_m_s",
            "non-numeric value 'fast'",
        ),
        (
            "speed_m_s,statistic,mean,half_width\n-1,e,0.5,0.1\n",
            2,
            "speed_m_s",
            "speed > 0",
        ),
        (
            "angle_deg,statistic,mean,half_width\n95,e,0.5,0.1\n",
            2,
            "angle_deg",
            r"\(0, 90\]",
        ),
        (
            "speed_m_s,statistic,mean,ci_low,ci_high\n1,e,0.5,0.6,0.7\n",
            2,
            "ci_low",
            "does not contain the mean",
        ),
        (
            "speed_m_s,statistic,mean,ci_low,ci_high\n1,e,0.5,0.4,\n",
            2,
            "ci_high",
            "together",
        ),
        (
            "speed_m_s,statistic,mean,half_width,std\n1,e,0.5,,0.1\n",
            2,
            "ci_low",
            "no interval",
        ),
        ("speed_m_s,statistic,mean,std,n\n1,e,0.5,0.1,2.5\n", 2, "n", "integer >= 2"),
        (
            "speed_m_s,statistic,mean,half_width\n1,capture_fraction,50,1\n",
            2,
            "mean",
            "not a percentage",
        ),
        ("speed_m_s,statistic,mean,half_width\n1,e,,0.1\n", 2, "mean", "missing"),
        ("speed_m_s,statistic,mean,half_width\n1,e,nan,0.1\n", 2, "mean", "finite"),
        (
            "speed_m_s,angle_deg,statistic,mean,half_width\n,,e,0.5,0.1\n",
            2,
            "speed_m_s/angle_deg",
            "needs speed_m_s or angle_deg",
        ),
        (
            "speed_m_s,speed_m_s,statistic,mean,half_width\n1,1,e,0.5,0.1\n",
            1,
            None,
            "duplicate",
        ),
    ],
)
def test_errors_name_file_line_field(tmp_path, text, line, field, match):
    p = write(tmp_path, text)
    with pytest.raises(DataFormatError, match=match) as info:
        read_experiments(p)
    err = info.value
    assert err.source == str(p)
    assert err.line == line
    assert err.field == field
    assert str(p) in str(err)


def test_missing_empty_and_headeronly_files(tmp_path):
    with pytest.raises(DataFormatError, match="file not found"):
        read_experiments(tmp_path / "nope.csv")
    with pytest.raises(DataFormatError, match="no header"):
        read_experiments(write(tmp_path, "# only a comment\n"))
    with pytest.raises(DataFormatError, match="no data rows"):
        read_experiments(write(tmp_path, "speed_m_s,statistic,mean,half_width\n"))
    with pytest.raises(DataFormatError, match="directory"):
        read_experiments(tmp_path)


def test_combine_experiments(tmp_path):
    a = write(tmp_path, "speed_m_s,statistic,mean,half_width\n1,e,0.5,0.1\n", "a.csv")
    b = read_experiments(
        write(tmp_path, "angle_deg,statistic,mean,half_width\n10,mu,0.3,0.1\n", "b.csv")
    )
    t = combine_experiments([a, b])
    assert len(t) == 2
    assert list(t["statistic"]) == ["e", "mu"]
    assert np.isnan(t.loc[0, "angle_deg"]) and np.isnan(t.loc[1, "speed_m_s"])
    # a table made by hand (the four columns combine_experiments requires) gets
    # the speed, angle and surface columns, empty
    own = pd.DataFrame(
        {"statistic": ["e"], "mean": [0.5], "ci_low": [0.4], "ci_high": [0.6]}
    )
    alone = combine_experiments(own)
    assert np.isnan(alone.loc[0, "speed_m_s"]) and np.isnan(alone.loc[0, "angle_deg"])
    assert alone.loc[0, "surface"] is None
    assert combine_experiments(None) is None
    assert combine_experiments([]) is None
    with pytest.raises(TypeError, match="experiments"):
        combine_experiments([pd.DataFrame({"x": [1]})])


def test_scenario_experiments_are_explicit(tmp_path):
    """Experiments are passed explicitly: None means none, and the scenario's own
    ``experiments`` attribute (being removed from Scenario) is never read."""
    from types import SimpleNamespace

    from microimpact.io.experiments import scenario_experiments

    a = write(tmp_path, "speed_m_s,statistic,mean,half_width\n1,e,0.5,0.1\n", "a.csv")
    b = write(tmp_path, "angle_deg,statistic,mean,half_width\n10,mu,0.3,0.1\n", "b.csv")
    sc = SimpleNamespace(experiments=(a, b))
    assert scenario_experiments(sc) is None
    assert scenario_experiments(sc, None) is None
    assert scenario_experiments(object()) is None
    t = scenario_experiments(sc, [a, b])
    assert list(t["statistic"]) == ["e", "mu"]
    given = scenario_experiments(sc, b)
    assert list(given["statistic"]) == ["mu"]
    bad = write(tmp_path, "speed_m_s,statistic,mean,half_width\n1,e,x,0.1\n", "c.csv")
    with pytest.raises(DataFormatError, match=r"c\.csv:2: mean: non-numeric"):
        scenario_experiments(None, (a, bad))


def test_written_experiments_read_back_the_same(tmp_path):
    # the documented round trip: write_experiments writes what read_experiments
    # reads, to the same means, intervals and standard errors
    text = "speed_m_s,statistic,mean,half_width\n1,e,0.5,0.1\n2,e,0.4,0.05\n"
    table = read_experiments(write(tmp_path, text, "a.csv"))
    out = tmp_path / "back.csv"
    write_experiments(table, out, comment="from a.csv")
    assert out.read_text(encoding="utf-8").startswith("# from a.csv\n")
    back = read_experiments(out)
    for c in ("speed_m_s", "mean", "ci_low", "ci_high", "se"):
        assert_allclose(back[c], table[c], rtol=1e-12)
    assert list(back["statistic"]) == ["e", "e"]


def test_a_table_without_speed_or_angle_names_both(tmp_path):
    with pytest.raises(DataFormatError) as info:
        read_experiments(write(tmp_path, "statistic,mean,half_width\ne,0.5,0.1\n"))
    assert info.value.field == "speed_m_s"
    assert str(info.value).endswith(
        "exp.csv:1: speed_m_s: required column missing; header has ['statistic', "
        "'mean', 'half_width'], need speed_m_s and/or angle_deg."
    )
