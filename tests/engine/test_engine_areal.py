"""Areal surfaces in the engine (issue 14, part 2a): joint (phi_par, phi_perp) pairs.

Oracles, each independent of the kernel's arithmetic:

* every impact against :func:`microimpact.apparent_rebound` with
  ``out_of_plane_angle_deg``, the pair recovered from the draws through the plan's
  pair table;
* the probability the engine gives each pair (found exactly from its own draw
  mapping by bisection over the 64-bit draws) against a brute-force enumeration
  with the exposure ``max(0, -n'.u)`` computed from the facet normal vector;
* pair tables with ``phi_perp = 0`` reproduce the profile engine bit for bit;
* mirror symmetry ``phi_perp -> -phi_perp`` flips the lateral angle;
* scenario files with ``kind = "areal"`` through ``microimpact.run``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from engine_helpers import PowerCoefficients, correlated_areal_angles, scenario
from numpy.testing import assert_allclose, assert_array_equal

import microimpact as mi
from microimpact.engine import kernel
from microimpact.engine.kernel import simulate_block, stream_raw
from microimpact.engine.plan import (
    A_PERP,
    VAR_ANGLE,
    ArealSampler,
    build_plan,
)
from microimpact.errors import ScenarioError
from microimpact.scenario.scenario import SurfaceVariant
from microimpact.surface.angles import angles_from_sample
from microimpact.surface.areal_angles import (
    ArealAngles,
    areal_angles_from_sample,
    gaussian_areal_angles,
)

TWO64 = 2**64
K = 4.0


def _pairs(n=400, seed=5, std_par=18.0, std_perp=14.0, rho=0.3):
    return correlated_areal_angles(n, seed, std_par, std_perp, rho)


def _wrap(d):
    """Angle differences [deg] wrapped into [-180, 180)."""
    return (np.asarray(d) + 180.0) % 360.0 - 180.0


# ------------------------------------------------------------ impacts vs physics
@pytest.mark.parametrize(
    "coeffs, shadowing, angle",
    [
        (PowerCoefficients(friction=0.2), "reject", 80.0),
        (PowerCoefficients(friction=0.15, p=1.7, q=0.6), "none", 20.0),
        (PowerCoefficients(k2=0.2, b=-1.5), "weighted", 45.0),
        (PowerCoefficients(friction=0.05), "weighted", 12.0),
    ],
)
def test_kernel_matches_apparent_rebound(coeffs, shadowing, angle):
    """Each impact: the pair the draw selects in the plan's table, and e_m, mu_m,
    the lateral angle, capture, shadowing and re-impact of apparent_rebound with
    out_of_plane_angle_deg at that pair."""
    surf = _pairs()
    sc = scenario(
        coefficients=coeffs,
        surfaces=(SurfaceVariant("areal", surf),),
        speeds_m_s=(0.35,),
        angles_deg=(angle,),
        shadowing=shadowing,
        speed_spread=0.1,
    )
    plan = build_plan(sc, kernel="numpy")
    assert isinstance(plan.surfaces[0], ArealSampler)
    n = 40_000
    s = simulate_block(plan, 0, 0, 0, n, store=True)
    # the pair of each impact, from the draw through the table
    tables = plan.angle_tables(0, angle)
    rows = tables.areal_cells(stream_raw(plan.entropy, 0, 0, VAR_ANGLE, n))
    par = tables.sampler.values[rows, 0]
    perp = tables.sampler.rows[rows, A_PERP]
    assert_array_equal(s["roughness_angle"], par)
    assert_array_equal(s["out_of_plane_angle"], perp)
    # ... which are pairs of the surface
    known = set(zip(surf.phi_par.tolist(), surf.phi_perp.tolist(), strict=True))
    assert set(zip(par.tolist(), perp.tolist(), strict=True)) <= known

    ref = mi.apparent_rebound(
        s["speed"],
        angle,
        np.rad2deg(par),
        out_of_plane_angle_deg=np.rad2deg(perp),
        k1=s["k1"],
        k2=s["k2"],
        v_c=s["v_c"],
        p=coeffs.p,
        q=coeffs.q,
        friction=coeffs.friction,
    )
    assert_array_equal(s["shadowed"], ref.shadowed)
    assert_array_equal(s["captured"], ref.captured)
    assert_array_equal(s["reimpact"], ref.reimpact)
    assert_allclose(s["e_m"], ref.e_m, rtol=1e-12, atol=1e-12, equal_nan=True)
    assert_allclose(s["mu_m"], ref.mu_m, rtol=1e-12, atol=1e-12, equal_nan=True)
    psi, want = s["lateral_angle_deg"], ref.lateral_angle_deg
    assert_array_equal(np.isnan(psi), np.isnan(want))
    ok = ~np.isnan(psi)
    assert np.abs(_wrap(psi[ok] - want[ok])).max() < 1e-9
    # the out-of-plane tilt matters: a spread of lateral angles, both signs
    assert np.std(psi[ok]) > 1.0 and (psi[ok] > 0).any() and (psi[ok] < 0).any()
    assert s["captured"].any() and (~s["captured"]).any()
    if shadowing == "none":
        assert s["shadowed"].any()
    else:
        assert not s["shadowed"].any()
    # the accumulator path reduces the same impacts
    acc = simulate_block(plan, 0, 0, 0, n)
    hit = ~s["shadowed"]
    assert acc.shadowed == n - hit.sum()
    assert acc.captured == int(s["captured"][hit].sum())
    reb = hit & ~s["captured"]
    assert acc.reimpact == int(s["reimpact"].sum())
    assert_allclose(acc.e.mean, s["e_m"][reb].mean(), rtol=1e-12)
    assert_allclose(acc.mu.mean, s["mu_m"][reb].mean(), rtol=1e-12)


def test_profile_surfaces_report_in_plane_lateral_angles():
    """phi_perp = 0: psi is 0 (forward) or 180 (backward), as apparent_rebound."""
    sc = scenario(
        surfaces=(SurfaceVariant("p", angles_from_sample(np.linspace(-60, 40, 51))),),
        speeds_m_s=(1.0,),
        angles_deg=(70.0,),
        coefficients=PowerCoefficients(friction=0.2, vc_ref=0.01),
    )
    s = mi.sample_point(sc, 0, 5000)
    ref = mi.apparent_rebound(
        s["speed"],
        70.0,
        np.rad2deg(s["roughness_angle"]),
        k1=s["k1"],
        k2=s["k2"],
        v_c=s["v_c"],
        friction=0.2,
    )
    psi = s["lateral_angle_deg"]
    assert_array_equal(psi, ref.lateral_angle_deg)
    assert set(np.unique(psi[~np.isnan(psi)])) == {0.0, 180.0}
    assert_array_equal(s["out_of_plane_angle"], 0.0)


# ---------------------------------------------------------- shadowing of pairs
def engine_pair_probabilities(tables):
    """The exact probability of each row of ``tables.sampler`` under the engine's
    draw mapping (monotone in the draw), by bisection over the 64-bit draws."""
    n = tables.sampler.table.size
    targets = np.arange(n + 1)
    lo = np.zeros(n + 1, dtype=object)
    hi = np.full(n + 1, TWO64, dtype=object)
    for _ in range(66):  # the smallest r whose row is >= target
        active = lo < hi
        if not active.any():
            break
        mid = (lo + hi) // 2
        r = np.array([min(int(m), TWO64 - 1) for m in mid], dtype=np.uint64)
        at_least = (tables.areal_cells(r) >= targets) | (mid >= TWO64)
        hi = np.where(active & at_least, mid, hi)
        lo = np.where(active & ~at_least, mid + 1, lo)
    return np.array(np.diff(lo).tolist(), dtype=float) / 2.0**64


def brute_force(par, perp, theta, shadowing):
    """Pair probabilities from the facet normal n' ~ (-tan par, -tan perp, 1) and
    the incoming direction u = (-cos theta, 0, -sin theta)."""
    n = np.stack([-np.tan(par), -np.tan(perp), np.ones_like(par)], axis=1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    u = np.array([-np.cos(theta), 0.0, -np.sin(theta)])
    exposure = np.maximum(0.0, -(n @ u))
    if shadowing == "weighted":
        mass = exposure / np.sin(theta)  # relative to the nominal surface
    elif shadowing == "reject":
        mass = (exposure > 0).astype(float)
    else:
        mass = np.ones_like(par)
    return mass / mass.sum()


@pytest.mark.parametrize("shadowing", ["reject", "weighted", "none"])
@pytest.mark.parametrize("theta_deg", [7.0, 30.0, 75.0])
def test_each_pair_drawn_with_its_exact_probability(shadowing, theta_deg):
    surf = _pairs(n=300, seed=11, std_par=15.0, std_perp=25.0)
    sc = scenario(
        surfaces=(SurfaceVariant("a", surf),),
        angles_deg=(theta_deg,),
        shadowing=shadowing,
    )
    plan = build_plan(sc, kernel="numpy")
    tables = plan.angle_tables(0, theta_deg)
    theta = np.deg2rad(theta_deg)
    par, perp = surf.phi_par, surf.phi_perp  # sorted like the plan's table
    assert_array_equal(plan.surfaces[0].values[:, 0], par)
    assert_array_equal(plan.surfaces[0].perp, perp)
    want = brute_force(par, perp, theta, shadowing)
    got_rows = engine_pair_probabilities(tables)
    # the rows of the per-angle table are pairs of the surface's table
    index = {p: i for i, p in enumerate(zip(par.tolist(), perp.tolist(), strict=True))}
    rows = [
        index[p]
        for p in zip(
            tables.sampler.values[:, 0].tolist(),
            tables.sampler.rows[:-1, A_PERP].tolist(),
            strict=True,
        )
    ]
    got = np.zeros_like(want)
    got[rows] = got_rows
    assert abs(got.sum() - 1.0) < 1e-15
    assert_allclose(got, want, rtol=0, atol=1e-15)
    # the shadowed fraction: P(phi_par >= theta), whatever phi_perp
    assert abs(tables.shadowed_mass - np.mean(par >= theta)) < 1e-15
    assert tables.count_shadowed == (shadowing == "none")


def test_weighted_exposure_reduces_to_the_profile_weight():
    """With phi_perp = 0 the exposure is sin(theta - phi)_+: the 2-D weights."""
    par = np.deg2rad(np.linspace(-40, 40, 81))
    want = brute_force(par, np.zeros_like(par), np.deg2rad(25.0), "weighted")
    two_d = np.maximum(np.sin(np.deg2rad(25.0) - par), 0.0)
    assert_allclose(want, two_d / two_d.sum(), rtol=1e-13, atol=1e-17)


# --------------------------------------------------- reduction to the profile
@pytest.mark.parametrize("shadowing", ["reject", "weighted", "none"])
@pytest.mark.parametrize("sampling", ["mc", "qmc"])
def test_zero_out_of_plane_reproduces_the_profile_engine(shadowing, sampling):
    """phi_perp = 0 at every pair: the same bits as the profile engine on the same
    in-plane angles, impact by impact and in the accumulators."""
    rng = np.random.default_rng(1)
    a = rng.normal(0.0, 12.0, 3000)
    kw = dict(
        angles_deg=(10.0, 45.0),
        speeds_m_s=(0.35, 1.0),
        shadowing=shadowing,
        coefficients=PowerCoefficients(friction=0.2),
        speed_spread=0.1,
        sampling=sampling,
    )
    areal = areal_angles_from_sample(a, np.zeros_like(a))
    pa = build_plan(scenario(surfaces=(SurfaceVariant("s", areal),), **kw))
    pp = build_plan(
        scenario(surfaces=(SurfaceVariant("s", angles_from_sample(a)),), **kw),
        kernel="numpy",
    )
    assert isinstance(pa.surfaces[0], ArealSampler) and pa.kernel == kernel.KERNEL
    # the areal plan on both kernels (the compiled one where it is built)
    areal_plans = [dataclasses.replace(pa, kernel="numpy")]
    if kernel.KERNEL == "compiled":
        areal_plans.append(dataclasses.replace(pa, kernel="compiled"))
    for point in range(len(pa.points)):
        sa = simulate_block(pa, point, 0, 1, 6000, store=True)
        sp = simulate_block(pp, point, 0, 1, 6000, store=True)
        assert set(sa) == set(sp)
        for key in sp:
            assert_array_equal(sa[key], sp[key], err_msg=key)
        gp = simulate_block(pp, point, 0, 1, 6000)
        for plan in areal_plans:
            ga = simulate_block(plan, point, 0, 1, 6000)
            for f in ("n", "shadowed", "captured", "reimpact", "rolling"):
                assert getattr(ga, f) == getattr(gp, f)
            for m in ("e", "mu", "lateral"):
                assert dataclasses.astuple(getattr(ga, m)) == dataclasses.astuple(
                    getattr(gp, m)
                ), (plan.kernel, m)
            assert_array_equal(ga.e_hist, gp.e_hist)
            assert_array_equal(ga.mu_hist, gp.mu_hist)
            assert_array_equal(ga.lateral_hist, gp.lateral_hist)


# ------------------------------------------------------------ mirror symmetry
def test_mirror_symmetric_surface_gives_a_symmetric_lateral_distribution():
    rng = np.random.default_rng(3)
    a = rng.normal(0.0, 10.0, 200)
    b = np.abs(rng.normal(0.0, 12.0, 200))
    surf = areal_angles_from_sample(np.r_[a, a], np.r_[b, -b])  # (a, b), (a, -b)
    sc = scenario(
        surfaces=(SurfaceVariant("m", surf),),
        speeds_m_s=(1.0,),
        angles_deg=(35.0,),
        coefficients=PowerCoefficients(friction=0.3, vc_ref=0.02),
        speed_spread=0.1,
    )
    s = mi.sample_point(sc, 0, 100_000)
    psi = s["lateral_angle_deg"]
    psi = psi[~np.isnan(psi)]
    assert psi.size > 50_000 and np.std(psi) > 2.0
    se = np.std(psi) / np.sqrt(psi.size)
    assert abs(psi.mean()) < K * se
    # the histogram of psi and of -psi agree bin by bin (binomial counts)
    edges = np.linspace(-60, 60, 25)
    h, _ = np.histogram(psi, edges)
    m, _ = np.histogram(-psi, edges)
    assert np.all(np.abs(h - m) <= K * np.sqrt(h + m + 1.0))


def test_mirrored_surface_mirrors_the_lateral_angle():
    """(phi_par, phi_perp) -> (phi_par, -phi_perp) for every pair: the same draws
    give the same e_m, mu_m and the opposite lateral angle."""
    surf = _pairs(n=500, seed=8)
    mirror = ArealAngles(surf.phi_par, -surf.phi_perp)
    common = dict(
        speeds_m_s=(0.5,),
        angles_deg=(50.0,),
        coefficients=PowerCoefficients(friction=0.2),
    )
    # the tables sort pairs by (phi_par, phi_perp): distinct phi_par keeps the
    # mirrored pairs in the same rows, so the same draws hit mirrored facets
    assert np.unique(surf.phi_par).size == surf.n
    s = mi.sample_point(scenario(surfaces=(SurfaceVariant("a", surf),), **common))
    m = mi.sample_point(scenario(surfaces=(SurfaceVariant("a", mirror),), **common))
    assert_array_equal(m["out_of_plane_angle"], -s["out_of_plane_angle"])
    assert_array_equal(m["e_m"], s["e_m"])
    assert_array_equal(m["mu_m"], s["mu_m"])
    assert_array_equal(m["lateral_angle_deg"], -s["lateral_angle_deg"])


# ----------------------------------------------------------- kernel routing
def test_areal_plans_run_on_either_kernel(monkeypatch):
    """Areal surfaces have a compiled path (issue 24): ``auto`` takes the compiled
    kernel where it is built, and both can be asked for."""
    sc = scenario(surfaces=(SurfaceVariant("a", _pairs(50)),), angles_deg=(40.0,))
    monkeypatch.delenv("MICROIMPACT_KERNEL", raising=False)
    assert build_plan(sc).kernel == kernel.KERNEL
    assert build_plan(sc, kernel="auto").kernel == kernel.KERNEL
    assert build_plan(sc, kernel="numpy").kernel == "numpy"
    if kernel.KERNEL == "compiled":
        assert build_plan(sc, kernel="compiled").kernel == "compiled"
        monkeypatch.setenv("MICROIMPACT_KERNEL", "compiled")
        assert build_plan(sc).kernel == "compiled"


def test_rough_particle_on_an_areal_surface_is_refused():
    sc = scenario(
        surfaces=(SurfaceVariant("a", _pairs(50)),),
        particle_roughness=angles_from_sample([1.0, 2.0]),
    )
    with pytest.raises(ScenarioError, match=r"particle_roughness.*not supported"):
        build_plan(sc, kernel="numpy")


def test_areal_angles_validation_and_description():
    surf = areal_angles_from_sample([10.0, -5.0, 95.0, 3.0], [1.0, 2.0, 0.0, -89.9])
    assert surf.n == 3 and surf.truncated_mass == 0.25
    assert list(surf.phi_par_deg) == sorted(surf.phi_par_deg)
    d = SurfaceVariant("x", surf).describe()
    assert d["kind"] == "areal" and d["n_pairs"] == 3 and d["name"] == "x"
    assert not SurfaceVariant("x", surf).smooth
    assert SurfaceVariant("z", areal_angles_from_sample([0.0], [0.0])).smooth
    with pytest.raises(ValueError, match="NaN"):
        areal_angles_from_sample([1.0, np.nan], [0.0, 0.0])
    with pytest.raises(ValueError, match="one value per pair"):
        areal_angles_from_sample([1.0, 2.0], [0.0])


# ------------------------------------------------------------ scenario files
SCENARIO = """
name = "areal-file"
seed = 7
samples = 3000
shadowing = "{shadowing}"
[particles]
distribution = "monodisperse"
diameter_um = 50
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.2
friction = 0.15
{surfaces}
[sweep]
speed_m_s = [0.5]
angle_deg = [20, 60]
"""

SYNTHETIC = """
[[surfaces]]
name = "gauss"
kind = "areal"
contact_diameter_um = 4
azimuth = "random"
synthetic = { rms_um = 1.0, corr_x_um = 10, corr_y_um = 20, nx = 96, ny = 96, \
dx_um = 1, seed = 3 }
"""

MAP = """
[[surfaces]]
name = "map"
kind = "areal"
file = "map.txt"
dx_um = 1.0
z_unit = "um"
contact_length_um = 4
azimuth_deg = 30
"""


def _write(tmp_path, surfaces, shadowing="weighted"):
    path = tmp_path / "s.toml"
    path.write_text(SCENARIO.format(shadowing=shadowing, surfaces=surfaces))
    return path


def test_scenario_file_with_areal_surfaces_runs_end_to_end(tmp_path):
    hm = mi.gaussian_areal_surface(64, 64, dx_um=1.0, rms_um=1.0, corr_x_um=8, seed=1)
    np.savetxt(tmp_path / "map.txt", hm.z * 1e6)
    path = _write(tmp_path, SYNTHETIC + MAP)
    result = mi.run(path)
    summary = result.summary
    assert list(summary["surface"].unique()) == ["gauss", "map"]
    assert result.provenance["kernel"] == kernel.KERNEL  # either kernel runs it
    assert summary["n"].eq(3000).all()
    # the file's surfaces are the Python factories' surfaces, bit for bit
    sc = result.scenario
    gauss = gaussian_areal_angles(
        nx=96,
        ny=96,
        dx_um=1.0,
        rms_um=1.0,
        corr_x_um=10.0,
        corr_y_um=20.0,
        seed=3,
        contact_diameter_um=4.0,
        azimuth_deg=None,
    )
    assert_array_equal(sc.surfaces[0].angles.phi_par, gauss.phi_par)
    assert_array_equal(sc.surfaces[0].angles.phi_perp, gauss.phi_perp)
    facets = mi.facet_angles(
        mi.read_height_map(tmp_path / "map.txt", dx_um=1.0, z_unit="um"),
        contact_diameter_um=4.0,
        azimuth_deg=30.0,
    )
    want = areal_angles_from_sample(facets.phi_par_deg, facets.phi_perp_deg)
    assert_array_equal(sc.surfaces[1].angles.phi_par, want.phi_par)
    assert_array_equal(sc.surfaces[1].angles.phi_perp, want.phi_perp)
    again = mi.run(
        scenario(
            name="areal-file",
            particles=sc.particles,
            coefficients=sc.coefficients,
            surfaces=(SurfaceVariant("gauss", gauss), sc.surfaces[1]),
            speeds_m_s=(0.5,),
            angles_deg=(20.0, 60.0),
            samples=3000,
            shadowing="weighted",
            seed=7,
        )
    )
    for col in ("capture_fraction", "e_mean", "mu_mean", "shadowed_fraction"):
        assert_array_equal(summary[col].to_numpy(), again.summary[col].to_numpy())


@pytest.mark.parametrize(
    "surfaces, match",
    [
        (
            '[[surfaces]]\nkind = "areal"\ncontact_diameter_um = 4\n',
            r"s\.toml: surfaces\[0\]\.file: give exactly one of 'file' or "
            r"'synthetic'",
        ),
        (
            SYNTHETIC.replace("contact_diameter_um = 4", ""),
            r"surfaces\[0\]\.contact_diameter_um: give exactly one of",
        ),
        (
            SYNTHETIC.replace("seed = 3", "sead = 3"),
            r"surfaces\[0\]\.synthetic\.sead: unknown key 'sead' \(did you mean "
            r"'seed'\?\)",
        ),
        (
            MAP.replace("file = ", "azimuth = 'random'\nfile = "),
            r"surfaces\[0\]\.azimuth: give either 'azimuth_deg' or 'azimuth'",
        ),
        (
            MAP.replace("azimuth_deg = 30", "azimuth_seed = 2"),
            r"surfaces\[0\]\.azimuth_seed: only allowed with azimuth = 'random'",
        ),
        (
            SYNTHETIC.replace("azimuth", "dx_um = 1\nazimuth"),
            r"surfaces\[0\]\.dx_um: only allowed with 'file'",
        ),
        (
            MAP.replace("map.txt", "nowhere.txt"),
            r"surfaces\[0\]\.file: file not found: 'nowhere\.txt'",
        ),
        (
            MAP.replace("contact_length_um = 4", "contact_length_um = 400"),
            r"s\.toml: surfaces\[0\]: the contact patch \(400 µm\) is larger than the "
            r"map",
        ),
    ],
)
def test_areal_scenario_errors_name_the_file_and_key(tmp_path, surfaces, match):
    hm = mi.gaussian_areal_surface(32, 32, dx_um=1.0, rms_um=1.0, corr_x_um=8, seed=1)
    np.savetxt(tmp_path / "map.txt", hm.z * 1e6)
    path = _write(tmp_path, surfaces)
    with pytest.raises(ScenarioError, match=match) as info:
        mi.Scenario.from_toml(path)
    assert "\n" not in str(info.value)


def test_checkpoints_of_areal_runs_name_the_areal_algorithm(monkeypatch):
    """The areal impact's arithmetic changed in its last bits (issue 24): the
    checkpoint fingerprint of an areal plan names it, so a checkpoint written
    before is not resumed; profile plans' fingerprints are untouched."""
    from microimpact.engine.checkpoint import plan_fingerprint

    areal = build_plan(scenario(surfaces=(SurfaceVariant("a", _pairs(50)),)), seed=1)
    profile = build_plan(scenario(angles_deg=(40.0,)), seed=1)
    assert areal.pair_algorithm(0) == ArealSampler.ALGORITHM
    assert profile.pair_algorithm(0) is None
    before = plan_fingerprint(areal, 100), plan_fingerprint(profile, 100)
    monkeypatch.setattr(ArealSampler, "ALGORITHM", "another")
    after = plan_fingerprint(areal, 100), plan_fingerprint(profile, 100)
    assert before[0] != after[0] and before[1] == after[1]
