"""Executable restatements of the rules in ``docs/conventions.md``.

Each test names the rule of the document it checks. The numbers come from geometry
(closed forms), not from the code under test.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import microimpact as mi

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[2]
ELASTIC = {"k1": math.inf, "k2": 0.0, "v_c": 0.0}  # e = 1
SOFT = {"k1": 2.0, "k2": 0.05, "v_c": 0.1}


def test_figure_script_writes_png(tmp_path):
    spec = importlib.util.spec_from_file_location(
        "conventions_figure", ROOT / "docs" / "figures" / "conventions.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    path = module.main(tmp_path)
    assert path == tmp_path / "conventions.png"
    assert path.stat().st_size > 10_000
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["conventions.png"]  # atomic


# Rule 1: n points out of the surface; approaching v_n < 0, rebounding V_n > 0.
def test_rule_outward_normal():
    r = mi.rebound([-1.0, -0.5], [0.3, -0.3], **SOFT)
    assert np.all(r.V_n > 0.0)
    assert_allclose(r.V_n, -r.e * np.array([-1.0, -0.5]), rtol=1e-14)


# Rule 2: not approaching (v_n >= 0) or NaN -> NaN floats and False flags.
def test_rule_not_approaching_is_nan():
    r = mi.rebound([0.0, 1.0, np.nan], [0.2, 0.2, 0.2], **SOFT)
    for f in ("R", "rho", "e", "V_n", "V_t", "mu", "mu0"):
        assert np.all(np.isnan(getattr(r, f))), f
    assert not np.any(r.rolling) and not np.any(r.captured)


# Rule 3: the particle travels in -t at theta from the nominal plane.
def test_rule_particle_travels_in_minus_t():
    theta = np.array([10.0, 45.0, 80.0])
    a = mi.apparent_rebound(2.0, theta, 0.0, **SOFT)
    th = np.deg2rad(theta)
    assert_allclose(a.v_t_true, -2.0 * np.cos(th), rtol=1e-14)
    assert_allclose(a.v_n_true, -2.0 * np.sin(th), rtol=1e-14)
    normal = mi.apparent_rebound(2.0, 90.0, 0.0, **SOFT)  # 90 deg is a normal impact
    assert_allclose(normal.v_t_true, 0.0, atol=1e-15)


# Rule 4: phi > 0 turns the facet away and lowers the true incidence angle.
def test_rule_positive_phi_lowers_true_incidence():
    theta, phi = 50.0, np.array([-20.0, 0.0, 20.0])
    a = mi.apparent_rebound(1.0, theta, phi, **SOFT)
    assert_allclose(a.true_incidence_angle_deg, theta - phi, rtol=1e-14)
    assert_allclose(a.v_n_true, -np.sin(np.deg2rad(theta - phi)), rtol=1e-13)
    # the normal speed on the facet falls as phi rises
    assert np.all(np.diff(-a.v_n_true) < 0.0)


# Rule 5: shadowing where phi >= theta (grazing included).
def test_rule_shadowing():
    a = mi.apparent_rebound(1.0, 30.0, [29.9, 30.0, 45.0, -30.0], **SOFT)
    assert_array_equal(a.shadowed, [False, True, True, False])
    assert np.all(np.isnan(a.e_m[1:3])) and np.all(np.isnan(a.mu_m[1:3]))
    assert not np.any(a.captured[1:3] | a.rolling[1:3] | a.reimpact[1:3])


# Rule 6: a facet facing the particle with phi = theta - 90 is struck normally,
# so the rebound retraces the path: V = -e v, e_m = e and mu_m = cot(theta).
def test_rule_facet_facing_particle_struck_normally():
    theta = np.array([20.0, 35.0, 60.0])
    a = mi.apparent_rebound(1.5, theta, theta - 90.0, friction=0.3, **SOFT)
    th = np.deg2rad(theta)
    assert_allclose(a.true_incidence_angle_deg, 90.0, rtol=1e-14)
    assert_allclose(a.mu, 0.0, atol=1e-12)
    assert_allclose(a.V_t, a.e * 1.5 * np.cos(th), rtol=1e-10)
    assert_allclose(a.V_n, a.e * 1.5 * np.sin(th), rtol=1e-10)
    assert_allclose(a.e_m, a.e, rtol=1e-10)
    assert_allclose(a.mu_m, 1.0 / np.tan(th), rtol=1e-10)


# Rule 7: mu > 0 where friction opposes the incoming tangential motion.
def test_rule_sign_of_mu():
    # travelling in -t: friction pushes towards +t, V_t > v_t, mu > 0
    r = mi.rebound(-1.0, -1.0, friction=0.2, **SOFT)
    assert r.mu > 0.0 and r.V_t > -1.0
    # travelling in +t: mu < 0
    r = mi.rebound(-1.0, 1.0, friction=0.2, **SOFT)
    assert r.mu < 0.0 and r.V_t < 1.0
    # sliding keeps the sign of mu0 with |mu| = friction
    r = mi.rebound(-0.3, [-3.0, 3.0], friction=0.1, **SOFT)
    assert_allclose(r.mu, [0.1, -0.1], rtol=1e-15)
    assert not np.any(r.rolling)


# Rule 8: spin about n x t; the contact point slips at v_t - r omega.
def test_rule_sign_of_spin():
    radius = 1e-5
    # already rolling in -t (omega = v_t / r < 0): no slip, no tangential impulse
    r = mi.rebound(-1.0, -0.8, radius=radius, spin=-0.8 / radius, **SOFT)
    assert_allclose([r.mu0, r.mu], 0.0, atol=1e-15)
    assert_allclose(r.V_t, -0.8, rtol=1e-14)
    assert_allclose(r.spin, -0.8 / radius, rtol=1e-14)
    # no initial spin, moving in -t: friction sets the sphere rolling in -t (omega < 0)
    r = mi.rebound(-1.0, -0.8, radius=radius, **SOFT)
    assert r.spin < 0.0
    assert_allclose(r.V_t - radius * r.spin, 0.0, atol=1e-13)
    # omega' = omega - (5/2)(V_t - v_t)/r for a solid sphere
    assert_allclose(r.spin, -2.5 * (r.V_t + 0.8) / radius, rtol=1e-13)


# Rule 9: capture where |v_n| <= v_c; e = 0 there and e -> 0 from above.
def test_rule_capture():
    r = mi.rebound([-0.1, -0.05, -0.1 - 1e-8], 0.0, k1=1.0, k2=0.2, v_c=0.1)
    assert_array_equal(r.captured, [True, True, False])
    assert_allclose(r.e[:2], 0.0, atol=0.0)
    assert 0.0 < r.e[2] < 1e-7
    assert np.all(np.isnan(r.mu[:2]))


# Rule 10: Eq. 7 as printed maps facet components to nominal ones.
def test_rule_eq7_as_printed():
    rng = np.random.default_rng(7)
    phi = rng.uniform(-40.0, 40.0, 200)
    a = mi.apparent_rebound(1.0, 70.0, phi, friction=0.2, **SOFT)
    c, s = np.cos(np.deg2rad(phi)), np.sin(np.deg2rad(phi))
    V_n1 = -a.e * a.v_n_true  # Eq. 1 in the facet frame
    V_t1 = a.v_t_true - a.mu * (1 + a.e) * a.v_n_true  # Eq. 2 in the facet frame
    assert_allclose(a.V_n, c * V_n1 + s * V_t1, rtol=1e-12, atol=1e-15)
    assert_allclose(a.V_t, -s * V_n1 + c * V_t1, rtol=1e-12, atol=1e-15)
    theta = np.deg2rad(70.0)
    assert_allclose(c * a.v_n_true + s * a.v_t_true, -np.sin(theta), rtol=1e-12)
    assert_allclose(-s * a.v_n_true + c * a.v_t_true, -np.cos(theta), rtol=1e-12)


# Rule 11: re-impact when the rebound heads into the nominal surface. On a
# frictionless elastic facet the nominal rebound angle is theta - 2 phi.
@pytest.mark.parametrize(
    ("phi", "reimpact"), [(4.0, False), (6.0, True), (-5.0, False)]
)
def test_rule_reimpact(phi, reimpact):
    a = mi.apparent_rebound(1.0, 10.0, phi, friction=0.0, **ELASTIC)
    assert bool(a.reimpact) is reimpact
    angle = math.degrees(math.atan2(float(a.V_n), -float(a.V_t)))
    assert_allclose(angle, 10.0 - 2.0 * phi, rtol=1e-12)
