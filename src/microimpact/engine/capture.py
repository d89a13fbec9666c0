r"""The speed at which a given fraction of the particles is captured, with its interval.

Model
-----
At one surface and angle the engine reports, per incident speed :math:`v_i`, the
number of impacts :math:`n_i` and of captured particles :math:`y_i`. The capture
probability is modelled as a binomial dose-response curve, a probit in log speed,

.. math:: P(\text{capture} \mid v) = \Phi(\alpha + \beta \ln v),

and the :math:`q`-capture speed is its inverse prediction
:math:`\ln v_q = (\Phi^{-1}(q) - \alpha)/\beta`.

The probit is not an approximation for the reference case: at normal incidence on a
smooth surface a particle of diameter :math:`d` is captured iff
:math:`v \le v_c(d) = a (d/d_{ref})^b`. With :math:`b < 0` that is
:math:`d \le d^*(v) = d_{ref} (v/a)^{1/b}`, so for log-normal diameters (median
:math:`m`, geometric standard deviation :math:`g`)

.. math:: P(\text{capture} \mid v) = \Phi\Big(\frac{\ln d^*(v) - \ln m}{\ln g}\Big)
          = \Phi\Big(\frac{\ln d_{ref} - \ln m - \ln a / b}{\ln g}
          + \frac{\ln v}{b \ln g}\Big),

exactly linear in :math:`\ln v` on the probit scale, and :math:`v_q = v_c(d_q)` with
:math:`d_q = m g^{\Phi^{-1}(q)}` the :math:`q`-quantile of the diameter.

Elsewhere (rough surfaces, oblique angles, other size distributions, the paper's
normal diameters) the probit is only a local description. Fitted to a *window* of the
sweep around the crossing (see :func:`crossing_window`), its shape bias does not
shrink with the number of impacts while its interval does, and the residual-deviance
test has too little power to catch that in time: on normal diameters its 95 %
interval held the true speed only 76-83 % of the time at 4,000-40,000 impacts per
speed (``docs/capture-speed.md``).
So the default estimate is shape-free (:mod:`.capture_monotone`: isotonic fit,
probit-scale interpolation between the two speeds bracketing the crossing,
Fieller-type interval); its only approximation is the interpolation between two
nodes, :math:`O(h^2)`, which is estimated and reported apart (``grid-limited``). The
probit is used where that interpolation is grid-limited and the probit fits.

Probit interval
---------------
The interval is the profile-likelihood interval of :math:`\theta = \ln v_q` in the
reparametrisation :math:`\eta_i = \Phi^{-1}(q) + \beta(\ln v_i - \theta)`:
:math:`\{\theta : 2[\ell(\hat\alpha, \hat\beta) - \max_\beta \ell(\theta, \beta)] \le
\chi^2_{1}(c)\}`. Unlike the delta method it is asymmetric where the data are, and it
widens when the swept speeds lie far from the crossing (a coarse sweep): the
resolution of the sweep enters through the likelihood, not only the counts. With
lack of fit (residual deviance :math:`G^2` on :math:`m - 2` degrees of freedom
significant at the 5 % level) the probit is not used by default; with
``estimator="probit"`` the criterion becomes
:math:`\Delta D / h \le F_{1, m-2}(c)` with :math:`h = G^2/(m - 2)` [1]_.

The interval is searched only inside the window's speed range: a side that the
profile likelihood does not close there is *open* and reported as NaN. The estimate
lies inside the interval by construction; a NaN estimate always comes with a NaN
interval.

References
----------
.. [1] D. J. Finney, *Probit Analysis*, 3rd ed., Cambridge University Press, 1971,
   ch. 4 (heterogeneity factor) and §4.6 (fiducial limits of the ED50).
.. [2] D. A. Williams, "Interval estimation of the median lethal dose,"
   *Biometrics* 42:641-645, 1986 (likelihood-ratio limits for the ED50).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize, special, stats

from .capture_monotone import monotone_crossing

__all__ = [
    "ESTIMATORS",
    "GRID_LIMITED_RATIO",
    "LACK_OF_FIT_LEVEL",
    "SPEED_RTOL",
    "WINDOW_MARGIN",
    "CaptureSpeedEstimate",
    "crossing_window",
    "estimate_capture_speed",
]

#: Level of the probit's residual-deviance test: a p-value below it is a lack of fit
#: ("auto" then keeps the isotonic estimate; "probit" widens its interval by the
#: heterogeneity factor, Finney's rule).
LACK_OF_FIT_LEVEL = 0.05

#: Sweep points added to the fitted window on each side of the crossing region.
WINDOW_MARGIN = 2

#: An isotonic estimate whose estimated interpolation error exceeds this fraction of
#: its interval's half-width is ``grid-limited`` (an error of half the half-width
#: lowers the coverage of the true speed from 0.95 to 0.84; the estimate's own noise
#: flags 1-4 % of log-normal curves, which have no such error, by chance).
GRID_LIMITED_RATIO = 0.5

#: Speeds closer than this (relative) are pooled as one repeated speed.
SPEED_RTOL = 1e-9

#: ``method`` values (see ``docs/capture-speed.md``); ``probit-profile-scaled`` only
#: with ``estimator="probit"``.
METHOD_PROFILE = "probit-profile"
METHOD_SCALED = "probit-profile-scaled"
METHOD_MONOTONE = "isotonic-interpolated"
METHOD_NONE = "none"

#: ``estimator`` values of :func:`estimate_capture_speed`: the isotonic estimate, or
#: the probit where the isotonic one is grid-limited and the probit fits
#: (``"auto"``); the probit alone; the isotonic estimate alone.
ESTIMATORS = ("auto", "probit", "monotone")

_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


@dataclass(frozen=True)
class CaptureSpeedEstimate:
    """The ``q``-capture speed of one capture curve.

    Attributes
    ----------
    speed_m_s : float
        Estimated speed at which the fraction ``q`` is captured [m s⁻¹]; NaN when the
        sweep cannot support an estimate (see `note`).
    ci_low, ci_high : float
        Confidence limits [m s⁻¹]; NaN for a side the data do not bound ("open"),
        and both NaN when `speed_m_s` is NaN. When finite,
        ``ci_low <= speed_m_s <= ci_high``.
    method : str
        ``"isotonic-interpolated"`` (shape-free), ``"probit-profile"``,
        ``"probit-profile-scaled"`` (interval widened for lack of fit, with
        ``estimator="probit"`` only) or ``"none"`` (no estimate).
    note : str
        Why a value is NaN, or what the estimate rests on; ``""`` when there is
        nothing to add.
    """

    speed_m_s: float
    ci_low: float
    ci_high: float
    method: str
    note: str


# ----------------------------------------------------------------- validation
def _estimate_capture_speed_iv(
    speed_m_s, captured, impacts, quantile, confidence, capture_se
):
    arrays = {}
    for name, x in (
        ("speed_m_s", speed_m_s),
        ("captured", captured),
        ("impacts", impacts),
    ):
        try:
            a = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(
                f"`{name}` must be numeric (array_like); got {x!r}."
            ) from None
        if a.ndim > 1:
            raise ValueError(f"`{name}` must be 1-d; got shape {a.shape}.")
        arrays[name] = np.atleast_1d(a)
    v, y, n = arrays["speed_m_s"], arrays["captured"], arrays["impacts"]
    if not v.size == y.size == n.size:
        raise ValueError(
            "`speed_m_s`, `captured` and `impacts` must have the same length; got "
            f"{v.size}, {y.size} and {n.size}."
        )
    if not np.all(np.isfinite(v) & (v > 0)):
        raise ValueError(f"`speed_m_s` must be finite and > 0; got {v.tolist()!r}.")
    if not np.all(np.isfinite(n) & (n >= 0)):
        raise ValueError(f"`impacts` must be finite and >= 0; got {n.tolist()!r}.")
    # round-off from fraction * impacts is tolerated
    tol = 1e-9 * np.maximum(n, 1.0)
    if not np.all(np.isfinite(y) & (y >= -tol) & (y <= n + tol)):
        raise ValueError(
            f"`captured` must be finite and in [0, impacts]; got {y.tolist()!r}."
        )
    y = np.clip(y, 0.0, n)
    for name, x in (("quantile", quantile), ("confidence", confidence)):
        if isinstance(x, bool) or not isinstance(x, int | float | np.floating):
            raise ValueError(f"`{name}` must be a number in (0, 1); got {x!r}.")
        if not 0.0 < float(x) < 1.0:
            raise ValueError(f"`{name}` must be in (0, 1); got {x!r}.")
    se = None
    if capture_se is not None:
        try:
            se = np.atleast_1d(np.asarray(capture_se, dtype=float))
        except (TypeError, ValueError):
            raise ValueError(
                "`capture_se` must be numeric (array_like) or None; "
                f"got {capture_se!r}."
            ) from None
        if se.shape != v.shape:
            raise ValueError(
                f"`capture_se` must have the length of `speed_m_s` ({v.size}); "
                f"got shape {se.shape}."
            )
        if np.any(se < 0):
            raise ValueError(
                f"`capture_se` must be >= 0 (NaN allowed); got {se.tolist()!r}."
            )
    return v, y, n, float(quantile), float(confidence), se


# ----------------------------------------------------------------- probit maths
def _loglik(eta, y, n):
    """Binomial log-likelihood (without the constant) of a probit predictor; NaN
    (never a NumPy warning) where a diverging step makes it overflow, and the
    callers reject such a step."""
    with np.errstate(over="ignore", invalid="ignore"):
        return float(
            np.sum(y * special.log_ndtr(eta) + (n - y) * special.log_ndtr(-eta))
        )


def _score_weights(eta, y, n):
    """d loglik / d eta and the Fisher weights of a probit predictor (NaN, without
    a warning, where `eta` overflows)."""
    with np.errstate(over="ignore", invalid="ignore"):
        log_pdf = -0.5 * eta * eta - _LOG_SQRT_2PI
        r_lo = np.exp(log_pdf - special.log_ndtr(eta))  # phi / Phi
        r_hi = np.exp(log_pdf - special.log_ndtr(-eta))  # phi / (1 - Phi)
        score = y * r_lo - (n - y) * r_hi
        weight = n * r_lo * r_hi  # n phi^2 / (Phi (1 - Phi))
    return score, weight


def _fit_probit(x, y, n):
    """Maximum-likelihood probit ``(alpha, beta)`` by Fisher scoring with
    step halving; the data must not be separated (checked by the caller)."""
    p = (y + 0.5) / (n + 1.0)
    z = special.ndtri(p)
    w = n * p * (1 - p) + 1e-12
    design = np.column_stack([np.ones_like(x), x])
    coef = np.linalg.lstsq(design * np.sqrt(w)[:, None], z * np.sqrt(w), rcond=None)[0]
    ll = _loglik(design @ coef, y, n)
    for _ in range(200):
        eta = design @ coef
        score, weight = _score_weights(eta, y, n)
        grad = design.T @ score
        info = design.T @ (design * weight[:, None])
        try:
            step = np.linalg.solve(info, grad)
        except np.linalg.LinAlgError:
            step = np.linalg.lstsq(info, grad, rcond=None)[0]
        t = 1.0
        while True:
            new = coef + t * step
            ll_new = _loglik(design @ new, y, n)
            if ll_new >= ll - 1e-12 or t < 1e-10:
                break
            t /= 2.0
        if not math.isfinite(ll_new):  # a diverging step: keep the last finite fit
            break
        done = abs(ll_new - ll) < 1e-11 * (1.0 + abs(ll))
        coef, ll = new, ll_new
        if done and np.max(np.abs(t * step)) < 1e-9 * (1.0 + np.max(np.abs(coef))):
            break
    return float(coef[0]), float(coef[1]), ll


def _profile_loglik(theta, x, y, n, z_q, beta0):
    """``max_beta loglik(eta = z_q + beta (x - theta))`` (concave in beta)."""
    u = x - theta
    beta = beta0
    ll = _loglik(z_q + beta * u, y, n)
    for _ in range(200):
        score, weight = _score_weights(z_q + beta * u, y, n)
        g = float(np.sum(score * u))
        info = float(np.sum(weight * u * u))
        if info <= 0 or not np.isfinite(info):
            break
        step = g / info
        t = 1.0
        while True:
            b_new = beta + t * step
            ll_new = _loglik(z_q + b_new * u, y, n)
            if ll_new >= ll - 1e-12 or t < 1e-10:
                break
            t /= 2.0
        if not math.isfinite(ll_new):  # a diverging step: keep the last finite one
            break
        done = abs(ll_new - ll) < 1e-12 * (1.0 + abs(ll)) and abs(t * step) < 1e-10 * (
            1.0 + abs(b_new)
        )
        beta, ll = b_new, ll_new
        if done:
            break
    return ll


def _separated(y, n):
    """Whether sorted grouped binomial data are (quasi-)completely separated in x:
    all trials captured below some speed and none above it (or the reverse), ties
    allowed at one speed. The probit MLE then does not exist [Albert & Anderson
    1984]: the slope runs off to infinity."""
    full = y >= n
    empty = y <= 0
    m = y.size
    for j in range(m):
        if (np.all(full[:j]) and np.all(empty[j + 1 :])) or (
            np.all(empty[:j]) and np.all(full[j + 1 :])
        ):
            return True
    return False


def crossing_window(fraction: ArrayLike, quantile: float) -> tuple[int, int] | None:
    """Indices ``(first, last)`` of the sweep points fitted around a crossing.

    `fraction` is the observed capture fraction at increasing speeds. The crossing
    region runs from the first to the last pair of neighbouring points between which
    ``fraction - quantile`` changes sign (or is 0), so that a noisy, non-monotone
    curve is fitted across all its crossings; the window adds
    :data:`WINDOW_MARGIN` (2) more points on each side where the sweep has them. That
    gives (for a single crossing) three points on each side: enough to fit two
    parameters and keep four degrees of freedom to detect a lack of fit (with two,
    Finney's widening :math:`h F_{1,2}` is erratic), few enough that the probit need
    only hold locally.

    Returns ``None`` when `fraction` does not bracket `quantile`.
    """
    f = np.asarray(fraction, dtype=float)
    s = np.sign(f - quantile)
    idx = [i for i in range(f.size - 1) if s[i] == 0 or s[i] != s[i + 1]]
    if f.size and s[-1] == 0:
        idx.append(f.size - 1)
    if not idx or (np.all(s > 0) or np.all(s < 0)):
        return None
    lo, hi = min(idx), min(max(idx) + 1, f.size - 1)
    return max(lo - WINDOW_MARGIN, 0), min(hi + WINDOW_MARGIN, f.size - 1)


def _fmt(v):
    return f"{v:.4g}"


def _within(est, v_lo, v_hi):
    """`est` with its speed clipped to the window's speeds ``[v_lo, v_hi]``: the
    estimate lies there by construction, exp(ln v) only adds a rounding error. The
    limits stay on their sides (they bracket the unclipped estimate)."""
    speed = min(max(est.speed_m_s, float(v_lo)), float(v_hi))
    return dataclasses.replace(est, speed_m_s=speed)


def _none(note):
    return CaptureSpeedEstimate(math.nan, math.nan, math.nan, METHOD_NONE, note)


# ----------------------------------------------------------------- public
class _NoEstimate(Exception):
    """No estimate: `message`, then the `notes` gathered so far."""

    def __init__(self, message, notes=()):
        super().__init__(message)
        self.message, self.notes = message, list(notes)


def _pooled_counts(v, y, n, se, se_df, notes):
    """Effective binomial counts where a non-binomial SE is given; speeds without
    impacts dropped; repeated speeds (equal to :data:`SPEED_RTOL`) pooled, sorted by
    speed."""
    if se is not None:
        with np.errstate(invalid="ignore", divide="ignore"):
            p = np.where(n > 0, y / np.where(n > 0, n, 1.0), np.nan)
            n_eff = p * (1.0 - p) / (se * se)
        use = np.isfinite(n_eff) & (n_eff > 0) & (p > 0) & (p < 1)
        n = np.where(use, n_eff, n)
        y = np.where(use, p * n_eff, y)
        if not np.any(use):
            se_df = None
        else:
            notes.append("effective counts from capture_se")
    has = n > 0
    if not np.all(has):
        notes.append(f"{int(np.sum(~has))} speed(s) without impacts ignored")
    v, y, n = v[has], y[has], n[has]
    if v.size == 0:
        raise _NoEstimate("no impacts at any speed", notes[:-1])
    order = np.argsort(v, kind="stable")
    v, y, n = v[order], y[order], n[order]
    # speeds a rounding error apart are one speed (distinct nodes that close make
    # the interpolation and its interval degenerate)
    first = np.r_[True, np.diff(np.log(v)) > SPEED_RTOL]
    group = np.cumsum(first) - 1
    v = v[first]
    y = np.bincount(group, weights=y)
    n = np.bincount(group, weights=n)
    if v.size == 1:
        raise _NoEstimate(
            f"one speed only ({_fmt(v[0])} m/s, capture "
            f"{y[0] / n[0]:.3g}): a capture speed needs a sweep that "
            "brackets the quantile",
            notes,
        )
    return v, y, n, se_df


def _window(v, frac, q, notes):
    """The sweep points fitted (:func:`crossing_window`), or no estimate when the
    capture fraction does not cross `q` within the sweep."""
    window = crossing_window(frac, q)
    if window is not None:
        return window
    if np.all(frac > q):
        msg = (
            f"capture stays above {q:g} up to the fastest speed "
            f"({_fmt(v[-1])} m/s, capture {frac[-1]:.3g}): the {q:g}-capture "
            f"speed is above the sweep; extend the sweep upwards"
        )
    else:
        msg = (
            f"capture stays below {q:g} down to the slowest speed "
            f"({_fmt(v[0])} m/s, capture {frac[0]:.3g}): the {q:g}-capture "
            f"speed is below the sweep; extend the sweep downwards"
        )
    raise _NoEstimate(msg, notes)


def _check_resolved(v, frac, q, i0, i1, yw, nw, notes):
    """No estimate where the window's data are separated (the crossing is not
    resolved by partially captured speeds)."""
    if not _separated(yw, nw):
        return
    partial = np.flatnonzero((yw > 0) & (yw < nw))
    s = np.sign(frac[i0 : i1 + 1] - q)
    k = next(j for j in range(s.size - 1) if s[j] == 0 or s[j] != s[j + 1])
    lo_v, hi_v = v[i0 + k], v[i0 + k + 1]
    raise _NoEstimate(
        f"not resolved: capture falls from {frac[i0 + k]:.3g} to "
        f"{frac[i0 + k + 1]:.3g} between {_fmt(lo_v)} and {_fmt(hi_v)} "
        f"m/s with {partial.size} partially captured speed(s) in the "
        f"window; the {q:g}-capture speed lies between them; refine the "
        "sweep there",
        notes,
    )


def _crossing(alpha, beta, z_q, xw, v, q, i0, i1, notes) -> float:
    """The log speed where the fitted probit crosses `q`: never extrapolated."""
    theta = (z_q - alpha) / beta if beta != 0 else math.nan
    x_lo, x_hi = float(xw[0]), float(xw[-1])
    if np.isfinite(theta) and x_lo <= theta <= x_hi:
        return theta
    if not np.isfinite(theta):
        where = "nowhere (flat fit) within"
    elif theta > 709.0:  # exp() would overflow: a nearly flat fit
        where = "above 1e308 m/s, outside"
    else:
        where = f"at {_fmt(math.exp(theta))} m/s, outside"
    raise _NoEstimate(
        f"the fitted curve crosses {q:g} {where} the fitted speeds "
        f"{_fmt(v[i0])}-{_fmt(v[i1])} m/s: not extrapolated; extend or "
        "refine the sweep",
        notes,
    )


def _lack_of_fit(xw, yw, nw, ll_hat):
    """``(G2, df, p)``: residual deviance of the probit against the saturated model
    on the window, its degrees of freedom and its chi-squared p-value (NaN for a
    saturated fit, ``df = 0``)."""
    df = xw.size - 2
    with np.errstate(divide="ignore", invalid="ignore"):
        pw = yw / nw
        sat = np.where(yw > 0, yw * np.log(pw), 0.0) + np.where(
            yw < nw, (nw - yw) * np.log1p(-pw), 0.0
        )
    g2 = max(2.0 * (float(np.sum(sat)) - ll_hat), 0.0)
    return g2, df, float(stats.chi2.sf(g2, df)) if df > 0 else math.nan


def _criterion(g2, df, p_fit, conf, se_df, notes):
    """``(critical value, method)`` of the likelihood-ratio interval: chi2 (or F
    for an estimated SE), widened by the heterogeneity factor on a significant
    lack of fit (``auto`` uses the probit only where it fits)."""
    method = METHOD_PROFILE
    crit = _critical(conf, se_df)
    if df == 0:
        notes.append(
            "two speeds in the window: the probit shape is assumed, not checked"
        )
    elif p_fit < LACK_OF_FIT_LEVEL:
        h = g2 / df
        crit = float(stats.f.ppf(conf, 1, df)) * h
        if se_df is not None:  # the more conservative of the two corrections
            crit = max(crit, float(stats.f.ppf(conf, 1, se_df)) * h)
        method = METHOD_SCALED
        notes.append(
            f"lack of fit (deviance {g2:.3g} on {df} df): interval widened by the "
            f"heterogeneity factor {h:.3g}"
        )
    return crit, method


def _critical(conf, se_df):
    """chi2_1(c), or F(1, se_df; c) where the binomial SE is itself estimated."""
    return float(
        stats.chi2.ppf(conf, 1) if se_df is None else stats.f.ppf(conf, 1, se_df)
    )


def _profile_interval(theta, xw, yw, nw, z_q, beta, ll_hat, crit, notes):
    """``(lo, hi)`` log speeds of the profile-likelihood interval, NaN on a side
    the data do not bound within the window."""
    x_lo, x_hi = float(xw[0]), float(xw[-1])

    def excess(t):
        return 2.0 * (ll_hat - _profile_loglik(t, xw, yw, nw, z_q, beta)) - crit

    limits = []
    for bound, side in ((x_lo, "below"), (x_hi, "above")):
        limit = math.nan
        prev = theta
        # walk outwards (fine steps first), then refine the first crossing
        for frac_step in (1 / 256, 1 / 64, 1 / 16, 1 / 4, 1 / 2, 1.0):
            t = theta + (bound - theta) * frac_step
            if t == prev:
                continue
            value = excess(t)
            if math.isnan(value):  # the profile fit fails out there: not bounded
                break
            if value > 0:
                try:
                    limit = optimize.brentq(excess, prev, t, xtol=1e-12, rtol=1e-10)
                except ValueError:  # NaN inside the bracket: the fit fails there
                    limit = math.nan
                break
            prev = t
        if math.isnan(limit):
            notes.append(
                f"open {side}: not bounded by the data within "
                f"{_fmt(math.exp(bound))} m/s"
            )
        limits.append(limit)
    return limits[0], limits[1]


def _monotone(xw, yw, nw, q, conf, se_df, decreasing, notes):
    """``(estimate, grid_limited)``: the shape-free estimate
    (:mod:`.capture_monotone`) of the window's points, with the bracketing speeds
    in the note, and whether it is grid-limited (then said in the note): its
    estimated interpolation error exceeds :data:`GRID_LIMITED_RATIO` of the
    interval's half-width, or a bracketing speed has no or full capture."""
    mc = monotone_crossing(xw, yw, nw, q, _critical(conf, se_df), decreasing=decreasing)
    v_lo, v_hi = _fmt(math.exp(xw[0])), _fmt(math.exp(xw[-1]))
    if not np.isfinite(mc.theta):
        raise _NoEstimate(
            f"the isotonic fit of the capture curve does not cross {q:g} within "
            f"the fitted speeds {v_lo}-{v_hi} m/s (the fractions cross it only "
            "through noise): extend the sweep or add impacts",
            notes,
        )
    if not decreasing:
        notes.append("capture rises with speed in the fitted window")
    est = math.exp(mc.theta)
    a, b = (math.exp(t) for t in mc.bracket)
    notes.append(
        f"isotonic (shape-free) estimate on the fitted point at {_fmt(a)} m/s"
        if a == b
        else f"isotonic (shape-free) estimate interpolated between {_fmt(a)} and "
        f"{_fmt(b)} m/s"
    )
    lo, hi = (math.exp(t) if np.isfinite(t) else math.nan for t in (mc.lo, mc.hi))
    for limit, side, bound in ((lo, "below", v_lo), (hi, "above", v_hi)):
        if math.isnan(limit):
            notes.append(f"open {side}: not bounded by the data within {bound} m/s")
    err = est * math.expm1(mc.interpolation_error)  # NaN without a third point
    half = np.nanmax([est - lo, hi - est]) if np.isfinite([lo, hi]).any() else 0.0
    extreme = a != b and any(f in (0.0, 1.0) for f in mc.bracket_fraction)
    limited = bool(err > GRID_LIMITED_RATIO * half) or extreme
    if extreme:
        notes.append(
            f"grid-limited: a speed beside the crossing has no or full capture, so "
            f"where between {_fmt(a)} and {_fmt(b)} m/s the curve crosses rests on "
            "the interpolation; refine the sweep there"
        )
    elif limited:
        against = (
            f"more than half the interval's half-width ({half:.2g} m/s)"
            if half > 0
            else "with an interval open on both sides"
        )
        notes.append(
            f"grid-limited: the interpolation between the fitted speeds may be off "
            f"by about {err:.2g} m/s, {against}; refine the sweep between {_fmt(a)} "
            f"and {_fmt(b)} m/s"
        )
    elif a != b and math.isnan(err):
        notes.append(
            "two fitted points: the probit shape between them is assumed, not checked"
        )
    return CaptureSpeedEstimate(est, lo, hi, METHOD_MONOTONE, "; ".join(notes)), limited


def estimate_capture_speed(
    speed_m_s: ArrayLike,
    captured: ArrayLike,
    impacts: ArrayLike,
    quantile: float = 0.5,
    *,
    confidence: float = 0.95,
    capture_se: ArrayLike | None = None,
    capture_se_df: float | None = None,
    estimator: str = "auto",
) -> CaptureSpeedEstimate:
    r"""Speed at which a fraction `quantile` of the particles is captured.

    One capture curve (one surface and angle), from the sweep points around the
    crossing (:func:`crossing_window`). Two estimators (see the module notes and
    ``docs/capture-speed.md``):

    * ``isotonic-interpolated`` (:mod:`.capture_monotone`): the centred isotonic
      fit of the fractions, interpolated on the probit scale between the two
      speeds that bracket `quantile`, with a Fieller-type interval. It assumes only
      that capture is monotone in speed; its interval covers the interpolated
      crossing and shrinks as :math:`1/\sqrt N`. The bracketing speeds are in the
      note, and a ``grid-limited`` note says when the estimated interpolation error
      between them exceeds :data:`GRID_LIMITED_RATIO` of the interval's half-width
      (or a bracketing speed has no or full capture).
    * ``probit-profile``: a binomial probit GLM in log speed, its inverse
      prediction and profile-likelihood interval (``probit-profile-scaled``: widened
      by the heterogeneity factor on a significant lack of fit, with
      ``estimator="probit"`` only).

    ``estimator="auto"`` reports the isotonic estimate, except where it is
    grid-limited and the probit fits (residual deviance not significant at
    :data:`LACK_OF_FIT_LEVEL`) and crosses `quantile` within the fitted speeds: the
    probit's shape then bridges the coarse sweep.

    Parameters
    ----------
    speed_m_s : array_like, shape (k,)
        Incident speeds [m s⁻¹], > 0, any order; repeated speeds (equal to a
        relative :data:`SPEED_RTOL`) are pooled.
    captured : array_like, shape (k,)
        Captured particles at each speed, in ``[0, impacts]``.
    impacts : array_like, shape (k,)
        Impacts at each speed, >= 0; speeds with no impacts (fully shadowed) carry
        no information and are ignored.
    quantile : float
        Captured fraction ``q`` in (0, 1).
    confidence : float, keyword-only
        Confidence level of the interval, in (0, 1).
    capture_se : array_like, shape (k,), optional, keyword-only
        Standard error of each capture fraction when it is not binomial (QMC
        replicates). Each point then enters with the effective binomial count
        :math:`n_{eff} = \hat p (1 - \hat p)/SE^2` and :math:`y = \hat p\,n_{eff}`;
        points with :math:`\hat p \in \{0, 1\}` or a zero or NaN SE keep `impacts`.
    capture_se_df : float, optional, keyword-only
        Degrees of freedom of `capture_se` (``R - 1`` for ``R`` QMC replicates). The
        likelihood-ratio criterion then uses :math:`F_{1,\nu}(c)` instead of
        :math:`\chi^2_1(c)`, as a t interval does for an estimated SE (the
        isotonic interval likewise). Ignored without `capture_se`.
    estimator : {"auto", "probit", "monotone"}, keyword-only
        ``"auto"`` (above), or the probit (the estimator before 0.2.0) or the
        isotonic estimate alone.

    Returns
    -------
    CaptureSpeedEstimate
        ``speed_m_s``, ``ci_low``, ``ci_high`` [m s⁻¹], ``method``, ``note``. Never
        an extrapolation: NaN estimate (and interval) when the capture fraction does
        not cross `quantile` within the swept speeds, when fewer than two speeds have
        impacts, or when the crossing is not resolved (at most one speed with partial
        capture between full and no capture: the data are separated). A side of the
        interval that the data do not bound within the fitted window is NaN
        ("open").

    Raises
    ------
    ValueError
        For arrays of different lengths, non-positive or non-finite speeds, negative
        impacts, `captured` outside ``[0, impacts]``, a negative `capture_se`, a
        `capture_se_df` that is not > 0, `quantile`/`confidence` outside (0, 1), or
        an `estimator` not in :data:`ESTIMATORS`.
    """
    v, y, n, q, conf, se = _estimate_capture_speed_iv(
        speed_m_s, captured, impacts, quantile, confidence, capture_se
    )
    se_df = None
    if capture_se_df is not None and se is not None:
        se_df = float(capture_se_df)
        if not (math.isfinite(se_df) and se_df > 0):
            raise ValueError(
                f"`capture_se_df` must be a finite number > 0; got {capture_se_df!r}."
            )
    if estimator not in ESTIMATORS:
        raise ValueError(
            f"`estimator` must be one of {', '.join(map(repr, ESTIMATORS))} "
            "(the default; the probit alone; the isotonic estimate alone); "
            f"got {estimator!r}."
        )
    notes = []
    try:
        v, y, n, se_df = _pooled_counts(v, y, n, se, se_df, notes)
        i0, i1 = _window(v, y / n, q, notes)
        xw, yw, nw = np.log(v[i0 : i1 + 1]), y[i0 : i1 + 1], n[i0 : i1 + 1]
        _check_resolved(v, y / n, q, i0, i1, yw, nw, notes)
        z_q = float(special.ndtri(q))
        alpha, beta, ll_hat = _fit_probit(xw, yw, nw)
        g2, df, p_fit = _lack_of_fit(xw, yw, nw, ll_hat)
        fits = df > 0 and p_fit >= LACK_OF_FIT_LEVEL
        if estimator != "probit":
            iso, limited = _monotone(xw, yw, nw, q, conf, se_df, beta <= 0, [*notes])
            crosses = beta != 0 and xw[0] <= (z_q - alpha) / beta <= xw[-1]
            # the probit bridges only where it fits and crosses within the window
            if estimator == "monotone" or not (limited and fits and crosses):
                return _within(iso, v[i0], v[i1])
            notes.append(
                f"the probit bridges the coarse sweep: it fits (deviance {g2:.3g} on "
                f"{df} df, p = {p_fit:.2g}) where the isotonic interpolation is "
                "grid-limited"
            )
        theta = _crossing(alpha, beta, z_q, xw, v, q, i0, i1, notes)
    except _NoEstimate as exc:
        return _none("; ".join([exc.message, *exc.notes]))
    if beta > 0:
        notes.append("capture rises with speed in the fitted window")
    crit, method = _criterion(g2, df, p_fit, conf, se_df, notes)
    lo, hi = _profile_interval(theta, xw, yw, nw, z_q, beta, ll_hat, crit, notes)
    # the interval holds the estimate by construction (the walk starts at theta)
    est = CaptureSpeedEstimate(
        float(math.exp(theta)),
        float(math.exp(lo)) if np.isfinite(lo) else math.nan,
        float(math.exp(hi)) if np.isfinite(hi) else math.nan,
        method,
        "; ".join(notes),
    )
    return _within(est, v[i0], v[i1])
