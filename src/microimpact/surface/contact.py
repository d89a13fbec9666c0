"""Hertzian contact size of an elastic sphere impact: the roughness length scale.

The paper [1]_ measures the roughness angle over the particle's contact diameter,
estimated from Hertzian contact mechanics with :math:`a^2 = r\\,n`, where ``n`` is
the (maximum) approach of the mass centre, ``r`` the undeformed radius and ``a`` the
contact radius. For an elastic sphere of mass ``m`` hitting a half-space at normal
speed ``v`` the maximum approach is [2]_

.. math::

    \\delta_{max} = \\left(\\frac{15\\, m\\, v^2}{16\\, E^* \\sqrt{r}}\\right)^{2/5},

from the energy balance of the Hertz equation of motion
:math:`m \\ddot x = -\\tfrac{4}{3} E^* \\sqrt{r}\\, x^{3/2}`.

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, *Aerosol Sci. Technol.* 33:376-386, 2000.
.. [2] K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, §11.4.
"""

from __future__ import annotations

from ..physics.adhesion import hertz_contact_radius, hertz_max_compression

__all__ = ["hertz_contact_diameter", "hertz_max_compression"]


def hertz_contact_diameter(diameter, density, contact_modulus, normal_speed):
    r"""
    Hertzian contact diameter ``2a`` at maximum compression of an elastic impact.

    Implements :math:`a^2 = r\,\delta_{max}` of [1]_ with
    :math:`\delta_{max} = (15 m v^2 / (16 E^* \sqrt{r}))^{2/5}` and
    :math:`m = \rho \pi d^3 / 6`. This is the horizontal length scale over which
    the roughness angle is measured (the paper's 20 µm for SST76 spheres).

    Parameters
    ----------
    diameter : array_like
        Particle diameter [m].
    density : array_like
        Particle density [kg m⁻³].
    contact_modulus : array_like
        Contact modulus :math:`E^*` [Pa].
    normal_speed : array_like
        Normal impact speed [m s⁻¹].

    Returns
    -------
    contact_diameter : ndarray
        :math:`2a` [m]; ``nan`` where ``diameter <= 0``, 0 for zero speed.

    Raises
    ------
    ValueError
        If `density` or `contact_modulus` is not > 0.

    Examples
    --------
    >>> from microimpact.surface.contact import hertz_contact_diameter
    >>> round(float(hertz_contact_diameter(70e-6, 7900.0, 10e9, 1.0)) * 1e6, 2)
    5.54
    """
    # [1]: a^2 = r n, computed once in microimpact.physics.adhesion; that returns a
    # float64 scalar or an ndarray (never 0-d), and so does 2.0 * it
    return 2.0 * hertz_contact_radius(diameter, density, contact_modulus, normal_speed)
