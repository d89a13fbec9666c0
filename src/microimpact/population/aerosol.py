"""Aerosol size conventions: slip correction, aerodynamic diameter, Hatch-Choate.

Pure functions in SI units (diameters in metres, densities in kg/m³).

* :func:`cunningham_correction` -- the slip correction factor of Seinfeld & Pandis
  [1]_ eq. 9.34, ``C = 1 + Kn [1.257 + 0.4 exp(-1.1/Kn)]`` with ``Kn = 2 λ / d``
  and the mean free path of air ``λ = 0.0651 µm`` (298 K, 1 atm), which reproduces
  their Table 9.3 (1.164 at 1 µm, 2.85 at 0.1 µm).
* :func:`aerodynamic_diameter` -- the diameter of the unit-density
  (``ρ_0 = 1000 kg/m³``) sphere settling at the same speed ([2]_ eq. 3.28,
  [1]_ eq. 9.45)::

      d_a = d_v sqrt(ρ_p C(d_v) / (ρ_0 χ C(d_a)))

  with the volume-equivalent diameter ``d_v``, the particle density ``ρ_p`` and the
  dynamic shape factor ``χ`` (1 for spheres); ``C(d_a)`` makes it implicit, solved
  by fixed-point iteration (a contraction: ``C`` varies slowly).
* :func:`hatch_choate_mass_median` -- the mass median diameter of a log-normal
  number distribution, ``MMD = CMD exp(3 ln² σ_g)`` ([2]_ eq. 4.39).
* :func:`volume_equivalent_diameter` -- the inverse of
  :func:`aerodynamic_diameter` (the particle whose aerodynamic diameter is given).
* :func:`count_median_diameter` -- the count median of a log-normal population
  given by its count median, its mass median (MMD) or its mass median aerodynamic
  diameter (MMAD, with a density and a shape factor), and its GSD: the
  conventions of ``[particles]``.

No maintained, light Python package was found that does these conversions (the
aerosol packages on PyPI are instrument readers or optics codes), so the closed
forms are implemented here and tested against the textbook table.

References
----------
.. [1] J. H. Seinfeld and S. N. Pandis, *Atmospheric Chemistry and Physics*, 2nd
   ed., Wiley, 2006, eqs. 9.34 and 9.45, Table 9.3.
.. [2] W. C. Hinds, *Aerosol Technology*, 2nd ed., Wiley, 1999, eqs. 3.28, 4.39.
"""

from __future__ import annotations

import math

import numpy as np

from .._core.validation import as_float_array, check_scalar

#: ln of the largest float: a mass median beyond it is inf.
_LOG_MAX = math.log(np.finfo(float).max)

__all__ = [
    "MEAN_FREE_PATH_AIR_M",
    "MEDIAN_CONVENTIONS",
    "UNIT_DENSITY_KG_M3",
    "aerodynamic_diameter",
    "count_median_diameter",
    "cunningham_correction",
    "hatch_choate_mass_median",
    "volume_equivalent_diameter",
]

#: The medians a log-normal population may be given by.
MEDIAN_CONVENTIONS = ("count", "mass", "mmad")

#: Mean free path of air at 298 K and 1 atm [m] ([1]_ p. 399).
MEAN_FREE_PATH_AIR_M = 0.0651e-6
#: The reference density of the aerodynamic diameter [kg/m³].
UNIT_DENSITY_KG_M3 = 1000.0
_A, _B, _C = 1.257, 0.4, 1.1  # [1] eq. 9.34


def cunningham_correction(diameter_m, *, mean_free_path_m=MEAN_FREE_PATH_AIR_M):
    """Cunningham slip correction factor ([1]_ eq. 9.34).

    Parameters
    ----------
    diameter_m : float or array_like
        Particle diameter [m], > 0.
    mean_free_path_m : float
        Mean free path of the gas [m] (default: air at 298 K, 1 atm).

    Returns
    -------
    float or ndarray
        ``1 + Kn [1.257 + 0.4 exp(-1.1/Kn)]``, ``Kn = 2 λ / d``; >= 1.
    """
    d = as_float_array(diameter_m, "diameter_m")
    if not np.all(np.isfinite(d) & (d > 0)):
        raise ValueError(f"`diameter_m` must be finite and > 0; got {diameter_m!r}.")
    lam = check_scalar(mean_free_path_m, "mean_free_path_m", minimum=0, strict=True)
    kn = 2.0 * lam / d
    c = 1.0 + kn * (_A + _B * np.exp(-_C / kn))
    return float(c) if c.ndim == 0 else c


def aerodynamic_diameter(
    diameter_m,
    density_kg_m3,
    *,
    shape_factor=1.0,
    mean_free_path_m=MEAN_FREE_PATH_AIR_M,
    rtol=1e-12,
    max_iter=200,
):
    """Aerodynamic diameter of particles of volume-equivalent diameter `diameter_m`.

    Solves ``d_a = d_v sqrt(ρ_p C(d_v) / (ρ_0 χ C(d_a)))`` ([2]_ eq. 3.28) by
    fixed-point iteration from the slip-free value ``d_v sqrt(ρ_p / (ρ_0 χ))``.

    Parameters
    ----------
    diameter_m : float or array_like
        Volume-equivalent diameter [m], > 0.
    density_kg_m3 : float
        Particle density [kg/m³], > 0.
    shape_factor : float
        Dynamic shape factor χ, >= 1 for non-spheres (1: a sphere).
    mean_free_path_m : float
        Mean free path of the gas [m].
    rtol : float
        Relative change at which the iteration stops.
    max_iter : int
        Iteration limit (``RuntimeError`` when reached: never in practice).

    Returns
    -------
    float or ndarray
        Aerodynamic diameter [m].
    """
    d = as_float_array(diameter_m, "diameter_m")
    rho = check_scalar(density_kg_m3, "density_kg_m3", minimum=0, strict=True)
    chi = check_scalar(shape_factor, "shape_factor", minimum=0, strict=True)
    lam = mean_free_path_m
    c_v = np.asarray(cunningham_correction(d, mean_free_path_m=lam))
    ratio = rho / (UNIT_DENSITY_KG_M3 * chi)
    d_a = d * np.sqrt(ratio)
    for _ in range(max_iter):
        new = d * np.sqrt(
            ratio * c_v / cunningham_correction(d_a, mean_free_path_m=lam)
        )
        done = np.all(np.abs(new - d_a) <= rtol * new)
        d_a = new
        if done:
            return float(d_a) if d_a.ndim == 0 else d_a
    raise RuntimeError("the aerodynamic diameter iteration did not converge.")


def hatch_choate_mass_median(count_median, geometric_std):
    """Mass median diameter of a log-normal number distribution ([2]_ eq. 4.39).

    Parameters
    ----------
    count_median : float
        Count median diameter (any length unit; the result has the same unit).
    geometric_std : float
        Geometric standard deviation σ_g, >= 1.

    Returns
    -------
    float
        ``count_median * exp(3 ln² σ_g)``; ``inf`` where that exceeds the largest
        float (a diverging fit's σ_g), without a NumPy overflow warning.
    """
    cmd = check_scalar(count_median, "count_median", minimum=0, strict=True)
    gsd = check_scalar(geometric_std, "geometric_std", minimum=1)
    log_mmd = math.log(cmd) + 3.0 * math.log(gsd) ** 2
    return math.exp(log_mmd) if log_mmd < _LOG_MAX else math.inf


def volume_equivalent_diameter(
    aerodynamic_m,
    density_kg_m3,
    *,
    shape_factor=1.0,
    mean_free_path_m=MEAN_FREE_PATH_AIR_M,
):
    """Volume-equivalent diameter of a particle of aerodynamic diameter
    `aerodynamic_m`: the inverse of :func:`aerodynamic_diameter` (eq. 3.28 of
    [2]_ solved for ``d_v``).

    ``d_a`` grows monotonically with ``d_v``, so the root is found by Brent's
    method (:func:`scipy.optimize.brentq`) on ``ln d_v`` to a relative 1e-13.

    Parameters
    ----------
    aerodynamic_m : float
        Aerodynamic diameter [m], > 0.
    density_kg_m3 : float
        Particle density [kg/m³], > 0.
    shape_factor : float
        Dynamic shape factor χ (1: a sphere).
    mean_free_path_m : float
        Mean free path of the gas [m].

    Returns
    -------
    float
        Volume-equivalent diameter [m].
    """
    # deferred: scipy is heavy and only this conversion needs it
    from scipy.optimize import brentq

    d_a = check_scalar(aerodynamic_m, "aerodynamic_m", minimum=0, strict=True)
    rho = check_scalar(density_kg_m3, "density_kg_m3", minimum=0, strict=True)
    chi = check_scalar(shape_factor, "shape_factor", minimum=0, strict=True)

    def gap(log_d):
        return math.log(
            aerodynamic_diameter(
                math.exp(log_d),
                rho,
                shape_factor=chi,
                mean_free_path_m=mean_free_path_m,
            )
        ) - math.log(d_a)

    # slip-free guess d_a sqrt(χ ρ_0 / ρ), bracketed by a factor of 100 each way
    guess = math.log(d_a) + 0.5 * math.log(chi * UNIT_DENSITY_KG_M3 / rho)
    return math.exp(
        brentq(gap, guess - math.log(100), guess + math.log(100), xtol=1e-13)
    )


def count_median_diameter(
    median_m,
    geometric_std,
    *,
    convention="count",
    density_kg_m3=None,
    shape_factor=1.0,
    mean_free_path_m=MEAN_FREE_PATH_AIR_M,
):
    """Count median diameter [m] of a log-normal population given by one of its
    medians and its GSD.

    Parameters
    ----------
    median_m : float
        The median [m]: the count median (``convention='count'``), the mass
        median of the volume-equivalent diameters (``'mass'``), or the mass median
        aerodynamic diameter (``'mmad'``).
    geometric_std : float
        GSD σ_g of the population, >= 1 (the same for the count and the mass
        distributions of a log-normal).
    convention : {'count', 'mass', 'mmad'}
    density_kg_m3 : float, optional
        Particle density [kg/m³]; required for ``'mmad'``, refused otherwise.
    shape_factor : float
        Dynamic shape factor χ of ``'mmad'`` (1: spheres).
    mean_free_path_m : float
        Mean free path of the gas [m].

    Returns
    -------
    float
        ``CMD = MMD exp(-3 ln² σ_g)`` (Hatch-Choate, [2]_ eq. 4.39), with
        ``MMD = volume_equivalent_diameter(MMAD)`` (Hinds eq. 3.28 with the
        Cunningham correction) for an MMAD.

    Notes
    -----
    The aerodynamic mass median is the image of the volume-equivalent mass
    median (``d_a(d_v)`` is monotone, so medians map to medians). The GSD is
    taken as the volume-equivalent distribution's: exact without slip; with slip
    ``d_a`` is not proportional to ``d_v`` and the aerodynamic distribution is a
    little narrower (GSD 2, 2000 kg/m³: 1.5 % at a count median of 1 µm, 0.7 % at
    3 µm).
    """
    d = check_scalar(median_m, "median_m", minimum=0, strict=True)
    gsd = check_scalar(geometric_std, "geometric_std", minimum=1)
    if convention not in MEDIAN_CONVENTIONS:
        raise ValueError(
            f"`convention` must be one of {', '.join(MEDIAN_CONVENTIONS)}; got "
            f"{convention!r}."
        )
    if convention == "mmad":
        if density_kg_m3 is None:
            raise ValueError("an MMAD needs the particle density `density_kg_m3`.")
        d = volume_equivalent_diameter(
            d,
            density_kg_m3,
            shape_factor=shape_factor,
            mean_free_path_m=mean_free_path_m,
        )
    elif density_kg_m3 is not None:
        raise ValueError(
            "`density_kg_m3` applies to an MMAD only (a count or mass median is "
            "already a volume-equivalent diameter)."
        )
    if convention == "count":
        return d
    return d * math.exp(-3.0 * math.log(gsd) ** 2)  # [2] eq. 4.39 inverted
