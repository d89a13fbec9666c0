"""The engine's samplers: no bias from the discretisation, at any N.

Oracles, independent of the tables:

* the capture probability on a smooth surface at normal incidence with a power-law
  ``v_c(d) = a (d / d_ref)^b`` (b < 0): ``P(capture at speed v) = F_D(d*)`` with
  ``d* = d_ref (v / a)^(1/b)``, from SciPy's CDF of the diameter distribution;
* for an empirical sample, the exact fraction of its atoms with ``v_c(d) >= v``;
* the conditional (``"reject"``) and re-weighted (``"weighted"``) angle
  distributions from SciPy's CDF and quadrature.

Two checks each: the *deterministic* error of the table (the probability the table
assigns to the event, computed exactly from its cells) must stay below 0.1 standard
error at N = 1e9 impacts for probabilities from 1e-6 to 1 - 1e-4; and estimates from
1e8 simulated impacts must lie within K standard errors of the closed form. The old
equiprobable 2^16-atom step table fails the first check
(``test_the_old_step_table_fails_the_criterion``), so the check can fail.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from engine_helpers import PowerCoefficients, scenario
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import integrate, stats

from microimpact import SurfaceVariant
from microimpact._core.tables import CellTable, QuantileTable, mulhi64
from microimpact.engine import kernel
from microimpact.engine import plan as plan_module
from microimpact.engine.plan import D_VC, build_plan
from microimpact.population.distributions import (
    empirical_diameters,
    histogram_diameters,
    lognormal_diameters,
    normal_diameters,
)
from microimpact.surface.angles import angles_from_sample, normal_angles

K = 4.0  # simulated estimates sit within K standard errors
N_MAX = 1e9  # the largest N the bias criterion covers
PROBABILITIES = (1e-6, 1e-4, 1e-2, 0.5, 1 - 1e-4)
COEFFS = PowerCoefficients(vc_ref=0.2, b=-1.2)
TWO64 = 2.0**64


def tenth_se(p, n=N_MAX):
    """0.1 standard error of a probability `p` estimated from `n` impacts."""
    return 0.1 * math.sqrt(p * (1.0 - p) / n)


def speed_for(p, dist):
    """Impact speed whose exact capture probability is `p` (smooth, normal)."""
    d_star = float(dist.ppf(p))
    return float(COEFFS.v_c(d_star))


def exact_capture(v, dist):
    d_star = COEFFS.d_ref * (v / COEFFS.vc_ref) ** (1.0 / COEFFS.b)
    return float(dist.cdf(d_star))


def table_capture(plan, v):
    """The capture probability the plan's diameter table assigns at speed `v`:
    P(v_c >= v) with v_c interpolated in each cell, exactly as the kernels do."""
    rows = plan.diameters.rows[:-1]
    lo, span = rows[:, D_VC], rows[:, D_VC + 1]
    return plan.diameters.table.probability_at_least(lo, lo + span, v)


def simulated_capture(plan, point, n):
    """(captured, n) from `n` impacts of the compiled or NumPy kernel."""
    b = plan.block_size
    specs = [(point, 0, k, min(b, n - k * b)) for k in range(math.ceil(n / b))]
    captured = sum(acc.captured for acc in kernel.simulate_specs(plan, specs))
    return captured, n


def _continuous_diameters():
    return {
        "lognormal": lognormal_diameters(45.0, 1.5),
        "truncnorm": normal_diameters(52.8, 15.3),
    }


# --------------------------------------------------- deterministic table error
@pytest.mark.parametrize("name", ["lognormal", "truncnorm"])
def test_table_capture_error_is_below_a_tenth_se_at_1e9(name):
    dist = _continuous_diameters()[name]
    speeds = tuple(speed_for(p, dist) for p in PROBABILITIES)
    plan = build_plan(scenario(particles=dist, coefficients=COEFFS, speeds_m_s=speeds))
    for p, v in zip(PROBABILITIES, speeds, strict=True):
        exact = exact_capture(v, dist)
        assert_allclose(exact, p, rtol=1e-6)  # the oracle inverts
        err = abs(table_capture(plan, v) - exact)
        assert err < tenth_se(exact), f"p={p:g}: error {err:.3g}"


def test_the_old_step_table_fails_the_criterion(monkeypatch):
    """The 2^16 equiprobable step atoms the engine used to draw from: the same
    check goes red (the criterion can fail)."""
    dist = _continuous_diameters()["lognormal"]

    def step_table(d):
        return CellTable.from_atoms(QuantileTable.from_ppf(d.ppf).values)

    monkeypatch.setattr(plan_module, "cell_table", step_table)
    speeds = tuple(speed_for(p, dist) for p in PROBABILITIES)
    plan = build_plan(scenario(particles=dist, coefficients=COEFFS, speeds_m_s=speeds))
    ratios = [
        abs(table_capture(plan, v) - exact_capture(v, dist))
        / tenth_se(exact_capture(v, dist))
        for v in speeds
    ]
    assert max(ratios) > 10.0


def test_empirical_sample_is_drawn_exactly():
    rng = np.random.default_rng(7)
    sample_um = rng.lognormal(np.log(45.0), 0.4, 4000)
    dist = empirical_diameters(sample_um)
    plan = build_plan(scenario(particles=dist, coefficients=COEFFS))
    v_c = COEFFS.v_c(np.sort(dist.atoms))
    for v in np.quantile(v_c, [0.0003, 0.01, 0.5, 0.9999]):
        exact = np.count_nonzero(v_c >= v) / 4000
        assert abs(table_capture(plan, v) - exact) < 1e-15


def test_histogram_is_sampled_exactly():
    dist = histogram_diameters([10.0, 30.0, 50.0, 80.0, 120.0], [1, 5, 3, 1])
    table = plan_module.cell_table(dist)
    x = np.linspace(10e-6, 120e-6, 1001)
    got = np.array(
        [1.0 - table.probability_at_least(table.left, table.right, v) for v in x]
    )
    assert_allclose(got, dist.cdf(x), atol=1e-12)


def test_speed_factor_table():
    sigma = 0.1
    table = plan_module._speed_factor_table(sigma)
    exact = stats.truncnorm(-1 / sigma, 1 / sigma, loc=1.0, scale=sigma)
    for p in PROBABILITIES:
        x = exact.ppf(p)
        got = 1.0 - table.probability_at_least(table.left, table.right, x)
        assert abs(got - p) < tenth_se(p), p


# -------------------------------------------------------------------- angles
def _angle_cdf(tables, x):
    """P(phi <= x) under the sampled angle distribution of an AngleTables."""
    t, values = tables.sampler.table, tables.sampler.values
    lo, span = values[:, 0], values[:, 1]
    w = t.widths()
    scale = t.inv_width * (w * TWO64)  # the fraction's range [0, scale) per cell
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(
            span > 0, np.clip((x - lo) / (span * scale), 0, 1), (lo <= x) * 1.0
        )
    below = float(np.sum(w * frac))
    if tables.cut:  # 'reject': draws scaled to [0, cut)
        return min(below, tables.cut / TWO64) / (tables.cut / TWO64)
    return below


@pytest.mark.parametrize("theta_deg", [10.0, 20.0, 45.0])
def test_reject_is_the_conditional_distribution(theta_deg):
    dist = normal_angles(10.0)
    sc = scenario(surfaces=(SurfaceVariant("n", dist),), angles_deg=(theta_deg,))
    tables = build_plan(sc).angle_tables(0, theta_deg)
    theta = np.deg2rad(theta_deg)
    f_theta = float(dist.cdf(theta))
    assert abs(tables.shadowed_mass - (1.0 - f_theta)) < tenth_se(1.0 - f_theta)
    for p in PROBABILITIES:
        x = float(dist.ppf(p * f_theta))
        assert abs(_angle_cdf(tables, x) - p) < tenth_se(p), p


@pytest.mark.parametrize("theta_deg", [12.0, 30.0])
def test_weighted_is_the_sommerfeld_huber_distribution(theta_deg):
    dist = normal_angles(10.0)
    sc = scenario(
        surfaces=(SurfaceVariant("n", dist),),
        angles_deg=(theta_deg,),
        shadowing="weighted",
    )
    tables = build_plan(sc).angle_tables(0, theta_deg)
    theta = np.deg2rad(theta_deg)
    std = np.deg2rad(10.0)

    def weighted(a, b):
        return integrate.quad(
            lambda p: dist.pdf(p) * np.sin(theta - p), a, b, epsabs=0, epsrel=1e-12
        )[0]

    total = weighted(-12 * std, 0.0) + weighted(0.0, theta)
    for x in np.deg2rad([-30.0, -10.0, 0.0, theta_deg / 2, theta_deg - 0.5]):
        exact = (weighted(-12 * std, min(x, 0.0)) + weighted(min(x, 0.0), x)) / total
        assert abs(_angle_cdf(tables, x) - exact) < tenth_se(exact), x


def test_none_counts_the_exact_shadowed_fraction():
    dist = normal_angles(10.0)
    sc = scenario(surfaces=(SurfaceVariant("n", dist),), shadowing="none")
    tables = build_plan(sc).angle_tables(0, 20.0)
    exact = float(dist.sf(np.deg2rad(20.0)))
    assert tables.cut == 0
    assert abs(tables.shadowed_mass - exact) < tenth_se(exact)


def test_particle_roughness_convolution_error_is_bounded():
    """Surface + particle roughness (two normals): the combined table is the exact
    convolution to far below the Monte Carlo error
    (tests/engine/test_sampling_particle.py checks it against 0.1 SE at 1e9; this is a
    coarse, independent check)."""
    a, b = normal_angles(8.0), normal_angles(6.0)
    table = plan_module.convolve_angles(a, b)
    exact = stats.norm(0.0, np.deg2rad(10.0))
    x = exact.ppf(np.linspace(0.001, 0.999, 999))
    got = np.array(
        [1.0 - table.probability_at_least(table.left, table.right, v) for v in x]
    )
    assert np.max(np.abs(got - exact.cdf(x))) < 1e-6


# ----------------------------------------------------- simulated, 1e8 impacts
def _capture_run(dist, p, n):
    v = speed_for(p, dist) if not hasattr(dist, "atoms") or dist.atoms is None else p
    plan = build_plan(scenario(particles=dist, coefficients=COEFFS, speeds_m_s=(v,)))
    captured, n = simulated_capture(plan, 0, n)
    return captured / n, v, plan


@pytest.mark.parametrize("n", [10**7, pytest.param(10**8, marks=pytest.mark.slow)])
def test_capture_rare_event_simulated(n):
    """p near 1e-4 (at 1e8 impacts the old tables were ~7 SE high here; 1e8 takes
    ~5-15 s on one shared core, so the default suite runs 1e7)."""
    dist = _continuous_diameters()["lognormal"]
    est, v, _ = _capture_run(dist, 1e-4, n)
    exact = exact_capture(v, dist)
    assert abs(est - exact) < K * math.sqrt(exact * (1 - exact) / n)


@pytest.mark.slow
@pytest.mark.parametrize("p", [1e-6, 0.5, 1 - 1e-4])
@pytest.mark.parametrize("name", ["lognormal", "truncnorm"])
def test_capture_at_1e8_impacts(name, p):
    dist = _continuous_diameters()[name]
    est, v, _ = _capture_run(dist, p, 10**8)
    exact = exact_capture(v, dist)
    assert abs(est - exact) < K * math.sqrt(exact * (1 - exact) / 1e8)


@pytest.mark.parametrize("n", [10**7, pytest.param(10**8, marks=pytest.mark.slow)])
def test_empirical_capture_simulated(n):
    rng = np.random.default_rng(11)
    dist = empirical_diameters(rng.lognormal(np.log(45.0), 0.4, 4000))
    v_c = COEFFS.v_c(dist.atoms)
    v = float(np.quantile(v_c, 0.99))  # ~1% of the atoms are captured
    exact = np.count_nonzero(v_c >= v) / 4000
    plan = build_plan(scenario(particles=dist, coefficients=COEFFS, speeds_m_s=(v,)))
    captured, n = simulated_capture(plan, 0, n)
    assert abs(captured / n - exact) < K * math.sqrt(exact * (1 - exact) / n)


def test_qmc_maps_the_full_precision_uniform():
    dist = _continuous_diameters()["truncnorm"]
    v = speed_for(0.3, dist)
    sc = scenario(
        particles=dist,
        coefficients=COEFFS,
        speeds_m_s=(v,),
        sampling="qmc",
        qmc_replicates=4,
    )
    plan = build_plan(sc)
    caps = [
        kernel.simulate_block(plan, 0, rep, 0, 1 << 14).captured / (1 << 14)
        for rep in range(plan.replicates)
    ]
    exact = exact_capture(v, dist)
    # scrambled Sobol in 1-d: the error is far below MC's sqrt(p(1-p)/n)
    assert abs(np.mean(caps) - exact) < 0.1 * math.sqrt(exact * (1 - exact) / 2**16)


# ------------------------------------------------------------ the primitives
def test_cells_are_located_exactly():
    rng = np.random.default_rng(3)
    t = CellTable.from_atoms(rng.normal(size=37))
    r = rng.integers(0, 2**64 - 1, 10_000, dtype=np.uint64, endpoint=True)
    j, _ = t.locate(r)
    # equal cells: cell j holds the draws with floor(r n / 2^64) = j
    assert np.array_equal(j, mulhi64(r, 37).astype(np.intp))
    g = CellTable.from_quantile(stats.norm.ppf, stats.norm.isf)
    assert g.kind == CellTable.DYADIC
    # the refined grid's arithmetic cells are the cells a search finds, also at
    # every cell start, next to it and at the powers of two
    one = np.uint64(1)
    powers = np.array(
        [(2**b + d) % 2**64 for b in range(64) for d in (-1, 0, 1)], dtype=np.uint64
    )
    with np.errstate(over="ignore"):
        edges = np.concatenate([g.starts, g.starts - one, g.starts + one, powers])
    for x in (r, edges, ~edges, r >> np.uint64(40), ~(r >> np.uint64(40))):
        x = np.asarray(x, dtype=np.uint64)
        search = np.searchsorted(g.starts, x, side="right") - 1
        assert np.array_equal(g.cells(x), search)
    j, f = g.locate(r)
    assert np.all((f >= 0) & (f < 1))
    assert np.all((g.starts[j] <= r) & ((j == g.size - 1) | (g.cum[j + 1] > r)))


def test_mulhi64_is_the_128_bit_product():
    rng = np.random.default_rng(5)
    a = rng.integers(0, 2**64 - 1, 1000, dtype=np.uint64, endpoint=True)
    for b in (1, 3, 2**63, 2**64 - 1, 12345678901234567):
        got = mulhi64(a, b)
        want = [(int(x) * b) >> 64 for x in a]
        assert [int(x) for x in got] == want


def test_equal_cells_hold_exact_probabilities():
    t = CellTable.from_atoms(np.arange(4000.0))
    starts = [int(c) for c in t.starts] + [2**64]
    widths = {b - a for a, b in itertools.pairwise(starts)}
    assert widths <= {2**64 // 4000, 2**64 // 4000 + 1}


def test_kernels_agree_on_the_capture_counts():
    dist = _continuous_diameters()["lognormal"]
    plan = build_plan(
        scenario(
            particles=dist, coefficients=COEFFS, speeds_m_s=(speed_for(0.01, dist),)
        )
    )
    other = dataclasses.replace(
        plan, kernel="numpy" if plan.kernel == "compiled" else "compiled"
    )
    if other.kernel == "compiled" and kernel.KERNEL != "compiled":
        pytest.skip("the compiled kernel is not built")
    a = kernel.simulate_block(plan, 0, 0, 0, 20_000).to_arrays()
    b = kernel.simulate_block(other, 0, 0, 0, 20_000).to_arrays()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])


def test_simulate_specs_equals_simulate_block_per_spec():
    sc = scenario(
        surfaces=(SurfaceVariant("n", normal_angles(8.0)),),
        speeds_m_s=(0.2, 0.6),
        angles_deg=(30.0, 70.0),
        speed_spread=0.05,
    )
    plan = build_plan(sc)
    specs = [(p, 0, b, n) for p in range(4) for b, n in ((0, 4000), (3, 1))]
    got = kernel.simulate_specs(plan, specs)
    assert len(got) == len(specs)
    for acc, spec in zip(got, specs, strict=True):
        want = kernel.simulate_block(plan, *spec).to_arrays()
        for key, value in acc.to_arrays().items():
            np.testing.assert_array_equal(value, want[key], err_msg=f"{key} {spec}")


# ------------------------------------------- rough particles on discrete surfaces
def _pair_scenario(shadowing, angles=(15.0, 60.0)):
    rng = np.random.default_rng(2)
    surf = angles_from_sample(rng.normal(0.0, 12.0, 1500))
    part = angles_from_sample(rng.normal(0.0, 8.0, 700))
    sc = scenario(
        coefficients=PowerCoefficients(friction=0.15),
        surfaces=(SurfaceVariant("s", surf),),
        particle_roughness=part,
        speeds_m_s=(0.3,),
        angles_deg=angles,
        shadowing=shadowing,
    )
    return sc, np.sort(surf.atoms), np.sort(part.atoms)


@pytest.mark.parametrize("shadowing", ["reject", "none"])
def test_rough_particle_pairs_are_drawn_exactly(shadowing):
    """Both angle distributions discrete: the pair (a_i, b_j) is drawn among the
    n_a n_b equiprobable pairs (the reachable ones for 'reject'), no convolution."""
    sc, a, b = _pair_scenario(shadowing)
    plan = build_plan(sc)
    assert isinstance(plan.surfaces[0], plan_module.PairSampler)
    theta = np.deg2rad(15.0)
    tables = plan.angle_tables(0, 15.0)
    # reachable, sin(theta - a_i - b_j) > 0: theta - pi < a_i + b_j < theta, a
    # range of the sorted b_j for each a_i (no pair leans back past -90 deg here)
    reach = np.searchsorted(b, theta - a, side="left") - np.searchsorted(
        b, theta - np.pi - a, side="right"
    )
    assert abs(tables.shadowed_mass - (1 - reach.sum() / (a.size * b.size))) < 1e-12
    # each surface atom's cell holds exactly its reachable (or all) partner atoms
    starts = tables.sampler.table.starts >> np.uint64(tables.pair_shift)
    counts = np.diff(np.append(starts.astype(np.int64), tables.pair_total))
    want = reach if shadowing == "reject" else np.full(a.size, b.size)
    assert np.array_equal(counts, want[want > 0])
    # the draws: pair ranks uniform, the angle is a_i + b_j
    r = np.random.default_rng(0).integers(0, 2**64 - 1, 20_000, np.uint64, True)
    _, i, j = tables.pair_draws(r)
    phi = tables.sampler.values[i, 0] + tables.pair.values[j, 0]
    if shadowing == "reject":
        assert np.all(phi < theta)


def test_rough_particle_pairs_match_the_reference_physics():
    from microimpact import apparent_rebound
    from microimpact.engine.montecarlo import sample_point

    sc, _, _ = _pair_scenario("reject", angles=(40.0,))
    s = sample_point(sc, 0, 20_000)
    ref = apparent_rebound(
        s["speed"],
        40.0,
        np.rad2deg(s["roughness_angle"]),
        k1=s["k1"],
        k2=s["k2"],
        v_c=s["v_c"],
        friction=0.15,
    )
    assert_array_equal_or_close = np.testing.assert_allclose
    np.testing.assert_array_equal(s["captured"], ref.captured)
    assert_array_equal_or_close(s["e_m"], ref.e_m, rtol=1e-9, atol=1e-12)
    assert_array_equal_or_close(
        s["mu_m"], ref.mu_m, rtol=1e-9, atol=1e-12, equal_nan=True
    )


@settings(max_examples=60, deadline=None)
@given(d_um=st.floats(min_value=0.01, max_value=5000.0, allow_nan=False))
def test_one_atom_table_is_the_cells_of_monodisperse_bit_for_bit(d_um):
    """The wall law's per-diameter table (one template, its atom replaced) is
    every field of cell_table(monodisperse(d)), and so is the sampler the
    plan makes of it."""
    import dataclasses

    from microimpact.engine._cells import cell_table, one_atom_table
    from microimpact.engine.plan import diameter_sampler
    from microimpact.population.distributions import monodisperse
    from microimpact.scenario import load_preset
    from microimpact.units import um_to_m

    ref = cell_table(monodisperse(d_um))
    got = one_atom_table(um_to_m(d_um))
    for f in dataclasses.fields(ref):
        a, b = getattr(ref, f.name), getattr(got, f.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and np.array_equal(a, b), f.name
            assert not b.flags.writeable, f.name
        else:
            assert a == b, f.name
    sc = _PRESET.get("sc") or _PRESET.setdefault(
        "sc", load_preset("sst76-formica-oblique")
    )
    s_ref = diameter_sampler(sc, monodisperse(d_um))
    s_got = diameter_sampler(sc, table=got)
    for f in dataclasses.fields(s_ref):
        a, b = getattr(s_ref, f.name), getattr(s_got, f.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), f.name
        elif not isinstance(a, type(ref)):
            assert a == b or (a != a and b != b), f.name


def _law_strategy():
    """Coefficient laws of every kind the scenario files make, with random
    parameters (the wall law evaluates them over all its diameters at once)."""
    from microimpact.physics import coefficients as c

    pos = st.floats(min_value=1e-3, max_value=10.0)
    d_ref = st.floats(min_value=1e-6, max_value=1e-4)
    table = st.lists(
        st.floats(min_value=1e-6, max_value=1e-3), min_size=2, max_size=5, unique=True
    ).flatmap(
        lambda ds: st.tuples(
            st.just(tuple(sorted(ds))),
            st.lists(pos, min_size=len(ds), max_size=len(ds)).map(tuple),
            st.sampled_from(("clamp", "loglinear")),
        )
    )
    return st.one_of(
        st.builds(c.PowerLaw, pos, st.floats(min_value=-3.0, max_value=3.0), d_ref),
        st.builds(
            c.PolynomialLaw,
            st.lists(pos, min_size=1, max_size=4).map(tuple),
            d_ref,
        ),
        table.map(lambda t: c.TableLaw(*t)),
        pos.map(c.ConstantLaw),
        st.builds(
            c.ThorntonNingLaw,
            st.floats(min_value=500.0, max_value=20000.0),
            st.floats(min_value=1e8, max_value=1e12),
            st.floats(min_value=1e-3, max_value=1.0),
        ),
        st.just(c.CallableLaw(lambda d: 0.3 * np.sqrt(d / 5e-5))),
    )


@settings(max_examples=80, deadline=None)
@given(
    laws=st.tuples(_law_strategy(), _law_strategy(), _law_strategy()),
    d_um=st.lists(st.floats(min_value=0.05, max_value=2000.0), min_size=1, max_size=20),
)
def test_atom_samplers_are_the_generic_diameter_samplers_bit_for_bit(laws, d_um):
    """A wall law's diameter plans (the laws evaluated once over all its
    diameters, each sampler's rows written directly: plan.atom_columns and
    atom_sampler) are every field of the generic path's sampler of each
    diameter alone (diameter_sampler of its one-atom table), for every kind of
    coefficient law."""
    import dataclasses
    import types

    from microimpact.engine._cells import one_atom_table
    from microimpact.engine.plan import atom_columns, atom_sampler, diameter_sampler
    from microimpact.errors import ScenarioError
    from microimpact.physics.coefficients import ImpactCoefficients
    from microimpact.units import um_to_m

    sc = types.SimpleNamespace(
        coefficients=ImpactCoefficients(*laws, friction=0.2), source=None
    )
    d = um_to_m(np.asarray(d_um))
    try:
        refs = [diameter_sampler(sc, table=one_atom_table(x)) for x in d]
    except ScenarioError:  # a law negative somewhere: refused as well
        with pytest.raises(ScenarioError, match="coefficients must be >= 0"):
            atom_columns(sc, d)
        return
    columns = atom_columns(sc, d)
    for x, row, ref in zip(d, columns, refs, strict=True):
        got = atom_sampler(x, row)
        for f in dataclasses.fields(ref):
            a, b = getattr(ref, f.name), getattr(got, f.name)
            if f.name == "table":  # (one_atom_table: tested above)
                a, b = vars(a), vars(b)
                assert a.keys() == b.keys()
                assert all(np.array_equal(a[k], b[k]) for k in a), f.name
            else:
                assert a.dtype == b.dtype and a.shape == b.shape, f.name
                assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), f.name
                assert not b.flags.writeable, f.name


_PRESET: dict = {}
