"""microimpact.analysis.statements: the checkers decide on evidence built by hand (known
answers), the docs table and the report table come from the same rows."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from microimpact.analysis.statements import (
    SIMILAR_TOL,
    STATEMENTS,
    Evidence,
    _md,
    evaluate,
    parting_angle,
    skewness_se,
    statement_table_html,
)

ANGLES = np.arange(10.0, 95.0, 5.0)
DOCS = Path(__file__).resolve().parents[2] / "docs" / "presets.md"


def frame(surface, **cols):
    """A summary of one surface over ANGLES; columns given as arrays or scalars."""
    base = {
        "surface": surface,
        "angle_deg": ANGLES,
        "e_relative_se": 0.01,
        "mu_se": 0.005,
        "n_rebounds": 4000.0,
        "mu_p50": 0.0,
        "mu_mean": 0.5 - ANGLES / 200.0,
        "e_skewness": -1.0,
        "mu_skewness": 0.0,
    }
    base.update(cols)
    return pd.DataFrame(base)


def oblique(rough_e, smooth_e=None, **rough_cols):
    smooth_e = (
        -0.4 * np.clip((45 - ANGLES) / 35, 0, None) if smooth_e is None else smooth_e
    )
    r = frame("formica", e_relative=rough_e, **rough_cols)
    s = frame("smooth", e_relative=smooth_e, mu_mean=np.where(ANGLES <= 45, 0.15, 0.1))
    return Evidence(summaries={"sst76-formica-oblique": pd.concat([r, s])})


def held(ev, sid):
    return evaluate(ev)[sid]


def unity_curve(e10):
    # a smooth rise from 0 at 50 deg up to e10 at 10 deg
    return e10 * np.clip((50 - ANGLES) / 40, 0, None) ** 2


def test_toward_unity_known_answers():
    assert held(oblique(unity_curve(1.0)), "rough-e-toward-unity").held
    v = held(oblique(unity_curve(2.4)), "rough-e-toward-unity")
    assert not v.held and v.miss == pytest.approx(1.1)
    v = held(oblique(unity_curve(0.5)), "rough-e-toward-unity")
    assert not v.held and v.miss == pytest.approx(0.2)
    # a dip below 45 deg larger than 2 standard errors breaks "rises"
    e = unity_curve(1.0)
    e[ANGLES == 30] -= 0.2
    assert not held(oblique(e), "rough-e-toward-unity").held


def test_similar_then_differ_known_answers():
    smooth = np.zeros(ANGLES.size)
    rough = np.where(ANGLES <= 40, 0.2, 0.0)
    ev = oblique(rough, smooth)
    assert held(ev, "rough-smooth-similar-above-45").held
    assert parting_angle(ev) == 40.0
    rough = np.where(ANGLES <= 25, 0.2, 0.0)  # parts at 25 deg: too late
    v = held(oblique(rough, smooth), "rough-smooth-similar-above-45")
    assert not v.held and v.miss == pytest.approx(SIMILAR_TOL)
    # the tolerance is 0.05 (5 % of unity): 0.03 apart is similar, 0.07 apart differs
    assert SIMILAR_TOL == 0.05
    rough = np.where(ANGLES <= 40, 0.07, 0.03)
    assert held(oblique(rough, smooth), "rough-smooth-similar-above-45").held
    rough = np.where(ANGLES <= 60, 0.2, 0.0)  # already apart at 60 deg
    assert not held(oblique(rough, smooth), "rough-smooth-similar-above-45").held


def test_skewness_statements_known_answers():
    lim = 5 * skewness_se(4000)
    g_e = np.where(ANGLES == 10, -0.5, -2.0)
    g_mu = np.where(ANGLES == 10, 1.0, np.where(ANGLES == 85, -0.5, 0.0))
    ev = oblique(unity_curve(1.0), e_skewness=g_e, mu_skewness=g_mu, mu_mean=0.01)
    v = evaluate(ev)
    assert v["e_m-asymmetric-similar"].held
    assert v["mu_m-85-symmetric"].held and v["mu_m-10-skewed"].held
    # opposite signs: not similar; the miss is the distance to -lim at 10 deg
    g_e = np.where(ANGLES == 10, 0.3, -2.0)
    ev = oblique(unity_curve(1.0), e_skewness=g_e, mu_skewness=g_mu, mu_mean=0.01)
    v = held(ev, "e_m-asymmetric-similar")
    assert not v.held and v.miss == pytest.approx(0.3 + lim)
    # mu_m at 85 deg more skewed than at 10 deg, or off-centre: not held
    g_mu = np.where(ANGLES == 10, 0.5, np.where(ANGLES == 85, -0.8, 0.0))
    ev = oblique(unity_curve(1.0), e_skewness=g_e, mu_skewness=g_mu, mu_mean=0.01)
    assert not held(ev, "mu_m-85-symmetric").held
    ev = oblique(unity_curve(1.0), e_skewness=g_e, mu_skewness=g_mu * 0, mu_mean=0.2)
    assert not held(ev, "mu_m-85-symmetric").held
    assert not held(ev, "mu_m-10-skewed").held


def test_angle_and_height_statements():
    rng = np.random.default_rng(0)
    sym = Evidence(angles_deg=rng.normal(0, 12, 4000), height_std_um=45.0)
    sym.contact_length_um = 20.0
    assert not held(sym, "angles-asymmetric").held
    assert held(sym, "height-std").held
    skewed = Evidence(angles_deg=rng.gamma(2.0, 6.0, 4000) - 12.0, height_std_um=53.0)
    assert held(skewed, "angles-asymmetric").held
    v = held(skewed, "height-std")  # 45 +- 5 um: 53 misses by 3
    assert not v.held and v.miss == pytest.approx(3.0)


def test_missing_evidence_is_not_evaluated():
    v = evaluate(Evidence())
    assert v["rough-e-toward-unity"] is None
    assert v["capture-sst65"] is None
    assert v["eq9-example"].held  # needs no evidence: Eq. 9 through the engine


def test_ids_unique_and_every_input_explained():
    ids = [s.id for s in STATEMENTS]
    assert len(ids) == len(set(ids))
    for s in STATEMENTS:
        assert s.words and s.reading and s.where
        assert s.kind in ("evidence", "input")
        assert bool(s.input_because) == (s.kind == "input"), s.id
    # the three statements issue 29 added (N2, O9, O10)
    assert {
        "capture-sudden",
        "e_m-asymmetry-from-small-spheres",
        "e_m-asymmetry-all-angles",
    } <= set(ids)


def test_a_statement_that_cannot_be_evaluated_is_not_held():
    """A NaN never passes: mu_m at 10 deg with a NaN skewness (a smooth surface,
    where every rebound slides) made mu_m-85-symmetric hold through
    max(0.0, abs(g85) - abs(nan)) == 0.0 (issue 29)."""
    g_mu = np.where(ANGLES == 10, np.nan, np.where(ANGLES == 85, -0.1, 0.0))
    ev = oblique(unity_curve(1.0), mu_skewness=g_mu, mu_mean=0.01)
    v = held(ev, "mu_m-85-symmetric")
    assert not v.held and v.miss == np.inf
    # and any checker whose shortfall is NaN is not held, whatever it says
    from dataclasses import replace

    from microimpact.analysis.statements import Verdict

    fake = replace(STATEMENTS[0], check=lambda ev: Verdict("", True, "x", np.nan))
    assert not evaluate(Evidence(), (fake,))[fake.id].held


def test_relatively_symmetric_is_half_a_skewness_unit():
    """Bulmer's rule (|g| <= 0.5 approximately symmetric), written down before
    the evaluation: -0.45 holds, -0.55 does not, even when 10 deg is more skewed."""
    for g85, ok in ((-0.45, True), (-0.55, False)):
        g_mu = np.where(ANGLES == 10, 1.5, np.where(ANGLES == 85, g85, 0.0))
        ev = oblique(unity_curve(1.0), mu_skewness=g_mu, mu_mean=0.01)
        assert held(ev, "mu_m-85-symmetric").held is ok


def test_capture_sudden_known_answers():
    """v(10 %) / v(90 %) <= 2 by linear interpolation of the capture curve."""
    v = np.array([0.1, 0.2, 0.3, 0.4, 0.5])
    for f, ratio in (
        ([1.0, 0.9, 0.5, 0.1, 0.0], 0.4 / 0.2),
        ([1.0, 0.95, 0.7, 0.4, 0.1], 0.5 / 0.22),
    ):
        ev = Evidence(capture_fractions={"sst65-silicon-normal": (v, np.array(f))})
        got = held(ev, "capture-sudden")
        assert got.held is (ratio <= 2.0 + 1e-12)
        assert f"ratio {ratio:.2f}" in got.ours


def test_e_m_asymmetry_statements_known_answers():
    from microimpact.analysis.statements import ONE_DIAMETER

    g = np.where(ANGLES == 90, 0.0, -1.0)
    ev = oblique(unity_curve(1.0), e_skewness=g)
    assert held(ev, "e_m-asymmetry-all-angles").held
    g2 = g.copy()
    g2[ANGLES == 40] = 0.05  # not significant at one angle
    assert not held(
        oblique(unity_curve(1.0), e_skewness=g2), "e_m-asymmetry-all-angles"
    ).held
    # one diameter keeps 40 % of the skewness: from the sizes; 80 %: not
    for kept, ok in ((0.4, True), (0.8, False)):
        one = frame("formica", e_relative=unity_curve(1.0), e_skewness=kept * g)
        ev.summaries[ONE_DIAMETER] = one
        assert held(ev, "e_m-asymmetry-from-small-spheres").held is ok


def test_docs_table_is_this_table():
    """docs/presets.md shows every evidence statement with the paper's words, our
    reading and a verdict word, and every input with why it holds by construction
    (written by docs/figures/paper_statements.py; the numbers are compared with a
    full-size study in tests/analysis/test_robustness.py, slow)."""
    from microimpact.analysis.robustness import verdict_word

    words = {verdict_word(x) for x in (0.0, 0.5, 1.0)}
    text = DOCS.read_text(encoding="utf-8")
    block = re.search(
        r"<!-- statements:begin -->\n(.*?)<!-- statements:end -->", text, re.DOTALL
    ).group(1)
    assert "13 of 14 held" not in text
    for s in STATEMENTS:
        row = next(line for line in block.splitlines() if f"| `{s.id}` |" in line)
        assert f"“{_md(s.words)}”" in row
        if s.kind == "evidence":
            assert _md(s.reading) in row
            assert any(f"**{w}**" in row for w in words), s.id
        else:
            assert _md(s.input_because) in row


def test_html_table_escapes_and_links():
    from microimpact.analysis.statements import Verdict

    s = STATEMENTS[0]
    verdicts = {s.id: Verdict(s.id, True, "<0.2 & more>")}
    html = statement_table_html(verdicts, anchors={s.figure: "#fig-a"})
    assert "&lt;0.2 &amp; more&gt;" in html
    assert 'href="#fig-a"' in html
    assert html.count("<tr") == len(STATEMENTS) + 1
    assert "not evaluated" in html  # the rows without a verdict


def test_reproduce_report_opens_with_the_table(tmp_path):
    """The reproduction report: the statement section comes before the first
    result, and every link it makes points at a figure of the page."""
    from microimpact.analysis.robustness import robustness_study
    from microimpact.engine.montecarlo import run
    from microimpact.pipeline.report import write_report
    from microimpact.scenario import PAPER_PRESETS, load_preset

    results = [run(load_preset(n), samples=400) for n in PAPER_PRESETS]
    study = robustness_study(2, 1000, speeds_m_s=(1.0,), shadowing=("reject",))
    path = write_report(results, tmp_path / "report.html", statements=study)
    page = path.read_text(encoding="utf-8")
    assert page.index('id="statements"') < page.index('<section id="r0-')
    ids = set(re.findall(r'id="([^"]+)"', page))
    start = page.index('id="statements"')
    section = page[start : page.index("</section>", start)]
    links = re.findall(r'href="#([^"]+)"', section)
    assert len(links) >= sum(s.kind == "evidence" for s in STATEMENTS)
    assert set(links) <= ids
    for s in STATEMENTS:
        assert s.words.replace("'", "&#x27;")[:40] in section


def test_reproduce_writes_the_table_linked_to_its_figure_files(tmp_path):
    """`microimpact reproduce` (make demo): the report opens with the table, and
    each figure link lands on a figure written by the run."""
    from microimpact.pipeline.study import reproduce

    reproduce(tmp_path, samples=300)
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert "How this compares with the paper" in page
    assert page.index('id="statements"') < page.index('<section id="r0-')
    ids = set(re.findall(r'<figure id="([^"]+)"', page))
    start = page.index('id="statements"')
    section = page[start : page.index("</section>", start)]
    links = set(re.findall(r'href="#([^"]+)"', section))
    assert links and links <= ids
    assert "r2-sst76-formica-oblique-coefficients_relative" in links
    # what a reader sees: the disclosure first, then no Python artefact anywhere
    text = _visible_text(page)
    first = text[text.index("How this compares with the paper") :][:1500]
    for word in ("synthetic", "assumed", "calibrated", "Formica family"):
        assert word.lower() in first.lower(), word
    for artefact in (
        r"\bNone\b",
        r"[{}]",
        r"\bnan\b",
        r"\bNaN\b",
        r"\binf\b",
        r"sha256",
        r"np\.float",
    ):
        assert not re.search(artefact, text), artefact
    assert "squares: experiments" not in text  # none in the paper's presets
    for verdict in ("robust", "contradicted", "depends on the unknown surface"):
        assert verdict in text


def _visible_text(page):
    """The text a browser shows: no style, no tags, no embedded images."""
    import html

    body = page[page.index("<body>") :]
    body = re.sub(r"<[^>]+>", " ", body)
    return html.unescape(body)
