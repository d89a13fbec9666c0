"""What a Bayesian calibration writes (:class:`.bayes.BayesResult`):
the ArviZ InferenceData (``posterior.nc``), ``calibration.json``, the report section
(Markdown, and HTML for the run report) and the figures."""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from .._core import json as _json
from .._core.files import atomic_write
from ..io.experiments import STATISTIC_LABELS as _LABELS
from ..plotting._style import use_agg
from ..plotting.posterior import plot_corner, plot_posterior_predictive
from .bayes_data import _group_keys
from .pairs import correlate, residual_correlation

__all__ = [
    "inference_data",
    "predictive_table",
    "report_html",
    "section_html",
    "section_html_of_folder",
    "write_result",
]


_DOMINATED = "prior-dominated: the data do not constrain it"


def _split(res):
    lk = res.likelihood
    b = res.blobs
    nm, nc = lk.n_means, lk.n_counts
    return (
        b[..., :nm],
        b[..., nm : 2 * nm],
        b[..., 2 * nm : 2 * nm + nc],
        b[..., 2 * nm + nc :],
    )


def _replicate(res, seed=0):
    """Replicated data at every posterior draw: ``(means, captured, e means)``,
    each walkers x draws x points."""
    rng = np.random.default_rng(seed)
    m, s_sim, p, e_mean = _split(res)
    data = res.data
    means = captured = None
    if res.likelihood.n_means:
        s_exp = data.means["se"].to_numpy(float)
        sigma = np.sqrt(s_exp**2 + np.nan_to_num(s_sim) ** 2)
        lk = res.likelihood  # e and mu on one set of impacts: correlated as fitted
        r = residual_correlation(lk.pairs, lk.rho, s_exp, np.nan_to_num(s_sim))
        means = m + sigma * correlate(rng.standard_normal(m.shape), lk.pairs, r)
    if res.likelihood.n_counts:
        n = data.counts["n"].to_numpy(int)
        lo = 0.5 / res.samples
        captured = rng.binomial(n, np.clip(np.nan_to_num(p, nan=lo), lo, 1 - lo))
    return means, captured, e_mean


def inference_data(res):
    """The ArviZ InferenceData of `res`: ``posterior`` (one variable per parameter
    key; chains are the walkers), ``sample_stats`` (``lp``), ``observed_data``
    (``mean`` with ``se``, ``captured`` with ``n``, ``e`` per impact) and
    ``posterior_predictive`` (replicated ``mean`` and ``captured``; ``e_mean``,
    the simulated mean rebound e at each per-impact point)."""
    # deferred: ArviZ loads only for a Bayesian calibration (import time)
    import arviz as az

    posterior = {k: res.chain[:, :, j] for j, k in enumerate(res.keys)}
    means, captured, e_mean = _replicate(res)
    data = res.data
    obs, pred, dims = {}, {}, {}
    if means is not None:
        obs["mean"] = data.means["mean"].to_numpy(float)
        obs["se"] = data.means["se"].to_numpy(float)
        pred["mean"] = means
        dims.update(mean=["mean_point"], se=["mean_point"])
    if captured is not None:
        obs["captured"] = data.counts["captured"].to_numpy(int)
        obs["n"] = data.counts["n"].to_numpy(int)
        pred["captured"] = captured
        dims.update(captured=["count_point"], n=["count_point"])
    if data.impacts is not None:
        obs["e"] = data.impacts["e"].to_numpy(float)
        pred["e_mean"] = e_mean
        dims.update(e=["impact"], e_mean=["impact_point"])
    idata = az.from_dict(
        posterior=posterior,
        sample_stats={"lp": res.log_prob},
        observed_data=obs,
        posterior_predictive=pred,
        dims=dims,
    )
    d = res.diagnostics
    idata.posterior.attrs.update(
        {
            "method": "emcee ensemble sampler, walkers as chains",
            "burn_in_discarded": int(d.burn_in),
            "steps": int(d.steps),
            "converged": int(d.converged),
            "more_steps_needed": int(d.more_steps),
            "engine_seed": int(res.seed),
            "impacts_per_point": int(res.samples),
            "priors": json.dumps(
                {k: p.to_dict() for k, p in zip(res.keys, res.priors, strict=True)}
            ),
        }
    )
    return idata


def predictive_table(res):
    """One row per measured point: where, the measurement and its interval, and the
    posterior predictive's median and central interval (at ``res.confidence``)."""
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    a = 1 - res.confidence
    means, captured, e_mean = _replicate(res)
    rows = []

    def x_of(t):
        for c in ("angle_deg", "speed_m_s"):
            if t[c].dropna().nunique() > 1:
                return c
        return "angle_deg" if t["angle_deg"].notna().any() else "speed_m_s"

    def add(t, panel, obs, lo, hi, pred):
        xc = x_of(t)
        q = np.nanquantile(
            pred.reshape(-1, pred.shape[-1]), [a / 2, 0.5, 1 - a / 2], axis=0
        )
        for i in range(len(t)):
            rows.append(
                {
                    "panel": panel[i] if isinstance(panel, list) else panel,
                    "x": float(t[xc].iloc[i]),
                    "xlabel": "angle [deg]" if xc == "angle_deg" else "speed [m/s]",
                    "obs": float(obs[i]),
                    "obs_low": float(lo[i]),
                    "obs_high": float(hi[i]),
                    "pred_low": float(q[0, i]),
                    "pred_median": float(q[1, i]),
                    "pred_high": float(q[2, i]),
                }
            )

    data = res.data
    if means is not None:
        t = data.means
        add(
            t,
            [_LABELS.get(s, s) for s in t["statistic"]],
            t["mean"].to_numpy(float),
            t["ci_low"].to_numpy(float),
            t["ci_high"].to_numpy(float),
            means,
        )
    if captured is not None:
        t = data.counts
        n = t["n"].to_numpy(float)
        k = t["captured"].to_numpy(float)
        # deferred: this SciPy submodule loads only when it is used (import time)
        from scipy.stats import beta

        lo = np.where(k > 0, beta.ppf(a / 2, k, n - k + 1), 0.0)  # Clopper-Pearson
        hi = np.where(k < n, beta.ppf(1 - a / 2, k + 1, n - k), 1.0)
        add(t, "capture fraction (counts)", k / n, lo, hi, captured / n)
    if data.impacts is not None:
        t = data.impacts
        keys = _group_keys(t)
        g = t.groupby(keys, sort=False)
        first = g.head(1).reset_index(drop=True)
        m = g["e"].mean().to_numpy(float)
        se = (g["e"].std(ddof=1) / np.sqrt(g["e"].count())).to_numpy(float)
        add(first, "mean e (per-impact data)", m, m - 2 * se, m + 2 * se, e_mean)
    return pd.DataFrame(rows)


def _table_rows(res):
    lo, hi = res.credible()
    med = res.posterior_median
    d = res.diagnostics
    dom = res.prior_dominated
    for j, key in enumerate(res.keys):
        yield key, med[j], lo[j], hi[j], d.r_hat[j], d.ess[j], res.priors[j], dom[j]


def report_markdown(res) -> str:
    """The report section (Markdown)."""
    d = res.diagnostics
    lines = [
        "## Calibration (Bayesian)",
        "",
        f"{res.data.n_points} measured values, {len(res.keys)} parameter(s); emcee "
        f"ensemble of {res.walkers} walkers, {d.steps} steps, burn-in {d.burn_in}; "
        f"engine seed {res.seed}, {res.samples} impacts per sweep point "
        "(common random numbers).",
        "",
        f"| parameter | prior | posterior median | {res.confidence:.0%} credible "
        "interval | R-hat | ESS | note |",
        "|---|---|---|---|---|---|---|",
    ]
    for key, m, lo, hi, r, e, p, dom in _table_rows(res):
        note = "prior-dominated: the data do not constrain it" if dom else ""
        lines.append(
            f"| `{key}` | {p.describe()} | {m:.5g} | [{lo:.4g}, {hi:.4g}] | "
            f"{r:.3f} | {e:.0f} | {note} |"
        )
    lines += ["", *(s.strip() for s in res.summary_lines()[len(res.keys) :])]
    lines += [
        "",
        "![posterior](corner.png)",
        "",
        "![posterior predictive against the measurements](posterior_predictive.png)",
        "",
    ]
    return "\n".join(lines)


def report_html(res, *, figures_dir="") -> str:
    """The report section of `res` as HTML (see :func:`section_html`)."""
    return section_html(res.to_dict(), figures_dir=figures_dir)


def section_html(doc: dict, *, figures_dir="") -> str:
    """The run report's section of a Bayesian calibration, as one HTML
    ``<section>``, from its ``calibration.json`` (`doc`, parsed); the figures are
    referred to under `figures_dir`. Everything shown is escaped."""
    e = html.escape
    conf = float(doc["confidence"])
    rows = []
    for key, p in doc["parameters"].items():
        prior = p["prior"]
        fields = ", ".join(
            f"{k} = {v:g}" for k, v in prior.items() if k != "distribution"
        )
        rows.append(
            f"<tr><td><code>{e(key)}</code></td>"
            f"<td>{e(prior['distribution'])}({e(fields)})</td>"
            f"<td>{p['posterior_median']:.5g}</td>"
            f"<td>[{p['credible_low']:.4g}, {p['credible_high']:.4g}]</td>"
            f"<td>{p['r_hat']:.3f}</td><td>{p['ess']:.0f}</td>"
            f"<td>{_DOMINATED if p['prior_dominated'] else ''}</td></tr>"
        )
    notes = [
        f"{a} and {b} are correlated (r = {r['correlation']:+.2f}): the data fix a "
        "combination of them"
        for r in doc.get("correlated_pairs", [])
        for a, b in [r["keys"]]
    ]
    verdict = (
        f"converged ({doc['steps']} steps, burn-in {doc['burn_in']})"
        if doc["converged"]
        else f"NOT converged after {doc['steps']} steps "
        f"({'; '.join(doc['not_converged_because'])}): run about "
        f"{doc['more_steps_needed']} more steps"
    )
    base = (figures_dir.rstrip("/") + "/") if figures_dir else ""
    items = "".join(f"<li>{e(n)}</li>" for n in [verdict, *notes])
    return (
        '<section id="calibration-bayes"><h2>Calibration (Bayesian)</h2>'
        f"<p>emcee ensemble of {int(doc['walkers'])} walkers; engine seed "
        f"{int(doc['seed'])}, {int(doc['samples'])} impacts per sweep point (common "
        "random numbers).</p>"
        "<table><thead><tr><th>parameter</th><th>prior</th><th>posterior median</th>"
        f"<th>{conf:.0%} credible interval</th><th>R-hat</th><th>ESS</th>"
        f"<th>note</th></tr></thead><tbody>{''.join(rows)}</tbody></table>"
        f"<ul>{items}</ul>"
        f'<figure><img src="{e(base)}corner.png" alt="posterior corner plot">'
        "<figcaption>Posterior after burn-in.</figcaption></figure>"
        f'<figure><img src="{e(base)}posterior_predictive.png" '
        'alt="posterior predictive against the measurements">'
        "<figcaption>Posterior predictive against the measurements.</figcaption>"
        "</figure></section>"
    )


def section_html_of_folder(folder, *, figures_dir="") -> str:
    """:func:`section_html` of the ``calibration.json`` in `folder`; ``""`` where
    there is none or it is not a Bayesian calibration (the hook for the run
    report)."""
    path = Path(folder) / "calibration.json"
    if not path.is_file():
        return ""
    doc = json.loads(path.read_text(encoding="utf-8"))
    if doc.get("method") != "bayes":
        return ""
    return section_html(doc, figures_dir=figures_dir)


def write_result(res, out, *, figure=True) -> Path:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    text = _json.dumps(res.to_dict(), indent=2)
    atomic_write(out / "calibration.json", lambda t: Path(t).write_text(text))
    idata = inference_data(res)
    atomic_write(out / "posterior.nc", lambda t: idata.to_netcdf(t))
    report = report_markdown(res)
    atomic_write(out / "calibration.md", lambda t: Path(t).write_text(report))
    if figure:
        use_agg()
        # deferred: matplotlib loads only when a figure is drawn (import time)
        import matplotlib.pyplot as plt

        for name, fig in (
            ("corner.png", plot_corner(res.flat, res.keys)),
            (
                "posterior_predictive.png",
                plot_posterior_predictive(predictive_table(res)),
            ),
        ):
            try:
                atomic_write(
                    out / name, lambda t, f=fig: f.savefig(t, format="png", dpi=150)
                )
            finally:
                plt.close(fig)
    return out
