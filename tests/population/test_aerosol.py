"""Slip correction, aerodynamic diameter and Hatch-Choate against textbook values
and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from microimpact.population.aerosol import (
    aerodynamic_diameter,
    count_median_diameter,
    cunningham_correction,
    hatch_choate_mass_median,
    volume_equivalent_diameter,
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


# -- [particles] conventions: count median, mass median, MMAD (issue 30) ---------------
def _slip(d):
    """Seinfeld & Pandis eq. 9.34, written out here: the test's own slip factor."""
    kn = 2 * 0.0651e-6 / d
    return 1 + kn * (1.257 + 0.4 * math.exp(-1.1 / kn))


def _cmd_closed_form(mmad, gsd, rho, chi):
    """The closed form the scenario must reproduce: Hinds eq. 3.28 solved for the
    volume-equivalent mass median by plain fixed-point iteration, then
    Hatch-Choate CMD = MMD exp(-3 ln² σ_g)."""
    d_v = mmad * math.sqrt(1000 * chi / rho)
    for _ in range(200):
        d_v = mmad * math.sqrt(1000 * chi * _slip(mmad) / (rho * _slip(d_v)))
    return d_v * math.exp(-3 * math.log(gsd) ** 2)


def _scenario_particles(**particles):
    from microimpact.scenario.scenario import scenario_from_dict

    data = {
        "particles": {"distribution": "lognormal", **particles},
        "coefficients": {"k1": 4.0, "k2": 0.05, "v_c": 0.2},
        "sweep": {"speed_m_s": [1.0]},
    }
    return scenario_from_dict(data).particles


@pytest.mark.parametrize(
    ("mmad_um", "gsd", "rho", "chi"),
    [(3.0, 2.0, 1000.0, 1.0), (3.0, 1.6, 1500.0, 1.0), (0.8, 1.8, 2650.0, 1.36)],
)
def test_an_mmad_gives_the_count_median_of_hatch_choate_and_cunningham(
    mmad_um, gsd, rho, chi
):
    want = _cmd_closed_form(mmad_um * 1e-6, gsd, rho, chi)
    got = count_median_diameter(
        mmad_um * 1e-6, gsd, convention="mmad", density_kg_m3=rho, shape_factor=chi
    )
    assert got == pytest.approx(want, rel=0.005)
    # through [particles]: the population the engine samples
    p = _scenario_particles(
        mmad_um=mmad_um, geometric_std=gsd, density_kg_m3=rho, shape_factor=chi
    )
    assert p.params["median_um"] * 1e-6 == pytest.approx(want, rel=0.005)
    # and its mass median is, by quadrature, the particle whose aerodynamic
    # diameter is the MMAD
    dist = stats.lognorm(math.log(gsd), scale=p.params["median_um"])
    mass = lambda x: x**3 * dist.pdf(x)  # noqa: E731
    total = integrate.quad(mass, 0, np.inf, limit=200)[0]
    mmd = dist.ppf(0.5) * math.exp(3 * math.log(gsd) ** 2)
    assert integrate.quad(mass, 0, mmd, limit=200)[0] / total == pytest.approx(0.5)
    assert aerodynamic_diameter(mmd * 1e-6, rho, shape_factor=chi) == pytest.approx(
        mmad_um * 1e-6, rel=0.005
    )


def test_mmad_3_um_is_not_a_count_median_of_3_um():
    # the issue: "MMAD 3 µm" (GSD 1.8) typed as median_um = 3 simulates a mass
    # median near 8.5 µm; given as mmad_um it is a count median near 1.06 µm
    p = _scenario_particles(mmad_um=3.0, geometric_std=1.8, density_kg_m3=1000.0)
    want = _cmd_closed_form(3e-6, 1.8, 1000.0, 1.0)
    assert p.params["median_um"] * 1e-6 == pytest.approx(want, rel=0.005)
    assert p.params["median_um"] == pytest.approx(1.064, rel=0.005)
    wrong = _scenario_particles(median_um=3.0, geometric_std=1.8)
    assert hatch_choate_mass_median(wrong.params["median_um"], 1.8) == pytest.approx(
        8.46, rel=0.005
    )


def test_a_mass_median_is_hatch_choate_inverted():
    p = _scenario_particles(mass_median_um=8.0, geometric_std=1.7)
    assert hatch_choate_mass_median(p.params["median_um"], 1.7) == pytest.approx(8.0)


@pytest.mark.parametrize(
    ("particles", "match"),
    [
        ({"mmad_um": 3.0, "geometric_std": 2.0}, r"density_kg_m3: missing"),
        (
            {"median_um": 3.0, "geometric_std": 2.0, "density_kg_m3": 1000.0},
            r"density_kg_m3: only allowed with 'mmad_um'",
        ),
        (
            {"median_um": 3.0, "mmad_um": 3.0, "geometric_std": 2.0},
            r"exactly one of 'median_um' or 'mass_median_um' or 'mmad_um'; got both",
        ),
        ({"geometric_std": 2.0}, r"exactly one of 'median_um'"),
    ],
)
def test_particles_conventions_refuse_what_does_not_fit(particles, match):
    from microimpact.errors import ScenarioError

    with pytest.raises(ScenarioError, match=match) as info:
        _scenario_particles(**particles)
    assert "np.float64" not in str(info.value)


def test_volume_equivalent_diameter_inverts_the_aerodynamic_one():
    for d in (0.05e-6, 0.5e-6, 5e-6, 50e-6):
        d_a = aerodynamic_diameter(d, 2200.0, shape_factor=1.2)
        back = volume_equivalent_diameter(d_a, 2200.0, shape_factor=1.2)
        assert back == pytest.approx(d, rel=1e-9)


def test_the_scenario_names_all_three_medians():
    # the scenario's own summary (what reports print) shows the count median
    # sampled, the mass median and the MMAD with its density
    from microimpact.scenario.scenario import scenario_from_dict

    data = {
        "particles": {
            "distribution": "lognormal",
            "mmad_um": 3.0,
            "geometric_std": 1.8,
            "density_kg_m3": 1500.0,
        },
        "coefficients": {"k1": 4.0, "k2": 0.05, "v_c": 0.2},
        "sweep": {"speed_m_s": [1.0]},
    }
    sc = scenario_from_dict(data)
    params = sc.describe()["particles"]["params"]
    cmd, mmd = params["median_um"], params["mass_median_um"]
    assert mmd == pytest.approx(cmd * math.exp(3 * math.log(1.8) ** 2), rel=1e-12)
    assert aerodynamic_diameter(mmd * 1e-6, 1500.0) == pytest.approx(3e-6, rel=1e-9)
    assert params["mmad_um"] == 3.0 and params["density_kg_m3"] == 1500.0
    text = repr(sc)
    assert "median_um=" in text and "mass_median_um=" in text and "mmad_um=3" in text


@pytest.mark.parametrize("bad", [-1e-6, 0.0])
def test_a_diameter_that_is_not_positive_is_refused_by_name(bad):
    from microimpact.population.aerosol import volume_equivalent_diameter

    with pytest.raises(ValueError, match="aerodynamic_m"):
        volume_equivalent_diameter(bad, 1000.0)


def test_a_geometric_std_below_1_is_refused_by_name():
    from microimpact.population.aerosol import count_median_diameter

    with pytest.raises(ValueError, match=r"^`geometric_std` must be a number >= 1"):
        count_median_diameter(3e-6, 0.5)


def test_the_aerodynamic_iteration_says_when_it_stops_short():
    # the documented RuntimeError when max_iter is reached: one step cannot meet
    # a tolerance of 1e-15 for a 0.1 um particle (slip correction about 2.9)
    with pytest.raises(
        RuntimeError, match=r"^the aerodynamic diameter iteration did not converge\.$"
    ):
        aerodynamic_diameter(1e-7, 2000.0, rtol=1e-15, max_iter=1)


def test_a_count_median_from_an_mmad_uses_the_mean_free_path_given():
    # at 0.5 atm the mean free path doubles: the MMAD's volume-equivalent
    # diameter d then solves d_a^2 Cc(d_a) = d^2 (rho / rho_0) Cc(d) with that
    # path (Hinds eq. 3.28), and CMD = d exp(-3 ln^2 sigma) (Hatch-Choate)
    mmad, gsd, rho, lam = 1e-6, 1.8, 2000.0, 2 * 65.1e-9
    cmd = count_median_diameter(
        mmad, gsd, convention="mmad", density_kg_m3=rho, mean_free_path_m=lam
    )
    d = cmd * math.exp(3 * math.log(gsd) ** 2)
    lhs = mmad**2 * cunningham_correction(mmad, mean_free_path_m=lam)
    rhs = d**2 * rho / 1000.0 * cunningham_correction(d, mean_free_path_m=lam)
    assert rhs == pytest.approx(lhs, rel=1e-6)
    # and not the sea-level answer
    assert cmd != pytest.approx(
        count_median_diameter(mmad, gsd, convention="mmad", density_kg_m3=rho),
        rel=1e-3,
    )


def test_a_diameter_that_is_not_positive_is_named():
    with pytest.raises(ValueError, match=r"^`diameter_m` must be finite and > 0; got"):
        cunningham_correction(-1e-6)
