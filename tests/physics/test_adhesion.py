"""Tests for microimpact.physics.adhesion against independent oracles.

Oracles: the JKR relations of Johnson, Kendall & Roberts (1971) integrated
numerically (scipy quad/brentq), the constants printed by Thornton & Ning (1998),
Powder Technol. 99:154-162 (Eqs. 49, 50, 52, 54), and a numerical integration of
the Hertz equation of motion.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq, minimize_scalar

from microimpact.physics import adhesion
from microimpact.physics.adhesion import (
    MATERIALS,
    contact_modulus,
    geometric_mean_work_of_adhesion,
    hertz_contact_radius,
    hertz_max_compression,
    material,
    thornton_ning_sticking_velocity,
)

# A stainless-steel-like sphere on a silicon-like flat (values only need to be
# physical; the oracles below are independent of them).
RHO, E_STAR, W = 8000.0, 9.35e10, 0.4


def _jkr(w, r, e_star):
    """JKR force P(a) and approach delta(a) (Johnson 1985, Eqs. 5.62-5.63), with w
    the Dupré work of adhesion."""

    def force(a):
        return 4 * e_star * a**3 / (3 * r) - np.sqrt(8 * np.pi * w * e_star * a**3)

    def approach(a):
        return a**2 / r - np.sqrt(2 * np.pi * w * a / e_star)

    def d_approach(a):
        return 2 * a / r - 0.5 * np.sqrt(2 * np.pi * w / (e_star * a))

    return force, approach, d_approach


def _separation_work(w, r, e_star):
    """Work to separate, from the jump-in at delta = 0 to the unstable point
    d(delta)/da = 0 on the unloading JKR curve, by quadrature."""
    force, approach, d_approach = _jkr(w, r, e_star)
    scale = (np.pi * w * r**2 / e_star) ** (1 / 3)
    a_f = brentq(d_approach, 0.05 * scale, 2 * scale, xtol=1e-14 * scale)
    a_0 = brentq(approach, 1.01 * a_f, 5 * scale, xtol=1e-14 * scale)
    work, _ = quad(
        lambda a: -force(a) * d_approach(a), a_f, a_0, epsabs=0, epsrel=1e-12
    )
    return work, a_f, a_0


@pytest.mark.parametrize("diameter", [5e-6, 50e-6, 200e-6])
def test_sticking_velocity_matches_jkr_energy_balance(diameter):
    r = diameter / 2
    work, _, _ = _separation_work(W, r, E_STAR)
    mass = 4 / 3 * np.pi * r**3 * RHO
    expected = np.sqrt(2 * work / mass)  # 1/2 m v_s^2 = W_s
    got = thornton_ning_sticking_velocity(diameter, RHO, E_STAR, W)
    assert_allclose(got, expected, rtol=1e-9)


def test_thornton_ning_printed_constants():
    # [TN98] Eq. 52: W_s = 7.09 (Gamma^5 R^4 / E*^2)^(1/3); Eq. 54 with
    # m = 4/3 pi R^3 rho gives v_s = 1.84 (...)^(1/6). Printed to 3 figures.
    r = 25e-6
    work, _, _ = _separation_work(W, r, E_STAR)
    assert_allclose(work / (W**5 * r**4 / E_STAR**2) ** (1 / 3), 7.09, atol=0.005)
    assert_allclose(adhesion.JKR_SEPARATION_WORK_CONSTANT, 7.09, atol=0.005)
    assert_allclose(adhesion.THORNTON_NING_CONSTANT, 1.84, atol=0.005)
    # the published formula, evaluated literally
    published = 1.84 * (W**5 / (RHO**3 * E_STAR**2 * r**5)) ** (1 / 6)
    assert_allclose(
        thornton_ning_sticking_velocity(2 * r, RHO, E_STAR, W), published, rtol=3e-3
    )
    # Eq. 54 in its m* form: v_s = (14.18 / m)^(1/2) (Gamma^5 R^4 / E*^2)^(1/6)
    m = 4 / 3 * np.pi * r**3 * RHO
    eq54 = math.sqrt(14.18 / m) * (W**5 * r**4 / E_STAR**2) ** (1 / 6)
    assert_allclose(
        thornton_ning_sticking_velocity(2 * r, RHO, E_STAR, W), eq54, rtol=3e-3
    )


def test_gamma_is_work_of_adhesion_with_pull_off_three_halves_pi_gamma_r():
    # [TN98] Eq. 50: pull-off force (load control) P_c = 3/2 pi Gamma R*, and
    # Eq. 49: separation approach alpha_f = 3/4 (pi^2 Gamma^2 R* / E*^2)^(1/3).
    # With the JKR relations written with the Dupré w, both hold for Gamma = w,
    # so Gamma is the work of adhesion (2 gamma for like solids), not gamma.
    r = 25e-6
    force, approach, _ = _jkr(W, r, E_STAR)
    scale = (np.pi * W * r**2 / E_STAR) ** (1 / 3)
    res = minimize_scalar(
        force,
        bounds=(0.01 * scale, 3 * scale),
        method="bounded",
        options={"xatol": 1e-12 * scale},
    )
    assert_allclose(-res.fun, 1.5 * np.pi * W * r, rtol=1e-8)
    _, a_f, _ = _separation_work(W, r, E_STAR)
    alpha_f = 0.75 * (np.pi**2 * W**2 * r / E_STAR**2) ** (1 / 3)
    assert_allclose(-approach(a_f), alpha_f, rtol=1e-9)


def test_sticking_velocity_scaling_laws():
    d = np.array([10e-6, 20e-6])
    v = thornton_ning_sticking_velocity(d, RHO, E_STAR, W)
    assert_allclose(v[1] / v[0], 2 ** (-5 / 6), rtol=1e-12)
    v2 = thornton_ning_sticking_velocity(10e-6, 2 * RHO, 2 * E_STAR, 2 * W)
    assert_allclose(v2 / v[0], 2 ** ((5 - 3 - 2) / 6), rtol=1e-12)


def test_sticking_velocity_input_matrix():
    v = thornton_ning_sticking_velocity(50e-6, RHO, E_STAR, W)
    assert np.ndim(v) == 0
    out = thornton_ning_sticking_velocity([[50e-6], [-1.0]], RHO, E_STAR, [W, 0.0])
    assert out.shape == (2, 2)
    assert_allclose(out[0], [v, 0.0], rtol=1e-12)
    assert np.all(np.isnan(out[1]))
    assert np.isnan(thornton_ning_sticking_velocity(np.nan, RHO, E_STAR, W))
    assert np.isnan(thornton_ning_sticking_velocity(0.0, RHO, E_STAR, W))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"density": 0.0}, "`density`"),
        ({"contact_modulus": -1.0}, "`contact_modulus`"),
        ({"work_of_adhesion": -0.1}, "`work_of_adhesion`"),
        ({"work_of_adhesion": np.nan}, "`work_of_adhesion`"),
    ],
)
def test_sticking_velocity_rejects_bad_parameters(kwargs, match):
    args = {"density": RHO, "contact_modulus": E_STAR, "work_of_adhesion": W} | kwargs
    with pytest.raises(ValueError, match=match):
        thornton_ning_sticking_velocity(50e-6, **args)


def test_sticking_velocity_error_shows_the_bad_element():
    for bad, shown in ((-0.2, r"-0\.2"), (np.inf, "inf")):
        with pytest.raises(
            ValueError, match=rf"`work_of_adhesion`.*got .*{shown}"
        ) as ei:
            thornton_ning_sticking_velocity(50e-6, RHO, E_STAR, [W, bad, W])
        assert "array" not in str(ei.value)


def test_contact_modulus_closed_forms():
    e, nu = 200e9, 0.3
    assert_allclose(contact_modulus(e, nu, e, nu), e / (2 * (1 - nu**2)), rtol=1e-14)
    assert_allclose(contact_modulus(e, nu, np.inf, 0.2), e / (1 - nu**2), rtol=1e-14)
    ss, si = material("stainless_steel_304"), material("silicon")
    expected = 1 / ((1 - 0.29**2) / 193e9 + (1 - 0.22**2) / 160e9)
    got = contact_modulus(
        ss.youngs_modulus, ss.poisson_ratio, si.youngs_modulus, si.poisson_ratio
    )
    assert_allclose(got, expected, rtol=1e-12)
    with pytest.raises(ValueError, match="`poisson_ratio_2`"):
        contact_modulus(e, nu, e, 0.6)
    with pytest.raises(ValueError, match="`youngs_modulus_1`"):
        contact_modulus(0.0, nu, e, nu)


def test_geometric_mean_work_of_adhesion():
    assert_allclose(geometric_mean_work_of_adhesion(0.04, 0.04), 0.08, rtol=1e-14)
    assert_allclose(geometric_mean_work_of_adhesion(0.01, 0.04), 0.04, rtol=1e-14)
    with pytest.raises(ValueError, match=r"`surface_energy_2`.*got .*-1\.0"):
        geometric_mean_work_of_adhesion(0.04, -1.0)
    # the message shows the bad element of an array, not the whole array
    for bad in (np.inf, np.nan):
        with pytest.raises(ValueError, match=rf"`surface_energy_1`.*got .*{bad}") as ei:
            geometric_mean_work_of_adhesion([0.04, bad, 0.03], 0.04)
        assert "0.04" not in str(ei.value) and "array" not in str(ei.value)


@pytest.mark.parametrize("speed", [0.05, 1.0, -3.0])
def test_hertz_compression_matches_equation_of_motion(speed):
    d, rho, e_star = 50e-6, RHO, E_STAR
    r, m = d / 2, rho * np.pi * d**3 / 6
    k = 4 / 3 * e_star * np.sqrt(r)

    def rhs(_, y):
        return [y[1], -k * max(y[0], 0.0) ** 1.5 / m]

    def turning(_, y):
        return y[1]

    turning.terminal = True
    turning.direction = -1
    x_guess = (m * speed**2 / k) ** 0.4
    t_end = 20 * x_guess / abs(speed)
    sol = solve_ivp(
        rhs,
        (0, t_end),
        [0.0, abs(speed)],
        events=turning,
        rtol=1e-11,
        atol=1e-14 * x_guess,
        max_step=t_end / 200,
    )
    x_max = sol.y_events[0][0][0]
    assert_allclose(hertz_max_compression(d, rho, e_star, speed), x_max, rtol=1e-6)
    assert_allclose(
        hertz_contact_radius(d, rho, e_star, speed), np.sqrt(r * x_max), rtol=1e-6
    )


def test_hertz_contact_radius_order_of_magnitude_in_paper():
    # [Li 2000]: the contact diameter of an SST76 microsphere (~70 um) on the
    # surface was estimated as about 20 um. Hertz gives a few um at ~1 m/s
    # on a stiff flat; only check the scaling a ~ (R delta)^(1/2) ~ v^(2/5).
    a1 = hertz_contact_radius(70e-6, RHO, E_STAR, 1.0)
    a2 = hertz_contact_radius(70e-6, RHO, E_STAR, 2.0)
    assert_allclose(a2 / a1, 2**0.4, rtol=1e-12)
    assert np.isnan(hertz_contact_radius(-1.0, RHO, E_STAR, 1.0))


def test_material_lookup():
    assert material("Stainless Steel") is MATERIALS["stainless_steel_304"]
    assert material("glass") is MATERIALS["soda_lime_glass"]
    with pytest.raises(ValueError, match=r"(?i)did you mean .silicon."):
        material("silicone")
    for m in MATERIALS.values():
        assert m.youngs_modulus > 0 and m.density > 0 and -1 < m.poisson_ratio <= 0.5
        assert m.source
