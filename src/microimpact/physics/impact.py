r"""
The impact of one microsphere on a surface: the paper's Eqs. 1-9.

Two pure, vectorised model functions:

* :func:`rebound` -- the rigid-body impact model of Brach & Dunn (1995, 1998) with the
  empirical coefficient laws of Li, Dunn & Brach (2000), Eqs. 1-6, in the frame of the
  surface that is struck.
* :func:`apparent_rebound` -- the same impact on a facet tilted by the local roughness
  angle :math:`\phi`, seen in the nominal frame of the apparent surface: Eqs. 7-9.

Frames and signs are set out once in ``docs/conventions.md``; in short:

* ``n`` is the outward normal, so an approaching particle has ``v_n < 0`` and a
  rebounding one ``V_n > 0``.
* In :func:`apparent_rebound` the particle travels in the ``-t`` direction, the
  incidence angle :math:`\theta` is measured from the nominal plane (90 deg is a
  normal impact), and a facet with :math:`\phi > 0` is tilted away from the
  particle. The true incidence angle is :math:`\theta' = \theta - \phi`; where
  :math:`\phi \ge \theta` the facet cannot be reached (``shadowed``).
* The impulse ratio :math:`\mu = (V_t - v_t)/(V_n - v_n)` is positive where friction
  opposes the incoming tangential motion.
* Spin :math:`\omega` is the angular velocity about the axis :math:`n \times t`, so the
  contact point slips at :math:`v_t - r\omega` (the paper's :math:`\eta` numerator).

Capture rule: the paper's Eq. 5 uses :math:`|v_n - v_c|`, which rises again below
:math:`v_c` and would let slow particles rebound. We read :math:`v_c` as the largest
normal speed that is captured: a particle with :math:`|v_n| \le v_c` is captured
(``e = 0``, ``V_n = V_t = 0``, ``mu = nan``); above it Eq. 5 applies with speeds,
:math:`\rho = k_2^q / (k_2^q + (|v_n| - v_c)^q)`, which is continuous at
:math:`|v_n| = v_c` (there :math:`\rho = 1` and :math:`e = 0`).

Elementwise rule for impossible inputs: where a particle is not approaching
(``v_n >= 0``), where the speed is not positive, where an angle is outside its domain,
or where any input is NaN, every float output is NaN and every flag is False. Such an
element never raises in the middle of a vectorised call. Invalid *coefficients*
(negative or NaN ``k1``, ``k2``, ``v_c``, ``friction < 0``, ``p <= 0``, ``q <= 0``)
raise ``ValueError`` because they are parameter mistakes, not data.

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, "Monte Carlo analysis of polydisperse
   microparticle impacts with surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
.. [2] R. M. Brach and P. F. Dunn, "Models of rebound and capture for oblique
   microparticle impacts," *Aerosol Sci. Technol.* 29:379-388, 1998.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._core.reprs import dataclass_repr
from .._core.validation import as_float_array, check_nonnegative, check_positive
from ..units import deg_to_rad, rad_to_deg

__all__ = [
    "ApparentReboundResult",
    "ReboundResult",
    "apparent_rebound",
    "rebound",
]

#: Ratio of the moment of inertia to m r^2 for a solid sphere.
SOLID_SPHERE_INERTIA = 2.0 / 5.0


@dataclass(frozen=True, repr=False)
class ReboundResult:
    """Outcome of :func:`rebound`, in the frame of the struck surface.

    All fields are ndarrays broadcast to a common shape.

    Attributes
    ----------
    R : ndarray
        Restitution coefficient for internal dissipation, Eq. 4 [-].
    rho : ndarray
        Adhesion coefficient, Eq. 5 [-]; 1 where captured.
    e : ndarray
        Overall coefficient of restitution ``R (1 - rho)``, Eq. 6 [-]; 0 where captured.
    V_n, V_t : ndarray
        Normal and tangential velocity after impact, Eqs. 1-2 [m s-1].
    mu : ndarray
        Impulse ratio ``(V_t - v_t)/(V_n - v_n)`` [-]; NaN where captured.
    mu0 : ndarray
        Critical impulse ratio for rolling at separation, Eq. 3 [-].
    rolling : ndarray of bool
        True where the sphere leaves rolling without sliding (``|mu0| <= friction``).
    captured : ndarray of bool
        True where ``|v_n| <= v_c``.
    spin : ndarray or None
        Angular velocity after impact about ``n x t`` [rad s-1] for a solid sphere;
        only when `radius` was given, else None. 0 where captured.
    """

    R: np.ndarray
    rho: np.ndarray
    e: np.ndarray
    V_n: np.ndarray
    V_t: np.ndarray
    mu: np.ndarray
    mu0: np.ndarray
    rolling: np.ndarray
    captured: np.ndarray
    spin: np.ndarray | None = None


@dataclass(frozen=True, repr=False)
class ApparentReboundResult:
    """Outcome of :func:`apparent_rebound`, seen on the nominal (apparent) surface.

    The nominal frame is right-handed, ``(t, b, n) = (x, y, z)``: ``n`` (z) is the
    outward normal of the nominal surface, ``t`` (x) lies in the plane of incidence
    (the particle travels towards ``-t``) and ``b = n x t`` (y) is the spin axis of
    the 2-D model. The facet frame ``(t', b', n')`` has ``n'`` the facet normal,
    ``t'`` the facet's line in the plane of incidence and ``b' = n' x t'``; with no
    out-of-plane tilt it is the paper's ``(t', n')`` with ``b' = b``.

    Attributes
    ----------
    e_m : ndarray
        Apparent (measured) coefficient of restitution ``-V_n/v_n`` in the nominal
        frame, Eq. 8 [-]. 0 where captured, NaN where shadowed.
    mu_m : ndarray
        Apparent impulse ratio ``(V_t - v_t)/(V_n - v_n)`` in the nominal frame,
        Eq. 9 [-]. NaN where captured or shadowed.
    e : ndarray
        Coefficient of restitution on the facet (from :func:`rebound`) [-].
    mu : ndarray
        Impulse ratio on the facet along ``t'`` [-], signed as in :func:`rebound`;
        with no out-of-plane tilt it is the paper's facet ``mu``.
    mu_b : ndarray
        Impulse ratio on the facet along ``b'`` [-]; 0 with no out-of-plane tilt.
        ``hypot(mu, mu_b)`` is the magnitude of the tangential-to-normal impulse.
    captured, shadowed, rolling : ndarray of bool
        Capture (decided on the true normal speed ``|v_n_true|``), facet out of
        reach (``phi >= theta``), and rolling at separation.
    reimpact : ndarray of bool
        True where the rebound still heads into the nominal surface (``V_n < 0`` in
        the nominal frame), so that a real particle would strike again.
    V_n, V_t, V_b : ndarray
        Rebound velocity in the nominal frame [m s-1]: along ``n`` (z, normal),
        ``t`` (x, in the plane of incidence) and ``b = n x t`` (y, lateral).
        0 where captured.
    v_n_true, v_t_true, v_b_true : ndarray
        Incoming velocity in the facet frame ``(n', t', b')`` [m s-1].
    true_incidence_angle_deg : ndarray
        ``theta - phi`` [deg], the true incidence angle in the plane of incidence
        (the path's angle to the facet is ``arcsin(|v_n_true| / speed)``).
    lateral_angle_deg : ndarray
        Lateral (out-of-plane) rebound angle :math:`\\psi = \\operatorname{atan2}(V_b,
        -V_t)` [deg], in (-180, 180]: 0 is forward scatter in the plane of incidence,
        positive towards ``+b``, ±180 back along the incoming direction. NaN where
        captured or shadowed.
    rebound_elevation_deg : ndarray
        Elevation of the rebound above the nominal plane,
        ``atan2(V_n, hypot(V_t, V_b))`` [deg]; negative where ``reimpact``. NaN
        where captured or shadowed.
    spin : ndarray or None
        Angular velocity after impact about ``b = n x t`` [rad s-1] when `radius` was
        given (the 2-D model's spin).
    spin_t, spin_n : ndarray or None
        Angular velocity after impact about ``t`` and ``n`` [rad s-1] when `radius`
        was given; 0 with no out-of-plane tilt.
    """

    e_m: np.ndarray
    mu_m: np.ndarray
    e: np.ndarray
    mu: np.ndarray
    captured: np.ndarray
    shadowed: np.ndarray
    rolling: np.ndarray
    reimpact: np.ndarray
    V_n: np.ndarray
    V_t: np.ndarray
    v_n_true: np.ndarray
    v_t_true: np.ndarray
    true_incidence_angle_deg: np.ndarray
    mu_b: np.ndarray
    V_b: np.ndarray
    v_b_true: np.ndarray
    lateral_angle_deg: np.ndarray
    rebound_elevation_deg: np.ndarray
    spin: np.ndarray | None = None
    spin_t: np.ndarray | None = None
    spin_n: np.ndarray | None = None


def _coefficients_iv(k1, k2, v_c, p, q, friction, radius, spin):
    """Validate the coefficient arguments shared by both model functions."""
    k1 = check_nonnegative(k1, "k1")
    k2 = check_nonnegative(k2, "k2")
    v_c = check_nonnegative(v_c, "v_c", allow_inf=False)
    p = check_positive(p, "p")
    q = check_positive(q, "q")
    friction = check_nonnegative(friction, "friction")
    spin = as_float_array(spin, "spin")
    if radius is None:
        if np.any(spin != 0):
            raise ValueError("`spin` needs `radius`: got spin != 0 and radius=None.")
    else:
        radius = check_positive(radius, "radius")
    return k1, k2, v_c, p, q, friction, radius, spin


def _ratio_law(k, x, power):
    """``k^power / (k^power + x^power)`` written as ``1 / (1 + (x/k)^power)``.

    This form is exact for the limits ``k = 0`` (gives 0 for x > 0) and ``k = inf``
    (gives 1), and for ``power = 1`` avoids ``pow`` entirely.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        z = x / k
        if not (np.ndim(power) == 0 and power == 1.0):
            z = z**power
        return 1.0 / (1.0 + z)


def rebound(
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
) -> ReboundResult:
    r"""
    Rebound of a sphere from a surface: the rigid-body model, Eqs. 1-6 of [1]_.

    Parameters
    ----------
    v_n : array_like
        Normal velocity before impact [m s-1]; negative for an approaching particle.
    v_t : array_like
        Tangential velocity before impact [m s-1].
    k1 : array_like
        Restitution speed scale of Eq. 4 [m s-1]; ``inf`` gives ``R = 1``.
    k2 : array_like
        Adhesion speed scale of Eq. 5 [m s-1]; 0 switches adhesion off.
    v_c : array_like
        Capture velocity [m s-1]: the largest normal speed that is captured.
    p, q : float or array_like, default 1.0
        Exponents of Eqs. 4 and 5 (the paper uses ``p = q = 1``, giving Eq. 6).
    friction : float or array_like, default inf
        Coulomb coefficient of friction; ``inf`` means the sphere always leaves
        rolling.
    radius : array_like, optional
        Sphere radius [m]; needed for initial spin and to report the final spin.
    spin : array_like, default 0.0
        Angular velocity before impact about ``n x t`` [rad s-1].

    Returns
    -------
    ReboundResult
        ``R``, ``rho``, ``e``, ``V_n``, ``V_t``, ``mu``, ``mu0``, ``rolling``,
        ``captured`` and ``spin``.

    Notes
    -----
    .. math::

        R &= k_1^p / (k_1^p + |v_n|^p)                          && \text{Eq. 4} \\
        \rho &= k_2^q / (k_2^q + (|v_n| - v_c)^q)               && \text{Eq. 5} \\
        e &= R (1 - \rho)                                      && \text{Eq. 6} \\
        V_n &= -e\, v_n                                        && \text{Eq. 1} \\
        V_t &= v_t - \mu (1 + e) v_n                           && \text{Eq. 2} \\
        \mu_0 &= 2\eta / [7 (1 + e)],\ \eta = (v_t - r\omega)/v_n && \text{Eq. 3}

    ``mu = mu0`` where ``|mu0| <= friction`` (rolling at separation), else
    ``mu = sign(mu0) * friction`` (sliding). A particle with ``|v_n| <= v_c`` is
    captured (see the module docstring for why Eq. 5 alone is not used there).

    The final spin of a solid sphere (moment of inertia ``2/5 m r^2``) follows from the
    tangential impulse: ``omega' = omega - (5/2) (V_t - v_t) / r``.

    References
    ----------
    .. [1] X. Li, P. F. Dunn and R. M. Brach, *Aerosol Sci. Technol.* 33:376-386, 2000.
    """
    k1, k2, v_c, p, q, friction, radius, spin = _coefficients_iv(
        k1, k2, v_c, p, q, friction, radius, spin
    )
    v_n = as_float_array(v_n, "v_n")
    v_t = as_float_array(v_t, "v_t")
    arrays = [v_n, v_t, k1, k2, v_c, p, q, friction, spin]
    if radius is not None:
        arrays.append(radius)
    arrays = np.broadcast_arrays(*arrays)
    v_n, v_t, k1, k2, v_c, p, q, friction, spin = arrays[:9]
    r = arrays[9] if radius is not None else None

    speed_n = np.abs(v_n)
    valid = v_n < 0  # approaching; False for NaN
    valid &= np.isfinite(v_t) & np.isfinite(spin)
    captured = valid & (speed_n <= v_c)
    rebounds = valid & ~captured

    with np.errstate(divide="ignore", invalid="ignore"):
        R = _ratio_law(k1, speed_n, p)  # [1], Eq. 4
        rho = _ratio_law(k2, speed_n - v_c, q)  # [1], Eq. 5 (speeds; see docstring)
        rho = np.where(captured, 1.0, rho)
        e = R * (1.0 - rho)  # [1], Eq. 6
        e = np.where(captured, 0.0, e)
        slip = v_t if r is None else v_t - r * spin
        eta = slip / v_n  # [1], Eq. 3
        mu0 = 2.0 * eta / (7.0 * (1.0 + e))  # [1], Eq. 3
        rolling = rebounds & (np.abs(mu0) <= friction)
        mu = np.where(rolling, mu0, np.sign(mu0) * friction)
        V_n = -e * v_n  # [1], Eq. 1
        V_t = v_t - mu * (1.0 + e) * v_n  # [1], Eq. 2
        final_spin = None
        if r is not None:
            dV_t = V_t - v_t
            # Angular impulse about the centre: I (omega' - omega) = -r m dV_t with
            # I = (2/5) m r^2, so omega' = omega - dV_t / ((2/5) r).
            final_spin = spin - dV_t / (SOLID_SPHERE_INERTIA * r)

    nan = np.nan
    R = np.where(valid, R, nan)
    rho = np.where(valid, rho, nan)
    e = np.where(valid, e, nan)
    mu0 = np.where(valid, mu0, nan)
    mu = np.where(rebounds, mu, nan)
    V_n = np.where(rebounds, V_n, np.where(captured, 0.0, nan))
    V_t = np.where(rebounds, V_t, np.where(captured, 0.0, nan))
    if final_spin is not None:
        final_spin = np.where(rebounds, final_spin, np.where(captured, 0.0, nan))
        final_spin = final_spin[()]

    return ReboundResult(
        R=R[()],
        rho=rho[()],
        e=e[()],
        V_n=V_n[()],
        V_t=V_t[()],
        mu=mu[()],
        mu0=mu0[()],
        rolling=rolling[()],
        captured=captured[()],
        spin=final_spin,
    )


def apparent_rebound(
    speed,
    incidence_angle_deg,
    roughness_angle_deg,
    *,
    out_of_plane_angle_deg=0.0,
    k1,
    k2,
    v_c,
    p=1.0,
    q=1.0,
    friction=math.inf,
    radius=None,
    spin=0.0,
) -> ApparentReboundResult:
    r"""
    Impact on a rough surface's local facet, seen on the nominal surface: Eqs. 7-9,
    and their 3-D extension to a facet tilted out of the plane of incidence.

    The incoming particle travels in the ``-t`` direction at `speed`, at the apparent
    incidence angle :math:`\theta` from the nominal plane,
    :math:`u = s(-\cos\theta, 0, -\sin\theta)` in the nominal frame
    ``(t, b, n) = (x, y, z)``. It strikes a facet with local slopes
    :math:`h_x = \tan\phi_\parallel` (the paper's roughness angle :math:`\phi`) and
    :math:`h_y = \tan\phi_\perp` (the out-of-plane angle), whose unit normal is
    :math:`n' \propto (-\tan\phi_\parallel, -\tan\phi_\perp, 1)`. The impact is
    computed on the facet with Eqs. 1-6 of [1]_ (through :func:`rebound`; capture
    is decided on the true normal speed :math:`|u\cdot n'|`) and seen on the nominal
    surface. With :math:`\phi_\perp = 0` this is exactly the paper's 2-D model.

    Parameters
    ----------
    speed : array_like
        Incident speed [m s-1], > 0.
    incidence_angle_deg : array_like
        Apparent incidence angle from the nominal plane [deg], in (0, 90]; 90 is normal.
    roughness_angle_deg : array_like
        Local facet angle :math:`\phi = \phi_\parallel` in the plane of incidence
        [deg], in (-90, 90). Positive: tilted away from the particle (the surface
        rises along ``+t``); negative: facing it.
    out_of_plane_angle_deg : array_like, default 0.0
        Local facet angle :math:`\phi_\perp` across the plane of incidence [deg], in
        (-90, 90): the surface rises along ``+b`` for :math:`\phi_\perp > 0`, so the
        facet normal leans towards ``-b`` and the rebound is deflected towards ``-b``.
    k1, k2, v_c, p, q, friction, radius, spin
        As in :func:`rebound`; `spin` is the initial angular velocity about
        ``b = n x t``.

    Returns
    -------
    ApparentReboundResult
        Includes the rebound velocity ``(V_t, V_b, V_n)`` along ``(x, y, z)``, the
        lateral angle :math:`\psi` and the rebound elevation.

    Notes
    -----
    **The 3-D impact** (docs/physics.md, "Areal roughness"). With
    :math:`u_{n'} = u\cdot n'` (< 0 for an impact; otherwise the facet is
    ``shadowed``) and the tangential velocity :math:`u_{t'} = u - u_{n'} n'`, the
    contact point slips at :math:`w = u_{t'} + \omega \times (-r n')`. Eqs. 1-6 hold
    with :math:`|u_{n'}|`, Eq. 3 with :math:`\eta = |w| / |u_{n'}|`, and the
    tangential impulse opposes the slip,

    .. math::

        V_{n'} = -e\,u_{n'}, \qquad
        V_{t'} = u_{t'} - \mu (1 + e) |u_{n'}|\, \hat w, \qquad
        U = V_{n'} n' + V_{t'},

    which for a sphere is exact: the slip keeps its direction during the impact.
    On the nominal surface :math:`e_m = U_z / (s\sin\theta)`,
    :math:`\mu_m = (U_x - u_x)/(U_z - u_z)`, :math:`\psi = \operatorname{atan2}(U_y,
    -U_x)`. The final spin is :math:`\omega' = \omega + (\Delta V \times n') /
    (\tfrac25 r)`.

    **How it is evaluated** (so that :math:`\phi_\perp = 0` reproduces the 2-D
    model bit for bit). The facet is the paper's facet, tilted by :math:`\phi` about
    ``b``, then tilted by :math:`\chi = \arctan(\tan\phi_\perp\cos\phi)` about its
    own line ``t'``: :math:`n' = \cos\chi\, n_\phi - \sin\chi\, b`,
    :math:`b' = \cos\chi\, b + \sin\chi\, n_\phi`, with
    :math:`n_\phi = (-\sin\phi, 0, \cos\phi)` and :math:`t' = (\cos\phi, 0,
    \sin\phi)`. The particle has no ``b`` component, so with the paper's
    :math:`v_{n\phi} = -s\sin\theta'`, :math:`v_{t'} = -s\cos\theta'`,
    :math:`\theta' = \theta - \phi`:

    .. math::

        u_{n'} = \cos\chi\, v_{n\phi}, \qquad u_{b'} = \sin\chi\, v_{n\phi},

    so shadowing depends on :math:`\phi` alone and :math:`\phi_\perp` lowers the
    normal speed by :math:`\cos\chi`. Projecting :math:`U` back on ``n_phi``, ``t'``
    and ``b`` gives Eq. 7 with :math:`V_{n'}` replaced by
    :math:`A = \cos\chi V_{n'} + \sin\chi V_{b'}`, and Eqs. 8-9 with :math:`e`
    and :math:`\mu` replaced by

    .. math::

        e_\phi &= e\cos^2\chi - \sin\chi\, V_{b'}/v_{n\phi}, \\
        \mu_\phi &= \mu_{t'} / (\cos\chi + \mu_{b'}\sin\chi),

    where :math:`\mu_{t'}, \mu_{b'}` are the facet impulse ratios along ``t'`` and
    ``b'``:

    .. math::

        e_m &= \frac{e_\phi - \tan\phi\, V_{t'}/v_{n\phi}}
                    {1 + \tan\phi\, v_{t'}/v_{n\phi}} && \text{Eq. 8} \\
        \mu_m &= \frac{\mu_\phi - \tan\phi}{\mu_\phi\tan\phi + 1} && \text{Eq. 9}

    With :math:`\chi = 0`: :math:`e_\phi = e`, :math:`\mu_\phi = \mu`, and these are
    the paper's Eqs. 7-9 as printed; they are exactly ``-V_n/v_n`` and
    ``(V_t - v_t)/(V_n - v_n)``. Shadowed elements (``phi >= theta``) are NaN with
    ``shadowed = True``. A captured particle has ``e_m = 0``, ``V = 0`` and NaN
    ``mu_m``, lateral angle and elevation.

    References
    ----------
    .. [1] X. Li, P. F. Dunn and R. M. Brach, *Aerosol Sci. Technol.* 33:376-386, 2000.
    """
    k1, k2, v_c, p, q, friction, radius, spin = _coefficients_iv(
        k1, k2, v_c, p, q, friction, radius, spin
    )
    speed = as_float_array(speed, "speed")
    theta_deg = as_float_array(incidence_angle_deg, "incidence_angle_deg")
    phi_deg = as_float_array(roughness_angle_deg, "roughness_angle_deg")
    perp_deg = as_float_array(out_of_plane_angle_deg, "out_of_plane_angle_deg")
    speed, theta_deg, phi_deg, perp_deg = np.broadcast_arrays(
        speed, theta_deg, phi_deg, perp_deg
    )
    g = _incoming_on_facet(speed, theta_deg, phi_deg, perp_deg)
    slip_t, slip_b, slip = _contact_slip(
        g["v_t_true"], g["v_b_true"], g["cos_chi"], radius, spin
    )
    facet = rebound(
        g["v_n_true"],
        slip,
        k1=k1,
        k2=k2,
        v_c=v_c,
        p=p,
        q=q,
        friction=friction,
    )
    # rebound broadcasts with the coefficients, so its outputs have the full shape;
    # the geometry is broadcast to it
    shape = np.shape(facet.e)
    g = {k: np.broadcast_to(v, shape) for k, v in g.items()}
    slip_t, slip_b, slip = (np.broadcast_to(a, shape) for a in (slip_t, slip_b, slip))
    out = _rebound_on_facet(facet, g, slip_t, slip_b, slip)
    out |= _apparent(facet, g, out)
    final = _final_spin(facet.captured, g, out, radius, spin, shape)
    return _apparent_result(facet, g, out, final)


def _incoming_on_facet(speed, theta_deg, phi_deg, perp_deg) -> dict:
    """The facet's geometry and the incoming velocity on it: the paper's facet
    (n_phi, t') at phi, tilted by chi about t' (issue 14's areal facet)."""
    in_domain = (
        (speed > 0)
        & np.isfinite(speed)
        & (theta_deg > 0)
        & (theta_deg <= 90)
        & (np.abs(phi_deg) < 90)
        & (np.abs(perp_deg) < 90)
    )
    theta = deg_to_rad(theta_deg)
    phi = deg_to_rad(phi_deg)
    true_angle = theta - phi  # theta' = theta - phi
    shadowed = in_domain & (true_angle <= 0)  # u . n' >= 0: phi_perp plays no part
    reachable = in_domain & ~shadowed

    with np.errstate(invalid="ignore"):
        # out-of-plane tilt of the facet about its own line t' (0 exactly for
        # phi_perp = 0, so that cos_chi = 1 and sin_chi = 0 exactly)
        chi = np.arctan(np.tan(deg_to_rad(perp_deg)) * np.cos(phi))
        cos_chi, sin_chi = np.cos(chi), np.sin(chi)
        # incoming velocity on the paper's facet (n_phi, t'), then on (n', b')
        v_n_phi = np.where(reachable, -speed * np.sin(true_angle), np.nan)
        v_t_true = np.where(reachable, -speed * np.cos(true_angle), np.nan)
        v_n_true = cos_chi * v_n_phi  # u . n'
        v_b_true = sin_chi * v_n_phi  # u . b'
    return {
        "in_domain": in_domain,
        "shadowed": shadowed,
        "phi": phi,
        "true_angle": true_angle,
        "cos_chi": cos_chi,
        "sin_chi": sin_chi,
        "v_n_phi": v_n_phi,
        "v_t_true": v_t_true,
        "v_n_true": v_n_true,
        "v_b_true": v_b_true,
    }


def _contact_slip(v_t_true, v_b_true, cos_chi, radius, spin):
    """``(slip_t, slip_b, slip)``: the slip of the contact point
    w = u_t' + omega x (-r n') (omega about b, and b x n' = cos(chi) t'), and the
    slip speed signed like its t' component (so that it is the 2-D slip itself when
    slip_b = 0)."""
    if radius is None:
        slip_t = v_t_true
    else:
        slip_t = v_t_true - radius * (spin * cos_chi)
    slip_b = v_b_true
    slip = np.copysign(np.hypot(slip_t, slip_b), slip_t)
    return slip_t, slip_b, slip


def _rebound_on_facet(facet, g, slip_t, slip_b, slip) -> dict:
    """The rebound velocity on the facet (n', t', b'): [1] Eqs. 1-2 along each
    facet tangent, the impulse ratio split along the slip direction."""
    e, mu, captured = facet.e, facet.mu, facet.captured
    v_t_true, v_n_true, v_b_true = g["v_t_true"], g["v_n_true"], g["v_b_true"]
    with np.errstate(divide="ignore", invalid="ignore"):
        # unit slip direction (w_t', w_b') * sign: (1, 0) exactly when slip_b = 0
        moving = slip != 0
        dir_t = np.where(moving, slip_t / slip, 1.0)
        dir_b = np.where(moving, slip_b / slip, 0.0)
        mu_t = mu * dir_t  # facet impulse ratio along t' (the 2-D mu)
        mu_b = mu * dir_b  # and along b'
        V_n_true = facet.V_n  # [1], Eq. 1: -e u_n'
        # [1], Eq. 2 along each facet tangent; 0 where captured
        V_t_true = np.where(captured, 0.0, v_t_true - mu_t * (1.0 + e) * v_n_true)
        V_b_true = np.where(captured, 0.0, v_b_true - mu_b * (1.0 + e) * v_n_true)
    return {
        "mu_t": mu_t,
        "mu_b": mu_b,
        "V_n_true": V_n_true,
        "V_t_true": V_t_true,
        "V_b_true": V_b_true,
    }


def _apparent(facet, g, f) -> dict:
    """The nominal velocity ([1], Eq. 7) and the apparent e_m and mu_m ([1],
    Eqs. 8-9, with e -> e_phi and mu -> mu_phi on a tilted facet)."""
    e = facet.e
    cos_chi, sin_chi, v_n_phi = g["cos_chi"], g["sin_chi"], g["v_n_phi"]
    V_n_true, V_t_true, V_b_true = f["V_n_true"], f["V_t_true"], f["V_b_true"]
    mu_t, mu_b = f["mu_t"], f["mu_b"]
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = g["phi"]
        cos_phi, sin_phi = np.cos(phi), np.sin(phi)
        tan_phi = np.tan(phi)
        # component of U along the paper's facet normal n_phi
        A = V_n_true * cos_chi + V_b_true * sin_chi
        # [1], Eq. 7 (with V_n' -> A): nominal components from the facet components
        V_n = cos_phi * A + sin_phi * V_t_true
        V_t = -sin_phi * A + cos_phi * V_t_true
        V_b = cos_chi * V_b_true - sin_chi * V_n_true
        # [1], Eq. 8 with e -> e_phi
        e_phi = e * cos_chi**2 - sin_chi * V_b_true / v_n_phi
        e_m = (e_phi - tan_phi * V_t_true / v_n_phi) / (
            1.0 + tan_phi * g["v_t_true"] / v_n_phi
        )
        # [1], Eq. 9 with mu -> mu_phi
        mu_phi = mu_t / (cos_chi + mu_b * sin_chi)
        mu_m = (mu_phi - tan_phi) / (mu_phi * tan_phi + 1.0)
    return {
        "cos_phi": cos_phi,
        "sin_phi": sin_phi,
        "V_n": V_n,
        "V_t": V_t,
        "V_b": V_b,
        "e_m": e_m,
        "mu_m": mu_m,
    }


def _final_spin(captured, g, f, radius, spin, shape) -> dict:
    """The spin after the impact (about b, t and n), where a radius is given."""
    if radius is None:
        return {}
    cos_chi, sin_chi = g["cos_chi"], g["sin_chi"]
    cos_phi, sin_phi = f["cos_phi"], f["sin_phi"]
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.broadcast_to(radius, shape)
        spin0 = np.broadcast_to(spin, shape)
        dV_t = f["V_t_true"] - g["v_t_true"]
        dV_b = f["V_b_true"] - g["v_b_true"]
        k = SOLID_SPHERE_INERTIA * r
        # omega' = omega + (dV x n') / ((2/5) r), dV = dV_t t' + dV_b b':
        # dV x n' = dV_b t' - dV_t b', resolved on (t, b, n)
        final = {
            "spin": spin0 - dV_t * cos_chi / k,
            "spin_t": (dV_b * cos_phi + dV_t * sin_chi * sin_phi) / k,
            "spin_n": (dV_b * sin_phi - dV_t * sin_chi * cos_phi) / k,
        }
    return {key: np.where(captured, 0.0, v)[()] for key, v in final.items()}


def _apparent_result(facet, g, f, final) -> ApparentReboundResult:
    """The result: e_m = 0 and V = 0 where captured; the lateral angle and the
    elevation of a particle that leaves."""
    captured = facet.captured
    V_n, V_t, V_b = f["V_n"], f["V_t"], f["V_b"]
    e_m = np.where(captured, 0.0, f["e_m"])
    mu_m = f["mu_m"]
    reimpact = ~captured & (V_n < 0)  # NaN compares False
    leaves = ~captured & np.isfinite(V_n)
    # + 0.0 turns a -0.0 lateral component into +0.0: psi = 180, not -180
    psi = np.arctan2(V_b + 0.0, -V_t)
    elevation = np.arctan2(V_n, np.hypot(V_t, V_b))
    mu_t, mu_b = f["mu_t"], f["mu_b"]
    v_n_true, v_t_true, v_b_true = g["v_n_true"], g["v_t_true"], g["v_b_true"]
    in_domain, true_angle, shadowed = g["in_domain"], g["true_angle"], g["shadowed"]
    e = facet.e
    return ApparentReboundResult(
        e_m=e_m[()],
        mu_m=mu_m[()],
        e=e,
        mu=np.array(mu_t)[()],
        captured=captured,
        shadowed=np.array(shadowed)[()],
        rolling=facet.rolling,
        reimpact=reimpact[()],
        V_n=V_n[()],
        V_t=V_t[()],
        v_n_true=np.array(v_n_true)[()],
        v_t_true=np.array(v_t_true)[()],
        true_incidence_angle_deg=np.where(in_domain, rad_to_deg(true_angle), np.nan)[
            ()
        ],
        mu_b=np.array(mu_b)[()],
        V_b=V_b[()],
        v_b_true=np.array(v_b_true)[()],
        lateral_angle_deg=np.where(leaves, rad_to_deg(psi), np.nan)[()],
        rebound_elevation_deg=np.where(leaves, rad_to_deg(elevation), np.nan)[()],
        spin=final.get("spin"),
        spin_t=final.get("spin_t"),
        spin_n=final.get("spin_n"),
    )


ReboundResult.__repr__ = dataclass_repr
ApparentReboundResult.__repr__ = dataclass_repr
