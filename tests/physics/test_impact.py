"""Tests for ``microimpact.physics.impact`` (paper Eqs. 1-9).

The reference is ``tests/oracle_impact.py``: an independent scalar implementation that
works with explicit unit vectors and never uses Eqs. 8-9. Further checks use closed
forms (the classical rigid-body impact of a sphere), the paper's own worked example for
Eq. 9, and the published trend of Kharaz, Gorham & Salman (2001).

[1] X. Li, P. F. Dunn and R. M. Brach, Aerosol Sci. Technol. 33:376-386 (2000).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal
from oracle_impact import (
    APPARENT_FIELDS,
    REBOUND_FIELDS,
    apparent_rebound_scalar,
    rebound_scalar,
)

import microimpact as mi

RTOL = 1e-10
FLAGS = {"rolling", "captured", "shadowed", "reimpact"}


# ----------------------------------------------------------------------------- helpers
def _oracle(func, fields, args, kwargs):
    """Run a scalar oracle elementwise over broadcast array arguments."""
    names = list(kwargs)
    arrays = np.broadcast_arrays(
        *[np.asarray(a, float) for a in args], *kwargs.values()
    )
    shape = arrays[0].shape
    out = {f: np.empty(shape, dtype=bool if f in FLAGS else float) for f in fields}
    has_spin = kwargs.get("radius") is not None
    for idx in np.ndindex(shape):
        pos = [float(a[idx]) for a in arrays[: len(args)]]
        kw = {k: float(a[idx]) for k, a in zip(names, arrays[len(args) :], strict=True)}
        res = func(*pos, **kw)
        for f in fields:
            if f == "spin" and not has_spin:
                continue
            out[f][idx] = res[f]
    if not has_spin:
        out["spin"] = None
    return out


def _check(result, expected, fields, *, atol, skip=None):
    """Compare a package result with the oracle, field by field."""
    for f in fields:
        got = getattr(result, f)
        want = expected[f]
        if want is None:
            assert got is None, f
            continue
        got = np.asarray(got)
        assert got.shape == want.shape, f
        skipped = np.asarray((skip or {}).get(f, False), dtype=bool)
        keep = ~np.broadcast_to(skipped, want.shape)
        if f in FLAGS:
            assert got.dtype == bool, f
            assert_array_equal(got[keep], want[keep], err_msg=f)
        else:
            assert_allclose(
                got[keep], want[keep], rtol=RTOL, atol=atol.get(f, 0.0),
                equal_nan=True, err_msg=f,
            )  # fmt: skip


def _random_coefficients(rng, n):
    k1 = np.exp(rng.uniform(np.log(0.05), np.log(200.0), n))
    k1[rng.random(n) < 0.1] = np.inf  # R = 1
    k2 = rng.uniform(0.0, 2.0, n)
    k2[rng.random(n) < 0.1] = 0.0  # no adhesion
    v_c = rng.uniform(0.0, 1.0, n)
    v_c[rng.random(n) < 0.1] = 0.0
    p = rng.uniform(0.3, 3.0, n)
    q = rng.uniform(0.3, 3.0, n)
    return {"k1": k1, "k2": k2, "v_c": v_c, "p": p, "q": q}


# ------------------------------------------------------------ rebound vs the oracle
def test_rebound_matches_oracle_random():
    rng = np.random.default_rng(20000)
    n = 4000
    c = _random_coefficients(rng, n)
    v_n = -rng.uniform(0.0, 4.0, n)
    # the capture rule near and at |v_n| = v_c
    v_n[:100] = -c["v_c"][:100]
    v_n[100:200] = -c["v_c"][100:200] * (1.0 + rng.choice([-1e-9, 1e-9, 1e-4], 100))
    v_t = rng.uniform(-5.0, 5.0, n)
    radius = rng.uniform(1e-6, 1e-4, n)
    spin = rng.uniform(-3.0, 3.0, n) / radius  # r*omega comparable with v_t
    spin[rng.random(n) < 0.3] = 0.0
    # friction: infinite, zero, random, and straddling |mu0| (the rolling switch)
    friction = rng.uniform(0.0, 0.8, n)
    friction[rng.random(n) < 0.15] = np.inf
    friction[rng.random(n) < 0.05] = 0.0
    mu0 = np.array(
        [
            rebound_scalar(v_n[i], v_t[i], **{k: c[k][i] for k in c},
                           radius=radius[i], spin=spin[i])["mu0"]
            for i in range(300, 700)
        ]
    )  # fmt: skip
    friction[300:700] = np.abs(mu0) * np.where(np.arange(400) % 2, 1 + 1e-6, 1 - 1e-6)
    # impossible elements: not approaching, NaN
    v_n[700:720] = 0.0
    v_n[720:740] = rng.uniform(0.1, 1.0, 20)
    v_n[740:750] = np.nan
    v_t[750:760] = np.nan
    spin[760:770] = np.nan

    kw = dict(c, friction=friction, radius=radius, spin=spin)
    got = mi.rebound(v_n, v_t, **kw)
    want = _oracle(rebound_scalar, REBOUND_FIELDS, (v_n, v_t), kw)
    # mu0 and the rolling flag of a captured particle are outside the contract
    skip = {"mu0": want["captured"], "rolling": want["captured"]}
    atol = {"e": 1e-15, "V_n": 1e-14, "V_t": 1e-14, "spin": 1e-6}
    _check(got, want, REBOUND_FIELDS, atol=atol, skip=skip)

    # the sample really exercises every branch
    assert want["captured"].sum() > 100
    assert want["rolling"].sum() > 300
    assert (~want["rolling"] & ~want["captured"] & ~np.isnan(want["e"])).sum() > 300
    assert np.all(np.isnan(want["e"][700:770]))
    assert np.all(np.isnan(np.asarray(got.e)[700:770]))
    assert not np.any(np.asarray(got.captured)[700:770])
    assert not np.any(np.asarray(got.rolling)[700:770])


def test_rebound_matches_oracle_without_radius():
    """Scalar general exponents, no radius: ``spin`` is None and eta = v_t / v_n."""
    rng = np.random.default_rng(20001)
    n = 1500
    v_n = -rng.uniform(0.0, 3.0, n)
    v_t = rng.uniform(-3.0, 3.0, n)
    kw = {"k1": 1.3, "k2": 0.25, "v_c": 0.4, "p": 2.5, "q": 0.6, "friction": 0.2}
    got = mi.rebound(v_n, v_t, **kw)
    want = _oracle(rebound_scalar, REBOUND_FIELDS, (v_n, v_t), kw)
    skip = {"mu0": want["captured"], "rolling": want["captured"]}
    _check(got, want, REBOUND_FIELDS, atol={"e": 1e-15, "V_n": 1e-14}, skip=skip)


# ---------------------------------------------------- apparent_rebound vs the oracle
def test_apparent_rebound_matches_oracle_random():
    rng = np.random.default_rng(20002)
    n = 4000
    c = _random_coefficients(rng, n)
    speed = rng.uniform(0.05, 5.0, n)
    theta = rng.uniform(0.5, 90.0, n)
    theta[:100] = 90.0
    phi = rng.normal(0.0, 25.0, n).clip(-89.0, 89.0)
    phi[100:150] = theta[100:150]  # exactly grazing: shadowed
    phi[150:300] = 0.6 * theta[150:300]  # low true angle: frequent re-impact
    radius = rng.uniform(1e-6, 1e-4, n)
    spin = rng.uniform(-2.0, 2.0, n) / radius
    friction = rng.uniform(0.0, 0.6, n)
    friction[rng.random(n) < 0.2] = np.inf
    # impossible elements: speed <= 0, angles out of range, NaN
    speed[300:310] = 0.0
    speed[310:320] = -1.0
    theta[320:330] = rng.choice([0.0, -5.0, 90.5, 120.0], 10)
    phi[330:340] = rng.choice([-90.0, 90.0, 95.0, -120.0], 10)
    speed[340:345] = np.nan
    theta[345:350] = np.nan
    phi[350:355] = np.nan

    kw = dict(c, friction=friction, radius=radius, spin=spin)
    got = mi.apparent_rebound(speed, theta, phi, **kw)
    want = _oracle(apparent_rebound_scalar, APPARENT_FIELDS, (speed, theta, phi), kw)
    atol = {
        f: 1e-13
        for f in ("e_m", "mu_m", "e", "mu", "V_n", "V_t", "v_n_true", "v_t_true")
    }
    atol.update({"true_incidence_angle_deg": 1e-12, "spin": 1e-6})
    _check(got, want, APPARENT_FIELDS, atol=atol)

    # every branch is exercised
    for flag, least in [("shadowed", 100), ("captured", 100), ("reimpact", 50)]:
        assert want[flag].sum() > least, flag
    live = ~want["captured"] & ~np.isnan(want["e"])
    assert (want["rolling"] & live).sum() > 300
    assert (~want["rolling"] & live).sum() > 300
    bad = slice(300, 355)
    for f in ("e_m", "mu_m", "e", "V_n", "v_n_true", "true_incidence_angle_deg"):
        assert np.all(np.isnan(getattr(got, f)[bad])), f
    for f in ("captured", "shadowed", "rolling", "reimpact"):
        assert not np.any(getattr(got, f)[bad]), f


def test_apparent_rebound_matches_oracle_scalar_coefficients_no_radius():
    rng = np.random.default_rng(20003)
    n = 1000
    speed = rng.uniform(0.1, 3.0, n)
    theta = rng.uniform(1.0, 90.0, n)
    phi = rng.uniform(-60.0, 60.0, n)
    kw = {"k1": 5.0, "k2": 0.1, "v_c": 0.3, "friction": 0.15}
    got = mi.apparent_rebound(speed, theta, phi, **kw)
    want = _oracle(apparent_rebound_scalar, APPARENT_FIELDS, (speed, theta, phi), kw)
    atol = dict.fromkeys(("e_m", "mu_m", "e", "mu", "V_n", "V_t"), 1e-13)
    atol.update(v_n_true=1e-13, v_t_true=1e-13, true_incidence_angle_deg=1e-12)
    _check(got, want, APPARENT_FIELDS, atol=atol)


def test_phi_zero_reproduces_rebound():
    """On a facet with phi = 0 the nominal and facet frames coincide."""
    rng = np.random.default_rng(20004)
    n = 2000
    c = _random_coefficients(rng, n)
    speed = rng.uniform(0.05, 4.0, n)
    theta = rng.uniform(0.5, 90.0, n)
    radius = rng.uniform(1e-6, 1e-4, n)
    spin = rng.uniform(-2.0, 2.0, n) / radius
    kw = dict(c, friction=rng.uniform(0.0, 0.5, n), radius=radius, spin=spin)
    th = np.deg2rad(theta)
    flat = mi.rebound(-speed * np.sin(th), -speed * np.cos(th), **kw)
    app = mi.apparent_rebound(speed, theta, 0.0, **kw)
    tol = {"rtol": 1e-13, "atol": 1e-15, "equal_nan": True}
    assert_allclose(app.V_n, flat.V_n, **tol)
    assert_allclose(app.V_t, flat.V_t, **tol)
    assert_allclose(app.e_m, flat.e, **tol)
    assert_allclose(app.e, flat.e, **tol)
    assert_allclose(app.mu_m, flat.mu, **tol)
    assert_allclose(app.mu, flat.mu, **tol)
    assert_allclose(app.spin, flat.spin, rtol=1e-13, atol=1e-6)
    assert_allclose(app.v_n_true, -speed * np.sin(th), rtol=1e-13)
    assert_allclose(app.true_incidence_angle_deg, theta, rtol=1e-15)
    assert_array_equal(app.captured, flat.captured)
    assert_array_equal(app.rolling, flat.rolling)
    assert not np.any(app.shadowed)
    assert not np.any(app.reimpact)
    assert np.asarray(flat.captured).sum() > 50


# ------------------------------------------------------------------- Eqs. 8-9 directly
def test_eq9_paper_example_mu_0p3_on_minus_20_deg():
    """[1], p. 383: mu = 0.3 on a facet of -20 deg gives an apparent mu of "0.7"."""
    mu, phi = 0.3, math.radians(-20.0)
    eq9 = (mu - math.tan(phi)) / (mu * math.tan(phi) + 1.0)  # [1], Eq. 9
    assert_allclose(eq9, 0.745, atol=5e-4)
    assert_allclose(eq9, 0.7, atol=0.05)  # the paper prints one significant figure
    # an impact that really slides with friction 0.3 on such a facet:
    # theta = 5 deg, theta' = 25 deg; mu0 = 2 cot(25 deg) / (7 (1 + e)) > 0.3
    res = mi.apparent_rebound(1.0, 5.0, -20.0, k1=1.0, k2=0.0, v_c=0.0, friction=0.3)
    assert not res.rolling and not res.captured and not res.shadowed
    assert_allclose(res.mu, 0.3, rtol=1e-14)
    assert_allclose(res.mu_m, eq9, rtol=1e-12)
    assert_allclose(res.mu_m, 0.745, atol=5e-4)


def test_eqs_8_9_closed_forms():
    """The package's e_m, mu_m equal Eqs. 8-9 evaluated from the inputs alone.

    The facet quantities (Eqs. 1-6 with p = q = 1 and Eq. 3) are written out here from
    the speed and angles, independently of the package's outputs; the oracle, which
    rotates vectors and never uses Eqs. 8-9, must agree with the same closed forms.
    """
    rng = np.random.default_rng(20005)
    n = 3000
    speed = rng.uniform(0.3, 3.0, n)
    theta = rng.uniform(1.0, 90.0, n)
    phi = rng.uniform(-70.0, 70.0, n)
    friction = rng.uniform(0.0, 0.5, n)
    k1, k2, v_c = 3.0, 0.05, 0.1
    res = mi.apparent_rebound(
        speed, theta, phi, k1=k1, k2=k2, v_c=v_c, friction=friction
    )
    # facet frame, from the inputs only: theta' = theta - phi
    true_angle = np.deg2rad(theta - phi)
    shadowed = true_angle <= 0.0
    v_n1 = -speed * np.sin(true_angle)
    v_t1 = -speed * np.cos(true_angle)
    captured = ~shadowed & (-v_n1 <= v_c)
    assert_array_equal(res.shadowed, shadowed)
    assert_array_equal(res.captured, captured)
    ok = ~shadowed & ~captured
    assert ok.sum() > 1500
    tp = np.tan(np.deg2rad(phi))[ok]
    v_n1, v_t1, f = v_n1[ok], v_t1[ok], friction[ok]
    s_n = -v_n1
    e = k1 / (k1 + s_n) * (1.0 - k2 / (k2 + (s_n - v_c)))  # [1], Eqs. 4-6
    mu0 = 2.0 * (v_t1 / v_n1) / (7.0 * (1.0 + e))  # [1], Eq. 3
    mu = np.where(np.abs(mu0) <= f, mu0, np.sign(mu0) * f)
    V_t1 = v_t1 - mu * (1.0 + e) * v_n1  # [1], Eq. 2
    eq8 = (e - tp * V_t1 / v_n1) / (1.0 + tp * v_t1 / v_n1)  # [1], Eq. 8
    eq9 = (mu - tp) / (mu * tp + 1.0)  # [1], Eq. 9
    assert_allclose(res.e_m[ok], eq8, rtol=1e-9, atol=1e-12)
    assert_allclose(res.mu_m[ok], eq9, rtol=1e-9, atol=1e-12)
    # the vector oracle (no Eqs. 8-9) agrees with the same closed forms
    kw = {"k1": k1, "k2": k2, "v_c": v_c, "friction": friction}
    want = _oracle(apparent_rebound_scalar, APPARENT_FIELDS, (speed, theta, phi), kw)
    assert_allclose(want["e_m"][ok], eq8, rtol=1e-9, atol=1e-12)
    assert_allclose(want["mu_m"][ok], eq9, rtol=1e-9, atol=1e-12)


# -------------------------------------------------------------------- invariants
# extreme ratios (e.g. k2 = 5e-324) overflow harmlessly inside the package to the
# right limit (0 or 1) with a RuntimeWarning; the values are what is tested here
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@settings(max_examples=200, deadline=None)
@given(
    v_n=st.floats(1e-6, 1e3),
    k1=st.floats(1e-3, 1e3) | st.just(math.inf),
    k2=st.floats(0.0, 1e3),
    v_c=st.floats(0.0, 1e2),
    p=st.floats(0.1, 5.0),
    q=st.floats(0.1, 5.0),
)
def test_restitution_between_zero_and_one(v_n, k1, k2, v_c, p, q):
    r = mi.rebound(-v_n, 0.3 * v_n, k1=k1, k2=k2, v_c=v_c, p=p, q=q)
    assert 0.0 <= r.e <= 1.0
    assert 0.0 <= r.R <= 1.0
    assert 0.0 <= r.rho <= 1.0
    assert r.V_n >= 0.0


def test_capture_rule_at_and_near_critical_speed():
    v_c = 0.37
    kw = {"k1": 10.0, "k2": 0.2, "v_c": v_c}
    at = mi.rebound(-v_c, -0.1, **kw)
    assert at.captured and at.e == 0.0 and at.V_n == 0.0 and at.V_t == 0.0
    assert at.rho == 1.0 and np.isnan(at.mu)
    below = mi.rebound(-0.5 * v_c, -0.1, **kw)
    assert below.captured and below.e == 0.0
    # continuity of e at |v_n| = v_c from above: e ~ R (dv / k2) for small dv
    dv = np.array([1e-9, 1e-6, 1e-3])
    above = mi.rebound(-(v_c + dv), -0.1, **kw)
    assert not np.any(above.captured)
    R = 10.0 / (10.0 + v_c + dv)
    assert_allclose(above.e, R * dv / (0.2 + dv), rtol=1e-6)


# ------------------------------------------------------- classical rigid-body limit
RIGID = {"k1": math.inf, "k2": 0.0, "v_c": 0.0}  # R = 1, rho = 0, e = 1


def test_rigid_limit_sliding_and_rolling_lines():
    """Tangential restitution V_t/v_t of a solid sphere without initial spin.

    Sliding: V_t/v_t = 1 - mu (1 + e) tan(theta); rolling: 5/7. Switch where
    mu0 = cot(theta) / 7 (e = 1) equals mu.
    """
    mu = 0.2
    theta = np.linspace(0.5, 89.5, 400)
    th = np.deg2rad(theta)
    r = mi.rebound(-np.sin(th), -np.cos(th), friction=mu, radius=1e-5, **RIGID)
    assert_allclose(r.e, 1.0, rtol=1e-15)
    sliding = 1.0 / np.tan(th) / 7.0 > mu
    assert_array_equal(~np.asarray(r.rolling), sliding)
    et = r.V_t / -np.cos(th)
    assert_allclose(et[sliding], 1.0 - mu * 2.0 * np.tan(th[sliding]), rtol=1e-12)
    assert_allclose(et[~sliding], 5.0 / 7.0, rtol=1e-12)
    # rolling at separation: the contact point is at rest, V_t - r omega' = 0
    roll = ~sliding
    assert_allclose(r.V_t[roll] - 1e-5 * r.spin[roll], 0.0, atol=1e-13)
    # sliding: the contact point still slips in the incoming direction
    assert np.all(r.V_t[sliding] - 1e-5 * r.spin[sliding] < 0.0)


def test_rolling_final_state_has_zero_contact_velocity_with_initial_spin():
    rng = np.random.default_rng(20006)
    n = 500
    radius = rng.uniform(1e-6, 1e-4, n)
    spin = rng.uniform(-5.0, 5.0, n) / radius
    r = mi.rebound(
        -rng.uniform(0.2, 3.0, n), rng.uniform(-3.0, 3.0, n), k1=2.0, k2=0.05,
        v_c=0.1, radius=radius, spin=spin,
    )  # fmt: skip
    assert np.all(r.rolling[~r.captured])
    live = ~r.captured
    assert_allclose((r.V_t - radius * r.spin)[live], 0.0, atol=1e-12)


def test_kharaz_2001_alumina_on_glass_trend():
    """Published oblique-impact behaviour, in the model's rigid-body limit.

    Kharaz, Gorham & Salman (2001), "An experimental study of the elastic rebound of
    spheres", Powder Technol. 120:281-291, doi:10.1016/S0032-5910(01)00283-2: 5 mm
    Al2O3 spheres on a soda-lime glass anvil at 3.9 m/s. Their abstract: "For impacts
    with a greater obliqueness than about 30 deg from the normal, the results also
    agree closely with the classical theory of rigid body sliding." The material
    constants of that experiment, as used by the benchmark of Chung & Ooi (2011),
    Granular Matter 13:643-656, Test 4 (and the YADE benchmark script of it): e = 0.98,
    mu = 0.092, r = 2.5 mm, speed 3.9 m/s, angles 5-85 deg from the normal.

    Classical theory: the tangential restitution e_t = V_t/v_t is 5/7 while the
    sphere leaves rolling and 1 - mu (1 + e) / tan(psi) while sliding (psi from the
    normal), with the switch at tan(psi_c) = 7 mu (1 + e) / 2 -> psi_c = 32.5 deg,
    i.e. "about 30 deg".
    """
    e_n, mu, speed, radius = 0.98, 0.092, 3.9, 2.5e-3
    psi = np.arange(5.0, 85.5, 0.5)  # from the normal
    theta = 90.0 - psi  # from the plane, this package's convention
    v_n = speed * np.sin(np.deg2rad(theta))
    k1 = e_n * v_n / (1.0 - e_n)  # p = 1: R = k1/(k1 + |v_n|) = 0.98
    res = mi.apparent_rebound(
        speed, theta, 0.0, k1=k1, k2=0.0, v_c=0.0, friction=mu, radius=radius
    )
    assert_allclose(res.e, e_n, rtol=1e-12)
    e_t = res.V_t / (-speed * np.cos(np.deg2rad(theta)))
    tan_psi = np.tan(np.deg2rad(psi))
    classical = np.where(
        tan_psi > 3.5 * mu * (1 + e_n), 1.0 - mu * (1 + e_n) / tan_psi, 5.0 / 7.0
    )
    assert_allclose(e_t, classical, rtol=1e-12)
    psi_switch = psi[np.argmax(~np.asarray(res.rolling))]  # first sliding angle
    assert 25.0 <= psi_switch <= 35.0  # "about 30 deg from the normal"
    assert_allclose(psi_switch, math.degrees(math.atan(3.5 * mu * 1.98)), atol=0.5)
    # continuity of the tangential restitution at the switch, and e_t -> 1 grazing
    assert np.all(np.diff(e_t) >= -1e-12)
    assert_allclose(e_t[-1], 1.0 - mu * 1.98 / np.tan(np.deg2rad(85.0)), rtol=1e-12)


# ----------------------------------------------------------------------- errors
@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("k1", -1.0),
        ("k1", math.nan),
        ("k2", -0.1),
        ("k2", math.nan),
        ("v_c", -0.2),
        ("v_c", math.nan),
        ("friction", -0.1),
        ("p", 0.0),
        ("p", -1.0),
        ("q", 0.0),
    ],
)
def test_invalid_coefficients_raise(name, value):
    kw = {"k1": 1.0, "k2": 0.1, "v_c": 0.1, name: value}
    with pytest.raises(ValueError, match=f"`{name}`"):
        mi.rebound(-1.0, 0.5, **kw)
    with pytest.raises(ValueError, match=f"`{name}`"):
        mi.apparent_rebound(1.0, 45.0, 5.0, **kw)


def test_spin_without_radius_raises():
    with pytest.raises(ValueError, match="`radius`"):
        mi.rebound(-1.0, 0.5, k1=1.0, k2=0.1, v_c=0.1, spin=3.0)


def test_invalid_coefficient_inside_array_raises():
    with pytest.raises(ValueError, match="`k2`"):
        mi.rebound([-1.0, -2.0], 0.0, k1=1.0, k2=[0.1, -0.1], v_c=0.1)


# ------------------------------------------------------------------- input matrix
KW = {"k1": 2.0, "k2": 0.1, "v_c": 0.2, "p": 1.5, "q": 0.8, "friction": 0.25}


def _scalar_oracle(v_n, v_t):
    return rebound_scalar(v_n, v_t, **KW)


@pytest.mark.parametrize("wrap", [float, np.float64, np.asarray])
def test_input_matrix_scalar_and_0d(wrap):
    r = mi.rebound(wrap(-1.3), wrap(-0.9), **KW)
    o = _scalar_oracle(-1.3, -0.9)
    for f in ("e", "V_n", "V_t", "mu", "mu0", "R", "rho"):
        assert np.shape(getattr(r, f)) == ()
        assert_allclose(getattr(r, f), o[f], rtol=RTOL)
    assert bool(r.rolling) is o["rolling"]
    a = mi.apparent_rebound(wrap(1.5), wrap(30.0), wrap(-10.0), **KW)
    oa = apparent_rebound_scalar(1.5, 30.0, -10.0, **KW)
    for f in ("e_m", "mu_m", "V_n", "V_t", "v_n_true"):
        assert np.shape(getattr(a, f)) == ()
        assert_allclose(getattr(a, f), oa[f], rtol=RTOL)


def test_input_matrix_1d_and_2d_broadcast():
    v_n = np.array([-0.1, -0.5, -2.0])[:, None]  # (3, 1), first one captured
    v_t = np.array([-1.0, 0.0, 0.4, 2.0])[None, :]  # (1, 4)
    r = mi.rebound(v_n, v_t, **KW)
    assert np.shape(r.e) == (3, 4)
    want = _oracle(rebound_scalar, REBOUND_FIELDS, (v_n, v_t), KW)
    skip = {"mu0": want["captured"], "rolling": want["captured"]}
    _check(r, want, REBOUND_FIELDS, atol={"V_t": 1e-15}, skip=skip)
    r1 = mi.rebound(v_n[:, 0], -1.0, **KW)
    assert np.shape(r1.V_t) == (3,)
    assert_allclose(r1.V_t, want["V_t"][:, 0], rtol=RTOL)
    # apparent: speeds (2, 1) x angles (3,) x one facet angle per column
    speed = np.array([[0.5], [2.0]])
    theta = np.array([10.0, 45.0, 90.0])
    phi = np.array([-15.0, 20.0, 5.0])
    a = mi.apparent_rebound(speed, theta, phi, **KW)
    assert np.shape(a.e_m) == (2, 3)
    wa = _oracle(apparent_rebound_scalar, APPARENT_FIELDS, (speed, theta, phi), KW)
    _check(a, wa, APPARENT_FIELDS, atol=dict.fromkeys(APPARENT_FIELDS, 1e-14))
