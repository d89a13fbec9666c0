"""The mean e and the mean mu measured on one set of impacts: a correlated pair.

Both calibration methods (least squares, :mod:`.calibration`; the posterior,
:mod:`.bayes_data`) take the mean ``e`` and the mean ``mu`` of one experiments
file at one point as measured on the same impacts. Per impact, ``e_m`` and
``mu_m`` are strongly correlated on a rough surface, and so are their means, in
the data and in the model (common random numbers): the pair's residuals have the
covariance of the measurement's errors and of the model's Monte Carlo errors,
each correlated by ``rho``, the correlation of ``e_m`` and ``mu_m`` over the
rebounds the model simulates there (docs/calibration.md).
"""

from __future__ import annotations

import math

import numpy as np

from ..engine.kernel import simulate_block, simulate_specs_impacts

__all__ = [
    "correlate",
    "gaussian_loglik",
    "pair_correlations",
    "pair_covariance",
    "pairs_info",
    "residual_correlation",
    "same_impact_pairs",
    "whiten",
]

_COORDS = ("speed_m_s", "angle_deg")


def same_impact_pairs(means) -> np.ndarray:
    """Rows ``(i, j)`` of the means table that are the mean e (i) and the mean mu
    (j) of one table (``impact_set``, else one ``source`` file) at one surface,
    speed and angle."""
    groups = {}
    for i, r in enumerate(means.itertuples(index=False)):
        stat = r.statistic
        if stat not in ("e", "mu"):
            continue
        key = (
            getattr(r, "impact_set", getattr(r, "source", 0)),
            str(getattr(r, "surface", None)),
            *(
                round(float(getattr(r, c)), 12)
                if math.isfinite(getattr(r, c))
                else None
                for c in _COORDS
            ),
        )
        groups.setdefault(key, {}).setdefault(stat, []).append(i)
    out = [
        (g["e"][0], g["mu"][0])
        for g in groups.values()
        if len(g.get("e", ())) == 1 and len(g.get("mu", ())) == 1
    ]
    return np.asarray(out, dtype=int).reshape(-1, 2)


def _impact_correlation(plan, point: int, samples: int) -> float:
    """The correlation of e_m and mu_m over the rebounds of `samples` impacts at
    sweep point `point` of `plan` (its first replicate's blocks; 0 with fewer
    than 3 rebounds or no spread)."""
    B = plan.block_size
    specs = [(point, 0, b, min(B, samples - b * B)) for b in range(-(-samples // B))]
    if plan.kernel == "compiled":  # the same impacts, in C
        d = simulate_specs_impacts(plan, specs)
        ok = d["outcome"] == 0
        e, mu = d["e_m"][ok], d["mu_m"][ok]
    else:
        e, mu = [], []
        for spec in specs:
            d = simulate_block(plan, *spec, store=True)
            ok = ~(np.asarray(d["captured"], bool) | np.asarray(d["shadowed"], bool))
            e.append(np.asarray(d["e_m"])[ok])
            mu.append(np.asarray(d["mu_m"])[ok])
        e, mu = np.concatenate(e), np.concatenate(mu)
    if e.size < 3 or e.std() == 0 or mu.std() == 0:
        return 0.0
    return float(np.corrcoef(e, mu)[0, 1])


def pair_correlations(model, row, pairs, matcher, *, plan=None) -> np.ndarray:
    """The correlation of ``e_m`` and ``mu_m`` over the rebounds `model` (a
    :class:`~.model.ScenarioModel`) simulates at each pair's sweep point(s) at
    parameters `row`, with its own seed and samples (weighted like the means where
    a point is interpolated); `matcher` maps experiment rows to sweep rows; `plan`:
    ``model.plan(row)`` where the caller has it already (the run's own tables)."""
    if plan is None:
        plan = model.plan(row)
    cache = {}

    def rho_at(point):
        if point not in cache:
            cache[point] = _impact_correlation(plan, point, model.samples)
        return cache[point]

    out = np.zeros(len(pairs))
    for k, (i, _) in enumerate(pairs):
        rows, w = matcher.rows[i], matcher.weights[i]
        out[k] = float(sum(wt * rho_at(int(r)) for r, wt in zip(rows, w, strict=True)))
    return out


def pair_covariance(pairs, rho, s_exp, s_sim) -> np.ndarray:
    """The covariance of each pair's two residuals: the measurement's errors and
    the model's Monte Carlo errors, each correlated by the pair's ``rho`` (the same
    impacts in each), ``rho (s_exp,i s_exp,j + s_sim,i s_sim,j)``; `s_exp` and
    `s_sim` may carry leading axes (draws) over the points' last one."""
    if not len(pairs):
        return np.zeros(0)
    i, j = pairs[:, 0], pairs[:, 1]
    return np.asarray(rho) * (
        s_exp[..., i] * s_exp[..., j] + s_sim[..., i] * s_sim[..., j]
    )


def residual_correlation(pairs, rho, s_exp, s_sim) -> np.ndarray:
    """Each pair's correlation of its two residuals (:func:`pair_covariance` over
    the product of their standard deviations)."""
    if not len(pairs):
        return np.zeros(0)
    i, j = pairs[:, 0], pairs[:, 1]
    sigma = np.sqrt(s_exp**2 + s_sim**2)
    cov = pair_covariance(pairs, rho, s_exp, s_sim)
    return cov / (sigma[..., i] * sigma[..., j])


def correlate(z, pairs, r) -> np.ndarray:
    """Standard normal draws `z` (points on the last axis) with each pair's two
    draws given correlation `r`, in place: ``z_j <- r z_i + sqrt(1 - r^2) z_j``."""
    if len(pairs):
        i, j = pairs[:, 0], pairs[:, 1]
        z[..., j] = r * z[..., i] + np.sqrt(1.0 - r * r) * z[..., j]
    return z


def whiten(resid, pairs, r) -> np.ndarray:
    """Standardised residuals with each pair's correlation `r` removed, in place
    (the inverse of :func:`correlate`): their sum of squares is then the
    generalised chi-squared ``r' C^-1 r``."""
    if len(pairs):
        i, j = pairs[:, 0], pairs[:, 1]
        resid[..., j] = (resid[..., j] - r * resid[..., i]) / np.sqrt(1.0 - r * r)
    return resid


def gaussian_loglik(resid, var, pairs=None, cov=None) -> float:
    """Log-density of residuals `resid` with variances `var`: independent
    Gaussians, except the rows of each pair ``(i, j)`` of `pairs`, bivariate with
    covariance ``cov[k]``."""
    resid = np.asarray(resid, float)
    var = np.asarray(var, float)
    single = np.ones(resid.size, bool)
    ll = 0.0
    if pairs is not None and len(pairs):
        i, j = pairs[:, 0], pairs[:, 1]
        single[i] = single[j] = False
        vi, vj = var[i], var[j]
        c = np.asarray(cov, float)
        det = vi * vj - c * c
        q = (
            resid[i] ** 2 * vj - 2 * resid[i] * resid[j] * c + resid[j] ** 2 * vi
        ) / det
        ll += float(-0.5 * np.sum(q + np.log((2 * math.pi) ** 2 * det)))
    r, v = resid[single], var[single]
    ll += float(-0.5 * np.sum(r * r / v + np.log(2 * math.pi * v)))
    return ll


def pairs_info(pairs, rho, lines) -> list[dict]:
    """``info["same_impact_pairs"]`` of a calibration: each pair's experiment
    lines and its ``rho``."""
    lines = np.asarray(lines)
    return [
        {"lines": [int(lines[i]), int(lines[j])], "rho": round(float(r), 6)}
        for (i, j), r in zip(pairs, rho, strict=True)
    ]
