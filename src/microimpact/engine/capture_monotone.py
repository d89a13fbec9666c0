r"""A shape-free crossing of a capture curve: isotonic fit, probit-scale interpolation.

Used by :func:`microimpact.engine.capture.estimate_capture_speed` where a probit in
log speed does not fit (see ``docs/capture-speed.md``).

Model
-----
The only assumption is that the capture probability :math:`p(x)`, :math:`x = \ln v`,
is monotone in speed. The observed fractions :math:`\hat p_i = y_i/n_i` at the swept
speeds are made monotone by the pool-adjacent-violators algorithm (weights
:math:`n_i`; the isotonic maximum-likelihood estimate of binomial probabilities
[1]_), and each pooled block is one point at the :math:`n`-weighted mean of its log
speeds (*centred* isotonic regression [2]_), so that the fitted curve is strictly
monotone between the points. The crossing :math:`\hat\theta` is interpolated
linearly on the probit scale :math:`z = \Phi^{-1}(p)` between the two points that
bracket :math:`z_q = \Phi^{-1}(q)`:

.. math:: \hat\theta = x_k + (x_{k+1} - x_k)
          \frac{z_q - \hat z_k}{\hat z_{k+1} - \hat z_k}.

The estimand is the crossing :math:`\theta_h` of the same interpolation of the *true*
node probabilities. It equals the true crossing wherever the curve is a probit in log
speed between the two nodes (the smooth-surface log-normal case) and differs from it
by the interpolation error, :math:`O(h^2)` in the node spacing :math:`h` and fixed as
the number of impacts grows; monotonicity alone only bounds that error by the two
bracketing nodes, so it is reported apart (the bracketing speeds and a
``grid-limited`` note), never folded into the interval.

Interval
--------
At a trial :math:`\theta` in the cell :math:`[x_k, x_{k+1}]`, with
:math:`\lambda = (\theta - x_k)/(x_{k+1} - x_k)`, the hypothesis
:math:`\theta_h = \theta` says :math:`(1 - \lambda) z_k + \lambda z_{k+1} = z_q`, a
linear combination of two independent node estimates. It is kept when

.. math:: \big[(1 - \lambda)\hat z_k + \lambda \hat z_{k+1} - z_q\big]^2 \le
          c\,\big[(1 - \lambda)^2 s_k^2 + \lambda^2 s_{k+1}^2\big],
          \qquad s_i^2 = \frac{\hat p_i (1 - \hat p_i)}{n_i\,\varphi(\hat z_i)^2},

(:math:`c = \chi^2_1` at the confidence level; the delta-method variance of the
probit of a binomial fraction). This is Fieller's construction [3]_ applied cell by
cell; the set of kept :math:`\theta` is the interval, walked outwards from
:math:`\hat\theta` across the cells, and a side not closed within the fitted
points is open (NaN). Both :math:`\hat z_i - z_i` and :math:`s_i` are
:math:`O(n_i^{-1/2})`, so the width shrinks as :math:`1/\sqrt N`, whatever the
shape of the curve.

References
----------
.. [1] M. Ayer, H. D. Brunk, G. M. Ewing, W. T. Reid and E. Silverman, "An empirical
   distribution function for sampling with incomplete information," *Ann. Math.
   Stat.* 26:641-647, 1955 (pool-adjacent-violators; the isotonic MLE of ordered
   binomial probabilities).
.. [2] A. P. Oron and N. Flournoy, "Centered isotonic regression: point and interval
   estimation for dose-response studies," *Stat. Biopharm. Res.* 9:258-267, 2017.
.. [3] E. C. Fieller, "Some problems in interval estimation," *J. R. Stat. Soc. B*
   16:175-185, 1954.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize, special

__all__ = ["MonotoneCrossing", "centred_isotonic", "monotone_crossing"]


@dataclass(frozen=True)
class MonotoneCrossing:
    """The interpolated crossing of a monotone capture curve, in log speed.

    Attributes
    ----------
    theta : float
        Estimated :math:`\\ln v_q`; NaN when the isotonic curve does not cross.
    lo, hi : float
        Confidence limits of :math:`\\ln v_q` (the interpolated crossing); NaN for
        an open side.
    bracket : tuple of float
        The log speeds of the two fitted points the estimate is interpolated
        between (equal when a point sits exactly on ``q``).
    bracket_fraction : tuple of float
        The fitted capture fractions at those points.
    interpolation_error : float
        Estimated error of the interpolation, in log speed (:func:`_curvature_error`):
        the next term of Newton's interpolation through a third fitted point, the
        larger of the two neighbours; NaN when there is no third point.
    """

    theta: float
    lo: float
    hi: float
    bracket: tuple[float, float]
    bracket_fraction: tuple[float, float]
    interpolation_error: float


def _pava(y, n, decreasing):
    """Blocks ``[[first, last, sum y, sum n], ...]`` of the pool-adjacent-violators
    fit of the fractions ``y/n`` (weights `n`), non-increasing if `decreasing`;
    each block's fitted fraction is ``sum y / sum n``."""
    blocks = []  # [first, last, sum y, sum n]
    for i in range(y.size):
        blocks.append([i, i, float(y[i]), float(n[i])])
        while len(blocks) > 1:
            a, b = blocks[-2], blocks[-1]
            pa, pb = a[2] / a[3], b[2] / b[3]
            if (pb >= pa) if decreasing else (pb <= pa):  # ties pooled too
                blocks[-2:] = [[a[0], b[1], a[2] + b[2], a[3] + b[3]]]
            else:
                break
    return blocks


def centred_isotonic(x, y, n, *, decreasing: bool = True):
    """Centred isotonic regression of binomial fractions (Oron & Flournoy 2017).

    Parameters
    ----------
    x : ndarray, shape (k,)
        Increasing abscissae (log speeds).
    y, n : ndarray, shape (k,)
        Successes (captures) and trials (impacts) at each `x`, ``n > 0``.
    decreasing : bool, keyword-only
        Fit a non-increasing curve (capture falling with speed) instead of a
        non-decreasing one.

    Returns
    -------
    x_fit, y_fit, n_fit : ndarray, shape (m,)
        One point per pool-adjacent-violators block: its ``n``-weighted mean
        abscissa and its pooled counts. Ties are pooled too, so the fractions
        ``y_fit / n_fit`` are strictly monotone.
    """
    x, y, n = (np.asarray(a, dtype=float) for a in (x, y, n))
    blocks = _pava(y, n, decreasing)
    x_fit = np.array(
        [np.average(x[a : b + 1], weights=n[a : b + 1]) for a, b, _, _ in blocks]
    )
    y_fit = np.array([blk[2] for blk in blocks])
    n_fit = np.array([blk[3] for blk in blocks])
    return x_fit, y_fit, n_fit


def _probit_nodes(y, n):
    """Probit of each fraction and its delta-method variance; a fraction of 0 or 1
    is moved half a count inwards (its probit would be infinite)."""
    p = np.clip(y / n, 0.5 / n, 1.0 - 0.5 / n)
    z = special.ndtri(p)
    pdf = np.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)
    return z, p * (1.0 - p) / (n * pdf * pdf)


def _bracket(d):
    """Index ``k`` of the first cell ``[k, k + 1]`` where `d` changes sign or is 0
    at ``k``; None if `d` has one strict sign."""
    for k in range(d.size):
        if d[k] == 0.0:
            return k
        if k + 1 < d.size and (d[k] > 0) != (d[k + 1] > 0) and d[k + 1] != 0.0:
            return k
        if k + 1 < d.size and d[k + 1] == 0.0:
            return k + 1
    return None


def _curvature_error(xf, z, k, theta):
    """The interpolation error of the crossing in the cell ``[k, k + 1]``, in log
    speed: the quadratic term of Newton's divided differences through a third
    fitted point, ``f[x_{k-1}, x_k, x_{k+1}] (theta - x_k)(theta - x_{k+1})`` (or
    through ``x_{k+2}``), over the cell's slope ``f[x_k, x_{k+1}]``; the larger of
    the two neighbours' readings, NaN if neither exists. It is the leading error of
    linear interpolation on the probit scale (exact for a quadratic); its own noise
    is :math:`O(N^{-1/2})`, like the interval's half-width."""
    slope = (z[k + 1] - z[k]) / (xf[k + 1] - xf[k])
    out = math.nan
    for i in (k - 1, k):  # the triples (k-1, k, k+1) and (k, k+1, k+2)
        if i < 0 or i + 2 >= xf.size:
            continue
        f_a = (z[i + 1] - z[i]) / (xf[i + 1] - xf[i])
        f_b = (z[i + 2] - z[i + 1]) / (xf[i + 2] - xf[i + 1])
        f2 = (f_b - f_a) / (xf[i + 2] - xf[i])
        err = abs(f2 * (theta - xf[k]) * (theta - xf[k + 1]) / slope)
        out = err if math.isnan(out) else max(out, err)
    return out


def _interp(xk, xk1, dk, dk1):
    """Root of the line through ``(xk, dk)``, ``(xk1, dk1)`` (``dk != dk1``)."""
    return xk + (xk1 - xk) * dk / (dk - dk1)


def monotone_crossing(x, y, n, quantile, crit, *, decreasing=True):
    r"""Crossing of `quantile` by the centred isotonic curve, probit-interpolated.

    Parameters
    ----------
    x : ndarray, shape (k,)
        Increasing log speeds.
    y, n : ndarray, shape (k,)
        Captured counts and impacts (``n > 0``; effective counts for QMC).
    quantile : float
        Captured fraction ``q`` in (0, 1).
    crit : float
        Critical value of the squared statistic (:math:`\chi^2_1(c)`, or
        :math:`F_{1,\nu}(c)` for an estimated standard error).
    decreasing : bool, keyword-only
        Capture falls with speed (the physical direction).

    Returns
    -------
    MonotoneCrossing
        With NaN `theta` (and limits) when the isotonic curve does not cross
        `quantile` within `x`.
    """
    xf, yf, nf = centred_isotonic(x, y, n, decreasing=decreasing)
    z, s2 = _probit_nodes(yf, nf)
    z_q = float(special.ndtri(quantile))
    d = z - z_q
    k = _bracket(d)
    if k is None:
        nan = math.nan
        return MonotoneCrossing(nan, nan, nan, (nan, nan), (nan, nan), nan)
    frac = yf / nf
    if d[k] == 0.0 or k + 1 == xf.size:
        theta, err = float(xf[k]), 0.0
        bracket, at = (theta, theta), (float(frac[k]), float(frac[k]))
    else:
        theta = float(_interp(xf[k], xf[k + 1], d[k], d[k + 1]))
        # monotonicity alone puts the crossing between the two bracketing nodes, so
        # the interpolation error is at most the distance to the farther one (the
        # curvature estimate is unbounded where two nodes almost coincide)
        far = max(theta - xf[k], xf[k + 1] - theta)
        err = min(_curvature_error(xf, z, k, theta), far)
        bracket = (float(xf[k]), float(xf[k + 1]))
        at = (float(frac[k]), float(frac[k + 1]))

    def excess(t):
        """Squared statistic minus ``crit`` times its variance at ``theta = t``."""
        j = int(np.clip(np.searchsorted(xf, t, side="right") - 1, 0, xf.size - 2))
        lam = (t - xf[j]) / (xf[j + 1] - xf[j])
        dev = (1.0 - lam) * d[j] + lam * d[j + 1]
        var = (1.0 - lam) ** 2 * s2[j] + lam**2 * s2[j + 1]
        return float(dev * dev - crit * var)

    if xf.size == 1:
        return MonotoneCrossing(theta, math.nan, math.nan, bracket, at, err)
    limits = []
    for step in (-1, 1):
        # the nodes outwards from theta, then the first one rejected
        nodes = xf[xf < theta][::-1] if step < 0 else xf[xf > theta]
        limit, prev = math.nan, theta
        for t in nodes:
            if excess(t) > 0:
                limit = optimize.brentq(excess, min(prev, t), max(prev, t), xtol=1e-14)
                break
            prev = t
        limits.append(limit)
    return MonotoneCrossing(theta, limits[0], limits[1], bracket, at, err)
