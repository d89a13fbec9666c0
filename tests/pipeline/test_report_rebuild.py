"""`microimpact report DIR` rebuilds the report a run wrote, section by section,
the comparison with experiments included (issue 33, item 3).

Oracle: the run's own report.html. Every section is compared as text, without
the embedded PNG bytes (rendering may differ) and the creation time.
"""

from __future__ import annotations

import re

import pandas as pd
import pytest

from microimpact.cli import main
from microimpact.io.experiments import read_experiments

SCENARIO = """\
name = "rebuild"
seed = 7
samples = 1500

[particles]
distribution = "normal"
mean_um = 52.8
std_um = 15.3

[coefficients]
k1 = 4.0
k2 = 0.05
v_c = { law = "power", a_m_s = 0.2, b = -1.5, d_ref_um = 52.8 }
friction = 0.15

[[surfaces]]
name = "rough"
kind = "normal"
std_deg = 10.0

[sweep]
speed_m_s = [0.2, 0.5]
angle_deg = [30, 85]

[outputs]
figures = ["png"]
experiments = "exp.csv"
"""

# six points, five of them far from the model (as in the case)
EXPERIMENTS = """\
# invented for this test
surface,speed_m_s,angle_deg,statistic,mean,ci_low,ci_high,n
rough,0.5,30,e,0.95,0.9,0.99,40
rough,0.5,85,e,0.2,0.15,0.25,40
rough,0.2,30,mu,0.9,0.85,0.95,
rough,0.2,85,capture_fraction,0.01,0.0,0.02,
rough,0.5,85,mu,-0.8,-0.9,-0.7,45
rough,0.5,30,capture_fraction,0.5,0.0,1.0,
"""


def _sections(html):
    html = re.sub(r'src="data:image/png;base64,[^"]+"', 'src="PNG"', html)
    html = re.sub(r"\d{4}-\d{2}-\d{2}T[0-9:.+]+", "TIME", html)
    html = re.sub(r"Run time</td><td>[^<]*", "Run time</td><td>", html)
    parts = re.split(r"(?=<h[23][ >])", html[html.index("<main>") :])
    return {re.match(r"<h[23][^>]*>(.*?)</h", p).group(1): p for p in parts[1:]}


@pytest.fixture
def run_folder(tmp_path):
    (tmp_path / "s.toml").write_text(SCENARIO)
    (tmp_path / "exp.csv").write_text(EXPERIMENTS)
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(out), "--quiet"]) == 0
    return out


def test_rebuilt_report_is_the_same_report(run_folder, tmp_path):
    before = (run_folder / "report.html").read_text(encoding="utf-8")
    assert "Comparison with experiments" in before
    assert (run_folder / "comparison.png").exists()
    (tmp_path / "exp.csv").unlink()  # the rebuild needs no original file
    assert main(["report", str(run_folder)]) == 0
    after = (run_folder / "report.html").read_text(encoding="utf-8")
    a, b = _sections(before), _sections(after)
    assert list(a) == list(b)
    assert "Comparison with experiments" in a
    for title in a:
        assert a[title] == b[title], title
    assert (run_folder / "comparison.png").exists()


def test_the_kept_experiments_read_back_the_same(run_folder, tmp_path):
    """experiments.csv, the run's copy, gives the same means, intervals and
    standard errors as the original file."""
    cols = [
        "surface",
        "speed_m_s",
        "angle_deg",
        "statistic",
        "mean",
        "ci_low",
        "ci_high",
        "se",
        "n",
        "confidence",
    ]
    orig = read_experiments(tmp_path / "exp.csv")[cols]
    kept = read_experiments(run_folder / "experiments.csv")[cols]
    pd.testing.assert_frame_equal(orig, kept)


def test_explicit_experiments_replace_the_runs(run_folder, tmp_path):
    first = _sections((run_folder / "report.html").read_text(encoding="utf-8"))
    assert first["Comparison with experiments"].count("<tr") == 7  # six points
    other = tmp_path / "other.csv"
    other.write_text(
        "surface,speed_m_s,angle_deg,statistic,mean,half_width\n"
        "rough,0.5,30,e,0.5,0.1\n"
    )
    assert main(["report", str(run_folder), "--experiments", str(other)]) == 0
    html = (run_folder / "report.html").read_text(encoding="utf-8")
    sec = _sections(html)["Comparison with experiments"]
    assert sec.count("<tr") == 2  # one point compared now (header row + one)


def test_report_counts_only_compared_points(tmp_path):
    """A point outside the sweep is 'not compared' in the report's table and is
    not counted among the points that disagree (issue 33)."""
    from microimpact.engine.result import open_result
    from microimpact.pipeline.report import write_report

    (tmp_path / "s.toml").write_text(SCENARIO.replace('experiments = "exp.csv"\n', ""))
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(out), "--quiet"]) == 0
    exp = tmp_path / "e.csv"
    exp.write_text(
        "surface,speed_m_s,angle_deg,statistic,mean,half_width\n"
        "rough,0.5,30,e,0.95,0.01\n"  # compared, far off: disagrees
        "rough,3.0,30,e,0.5,0.1\n"  # outside the swept speeds: not compared
    )
    res = open_result(out)
    html = write_report(
        res, tmp_path / "r.html", experiments={res.scenario.name: exp}
    ).read_text(encoding="utf-8")
    sec = _sections(html)["Comparison with experiments"]
    assert "0 of 1 compared experimental points agree" in sec
    assert "1 not compared" in sec
    assert sec.count("not compared") >= 2  # the header and the row
