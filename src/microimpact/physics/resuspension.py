r"""Resuspension of deposited particles by a turbulent flow: the Rock'n'Roll model.

A particle resting on a surface touches it at asperities. The quasi-static
Rock'n'Roll model of Reeks & Hall [1]_ takes the particle to rock about one
asperity under the turbulent drag and lift, and to leave the surface when the
aerodynamic moment about that pivot exceeds the adhesive moment. The aerodynamic
force is a Gaussian random process; the rate at which it first exceeds the
adhesive threshold is the resuspension rate constant. The adhesive force of each
particle is its smooth-contact (JKR) pull-off force times a reduction factor for
roughness, log-normally distributed over the particles, with the median and
spread of Biasi et al. [2]_ by default.

Everything is SI (m, s, kg m⁻³, m² s⁻¹, N, J m⁻²); micrometres appear only in
:func:`biasi2001_adhesion`'s published correlation, converted inside with
:func:`~microimpact.units.m_to_um`. ``docs/resuspension.md`` maps each equation to
its source and its tests.

The equations, with :math:`r` the particle radius, :math:`u_\tau` the friction
velocity, :math:`\rho` and :math:`\nu` the fluid's density and kinematic viscosity:

* wall units: :math:`r^+ = r u_\tau / \nu`;
* mean drag (O'Neill's Stokes-flow drag on a sphere at a wall in the viscous
  sublayer, as used in [1]_ and [2]_): :math:`F_D = 32\,\rho\nu^2 (r^+)^2`;
* mean lift (Hall's measurement, [1]_, [2]_):
  :math:`F_L = 20.9\,\rho\nu^2 (r^+)^{2.31}`;
* the moment about the pivot asperity, divided by the asperity half-spacing
  :math:`a`, is the equivalent removal force
  :math:`\langle f\rangle = \tfrac12 F_L + (r/a) F_D`, with :math:`r/a = 100`
  ([1]_, [2]_), and its fluctuation has rms
  :math:`f_{rms} = 0.2\,\langle f\rangle` ([1]_, [2]_);
* burst (forcing) frequency :math:`n_\theta = 0.00658\,u_\tau^2/\nu`, that is
  :math:`\omega^+ = 2\pi n_\theta \nu/u_\tau^2 = 0.0413` ([1]_, [2]_);
* quasi-static rate constant of a particle of adhesive force :math:`f_a` ([1]_,
  the quasi-static limit; [2]_):

  .. math:: p(f_a) = n_\theta\,
     \frac{\exp\!\left(-\frac{(f_a-\langle f\rangle)^2}{2 f_{rms}^2}\right)}
          {\tfrac12\left[1+\operatorname{erf}\!\left(
           \frac{f_a-\langle f\rangle}{\sqrt2\, f_{rms}}\right)\right]}

* adhesive force :math:`f_a = f'\,\tfrac32\pi\gamma r` (JKR pull-off force of a
  sphere on a flat; :math:`\gamma`, which [1]_ and [2]_ call the surface energy,
  takes the place of JKR's Dupré work of adhesion w, docs/adhesion.md §2.1),
  :math:`f'` log-normal with median :math:`\bar f'` and geometric spread
  :math:`\sigma'`; Biasi's correlation ([2]_), with :math:`r` in µm:
  :math:`\bar f' = 0.016 - 0.0023\,r^{0.545}`,
  :math:`\sigma' = 1.8 + 0.136\,r^{1.4}`;
* remaining fraction after exposures :math:`t_k` at friction velocities
  :math:`u_{\tau,k}`, each step acting on what the earlier ones left:

  .. math:: R = \int_0^\infty \varphi(f')\,
     \exp\Bigl(-\sum_k p_k(f')\,t_k\Bigr)\,df'

  evaluated by adaptive quadrature (:func:`scipy.integrate.quad`) in the
  standard-normal variable :math:`z = \ln(f'/\bar f')/\ln\sigma'`, to an absolute
  accuracy better than 1e-6.

The constants above are the published ones ([1]_, [2]_) as the open
Rock'n'Roll implementations use them (V. Bourgin, *discrete-rocknroll*,
GPL-3.0, github.com/TheSquareRoot/discrete-rocknroll-revamped), which we read
beside the papers' abstracts; :data:`RNR_PARAMETERS` holds them in one place.

References
----------
.. [1] M. W. Reeks, D. Hall, "Kinetic models for particle resuspension in
   turbulent flows: theory and measurement," *J. Aerosol Sci.* 32:1-31, 2001,
   :doi:`10.1016/S0021-8502(00)00063-X`.
.. [2] L. Biasi, A. de los Reyes, M. W. Reeks, G. F. de Santi, "Use of a simple
   model for the interpretation of experimental data on particle resuspension in
   turbulent flows," *J. Aerosol Sci.* 32:1175-1200, 2001,
   :doi:`10.1016/S0021-8502(01)00048-9`.
.. [3] M. E. O'Neill, "A sphere in contact with a plane wall in a slow linear
   shear flow," *Chem. Eng. Sci.* 23:1293-1298, 1968.
.. [4] K. L. Johnson, K. Kendall, A. D. Roberts, "Surface energy and the contact
   of elastic solids," *Proc. R. Soc. Lond. A* 324:301-313, 1971.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from .._core.validation import as_float_array, check_positive
from ..units import m_to_um

__all__ = [
    "BIASI2001_FITTED_RADIUS_UM",
    "BIASI2001_POSITIVE_RADIUS_UM",
    "RNR_PARAMETERS",
    "AdhesionRangeWarning",
    "AdhesionReduction",
    "AerodynamicForces",
    "aerodynamic_forces",
    "air_properties",
    "biasi2001_adhesion",
    "burst_frequency",
    "jkr_pull_off_force",
    "quasi_static_rate",
    "remaining_fraction",
    "remaining_fraction_ramp",
    "resuspension_rate",
    "wall_units_radius",
]

#: The published Rock'n'Roll constants ([1], [2] of the module docstring):
#: ``drag_coefficient`` and ``lift_coefficient`` multiply rho nu^2 (r+)^2 and
#: rho nu^2 (r+)^lift_exponent; ``moment_arm_ratio`` is r/a; ``fluctuation_ratio``
#: is f_rms / <f>; ``burst_coefficient`` is n_theta nu / u_tau^2.
RNR_PARAMETERS: dict[str, dict[str, float]] = {
    "reeks_hall_2001": {
        "drag_coefficient": 32.0,  # [1], after O'Neill (1968): 1.7009 * 6 pi
        "lift_coefficient": 20.9,  # [1], Hall (1988) lift on a sphere at a wall
        "lift_exponent": 2.31,  # [1], Hall (1988)
        "moment_arm_ratio": 100.0,  # [1], [2]: r/a
        "fluctuation_ratio": 0.2,  # [1], [2]: f_rms / <f>
        "burst_coefficient": 0.00658,  # [1], [2]: omega+ = 0.0413 = 2 pi n+
    }
}
_P = RNR_PARAMETERS["reeks_hall_2001"]

#: Biasi et al. (2001) correlation coefficients, radius in µm ([2]).
BIASI2001 = {"median": (0.016, 0.0023, 0.545), "spread": (1.8, 0.136, 1.4)}

#: Radii [µm] of the experiments Biasi et al. fitted (sub-micron aerosol up to
#: Reeks & Hall's 20 µm alumina, radius 10 µm), as we read the paper: outside
#: this range :func:`biasi2001_adhesion` warns.
BIASI2001_FITTED_RADIUS_UM = (0.1, 10.0)
#: Radius [µm] beyond which the correlation's median is <= 0 (no distribution):
#: 0.016 = 0.0023 r^0.545. :func:`biasi2001_adhesion` refuses such radii.
BIASI2001_POSITIVE_RADIUS_UM = (0.016 / 0.0023) ** (1.0 / 0.545)

#: Half-width of the quadrature range in z = ln(f'/median)/ln(spread): the
#: standard-normal mass beyond it is 2 Phi(-12) < 4e-33.
_Z_MAX = 12.0


class AdhesionRangeWarning(UserWarning):
    """A radius outside the range the Biasi (2001) correlation was fitted to."""


@dataclass(frozen=True)
class AerodynamicForces:
    """The aerodynamic forces on a particle at the wall (all [N]).

    Attributes
    ----------
    drag, lift : ndarray
        Mean drag and lift forces.
    mean_force : ndarray
        Mean aerodynamic moment about the pivot asperity divided by the asperity
        half-spacing a: ``lift / 2 + (r/a) drag``.
    rms_force : ndarray
        Root-mean-square fluctuation of that moment (divided by a).
    """

    drag: np.ndarray
    lift: np.ndarray
    mean_force: np.ndarray
    rms_force: np.ndarray


@dataclass(frozen=True)
class AdhesionReduction:
    """Median and geometric spread of the log-normal adhesion reduction factor f'.

    ``distribution()`` gives it as a frozen :func:`scipy.stats.lognorm` with
    ``s = ln(spread)`` and ``scale = median``.
    """

    median: np.ndarray
    spread: np.ndarray

    def distribution(self):
        """The reduction factor's distribution (scipy frozen ``lognorm``)."""
        # deferred: scipy.stats is slow to import and only this method needs it
        from scipy import stats

        return stats.lognorm(np.log(self.spread), scale=self.median)


def _nonneg(x, name):
    a = as_float_array(x, name)
    if np.any(a < 0):  # NaN passes through
        v = a[a < 0].flat[0].item()
        raise ValueError(f"`{name}` must be >= 0; got {v!r}.")
    return a


def wall_units_radius(radius, friction_velocity, kinematic_viscosity):
    r"""
    Particle radius in wall units, :math:`r^+ = r u_\tau/\nu`.

    Parameters
    ----------
    radius : array_like
        Particle radius [m].
    friction_velocity : array_like
        Friction velocity [m s⁻¹], >= 0.
    kinematic_viscosity : array_like
        Kinematic viscosity of the fluid [m² s⁻¹], > 0.

    Returns
    -------
    r_plus : ndarray
        [-]
    """
    r = _nonneg(radius, "radius")
    u = _nonneg(friction_velocity, "friction_velocity")
    nu = check_positive(kinematic_viscosity, "kinematic_viscosity")
    return np.asarray(r * u / nu)[()]


def aerodynamic_forces(
    radius,
    friction_velocity,
    density,
    kinematic_viscosity,
    drag_coefficient=_P["drag_coefficient"],
    lift_coefficient=_P["lift_coefficient"],
    lift_exponent=_P["lift_exponent"],
    moment_arm_ratio=_P["moment_arm_ratio"],
    fluctuation_ratio=_P["fluctuation_ratio"],
) -> AerodynamicForces:
    r"""
    Mean and fluctuating aerodynamic moment on a particle in the viscous sublayer.

    .. math::
       F_D = C_D \rho\nu^2 (r^+)^2,\quad F_L = C_L \rho\nu^2 (r^+)^{m},\quad
       \langle f\rangle = \tfrac12 F_L + \frac{r}{a} F_D,\quad
       f_{rms} = \epsilon \langle f\rangle

    The moment about the pivot asperity is expressed as a force by dividing it
    by the asperity half-spacing a, so that it compares with the adhesive force.

    Parameters
    ----------
    radius : array_like
        Particle radius [m], >= 0.
    friction_velocity : array_like
        Friction velocity [m s⁻¹], >= 0.
    density : array_like
        Fluid density [kg m⁻³], > 0.
    kinematic_viscosity : array_like
        Fluid kinematic viscosity [m² s⁻¹], > 0.
    drag_coefficient, lift_coefficient, lift_exponent : float
        :math:`C_D = 32` (O'Neill 1968 [3]_ as used by [1]_), :math:`C_L = 20.9`,
        :math:`m = 2.31` (Hall 1988, [1]_).
    moment_arm_ratio : float
        r/a, the ratio of the particle radius to the asperity half-spacing
        (100, [1]_, [2]_).
    fluctuation_ratio : float
        :math:`\epsilon = f_{rms}/\langle f\rangle` (0.2, [1]_, [2]_).

    Returns
    -------
    AerodynamicForces
        ``drag``, ``lift``, ``mean_force``, ``rms_force`` [N].

    Notes
    -----
    The drag and lift laws hold for a particle inside the viscous sublayer,
    :math:`r^+ \lesssim 2.5`; beyond it they extrapolate.
    """
    rho = check_positive(density, "density")
    for name, v in (
        ("drag_coefficient", drag_coefficient),
        ("lift_coefficient", lift_coefficient),
        ("moment_arm_ratio", moment_arm_ratio),
        ("fluctuation_ratio", fluctuation_ratio),
        ("lift_exponent", lift_exponent),
    ):
        check_positive(v, name)
    nu = check_positive(kinematic_viscosity, "kinematic_viscosity")
    r_plus = wall_units_radius(radius, friction_velocity, nu)
    scale = rho * nu**2
    drag = drag_coefficient * scale * r_plus**2  # [1], [3]: O'Neill drag
    lift = lift_coefficient * scale * r_plus**lift_exponent  # [1]: Hall's lift
    mean = 0.5 * lift + moment_arm_ratio * drag  # [1], [2]: moments about pivot
    rms = fluctuation_ratio * mean  # [1], [2]
    return AerodynamicForces(
        np.asarray(drag)[()],
        np.asarray(lift)[()],
        np.asarray(mean)[()],
        np.asarray(rms)[()],
    )


def burst_frequency(
    friction_velocity, kinematic_viscosity, burst_coefficient=_P["burst_coefficient"]
):
    r"""
    Typical frequency of the aerodynamic forcing, :math:`n_\theta = n^+ u_\tau^2/\nu`.

    Parameters
    ----------
    friction_velocity : array_like
        [m s⁻¹], >= 0.
    kinematic_viscosity : array_like
        [m² s⁻¹], > 0.
    burst_coefficient : float
        :math:`n^+ = 0.00658`, that is :math:`\omega^+ = 2\pi n^+ = 0.0413`
        ([1]_, [2]_).

    Returns
    -------
    n_theta : ndarray
        [s⁻¹]
    """
    u = _nonneg(friction_velocity, "friction_velocity")
    nu = check_positive(kinematic_viscosity, "kinematic_viscosity")
    check_positive(burst_coefficient, "burst_coefficient")
    return np.asarray(burst_coefficient * u**2 / nu)[()]  # [1], [2]


def quasi_static_rate(adhesion_force, mean_force, rms_force, burst_frequency):
    r"""
    Quasi-static Rock'n'Roll resuspension rate constant of one particle.

    .. math:: p = n_\theta\,\frac{\exp(-x^2/2)}{\Phi(x)},\qquad
       x = \frac{f_a - \langle f\rangle}{f_{rms}}

    with :math:`\Phi` the standard normal distribution function
    (:math:`\Phi(x) = \tfrac12[1+\operatorname{erf}(x/\sqrt2)]`), evaluated as
    ``exp(-x**2/2 - log_ndtr(x))`` so that it stays finite where the adhesion is
    far below the mean force ([1]_, quasi-static limit; [2]_).

    Parameters
    ----------
    adhesion_force : array_like
        Adhesive force of the particle [N], >= 0.
    mean_force, rms_force : array_like
        Mean and rms aerodynamic removal force [N] (:func:`aerodynamic_forces`).
    burst_frequency : array_like
        :math:`n_\theta` [s⁻¹] (:func:`burst_frequency`).

    Returns
    -------
    p : ndarray
        [s⁻¹]; 0 where there is no flow (``rms_force == 0`` and
        ``burst_frequency == 0``).
    """
    # deferred: scipy loads only when a rate is computed (import stays fast)
    from scipy import special

    fa = _nonneg(adhesion_force, "adhesion_force")
    mean = _nonneg(mean_force, "mean_force")
    rms = _nonneg(rms_force, "rms_force")
    n = _nonneg(burst_frequency, "burst_frequency")
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (fa - mean) / rms
        log_ratio = -0.5 * x**2 - special.log_ndtr(x)  # [1], [2]
        p = n * np.exp(log_ratio)
    # no fluctuation: the particle goes at the first burst iff fa < <f>
    still = rms == 0
    p = np.where(still, np.where(fa < mean, n, 0.0), p)
    p = np.where(np.isnan(fa) | np.isnan(mean) | np.isnan(n), np.nan, p)
    return np.asarray(p)[()]


def jkr_pull_off_force(radius, surface_energy):
    r"""
    Smooth-contact pull-off force of a sphere on a flat, :math:`\tfrac32\pi\gamma r`.

    Johnson, Kendall & Roberts [4]_, with :math:`\gamma` as Reeks & Hall [1]_
    and Biasi et al. [2]_ use it: they call it the surface energy, and it takes
    the place of the Dupré work of adhesion w of the JKR pull-off force
    :math:`\tfrac32\pi w R` (docs/adhesion.md, section 2.1).

    Parameters
    ----------
    radius : array_like
        [m], >= 0.
    surface_energy : array_like
        [J m⁻²], >= 0.

    Returns
    -------
    force : ndarray
        [N]
    """
    r = _nonneg(radius, "radius")
    gamma = _nonneg(surface_energy, "surface_energy")
    return np.asarray(1.5 * np.pi * gamma * r)[()]  # [4], as in [1], [2]


def biasi2001_adhesion(radius, *, outside="warn") -> AdhesionReduction:
    r"""
    Median and spread of the adhesion reduction factor, Biasi et al. (2001).

    .. math:: \bar f' = 0.016 - 0.0023\,r^{0.545},\qquad
              \sigma' = 1.8 + 0.136\,r^{1.4}\qquad (r \text{ in µm})

    Parameters
    ----------
    radius : array_like
        Particle radius [m], > 0.
    outside : {"warn", "raise", "ignore"}
        What to do for a radius outside the fitted range
        :data:`BIASI2001_FITTED_RADIUS_UM` (0.1 to 10 µm). A radius at or beyond
        :data:`BIASI2001_POSITIVE_RADIUS_UM` (about 35 µm), where the median is
        not positive, always raises.

    Returns
    -------
    AdhesionReduction
        ``median`` and ``spread`` (geometric standard deviation) [-].

    Raises
    ------
    ValueError
        A radius where the correlation's median is not positive, or (with
        ``outside="raise"``) one outside the fitted range.

    Warns
    -----
    AdhesionRangeWarning
        With ``outside="warn"``, a radius outside the fitted range.
    """
    if outside not in ("warn", "raise", "ignore"):
        raise ValueError(
            f"`outside` must be one of 'warn', 'raise', 'ignore'; got {outside!r}."
        )
    r_um = m_to_um(check_positive(radius, "radius"))
    lo, hi = BIASI2001_FITTED_RADIUS_UM
    if np.any(r_um >= BIASI2001_POSITIVE_RADIUS_UM):
        bad = float(np.max(r_um))
        raise ValueError(
            f"`radius` {bad:.4g} µm is beyond {BIASI2001_POSITIVE_RADIUS_UM:.3g} µm, "
            "where the Biasi (2001) median adhesion reduction is not positive; give "
            "an explicit median and spread."
        )
    out = (r_um < lo) | (r_um > hi)
    if np.any(out) and outside != "ignore":
        bad = float(r_um[out].flat[0]) if r_um.ndim else float(r_um)
        message = (
            f"radius {bad:.4g} µm is outside the range the Biasi (2001) adhesion "
            f"correlation was fitted to ({lo:g} to {hi:g} µm)"
        )
        if outside == "raise":
            raise ValueError(f"`radius`: {message}.")
        warnings.warn(message, AdhesionRangeWarning, stacklevel=2)
    a, b, c = BIASI2001["median"]
    median = a - b * r_um**c  # [2]
    a, b, c = BIASI2001["spread"]
    spread = a + b * r_um**c  # [2]
    return AdhesionReduction(np.asarray(median)[()], np.asarray(spread)[()])


#: Sutherland's law for air, mu = C T^1.5 / (T + S) ([5]: C in kg m-1 s-1 K-0.5,
#: S in K), and the molar mass of dry air [kg mol-1] ([5]).
_SUTHERLAND_AIR = (1.458e-6, 110.4)
_MOLAR_MASS_AIR = 0.0289644
_GAS_CONSTANT = 8.31446261815324  # J mol-1 K-1, exact (SI 2019)


def air_properties(temperature, pressure):
    r"""
    Density and kinematic viscosity of dry air as an ideal gas.

    :math:`\rho = p M / (R T)` and :math:`\nu = \mu/\rho` with Sutherland's law
    :math:`\mu = 1.458\times10^{-6}\,T^{1.5}/(T + 110.4)` and
    :math:`M = 0.0289644` kg mol⁻¹, the constants of the U.S. Standard Atmosphere
    1976 [5]_.

    Parameters
    ----------
    temperature : array_like
        [K], > 0.
    pressure : array_like
        [Pa], > 0.

    Returns
    -------
    density : ndarray
        [kg m⁻³]
    kinematic_viscosity : ndarray
        [m² s⁻¹]

    References
    ----------
    .. [5] *U.S. Standard Atmosphere, 1976*, NOAA/NASA/USAF, Eqs. 42 and 51.
    """
    t = check_positive(temperature, "temperature")
    p = check_positive(pressure, "pressure")
    c, s = _SUTHERLAND_AIR
    mu = c * t**1.5 / (t + s)  # [5], Eq. 51
    rho = p * _MOLAR_MASS_AIR / (_GAS_CONSTANT * t)  # [5], Eq. 42
    return np.asarray(rho)[()], np.asarray(mu / rho)[()]


# --------------------------------------------------------------------- quadrature
def _rate(fa, mean, rms, n, log_ndtr):
    """:func:`quasi_static_rate` of scalars, without the checks (quadrature)."""
    if rms == 0.0:
        return n if fa < mean else 0.0
    x = (fa - mean) / rms
    return n * math.exp(-0.5 * x * x - float(log_ndtr(x)))  # [1], [2]


def _survival_integral(jkr, median, spread, steps, *, moment=0):
    r"""``∫ φ(z) p_last^moment exp(-Σ p_k t_k) dz`` over the standard normal z,
    with f_a = jkr median spread^z; `steps` is a list of (mean, rms, n, t)."""
    # deferred: scipy loads only when an integral is taken (import stays fast)
    from scipy import integrate
    from scipy.special import log_ndtr

    log_s = math.log(spread)
    if moment and not steps:
        return 0.0

    def fa(z):
        return jkr * median * math.exp(z * log_s)

    def exponent(z):
        f = fa(z)
        return sum(_rate(f, m, s, n, log_ndtr) * t for m, s, n, t in steps)

    def integrand(z):
        phi = math.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)
        e = exponent(z)
        value = phi * math.exp(-e)
        if moment:
            m, s, n, _ = steps[-1]
            value *= _rate(fa(z), m, s, n, log_ndtr) ** moment
        return value

    # breakpoints: where each step's mean force and the survival edge sit in z
    points = []
    if jkr * median > 0:
        for m, s, n, t in steps:
            for f in (m, m + s * math.sqrt(2.0 * math.log(max(n * t, 1.0) + 1.0))):
                if f > 0:
                    z = math.log(f / (jkr * median)) / log_s
                    if -_Z_MAX < z < _Z_MAX:
                        points.append(z)
    value, _ = integrate.quad(
        integrand,
        -_Z_MAX,
        _Z_MAX,
        points=sorted(set(points)) or None,
        epsabs=1e-10,
        epsrel=1e-10,
        limit=500,
    )
    return value


def _pair_iv(adhesion_median, adhesion_spread):
    if (adhesion_median is None) != (adhesion_spread is None):
        raise ValueError(
            "`adhesion_median` and `adhesion_spread` go together: give both, or "
            "neither for the Biasi (2001) correlation."
        )


def _adhesion_iv(radius, surface_energy, adhesion_median, adhesion_spread, outside):
    r = check_positive(radius, "radius")
    gamma = _nonneg(surface_energy, "surface_energy")
    _pair_iv(adhesion_median, adhesion_spread)
    if adhesion_median is None:
        red = biasi2001_adhesion(r, outside=outside)
        median, spread = red.median, red.spread
    else:
        median = check_positive(adhesion_median, "adhesion_median")
        spread = as_float_array(adhesion_spread, "adhesion_spread")
        if np.any(~(spread > 1)) or np.any(~np.isfinite(spread)):
            v = spread[~(spread > 1) | ~np.isfinite(spread)].flat[0].item()
            raise ValueError(
                f"`adhesion_spread` must be a finite number > 1; got {v!r}."
            )
    return r, gamma, median, spread


def remaining_fraction_ramp(
    radius,
    friction_velocities,
    exposures,
    density,
    kinematic_viscosity,
    surface_energy,
    *,
    adhesion_median=None,
    adhesion_spread=None,
    outside="warn",
    parameters=None,
):
    r"""
    Remaining fraction after each step of a friction-velocity ramp.

    Each step k holds the friction velocity :math:`u_{\tau,k}` for
    :math:`t_k` and acts on what the earlier steps left: for a particle of
    reduction factor :math:`f'` the survival is
    :math:`\exp(-\sum_{j\le k} p_j(f') t_j)`, and the remaining fraction after
    step k is its mean over the log-normal :math:`f'` (module docstring),
    integrated by adaptive quadrature to better than 1e-6.

    Parameters
    ----------
    radius : array_like
        Particle radius [m], > 0; any shape S.
    friction_velocities : sequence of float
        Friction velocity of each step [m s⁻¹], >= 0 (K steps).
    exposures : float or sequence of float
        Duration of each step [s], >= 0 (one value for every step, or K).
    density, kinematic_viscosity : float
        Fluid density [kg m⁻³] and kinematic viscosity [m² s⁻¹], > 0.
    surface_energy : float
        :math:`\gamma` of :func:`jkr_pull_off_force` [J m⁻²], >= 0.
    adhesion_median, adhesion_spread : array_like, optional
        Median (> 0) and geometric spread (> 1) of the reduction factor; both or
        neither. Neither: :func:`biasi2001_adhesion` of `radius`.
    outside : {"warn", "raise", "ignore"}
        Passed to :func:`biasi2001_adhesion`.
    parameters : dict, optional
        Keyword arguments of :func:`aerodynamic_forces` and
        :func:`burst_frequency` replacing :data:`RNR_PARAMETERS`'s values.

    Returns
    -------
    remaining : ndarray
        Shape ``S + (K,)``: the fraction of the particles still on the surface
        after each step, in [0, 1], non-increasing along the last axis.
    """
    r, gamma, median, spread = _adhesion_iv(
        radius, surface_energy, adhesion_median, adhesion_spread, outside
    )
    u = np.atleast_1d(_nonneg(friction_velocities, "friction_velocities"))
    if u.ndim != 1:
        raise ValueError("`friction_velocities` must be one value or a 1-d sequence.")
    t = np.broadcast_to(_nonneg(exposures, "exposures"), u.shape).astype(float)
    if t.ndim != 1:
        raise ValueError("`exposures` must be one value or one per step.")
    if np.any(~np.isfinite(u)) or np.any(~np.isfinite(t)):
        raise ValueError("`friction_velocities` and `exposures` must be finite.")
    params = dict(_P)
    params.update(parameters or {})
    burst_coefficient = params.pop("burst_coefficient")
    r, median, spread, gamma = np.broadcast_arrays(r, median, spread, gamma)
    out = np.empty(r.shape + u.shape)
    n = np.atleast_1d(burst_frequency(u, kinematic_viscosity, burst_coefficient))
    for idx in np.ndindex(r.shape):
        ri = float(r[idx])
        forces = aerodynamic_forces(ri, u, density, kinematic_viscosity, **params)
        mean = np.atleast_1d(forces.mean_force)
        rms = np.atleast_1d(forces.rms_force)
        jkr = float(jkr_pull_off_force(ri, gamma[idx]))
        steps = []
        for k in range(u.size):  # step k acts on what steps 0..k-1 left
            steps.append((float(mean[k]), float(rms[k]), float(n[k]), float(t[k])))
            out[(*idx, k)] = _survival_integral(
                jkr, float(median[idx]), float(spread[idx]), steps
            )
    return np.clip(out, 0.0, 1.0)


def remaining_fraction(
    radius,
    friction_velocity,
    exposure,
    density,
    kinematic_viscosity,
    surface_energy,
    *,
    adhesion_median=None,
    adhesion_spread=None,
    outside="warn",
    parameters=None,
):
    r"""
    Remaining fraction after one exposure at one friction velocity.

    :math:`R = \int \varphi(f') \exp(-p(f') t)\,df'` (module docstring). Each
    ``(radius, friction_velocity, exposure)`` element is a separate, fresh
    population; for a ramp acting on what earlier steps left, see
    :func:`remaining_fraction_ramp`.

    Parameters
    ----------
    radius : array_like
        Particle radius [m], > 0.
    friction_velocity : array_like
        [m s⁻¹], >= 0.
    exposure : array_like
        Duration [s], >= 0; long exposures give the long-term regime.
    density, kinematic_viscosity, surface_energy : float
        As in :func:`remaining_fraction_ramp`.
    adhesion_median, adhesion_spread, outside, parameters
        As in :func:`remaining_fraction_ramp`.

    Returns
    -------
    remaining : ndarray
        The broadcast shape of `radius`, `friction_velocity` and `exposure`.
    """
    r, u, t = np.broadcast_arrays(
        check_positive(radius, "radius"),
        _nonneg(friction_velocity, "friction_velocity"),
        _nonneg(exposure, "exposure"),
    )
    _pair_iv(adhesion_median, adhesion_spread)
    med = spr = None
    if adhesion_median is not None:
        med, spr = np.broadcast_arrays(
            as_float_array(adhesion_median, "adhesion_median"),
            as_float_array(adhesion_spread, "adhesion_spread"),
        )
        med = np.broadcast_to(med, r.shape)
        spr = np.broadcast_to(spr, r.shape)
    out = np.empty(r.shape)
    for idx in np.ndindex(r.shape):
        out[idx] = remaining_fraction_ramp(
            r[idx],
            [u[idx]],
            [t[idx]],
            density,
            kinematic_viscosity,
            surface_energy,
            adhesion_median=None if med is None else med[idx],
            adhesion_spread=None if spr is None else spr[idx],
            outside=outside,
            parameters=parameters,
        )[0]
    return np.asarray(out)[()]


def resuspension_rate(
    radius,
    friction_velocity,
    time,
    density,
    kinematic_viscosity,
    surface_energy,
    *,
    adhesion_median=None,
    adhesion_spread=None,
    outside="warn",
    parameters=None,
):
    r"""
    Resuspension rate of a population at a constant friction velocity.

    .. math:: \Lambda(t) = -\frac{dR}{dt}
       = \int \varphi(f')\,p(f')\,e^{-p(f')\,t}\,df'

    the fraction of the initial population leaving per second at time t. At long
    times it falls off nearly as a power law, :math:`\Lambda \propto t^{-1}`
    (the long-term regime of [1]_), because the log-normal spread of adhesion
    holds particles whose rates span many decades.

    Parameters
    ----------
    radius, friction_velocity : float
        [m] (> 0) and [m s⁻¹] (>= 0).
    time : array_like
        Times since the flow started [s], >= 0.
    density, kinematic_viscosity, surface_energy
        As in :func:`remaining_fraction_ramp`.
    adhesion_median, adhesion_spread, outside, parameters
        As in :func:`remaining_fraction_ramp`.

    Returns
    -------
    rate : ndarray
        [s⁻¹], the shape of `time`.
    """
    r, gamma, median, spread = _adhesion_iv(
        radius, surface_energy, adhesion_median, adhesion_spread, outside
    )
    if np.ndim(r) or np.ndim(median) or np.ndim(friction_velocity):
        raise ValueError("`radius` and `friction_velocity` must be scalars here.")
    u = float(_nonneg(friction_velocity, "friction_velocity"))
    times = _nonneg(time, "time")
    params = dict(_P)
    params.update(parameters or {})
    burst_coefficient = params.pop("burst_coefficient")
    forces = aerodynamic_forces(float(r), u, density, kinematic_viscosity, **params)
    n = float(burst_frequency(u, kinematic_viscosity, burst_coefficient))
    jkr = float(jkr_pull_off_force(float(r), gamma))
    out = np.empty(times.shape)
    for idx in np.ndindex(times.shape):
        step = (float(forces.mean_force), float(forces.rms_force), n, float(times[idx]))
        out[idx] = _survival_integral(
            jkr, float(median), float(spread), [step], moment=1
        )
    return np.asarray(out)[()]
