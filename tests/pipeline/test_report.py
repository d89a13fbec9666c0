"""Tests for microimpact.pipeline.report: the self-contained HTML report and text
summary."""

from __future__ import annotations

import base64
import os
import re
import shutil
import subprocess

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from engine_helpers import (
    FrozenDist,
    PowerCoefficients,
    normal_diameters,
    rough,
    scenario,
)

from microimpact.engine.montecarlo import run
from microimpact.pipeline.figures import figures_for_result
from microimpact.pipeline.report import summary_text, write_report
from microimpact.scenario.scenario import SurfaceVariant

DIAM = FrozenDist(normal_diameters().dist, label="test <b>bold</b>")


@pytest.fixture(scope="module")
def results():
    normal = scenario(
        name="normal",
        particles=DIAM,
        coefficients=PowerCoefficients(friction=0.15),
        speeds_m_s=(0.1, 0.2, 0.3, 1.0),
        angles_deg=(90,),
        seed=21,
        description="Normal impact & capture",
    )
    oblique = scenario(
        name="oblique",
        particles=DIAM,
        coefficients=PowerCoefficients(friction=0.15),
        speeds_m_s=(1.0,),
        angles_deg=(10, 45, 85),
        surfaces=(rough(), SurfaceVariant("smooth")),
        seed=22,
    )
    return run(normal, samples=800), run(oblique, samples=800)


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def report(results, tmp_path_factory):
    out = tmp_path_factory.mktemp("rep") / "report.html"
    exp = out.parent / "exp.csv"
    exp.write_text("speed_m_s,statistic,mean,half_width\n1.0,e,0.78,0.05\n")
    path = write_report(
        list(results),
        out,
        title="Report <script>alert(1)</script>",
        notes=["Note with <tags> & ampersands."],
        experiments={"normal": exp},
    )
    return path


def test_report_is_self_contained(report):
    html = report.read_text(encoding="utf-8")
    assert html.startswith("<!DOCTYPE html>")
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", html, re.I)
    assert "<script" not in html.lower()  # the title was escaped
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    assert "Note with &lt;tags&gt; &amp; ampersands." in html
    assert "test &lt;b&gt;bold&lt;/b&gt;" in html  # describe() text escaped
    assert "<link" not in html.lower()
    imgs = re.findall(r'<img src="([^"]+)"', html)
    assert len(imgs) >= 5  # capture, comparison, 2 angle figures, 2 distributions
    for uri in imgs:
        assert uri.startswith("data:image/png;base64,")
        assert base64.b64decode(uri.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"


def test_report_content_and_links(report, results):
    html = report.read_text(encoding="utf-8")
    for r in results:
        assert str(r.seed_entropy) in html
        assert f'href="{r.scenario.name}_summary.csv"' in html
        assert (report.parent / f"{r.scenario.name}_summary.csv").exists()
    assert "Normal impact &amp; capture" in html
    assert "Capture speed" in html and "Comparison with experiments" in html
    assert "numpy" in html and "Run time" in html
    # no temporary files left behind
    assert not [p for p in report.parent.iterdir() if p.name.startswith(".")]


def test_saved_figures_are_reused(results, tmp_path):
    normal = results[0]
    files = figures_for_result(normal, tmp_path / "figs", formats=("png", "pdf"))
    png = (tmp_path / "figs" / "capture.png").read_bytes()
    out = write_report(
        [normal],
        tmp_path / "r.html",
        extra_figures={"normal": files},
        csv_paths=[tmp_path / "figs" / "summary.csv"],
    )
    html = out.read_text(encoding="utf-8")
    assert base64.b64encode(png).decode("ascii") in html
    assert 'href="figs/summary.csv"' in html
    assert "Additional figures" not in html


def test_extra_figure_errors(results, tmp_path):
    with pytest.raises(ValueError, match="PNG"):
        write_report(
            [results[0]], tmp_path / "r.html", extra_figures={"x": tmp_path / "a.pdf"}
        )
    with pytest.raises(TypeError, match="extra_figures"):
        write_report([results[0]], tmp_path / "r.html", extra_figures=[42])
    with pytest.raises(TypeError, match="results"):
        write_report([], tmp_path / "r.html")
    with pytest.raises(ValueError, match="csv_paths"):
        write_report([results[0]], tmp_path / "r.html", csv_paths=["a", "b"])
    assert not (tmp_path / "r.html").exists()


def test_summary_text(results):
    normal = results[0]
    text = summary_text(normal)
    assert text.startswith("# normal")
    assert f"seed entropy: {normal.seed_entropy}" in text
    assert "numpy" in text
    assert "800" in text and "±" in text
    s = normal.summary
    last = s.iloc[-1]
    assert f"{last['e_rebound_mean']:.3g} ± {last['e_rebound_se']:.2g}" in text
    assert "capture speed" in text
    with pytest.raises(TypeError, match="SimulationResult"):
        summary_text(object())


def _chromium():
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


def _need_chromium():
    """Chromium's path; in CI (CI=true, where .ci/run installs it) a missing
    Chromium fails the test instead of skipping it."""
    exe = _chromium()
    if exe is None:
        if os.environ.get("CI") == "true":
            pytest.fail("CI: Chromium is not installed (.ci/run installs chromium)")
        pytest.skip("Chromium is not installed (chromium or chromium-browser)")
    return exe


def _chromium_cmd(exe, tmp_path, *args):
    return [
        exe,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={tmp_path / 'profile'}",
        *args,
    ]


def test_reproduction_report_as_chromium_renders_it(tmp_path):
    """What a reader sees (the DOM as Chromium renders it, --dump-dom): the
    statements table with a verdict per evidence statement, the inputs apart,
    and no Python artefact in the text (issue 33, item 7)."""
    from html.parser import HTMLParser

    from microimpact.analysis.robustness import robustness_study
    from microimpact.analysis.statements import STATEMENTS
    from microimpact.scenario import PAPER_PRESETS, load_preset

    exe = _need_chromium()
    results = [run(load_preset(n), samples=300) for n in PAPER_PRESETS]
    study = robustness_study(2, 1000, speeds_m_s=(1.0,), shadowing=("reject",))
    page = write_report(results, tmp_path / "report.html", statements=study)
    cmd = _chromium_cmd(exe, tmp_path, "--dump-dom", page.resolve().as_uri())
    try:
        done = subprocess.run(cmd, capture_output=True, timeout=90, check=False)
    except subprocess.TimeoutExpired:
        pytest.fail("headless Chromium did not finish within 90 s")
    dom = done.stdout.decode("utf-8", errors="replace")
    assert '<table class="statements">' in dom, done.stderr[-2000:]

    class Text(HTMLParser):
        def __init__(self):
            super().__init__()
            self.parts, self.skip = [], 0

        def handle_starttag(self, tag, attrs):
            self.skip += tag in ("style", "script")

        def handle_endtag(self, tag):
            self.skip -= tag in ("style", "script")

        def handle_data(self, data):
            if not self.skip:
                self.parts.append(data)

    parser = Text()
    parser.feed(dom)
    text = " ".join(parser.parts)
    table = dom[dom.index('<table class="statements">') :]
    table = table[: table.index("</table>")]
    evidence = [s for s in STATEMENTS if s.kind == "evidence"]
    assert table.count("<tr") == len(evidence) + 1
    for s in evidence:
        assert s.reading.split(" ")[0] in table
    assert '<table class="inputs">' in dom
    for artefact in (r"\bNone\b", r"[{}]", r"\bnan\b", r"\binf\b", r"sha256"):
        assert not re.search(artefact, text), artefact


def test_report_renders_in_headless_chromium(report, tmp_path):
    exe = _need_chromium()
    shot = tmp_path / "shot.png"
    cmd = _chromium_cmd(
        exe,
        tmp_path,
        f"--screenshot={shot}",
        "--window-size=1280,2000",
        report.resolve().as_uri(),
    )
    try:
        subprocess.run(cmd, capture_output=True, timeout=90, check=False)
    except subprocess.TimeoutExpired:
        pytest.fail("headless Chromium did not finish within 90 s")
    assert shot.exists()
    img = plt.imread(shot)
    assert img.shape[:2] == (2000, 1280)
    # not a blank page: many distinct grey levels (text, tables, figures)
    grey = np.round(img[..., :3].mean(axis=2) * 255).astype(int)
    assert np.unique(grey).size > 50
    assert grey.std() > 10


def test_figures_saved_without_png_are_drawn(results, tmp_path):
    normal = results[0]
    files = figures_for_result(normal, tmp_path / "figs", formats=("svg",))
    assert files and all(p.suffix == ".svg" for p in files)
    html = write_report(
        [normal], tmp_path / "r.html", extra_figures={"normal": files}
    ).read_text(encoding="utf-8")
    imgs = re.findall(r'<img src="data:image/png;base64,', html)
    # the capture figure and the diameter distribution, drawn by the report
    assert len(imgs) == len(files) + 1 and "Particle diameter distribution" in html
    # an empty group: no figures for that result (the CLI's --no-figures)
    html = write_report(
        [normal], tmp_path / "r.html", extra_figures={"normal": []}
    ).read_text(encoding="utf-8")
    assert "<img " not in html
    assert plt.get_fignums() == []


def test_input_figure_names_are_file_names(results):
    """Input figures come from the Dataset alone: one per rough surface (by the
    ``surface_is_smooth`` flag, not the name), names safe for files."""
    from types import SimpleNamespace

    from microimpact.pipeline.report import input_figures

    ds = results[1].dataset
    q = ds["roughness_angle_quantile"].values
    rough_row = q[~ds["surface_is_smooth"].values.astype(bool)][0]
    names = ["x/y", "x_y", "../../esc", "smooth-looking", "rough"]
    fake = ds.isel(surface=[0] * len(names)).assign_coords(surface=names)
    fake["roughness_angle_quantile"] = (
        ("surface", "probability"),
        np.stack([rough_row] * 4 + [np.full_like(rough_row, np.nan)]),
    )
    # "rough" is flagged smooth (structure wins over the name): no figure
    fake["surface_is_smooth"] = ("surface", np.array([0, 0, 0, 0, 1], dtype=np.int8))
    fake = fake.drop_vars("diameter_quantile")
    out = input_figures(SimpleNamespace(dataset=fake, scenario=results[1].scenario))
    assert [name for name, _, _ in out] == [
        "angle_pdf_x_y",
        "angle_pdf_x_y_2",
        "angle_pdf_______esc",
        "angle_pdf_smooth-looking",
    ]
    # without the input variables (an old file): no input figures, no error
    bare = ds.drop_vars(["diameter_quantile", "roughness_angle_quantile"])
    assert input_figures(SimpleNamespace(dataset=bare, scenario=None)) == []
