"""Reports: one self-contained HTML page, and a plain-text summary for terminals.

:func:`write_report` writes ``report.html`` with inline CSS and every figure embedded
as a base64 PNG (no external assets, no scripts), so the file can be mailed or
archived on its own. For each result it shows the scenario and its key settings, the
provenance (seed entropy, versions, sample counts, run time, backend), the capture
speed table, a readable summary table (estimate and confidence interval) with a
relative link to the full CSV, the comparison with experiments if any, and the
figures. :func:`summary_text` gives scenario, versions, seed entropy, n and
estimate ± SE as Markdown-flavoured text.

Both scale with the page, not with the sweep: a table of more rows than
:data:`~microimpact.pipeline.rows.MAX_TABLE_ROWS` (:data:`TEXT_ROWS` in the text)
shows informative rows only (:mod:`microimpact.pipeline.rows`) and says how many
are left out and where they are (``summary.csv``, ``capture_speed.csv``,
``results.nc``); the figures are a bounded number of PNGs of bounded size.
"""

from __future__ import annotations

import base64
import html
import io
import math
import os
from pathlib import Path

import numpy as np

from .. import __version__
from .._core.files import atomic_write
from ..analysis.compare import compare
from ..analysis.robustness import (
    CONTRADICTED,
    DISCLOSURE,
    ROBUST,
    conditions_table_html,
    inputs_table_html,
    robustness_study,
    robustness_table_html,
    summary_sentence,
)
from ..analysis.statements import STATEMENTS, Evidence, evaluate
from ..engine.summary import TAIL_FRACTION, TAIL_SHARE_LIMIT
from ..io.experiments import combine_experiments
from ..plotting._style import styled
from ..plotting.areal import CAPTION
from ..plotting.results import STYLE, _confidence, smooth_surfaces
from ..plotting.roughness import plot_angle_pdf
from ..plotting.sizes import plot_size_quantiles
from ..units import m_to_um, rad_to_deg
from .figures import figure_caption, result_figures
from .rows import capture_rows, summary_rows

__all__ = ["summary_text", "write_report"]

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;
 margin:0;color:#1d2329;background:#f6f7f9;line-height:1.45}
main{max-width:1100px;margin:0 auto;padding:24px 32px 48px;background:#fff;
 box-shadow:0 0 12px rgba(0,0,0,.06)}
h1{font-size:1.7em;margin:.2em 0 .1em}h2{font-size:1.35em;margin-top:2em;
 border-bottom:2px solid #0072B2;padding-bottom:.2em}
h3{font-size:1.08em;margin:1.4em 0 .4em}
p.sub{color:#56606b;margin-top:0}
table{border-collapse:collapse;font-size:.86em;margin:.4em 0 1em}
th,td{padding:3px 9px;border-bottom:1px solid #e3e6ea;text-align:right;
 vertical-align:top;white-space:nowrap}
th{background:#eef2f6;font-weight:600}td.l,th.l{text-align:left;white-space:normal}
table.kv td:first-child{text-align:left;color:#56606b;font-weight:600}
table.kv td{text-align:left;white-space:normal}
.scroll{overflow-x:auto;max-height:560px;overflow-y:auto;border:1px solid #e3e6ea}
.scroll table{margin:0;font-size:.8em}
.scroll th{position:sticky;top:0;white-space:normal;vertical-align:bottom}
figure{margin:1.2em 0;text-align:center}figure img{max-width:100%;height:auto;
 border:1px solid #e3e6ea}figcaption{font-size:.86em;color:#56606b;max-width:820px;
 margin:.4em auto 0;text-align:left}
.no{color:#b00020;font-weight:600}.yes{color:#00703c}
nav ul{columns:2;font-size:.92em}code{font-size:.92em}
.notes{background:#fff8e1;border-left:4px solid #E69F00;padding:.5em 1em}
table.statements td{text-align:left;white-space:normal}
table.statements tr.held td:nth-child(4){color:#00703c;font-weight:600}
table.statements tr.failed td:nth-child(4){color:#b00020;font-weight:600}
table.inputs td,table.conditions td:first-child{text-align:left;white-space:normal}
details summary{cursor:pointer;color:#0072B2}
"""


def _workers(p: dict, missing: str) -> str:
    """The worker count, with the provenance's kind of local workers if recorded
    (e.g. ``2 worker(s) (threads)``)."""
    kind = p.get("local_workers")
    return f"{p.get('workers', missing)} worker(s)" + (f" ({kind})" if kind else "")


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _fmt(x, digits=4) -> str:
    if x is None:
        return "–"
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(x):
        return "–"
    return f"{x:.{digits}g}"


def _tidy(x):
    """Round-off noise (|x| < 1e-12, e.g. μ of a normal impact) shown as 0."""
    return 0.0 if abs(x) < 1e-12 else x


def _ci(m, lo, hi, *, scale=1.0, digits=3) -> str:
    m, lo, hi = _tidy(m), _tidy(lo), _tidy(hi)
    if not np.isfinite(m):
        return "–"
    s = f"{m * scale:.{digits}g}"
    if np.isfinite(lo) and np.isfinite(hi):
        s += f" [{lo * scale:.{digits}g}, {hi * scale:.{digits}g}]"
    return s


def _pm(m, se, digits=3) -> str:
    m, se = _tidy(m), _tidy(se)
    if not np.isfinite(m):
        return "–"
    return f"{m:.{digits}g} ± {se:.2g}" if np.isfinite(se) else f"{m:.{digits}g}"


def _slug(name: str) -> str:
    """`name` safe as (part of) a file name: characters other than letters, digits,
    ``-`` and ``_`` (path separators, dots) become ``_``."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in str(name))


def _table(header, rows, *, left=(0,)) -> str:
    th = "".join(
        f'<th class="l">{_e(h)}</th>' if i in left else f"<th>{_e(h)}</th>"
        for i, h in enumerate(header)
    )
    body = []
    for r in rows:
        tds = "".join(
            f'<td class="l">{c}</td>' if i in left else f"<td>{c}</td>"
            for i, c in enumerate(r)
        )
        body.append(f"<tr>{tds}</tr>")
    return f"<table><thead><tr>{th}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _kv(pairs) -> str:
    rows = "".join(f"<tr><td>{_e(k)}</td><td>{v}</td></tr>" for k, v in pairs)
    return f'<table class="kv"><tbody>{rows}</tbody></table>'


def _plain(obj) -> str:
    """A describe() value in words and numbers, escaped: no dicts, None, digests
    or ``inf`` (``mean 52.8 µm, std 15.3 µm, support 0–∞ µm``)."""
    if isinstance(obj, dict):
        text = ", ".join(p for p in _pairs(obj) if p)
        return _e(text.replace("as sampled:,", "as sampled:") or "–")
    if isinstance(obj, list | tuple):
        return _e("; ".join(_short(v) for v in obj) or "–")
    return _e(_short(obj))


#: describe() keys never shown (digests, bookkeeping)
_HIDDEN = {"sha256", "n_kept"}
_UNITS = {
    "_um": " µm",
    "_deg": "°",
    "_m_s": " m/s",
    "_kg_m3": " kg/m³",
    "_j_m2": " J/m²",
    "_m": " m",
}


def _pairs(d) -> list:
    out = []
    after_params = False
    for k, v in d.items():
        if v is None or k in _HIDDEN or (isinstance(v, float) and v != v):
            continue
        if isinstance(v, dict):  # a nested law or parameter set, under its key
            inner = ", ".join(_pairs(v))
            if k == "params":  # as given; what follows describes the sample
                out.append(f"given ({inner})" if inner else "")
                after_params = bool(inner)
            else:
                out.append(f"{k} ({inner})")
            continue
        if after_params:
            out.append("as sampled:")
            after_params = False
        unit = ""
        name = str(k)
        for suffix, u in _UNITS.items():
            if name.endswith(suffix):
                name, unit = name.removesuffix(suffix), u
                break
        out.append(f"{name.replace('_', ' ')} {_short(v)}{unit}")
    return out


def _short(v) -> str:
    if v is None:
        return "–"
    if isinstance(v, dict):
        text = ", ".join(p for p in _pairs(v) if p)
        return text.replace("as sampled:,", "as sampled:") or "–"
    if isinstance(v, list | tuple):
        if len(v) == 2 and all(isinstance(x, int | float) for x in v):
            return f"{_short(v[0])}–{_short(v[1])}"
        if len(v) > 12:
            return f"{', '.join(_short(x) for x in v[:6])}, … ({len(v)} values)"
        return ", ".join(_short(x) for x in v)
    if isinstance(v, float):
        if math.isinf(v):
            return "∞" if v > 0 else "−∞"
        if v != v:
            return "–"
        return f"{v:.6g}"
    return str(v)


def _png_data_uri(fig) -> str:

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=STYLE["savefig.dpi"] * 0.75)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _figure_html(uri, caption, fig_id=None) -> str:
    ident = f' id="{_e(fig_id)}"' if fig_id else ""
    return (
        f'<figure{ident}><img src="{uri}" alt="{_e(caption)}">'
        f"<figcaption>{_e(caption)}</figcaption></figure>"
    )


#: Rows at most of each table of :func:`summary_text` (a terminal's worth).
TEXT_ROWS = 30
#: Flagged heavy-tail points named at most in the report and the text summary.
HEAVY_TAIL_NAMED = 20


def heavy_tail_points(summary, limit=None):
    """The rows of `summary` flagged by the heavy-tail rule (``heavy_tail == 1``,
    docs/outputs.md): their surface, speed, angle and the two shares; the first
    `limit` of them if given (with ``attrs["flagged"]``, how many there are), so
    that naming a few of 10^5 flagged points copies a few rows, not 10^5."""
    if "heavy_tail" not in summary:
        out = summary.iloc[0:0]
        out.attrs["flagged"] = 0
        return out
    flagged = np.flatnonzero(summary["heavy_tail"].to_numpy(dtype=float) == 1.0)
    out = summary.iloc[flagged if limit is None else flagged[:limit]]
    out.attrs["flagged"] = int(flagged.size)
    return out


def _share(x) -> str:
    """A share in per cent, or ``–`` where it is not defined."""
    return f"{100 * x:.0f} %" if np.isfinite(x) else "–"


def _heavy_tail_note(summary) -> str:
    if "heavy_tail" not in summary or summary["heavy_tail"].isna().all():
        return ""
    bad = heavy_tail_points(summary, HEAVY_TAIL_NAMED)
    flagged = bad.attrs["flagged"]
    rule = (
        f"a point is flagged when the {100 * TAIL_FRACTION:g} % of its rebounds "
        "farthest from the mean hold more than "
        f"{100 * TAIL_SHARE_LIMIT:g} % of the squared deviations of e<sub>m</sub> "
        "or μ<sub>m</sub> (columns <code>e_tail_share</code>, "
        "<code>mu_tail_share</code>, <code>heavy_tail</code>)"
    )
    if bad.empty:
        worst = float(
            np.nanmax(summary[["e_tail_share", "mu_tail_share"]].to_numpy(float))
        )
        return (
            f'<p class="yes">Heavy tails: no point flagged ({rule}); the largest '
            f"share is {100 * worst:.1f} %.</p>"
        )
    items = ", ".join(
        f"{_e(r['surface'])} {_fmt(r['speed_m_s'])} m/s {_fmt(r['angle_deg'])}° "
        f"(e {_share(r['e_tail_share'])}, μ {_share(r['mu_tail_share'])})"
        for _, r in bad.iterrows()
    )
    if flagged > len(bad):
        items += (
            f" and {flagged - len(bad):,} more (column "
            "<code>heavy_tail</code> of the summary)"
        )
    return (
        f'<p class="no">Heavy tails: the mean of {flagged:,} point(s) is at the '
        f"mercy of a few impacts ({rule}): {items}. Read their medians and "
        "5–95 % ranges (the figures) beside the means.</p>"
    )


# ------------------------------------------------------------------ sections
def _settings(result) -> str:
    sc = result.scenario
    d = sc.describe() if hasattr(sc, "describe") else {}
    pairs = [
        ("Description", _e(d.get("description") or "–")),
        ("Particles", _plain(d.get("particles", "–"))),
        ("Coefficient laws", _plain(d.get("coefficients", "–"))),
        ("Surfaces", _plain(d.get("surfaces", "–"))),
        ("Particle roughness", _plain(d.get("particle_roughness") or "none")),
        ("Speeds [m s⁻¹]", _e(_short(list(sc.speeds_m_s)))),
        ("Angles [deg]", _e(_short(list(sc.angles_deg)))),
        ("Speed spread (relative SD)", _e(_fmt(sc.speed_spread))),
        (
            "Samples per point (scenario)",
            _e(sc.samples if sc.precision is None else "adaptive"),
        ),
        ("Precision target", _plain(d.get("precision") or "none")),
        ("Sampling", _e(sc.sampling)),
        ("Shadowing", _e(sc.shadowing)),
        ("Confidence level", _e(_fmt(sc.confidence))),
        ("Reference angle [deg]", _e(_fmt(sc.reference_angle_deg))),
        ("Seed (scenario)", _e(sc.seed if sc.seed is not None else "fresh entropy")),
        ("Source file", _e(d.get("source") or "built in Python")),
    ]
    return _kv(pairs)


def _provenance(result) -> str:
    p = dict(result.provenance or {})
    s = result.summary
    n = s["n"].to_numpy(dtype=float) if "n" in s else np.array([np.nan])
    versions = p.get("versions", {})
    pairs = [
        ("Seed entropy", f"<code>{_e(result.seed_entropy)}</code>"),
        ("Versions", _e(", ".join(f"{k} {v}" for k, v in versions.items()))),
        (
            "Impacts per sweep point",
            _e(f"{int(np.nanmin(n)):,} – {int(np.nanmax(n)):,}")
            if np.isfinite(n).any()
            else "–",
        ),
        ("Sweep points", _e(len(s))),
        ("Run time", _e(f"{float(result.elapsed_s):.3g} s")),
        ("Backend", _e(f"{p.get('backend', '–')}, {_workers(p, '–')}")),
        (
            "Sampling",
            _e(f"{p.get('sampling', '–')}, {p.get('replicates', '–')} replicate(s)"),
        ),
        (
            "Block size / table size",
            _e(f"{p.get('block_size')} / {p.get('table_size')}"),
        ),
        ("Created", _e(p.get("created", "–"))),
    ]
    return _kv(pairs)


def _num(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _speed_interval(m, lo, hi, digits=3) -> str:
    """``m [lo, hi]`` of a capture speed: a NaN limit is an open side ("open");
    a NaN estimate is "no estimate". Never drops a finite limit."""
    m, lo, hi = _num(m), _num(lo), _num(hi)
    if not math.isfinite(m):
        return "no estimate"

    def side(x):
        return f"{x:.{digits}g}" if math.isfinite(x) else "open"

    return f"{m:.{digits}g} [{side(lo)}, {side(hi)}]"


def _capture_table(result) -> str:
    try:
        cs = result.capture_speed()
    except (KeyError, ValueError) as err:
        return f"<p>No capture speed: {_e(err)}</p>"
    if cs.empty:
        return "<p>No capture speed (no capture curves in the summary).</p>"
    speeds = getattr(result.scenario, "speeds_m_s", ())
    if len(speeds) == 1 and cs["speed_m_s"].isna().all():
        return (
            f"<p>No capture speed: one incident speed ({_fmt(speeds[0])} m/s) was "
            "simulated, and a capture speed needs a sweep of speeds that brackets "
            "the quantile. The capture fraction at each point is in the summary.</p>"
        )
    total = len(cs)
    cs = cs.iloc[capture_rows(cs)]
    has_note = "note" in cs and cs["note"].fillna("").astype(str).str.strip().any()
    rows = []
    for _, r in cs.iterrows():
        row = [
            _e(r["surface"]),
            _e(_fmt(r["angle_deg"])),
            _e(f"{100 * _num(r['quantile']):g} %"),
            _e(_speed_interval(r["speed_m_s"], r["speed_ci_low"], r["speed_ci_high"])),
        ]
        if has_note:
            note = r.get("note")
            row.append(_e("" if note is None or note != note else note))
        rows.append(row)
    conf = f"{100 * _confidence(result):g} %"
    header = [
        "surface",
        "angle [deg]",
        "captured",
        f"capture speed [m s⁻¹] [{conf} CI]",
    ]
    if has_note:
        header.append("note")
    legend = (
        "<p>“open”: the simulated speeds do not bound that side of the interval; "
        "“no estimate”: the note says why.</p>"
    )
    if len(cs) < total:
        legend += _omitted(
            len(cs),
            total,
            "capture curves",
            "<code>capture_speed.csv</code> (evenly spaced curves shown)",
        )
    return _table(header, rows, left=(0, 4)) + legend


def _omitted(shown: int, total: int, what: str, where: str) -> str:
    """The sentence under a capped table: how many rows are left out, and where
    they all are."""
    return (
        f'<p class="omitted">{shown:,} of {total:,} {what} shown; the other '
        f"{total - shown:,} are in {where}.</p>"
    )


def _summary_table(result, csv_href) -> str:
    s = result.summary
    rows_idx, why = summary_rows(s)
    capped = bool(why)
    has_rel = "e_relative" in s
    conf = f"{100 * _confidence(result):g} %"
    header = ["row", "shown for"] if capped else []
    header += [
        "surface",
        "speed [m s⁻¹]",
        "angle [deg]",
        "n",
        f"capture [%] [{conf} CI]",
        f"e of rebounds [{conf} CI]",
        f"μ [{conf} CI]",
    ]
    if has_rel:
        header += ["e relative ± SE", "μ relative ± SE"]
    header += ["shadowed [%]", "re-impact [%]"]
    sub = s.iloc[rows_idx]

    def col(c):
        if c not in sub:
            return np.full(len(sub), math.nan)
        return sub[c].to_numpy(dtype=float)

    cols = {
        c: col(c)
        for c in (
            "speed_m_s",
            "angle_deg",
            "n",
            "capture_fraction",
            "capture_ci_low",
            "capture_ci_high",
            "e_rebound_mean",
            "e_rebound_ci_low",
            "e_rebound_ci_high",
            "mu_mean",
            "mu_ci_low",
            "mu_ci_high",
            "e_relative",
            "e_relative_se",
            "mu_relative",
            "mu_relative_se",
            "shadowed_fraction",
            "reimpact_fraction",
        )
    }
    surfaces = sub["surface"].astype(str).to_numpy()
    rows = []
    for k, i in enumerate(rows_idx):
        v = {c: a[k] for c, a in cols.items()}
        row = [_e(f"{int(i):,}"), _e(why[int(i)])] if capped else []
        row += [
            _e(surfaces[k]),
            _e(_fmt(v["speed_m_s"])),
            _e(_fmt(v["angle_deg"])),
            _e(f"{int(v['n']):,}"),
            _e(
                _ci(
                    v["capture_fraction"],
                    v["capture_ci_low"],
                    v["capture_ci_high"],
                    scale=100,
                )
            ),
            _e(_ci(v["e_rebound_mean"], v["e_rebound_ci_low"], v["e_rebound_ci_high"])),
            _e(_ci(v["mu_mean"], v["mu_ci_low"], v["mu_ci_high"])),
        ]
        if has_rel:
            row += [
                _e(_pm(v["e_relative"], v["e_relative_se"])),
                _e(_pm(v["mu_relative"], v["mu_relative_se"])),
            ]
        row += [
            _e(_fmt(100 * v["shadowed_fraction"], 3)),
            _e(_fmt(100 * v["reimpact_fraction"], 3)),
        ]
        rows.append(row)
    link = (
        f'<p>All {len(s.columns)} columns: <a href="{_e(csv_href)}">'
        f"{_e(csv_href)}</a> (described in <code>docs/outputs.md</code>).</p>"
    )
    note = ""
    if capped:
        note = _omitted(
            len(rows_idx),
            len(s),
            "sweep points",
            f'<a href="{_e(csv_href)}">{_e(csv_href)}</a> and <code>results.nc</code> '
            "(row: the row number in the CSV counted from 0, the point index of "
            "<code>result.histogram</code>; shown: on each capture curve the point "
            "nearest 50 % capture (evenly spaced curves), the extremes of capture, "
            "e and μ per surface, and evenly spaced rows)",
        )
    left = (0, 1, 2) if capped else (0,)
    table = f'<div class="scroll">{_table(header, rows, left=left)}</div>'
    return table + note + link + _heavy_tail_note(s)


def _comparison_html(table) -> str:
    rows = []
    for _, r in table.iterrows():
        where = f"{_fmt(r['speed_m_s'])} m s⁻¹, {_fmt(r['angle_deg'])}°, {r['surface']}"
        compared = bool(r.get("compared", True))
        ok = (
            "not compared"
            if not compared
            else '<span class="yes">yes</span>'
            if r["agree"]
            else '<span class="no">no</span>'
        )
        rows.append(
            [
                _e(where),
                _e(r["statistic"]),
                _e(_ci(r["exp_mean"], r["exp_ci_low"], r["exp_ci_high"])),
                _e(_ci(r["sim_mean"], r["sim_ci_low"], r["sim_ci_high"])),
                _e(_fmt(r["z"], 3)),
                ok,
                _e(r["note"]),
            ]
        )
    done = (
        table["compared"].astype(bool)
        if "compared" in table
        else table["agree"].notna()
    )
    n_ok = int((table["agree"].astype(bool) & done).sum())
    conf = table.attrs.get("confidence", 0.95)
    skipped = len(table) - int(done.sum())
    head = (
        f"<p>{n_ok} of {int(done.sum())} compared experimental points agree with the "
        f"simulation at the {100 * conf:g} % level (|simulated − experimental| "
        "within z·√(SE²<sub>sim</sub> + SE²<sub>exp</sub>), widened by the "
        "interpolation's error bound; see <code>docs/outputs.md</code>)"
        + (
            f"; {skipped} not compared (outside the sweep: the note says why)"
            if skipped
            else ""
        )
        + ".</p>"
    )
    return head + _table(
        [
            "point",
            "statistic",
            "experiment [CI]",
            "simulation [CI]",
            "z",
            "agree",
            "note",
        ],
        rows,
        left=(0, 6),
    )


def input_figures(result):
    """The input figures of a result: its diameter distribution (paper Fig. 2) and
    the roughness-angle PDF of each rough surface (Fig. 4).

    Both are drawn from the result's Dataset only, so a result opened from
    ``results.nc`` gets the same figures as a fresh one: ``diameter_quantile``
    (probability) [m] and ``roughness_angle_quantile`` (surface, probability)
    [rad], the quantile functions at equally spaced mid-probabilities. Smooth
    surfaces (``surface_is_smooth``) and rows without a finite quantile have no
    figure; a result without these variables has none.

    Returns a list of ``(name, caption, figure)``; names are ``size_distribution``
    and ``angle_pdf_<surface>``, the surface name made safe for a file name
    (characters other than letters, digits, ``-`` and ``_`` become ``_``; a name
    that clashes with an earlier one gets ``_2``, ``_3``, ...).
    """

    out = []
    ds = getattr(result, "dataset", None)
    if ds is None:
        return out
    if "diameter_quantile" in ds:
        d_um = m_to_um(np.asarray(ds["diameter_quantile"].values, dtype=float))
        if np.isfinite(d_um).any():
            ax = plot_size_quantiles(d_um)
            out.append(
                (
                    "size_distribution",
                    "Particle diameter distribution (paper Fig. 2), drawn from its "
                    "quantile function.",
                    ax.figure,
                )
            )
    if "roughness_angle_quantile" not in ds:
        return out
    smooth = smooth_surfaces(result)
    quantiles = np.asarray(ds["roughness_angle_quantile"].values, dtype=float)
    used = set()
    for name, row in zip(ds["surface"].values, quantiles, strict=True):
        name = str(name)
        if smooth.get(name, False) or not np.isfinite(row).any():
            continue
        ax = plot_angle_pdf(rad_to_deg(row[np.isfinite(row)]))
        ax.set_title(f"Surface {name}")
        fname = stem = f"angle_pdf_{_slug(name)}"
        k = 1
        while fname in used:  # e.g. surfaces "a/b" and "a_b"
            k += 1
            fname = f"{stem}_{k}"
        used.add(fname)
        out.append(
            (
                fname,
                f"Roughness-angle probability density of surface {name!r} "
                "(paper Fig. 4), drawn from its quantile function.",
                ax.figure,
            )
        )
    return out


def _experiments_for(result, experiments):
    """The experiments table of `result` (`experiments` may map scenario names to
    experiments); None: none (the scenario's files are not read here)."""

    if isinstance(experiments, dict):
        experiments = experiments.get(result.scenario.name)
    return combine_experiments(experiments)


def _png_uri_from_file(path) -> str:
    data = Path(path).read_bytes()
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _stem_of(fig):
    return fig.stem if isinstance(fig, Path) else None


def _embed(fig, caption) -> str:
    """A figure (a PNG file or a matplotlib Figure, closed here) as HTML."""
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    if isinstance(fig, Path):
        return _figure_html(_png_uri_from_file(fig), caption)
    try:
        return _figure_html(_png_data_uri(fig), caption)
    finally:
        plt.close(fig)


def figure_anchor(k, name, stem) -> str:
    """The in-page id of figure `stem` of result `k` (named `name`)."""
    return f"r{k}-{_slug(name)}-{_slug(stem)}"


def _statements_section(results, study) -> str:
    """The paper's statements judged over the Formica family
    (:mod:`microimpact.analysis.robustness`): first what is the paper's, assumed
    and calibrated, then the verdicts, the unstated conditions and, apart, the
    statements that hold by construction."""
    names = [r.scenario.name for r in results]
    verdicts = evaluate(Evidence.from_results(results))
    anchors = {}
    for st in STATEMENTS:
        preset, _, stem = st.figure.partition("/")
        if preset in names:
            k = names.index(preset)
            anchors[st.figure] = "#" + figure_anchor(k, preset, stem)
    return (
        '<section id="statements"><h2>How this compares with the paper</h2>'
        f"<p>{_e(DISCLOSURE)}</p>"
        f"<p>{_e(summary_sentence(study))} Verdicts: <b>robust</b> (held in at "
        f"least {100 * ROBUST:.0f} % of the runs), <b>contradicted</b> (at most "
        f"{100 * CONTRADICTED:.0f} %), otherwise <b>depends on the unknown "
        "surface</b>; "
        "the interval is a 95 % Wilson interval. Every claim of the paper, with "
        "ours: <code>docs/paper-comparison.md</code>; the readings' thresholds and "
        "their reasons: <code>docs/presets.md</code>.</p>"
        + robustness_table_html(study, anchors=anchors)
        + "<h3>Under the conditions the paper does not state</h3>"
        "<p>Share of the surfaces on which each statement holds, by incident speed "
        "of the oblique case and shadowing rule (the preset: 1 m/s, reject).</p>"
        + '<div class="scroll">'
        + conditions_table_html(study)
        + "</div>"
        + "<h3>Inputs: statements that hold by construction</h3>"
        "<p>Calibrated inputs, algebra and properties the surface family is built "
        "with. They hold here because we made them hold; they are not evidence.</p>"
        + inputs_table_html(study, verdicts)
        + "</section>"
    )


def _result_section(result, k, csv_href, experiments, saved, speeds=None) -> str:
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    sc = result.scenario
    anchor = f"r{k}-{_slug(sc.name)}"
    parts = [f'<section id="{anchor}"><h2>{_e(sc.name)}</h2>']
    if getattr(sc, "description", ""):
        parts.append(f'<p class="sub">{_e(sc.description)}</p>')
    parts += ["<h3>Scenario</h3>", _settings(result)]
    parts += ["<h3>Provenance</h3>", _provenance(result)]
    parts += ["<h3>Capture speed</h3>", _capture_table(result)]
    parts += ["<h3>Summary</h3>", _summary_table(result, csv_href)]
    exp = _experiments_for(result, experiments)
    if exp is not None and len(exp):
        parts += [
            "<h3>Comparison with experiments</h3>",
            _comparison_html(compare(result, exp)),
        ]
    pngs = [Path(p) for p in saved or () if Path(p).suffix.lower() == ".png"]
    if saved is not None and not pngs and len(saved):
        saved = None  # figure files, but none a PNG (e.g. SVG only): draw them here
    if saved is not None:  # figure files already written for this result
        v = (speeds or {}).get(result.scenario.name)
        figs = [
            (
                figure_caption(
                    p.stem,
                    result,
                    distribution_speed_m_s=v,
                    experiments=exp is not None and len(exp) > 0,
                ),
                p,
            )
            for p in pngs
        ]
    else:
        made = result_figures(
            result,
            experiments=exp,
            distribution_speed_m_s=(speeds or {}).get(result.scenario.name),
        )
        stems = {id(f): stem for stem, _, f in made}
        figs = [(c, f) for _, c, f in made]
    rc = {"figure.figsize": (5.0, 3.4), "figure.constrained_layout.use": True}
    if saved is None:  # otherwise the caller wrote the input figures too
        with styled(rc):  # not rc_context: it would reset a notebook's interactive
            inputs = input_figures(result)
        stems.update({id(f): stem for stem, _, f in inputs})
        figs += [(c, f) for _, c, f in inputs]
    areal = [(c, f) for c, f in figs if _stem_of(f) == "profile_vs_areal"]
    if not areal and saved is None:
        areal = [(c, f) for c, f in figs if c == CAPTION]
    if areal:  # its own section: a comparison the paper does not make
        figs = [x for x in figs if x not in areal]
        parts += [
            "<h3>Profile versus areal roughness</h3>",
            "<p>This comparison is new: it is not in the paper. Li, Dunn &amp; "
            "Brach (2000) model a profile, whose facets tilt in the plane of "
            "incidence only; an areal surface's facets also tilt across it, which "
            "changes the normal speed on the facet and deflects the rebound "
            "sideways. The lateral scatter is the standard deviation of the folded "
            "lateral angle ψ<sub>f</sub> = atan2(V<sub>b</sub>, |V<sub>t</sub>|) "
            "of the rebounds, exactly 0 on a profile. It is a model prediction "
            "that no experiment here confirms.</p>",
        ]
        parts += [_embed(f, c) for c, f in areal]
    if figs:
        parts.append("<h3>Figures</h3>")
    for caption, fig in figs:
        if isinstance(fig, Path):  # the statement table links here (figure_anchor)
            fid = figure_anchor(k, sc.name, fig.stem)
            parts.append(_figure_html(_png_uri_from_file(fig), caption, fid))
            continue
        stem = stems.get(id(fig)) if saved is None else None
        fid = figure_anchor(k, sc.name, stem) if stem else None
        try:
            parts.append(_figure_html(_png_data_uri(fig), caption, fid))
        finally:
            plt.close(fig)
    parts.append("</section>")
    return "\n".join(parts)


def _extra_items(extra_figures):
    """``extra_figures`` -> list of (caption, Figure | Axes | Path)."""
    if not extra_figures:
        return []
    pairs = (
        list(extra_figures.items())
        if isinstance(extra_figures, dict)
        else [(None, f) for f in extra_figures]
    )
    out = []
    for caption, fig in pairs:
        if isinstance(fig, list | tuple):  # a group of files: embed the PNGs
            for f in fig:
                if Path(f).suffix.lower() == ".png":
                    stem = Path(f).stem.replace("_", " ")
                    out.append((f"{caption}: {stem}" if caption else stem, Path(f)))
            continue
        if isinstance(fig, str | os.PathLike):
            path = Path(fig)
            if path.suffix.lower() != ".png":
                raise ValueError(
                    f"`extra_figures` files must be PNG images; got {str(path)!r}."
                )
            out.append((caption or path.stem.replace("_", " "), path))
        elif hasattr(fig, "savefig") or (
            hasattr(fig, "figure") and hasattr(fig.figure, "savefig")
        ):
            out.append((caption or "", fig))
        else:
            raise TypeError(
                "`extra_figures` items must be matplotlib Figures/Axes or PNG paths; "
                f"got {type(fig).__name__}."
            )
    return out


def _extra_figures_html(items) -> str:
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    if not items:
        return ""
    parts = ['<section id="extra"><h2>Additional figures</h2>']
    for caption, fig in items:
        if isinstance(fig, Path):
            uri = _png_uri_from_file(fig)
        else:
            f = fig if hasattr(fig, "savefig") else fig.figure
            uri = _png_data_uri(f)
            plt.close(f)
        parts.append(_figure_html(uri, caption))
    parts.append("</section>")
    return "\n".join(parts)


def write_report(
    results,
    out_path,
    *,
    title=None,
    extra_figures=None,
    notes=None,
    experiments=None,
    csv_paths=None,
    statements=False,
    distribution_speeds=None,
):
    """Write one self-contained HTML report for one or several results.

    Parameters
    ----------
    results : SimulationResult or sequence of SimulationResult
    out_path : str or path-like
        The HTML file (its folder is created if needed); written atomically.
    title : str, optional
        Page title (default: "microimpact report" and the scenario names).
    extra_figures : dict or sequence, optional
        More figures to embed: ``{caption: Figure | Axes | path.png}`` or a list of
        them. A value that is a list of files is a group: its PNG files are
        embedded (other formats skipped). When the key of such a group is the name
        of a scenario in `results` (as ``{name: figures_for_result(...)}``), those
        files are that result's figures and are embedded in its section instead of
        being drawn again; if the group holds files but no PNG (e.g. SVG only),
        the section draws its figures itself, and an empty group means no figures
        for that result.
    notes : str or sequence of str, optional
        Paragraphs shown at the top (escaped; no HTML).
    experiments : dict, optional
        ``{scenario name: experiments}`` (DataFrame, path or list of them), for
        the comparison table and figure; default: none.
    csv_paths : sequence of path-like, optional
        One per result: the full summary CSV to link to (e.g. the ``summary.csv``
        written by :meth:`SimulationResult.to_files`). By default the summary is
        written next to the report as ``<name>_summary.csv`` and linked.
    statements : bool or RobustnessStudy, default False
        Open with the paper's statements judged over the Formica family
        (:func:`microimpact.analysis.robustness.robustness_study`; for the
        paper's presets, as ``microimpact reproduce`` writes it). ``True`` runs
        the study at its full size (about 20 s).
    distribution_speeds : dict, optional
        Scenario name -> the swept speed [m/s] of its distribution figures
        (default: the slowest swept speed at which particles rebound).

    Returns
    -------
    pathlib.Path
        `out_path`.
    """

    if hasattr(results, "summary"):
        results = [results]
    results = list(results)
    if not results or not all(hasattr(r, "summary") for r in results):
        raise TypeError(
            "`results` must be a SimulationResult or a non-empty sequence of them; "
            f"got {results!r}."
        )
    if csv_paths is not None and len(csv_paths) != len(results):
        raise ValueError(
            f"`csv_paths` must have one path per result ({len(results)}); "
            f"got {len(csv_paths)}."
        )
    out_path = Path(out_path)
    report_dir = out_path.parent
    report_dir.mkdir(parents=True, exist_ok=True)
    names = [r.scenario.name for r in results]
    title = title or "microimpact report: " + ", ".join(names)
    if isinstance(notes, str):
        notes = [notes]
    hrefs = []
    for k, r in enumerate(results):
        if csv_paths is None:
            csv = report_dir / f"{_slug(r.scenario.name)}_summary.csv"
            r.to_csv(csv)
        else:
            csv = Path(csv_paths[k])
        rel = os.path.relpath(csv.resolve(), report_dir.resolve())
        hrefs.append(Path(rel).as_posix())
    saved = {}
    if isinstance(extra_figures, dict):
        extra_figures = dict(extra_figures)
        for n in names:
            if isinstance(extra_figures.get(n), list | tuple):
                saved[n] = extra_figures.pop(n)
    extra = _extra_items(extra_figures)  # validated before any drawing
    sections = [
        _result_section(
            r,
            k,
            hrefs[k],
            experiments,
            saved.get(r.scenario.name),
            distribution_speeds,
        )
        for k, r in enumerate(results)
    ]
    extra_html = _extra_figures_html(extra)
    if statements is True:
        statements = robustness_study()
    statements_html = _statements_section(results, statements) if statements else ""
    nav = "".join(
        f'<li><a href="#r{k}-{_slug(n)}">{_e(n)}</a></li>' for k, n in enumerate(names)
    )
    created = results[0].provenance.get("created", "")
    notes_html = (
        '<div class="notes">' + "".join(f"<p>{_e(p)}</p>" for p in notes) + "</div>"
        if notes
        else ""
    )
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="microimpact {_e(__version__)}">
<title>{_e(title)}</title><style>{_CSS}</style></head>
<body><main>
<h1>{_e(title)}</h1>
<p class="sub">Monte Carlo analysis of polydisperse microparticle impacts after
Li, Dunn &amp; Brach (2000), <i>Aerosol Sci. Technol.</i> 33:376–386.
microimpact {_e(__version__)}; {_e(created)}.</p>
{notes_html}
{statements_html}
<nav><ul>{nav}</ul></nav>
{"".join(sections)}
{extra_html}
</main></body></html>
"""
    return atomic_write(out_path, lambda t: Path(t).write_text(page, encoding="utf-8"))


def write_section_page(path, title, section_html, *, subtitle="") -> Path:
    """Write a self-contained report page (the reports' style sheet) around one
    section's HTML, atomically: the page of a verb whose report is one section
    (``microimpact resuspend``, ``microimpact calibrate --method bayes``)."""
    page = (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f'<meta name="generator" content="microimpact {_e(__version__)}">'
        f"<title>{_e(title)}</title><style>{_CSS}</style></head>"
        f"<body><main><h1>{_e(title)}</h1>"
        + (f'<p class="sub">{_e(subtitle)}</p>' if subtitle else "")
        + section_html
        + "</main></body></html>\n"
    )
    return atomic_write(
        Path(path), lambda t: Path(t).write_text(page, encoding="utf-8")
    )


# ------------------------------------------------------------------ text
def summary_text(result) -> str:
    """A plain-text (Markdown) summary of a result for terminals.

    Gives the scenario, versions, seed entropy, run time and, per sweep point, n and
    estimate ± SE of the capture fraction, e (rebounds) and μ. A sweep of more than
    :data:`TEXT_ROWS` points shows that many informative ones (see
    :func:`~microimpact.pipeline.rows.summary_rows`), and as many capture curves,
    and says where the rest are.

    Parameters
    ----------
    result : SimulationResult

    Returns
    -------
    str
    """
    if not hasattr(result, "summary"):
        raise TypeError(
            f"`result` must be a SimulationResult; got {type(result).__name__}."
        )
    sc = result.scenario
    p = result.provenance or {}
    s = result.summary
    lines = [f"# {sc.name}"]
    if getattr(sc, "description", ""):
        lines.append(sc.description)
    lines += [
        "",
        f"- seed entropy: {result.seed_entropy}",
        "- versions: "
        + ", ".join(f"{k} {v}" for k, v in p.get("versions", {}).items()),
        f"- sampling: {p.get('sampling', sc.sampling)}, shadowing: {sc.shadowing}, "
        f"confidence: {_confidence(result):g}",
        f"- sweep: {len(s)} points; run time {float(result.elapsed_s):.3g} s "
        f"({p.get('backend', '?')}, {_workers(p, '?')})",
        "",
    ]
    head = [
        "surface",
        "speed [m/s]",
        "angle [deg]",
        "n",
        "capture ± SE",
        "e (rebounds) ± SE",
        "mu ± SE",
    ]
    shown, why = summary_rows(s, TEXT_ROWS)
    rows = []
    for _, r in s.iloc[shown].iterrows():
        rows.append(
            [
                str(r["surface"]),
                _fmt(r["speed_m_s"]),
                _fmt(r["angle_deg"]),
                f"{int(r['n'])}",
                _pm(float(r["capture_fraction"]), float(r["capture_se"])),
                _pm(float(r["e_rebound_mean"]), float(r["e_rebound_se"])),
                _pm(float(r["mu_mean"]), float(r["mu_se"])),
            ]
        )
    widths = [max(len(h), *(len(x[i]) for x in rows)) for i, h in enumerate(head)]
    lines.append(
        "| " + " | ".join(h.ljust(w) for h, w in zip(head, widths, strict=True)) + " |"
    )
    lines.append("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for row in rows:
        lines.append(
            "| "
            + " | ".join(c.rjust(w) for c, w in zip(row, widths, strict=True))
            + " |"
        )
    if why:
        lines.append(
            f"\n{len(shown)} of {len(s):,} sweep points shown (the point nearest 50 % "
            "capture on evenly spaced capture curves, the extremes, evenly spaced "
            "rows); every point is in summary.csv and results.nc."
        )
    try:
        cs = result.capture_speed()
    except (KeyError, ValueError, AttributeError):
        cs = []
    if len(cs):
        lines.append("")
        total = len(cs)
        cs = cs.iloc[capture_rows(cs, TEXT_ROWS)]
        for _, r in cs.iterrows():
            line = (
                f"- {100 * _num(r['quantile']):g} % capture speed, {r['surface']} at "
                f"{_num(r['angle_deg']):g} deg: "
                + _speed_interval(
                    r["speed_m_s"], r["speed_ci_low"], r["speed_ci_high"], 4
                ).replace(" [", " m/s [", 1)
            )
            note = r.get("note")
            if isinstance(note, str) and note.strip():
                line += f" ({note.strip()})"
            lines.append(line)
        if len(cs) < total:
            lines.append(
                f"- ... {len(cs)} of {total:,} capture curves shown (evenly spaced); "
                "all in capture_speed.csv"
            )
    bad = heavy_tail_points(s, HEAVY_TAIL_NAMED)
    flagged = bad.attrs["flagged"]
    if flagged:
        lines.append("")
        lines.append(
            f"- heavy tails: the mean of {flagged} point(s) is at the mercy of a few "
            "impacts (the 0.1 % farthest rebounds hold > 25 % of the squared "
            "deviations of e_m or mu_m; docs/outputs.md): "
            + ", ".join(
                f"{r['surface']} {_fmt(r['speed_m_s'])} m/s {_fmt(r['angle_deg'])} deg"
                for _, r in bad.iterrows()
            )
            + (
                f" and {flagged - len(bad):,} more (summary.csv column heavy_tail)"
                if flagged > len(bad)
                else ""
            )
        )
    return "\n".join(lines) + "\n"
