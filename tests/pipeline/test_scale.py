"""Issue 22 (item 4): outputs that scale with the study, not with the sweep.

The report and the terminal show capped tables (the rest in summary.csv,
capture_speed.csv, results.nc), the coefficients figures draw a bounded number of
speeds, the capture speed is estimated once per result, and the report's size and
memory do not grow with the sweep. The full 10^6-point study is the slow test at
the end (and benchmarks/study_scale.py)."""

from __future__ import annotations

import re
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import microimpact as mi
from microimpact.cli import _common
from microimpact.engine import result as result_module
from microimpact.pipeline.figures import figure_caption, result_figures
from microimpact.pipeline.report import TEXT_ROWS, summary_text, write_report
from microimpact.pipeline.rows import MAX_TABLE_ROWS, capture_rows, summary_rows
from microimpact.plotting.results import MAX_SPEED_CURVES, plot_coefficients_vs_angle

ROOT = Path(__file__).resolve().parents[2]


def _oblique(speeds, angles, surfaces=2):
    """The oblique preset (Formica, then smooth) over the given sweep, with its
    first `surfaces` surfaces."""
    s = mi.Scenario.from_preset("sst76-formica-oblique")
    return s.with_options(
        speeds_m_s=tuple(speeds),
        angles_deg=tuple(angles),
        surfaces=s.surfaces[:surfaces],
    )


@pytest.fixture(scope="module")
def wide():
    """1 surface x 30 speeds x 150 angles = 4,500 points, 150 capture curves."""
    s = _oblique(np.geomspace(0.05, 3.0, 30), np.linspace(5, 90, 150), 1)
    return mi.run(s, samples=60, seed=3, progress=False)


# ------------------------------------------------------------------ row choice
def _synthetic(S=2, V=50, A=40):
    """A grid-ordered summary whose 50 % crossing on curve (s, a) is at speed index
    c(a) = (7 a) % V by construction, with one planted maximum of e."""
    s, v, a = np.meshgrid(np.arange(S), np.arange(V), np.arange(A), indexing="ij")
    cross = (7 * a) % V
    cf = np.clip(0.5 - 0.02 * (v - cross) + 0.001, 0.0, 1.0)  # nearest 0.5 at cross
    e = np.full(s.shape, 0.5)
    e[1, 3, 5] = 0.9  # the planted extreme
    return pd.DataFrame(
        {
            "surface": np.array(["a", "b"])[s.ravel()],
            "speed_m_s": (0.1 * (1 + v)).ravel().astype(float),
            "angle_deg": (5.0 + a).ravel().astype(float),
            "capture_fraction": cf.ravel(),
            "e_rebound_mean": e.ravel(),
            "mu_mean": np.zeros(s.size),
        }
    ), cross


def test_summary_rows_choose_crossings_extremes_and_a_regular_subset():
    table, cross = _synthetic()
    rows, why = summary_rows(table, limit=60)
    assert len(rows) <= 60 and np.all(np.diff(rows) > 0)
    assert set(why) == set(rows.tolist())
    V, A = 50, 40
    crossings = {(s * V + cross[s, 0, a]) * A + a for s in range(2) for a in range(A)}
    shown = [r for r, w in why.items() if "50 %" in w]
    assert shown and set(shown) <= crossings  # each one a true crossing point
    assert (1 * V + 3) * A + 5 in rows  # the planted extreme
    assert 0 in rows and len(table) - 1 in rows  # the regular subset's ends
    small, none = summary_rows(table.head(60), limit=60)
    assert small.tolist() == list(range(60)) and none == {}


def test_capture_rows_are_evenly_spaced():
    assert capture_rows(range(10), 20).tolist() == list(range(10))
    assert capture_rows(range(1000), 5).tolist() == [0, 250, 500, 749, 999]


# ------------------------------------------------------------------ report
def _table_rows(html_text, heading):
    part = html_text.split(f"<h3>{heading}</h3>", 1)[1].split("</table>", 1)[0]
    return part.count("<tr>") - 1  # less the header row


def test_report_tables_are_capped_and_say_where_the_rest_is(wide, tmp_path):
    path = write_report(wide, tmp_path / "r.html", extra_figures={wide.name: []})
    text = path.read_text()
    n_sum = _table_rows(text, "Summary")
    n_cap = _table_rows(text, "Capture speed")
    assert n_sum <= MAX_TABLE_ROWS and n_cap == MAX_TABLE_ROWS
    assert f"{n_sum:,} of 4,500 sweep points shown" in text
    assert f"the other {4500 - n_sum:,} are in" in text
    assert f"{MAX_TABLE_ROWS} of 150 capture curves shown" in text
    assert "capture_speed.csv" in text and "results.nc" in text


def test_summary_text_is_capped(wide):
    text = summary_text(wide)
    table = [ln for ln in text.splitlines() if ln.startswith("| ")]
    assert len(table) - 1 <= TEXT_ROWS  # less the header
    assert "of 4,500 sweep points shown" in text
    bullets = [ln for ln in text.splitlines() if "capture speed, " in ln]
    assert len(bullets) == TEXT_ROWS
    assert f"{TEXT_ROWS} of 150 capture curves shown" in text


def test_the_terminal_prints_a_capped_capture_table(wide, capsys):
    _common.print_capture(wide)
    lines = capsys.readouterr().out.splitlines()
    assert len([ln for ln in lines if "capture" in ln and "deg" in ln]) == 20
    assert lines[-1].strip().startswith("... 20 of 150 capture curves shown")


def test_the_capture_speed_is_estimated_once_per_result(wide, monkeypatch, tmp_path):
    calls = []
    real = result_module.capture_speed

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(result_module, "capture_speed", counting)
    res = mi.SimulationResult.from_dataset(wide.dataset)  # a fresh cache
    first = res.capture_speed()
    first.loc[0, "speed_m_s"] = -1.0  # a caller's edit does not reach the cache
    again = res.capture_speed()
    _common.print_capture(res)
    summary_text(res)
    assert len(calls) == 1
    assert again["speed_m_s"].iloc[0] != -1.0


def _traced_report(result, path):
    """Peak traced allocation [B] and time [s] of writing `result`'s report (no
    figures; the CSV linked, not copied, as Study.write does)."""
    tracemalloc.start()
    t = time.perf_counter()
    try:
        write_report(
            result,
            path,
            extra_figures={result.name: []},
            csv_paths=[path.with_suffix(".csv")],
        )
        return tracemalloc.get_traced_memory()[1], time.perf_counter() - t
    finally:
        tracemalloc.stop()


def test_report_size_memory_and_time_do_not_grow_with_the_sweep(tmp_path):
    """10^3 against 10^5 points (100x): the page keeps its size, and the report
    allocates what the capped tables need plus a few whole columns, not strings
    for every point (before: a 19 MB page at 10^5, ~200 B per point)."""
    s = mi.Scenario.from_preset("sst76-formica-oblique")
    results = [
        mi.run(
            _oblique(np.geomspace(0.05, 3.0, v), np.linspace(5, 90, 50), 1),
            samples=5,
            seed=1,
            progress=False,
        )
        for v in (20, 2000)
    ]
    small, big = results
    assert len(big.summary) == 100_000
    for r in results:  # built beforehand: the arrays, not the report
        r.summary, r.capture_speed()
    write_report(small, tmp_path / "warm.html", extra_figures={s.name: []})
    peak_s, _ = _traced_report(small, tmp_path / "s.html")
    peak_b, secs = _traced_report(big, tmp_path / "b.html")
    size_s = (tmp_path / "s.html").stat().st_size
    size_b = (tmp_path / "b.html").stat().st_size
    assert size_b < 1.5 * size_s and size_b < 200_000
    column = 8 * len(big.summary)  # bytes of one float column
    assert peak_b - peak_s < 8 * column, (peak_s, peak_b)
    assert secs < 5


# ------------------------------------------------------------------ figures
def test_coefficients_figures_draw_a_bounded_subset_of_speeds():
    speeds = np.geomspace(0.3, 3.0, 200)
    res = mi.run(
        _oblique(speeds, (10.0, 45.0, 85.0)), samples=40, seed=2, progress=False
    )
    axs = plot_coefficients_vs_angle(res, relative=False)
    try:
        curves = [ln for ln in axs[0].get_lines() if len(ln.get_xdata()) == 3]
        assert len(curves) == 2 * MAX_SPEED_CURVES  # two surfaces
        (bar,) = [a for a in axs[0].figure.axes if a.get_label() == "<colorbar>"]
        lo, hi = bar.get_ylim()  # the colour bar spans every swept speed
        assert lo == pytest.approx(speeds[0]) and hi == pytest.approx(speeds[-1])
        assert f"({MAX_SPEED_CURVES} of 200 drawn)" in bar.get_ylabel()
    finally:
        plt.close(axs[0].figure)
    caption = figure_caption("coefficients", res)
    assert f"{MAX_SPEED_CURVES} of the 200 swept speeds are drawn" in caption
    t = time.perf_counter()
    for _, _, fig in result_figures(res):
        plt.close(fig)
    assert time.perf_counter() - t < 20


# ------------------------------------------------------------------ at scale
_TOML = """name = "scale-1e6"
seed = 1
samples = 100
reference_angle_deg = 85.0

[particles]
distribution = "normal"
mean_um = 52.8
std_um = 15.3

[coefficients]
k1 = 4.0
k2 = {{ law = "power", a_m_s = 0.05, b = -1.58, d_ref_um = 52.8 }}
v_c = {{ law = "power", a_m_s = 0.20, b = -1.58, d_ref_um = 52.8 }}
p = 1.0
q = 1.0
friction = 0.15

[[surfaces]]
name = "formica"
kind = "angles"
file = "{angles}"

[sweep]
speed_m_s = {{ start = 0.05, stop = 5, num = 1000, spacing = "log" }}
angle_deg = {{ start = 5, stop = 90, num = 1000 }}

[outputs]
figures = ["png"]
"""


@pytest.mark.slow
def test_a_million_point_study_with_figures_and_report_in_ten_minutes(tmp_path):
    """The issue's criterion: 10^6 points at 100 impacts, one worker, figures and
    report, within 10 minutes and a report under 20 MB (before: a 181 MB page,
    6.2 GB peak RSS)."""
    angles = ROOT / "src/microimpact/scenario/presets/formica_angles_20um.csv"
    toml = tmp_path / "scale.toml"
    toml.write_text(_TOML.format(angles=angles.as_posix()))
    out = tmp_path / "out"
    t = time.perf_counter()
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "microimpact.cli",
            "run",
            str(toml),
            "--out",
            str(out),
            "--workers",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=ROOT,
    )
    seconds = time.perf_counter() - t
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert seconds < 600
    assert (out / "report.html").stat().st_size < 20e6
    with open(out / "summary.csv") as f:
        assert sum(1 for _ in f) == 1 + 10**6  # every point kept in the CSV
    capture_lines = [ln for ln in proc.stdout.splitlines() if "% capture" in ln]
    assert len(capture_lines) <= 20
    assert re.search(r"of 1,000 capture curves shown", proc.stdout)


@settings(max_examples=40, deadline=None)
@given(
    shape=st.tuples(st.integers(1, 3), st.integers(1, 30), st.integers(1, 30)),
    limit=st.integers(1, 150),
    seed=st.integers(0, 2**32 - 1),
)
def test_property_summary_rows_are_valid_and_capped(shape, limit, seed):
    """Any grid, any cap, any capture fractions (NaN included): the chosen rows
    are increasing row numbers of the table, at most `limit` of them (all of them
    when the table fits), each with its reason."""
    rng = np.random.default_rng(seed)
    S, V, A = shape
    s, v, a = np.meshgrid(np.arange(S), np.arange(V), np.arange(A), indexing="ij")
    cf = rng.random(s.size)
    cf[rng.random(s.size) < 0.2] = np.nan
    table = pd.DataFrame(
        {
            "surface": np.array(["x", "y", "z"])[s.ravel()],
            "speed_m_s": 0.1 * (1.0 + v.ravel()),
            "angle_deg": 1.0 + a.ravel(),
            "capture_fraction": cf,
            "e_rebound_mean": rng.normal(size=s.size),
            "mu_mean": rng.normal(size=s.size),
        }
    )
    rows, why = summary_rows(table, limit)
    assert np.all(np.diff(rows) > 0) and rows.min() >= 0 and rows.max() < len(table)
    if len(table) <= limit:
        assert rows.tolist() == list(range(len(table))) and why == {}
    else:
        assert 0 < len(rows) <= limit and set(why) == set(rows.tolist())
