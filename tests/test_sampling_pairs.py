"""A rough particle on a discrete surface, pairs drawn by a search: exact.

When both angle distributions are discrete but the equiprobable pair ranks do not
apply (``"weighted"`` shadowing, or unequal masses) and the pairs are too many to
tabulate their sums (more than ``MAX_SUM_ATOMS``, e.g. the Formica angles with
themselves: 16 M pairs), the engine draws the pair ``(a_i, b_j)`` by a search
(``plan.PairSearch``). Oracles, computed here by brute force over every pair:

* ``"weighted"``: ``P(i, j) ∝ w_i v_j sin(theta - a_i - b_j)_+`` (Sommerfeld &
  Huber), with ``np.sin`` of the sum;
* ``"reject"``: ``∝ w_i v_j`` over the reachable pairs; ``"none"``: ``w_i v_j``.

The probability the engine gives each pair is found exactly from its own draw
mapping (``AngleTables.pair_draws``), by bisection over the 64-bit draws; the
reduced 1,024-atom convolution used before fails the same check.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from engine_helpers import PowerCoefficients, scenario

from microimpact import SurfaceVariant
from microimpact._distributions import DiscreteAtoms
from microimpact.engine import kernel
from microimpact.engine import plan as plan_module
from microimpact.engine.plan import build_plan
from microimpact.scenario import Scenario
from microimpact.surface.angles import AngleDistribution, angles_from_sample

TWO64 = 2**64
N_MAX = 1e9
K = 4.0


def tenth_se(p, n=N_MAX):
    p = np.asarray(p, dtype=float)
    return 0.1 * np.sqrt(p * (1.0 - p) / n)


def weighted_angles(atoms_deg, weights):
    return AngleDistribution(
        "empirical", {}, None, DiscreteAtoms(np.deg2rad(atoms_deg), weights)
    )


def brute_force(a, w, b, v, theta, shadowing):
    """Exact pair probabilities (n_a, n_b) over the sorted atoms."""
    phi = a[:, None] + b[None, :]
    mass = w[:, None] * v[None, :]
    if shadowing == "weighted":
        mass = mass * np.maximum(np.sin(theta - phi), 0.0)
    elif shadowing == "reject":
        mass = mass * (phi < theta)
    return mass / mass.sum()


def engine_pair_probabilities(tables, n_b):
    """The exact probability of every (surface cell, particle atom) pair under the
    engine's draw mapping: the draw ``r`` gives a pair, monotonically in ``r``
    (cell by cell, atom by atom), so the first draw of each pair is found by
    bisection over the 64-bit integers."""
    starts = tables.sampler.table.cum[:-1].astype(object)
    n_cells = starts.size
    ends = [*starts[1:], TWO64]
    cells, atoms = np.meshgrid(np.arange(n_cells), np.arange(n_b + 1), indexing="ij")
    cells, atoms = cells.ravel(), atoms.ravel()
    lo = np.array([int(starts[i]) for i in cells], dtype=object)
    hi = np.array([int(ends[i]) for i in cells], dtype=object)  # first r of atom j
    for _ in range(66):  # smallest r in [lo, hi] whose atom is >= j
        mid = (lo + hi) // 2
        active = lo < hi
        if not active.any():
            break
        r = np.array([min(int(m), TWO64 - 1) for m in mid], dtype=np.uint64)
        _, i, j = tables.pair_draws(r)
        at_least = (j >= atoms) | (i != cells)
        hi = np.where(active & at_least, mid, hi)
        lo = np.where(active & ~at_least, mid + 1, lo)
    first = lo.reshape(n_cells, n_b + 1)
    width = np.diff(first, axis=1)
    return np.array(width.tolist(), dtype=float) / 2.0**64


def _moderate(shadowing, weighted_masses=False, wide=False):
    rng = np.random.default_rng(4)
    a_deg = rng.normal(2.0, 14.0, 90)
    b_deg = rng.normal(-1.0, 9.0, 70)
    if wide:  # steep facets: some pairs lean back past -90 deg (a + b < theta - 180)
        a_deg = rng.uniform(-88.0, 80.0, 60)
        b_deg = rng.uniform(-88.0, 80.0, 50)
    if weighted_masses:
        surf = weighted_angles(a_deg, rng.uniform(0.2, 3.0, a_deg.size))
        part = weighted_angles(b_deg, rng.uniform(0.2, 3.0, b_deg.size))
    else:
        surf, part = angles_from_sample(a_deg), angles_from_sample(b_deg)
    return surf, part


@pytest.mark.parametrize(
    ("shadowing", "weighted_masses", "wide"),
    [
        ("weighted", False, False),
        ("weighted", True, False),
        ("reject", True, False),
        ("none", True, False),
        ("weighted", True, True),
    ],
)
@pytest.mark.parametrize("theta_deg", [12.0, 35.0, 80.0])
def test_search_draws_each_pair_with_its_exact_probability(
    monkeypatch, shadowing, weighted_masses, wide, theta_deg
):
    """With ``wide``, at 80 deg some pairs lean back past -90 deg (``a + b <
    theta - 180``): ``sin(theta - a - b) < 0`` although ``a + b < theta``, and
    'weighted' gives them no weight."""
    monkeypatch.setattr(plan_module, "MAX_SUM_ATOMS", 0)  # a search at any size
    surf, part = _moderate(shadowing, weighted_masses, wide)
    sc = scenario(
        surfaces=(SurfaceVariant("s", surf),),
        particle_roughness=part,
        angles_deg=(theta_deg,),
        shadowing=shadowing,
    )
    plan = build_plan(sc, kernel="numpy")
    assert isinstance(plan.surfaces[0], plan_module.PairSearch)
    tables = plan.angle_tables(0, theta_deg)
    a, b = np.asarray(surf.atoms), np.asarray(part.atoms)
    w = np.asarray(surf.weights) if surf.weights is not None else np.ones(a.size)
    v = np.asarray(part.weights) if part.weights is not None else np.ones(b.size)
    theta = np.deg2rad(theta_deg)
    want = brute_force(a, w / w.sum(), b, v / v.sum(), theta, shadowing)
    got = np.zeros_like(want)
    # the engine's cells are the surface atoms with positive weight
    cell_atoms = tables.sampler.values[:, 0]
    rows = np.searchsorted(a, cell_atoms)
    got[rows] = engine_pair_probabilities(tables, b.size)
    assert abs(got.sum() - 1.0) < 1e-15
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    # the shadowed fraction: P(phi >= theta) of the unweighted pairs
    plain = brute_force(a, w / w.sum(), b, v / v.sum(), theta, "none")
    shadowed = plain[(a[:, None] + b[None, :]) >= theta].sum()
    assert abs(tables.shadowed_mass - shadowed) < 1e-13


def test_search_is_used_beyond_max_sum_atoms_only():
    surf, part = _moderate("weighted")  # 90 x 70 pairs: the exact sum atoms
    sc = scenario(
        surfaces=(SurfaceVariant("s", surf),),
        particle_roughness=part,
        shadowing="weighted",
    )
    assert not isinstance(build_plan(sc).surfaces[0], plan_module.PairSearch)


def test_both_kernels_draw_the_same_pairs(monkeypatch):
    """Compiled and NumPy kernels: the same search, the same bits."""
    monkeypatch.setattr(plan_module, "MAX_SUM_ATOMS", 0)
    cases = [
        (_moderate("weighted", weighted_masses=True), shadowing)
        for shadowing in ("weighted", "reject", "none")
    ]
    cases.append((_moderate("weighted", weighted_masses=True, wide=True), "weighted"))
    for (surf, part), shadowing in cases:
        sc = scenario(
            coefficients=PowerCoefficients(friction=0.15),
            surfaces=(SurfaceVariant("s", surf),),
            particle_roughness=part,
            speeds_m_s=(0.3,),
            angles_deg=(5.0, 30.0, 90.0),
            shadowing=shadowing,
        )
        plan = build_plan(sc, kernel="numpy")
        if kernel.KERNEL != "compiled":
            pytest.skip("compiled kernel not built")
        compiled = dataclasses.replace(plan, kernel="compiled")
        for point in range(len(plan.points)):
            want = kernel.simulate_block(plan, point, 0, 0, 3000).to_arrays()
            got = kernel.simulate_block(compiled, point, 0, 0, 3000).to_arrays()
            for key, value in got.items():
                np.testing.assert_array_equal(value, want[key], err_msg=key)


# ------------------------------------------------------ Formica x Formica, 16 M
THETA_DEG = 30.0


@pytest.fixture(scope="module")
def formica():
    sc = Scenario.from_preset("lycopodium-formica-oblique")
    sc = dataclasses.replace(
        sc, shadowing="weighted", angles_deg=(THETA_DEG,), speeds_m_s=(2.0,)
    )
    a = np.sort(np.asarray(sc.surfaces[0].angles.atoms))
    b = np.sort(np.asarray(sc.particle_roughness.atoms))
    return sc, a, b


def exact_weighted_cdf(a, b, theta, x):
    """Brute force over every pair: P(phi <= x) of the weighted law, per `x`."""
    x = np.asarray(x, dtype=float)
    below = np.zeros(x.size)
    total = 0.0
    for i0 in range(0, a.size, 128):
        phi = (a[i0 : i0 + 128, None] + b[None, :]).ravel()
        wt = np.maximum(np.sin(theta - phi), 0.0)
        order = np.argsort(phi)
        phi, wt = phi[order], np.cumsum(wt[order])
        k = np.searchsorted(phi, x, side="right")
        below += np.where(k > 0, wt[np.maximum(k - 1, 0)], 0.0)
        total += wt[-1]
    return below / total


def table_cdf(tables, x):
    """What the engine's tables give P(phi <= x), exactly (to ~1e-16): per
    surface cell its probability times the conditional mass of the particle atoms
    at or below ``x - a_i`` (a search table), or the table's own CDF."""
    x = np.asarray(x, dtype=float)
    if not tables.pair_search:
        v = tables.sampler.values
        return np.array(
            [
                1.0
                - tables.sampler.table.probability_at_least(
                    v[:, 0], v[:, 0] + v[:, 1], np.nextafter(xx, np.inf)
                )
                for xx in x
            ]
        )
    rows = tables.sampler.rows[:-1]
    q = tables.sampler.table.widths()
    alpha, beta = rows[:, plan_module.Q_ALPHA], rows[:, plan_module.Q_BETA]
    count = rows[:, plan_module.Q_COUNT].astype(np.int64)
    total = rows[:, plan_module.Q_TOTAL]
    p1 = tables.pair.rows[:, plan_module.P_ONE]
    p2 = tables.pair.rows[:, plan_module.P_TWO]
    a = tables.sampler.values[:, 0]
    b = tables.pair.values[:, 0]
    out = np.empty(x.size)
    for k, xx in enumerate(x):
        m = np.minimum(np.searchsorted(b, xx - a, side="right"), count)
        out[k] = np.sum(q * (alpha * p1[m] + beta * p2[m]) / total)
    return out


def _cdf_errors(sc, a, b):
    plan = build_plan(sc, kernel="numpy")
    tables = plan.angle_tables(0, THETA_DEG)
    theta = np.deg2rad(THETA_DEG)
    x = np.deg2rad(np.linspace(-40.0, THETA_DEG, 141))
    exact = exact_weighted_cdf(a, b, theta, x)
    keep = (exact > 1e-6) & (exact < 1 - 1e-6)
    err = np.abs(table_cdf(tables, x[keep]) - exact[keep])
    p = np.minimum(exact[keep], 1 - exact[keep])
    return err, p, tables


def test_formica_pairs_weighted_cdf_within_a_tenth_se_at_1e9(formica):
    sc, a, b = formica
    err, p, tables = _cdf_errors(sc, a, b)
    assert tables.pair_search
    ratio = err / tenth_se(p)
    assert ratio.max() < 1e-3, ratio.max()  # exact to round-off


def test_the_old_reduced_convolution_fails_the_criterion(formica, monkeypatch):
    """Mutation: without the pair search the plan falls back to the reduced
    1,024-atom convolution (the code before), which the same check rejects."""
    sc, a, b = formica
    monkeypatch.setattr(plan_module, "MAX_SUM_ATOMS", 1 << 62)
    err, p, tables = _cdf_errors(sc, a, b)
    assert not tables.pair_search
    assert (err / tenth_se(p)).max() > 1.0


def _capture_case(formica, speed):
    sc, a, b = formica
    vc = 0.2  # m/s, the same for every diameter (b = 0): capture iff u <= vc
    sc = dataclasses.replace(
        sc,
        coefficients=PowerCoefficients(k1=4.0, k2=0.05, vc_ref=vc, b=0.0),
        speeds_m_s=(speed,),
        speed_spread=0.0,
    )
    theta = np.deg2rad(THETA_DEG)
    # capture iff speed sin(theta - phi) <= vc, i.e. phi >= theta - asin(vc/speed)
    x = theta - math.asin(vc / speed)
    exact = 1.0 - exact_weighted_cdf(a, b, theta, np.array([np.nextafter(x, -1)]))[0]
    return sc, exact


@pytest.mark.parametrize(
    ("n", "speed"),
    [
        (10**7, 8.0),
        pytest.param(10**8, 8.0, marks=pytest.mark.slow),
        pytest.param(10**8, 20.0, marks=pytest.mark.slow),
    ],
)
def test_formica_pairs_rare_capture_simulated(formica, n, speed):
    """A rare capture (p ~ 1e-4 at 8 m/s, ~2e-5 at 20 m/s) under 'weighted'
    shadowing, simulated, against the brute-force probability."""
    sc, exact = _capture_case(formica, speed)
    plan = build_plan(sc)
    b = plan.block_size
    specs = [(0, 0, k, min(b, n - k * b)) for k in range(math.ceil(n / b))]
    captured = sum(acc.captured for acc in kernel.simulate_specs(plan, specs))
    se = math.sqrt(exact * (1 - exact) / n)
    assert 1e-6 < exact < 1e-3
    assert abs(captured / n - exact) < K * se, (captured / n, exact)
