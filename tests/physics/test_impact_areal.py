"""Tests for the 3-D (areal-roughness) extension of ``microimpact.apparent_rebound``.

Issue 14, "Physics": a facet with slopes ``h_x = tan(phi_par)``, ``h_y =
tan(phi_perp)`` has the normal ``n' ~ (-tan phi_par, -tan phi_perp, 1)`` in the
nominal frame ``(t, b, n) = (x, y, z)``; the particle arrives with
``u = s (-cos theta, 0, -sin theta)``.

Two references, both written here independently of the package:

* :func:`_vector_oracle` -- the issue's definitions taken literally, with explicit
  3-vectors: ``u_n' = u . n'``, ``u_t' = u - u_n' n'``, the contact slip
  ``w = u_t' + omega x (-r n')``, Eqs. 1-6 with ``|u_n'|``, Eq. 3 with
  ``eta = |w|/|u_n'|``, ``V_t' = u_t' - mu (1 + e) |u_n'| w_hat``,
  ``U = -e u_n' n' + V_t'``, then ``e_m = U_z/(s sin theta)``,
  ``mu_m = (U_x - u_x)/(U_z - u_z)``, ``psi = atan2(U_y, -U_x)``. It never uses the
  package's decomposition (tilt about b, then about t') nor Eqs. 8-9.
* :func:`_rotation_matrix_oracle` -- the paper's 2-D model (phi_perp = 0) written as
  a rotation matrix about ``b`` applied to facet-frame vectors (Eq. 7).

[1] X. Li, P. F. Dunn and R. M. Brach, Aerosol Sci. Technol. 33:376-386 (2000).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal
from oracle_impact import apparent_rebound_scalar

import microimpact as mi

SOFT = {"k1": 3.0, "k2": 0.05, "v_c": 0.1}


# ------------------------------------------------------------------ reference models
def _eqs_4_6(speed_n, k1, k2, v_c, p, q):
    """(e, captured) from Eqs. 4-6 with the capture rule |v_n| <= v_c."""
    captured = speed_n <= v_c
    R = 1.0 if math.isinf(k1) else k1**p / (k1**p + speed_n**p)  # Eq. 4
    if captured:
        return 0.0, True
    x = (speed_n - v_c) ** q
    rho = k2**q / (k2**q + x)  # Eq. 5
    return R * (1.0 - rho), False  # Eq. 6


def _vector_oracle(
    speed, theta_deg, phi_deg, perp_deg, *, k1, k2, v_c, p=1.0, q=1.0,
    friction=math.inf, radius=None, spin=0.0,
):  # fmt: skip
    """One 3-D impact from the issue's vector definitions (see the module doc)."""
    th = math.radians(theta_deg)
    u = np.array([-speed * math.cos(th), 0.0, -speed * math.sin(th)])
    n = np.array(
        [-math.tan(math.radians(phi_deg)), -math.tan(math.radians(perp_deg)), 1.0]
    )
    n /= np.linalg.norm(n)
    u_n = float(u @ n)
    out = {"shadowed": u_n >= 0.0}
    if u_n >= 0.0:
        return out
    u_t = u - u_n * n
    omega = np.array([0.0, spin, 0.0])  # about b = n x t
    r = 0.0 if radius is None else radius
    w = u_t + np.cross(omega, -r * n)  # contact-point slip
    e, captured = _eqs_4_6(abs(u_n), k1, k2, v_c, p, q)
    out["captured"] = captured
    out["v_n_true"] = u_n
    if captured:
        U = np.zeros(3)
        mu = math.nan
    else:
        w_abs = float(np.linalg.norm(w))
        mu0 = 2.0 * (w_abs / abs(u_n)) / (7.0 * (1.0 + e))  # Eq. 3, eta = |w|/|u_n|
        mu = min(mu0, friction)
        w_hat = w / w_abs if w_abs > 0 else np.zeros(3)
        V_t = u_t - mu * (1.0 + e) * abs(u_n) * w_hat
        U = -e * u_n * n + V_t
    out.update(e=e, U=U, mu_abs=mu)
    out["e_m"] = 0.0 if captured else U[2] / (speed * math.sin(th))
    with np.errstate(invalid="ignore", divide="ignore"):
        out["mu_m"] = math.nan if captured else (U[0] - u[0]) / (U[2] - u[2])
    out["psi"] = math.nan if captured else math.degrees(math.atan2(U[1], -U[0]))
    out["elevation"] = (
        math.nan if captured else math.degrees(math.atan2(U[2], math.hypot(U[0], U[1])))
    )
    if radius is not None:
        dV = U - u
        out["omega"] = (
            np.zeros(3) if captured else omega + np.cross(dV, n) / (0.4 * radius)
        )
    return out


def _rotation_matrix_oracle(speed, theta_deg, phi_deg, *, k1, k2, v_c, friction):
    """The paper's 2-D model with an explicit rotation matrix about b (Eq. 7)."""
    phi = math.radians(phi_deg)
    # columns: facet t', n' in nominal (t, n) coordinates; rows map facet -> nominal
    rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    th = math.radians(theta_deg)
    u = np.array([-speed * math.cos(th), -speed * math.sin(th)])  # (t, n)
    v_t1, v_n1 = rot.T @ u  # facet components
    if v_n1 >= 0.0:
        return None
    e, captured = _eqs_4_6(-v_n1, k1, k2, v_c, 1.0, 1.0)
    if captured:
        return {"V": np.zeros(2), "e_m": 0.0, "mu_m": math.nan}
    mu0 = 2.0 * (v_t1 / v_n1) / (7.0 * (1.0 + e))
    mu = mu0 if abs(mu0) <= friction else math.copysign(friction, mu0)
    V1 = np.array([v_t1 - mu * (1.0 + e) * v_n1, -e * v_n1])
    V = rot @ V1
    return {"V": V, "e_m": -V[1] / u[1], "mu_m": (V[0] - u[0]) / (V[1] - u[1])}


def _random_inputs(rng, n):
    speed = rng.uniform(0.1, 4.0, n)
    theta = rng.uniform(1.0, 90.0, n)
    phi = rng.uniform(-70.0, 70.0, n)
    perp = rng.uniform(-70.0, 70.0, n)
    return speed, theta, phi, perp


# ------------------------------------------------------ agreement with the oracle
@pytest.mark.parametrize("with_spin", [False, True])
def test_matches_vector_oracle_random(with_spin):
    rng = np.random.default_rng(1401)
    n = 1500
    speed, theta, phi, perp = _random_inputs(rng, n)
    friction = rng.uniform(0.0, 0.6, n)
    friction[rng.random(n) < 0.2] = np.inf
    k1 = rng.uniform(0.5, 20.0, n)
    k2 = rng.uniform(0.0, 0.5, n)
    v_c = rng.uniform(0.0, 0.6, n)
    kw = {"k1": k1, "k2": k2, "v_c": v_c, "friction": friction}
    if with_spin:
        kw["radius"] = rng.uniform(1e-6, 1e-4, n)
        kw["spin"] = rng.uniform(-2.0, 2.0, n) / kw["radius"]
    got = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=perp, **kw)
    counts = {"shadowed": 0, "captured": 0, "rolling": 0, "sliding": 0}
    for i in range(n):
        kwi = {k: float(v[i]) for k, v in kw.items()}
        want = _vector_oracle(speed[i], theta[i], phi[i], perp[i], **kwi)
        assert bool(got.shadowed[i]) == want["shadowed"], i
        if want["shadowed"]:
            counts["shadowed"] += 1
            assert np.isnan(got.e_m[i]) and np.isnan(got.lateral_angle_deg[i])
            continue
        assert bool(got.captured[i]) == want["captured"], i
        U = np.array([got.V_t[i], got.V_b[i], got.V_n[i]])
        assert_allclose(U, want["U"], rtol=1e-10, atol=1e-13, err_msg=str(i))
        assert_allclose(got.v_n_true[i], want["v_n_true"], rtol=1e-12)
        assert_allclose(got.e[i], want["e"], rtol=1e-12, atol=1e-15)
        assert_allclose(got.e_m[i], want["e_m"], rtol=1e-9, atol=1e-12)
        assert_allclose(got.mu_m[i], want["mu_m"], rtol=1e-9, atol=1e-12)
        for f, k in (("lateral_angle_deg", "psi"), ("rebound_elevation_deg",
                                                    "elevation")):  # fmt: skip
            assert_allclose(getattr(got, f)[i], want[k], rtol=1e-9, atol=1e-9)
        if want["captured"]:
            counts["captured"] += 1
        else:
            assert_allclose(
                math.hypot(got.mu[i], got.mu_b[i]), want["mu_abs"], rtol=1e-10
            )
            counts["rolling" if got.rolling[i] else "sliding"] += 1
        if with_spin:
            omega = np.array([got.spin_t[i], got.spin[i], got.spin_n[i]])
            scale = 1.0 / kw["radius"][i]
            assert_allclose(omega, want["omega"], rtol=1e-9, atol=1e-9 * scale)
    assert min(counts.values()) > 50, counts


def test_shadowing_and_capture_decided_on_true_normal_speed():
    """Shadowing needs u . n' >= 0, which does not depend on phi_perp; capture is
    decided on |u . n'| = cos(chi) s sin(theta'), which phi_perp lowers."""
    # normal incidence on a facet tilted out of plane only: |u_n'| = s cos(phi_perp)
    res = mi.apparent_rebound(
        1.0, 90.0, 0.0, out_of_plane_angle_deg=[30.0, 40.0, -40.0], k1=5.0, k2=0.1,
        v_c=0.8,
    )  # fmt: skip
    assert_allclose(res.v_n_true, -np.cos(np.deg2rad([30.0, 40.0, -40.0])))
    assert_array_equal(res.captured, [False, True, True])  # 0.866 > 0.8 > 0.766
    assert res.e_m[1] == 0.0 and np.isnan(res.mu_m[1])
    assert np.isnan(res.lateral_angle_deg[1]) and res.V_b[1] == 0.0
    # random: capture <=> |v_n_true| <= v_c, shadowing <=> phi >= theta
    rng = np.random.default_rng(1402)
    speed, theta, phi, perp = _random_inputs(rng, 4000)
    r = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=perp, **SOFT)
    assert_array_equal(r.shadowed, phi >= theta)
    live = ~r.shadowed
    assert_array_equal(r.captured[live], np.abs(r.v_n_true[live]) <= SOFT["v_c"])
    # and some of these are captured only because of phi_perp
    flat = mi.apparent_rebound(speed, theta, phi, **SOFT)
    assert np.sum(r.captured & ~flat.captured) > 20


# --------------------------------------------------------- reduction to the paper
def test_phi_perp_zero_is_the_2d_model_bit_for_bit():
    """out_of_plane_angle_deg = 0 (given or not) gives the 2-D path's values."""
    rng = np.random.default_rng(1403)
    n = 3000
    speed, theta, phi, _ = _random_inputs(rng, n)
    radius = rng.uniform(1e-6, 1e-4, n)
    kw = dict(SOFT, friction=rng.uniform(0.0, 0.5, n), radius=radius,
              spin=rng.uniform(-2, 2, n) / radius)  # fmt: skip
    a = mi.apparent_rebound(speed, theta, phi, **kw)
    b = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=0.0, **kw)
    c = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=-0.0, **kw)
    for f in a.__dataclass_fields__:
        assert_array_equal(getattr(b, f), getattr(a, f), err_msg=f)
        assert_array_equal(getattr(c, f), getattr(a, f), err_msg=f)
    live = np.isfinite(a.V_n)
    assert np.all(a.V_b[live] == 0.0) and np.all(a.mu_b[np.isfinite(a.mu)] == 0.0)
    assert np.all(a.spin_t[live] == 0.0) and np.all(a.spin_n[live] == 0.0)
    fwd = live & ~a.captured
    assert set(np.unique(a.lateral_angle_deg[fwd])) <= {0.0, 180.0}
    assert_array_equal(a.lateral_angle_deg[fwd] == 0.0, a.V_t[fwd] < 0.0)


def test_phi_perp_zero_matches_2d_oracle_and_rotation_matrix():
    rng = np.random.default_rng(1404)
    n = 1500
    speed, theta, phi, _ = _random_inputs(rng, n)
    friction = rng.uniform(0.0, 0.5, n)
    kw = dict(SOFT, friction=friction)
    got = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=0.0, **kw)
    live = 0
    for i in range(n):
        kwi = dict(SOFT, friction=float(friction[i]))
        old = apparent_rebound_scalar(speed[i], theta[i], phi[i], **kwi)  # 2-D oracle
        mat = _rotation_matrix_oracle(speed[i], theta[i], phi[i], **kwi)
        if mat is None:
            assert got.shadowed[i] and old["shadowed"]
            continue
        live += 1
        for want in (
            {"V_t": old["V_t"], "V_n": old["V_n"], "e_m": old["e_m"],
             "mu_m": old["mu_m"]},
            {"V_t": mat["V"][0], "V_n": mat["V"][1], "e_m": mat["e_m"],
             "mu_m": mat["mu_m"]},
        ):  # fmt: skip
            for f, w in want.items():
                assert_allclose(
                    getattr(got, f)[i], w, rtol=1e-10, atol=1e-12, equal_nan=True,
                    err_msg=f"{f}[{i}]",
                )  # fmt: skip
    assert live > 1000


def test_eqs_8_9_closed_forms_at_phi_perp_zero():
    """[1], Eqs. 8-9 evaluated from the facet values the function reports."""
    rng = np.random.default_rng(1405)
    speed, theta, phi, _ = _random_inputs(rng, 3000)
    r = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=0.0,
                            friction=0.2, **SOFT)  # fmt: skip
    ok = ~r.shadowed & ~r.captured
    tp = np.tan(np.deg2rad(phi))[ok]
    v_n, v_t, e, mu = r.v_n_true[ok], r.v_t_true[ok], r.e[ok], r.mu[ok]
    V_t1 = v_t - mu * (1.0 + e) * v_n  # Eq. 2
    assert_allclose(
        r.e_m[ok], (e - tp * V_t1 / v_n) / (1.0 + tp * v_t / v_n), rtol=1e-12
    )  # Eq. 8
    assert_allclose(r.mu_m[ok], (mu - tp) / (mu * tp + 1.0), rtol=1e-12)  # Eq. 9


def test_small_phi_perp_is_continuous():
    rng = np.random.default_rng(1406)
    speed, theta, phi, _ = _random_inputs(rng, 2000)
    a = mi.apparent_rebound(speed, theta, phi, friction=0.3, **SOFT)
    b = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=1e-7,
                            friction=0.3, **SOFT)  # fmt: skip
    ok = ~a.captured & ~a.shadowed & (np.abs(a.V_t) > 1e-3)
    for f in ("e_m", "mu_m", "V_n", "V_t"):
        assert_allclose(getattr(b, f)[ok], getattr(a, f)[ok], rtol=1e-6, atol=1e-8)
    assert np.all(np.abs(b.V_b[ok]) < 1e-8 * speed[ok])  # ~ sin(1e-7 deg) s
    assert np.all(np.abs(b.lateral_angle_deg[ok & (a.V_t < 0)]) < 1e-3)


# ---------------------------------------------------------------------- symmetries
def test_mirror_symmetry_flips_lateral_angle():
    rng = np.random.default_rng(1407)
    n = 3000
    speed, theta, phi, perp = _random_inputs(rng, n)
    radius = rng.uniform(1e-6, 1e-4, n)
    kw = dict(SOFT, friction=rng.uniform(0.0, 0.5, n), radius=radius)
    a = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=perp, **kw)
    b = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=-perp, **kw)
    for f in ("V_b", "mu_b", "v_b_true", "spin_t", "spin_n"):
        assert_allclose(getattr(b, f), -getattr(a, f), rtol=1e-14, atol=1e-300,
                        equal_nan=True, err_msg=f)  # fmt: skip
    back = np.abs(a.lateral_angle_deg) == 180.0  # on the cut: +180 both ways
    assert_allclose(b.lateral_angle_deg[~back], -a.lateral_angle_deg[~back],
                    rtol=1e-14, equal_nan=True)  # fmt: skip
    for f in ("e_m", "mu_m", "e", "mu", "V_n", "V_t", "v_n_true", "v_t_true",
              "rebound_elevation_deg", "spin"):  # fmt: skip
        assert_allclose(getattr(b, f), getattr(a, f), rtol=1e-14, atol=1e-300,
                        equal_nan=True, err_msg=f)  # fmt: skip
    for f in ("captured", "shadowed", "rolling", "reimpact"):
        assert_array_equal(getattr(b, f), getattr(a, f), err_msg=f)
    # and the lateral deflection is towards -b for phi_perp > 0 (facet rising along
    # +b leans its normal towards -b) at normal incidence
    c = mi.apparent_rebound(1.0, 90.0, 0.0, out_of_plane_angle_deg=20.0, **SOFT)
    assert c.V_b < 0.0 and c.lateral_angle_deg < 0.0


def test_normal_incidence_out_of_plane_tilt_is_in_plane_tilt_rotated():
    """At theta = 90 deg the plane of incidence is arbitrary: a facet tilted by alpha
    across it behaves like one tilted by alpha along it, rotated by 90 deg about n:
    (U_t, U_b) -> (-U_b, U_t) up to the O(cos 90 deg) = 6e-17 incoming tangent."""
    alpha = np.array([-60.0, -35.0, -10.0, -1.0, 1.0, 10.0, 35.0, 60.0])
    kw = dict(SOFT, friction=0.2, k1=2.0)
    inp = mi.apparent_rebound(1.5, 90.0, alpha, **kw)
    out = mi.apparent_rebound(1.5, 90.0, 0.0, out_of_plane_angle_deg=alpha, **kw)
    assert not np.any(inp.captured | out.captured | inp.shadowed)
    tol = {"rtol": 1e-12, "atol": 1e-12}
    assert_allclose(out.e_m, inp.e_m, **tol)
    assert_allclose(out.e, inp.e, **tol)
    assert_allclose(out.V_n, inp.V_n, **tol)
    # rotation by +90 deg about n maps t -> b: U_b(out) = U_t(in), U_t(out) = -U_b(in)
    assert_allclose(out.V_b, inp.V_t, **tol)
    assert_allclose(out.V_t, -inp.V_b, **tol)
    # the apparent impulse ratio moves to the lateral direction
    lateral_mu = (out.V_b - 0.0) / (out.V_n + 1.5)  # dU_b / dU_n, u = (~0, 0, -1.5)
    assert_allclose(np.abs(lateral_mu), np.abs(inp.mu_m), **tol)
    assert_allclose(np.abs(out.mu_m), 0.0, atol=1e-12)
    assert_allclose(np.hypot(out.mu, out.mu_b), np.abs(inp.mu), **tol)
    # the lateral angle is +-90 deg (sideways), the in-plane one 0 or 180
    assert_allclose(np.abs(out.lateral_angle_deg), 90.0, atol=1e-9)
    assert_allclose(out.rebound_elevation_deg, inp.rebound_elevation_deg, **tol)


# ------------------------------------------------------------------------- energy
# extreme ratios (k2 = 1e-308) overflow harmlessly to the right limit inside
# rebound's ratio law (as in test_impact.py); the energies are what is tested here
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@settings(max_examples=300, deadline=None)
@given(
    speed=st.floats(1e-3, 50.0),
    theta=st.floats(0.01, 90.0),
    phi=st.floats(-89.0, 89.0),
    perp=st.floats(-89.0, 89.0),
    k1=st.floats(1e-3, 1e3) | st.just(math.inf),
    k2=st.floats(0.0, 1e2),
    v_c=st.floats(0.0, 10.0),
    friction=st.floats(0.0, 2.0) | st.just(math.inf),
    spin_r=st.floats(-5.0, 5.0),
)
def test_energy_never_increases(speed, theta, phi, perp, k1, k2, v_c, friction,
                                spin_r):  # fmt: skip
    kw = {"k1": k1, "k2": k2, "v_c": v_c, "friction": friction}
    r = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=perp, **kw)
    if r.shadowed or not np.isfinite(r.V_n):
        return
    U2 = r.V_t**2 + r.V_b**2 + r.V_n**2
    assert U2 <= speed**2 * (1.0 + 1e-12)
    # with spin: translational + rotational energy of a solid sphere
    radius = 1e-5
    omega = spin_r * speed / radius
    s = mi.apparent_rebound(speed, theta, phi, out_of_plane_angle_deg=perp,
                            radius=radius, spin=omega, **kw)  # fmt: skip
    before = speed**2 + 0.4 * radius**2 * omega**2
    after = (
        s.V_t**2 + s.V_b**2 + s.V_n**2
        + 0.4 * radius**2 * (s.spin**2 + s.spin_t**2 + s.spin_n**2)
    )  # fmt: skip
    assert after <= before * (1.0 + 1e-12)


# ------------------------------------------------------------ shapes and domain
def test_broadcasting_and_impossible_elements():
    perp = np.array([[-20.0], [0.0], [20.0]])  # (3, 1)
    theta = np.array([10.0, 45.0, 90.0])  # (3,)
    r = mi.apparent_rebound(1.0, theta, 5.0, out_of_plane_angle_deg=perp, **SOFT)
    assert r.e_m.shape == (3, 3) and r.lateral_angle_deg.shape == (3, 3)
    assert r.V_b.shape == (3, 3) and r.shadowed.shape == (3, 3)
    scalar = mi.apparent_rebound(1.0, 45.0, 5.0, out_of_plane_angle_deg=20.0, **SOFT)
    assert np.shape(scalar.lateral_angle_deg) == ()
    assert_allclose(scalar.lateral_angle_deg, r.lateral_angle_deg[2, 1], rtol=1e-15)
    bad = mi.apparent_rebound(
        1.0, 45.0, 5.0, out_of_plane_angle_deg=[90.0, -90.0, 120.0, np.nan], **SOFT
    )
    nan_fields = (
        "e_m", "mu_m", "V_n", "V_t", "V_b", "lateral_angle_deg",
        "rebound_elevation_deg", "v_n_true", "true_incidence_angle_deg",
    )  # fmt: skip
    for f in nan_fields:
        assert np.all(np.isnan(getattr(bad, f))), f
    for f in ("captured", "shadowed", "rolling", "reimpact"):
        assert not np.any(getattr(bad, f)), f
    # shadowed elements stay NaN with the flag, whatever phi_perp
    sh = mi.apparent_rebound(1.0, 20.0, 30.0, out_of_plane_angle_deg=45.0, **SOFT)
    assert sh.shadowed and np.isnan(sh.e_m) and np.isnan(sh.lateral_angle_deg)


def test_spin_without_radius_still_raises():
    with pytest.raises(ValueError, match="`radius`"):
        mi.apparent_rebound(1.0, 45.0, 0.0, out_of_plane_angle_deg=10.0, spin=1.0,
                            **SOFT)  # fmt: skip
