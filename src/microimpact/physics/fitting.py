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

from .._core.json import dumps
from .._core.toml import coefficients_snippet
from .._core.validation import (
    as_float_array,
    check_choice,
    check_int,
    check_positive,
    check_scalar,
    did_you_mean,
)
from ..errors import InputError
from ..units import m_to_um, um_to_m
from .coefficients import (
    ConstantLaw,
    ImpactCoefficients,
    PolynomialLaw,
    PowerLaw,
)
from .impact import _ratio_law

__all__ = [
    "CoefficientLawsFit",
    "IdentifiabilityError",
    "IdentifiabilityWarning",
    "LawFit",
    "RestitutionFit",
    "coefficient_laws_fit",
    "fit_coefficient_laws",
    "fit_impact_coefficients",
    "fit_law",
    "fit_restitution",
]


# ------------------------------------------------------------------ identifiability
class IdentifiabilityError(InputError):
    """The data cannot identify the parameters asked for (e.g. every impact at one
    speed: k1, k2 and v_c cannot be told apart from e at one v_n). A user error:
    the CLI reports it in one line with exit code 2."""


class IdentifiabilityWarning(UserWarning):
    """Some parameters are not identified by the data; they are reported as NaN
    with a ``*_identified = False`` flag, never as a number with a NaN error."""


#: A parameter whose standard error exceeds this multiple of its magnitude is
#: taken as not identified by the data.
MAX_RELATIVE_SE = 1.0
#: Singular values of the scaled Jacobian below this fraction of the largest mark
#: directions of parameter space the data do not constrain.
RANK_TOLERANCE = 1e-8
_NAMES = ("k1", "k2", "v_c")


def _identify(jac, theta, s2, max_relative_se):
    """``(covariance, standard errors, {name: reason})`` of a fit.

    Directions of parameter space the scaled Jacobian does not constrain (singular
    values below :data:`RANK_TOLERANCE` of the largest) mark their parameters as
    not identified; the covariance of the others is computed with those held
    fixed. A parameter whose standard error is not finite or exceeds
    `max_relative_se` times its value is not identified either.
    """
    k = theta.size
    notes = {}
    scaled = jac * np.where(theta > 0, theta, 1.0)  # relative sensitivities
    try:
        _, sv, vt = np.linalg.svd(scaled, full_matrices=False)
        weak = sv <= RANK_TOLERANCE * (sv.max() if sv.max() > 0 else 1.0)
    except np.linalg.LinAlgError:
        vt, weak = np.eye(k), np.ones(k, dtype=bool)
    for i, name in enumerate(_NAMES):
        if np.any(np.abs(vt[weak, i]) > 0.1):
            notes[name] = "the data do not constrain it (singular Jacobian)"
    keep = [i for i, name in enumerate(_NAMES) if name not in notes]
    cov = np.full((k, k), np.nan)
    if keep:
        sub = jac[:, keep]
        try:
            cov[np.ix_(keep, keep)] = np.linalg.inv(sub.T @ sub) * s2
        except np.linalg.LinAlgError:
            pass
    with np.errstate(invalid="ignore"):
        diag = np.diag(cov)
        se = np.sqrt(np.where(diag >= 0, diag, np.nan))
    for i in keep:
        name = _NAMES[i]
        if not np.isfinite(se[i]):
            notes[name] = "its standard error is not finite"
        elif se[i] > max_relative_se * abs(theta[i]):
            notes[name] = (
                f"its standard error {se[i]:.3g} m/s exceeds {max_relative_se:g} x "
                f"its value {theta[i]:.3g} m/s"
            )
    return cov, se, notes


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
    identified : dict
        ``{"k1": bool, "k2": bool, "v_c": bool}``; a parameter not identified by
        the data has value and standard error NaN (see :func:`fit_restitution`).
    notes : dict
        Why each unidentified parameter is not identified.
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
    identified: dict = field(default_factory=lambda: dict.fromkeys(_NAMES, True))
    notes: dict = field(default_factory=dict)


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


def fit_restitution(
    v_n, e, *, p=1.0, q=1.0, p0=None, max_relative_se=MAX_RELATIVE_SE
) -> RestitutionFit:
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
    max_relative_se : float
        A parameter whose standard error exceeds this multiple of its value is
        not identified.

    Returns
    -------
    RestitutionFit
        A parameter the data do not identify (its direction of the scaled Jacobian
        is singular, its standard error not finite or above `max_relative_se`
        times its value) is NaN with a NaN standard error and ``identified[name]``
        False, and an :class:`IdentifiabilityWarning` names it.

    Raises
    ------
    IdentifiabilityError
        Fewer than 3 distinct speeds, or fewer than 2 distinct speeds with
        ``e > 0``: three parameters cannot be identified (e.g. every impact at
        one speed).
    """
    # deferred: this SciPy submodule loads only when it is used (import time)
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
        check_scalar(p, "p", minimum=0, strict=True),
        check_scalar(q, "q", minimum=0, strict=True),
    )
    max_relative_se = check_scalar(
        max_relative_se, "max_relative_se", minimum=0, strict=True
    )
    speeds, rebound = np.unique(v).size, np.unique(v[y > 0]).size
    if speeds < 3 or rebound < 2:
        listing = ", ".join(f"{x:g}" for x in np.unique(v)[:6])
        raise IdentifiabilityError(
            f"k1, k2 and v_c cannot be identified from {v.size} impacts at "
            f"{speeds} distinct speed(s) ({listing} m/s), {rebound} of them with "
            "e > 0; allowed: at least 3 distinct normal speeds, 2 or more of them "
            "with rebounds (e > 0)",
            field="v_n_m_s",
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
        start = tuple(check_scalar(x, f"p0[{i}]") for i, x in enumerate(start))

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
    theta = np.array(best.x, dtype=float)
    cov, se, notes = _identify(best.jac, theta, s2, max_relative_se)
    if notes:
        warnings.warn(
            "not identified by the data, reported as NaN: "
            + "; ".join(f"{k} ({why})" for k, why in notes.items()),
            IdentifiabilityWarning,
            stacklevel=2,
        )
        for i, name in enumerate(_NAMES):
            if name in notes:
                theta[i] = se[i] = np.nan
    k1, k2, v_c = (float(x) for x in theta)
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
        {name: name not in notes for name in _NAMES},
        notes,
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
        v_c_m_s, v_c_se, rmse, k1_identified, k2_identified, v_c_identified``;
        ``attrs`` holds ``p`` and ``q``. A parameter the group's data do not
        identify is NaN (value and standard error) with its ``*_identified`` flag
        False (:func:`fit_restitution`; an :class:`IdentifiabilityWarning` says
        so).

    Raises
    ------
    IdentifiabilityError
        If no group can identify k1, k2 and v_c (e.g. every impact at one speed);
        a group that cannot, among others that can, is skipped with an
        :class:`IdentifiabilityWarning`.
    """
    # deferred: pandas loads only where a table is made (import time)
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
    rows, refused = [], []
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
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", IdentifiabilityWarning)
                f = fit_restitution(v[sel], y[sel], p=p, q=q)
        except IdentifiabilityError as exc:
            refused.append((dk, exc))
            continue
        for w in caught:
            if issubclass(w.category, IdentifiabilityWarning):
                msg = f"diameter group {m_to_um(dk):.4g} um: {w.message}"
                warnings.warn(msg, IdentifiabilityWarning, stacklevel=2)
            else:
                warnings.warn_explicit(
                    w.message, w.category, w.filename, w.lineno, source=w.source
                )
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
                *(bool(f.identified[name]) for name in _NAMES),
            )
        )
    if refused and not rows:
        dk, exc = refused[0]
        raise IdentifiabilityError(
            f"no diameter group identifies k1, k2 and v_c; e.g. at "
            f"{m_to_um(dk):.4g} um: {exc.message}",
            field=exc.field,
        )
    for dk, exc in refused:
        warnings.warn(
            f"skipping diameter group {m_to_um(dk):.4g} um: {exc.message}",
            IdentifiabilityWarning,
            stacklevel=2,
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
        "k1_identified",
        "k2_identified",
        "v_c_identified",
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
        else check_scalar(d_ref, "d_ref", minimum=0, strict=True)
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


@dataclass(frozen=True, eq=False)
class CoefficientLawsFit:
    """Result of :func:`coefficient_laws_fit`: the laws and how they were fitted.

    Attributes
    ----------
    laws : ImpactCoefficients
        The fitted laws (as :func:`fit_coefficient_laws` returns).
    fits : dict
        ``{"k1": LawFit, "k2": LawFit, "v_c": LawFit}``.
    forms : dict
        The law form of each coefficient.
    used : dict
        Number of diameter groups each law was fitted on (those where the
        coefficient is identified).
    weighted : dict
        Whether each fit was weighted by the per-diameter standard errors.
    table : pandas.DataFrame
        The per-diameter table fitted.
    """

    laws: ImpactCoefficients
    fits: dict
    forms: dict
    used: dict
    weighted: dict
    table: Any = field(repr=False)

    def to_dict(self) -> dict:
        """Plain data in the layout of ``coefficient_laws.json`` (documented in
        ``docs/adhesion.md``, :data:`LAWS_SCHEMA`)."""
        coefficients = {}
        for name in _NAMES:
            f = self.fits[name]
            coefficients[name] = {
                "law": f.law.describe(),
                "form": self.forms[name],
                "parameters": dict(
                    zip(f.parameter_names, map(float, f.parameters), strict=True)
                ),
                "standard_errors": dict(
                    zip(f.parameter_names, map(float, f.standard_errors), strict=True)
                ),
                "residual_std": float(f.residual_std),
                "n_diameters": int(self.used[name]),
                "weighted": bool(self.weighted[name]),
            }
        return {
            "schema": LAWS_SCHEMA,
            "coefficients": coefficients,
            "p": self.laws.p,
            "q": self.laws.q,
            "friction": self.laws.friction,
            # pandas (>= 2) gives the records as Python scalars
            "by_diameter": self.table.to_dict(orient="records"),
            "scenario_toml": self.toml(),
        }

    def to_json(self, *, indent=2) -> str:
        """:meth:`to_dict` as standard JSON (NaN and infinities as ``null``)."""

        return dumps(self.to_dict(), indent=indent)

    def toml(self) -> str:
        """The ``[coefficients]`` table to paste into a scenario file."""

        return coefficients_snippet(
            self.laws,
            comment="fitted by microimpact fit: laws of diameter, "
            + ", ".join(
                f"{n} ({self.forms[n]}, {self.used[n]} diameters)" for n in _NAMES
            ),
        )


#: Identifies the layout of :meth:`CoefficientLawsFit.to_dict`.
LAWS_SCHEMA = "microimpact.coefficient_laws/1"


def coefficient_laws_fit(
    table, *, form="power", friction=math.inf
) -> CoefficientLawsFit:
    """Regress the per-diameter table of :func:`fit_impact_coefficients` on diameter,
    keeping the law fits (standard errors) and the identifiability bookkeeping.

    Each coefficient's law is fitted on the diameter groups where it is identified
    (``*_identified``; every group when the table has no such column); the
    standard errors weight the fit when all of them are finite and > 0.

    Parameters
    ----------
    table, form, friction
        As for :func:`fit_coefficient_laws`.

    Returns
    -------
    CoefficientLawsFit

    Raises
    ------
    IdentifiabilityError
        If a coefficient is identified at fewer distinct diameters than its law
        has parameters (e.g. a power law from one diameter).
    ValueError
        Missing columns, an empty table or an unknown form.
    """
    forms = form if isinstance(form, dict) else dict.fromkeys(_NAMES, form)
    for key in forms:
        if key not in _NAMES:
            raise ValueError(
                f"`form` has unknown key {key!r}; allowed: "
                f"{', '.join(map(repr, _NAMES))}{did_you_mean(key, _NAMES)}."
            )
    forms = {n: forms.get(n, "power") for n in _NAMES}
    for n in _NAMES:
        check_choice(forms[n], f"form[{n!r}]", ("power", "polynomial", "constant"))
    missing = [
        c
        for c in ("diameter_um", *(f"{n}_m_s" for n in _NAMES))
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
    d_all = um_to_m(np.asarray(table["diameter_um"], dtype=float))
    fits, used, weighted = {}, {}, {}
    for n in _NAMES:
        vals = np.asarray(table[f"{n}_m_s"], dtype=float)
        flag = f"{n}_identified"
        ok = np.isfinite(vals)
        if flag in table.columns:
            ok &= np.asarray(table[flag], dtype=bool)
        need = {"power": 2, "constant": 1, "polynomial": 2}[forms[n]]
        distinct = np.unique(d_all[ok]).size
        if distinct < need:
            raise IdentifiabilityError(
                f"{n} is identified at {distinct} distinct diameter(s) of "
                f"{len(table)}; a {forms[n]!r} law needs at least {need}; allowed: "
                "impacts at more diameters, each over at least 3 speeds, or "
                "form 'constant'",
                field=n,
            )
        se = (
            np.asarray(table[f"{n}_se"], dtype=float)[ok]
            if f"{n}_se" in table.columns
            else None
        )
        use_se = se is not None and np.all(np.isfinite(se)) and np.all(se > 0)
        fit = fit_law(d_all[ok], vals[ok], form=forms[n], sigma=se if use_se else None)
        if not np.all(np.isfinite(fit.standard_errors)):
            warnings.warn(
                f"the {forms[n]} law of {n} is fitted on {int(ok.sum())} diameter(s) "
                "with no residual degrees of freedom and no usable standard errors: "
                "its parameters have no error estimate (null in the JSON)",
                IdentifiabilityWarning,
                stacklevel=2,
            )
        fits[n], used[n], weighted[n] = fit, int(ok.sum()), bool(use_se)
    attrs = getattr(table, "attrs", {})
    laws = ImpactCoefficients(
        **{n: fits[n].law for n in _NAMES},
        p=attrs.get("p", 1.0),
        q=attrs.get("q", 1.0),
        friction=friction,
    )
    return CoefficientLawsFit(laws, fits, forms, used, weighted, table)


def fit_coefficient_laws(
    table, *, form="power", friction=math.inf
) -> ImpactCoefficients:
    """Regress the per-diameter table of :func:`fit_impact_coefficients` on diameter.

    Parameters
    ----------
    table : pandas.DataFrame
        With columns ``diameter_um, k1_m_s, k1_se, k2_m_s, k2_se, v_c_m_s, v_c_se``
        and optionally ``k1_identified, k2_identified, v_c_identified``;
        ``table.attrs`` may give ``p`` and ``q`` (default 1).
    form : str or dict
        Law form for all three (see :func:`fit_law`) or a dict per coefficient,
        e.g. ``{"k1": "constant", "k2": "power", "v_c": "power"}``.
    friction : float
        Coulomb friction coefficient to store.

    Returns
    -------
    ImpactCoefficients
        Its laws are the fitted ones; each is fitted on the groups where its
        coefficient is identified, and standard errors weight each fit where they
        are finite and > 0. :func:`coefficient_laws_fit` returns the law fits
        (standard errors) as well.

    Raises
    ------
    IdentifiabilityError
        A coefficient identified at too few diameters for its law.
    """
    return coefficient_laws_fit(table, form=form, friction=friction).laws
