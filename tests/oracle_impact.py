r"""
Independent scalar oracle for the impact physics of Li, Dunn & Brach (2000).

This module is a *test reference*, written from the paper's text alone and kept apart
from ``microimpact.physics.impact`` on purpose: it handles one impact at a time with
plain Python floats and the :mod:`math` module, and it works with explicit 2-D (and,
for the angular impulse, 3-D) vectors instead of the component formulas.

In particular, :func:`apparent_rebound_scalar` does **not** use the paper's Eqs. 8-9.
It builds the facet unit vectors :math:`n', t'` as vectors, projects the incoming
velocity on them, applies the impact in the facet frame, rebuilds the rebound velocity
as the vector sum :math:`V = V_{n'} n' + V_{t'} t'`, projects it back on the nominal
:math:`n, t`, and only then forms :math:`e_m = -V_n/v_n` and
:math:`\mu_m = (V_t - v_t)/(V_n - v_n)`. Agreement with the package therefore checks
the rotation of Eq. 7 and the algebra of Eqs. 8-9 together.

Conventions (see ``docs/conventions.md``): ``n`` is the outward normal (an approaching
particle has ``v_n < 0``); the particle travels in ``-t``; the incidence angle
:math:`\theta` is measured from the nominal plane; a facet angle :math:`\phi > 0`
turns the facet away from the particle; spin is about :math:`n \times t`.

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, "Monte Carlo analysis of polydisperse
   microparticle impacts with surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
"""

from __future__ import annotations

import math

NAN = math.nan

#: Moment of inertia of a solid sphere divided by m r^2.
_INERTIA_FACTOR = 0.4

REBOUND_FIELDS = (
    "R",
    "rho",
    "e",
    "V_n",
    "V_t",
    "mu",
    "mu0",
    "rolling",
    "captured",
    "spin",
)

APPARENT_FIELDS = (
    "e_m",
    "mu_m",
    "e",
    "mu",
    "captured",
    "shadowed",
    "rolling",
    "reimpact",
    "V_n",
    "V_t",
    "v_n_true",
    "v_t_true",
    "true_incidence_angle_deg",
    "spin",
)


# ---------------------------------------------------------------- small vector kit
def _dot(a, b):
    return sum(x * y for x, y in zip(a, b, strict=True))


def _add(*vs):
    return tuple(sum(c) for c in zip(*vs, strict=True))


def _scale(s, v):
    return tuple(s * x for x in v)


def _cross3(a, b):
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def _as3(v):
    return (v[0], v[1], 0.0)


def _isnan(*xs):
    return any(x is not None and math.isnan(x) for x in xs)


def _nan_rebound():
    out = dict.fromkeys(REBOUND_FIELDS, NAN)
    out["rolling"] = False
    out["captured"] = False
    return out


# ---------------------------------------------------------------- coefficient laws
def _ratio(k, x, power):
    """``k^p / (k^p + x^p)``; ``k = inf`` gives 1 (the limit in Eqs. 4-5)."""
    if math.isinf(k):
        return 1.0
    kp = k**power
    return kp / (kp + x**power)


# ---------------------------------------------------------------- one impact
def rebound_scalar(
    v_n,
    v_t,
    *,
    k1,
    k2,
    v_c,
    p=1.0,
    q=1.0,
    friction=math.inf,
    radius=None,
    spin=0.0,
):
    r"""
    One rigid-body impact in the frame of the struck surface, paper Eqs. 1-6.

    The impact is applied as an impulse: with the unit vectors ``n = (0, 1)`` and
    ``t = (1, 0)`` the velocity change per unit mass is
    :math:`P = P_n n + P_t t` with :math:`P_n = (1 + e)|v_n|` (Eq. 1) and
    :math:`P_t = \mu P_n` (Eq. 2). The spin change follows from the angular impulse
    :math:`r_c \times P` about the centre, with the contact point at
    :math:`r_c = -r n`, projected on the spin axis :math:`n \times t`.

    Returns
    -------
    dict
        Keys as in :data:`REBOUND_FIELDS`; ``spin`` is None when `radius` is None.
    """
    nan_inputs = [v_n, v_t, k1, k2, v_c, p, q, friction, spin]
    if radius is not None:
        nan_inputs.append(radius)
    if _isnan(*nan_inputs) or not v_n < 0.0:
        out = _nan_rebound()
        if radius is None:
            out["spin"] = None
        return out

    n = (0.0, 1.0)
    t = (1.0, 0.0)
    v = _add(_scale(v_n, n), _scale(v_t, t))  # incoming velocity vector
    speed_n = abs(_dot(v, n))

    R = _ratio(k1, speed_n, p)  # [1], Eq. 4
    captured = bool(speed_n <= v_c)  # capture rule: |v_n| <= v_c
    r_omega = 0.0 if radius is None else radius * spin
    # [1], Eq. 3: eta = (v_t - r omega) / v_n (contact-point slip over normal velocity)
    eta = (_dot(v, t) - r_omega) / _dot(v, n)

    if captured:
        out = {
            "R": R,
            "rho": 1.0,
            "e": 0.0,
            "V_n": 0.0,
            "V_t": 0.0,
            "mu": NAN,
            "mu0": 2.0 * eta / 7.0,  # Eq. 3 with e = 0; not part of the contract
            "rolling": False,
            "captured": True,
            "spin": None if radius is None else 0.0,
        }
        return out

    rho = _ratio(k2, speed_n - v_c, q)  # [1], Eq. 5 written with speeds
    # 1 - rho formed as (|v_n| - v_c)^q / (k2^q + (|v_n| - v_c)^q), exact near capture
    one_minus_rho = 0.0 if math.isinf(k2) else _ratio(speed_n - v_c, k2, q)
    e = R * one_minus_rho  # [1], Eq. 6 (general p, q)
    mu0 = 2.0 * eta / (7.0 * (1.0 + e))  # [1], Eq. 3
    rolling = bool(abs(mu0) <= friction)
    mu = mu0 if rolling else math.copysign(friction, mu0)

    P_n = (1.0 + e) * speed_n  # normal impulse per unit mass, so V_n = -e v_n (Eq. 1)
    P_t = mu * P_n  # tangential impulse per unit mass (Eq. 2)
    P = _add(_scale(P_n, n), _scale(P_t, t))
    V = _add(v, P)
    out = {
        "R": R,
        "rho": rho,
        "e": e,
        "V_n": _dot(V, n),
        "V_t": _dot(V, t),
        "mu": mu,
        "mu0": mu0,
        "rolling": rolling,
        "captured": False,
        "spin": None,
    }
    if radius is not None:
        axis = _cross3(_as3(n), _as3(t))  # spin axis n x t
        arm = _scale(-radius, _as3(n))  # centre -> contact point
        dL = _cross3(arm, _as3(P))  # angular impulse per unit mass
        d_omega = _scale(1.0 / (_INERTIA_FACTOR * radius**2), dL)
        out["spin"] = spin + _dot(d_omega, axis)
    return out


def _nan_apparent(radius, *, shadowed=False, geometry=None):
    out = dict.fromkeys(APPARENT_FIELDS, NAN)
    for flag in ("captured", "shadowed", "rolling", "reimpact"):
        out[flag] = False
    out["shadowed"] = shadowed
    if geometry is not None:
        out.update(geometry)
    if radius is None:
        out["spin"] = None
    return out


def apparent_rebound_scalar(
    speed,
    incidence_angle_deg,
    roughness_angle_deg,
    *,
    k1,
    k2,
    v_c,
    p=1.0,
    q=1.0,
    friction=math.inf,
    radius=None,
    spin=0.0,
):
    r"""
    One impact on a facet tilted by :math:`\phi`, seen in the nominal frame.

    Geometry ([1], Figs. 1 and 3): nominal ``n = (0, 1)``, ``t = (1, 0)``; the
    particle moves along :math:`-\cos\theta\, t - \sin\theta\, n`. The facet's
    tangent is ``t' = (cos phi, sin phi)`` and its outward normal
    ``n' = (-sin phi, cos phi)``, i.e. the nominal frame rotated by :math:`\phi`,
    which turns the facet away from a particle arriving from ``+t`` when
    :math:`\phi > 0`. The true incidence angle is then :math:`\theta - \phi`.

    The facet impact is :func:`rebound_scalar` applied to the projections
    :math:`v\cdot n'` and :math:`v\cdot t'`; the rebound vector is rebuilt as
    :math:`V_{n'} n' + V_{t'} t'` and projected back on ``n`` and ``t``.
    """
    coeffs = {
        "k1": k1,
        "k2": k2,
        "v_c": v_c,
        "p": p,
        "q": q,
        "friction": friction,
        "radius": radius,
        "spin": spin,
    }
    if (
        _isnan(speed, incidence_angle_deg, roughness_angle_deg)
        or not speed > 0.0
        or not 0.0 < incidence_angle_deg <= 90.0
        or not -90.0 < roughness_angle_deg < 90.0
    ):
        return _nan_apparent(radius)

    theta = math.radians(incidence_angle_deg)
    phi = math.radians(roughness_angle_deg)
    n = (0.0, 1.0)
    t = (1.0, 0.0)
    n_f = (-math.sin(phi), math.cos(phi))  # facet outward normal n'
    t_f = (math.cos(phi), math.sin(phi))  # facet tangent t'

    v = _add(_scale(-speed * math.cos(theta), t), _scale(-speed * math.sin(theta), n))
    v_n_f = _dot(v, n_f)
    v_t_f = _dot(v, t_f)
    geometry = {
        "v_n_true": v_n_f,
        "v_t_true": v_t_f,
        "true_incidence_angle_deg": incidence_angle_deg - roughness_angle_deg,
    }
    if roughness_angle_deg >= incidence_angle_deg:
        # the facet faces away at least as steeply as the path: it cannot be reached
        geometry["v_n_true"] = geometry["v_t_true"] = NAN  # NaN rule: no impact
        return _nan_apparent(radius, shadowed=True, geometry=geometry)

    facet = rebound_scalar(v_n_f, v_t_f, **coeffs)
    V = _add(_scale(facet["V_n"], n_f), _scale(facet["V_t"], t_f))  # vector sum
    v_n, v_t = _dot(v, n), _dot(v, t)
    V_n, V_t = _dot(V, n), _dot(V, t)

    out = dict(geometry)
    out.update(
        {
            "e": facet["e"],
            "mu": facet["mu"],
            "captured": facet["captured"],
            "shadowed": False,
            "rolling": facet["rolling"],
            "V_n": V_n,
            "V_t": V_t,
            "spin": facet["spin"],
        }
    )
    if facet["captured"]:
        out.update({"e_m": 0.0, "mu_m": NAN, "reimpact": False})
    else:
        out["e_m"] = -V_n / v_n  # definition of e, nominal frame
        out["mu_m"] = (V_t - v_t) / (V_n - v_n)  # definition of mu, nominal frame
        out["reimpact"] = bool(V_n < 0.0)
    return out
