"""Slip correction, aerodynamic diameter and Hatch-Choate against textbook values
and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from microimpact.population.aerosol import (
    aerodynamic_diameter,
    cunningham_correction,
    hatch_choate_mass_median,
)

# Seinfeld & Pandis (2006) Table 9.3: slip correction of particles in air, 298 K, 1 atm
TABLE_9_3 = [
    (0.001, 216.0), (0.002, 108.0), (0.005, 43.6), (0.01, 22.2), (0.02, 11.4),
    (0.05, 4.95), (0.1, 2.85), (0.2, 1.865), (0.5, 1.326), (1.0, 1.164),
    (2.0, 1.082), (5.0, 1.032), (10.0, 1.016), (20.0, 1.008), (50.0, 1.003),
    (100.0, 1.0016),
]  # fmt: skip


@pytest.mark.parametrize(("d_um", "c"), TABLE_9_3)
def test_cunningham_matches_the_textbook_table(d_um, c):
    assert cunningham_correction(d_um * 1e-6) == pytest.approx(c, rel=0.006)


def test_aerodynamic_diameter_solves_its_equation():
    d = np.array([0.05, 0.3, 1.0, 3.0, 20.0]) * 1e-6
    rho, chi = 2650.0, 1.36
    da = aerodynamic_diameter(d, rho, shape_factor=chi)
    rhs = d * np.sqrt(
        rho * cunningham_correction(d) / (1000.0 * chi * cunningham_correction(da))
    )
    np.testing.assert_allclose(da, rhs, rtol=1e-10)


def test_aerodynamic_diameter_limits():
    # unit-density sphere: the aerodynamic diameter is itself
    assert aerodynamic_diameter(0.7e-6, 1000.0) == pytest.approx(0.7e-6, rel=1e-12)
    # large particles: slip is negligible, d_a = d sqrt(rho / (rho_0 chi))
    assert aerodynamic_diameter(100e-6, 2000.0, shape_factor=1.2) == pytest.approx(
        100e-6 * math.sqrt(2000 / 1200), rel=2e-3
    )
    # Hinds (1999) eq. 3.28 fixes d_a between its slip-free value and the Stokes
    # one with the full ratio of slip corrections
    d = 0.2e-6
    da = aerodynamic_diameter(d, 2000.0)
    assert d * math.sqrt(2.0) < da < d * math.sqrt(2.0 * cunningham_correction(d))


def test_hatch_choate_is_the_mass_median_of_a_lognormal():
    cmd, gsd = 2.0, 1.9
    dist = stats.lognorm(math.log(gsd), scale=cmd)
    mass = lambda x: x**3 * dist.pdf(x)  # noqa: E731
    total = integrate.quad(mass, 0, np.inf, limit=200)[0]
    mmd = hatch_choate_mass_median(cmd, gsd)
    below = integrate.quad(mass, 0, mmd, limit=200)[0]
    assert below / total == pytest.approx(0.5, abs=1e-6)


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_hatch_choate_of_a_diverging_gsd_is_inf_without_a_warning():
    """A diverged binned fit's GSD (flagged, never recommended) still gets a
    reported mass median: inf, not NumPy's overflow warning on the terminal."""
    assert hatch_choate_mass_median(3.0, 1e6) == pytest.approx(
        3.0 * math.exp(3 * math.log(1e6) ** 2)
    )
    assert hatch_choate_mass_median(3.0, 1e9) == math.inf  # exp(1289): beyond floats
    assert hatch_choate_mass_median(3.0, 1.69) == pytest.approx(
        3.0 * math.exp(3 * math.log(1.69) ** 2), rel=1e-14
    )
