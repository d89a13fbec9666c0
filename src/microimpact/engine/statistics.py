"""Estimates, standard errors and confidence intervals from accumulators.

Plain Monte Carlo: the capture fraction gets a Wilson score interval (binomial) and
the standard error ``capture_se`` = the interval's width over ``2 z``
(:func:`interval_se`); means get normal-theory intervals ``mean +- z SE`` with
``SE = s/sqrt(n)``.

Quasi-Monte Carlo: the ``R`` independently scrambled replicates give ``R`` independent
estimates of every statistic; the point estimate pools all impacts and the interval
is ``+- t_{R-1} SE`` with ``SE`` the standard deviation of the replicate estimates over
``sqrt(R)`` (Owen 1997).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtri

from .accumulators import E_EDGES, MU_EDGES, PointAccumulator, histogram_quantile

QUANTILES = (0.05, 0.5, 0.95)


def z_value(confidence: float) -> float:
    """Two-sided standard-normal quantile for `confidence`."""
    return float(ndtri(0.5 + confidence / 2.0))


def wilson_interval(k, n, confidence=0.95):
    """Wilson score interval for a binomial proportion ``k/n``.

    Returns ``(low, high)``; NaN where ``n == 0``.
    """
    k = np.asarray(k, dtype=float)
    n = np.asarray(n, dtype=float)
    z = z_value(confidence)
    with np.errstate(invalid="ignore", divide="ignore"):
        p = k / n
        z2n = z * z / n
        centre = (p + z2n / 2.0) / (1.0 + z2n)
        half = z / (1.0 + z2n) * np.sqrt(p * (1.0 - p) / n + z2n / (4.0 * n))
    return centre - half, centre + half


def interval_se(low, high, confidence):
    """The standard error implied by a two-sided interval: ``(high - low) / (2 z)``.

    The definition of the plain Monte Carlo ``capture_se`` (from the Wilson
    interval, so it stays > 0 at a capture fraction of 0 or 1); NaN where the
    limits are NaN.
    """
    return (np.asarray(high, dtype=float) - np.asarray(low, dtype=float)) / (
        2.0 * z_value(confidence)
    )


def _mean_ci(m, z):
    if m.n < 2:
        return m.mean if m.n else math.nan, math.nan, math.nan, math.nan
    se = math.sqrt(m.variance / m.n)
    return m.mean, se, m.mean - z * se, m.mean + z * se


def point_row(acc: PointAccumulator, confidence: float) -> dict:
    """Summary statistics of one sweep point from its (pooled) accumulator."""
    z = z_value(confidence)
    imp = acc.impacts
    low, high = wilson_interval(acc.captured, imp, confidence)
    e_all = acc.e_all()
    e_mean, e_se, e_lo, e_hi = _mean_ci(e_all, z)
    er_mean, er_se, er_lo, er_hi = _mean_ci(acc.e, z)
    mu_mean, mu_se, mu_lo, mu_hi = _mean_ci(acc.mu, z)
    row = {
        "n": acc.n,
        "n_impacts": imp,
        "n_rebounds": acc.rebounds,
        "capture_fraction": acc.captured / imp if imp else math.nan,
        "capture_ci_low": float(low),
        "capture_ci_high": float(high),
        "e_mean": e_mean,
        "e_std": e_all.std,
        "e_se": e_se,
        "e_ci_low": e_lo,
        "e_ci_high": e_hi,
        "e_rebound_mean": er_mean,
        "e_rebound_std": acc.e.std,
        "e_rebound_se": er_se,
        "e_rebound_ci_low": er_lo,
        "e_rebound_ci_high": er_hi,
        "e_skewness": acc.e.skewness,
        "mu_mean": mu_mean,
        "mu_std": acc.mu.std,
        "mu_se": mu_se,
        "mu_ci_low": mu_lo,
        "mu_ci_high": mu_hi,
        "mu_skewness": acc.mu.skewness,
        "shadowed_fraction": acc.shadowed / acc.n if acc.n else math.nan,
        "reimpact_fraction": acc.reimpact / acc.rebounds if acc.rebounds else math.nan,
        "rolling_fraction": acc.rolling / acc.rebounds if acc.rebounds else math.nan,
    }
    for name, hist, edges in (
        ("e", acc.e_hist, E_EDGES),
        ("mu", acc.mu_hist, MU_EDGES),
    ):
        qs = histogram_quantile(hist, edges, QUANTILES)
        for qv, val in zip(QUANTILES, qs, strict=True):
            row[f"{name}_p{round(qv * 100):02d}"] = float(val)
    row["capture_se"] = float(interval_se(low, high, confidence))
    return row


_REPLICATED = {
    "capture_fraction": ("capture_ci_low", "capture_ci_high", None),
    "e_mean": ("e_ci_low", "e_ci_high", "e_se"),
    "e_rebound_mean": ("e_rebound_ci_low", "e_rebound_ci_high", "e_rebound_se"),
    "mu_mean": ("mu_ci_low", "mu_ci_high", "mu_se"),
}


def replicate_row(accs: list[PointAccumulator], confidence: float) -> dict:
    """QMC summary: pooled estimates, intervals from the spread of replicates."""
    from scipy.stats import t as student_t

    pooled = accs[0]
    for a in accs[1:]:
        pooled = pooled.merge(a)
    row = point_row(pooled, confidence)
    reps = [point_row(a, confidence) for a in accs]
    r = len(reps)
    tq = float(student_t.ppf(0.5 + confidence / 2.0, r - 1))
    for stat, (lo, hi, se_name) in _REPLICATED.items():
        vals = np.array([x[stat] for x in reps], dtype=float)
        se = float(np.std(vals, ddof=1) / math.sqrt(r))
        row[lo] = row[stat] - tq * se
        row[hi] = row[stat] + tq * se
        if se_name:
            row[se_name] = se
        else:
            row["capture_se"] = se
    row["replicates"] = r
    return row


def capture_speed(summary, quantile: float = 0.5):
    """Speed at which a given fraction of particles is captured.

    For each surface and apparent angle, the capture fraction and its confidence
    limits are interpolated linearly against the incident speed (the capture fraction
    falls as the speed rises). The estimate crosses the `quantile`; the interval is
    where the upper and lower confidence curves cross it. NaN where the sweep does
    not bracket the quantile.

    Returns a DataFrame with ``surface``, ``angle_deg``, ``quantile``, ``speed_m_s``,
    ``speed_ci_low``, ``speed_ci_high``.
    """
    import pandas as pd

    rows = []
    for (surface, angle), g in summary.groupby(["surface", "angle_deg"], sort=False):
        g = g.sort_values("speed_m_s")
        v = g["speed_m_s"].to_numpy()
        rows.append(
            {
                "surface": surface,
                "angle_deg": angle,
                "quantile": quantile,
                "speed_m_s": _crossing(v, g["capture_fraction"].to_numpy(), quantile),
                # the high curve crosses later (faster), the low curve earlier
                "speed_ci_low": _crossing(v, g["capture_ci_low"].to_numpy(), quantile),
                "speed_ci_high": _crossing(
                    v, g["capture_ci_high"].to_numpy(), quantile
                ),
            }
        )
    out = pd.DataFrame(rows)
    # the interval is reported low <= high whatever the curve orientation
    lo = out[["speed_ci_low", "speed_ci_high"]].min(axis=1)
    hi = out[["speed_ci_low", "speed_ci_high"]].max(axis=1)
    out["speed_ci_low"], out["speed_ci_high"] = lo, hi
    return out


def _crossing(v, f, level):
    """First speed where the piecewise-linear curve f(v) crosses `level`."""
    d = f - level
    for i in range(len(v) - 1):
        if np.isnan(d[i]) or np.isnan(d[i + 1]):
            continue
        if d[i] == 0:
            return float(v[i])
        if d[i] * d[i + 1] < 0:
            return float(v[i] + (v[i + 1] - v[i]) * d[i] / (d[i] - d[i + 1]))
    if len(v) and d[-1] == 0:
        return float(v[-1])
    return math.nan


def relative_coefficients(summary, reference_angle_deg: float = 85.0):
    """The paper's relative coefficients ``e - e(ref)`` and ``mu - mu(ref)``.

    Adds ``e_relative``, ``e_relative_se``, ``mu_relative``, ``mu_relative_se`` to a
    copy of `summary`: each point's mean minus the mean at the reference angle for the
    same surface and speed, with the standard errors of the two independent estimates
    combined in quadrature. NaN where the reference angle is not in the sweep.
    """
    out = summary.copy()
    ref = summary[np.isclose(summary["angle_deg"], reference_angle_deg)]
    ref = ref.set_index(["surface", "speed_m_s"])
    for stat, se in (("e_rebound_mean", "e_rebound_se"), ("mu_mean", "mu_se")):
        name = "e_relative" if stat.startswith("e") else "mu_relative"
        vals, ses = [], []
        for _, r in out.iterrows():
            key = (r["surface"], r["speed_m_s"])
            if key in ref.index:
                vals.append(r[stat] - ref.loc[key, stat])
                ses.append(math.hypot(r[se], ref.loc[key, se]))
            else:
                vals.append(math.nan)
                ses.append(math.nan)
        out[name] = vals
        out[f"{name}_se"] = ses
    return out
