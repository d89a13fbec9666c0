r"""Least-squares fits of the impact coefficients, as in [1]_.

[1]_ obtains :math:`k_1, k_2, v_c` "from least-squares regression analysis" at each
diameter and then expresses "how k_1, k_2 and v_c vary with diameter" by a second
regression. :func:`fit_restitution` does the first step for one diameter,
:func:`fit_impact_coefficients` does it per diameter group, :func:`fit_law`
regresses one coefficient on diameter and :func:`fit_coefficient_laws` turns the
per-diameter table into :class:`~microimpact.physics.coefficients.ImpactCoefficients`.

References
----------
.. [1] X. Li, P. F. Dunn, R. M. Brach, "Monte Carlo analysis of polydisperse
   microparticle impacts with surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._validation import (
    as_float_array,
    check_choice,
    check_int,
    check_positive,
    check_real_scalar,
    did_you_mean,
)
from ..units import m_to_um, um_to_m
from .coefficients import (
    ConstantLaw,
    ImpactCoefficients,
    PolynomialLaw,
    PowerLaw,
)
from .impact import _ratio_law

__all__ = [
    "LawFit",
    "RestitutionFit",
    "fit_coefficient_laws",
    "fit_impact_coefficients",
    "fit_law",
    "fit_restitution",
]


# ------------------------------------------------------------------------ fitting
def _restitution(v, k1, k2, v_c, p, q):
    """e(v) of [1], Eq. 6 generalised to exponents p, q; 0 where |v| <= v_c."""
    s = np.abs(v)
    r = _ratio_law(k1, s, p)  # [1], Eq. 4
    rho = _ratio_law(k2, s - v_c, q)  # [1], Eq. 5 (s > v_c where it is used)
    return np.where(s > v_c, r * (1.0 - rho), 0.0)  # [1], Eq. 6


@dataclass(frozen=True)
class RestitutionFit:
    """Least-squares estimates of k1, k2, v_c [m s⁻¹] at one diameter.

    Attributes
    ----------
    k1, k2, v_c : float
        Estimates [m s⁻¹].
    k1_se, k2_se, v_c_se : float
        Standard errors from ``s² (JᵀJ)⁻¹`` [m s⁻¹].
    covariance : ndarray, shape (3, 3)
        Covariance of (k1, k2, v_c).
    residual_std : float
        ``sqrt(SSR / (n - 3))`` [-].
    n : int
        Number of points.
    p, q : float
        Exponents held fixed.
    success : bool
    message : str
    """

    k1: float
    k2: float
    v_c: float
    k1_se: float
    k2_se: float
    v_c_se: float
    covariance: np.ndarray = field(repr=False)
    residual_std: float
    n: int
    p: float
    q: float
    success: bool
    message: str


def _initial_guess(v, e):
    caught, bounced = v[e <= 0], v[e > 0]
    if caught.size and bounced.size:
        v_c = (
            0.5 * (caught.max() + bounced[bounced > caught.max()].min())
            if np.any(bounced > caught.max())
            else caught.max()
        )
    else:
        v_c = 0.5 * v.min()
    i = np.argmax(v)
    k1 = e[i] * v[i] / (1 - e[i]) if 0 < e[i] < 1 else 10.0 * v.max()
    return max(k1, 1e-6), max(0.1 * (np.median(v) - v_c), 1e-6), max(v_c, 0.0)


def fit_restitution(v_n, e, *, p=1.0, q=1.0, p0=None) -> RestitutionFit:
    """Fit k1, k2 and v_c of [1], Eq. 6 to (normal impact speed, e) at one diameter.

    Nonlinear least squares (``scipy.optimize.least_squares``, bounds k1, k2 > 0,
    v_c >= 0) from several starting values; the best is kept.

    Parameters
    ----------
    v_n : array_like
        Normal impact speeds [m s⁻¹] (sign ignored).
    e : array_like
        Measured coefficients of restitution [-]; 0 for captured particles.
    p, q : float
        Exponents of Eqs. 4-5, held fixed.
    p0 : sequence of 3 floats, optional
        Starting (k1, k2, v_c) [m s⁻¹].

    Returns
    -------
    RestitutionFit
    """
    from scipy.optimize import least_squares

    v = np.abs(as_float_array(v_n, "v_n")).ravel()
    y = as_float_array(e, "e").ravel()
    if v.shape != y.shape:
        raise ValueError(
            f"`v_n` and `e` must have the same length; got {v.size} and {y.size}."
        )
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(y))):
        raise ValueError("`v_n` and `e` must be finite.")
    if v.size < 4:
        raise ValueError(
            "`v_n` must hold at least 4 points to fit 3 parameters with errors; "
            f"got {v.size}."
        )
    p, q = (
        check_real_scalar(p, "p", minimum=0, strict=True),
        check_real_scalar(q, "q", minimum=0, strict=True),
    )
    if p0 is None:
        start = _initial_guess(v, y)
    else:
        try:
            start = tuple(p0)
        except TypeError:
            raise TypeError(
                f"`p0` must be a sequence of 3 numbers (k1, k2, v_c); got {p0!r}."
            ) from None
        if len(start) != 3:
            raise ValueError(f"`p0` must hold 3 numbers (k1, k2, v_c); got {p0!r}.")
        start = tuple(check_real_scalar(x, f"p0[{i}]") for i, x in enumerate(start))

    def resid(theta):
        return _restitution(v, *theta, p, q) - y

    lower, upper = [1e-12, 1e-12, 0.0], [np.inf, np.inf, np.inf]
    best = None
    for scale in (1.0, 0.1, 10.0):
        x0 = np.clip([start[0], start[1] * scale, start[2]], np.array(lower) * 2, None)
        r = least_squares(resid, x0, bounds=(lower, upper), x_scale="jac", method="trf")
        if best is None or r.cost < best.cost:
            best = r
    dof = v.size - 3
    s2 = 2.0 * best.cost / dof
    jtj = best.jac.T @ best.jac
    try:
        cov = np.linalg.inv(jtj) * s2
    except np.linalg.LinAlgError:
        cov = np.full((3, 3), np.nan)
    se = np.sqrt(np.where(np.diag(cov) >= 0, np.diag(cov), np.nan))
    k1, k2, v_c = (float(x) for x in best.x)
    return RestitutionFit(
        k1,
        k2,
        v_c,
        *(float(x) for x in se),
        cov,
        float(np.sqrt(s2)),
        int(v.size),
        p,
        q,
        bool(best.success),
        best.message,
    )


def fit_impact_coefficients(
    diameter, v_n, e, *, groups=None, p=1.0, q=1.0, min_points=5
):
    """Fit k1, k2, v_c at each diameter, as [1] does before regressing on diameter.

    Parameters
    ----------
    diameter : array_like
        Particle diameter of each measurement [m].
    v_n, e : array_like
        Normal impact speed [m s⁻¹] and restitution coefficient [-] of each.
    groups : array_like, optional
        Bin edges [m]; measurements are grouped by bin, each represented by its
        mean diameter. Default: one group per unique diameter.
    p, q : float
        Exponents held fixed.
    min_points : int
        Groups with fewer points are skipped with a ``RuntimeWarning``.

    Returns
    -------
    pandas.DataFrame
        One row per group: ``diameter_um, n, k1_m_s, k1_se, k2_m_s, k2_se,
        v_c_m_s, v_c_se, rmse``; ``attrs`` holds ``p`` and ``q``.
    """
    import pandas as pd

    d = as_float_array(diameter, "diameter").ravel()
    v = as_float_array(v_n, "v_n").ravel()
    y = as_float_array(e, "e").ravel()
    if not (d.size == v.size == y.size):
        raise ValueError(
            "`diameter`, `v_n` and `e` must have equal lengths; "
            f"got {d.size}, {v.size}, {y.size}."
        )
    min_points = check_int(min_points, "min_points", minimum=0)
    if groups is None:
        keys = np.unique(d, return_inverse=True)[1]
    else:
        edges = as_float_array(groups, "groups").ravel()
        if edges.size < 2 or np.any(np.diff(edges) <= 0):
            raise ValueError(
                f"`groups` must be strictly increasing bin edges [m]; got {edges!r}."
            )
        keys = np.digitize(d, edges) - 1
        keys = np.where(
            (d >= edges[0]) & (d <= edges[-1]), np.minimum(keys, edges.size - 2), -1
        )
    rows = []
    for k in np.unique(keys[keys >= 0]):
        sel = keys == k
        dk = float(d[sel].mean())
        if sel.sum() < min_points:
            warnings.warn(
                f"skipping diameter group {m_to_um(dk):.4g} um: {int(sel.sum())} "
                f"points < min_points={min_points}.",
                RuntimeWarning,
                stacklevel=2,
            )
            continue
        f = fit_restitution(v[sel], y[sel], p=p, q=q)
        rows.append(
            (
                float(m_to_um(dk)),
                f.n,
                f.k1,
                f.k1_se,
                f.k2,
                f.k2_se,
                f.v_c,
                f.v_c_se,
                f.residual_std,
            )
        )
    cols = [
        "diameter_um",
        "n",
        "k1_m_s",
        "k1_se",
        "k2_m_s",
        "k2_se",
        "v_c_m_s",
        "v_c_se",
        "rmse",
    ]
    table = pd.DataFrame(rows, columns=cols)
    table.attrs.update(p=float(p), q=float(q))
    return table


@dataclass(frozen=True)
class LawFit:
    """A law regressed against diameter, with the covariance of its parameters.

    Attributes
    ----------
    law : PowerLaw, PolynomialLaw or ConstantLaw
    parameter_names : tuple of str
        E.g. ``("a", "b")`` for the power law.
    parameters : ndarray
    covariance : ndarray
    standard_errors : ndarray
    residual_std : float
        Of the (weighted) residuals in the space of the fit (log for 'power').
    n : int
    """

    law: Any
    parameter_names: tuple[str, ...]
    parameters: np.ndarray
    covariance: np.ndarray = field(repr=False)
    standard_errors: np.ndarray
    residual_std: float
    n: int


def _wls(x_matrix, y, w, absolute):
    """Weighted linear least squares; returns beta, covariance, residual std."""
    sw = np.sqrt(w)
    a, b = x_matrix * sw[:, None], y * sw
    beta, *_ = np.linalg.lstsq(a, b, rcond=None)
    res = b - a @ beta
    dof = y.size - beta.size
    s2 = float((res**2).sum() / dof) if dof > 0 else np.nan
    cov = np.linalg.inv(a.T @ a) * (1.0 if absolute else s2)
    return beta, cov, math.sqrt(s2) if dof > 0 else np.nan


def fit_law(
    diameter, values, *, form="power", sigma=None, degree=1, d_ref=None
) -> LawFit:
    """Regress a coefficient against diameter.

    Parameters
    ----------
    diameter : array_like
        Diameters [m], > 0.
    values : array_like
        Coefficient values [m s⁻¹] (> 0 for ``form='power'``).
    form : {'power', 'polynomial', 'constant'}
        ``'power'``: weighted least squares of ``ln v = ln a + b ln(d/d_ref)``
        with weights ``(v/sigma)²`` (delta method); ``'polynomial'``: weighted
        linear least squares of degree `degree` in ``d/d_ref``; ``'constant'``:
        weighted mean.
    sigma : array_like, optional
        Standard errors of `values` [m s⁻¹]. If given they are taken as
        absolute (the covariance is not rescaled by the residual variance);
        otherwise the fit is unweighted and the covariance is scaled by it.
    degree : int
        Polynomial degree.
    d_ref : float, optional
        Reference diameter [m]; default the geometric mean of `diameter`.

    Returns
    -------
    LawFit
    """
    d = as_float_array(diameter, "diameter").ravel()
    v = as_float_array(values, "values").ravel()
    if d.size != v.size:
        raise ValueError(
            "`diameter` and `values` must have the same length; "
            f"got {d.size} and {v.size}."
        )
    if not (np.all(np.isfinite(d)) and np.all(d > 0) and np.all(np.isfinite(v))):
        raise ValueError("`diameter` must be finite and > 0 and `values` finite.")
    check_choice(form, "form", ("power", "polynomial", "constant"))
    degree = check_int(degree, "degree", minimum=0)
    n_par = {"power": 2, "polynomial": degree + 1, "constant": 1}[form]
    distinct = np.unique(d).size
    if distinct < n_par:
        raise ValueError(
            f"form={form!r}"
            + (f" of degree {degree}" if form == "polynomial" else "")
            + f" needs at least {n_par} distinct diameters; got {distinct} "
            f"({d.size} values)."
        )
    absolute = sigma is not None
    if absolute:
        s = np.broadcast_to(check_positive(sigma, "sigma"), v.shape)
    d_ref = (
        float(np.exp(np.log(d).mean()))
        if d_ref is None
        else check_real_scalar(d_ref, "d_ref", minimum=0, strict=True)
    )
    x = d / d_ref
    if form == "power":
        if np.any(v <= 0):
            raise ValueError(
                "`values` must be > 0 for form='power'; use 'polynomial' or 'constant'."
            )
        design = np.column_stack([np.ones_like(x), np.log(x)])
        w = (v / s) ** 2 if absolute else np.ones_like(v)
        # sd(ln v) = sigma / v (delta method) with v the *fitted* value: weights
        # from the noisy observations would bias the fit upwards, so reweight.
        for _ in range(3 if absolute else 0):
            beta, _, _ = _wls(design, np.log(v), w, absolute)
            w = (np.exp(design @ beta) / s) ** 2
        beta, cov_log, rstd = _wls(design, np.log(v), w, absolute)
        a, b = math.exp(beta[0]), float(beta[1])
        jac = np.array([[a, 0.0], [0.0, 1.0]])  # d(a, b) / d(ln a, b)
        cov, params, names, law = (
            jac @ cov_log @ jac.T,
            np.array([a, b]),
            ("a", "b"),
            PowerLaw(a, b, d_ref),
        )
    else:
        deg = 0 if form == "constant" else degree
        w = 1.0 / s**2 if absolute else np.ones_like(v)
        cov_matrix = np.vander(x, deg + 1, increasing=True)
        params, cov, rstd = _wls(cov_matrix, v, w, absolute)
        names = tuple(f"c{i}" for i in range(deg + 1))
        law = (
            ConstantLaw(max(float(params[0]), 0.0))
            if form == "constant"
            else PolynomialLaw(tuple(params), d_ref)
        )
    se = np.sqrt(np.diag(cov))
    return LawFit(
        law, names, np.asarray(params, dtype=float), cov, se, float(rstd), int(v.size)
    )


def fit_coefficient_laws(
    table, *, form="power", friction=math.inf
) -> ImpactCoefficients:
    """Regress the per-diameter table of :func:`fit_impact_coefficients` on diameter.

    Parameters
    ----------
    table : pandas.DataFrame
        With columns ``diameter_um, k1_m_s, k1_se, k2_m_s, k2_se, v_c_m_s, v_c_se``;
        ``table.attrs`` may give ``p`` and ``q`` (default 1).
    form : str or dict
        Law form for all three (see :func:`fit_law`) or a dict per coefficient,
        e.g. ``{"k1": "constant", "k2": "power", "v_c": "power"}``.
    friction : float
        Coulomb friction coefficient to store.

    Returns
    -------
    ImpactCoefficients
        Its laws are the fitted ones; standard errors weight each fit where they
        are finite and > 0.
    """
    names = ("k1", "k2", "v_c")
    forms = form if isinstance(form, dict) else dict.fromkeys(names, form)
    for key in forms:
        if key not in names:
            raise ValueError(
                f"`form` has unknown key {key!r}; allowed: "
                f"{', '.join(map(repr, names))}{did_you_mean(key, names)}."
            )
    missing = [
        c
        for c in ("diameter_um", *(f"{n}_m_s" for n in names))
        if c not in table.columns
    ]
    if missing:
        raise ValueError(f"`table` lacks columns {missing}; got {list(table.columns)}.")
    if len(table) == 0:
        raise ValueError(
            "`table` has no rows: no diameter group was fitted "
            "(fit_impact_coefficients skips groups with fewer than `min_points` "
            "impacts)."
        )
    d = um_to_m(np.asarray(table["diameter_um"], dtype=float))
    laws = {}
    for n in names:
        vals = np.asarray(table[f"{n}_m_s"], dtype=float)
        se = (
            np.asarray(table[f"{n}_se"], dtype=float)
            if f"{n}_se" in table.columns
            else None
        )
        use_se = se is not None and np.all(np.isfinite(se)) and np.all(se > 0)
        laws[n] = fit_law(
            d, vals, form=forms.get(n, "power"), sigma=se if use_se else None
        ).law
    attrs = getattr(table, "attrs", {})
    return ImpactCoefficients(
        **laws, p=attrs.get("p", 1.0), q=attrs.get("q", 1.0), friction=friction
    )
