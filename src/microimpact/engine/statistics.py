"""Estimates, standard errors and confidence intervals from accumulators.

Plain Monte Carlo: the capture fraction gets a Wilson score interval (binomial) and
the standard error ``capture_se`` = the interval's width over ``2 z``
(:func:`interval_se`); means get normal-theory intervals ``mean +- z SE`` with
``SE = s/sqrt(n)``.

Quasi-Monte Carlo: the ``R`` independently scrambled replicates give ``R`` independent
estimates of every statistic; the point estimate pools all impacts and the interval
is ``+- t_{R-1} SE`` with ``SE`` the standard deviation of the replicate estimates over
``sqrt(R)`` (Owen 1997).

A run computes these for all sweep points at once in :mod:`.summary`;
:func:`point_row` is the one-point definition the tests check it against.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtri

from ..scenario.grid import DIMS
from .accumulators import (
    E_EDGES,
    LATERAL_EDGES,
    MU_EDGES,
    PointAccumulator,
    histogram_quantile,
)
from .capture import estimate_capture_speed

#: Histogram quantiles reported per point (``e_p05`` ...).
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
    # the exact limits lie in [0, 1] and hold k/n; round-off must not push them
    # out (at k = 0 it gave a lower limit of 3e-18 > 0 = k/n)
    low = np.minimum(np.clip(centre - half, 0.0, 1.0), p)
    high = np.maximum(np.clip(centre + half, 0.0, 1.0), p)
    return low, high


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
    """Summary statistics of one sweep point from its (pooled) accumulator.

    The scalar, one-point definition of the plain Monte Carlo statistics, kept as
    the independent oracle the tests hold the vectorised
    :func:`microimpact.engine.summary.point_statistics` to (bit for bit); runs use
    that one (and :func:`~microimpact.engine.summary.replicate_statistics` for QMC).
    """
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
    lat = acc.lateral  # the folded lateral angle psi_f [deg] over rebounds
    lat_mean, lat_se, lat_lo, lat_hi = _mean_ci(lat, z)
    row["lateral_mean_deg"] = lat_mean
    row["lateral_std_deg"] = lat.std
    row["lateral_se_deg"] = lat_se
    row["lateral_ci_low_deg"] = lat_lo
    row["lateral_ci_high_deg"] = lat_hi
    if lat.n and lat.m2 == 0.0:  # no spread (a profile surface): its value
        qs = [lat.mean] * len(QUANTILES)
    else:
        qs = histogram_quantile(acc.lateral_hist, LATERAL_EDGES, QUANTILES)
    for qv, val in zip(QUANTILES, qs, strict=True):
        row[f"lateral_p{round(qv * 100):02d}_deg"] = float(val)
    return row


def capture_speed(
    summary, quantile: float = 0.5, *, confidence=None, by=None, estimator="auto"
):
    """Speed at which a fraction `quantile` of the particles is captured.

    For each capture curve (by default each surface and angle), from the sweep
    points around the crossing: by default the shape-free isotonic estimate
    (interpolated on the probit scale between the two speeds that bracket the
    crossing, with an interval that shrinks as 1/sqrt(N) whatever the shape of the
    curve), and a probit in log speed only where it fits and the sweep is too
    coarse to interpolate. See
    :func:`microimpact.engine.capture.estimate_capture_speed` and
    ``docs/capture-speed.md``.

    Parameters
    ----------
    summary : DataFrame
        The summary table: ``speed_m_s``, ``n_impacts``, ``capture_fraction`` and the
        `by` columns; with a ``replicates`` column (QMC) also ``capture_se``, from
        which effective binomial counts are derived (``capture_se_df`` =
        replicates - 1). Captured counts are ``round(capture_fraction * n_impacts)``.
    quantile : float
        Captured fraction in (0, 1).
    confidence : float, optional, keyword-only
        Confidence level; default ``summary.attrs["confidence"]``, else 0.95.
    by : sequence of str, optional, keyword-only
        Columns that identify one curve; default every sweep axis of
        :data:`microimpact.scenario.grid.DIMS` present in `summary` except ``speed_m_s``
        (today ``surface`` and ``angle_deg``), so a new sweep axis is grouped by
        without a change here.
    estimator : {"auto", "probit", "monotone"}, keyword-only
        Passed to :func:`~microimpact.engine.capture.estimate_capture_speed`
        (``"probit"``: the probit alone, the estimator before 0.2.0).

    Returns
    -------
    DataFrame
        One row per curve, in order of first appearance: the `by` columns,
        ``quantile``, ``speed_m_s``, ``speed_ci_low``, ``speed_ci_high`` [m s⁻¹],
        ``method`` and ``note``. NaN ``speed_m_s`` means no estimate (then both
        limits are NaN; ``note`` says why); a NaN limit beside a finite estimate is
        an open side of the interval. Finite values satisfy
        ``speed_ci_low <= speed_m_s <= speed_ci_high``.

    Raises
    ------
    ValueError
        If a needed column is missing, `quantile`/`confidence` is outside (0, 1),
        or `estimator` is not one of the three.
    """
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    if confidence is None:
        confidence = summary.attrs.get("confidence", 0.95)
    if by is None:
        by = [c for c in DIMS if c != "speed_m_s" and c in summary.columns]
    else:
        by = [by] if isinstance(by, str) else list(by)
    qmc = "replicates" in summary.columns
    need = [*by, "speed_m_s", "n_impacts", "capture_fraction"]
    need += ["capture_se"] if qmc else []
    missing = [c for c in need if c not in summary.columns]
    if missing:
        raise ValueError(
            f"`summary` lacks the column(s) {missing} needed for the capture speed."
        )
    if not 0.0 < float(quantile) < 1.0:
        raise ValueError(f"`quantile` must be in (0, 1); got {quantile!r}.")
    columns = [
        *by,
        "quantile",
        "speed_m_s",
        "speed_ci_low",
        "speed_ci_high",
        "method",
        "note",
    ]
    rows = []
    groups = summary.groupby(by, sort=False, dropna=False) if by else [((), summary)]
    for key, g in groups:
        key = key if isinstance(key, tuple) else (key,)
        n = g["n_impacts"].to_numpy(dtype=float)
        frac = g["capture_fraction"].to_numpy(dtype=float)
        y = np.where(n > 0, np.round(np.nan_to_num(frac) * n), 0.0)
        se = g["capture_se"].to_numpy(dtype=float) if qmc else None
        reps = g["replicates"].to_numpy(dtype=float) if qmc else None
        se_df = float(np.nanmin(reps)) - 1.0 if qmc and np.any(reps > 1) else None
        est = estimate_capture_speed(
            g["speed_m_s"].to_numpy(dtype=float),
            y,
            n,
            quantile,
            confidence=confidence,
            capture_se=se,
            capture_se_df=se_df,
            estimator=estimator,
        )
        rows.append(
            [
                *key,
                float(quantile),
                est.speed_m_s,
                est.ci_low,
                est.ci_high,
                est.method,
                est.note,
            ]
        )
    return pd.DataFrame(rows, columns=columns)


def relative_coefficients(summary, reference_angle_deg: float = 85.0):
    """The paper's relative coefficients ``e - e(ref)`` and ``mu - mu(ref)``.

    Adds ``e_relative``, ``e_relative_se``, ``mu_relative``, ``mu_relative_se`` to a
    copy of `summary`: each point's mean minus the mean at the reference angle for the
    same surface and speed, with the standard errors of the two independent estimates
    combined in quadrature; at the reference angle itself the difference is exactly 0
    with standard error 0. NaN where the reference angle is not in the sweep.

    The table form of :func:`microimpact.engine.summary.relative_to_reference` (which
    fills the result's own columns on the sweep grid), for any summary table, also
    one that is not a full grid.
    """
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    out = summary.copy()
    keys = ["surface", "speed_m_s"]
    ref = summary[np.isclose(summary["angle_deg"], reference_angle_deg)]
    ref = ref.drop_duplicates(keys).set_index(keys)
    where = pd.MultiIndex.from_frame(summary[keys])
    has_ref = where.isin(ref.index)
    at_ref = has_ref & np.array(
        [math.isclose(a, reference_angle_deg) for a in summary["angle_deg"]], dtype=bool
    )
    for stat, se, name in (
        ("e_rebound_mean", "e_rebound_se", "e_relative"),
        ("mu_mean", "mu_se", "mu_relative"),
    ):
        x = summary[stat].to_numpy(dtype=float)
        x_se = summary[se].to_numpy(dtype=float)
        r = ref[stat].reindex(where).to_numpy(dtype=float)
        r_se = ref[se].reindex(where).to_numpy(dtype=float)
        # math.hypot per value, not np.hypot: they can differ in the last bit
        hyp = np.array([math.hypot(a, b) for a, b in zip(x_se, r_se, strict=True)])
        zero = np.where(np.isnan(x), np.nan, 0.0)
        out[name] = np.where(at_ref, zero, np.where(has_ref, x - r, np.nan))
        out[f"{name}_se"] = np.where(at_ref, zero, np.where(has_ref, hyp, np.nan))
    return out
