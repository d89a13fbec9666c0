"""The paper's statements judged over the unknown Formica surface.

The paper's Formica scans are not published, so no one surface can stand for
them. :func:`robustness_study` runs ``sst76-formica-oblique`` on every
realization of the Formica family (:mod:`microimpact.surface.formica`), each with
its own engine seed, and the normal-impact presets over as many engine seeds, and
reports for each statement of :mod:`microimpact.analysis.statements` the share of
runs in which it holds, with a Wilson interval, and a verdict in three words:

* **robust**: holds in at least :data:`ROBUST` of the runs;
* **contradicted**: holds in at most :data:`CONTRADICTED` of them;
* **depends on the unknown surface**: in between.

Statements of kind ``"input"`` hold by construction; they are reported apart
with the verdict **input** and never counted. A second table judges the
evidence statements under the conditions the paper does not state: the incident
speed (:data:`SPEEDS_M_S`) and the shadowing rule (:data:`SHADOWING`).
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from .._core.validation import as_float_array, check_int, check_subset
from ..engine.montecarlo import run
from ..engine.statistics import wilson_interval
from ..population.distributions import monodisperse
from ..scenario import load_preset
from ..scenario.parts import SHADOWING_OPTIONS
from ..surface.angles import angles_from_sample
from ..surface.formica import N_REALIZATIONS, ROOT_SEED, formica_ensemble
from ..units import m_to_um
from .statements import (
    OBLIQUE,
    ONE_DIAMETER,
    ROUGH,
    STATEMENTS,
    Evidence,
    evaluate,
)

__all__ = [
    "CONTRADICTED",
    "ROBUST",
    "SHADOWING",
    "SPEEDS_M_S",
    "RobustnessStudy",
    "robustness_study",
    "verdict_word",
]

#: "robust": held in at least this share of the runs.
ROBUST = 0.9
#: "contradicted": held in at most this share.
CONTRADICTED = 0.1
#: Incident speeds of the conditions table [m/s] (the paper states none).
SPEEDS_M_S = (0.5, 1.0, 2.0, 5.0)
#: Shadowing rules of the conditions table (docs/engine.md).
SHADOWING = ("reject", "weighted")
#: Impacts per sweep point of the full study (the issue's minimum).
SAMPLES = 40_000
#: The preset's own conditions.
BASE_SPEED_M_S, BASE_SHADOWING = 1.0, "reject"
NORMAL_PRESETS = ("sst65-silicon-normal", "sst125-silicon-normal")


def verdict_word(rate, kind="evidence") -> str:
    """``"robust"``, ``"contradicted"``, ``"depends on the unknown surface"``,
    ``"input"`` (for an input) or ``"not evaluated"`` (NaN rate)."""
    if kind == "input":
        return "input"
    if not np.isfinite(rate):
        return "not evaluated"
    if rate >= ROBUST:
        return "robust"
    if rate <= CONTRADICTED:
        return "contradicted"
    return "depends on the unknown surface"


@dataclass
class RobustnessStudy:
    """What :func:`robustness_study` found.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per statement: ``id``, ``kind``, ``runs``, ``held``, ``rate``,
        ``ci_low``, ``ci_high`` (95 % Wilson), ``verdict``.
    conditions : pandas.DataFrame
        Evidence statements (rows) by condition (``"<speed> m/s, <rule>"``
        columns): the share of realizations in which each holds.
    runs : pandas.DataFrame
        One row per (run, statement): ``condition``, ``realization`` (its seed,
        ``root/index``, or the engine seed of a normal-impact run), ``id``,
        ``held``, ``ours``.
    realizations : pandas.DataFrame
        The surfaces: seed, drawn parameters and measured statistics.
    samples : int
        Impacts per sweep point.
    """

    table: pd.DataFrame
    conditions: pd.DataFrame
    runs: pd.DataFrame
    realizations: pd.DataFrame
    samples: int
    settings: dict = field(default_factory=dict)

    def verdict(self, statement_id) -> str:
        """The verdict word of one statement."""
        return str(self.table.set_index("id").loc[statement_id, "verdict"])


def _oblique(base, realization, speed, shadowing, seed):
    surfaces = tuple(
        replace(s, angles=angles_from_sample(realization.angles_deg))
        if s.name == ROUGH
        else s
        for s in base.surfaces
    )
    return base.with_options(
        surfaces=surfaces,
        speeds_m_s=(float(speed),),
        shadowing=shadowing,
        seed=int(seed),
    )


def _one_diameter(scenario):
    """The scenario with every particle at the median diameter [µm] of its
    population (the mechanism statement)."""
    return scenario.with_options(
        particles=monodisperse(float(m_to_um(scenario.particles.median())))
    )


def _seed(root, *key) -> int:
    ss = np.random.SeedSequence(int(root), spawn_key=tuple(int(k) for k in key))
    return int(ss.generate_state(1, dtype=np.uint32)[0])


def _rows(condition, label, verdicts):
    return [
        {
            "condition": condition,
            "realization": label,
            "id": k,
            "held": None if v is None else bool(v.held),
            "ours": "" if v is None else v.ours,
        }
        for k, v in verdicts.items()
    ]


def robustness_study(
    n_realizations=N_REALIZATIONS,
    samples=SAMPLES,
    *,
    speeds_m_s=SPEEDS_M_S,
    shadowing=SHADOWING,
    root=ROOT_SEED,
    workers=1,
) -> RobustnessStudy:
    """Judge every statement over `n_realizations` Formica surfaces.

    Parameters
    ----------
    n_realizations : int
        Surfaces of the family (and engine seeds of the normal presets).
    samples : int
        Impacts per sweep point.
    speeds_m_s, shadowing : sequence
        The conditions table; the preset's own (1 m/s, ``"reject"``) gives the
        main table.
    root : int
        Root seed of the surfaces and of the engine seeds.
    workers : int
        Passed to :func:`~microimpact.engine.montecarlo.run`.

    Returns
    -------
    RobustnessStudy
    """
    n, samples, speeds_m_s, shadowing = _robustness_study_iv(
        n_realizations, samples, speeds_m_s, shadowing
    )
    surfaces = formica_ensemble(n, root=root)
    base = load_preset(OBLIQUE)
    rows = []
    conditions = [(BASE_SPEED_M_S, BASE_SHADOWING)] + [
        (v, sh)
        for v in speeds_m_s
        for sh in shadowing
        if (v, sh) != (BASE_SPEED_M_S, BASE_SHADOWING)
    ]
    for r in surfaces:
        for speed, rule in conditions:
            sc = _oblique(base, r, speed, rule, _seed(root, r.index, 1))
            res = run(sc, samples=samples, workers=workers)
            ev = Evidence.from_results({OBLIQUE: res}, surface_data=False)
            ev.add_realization(r)
            one = run(_one_diameter(sc), samples=samples, workers=workers)
            ev.summaries[ONE_DIAMETER] = one.summary
            label = f"{float(speed):g} m/s, {rule}"
            rows += _rows(label, r.seed_text, evaluate(ev))
    base_label = f"{BASE_SPEED_M_S:g} m/s, {BASE_SHADOWING}"
    for k in range(n):  # the normal presets do not see the Formica surface
        results = {
            name: run(
                load_preset(name).with_options(seed=_seed(root, k, 2)),
                samples=samples,
                workers=workers,
            )
            for name in NORMAL_PRESETS
        }
        ev = Evidence.from_results(results, surface_data=False)
        verdicts = {
            key: v
            for key, v in evaluate(ev).items()
            if v is not None and key not in {"angles-asymmetric", "height-std"}
        }
        rows += _rows(base_label, f"engine seed {_seed(root, k, 2)}", verdicts)
    runs = pd.DataFrame(rows)
    return RobustnessStudy(
        table=_table(runs[runs["condition"] == base_label]),
        conditions=_conditions(runs),
        runs=runs,
        realizations=_realizations(surfaces),
        samples=samples,
        settings={
            "root_seed": int(root),
            "n_realizations": n,
            "speeds_m_s": tuple(float(v) for v in speeds_m_s),
            "shadowing": tuple(shadowing),
        },
    )


def _robustness_study_iv(n, samples, speeds_m_s, shadowing):
    n = check_int(n, "n_realizations", minimum=1)
    samples = check_int(samples, "samples", minimum=100)
    speeds = as_float_array(speeds_m_s, "speeds_m_s").ravel()
    if speeds.size == 0 or not np.all(np.isfinite(speeds) & (speeds > 0)):
        raise ValueError(
            "`speeds_m_s` must be positive speeds [m/s]; got "
            f"{', '.join(f'{v:g}' for v in speeds) or 'none'}."
        )
    rules = check_subset(shadowing, "shadowing", SHADOWING_OPTIONS)
    return n, samples, tuple(float(v) for v in speeds), rules


def _table(runs) -> pd.DataFrame:
    out = []
    for s in STATEMENTS:
        held = runs.loc[(runs["id"] == s.id) & runs["held"].notna(), "held"]
        k, m = int(held.astype(bool).sum()), int(held.size)
        lo, hi = wilson_interval(k, m) if m else (np.nan, np.nan)
        rate = k / m if m else np.nan
        out.append(
            {
                "id": s.id,
                "kind": s.kind,
                "runs": m,
                "held": k,
                "rate": rate,
                "ci_low": float(lo),
                "ci_high": float(hi),
                "verdict": verdict_word(rate, s.kind),
            }
        )
    return pd.DataFrame(out)


def _conditions(runs) -> pd.DataFrame:
    ev = [s.id for s in STATEMENTS if s.kind == "evidence"]
    sub = runs[runs["id"].isin(ev) & runs["realization"].str.contains("/")]
    sub = sub[sub["held"].notna()]
    tab = sub.assign(held=sub["held"].astype(float)).pivot_table(
        index="id", columns="condition", values="held", aggfunc="mean", sort=False
    )
    return tab.reindex([i for i in ev if i in tab.index])


def _realizations(surfaces) -> pd.DataFrame:
    return pd.DataFrame(
        [{"seed": r.seed_text, **r.parameters, **r.measured} for r in surfaces]
    )


# ------------------------------------------------------------------ tables
def _pct(x) -> str:
    return "–" if not np.isfinite(x) else f"{100.0 * x:.0f} %"


def rate_text(row) -> str:
    """``"12 of 16 (75 %, 95 % CI 51–90 %)"``: a row of ``RobustnessStudy.table``."""
    if not row["runs"]:
        return "not evaluated"
    return (
        f"{row['held']} of {row['runs']} ({_pct(row['rate'])}, 95 % CI "
        f"{100.0 * row['ci_low']:.0f}–{100.0 * row['ci_high']:.0f} %)"
    )


def _md(text) -> str:
    return str(text).replace("|", "\\|")


def _n(k) -> str:
    return f"{k} is" if k == 1 else f"{k} are"


def summary_sentence(study) -> str:
    """One sentence: how many evidence statements are robust, depend on the
    surface, are contradicted; how many are inputs."""
    t = study.table
    ev = t[t["kind"] == "evidence"]
    count = ev["verdict"].value_counts()
    n_in = int((t["kind"] == "input").sum())
    return (
        f"Of the {len(ev)} statements our model could contradict, "
        f"{_n(count.get('robust', 0))} robust, "
        f"{count.get('depends on the unknown surface', 0)} depend on the unknown "
        f"surface and {count.get('contradicted', 0)} are contradicted, judged over "
        f"{study.settings['n_realizations']} realizations of the Formica family "
        f"(and as many engine seeds) at {study.samples:,} impacts per point; "
        f"{n_in} more hold by construction and are shown apart as inputs."
    )


def robustness_table_markdown(study) -> str:
    """The evidence statements: the paper's words, our reading, the verdict and
    the hold rate (``docs/presets.md``)."""
    by_id = study.table.set_index("id")
    rows = [
        "| id | paper | the paper's words | our reading | verdict | held in |",
        "|---|---|---|---|---|---|",
    ]
    for s in STATEMENTS:
        if s.kind != "evidence":
            continue
        r = by_id.loc[s.id]
        rows.append(
            f"| `{s.id}` | {s.where} | “{_md(s.words)}” | {_md(s.reading)} | "
            f"**{r['verdict']}** | {rate_text(r)} |"
        )
    return "\n".join(rows)


def inputs_table_markdown(study, verdicts=None) -> str:
    """The statements that hold by construction, and why (never counted)."""
    verdicts = verdicts or {}
    rows = [
        "| id | paper | the paper's words | why it holds by construction | ours |",
        "|---|---|---|---|---|",
    ]
    for s in STATEMENTS:
        if s.kind != "input":
            continue
        v = verdicts.get(s.id)
        ours = "–" if v is None else v.ours
        rows.append(
            f"| `{s.id}` | {s.where} | “{_md(s.words)}” | {_md(s.input_because)} | "
            f"{_md(ours)} |"
        )
    return "\n".join(rows)


def conditions_table_markdown(study) -> str:
    """Share of realizations holding each evidence statement, by condition."""
    c = study.conditions
    cols = list(c.columns)
    rows = [
        "| id | " + " | ".join(cols) + " |",
        "|---|" + "---|" * len(cols),
    ]
    for sid, r in c.iterrows():
        rows.append(f"| `{sid}` | " + " | ".join(_pct(r[k]) for k in cols) + " |")
    return "\n".join(rows)


def realizations_table_markdown(study) -> str:
    """The surfaces: seed, drawn parameters, measured statistics."""
    t = study.realizations
    rows = [
        "| seed | σ [µm] | Ra [µm] | ℓ_w [µm] | ℓ_r [µm] | texture share | "
        "period [µm] | rise | orient. | angle std [°] | angle skew |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for _, r in t.iterrows():
        rows.append(
            f"| {r['seed']} | {r['height_std_um']:.1f} | {r['ra_um']:.2f} | "
            f"{r['waviness_length_um']:.0f} | {r['roughness_length_um']:.1f} | "
            f"{r['texture_share']:.2f} | {r['texture_period_um']:.0f} | "
            f"{r['texture_rise_fraction']:.2f} | {int(r['texture_orientation']):+d} | "
            f"{r['angle_std_deg']:.2f} | {r['angle_skewness']:+.2f} |"
        )
    return "\n".join(rows)


#: What the reader must know before the statements (report and docs/presets.md).
DISCLOSURE = (
    "What is the paper's, what is assumed, what is calibrated. From the paper: the "
    "rigid-body impact model (Eqs. 1–9), the SST65 size distribution (normal, "
    "52.8 ± 15.3 µm), the Lycopodium sizes (normal, 30 ± 1.7 µm), 4,000 impacts per "
    "point, the 20 µm contact length and the Formica height std of about 45 µm. "
    "Assumed (the paper does not say): the incident speed of the oblique cases "
    "(1 m/s; 2 m/s for Lycopodium), the shadowing rule (an impact strikes only a "
    "facet the particle can reach), the SST76 and SST125 size samples, and the "
    "coefficient k1 = 4 m/s and the law k2 = v_c/4. Calibrated to the paper's own "
    "sentences, so they cannot confirm them: the capture-speed law v_c = 0.20 "
    "(d/52.8 µm)^−1.58 m/s (from the 50 % capture speeds 0.20 and 0.13 m/s) and "
    "the friction coefficient 0.15 (from the smooth surface's impulse ratio). The "
    "Formica roughness is synthetic: the paper's scans are unpublished, so the "
    "preset pools 16 realizations of a documented surface family (the paper's "
    "45 µm, its instrument's ±150 µm and a published laminate Ra; every other "
    "parameter drawn from a stated range, none chosen against the statements), "
    "and each statement is judged over those realizations, not at one surface."
)


def _e(x) -> str:
    return html.escape(str(x))


def robustness_table_html(study, *, anchors=None) -> str:
    """The evidence statements with their verdicts and hold rates (the report);
    `anchors` maps a statement's ``figure`` to an in-page link."""
    anchors = anchors or {}
    by_id = study.table.set_index("id")
    out = [
        '<table class="statements"><thead><tr><th>paper</th><th>the paper\'s '
        "words</th><th>our reading</th><th>verdict</th><th>held in</th>"
        "<th>figure</th></tr></thead><tbody>"
    ]
    for s in STATEMENTS:
        if s.kind != "evidence":
            continue
        r = by_id.loc[s.id]
        cls = {"robust": "held", "contradicted": "failed"}.get(r["verdict"], "na")
        label = s.figure.split("/")[-1].replace("_", " ") if s.figure else "–"
        link = anchors.get(s.figure)
        fig = f'<a href="{_e(link)}">{_e(label)}</a>' if link else _e(label)
        out.append(
            f'<tr class="{cls}"><td>{_e(s.where)}</td><td>“{_e(s.words)}”</td>'
            f"<td>{_e(s.reading)}</td><td>{_e(r['verdict'])}</td>"
            f"<td>{_e(rate_text(r))}</td><td>{fig}</td></tr>"
        )
    out.append("</tbody></table>")
    return "\n".join(out)


def conditions_table_html(study) -> str:
    """Hold rate of each evidence statement under each unstated condition."""
    c = study.conditions
    head = "".join(f"<th>{_e(k)}</th>" for k in c.columns)
    out = [
        f'<table class="conditions"><thead><tr><th>statement</th>{head}</tr>'
        "</thead><tbody>"
    ]
    for sid, r in c.iterrows():
        cells = "".join(f"<td>{_e(_pct(r[k]))}</td>" for k in c.columns)
        out.append(f"<tr><td>{_e(sid)}</td>{cells}</tr>")
    out.append("</tbody></table>")
    return "\n".join(out)


def inputs_table_html(study, verdicts=None) -> str:
    """The statements that hold by construction, and why; never counted."""
    verdicts = verdicts or {}
    out = [
        '<table class="inputs"><thead><tr><th>paper</th><th>the paper\'s words'
        "</th><th>why it holds by construction</th><th>ours</th></tr></thead>"
        "<tbody>"
    ]
    for s in STATEMENTS:
        if s.kind != "input":
            continue
        v = verdicts.get(s.id)
        ours = "–" if v is None else v.ours
        out.append(
            f"<tr><td>{_e(s.where)}</td><td>“{_e(s.words)}”</td>"
            f"<td>{_e(s.input_because)}</td><td>{_e(ours)}</td></tr>"
        )
    out.append("</tbody></table>")
    return "\n".join(out)
