"""A user's own study runs to the end: any scenario that passes validation gives
exit 0 with summary.csv, results.nc, capture_speed.csv, the figures and report.html,
consistent with each other, and no checkpoint left behind.

Random valid scenarios come from :func:`strategies.studies`; the default suite runs
a few small examples (derandomized: the same examples every run), ``-m slow`` many
more.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from numpy.testing import assert_allclose
from strategies import studies

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from microimpact.cli import main
from microimpact.scenario.scenario import scenario_from_toml

CHECKPOINT = ".microimpact-checkpoint.npz"
_FAST = settings(
    max_examples=5,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
_SLOW = settings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


# ------------------------------------------------------------------ checks
def _between(lo, x, hi, what):
    lo, x, hi = (np.asarray(v, dtype=float) for v in (lo, x, hi))
    ok = np.isfinite(lo) & np.isfinite(x) & np.isfinite(hi)
    tol = 1e-12 + 1e-9 * np.abs(x)
    bad = ok & ((lo > x + tol) | (x > hi + tol))
    assert not bad.any(), f"{what}: interval excludes its estimate at rows " + str(
        np.flatnonzero(bad).tolist()
    )


def check_run(out: Path, scenario_path: Path, formats=None):
    """Every output of a completed run, and their consistency."""
    sc = scenario_from_toml(scenario_path)
    n_points = len(sc.surfaces) * len(sc.speeds_m_s) * len(sc.angles_deg)
    names = {p.name for p in out.iterdir()}
    assert CHECKPOINT not in names, "checkpoint left behind"
    assert {"summary.csv", "results.nc", "capture_speed.csv", "report.html"} <= names
    leftovers = [n for n in names if n.endswith((".tmp", ".part")) or "tmp" in n]
    assert not leftovers, leftovers

    s = pd.read_csv(out / "summary.csv")
    assert len(s) == n_points
    assert list(dict.fromkeys(s["surface"].astype(str))) == [
        x.name for x in sc.surfaces
    ]
    for c in s.columns:
        if c.endswith("_fraction") or c in ("capture_ci_low", "capture_ci_high"):
            v = s[c].to_numpy(dtype=float)
            v = v[np.isfinite(v)]
            assert ((v >= 0) & (v <= 1)).all(), c
    assert (s["n"] >= 1).all()
    assert (s["n_impacts"] <= s["n"]).all() and (
        s["n_rebounds"] <= s["n_impacts"]
    ).all()
    for m, lo, hi in (
        ("capture_fraction", "capture_ci_low", "capture_ci_high"),
        ("e_mean", "e_ci_low", "e_ci_high"),
        ("e_rebound_mean", "e_rebound_ci_low", "e_rebound_ci_high"),
        ("mu_mean", "mu_ci_low", "mu_ci_high"),
    ):
        _between(s[lo], s[m], s[hi], m)

    import xarray as xr

    with xr.open_dataset(out / "results.nc") as ds:
        dims = list(ds["capture_fraction"].dims)
        assert [ds.sizes[d] for d in dims] == [
            len(sc.surfaces),
            len(sc.speeds_m_s),
            len(sc.angles_deg),
        ]
        for c in s.columns:
            if c in dims or c not in ds:
                continue
            assert_allclose(
                ds[c].values.ravel(), s[c].to_numpy(dtype=float), rtol=1e-12, err_msg=c
            )

    cs = pd.read_csv(out / "capture_speed.csv")
    n_curves = len(sc.surfaces) * len(dict.fromkeys(sc.angles_deg))
    assert len(cs) == n_curves * len(sc.capture_quantiles)
    _between(cs["speed_ci_low"], cs["speed_m_s"], cs["speed_ci_high"], "capture speed")
    refused = ~np.isfinite(cs["speed_m_s"].to_numpy(dtype=float))
    if "note" in cs:  # a refused estimate says why
        assert (
            cs.loc[refused, "note"]
            .fillna("")
            .astype(str)
            .str.strip()
            .astype(bool)
            .all()
        )

    # figures: the rules of docs/outputs.md, in every requested format
    if formats is None:
        raw = tomllib.loads(scenario_path.read_text(encoding="utf-8"))
        formats = tuple(raw.get("outputs", {}).get("figures") or ("png", "pdf"))
    stems = {p.stem for p in out.iterdir() if p.suffix[1:] in formats}
    for fmt in formats:
        assert stems == {p.stem for p in out.glob(f"*.{fmt}")}, fmt
    speeds, angles = set(sc.speeds_m_s), set(sc.angles_deg)
    assert ("capture" in stems) == (len(speeds) >= 2 and 90.0 in angles)
    assert ("coefficients" in stems) == (len(angles) >= 2)
    assert "size_distribution" in stems
    rough = [x for x in sc.surfaces if not x.smooth]
    assert len([t for t in stems if t.startswith("angle_pdf_")]) <= len(rough)

    html = (out / "report.html").read_text(encoding="utf-8")
    assert html.rstrip().endswith("</html>")
    assert "Capture speed" in html and "Summary" in html
    n_img = len(re.findall(r'<img src="data:image/png;base64,', html))
    assert n_img >= len(stems)
    return s


def _run(study, tmp: Path, *extra):
    folder = Path(tempfile.mkdtemp(dir=tmp))
    path = study.write(folder)
    out = folder / "out"
    rc = main(["run", str(path), "--out", str(out), "--quiet", *extra])
    plt.close("all")
    return rc, path, out


# ------------------------------------------------------------------ tests
@_FAST
@given(study=studies(max_speeds=12, max_angles=6, budget=6_000))
def test_own_study_runs_to_the_end(study, tmp_path_factory):
    _runs_to_the_end(study, tmp_path_factory)


@pytest.mark.slow
@_SLOW
@given(study=studies())
def test_own_study_runs_to_the_end_many(study, tmp_path_factory):
    _runs_to_the_end(study, tmp_path_factory)


def _runs_to_the_end(study, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("own")
    rc, path, out = _run(study, tmp)
    assert rc == 0, study.toml
    check_run(out, path)
    shutil.rmtree(path.parent)


_ISSUE = """\
name = "own"
seed = 7
samples = {samples}

[particles]
distribution = "lognormal"
median_um = 10
geometric_std = 1.5

[coefficients]
k1 = 4.0
k2 = 0.05
v_c = {{ law = "power", a_m_s = 0.5, b = -1.2, d_ref_um = 10 }}

[sweep]
speed_m_s = {speeds}
"""


@pytest.mark.parametrize(
    "speeds, samples",
    [
        ("[0.3, 0.8]", 400),  # the issue's study
        ("[0.001, 1000.0]", 50),  # all captured, then none
        ("[0.5, 0.5001]", 3),  # tiny sample: the interval is open or refused
        ("[0.01, 0.02]", 200),  # all captured: no crossing
    ],
)
def test_the_issue_study(tmp_path, speeds, samples):
    from strategies import Study

    study = Study(_ISSUE.format(samples=samples, speeds=speeds))
    rc, path, out = _run(study, tmp_path)
    assert rc == 0
    check_run(out, path)


def test_console_script_smoke(tmp_path):
    """The installed ``microimpact`` command, as a user runs it."""
    path = tmp_path / "study.toml"
    path.write_text(_ISSUE.format(samples=200, speeds="[0.2, 0.4, 0.8]"))
    exe = Path(sys.executable).with_name("microimpact")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "microimpact.cli"]
    out = tmp_path / "out"
    proc = subprocess.run(
        [*cmd, "run", str(path), "--out", str(out), "--quiet", "--formats", "png"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    check_run(out, path, formats=("png",))


def test_opened_result_gives_the_same_figures_and_report(tmp_path):
    """A result opened from results.nc draws the same figures (same stems, input
    figures included) and a report with the same tables as the fresh one."""
    from microimpact.engine.montecarlo import run
    from microimpact.engine.result import open_result
    from microimpact.pipeline.figures import figures_for_result
    from microimpact.pipeline.report import input_figures, write_report

    path = tmp_path / "s.toml"
    path.write_text(
        _ISSUE.format(samples=300, speeds="[0.2, 0.4, 0.8]").replace(
            "[sweep]",
            '[[surfaces]]\nname = "smooth-ish"\nkind = "normal"\nstd_deg = 8\n\n'
            '[[surfaces]]\nname = "rough"\nkind = "smooth"\n\n[sweep]\n'
            "angle_deg = [30, 85, 90]",
        )
    )
    fresh = run(scenario_from_toml(path), progress=False)
    fresh.to_files(tmp_path / "saved")
    opened = open_result(tmp_path / "saved")
    exp = tmp_path / "exp.csv"
    exp.write_text(
        "surface,speed_m_s,angle_deg,statistic,mean,half_width\n"
        "smooth-ish,0.4,30,e,0.5,0.1\n"
    )
    stems = []
    for k, res in enumerate((fresh, opened)):
        files = figures_for_result(
            res, tmp_path / f"f{k}", formats=("png",), experiments=exp
        )
        stems.append(sorted(p.stem for p in files))
        stems[-1] += sorted(n for n, _, f in input_figures(res))
        plt.close("all")
    assert stems[0] == stems[1]
    # smooth by structure: "rough" is the smooth one, "smooth-ish" the rough one
    assert "angle_pdf_smooth-ish" in stems[0] and "angle_pdf_rough" not in stems[0]
    assert "size_distribution" in stems[0] and "comparison" in stems[0]
    tables = []
    for k, res in enumerate((fresh, opened)):
        html = write_report(
            res,
            tmp_path / f"r{k}" / "report.html",
            experiments={res.scenario.name: exp},
        ).read_text(encoding="utf-8")
        # the tables, without the figures (PNG bytes differ only in rendering)
        tables.append(re.findall(r"<table.*?</table>", html, flags=re.S))
        assert html.count("<img ") == len(stems[0])
    assert len(tables[0]) == len(tables[1]) >= 4
    # the settings table (0) differs only where the stored JSON lost an infinity
    # (see test_opened_settings_keep_infinities); provenance (1): same run
    for a, b in zip(tables[0][2:], tables[1][2:], strict=True):
        assert a == b
    assert tables[0][1] == tables[1][1]


def test_opened_settings_keep_infinities(tmp_path):
    from microimpact.engine.montecarlo import run
    from microimpact.engine.result import open_result

    path = tmp_path / "s.toml"
    path.write_text(_ISSUE.format(samples=10, speeds="[0.2, 0.4]"))
    fresh = run(scenario_from_toml(path), progress=False)
    fresh.to_files(tmp_path)
    opened = open_result(tmp_path)
    assert opened.scenario.describe()["coefficients"]["friction"] == math.inf


def test_capture_marker_and_table_handle_open_and_refused(tmp_path):
    """plot_capture and the report's capture table take any capture_speed row:
    a NaN estimate (no marker, the note shown), NaN sides ("open"), and limits
    that would give a negative error bar."""
    from types import SimpleNamespace

    from microimpact.pipeline.report import _capture_table, summary_text
    from microimpact.plotting.results import plot_capture

    rows = pd.DataFrame(
        {
            "surface": ["a", "b", "c", "d"],
            "angle_deg": [90.0] * 4,
            "quantile": [0.5] * 4,
            "speed_m_s": [0.3, math.nan, 0.3, 0.3],
            "speed_ci_low": [math.nan, math.nan, 0.35, 0.2],  # c: excludes it
            "speed_ci_high": [0.4, math.nan, 0.5, math.nan],
            "method": ["probit-profile", "none", "x", "probit-profile"],
            "note": ["", "all captured: no crossing", "", ""],
        }
    )
    speeds = np.array([0.1, 0.2, 0.4, 0.8])
    summary = pd.DataFrame(
        {
            "surface": np.repeat(list("abcd"), 4),
            "speed_m_s": np.tile(speeds, 4),
            "angle_deg": 90.0,
            "n": 100,
            "n_impacts": 100,
            "capture_fraction": np.tile([0.9, 0.7, 0.4, 0.1], 4),
            "capture_ci_low": np.tile([0.8, 0.6, 0.3, 0.05], 4),
            "capture_ci_high": np.tile([0.95, 0.8, 0.5, 0.2], 4),
            "e_rebound_mean": 0.5,
            "e_rebound_ci_low": 0.4,
            "e_rebound_ci_high": 0.6,
        }
    )
    res = SimpleNamespace(
        summary=summary,
        scenario=SimpleNamespace(name="x", confidence=0.95, capture_quantiles=(0.5,)),
        capture_speed=lambda q=None: rows,
        confidence=0.95,
    )
    _ax_e, ax_c = plot_capture(res)
    labels = [" ".join(t.get_text().split()) for t in ax_c.get_legend().get_texts()]
    assert any("0.3 m s⁻¹ [open, 0.4]" in t for t in labels)
    assert any("no estimate" in t and "no crossing" in t for t in labels)
    assert any("[0.2, open]" in t for t in labels)
    for line in ax_c.get_lines():  # every segment drawn forwards
        x = np.asarray(line.get_xdata(), dtype=float)
        assert np.all(np.diff(x) >= 0)
    html = _capture_table(res)
    assert html.count("<tr>") == 1 + 4  # header + every row, none vanishes
    assert "0.3 [open, 0.4]" in html and "no estimate" in html
    assert "all captured: no crossing" in html
    plt.close("all")
    _ = summary_text  # the text version is checked through the CLI runs


def test_wilson_limits_stay_in_unit_interval():
    from microimpact.engine.statistics import wilson_interval

    lo, hi = wilson_interval(109, 109, 0.95)
    assert 0.0 <= lo <= hi <= 1.0


_ALL_SHADOWED = """\
seed = 1
samples = 100
[particles]
distribution = "monodisperse"
diameter_um = 10
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.3
[[surfaces]]
name = "steep"
kind = "angles"
angles_deg = [5.0]
[sweep]
speed_m_s = [0.1, 1.0]
angle_deg = [1.0, 90]
"""


@pytest.mark.parametrize("shadowing", ["reject", "weighted", "none"])
def test_all_shadowed_point_runs_to_the_end(tmp_path, shadowing):
    """A point at which no facet can be reached (every roughness angle >= the
    apparent angle) is reported, not an error: every sample shadowed, no impact."""
    import pandas as pd
    from strategies import Study

    text = f'shadowing = "{shadowing}"\n' + _ALL_SHADOWED  # a top-level key
    rc, path, out = _run(Study(text), tmp_path)
    assert rc == 0
    check_run(out, path)
    s = pd.read_csv(out / "summary.csv")
    blocked = s[np.isclose(s["angle_deg"], 1.0)]
    assert (blocked["shadowed_fraction"] == 1.0).all()
    assert (blocked["n_impacts"] == 0).all() and blocked[
        "capture_fraction"
    ].isna().all()
    normal = s[np.isclose(s["angle_deg"], 90.0)]
    assert (normal["shadowed_fraction"] == 0.0).all() and (
        normal["n_impacts"] > 0
    ).all()
