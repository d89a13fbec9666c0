r"""Contact mechanics of a sphere on a flat: Hertz compression, JKR sticking velocity.

These closed forms give physically based estimates of the capture velocity
:math:`v_c` and of the contact size used to choose the roughness length scale
in [1]_. Everything is SI: m, kg m⁻³, Pa, J m⁻², m s⁻¹.

The derivation of the Thornton–Ning constant 1.84, the meaning of
:math:`\Gamma` and of :math:`R` are written out in ``docs/adhesion.md``.

References
----------
.. [1] X. Li, P. F. Dunn, R. M. Brach, "Monte Carlo analysis of polydisperse
   microparticle impacts with surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
.. [2] C. Thornton, Z. Ning, "A theoretical model for the stick/bounce behaviour
   of adhesive, elastic-plastic spheres," *Powder Technol.* 99:154-162, 1998,
   :doi:`10.1016/S0032-5910(98)00099-0`.
.. [3] K. L. Johnson, K. Kendall, A. D. Roberts, "Surface energy and the contact
   of elastic solids," *Proc. R. Soc. Lond. A* 324:301-313, 1971.
.. [4] K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, §4.2
   and §11.4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._core.validation import (
    as_float_array,
    check_nonnegative,
    check_positive,
    did_you_mean,
)

__all__ = [
    "MATERIALS",
    "Material",
    "contact_modulus",
    "geometric_mean_work_of_adhesion",
    "hertz_contact_radius",
    "hertz_max_compression",
    "material",
    "thornton_ning_sticking_velocity",
]

# Thornton-Ning constant, exact value of the JKR energy balance (docs/adhesion.md):
# W_s = pi^(5/3) [F(2^(1/3)) - F(1/2)] Gamma^(5/3) R^(4/3) E*^(-2/3),
# F(s) = (4 sqrt2 / 3) s^(7/2) - s^2 - (8/15) s^5, and v_s = sqrt(2 W_s / m).
_F = lambda s: 4.0 * math.sqrt(2.0) / 3.0 * s**3.5 - s**2 - 8.0 / 15.0 * s**5  # noqa: E731
#: Dimensionless work of separation; [2] Eq. 52 prints 7.09.
JKR_SEPARATION_WORK_CONSTANT = math.pi ** (5.0 / 3.0) * (_F(2.0 ** (1 / 3)) - _F(0.5))
#: Sticking-velocity constant for a sphere on a flat; [2] Eq. 54 prints 1.84.
THORNTON_NING_CONSTANT = math.sqrt(3.0 * JKR_SEPARATION_WORK_CONSTANT / (2.0 * math.pi))
del _F


def _diameter(diameter):
    """Diameter as a float array, NaN where it is not finite and > 0."""
    d = as_float_array(diameter, "diameter")
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(d) & (d > 0)
    return np.where(ok, d, np.nan)


def contact_modulus(
    youngs_modulus_1, poisson_ratio_1, youngs_modulus_2, poisson_ratio_2
):
    r"""
    Effective (contact) modulus of two elastic bodies.

    .. math:: E^* = \left(\frac{1-\nu_1^2}{E_1} + \frac{1-\nu_2^2}{E_2}\right)^{-1}

    Parameters
    ----------
    youngs_modulus_1, youngs_modulus_2 : array_like
        Young's moduli [Pa], > 0; ``inf`` models a rigid body.
    poisson_ratio_1, poisson_ratio_2 : array_like
        Poisson ratios [-], in ``(-1, 0.5]``.

    Returns
    -------
    e_star : ndarray
        Contact modulus [Pa].

    References
    ----------
    Johnson (1985), *Contact Mechanics*, Eq. 4.22.
    """
    e1 = check_positive(youngs_modulus_1, "youngs_modulus_1", allow_inf=True)
    e2 = check_positive(youngs_modulus_2, "youngs_modulus_2", allow_inf=True)
    nus = []
    for name, nu in (
        ("poisson_ratio_1", poisson_ratio_1),
        ("poisson_ratio_2", poisson_ratio_2),
    ):
        a = as_float_array(nu, name)
        bad = ~((a > -1) & (a <= 0.5))
        if np.any(bad):
            v = a[bad].flat[0] if a.ndim else a[()]
            raise ValueError(f"`{name}` must lie in (-1, 0.5]; got {v!r}.")
        nus.append(a)
    compliance = (1 - nus[0] ** 2) / e1 + (1 - nus[1] ** 2) / e2
    if np.any(compliance <= 0):
        raise ValueError(
            "`youngs_modulus_1` and `youngs_modulus_2` cannot both be inf."
        )
    return np.asarray(1.0 / compliance)[()]


def geometric_mean_work_of_adhesion(surface_energy_1, surface_energy_2):
    r"""
    Work of adhesion from two surface energies, :math:`2\sqrt{\gamma_1\gamma_2}`.

    This is the Girifalco–Good (Berthelot) combining rule with interaction
    parameter 1; it is exact for two identical solids (:math:`w = 2\gamma`) and an
    approximation otherwise. Prefer a measured work of adhesion when one exists.

    Parameters
    ----------
    surface_energy_1, surface_energy_2 : array_like
        Surface energies of the two solids [J m⁻²], >= 0.

    Returns
    -------
    work_of_adhesion : ndarray
        Dupré work of adhesion [J m⁻²].
    """
    g1 = check_nonnegative(surface_energy_1, "surface_energy_1", allow_inf=False)
    g2 = check_nonnegative(surface_energy_2, "surface_energy_2", allow_inf=False)
    return np.asarray(2.0 * np.sqrt(g1 * g2))[()]


def thornton_ning_sticking_velocity(
    diameter, density, contact_modulus, work_of_adhesion
):
    r"""
    Critical sticking (capture) velocity of an elastic adhesive sphere on a flat.

    Implements Eq. 54 of Thornton & Ning [2]_ for a sphere striking a massive
    flat (:math:`R^* = R`, :math:`m^* = m = \tfrac{4}{3}\pi R^3\rho`):

    .. math:: v_s = 1.84\left(\frac{\Gamma^5}{\rho^3 E^{*2} R^5}\right)^{1/6}

    where :math:`\Gamma` is the work of adhesion of JKR theory [3]_, defined so
    that the JKR pull-off force is :math:`\tfrac{3}{2}\pi\Gamma R^*` ([2]_ Eq. 50),
    i.e. the Dupré energy :math:`\gamma_1+\gamma_2-\gamma_{12}` (:math:`2\gamma`
    for like solids), **not** the surface energy :math:`\gamma` of one solid.
    The constant is computed exactly, 1.84018..., from the energy lost between
    the JKR jump-in at zero approach and separation at the unstable point (see
    ``docs/adhesion.md``); [2]_ prints it as 1.84.

    Parameters
    ----------
    diameter : array_like
        Particle diameter [m]. Radius :math:`R = d/2`.
    density : array_like
        Particle density [kg m⁻³], > 0.
    contact_modulus : array_like
        Contact modulus :math:`E^*` [Pa], > 0 (see :func:`contact_modulus`).
    work_of_adhesion : array_like
        Dupré work of adhesion :math:`\Gamma` [J m⁻²], >= 0.

    Returns
    -------
    v_s : ndarray
        Sticking velocity [m s⁻¹]; impacts with normal speed below it are
        captured. ``nan`` where ``diameter <= 0`` or is ``nan``.

    References
    ----------
    .. [2] C. Thornton, Z. Ning, *Powder Technol.* 99:154-162, 1998.
    .. [3] K. L. Johnson, K. Kendall, A. D. Roberts, *Proc. R. Soc. Lond. A*
       324:301-313, 1971.
    """
    d = _diameter(diameter)
    rho = check_positive(density, "density")
    e_star = check_positive(contact_modulus, "contact_modulus")
    w = check_nonnegative(work_of_adhesion, "work_of_adhesion", allow_inf=False)
    radius = 0.5 * d
    v_s = THORNTON_NING_CONSTANT * (w**5 / (rho**3 * e_star**2 * radius**5)) ** (
        1.0 / 6.0
    )  # [2], Eq. 54
    return np.asarray(v_s)[()]


def _hertz(diameter, density, contact_modulus, normal_speed):
    """Validate the inputs once; radius [m] and maximum compression [m] as ndarrays."""
    d = _diameter(diameter)
    rho = check_positive(density, "density")
    e_star = check_positive(contact_modulus, "contact_modulus")
    v = np.abs(as_float_array(normal_speed, "normal_speed"))
    radius = 0.5 * d
    mass = rho * np.pi * d**3 / 6.0
    delta = (15.0 * mass * v**2 / (16.0 * e_star * np.sqrt(radius))) ** 0.4
    return radius, delta


def hertz_max_compression(diameter, density, contact_modulus, normal_speed):
    r"""
    Maximum compression (approach) of an elastic sphere striking a rigid-backed flat.

    .. math:: \delta_{max} = \left(\frac{15 m v^2}{16 E^* \sqrt{R}}\right)^{2/5}

    from the energy balance :math:`\tfrac12 m v^2 = \tfrac{8}{15}E^*\sqrt{R}\,
    \delta^{5/2}` of the Hertz force :math:`F = \tfrac43 E^*\sqrt{R}\,\delta^{3/2}`
    (Johnson 1985, §11.4).

    Parameters
    ----------
    diameter : array_like
        Particle diameter [m].
    density : array_like
        Particle density [kg m⁻³], > 0.
    contact_modulus : array_like
        Contact modulus :math:`E^*` [Pa], > 0.
    normal_speed : array_like
        Normal impact speed [m s⁻¹]; the sign is ignored.

    Returns
    -------
    delta_max : ndarray
        Maximum mutual approach [m]; ``nan`` where ``diameter <= 0`` or ``nan``.
    """
    _, delta = _hertz(diameter, density, contact_modulus, normal_speed)
    return np.asarray(delta)[()]


def hertz_contact_radius(diameter, density, contact_modulus, normal_speed):
    r"""
    Hertz contact radius at maximum compression, :math:`a = \sqrt{R\,\delta_{max}}`.

    This is the relation :math:`a^2 = r n` used in [1]_ to set the roughness
    averaging length (contact diameter :math:`2a`).

    Parameters
    ----------
    diameter, density, contact_modulus, normal_speed : array_like
        As for :func:`hertz_max_compression`.

    Returns
    -------
    a : ndarray
        Contact radius [m]; ``nan`` where ``diameter <= 0`` or ``nan``.
    """
    radius, delta = _hertz(diameter, density, contact_modulus, normal_speed)
    return np.asarray(np.sqrt(radius * delta))[()]  # [1], a^2 = r n


@dataclass(frozen=True)
class Material:
    """Elastic and surface properties of one solid (SI units).

    Attributes
    ----------
    name : str
    youngs_modulus : float
        [Pa]
    poisson_ratio : float
        [-]
    density : float
        [kg m⁻³]
    surface_energy : float or None
        Surface energy of the solid [J m⁻²] (not the work of adhesion), or
        ``None`` where no trustworthy value is known.
    source : str
        Where each number comes from.
    """

    name: str
    youngs_modulus: float
    poisson_ratio: float
    density: float
    surface_energy: float | None
    source: str


#: Material name -> elastic and surface properties (``docs/adhesion.md``).
MATERIALS: dict[str, Material] = {
    "stainless_steel_304": Material(
        "stainless_steel_304",
        youngs_modulus=193e9,  # ASM Handbook Vol. 1 / AK Steel 304 data bulletin
        poisson_ratio=0.29,  # ASM Handbook Vol. 1 (room temperature)
        density=8000.0,  # AK Steel 304/304L product data bulletin: 8.03 g/cm3
        surface_energy=None,  # no trustworthy value for oxidised steel in air
        source="E, nu, rho: ASM Handbook Vol. 1 and AK Steel 304/304L data bulletin "
        "(E = 193 GPa, rho = 7.9-8.0 g/cm^3).",
    ),
    "stainless_steel_316": Material(
        "stainless_steel_316",
        youngs_modulus=193e9,  # AK Steel 316/316L product data bulletin
        poisson_ratio=0.30,  # typical handbook value, ASM Handbook Vol. 1
        density=8000.0,  # AK Steel 316/316L product data bulletin: 7.99 g/cm3
        surface_energy=None,
        source="E, nu, rho: AK Steel 316/316L data bulletin and ASM Handbook Vol. 1.",
    ),
    "silicon": Material(
        "silicon",
        youngs_modulus=160e9,  # Hopcroft et al. 2010, isotropic (Hill) estimate
        poisson_ratio=0.22,  # Hopcroft et al. 2010, isotropic (Hill) estimate
        density=2329.0,  # CRC Handbook of Chemistry and Physics
        surface_energy=None,  # native-oxide surface in air: no reliable value
        source="E, nu: M. A. Hopcroft, W. D. Nix, T. W. Kenny, 'What is the Young's "
        "modulus of silicon?', J. MEMS 19:229-238 (2010), isotropic estimate; "
        "single-crystal E ranges 130-188 GPa with direction. rho: CRC Handbook.",
    ),
    "soda_lime_glass": Material(
        "soda_lime_glass",
        youngs_modulus=72e9,  # handbook range 70-74 GPa
        poisson_ratio=0.22,  # handbook range 0.22-0.23
        density=2500.0,  # handbook range 2.44-2.52 g/cm3
        surface_energy=None,
        source="Typical handbook values for soda-lime-silica glass (e.g. J. E. "
        "Shelby, Introduction to Glass Science and Technology, 2nd ed., 2005): "
        "E 70-74 GPa, nu 0.22-0.23, rho 2.44-2.52 g/cm^3.",
    ),
    "polystyrene": Material(
        "polystyrene",
        youngs_modulus=3.2e9,  # Polymer Handbook range 3.0-3.5 GPa
        poisson_ratio=0.34,  # Polymer Handbook (glassy PS)
        density=1050.0,  # Polymer Handbook: 1.04-1.065 g/cm3
        surface_energy=0.0407,  # S. Wu, Polymer Interface and Adhesion (1982), 20 C
        source="E, nu, rho: J. Brandrup et al., Polymer Handbook, 4th ed. (1999); "
        "surface energy 40.7 mJ/m^2 at 20 C: S. Wu, Polymer Interface and "
        "Adhesion (Dekker, 1982).",
    ),
    "formica": Material(
        "formica",
        youngs_modulus=9e9,  # approximate flexural modulus of HPL, ~9-10 GPa
        poisson_ratio=0.30,  # assumption: no sourced value
        density=1400.0,  # EN 438-2 requires >= 1350 kg/m3 for HPL
        surface_energy=None,
        source="APPROXIMATE. High-pressure decorative (melamine) laminate: density "
        ">= 1350 kg/m^3 per EN 438-2; modulus ~9-10 GPa is a typical manufacturer "
        "datasheet flexural value; Poisson ratio 0.30 is an assumption. The "
        "laminate is anisotropic and layered; treat these as order-of-magnitude.",
    ),
}

_ALIASES = {
    "stainless_steel": "stainless_steel_304",
    "ss304": "stainless_steel_304",
    "ss316": "stainless_steel_316",
    "glass": "soda_lime_glass",
    "melamine_laminate": "formica",
    "ps": "polystyrene",
}


def material(name: str) -> Material:
    """Look up a material of :data:`MATERIALS` by name (or alias, case-insensitive).

    Raises
    ------
    ValueError
        For an unknown name; the message lists the known names and the closest.
    """
    if not isinstance(name, str):
        raise TypeError(f"`name` must be a string; got {name!r}.")
    key = name.strip().lower().replace(" ", "_").replace("-", "_")
    key = _ALIASES.get(key, key)
    try:
        return MATERIALS[key]
    except KeyError:
        known = sorted(MATERIALS) + sorted(_ALIASES)
        raise ValueError(
            f"unknown material {name!r}; known: {', '.join(known)}"
            f"{did_you_mean(key, known)}."
        ) from None
