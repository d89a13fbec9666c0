"""A rough particle: the table of surface + particle roughness angle is exact.

When at least one of the two angle distributions is continuous (or shadowing is
``"weighted"``), the engine tabulates the law of the sum (``plan.convolve_angles``,
``engine/_convolution.py``). Oracles, independent of that code:

* two normal angles sum to a normal angle (closed form; both far from ±90°, so the
  truncation to (-90°, 90°) is below 1e-30);
* a discrete angle sample + a normal angle: the mixture
  ``mean_i Phi((x - a_i) / sigma)``, computed directly with SciPy;
* two weighted discrete ones: the exact atoms ``a_i + b_j`` with weights
  ``w_i v_j``.

The table's CDF (exact from its 64-bit cells) must be within 0.1 standard error at
N = 1e9 impacts of the oracle at its refined-grid nodes and at random points, in
the body and in both tails down to probabilities of 1e-9; the old reduced
convolution (1,024 atoms each) fails that check. The engine's sampled shadowed
fraction at 1e7 impacts lies within K standard errors of the closed form.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from engine_helpers import scenario
from scipy import stats

from microimpact import SurfaceVariant
from microimpact._core.tables import CellTable
from microimpact.engine import _convolution, kernel
from microimpact.engine import plan as plan_module
from microimpact.engine.plan import build_plan
from microimpact.surface.angles import angles_from_sample, normal_angles

K = 4.0
N_MAX = 1e9
P_MIN = 1e-9  # the tails are checked down to this probability
TWO64 = 2.0**64


def tenth_se(p, n=N_MAX):
    p = np.asarray(p, dtype=float)
    return 0.1 * np.sqrt(p * (1.0 - p) / n)


def table_cdf_sf(table: CellTable, x):
    """The table's exact ``(P(X <= x), P(X > x))``: whole cells below `x` from
    their 64-bit starts, the cell holding `x` by its linear quantile function."""
    x = np.asarray(x, dtype=float)
    n = table.size
    j = np.clip(np.searchsorted(table.right, x, side="left"), 0, n - 1)
    lo, hi = table.left[j], table.right[j]
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(hi > lo, np.clip((x - lo) / (hi - lo), 0.0, 1.0), 1.0 * (x >= lo))
    start = table.cum[j].astype(float) / TWO64
    nxt = np.where(j + 1 < n, table.cum[np.minimum(j + 1, n)], np.uint64(0))
    above = (np.uint64(0) - nxt).astype(float) / TWO64  # 2^64 - cum[j+1]
    above = np.where(j + 1 < n, above, 0.0)
    w = table.widths()[j]
    return start + f * w, above + (1.0 - f) * w


def node_errors(table: CellTable, cdf, sf):
    """Oracle CDF (lower half) or SF (upper half) error at the table's nodes (the
    cell starts, with their exact 64-bit probabilities), and the probabilities
    ``min(p, 1 - p)``; nodes beyond 1e-9 (and the outermost atoms) left out."""
    x = table.left
    p = table.cum[:-1].astype(float) / TWO64
    s = (np.uint64(0) - table.cum[:-1]).astype(float) / TWO64  # 2^64 - cum
    s[0] = 1.0
    keep = np.minimum(p, s) >= P_MIN
    p, s, x = p[keep], s[keep], x[keep]
    lower = p <= 0.5
    err = np.where(lower, np.abs(cdf(x) - p), np.abs(sf(x) - s))
    return err, np.minimum(p, s)


def random_point_errors(table: CellTable, exact_ppf, exact_isf, cdf, sf, seed=0):
    """Errors of the table's CDF/SF at random points: log-uniform probabilities in
    both tails (1e-9 .. 0.5) and uniform ones in the body."""
    rng = np.random.default_rng(seed)
    q = np.concatenate([10 ** rng.uniform(-9, math.log10(0.5), 3000), rng.random(2000)])
    q = q[(q >= P_MIN) & (q <= 1 - P_MIN)]
    lower = np.concatenate([q[q <= 0.5], q[q > 0.5]])
    xl = exact_ppf(q[q <= 0.5])
    xu = exact_isf(q[q <= 0.5])  # mirrored: upper tail
    xb = exact_ppf(q[q > 0.5])
    x = np.concatenate([xl, xu, xb])
    del lower
    t_cdf, t_sf = table_cdf_sf(table, x)
    f, s = cdf(x), sf(x)
    use_f = f <= s
    err = np.where(use_f, np.abs(t_cdf - f), np.abs(t_sf - s))
    return err, np.where(use_f, f, s)


def assert_within(err, p, limit=1.0, what=""):
    ratio = err / tenth_se(p)
    worst = int(np.argmax(ratio))
    assert ratio[worst] < limit, (
        f"{what}: error {err[worst]:.3g} at p={p[worst]:.3g} is "
        f"{ratio[worst]:.3g} x 0.1 SE at 1e9"
    )
    return float(ratio[worst])


# --------------------------------------------------------------- normal + normal
SA, SB = 8.0, 6.0  # deg: the sum is normal with std 10 deg
EXACT = stats.norm(0.0, np.deg2rad(math.hypot(SA, SB)))


@pytest.fixture(scope="module")
def normal_sum():
    return plan_module.convolve_angles(normal_angles(SA), normal_angles(SB))


def _normal_sum_checks(table, limit=1.0):
    err, p = node_errors(table, EXACT.cdf, EXACT.sf)
    body = p >= 1e-3
    r_body = assert_within(err[body], p[body], limit, "nodes, body")
    r_tail = assert_within(err[~body], p[~body], limit, "nodes, tails")
    err, p = random_point_errors(table, EXACT.ppf, EXACT.isf, EXACT.cdf, EXACT.sf)
    # inside the cells: the linear interpolation of every continuous table
    r_rand = assert_within(err, p, max(limit, 0.1), "random points")
    return r_body, r_tail, r_rand


def test_two_normals_sum_to_a_normal(normal_sum):
    # far below the criterion: 1e-2 of 0.1 SE at 1e9 at every node and point
    _normal_sum_checks(normal_sum, limit=1e-2)
    # and in relative terms in the tails (the nodes are exact to ~1e-8)
    err, p = node_errors(normal_sum, EXACT.cdf, EXACT.sf)
    assert np.max(err / p) < 1e-6


def test_the_old_convolution_fails_the_criterion():
    """Mutation: the reduced convolution (1,024 equiprobable atoms each, the code
    before) turns the accuracy check red."""
    old = _convolution.reduced_convolution(normal_angles(SA), normal_angles(SB))
    with pytest.raises(AssertionError, match=r"0\.1 SE"):
        _normal_sum_checks(old)


def test_build_plan_uses_the_exact_table(monkeypatch):
    """The engine's angle table for (normal surface, normal particle) meets the
    criterion, and with the old convolution put back in the plan it does not."""

    def surface_table(plan):
        return plan.surfaces[0].table

    sc = scenario(
        surfaces=(SurfaceVariant("s", normal_angles(SA)),),
        particle_roughness=normal_angles(SB),
        angles_deg=(30.0,),
    )
    _normal_sum_checks(surface_table(build_plan(sc)), limit=1e-2)
    monkeypatch.setattr(plan_module, "sum_table", _convolution.reduced_convolution)
    with pytest.raises(AssertionError, match=r"0\.1 SE"):
        _normal_sum_checks(surface_table(build_plan(sc)))


def test_wider_law_against_narrow_and_shifted():
    """Unequal widths and non-zero means (the quadrature runs over the narrower
    one): N(5, 12) + N(-2, 1.5) = N(3, hypot(12, 1.5))."""
    table = plan_module.convolve_angles(
        normal_angles(1.5, mean_deg=-2.0), normal_angles(12.0, mean_deg=5.0)
    )
    exact = stats.norm(np.deg2rad(3.0), np.deg2rad(math.hypot(12.0, 1.5)))
    err, p = node_errors(table, exact.cdf, exact.sf)
    assert_within(err, p, 1e-2, "nodes")
    err, p = random_point_errors(table, exact.ppf, exact.isf, exact.cdf, exact.sf)
    assert_within(err, p, 0.1, "random points")


# ------------------------------------------------------------ discrete + normal
def _mixture_oracle(atoms, sigma):
    """The exact CDF and SF of atoms (equal masses) + N(0, sigma), directly."""
    atoms = np.asarray(atoms)

    def cdf(x):
        x = np.asarray(x, float)
        return stats.norm.cdf((x[:, None] - atoms[None, :]) / sigma).mean(axis=1)

    def sf(x):
        x = np.asarray(x, float)
        return stats.norm.sf((x[:, None] - atoms[None, :]) / sigma).mean(axis=1)

    return cdf, sf


def _check_random_points(table, cdf, sf):
    """The oracle's CDF (SF in the upper half) at the table's own quantiles of
    random probabilities, body and both tails to 1e-9, against the table's."""
    rng = np.random.default_rng(1)
    q = np.concatenate([10 ** rng.uniform(-9, -0.3, 2000), rng.random(2000)])
    q = np.concatenate([q, 1.0 - 10 ** rng.uniform(-9, -0.3, 2000)])
    x = table.quantile(q)
    t_cdf, t_sf = table_cdf_sf(table, x)
    f, s = cdf(x), sf(x)
    use_f = f <= s
    err = np.where(use_f, np.abs(t_cdf - f), np.abs(t_sf - s))
    pp = np.where(use_f, f, s)
    keep = pp >= P_MIN
    assert_within(err[keep], pp[keep], 1.0, "random points")


@pytest.mark.parametrize("sigma_deg", [0.5, 4.0])
def test_discrete_plus_normal_is_the_mixture(sigma_deg):
    rng = np.random.default_rng(7)
    surf = angles_from_sample(rng.normal(3.0, 15.0, 300))
    sigma = np.deg2rad(sigma_deg)
    table = plan_module.convolve_angles(surf, normal_angles(sigma_deg))
    cdf, sf = _mixture_oracle(surf.atoms, sigma)
    err, p = node_errors(table, cdf, sf)
    assert_within(err, p, 1e-2, "nodes")
    _check_random_points(table, cdf, sf)


def test_discrete_plus_normal_either_way_round():
    """Surface normal, particle discrete: the same law."""
    rng = np.random.default_rng(3)
    part = angles_from_sample(rng.normal(0.0, 9.0, 150))
    t1 = plan_module.convolve_angles(normal_angles(5.0), part)
    t2 = plan_module.convolve_angles(part, normal_angles(5.0))
    np.testing.assert_array_equal(t1.left, t2.left)


# ---------------------------------------------------- discrete + discrete, weighted
def test_weighted_discrete_pairs_are_exact_atoms():
    rng = np.random.default_rng(5)
    a = angles_from_sample(rng.normal(0.0, 10.0, 120))
    b = angles_from_sample(rng.normal(0.0, 6.0, 90))
    table = plan_module.convolve_angles(a, b)
    sums = np.sort((a.atoms[:, None] + b.atoms[None, :]).ravel())
    u, counts = np.unique(sums, return_counts=True)
    np.testing.assert_array_equal(table.left, u)
    want = np.concatenate([[0], np.cumsum(counts)[:-1]]) / sums.size
    np.testing.assert_allclose(table.probabilities(), want, atol=1e-15)
    sc = scenario(
        surfaces=(SurfaceVariant("s", a),),
        particle_roughness=b,
        shadowing="weighted",
    )
    assert build_plan(sc).surfaces[0].table.size == u.size


# ------------------------------------------------------------- the engine, 1e7
def _shadowed(plan, n):
    b = plan.block_size
    specs = [(0, 0, k, min(b, n - k * b)) for k in range(math.ceil(n / b))]
    return sum(acc.shadowed for acc in kernel.simulate_specs(plan, specs))


@pytest.mark.parametrize("n", [10**7, pytest.param(10**8, marks=pytest.mark.slow)])
def test_engine_shadowed_fraction_two_normals(n):
    theta = 20.0
    sc = scenario(
        surfaces=(SurfaceVariant("s", normal_angles(SA)),),
        particle_roughness=normal_angles(SB),
        angles_deg=(theta,),
        shadowing="none",
    )
    exact = float(EXACT.sf(np.deg2rad(theta)))
    plan = build_plan(sc)
    got = _shadowed(plan, n) / n
    se = math.sqrt(exact * (1 - exact) / n)
    assert abs(got - exact) < K * se, (got, exact, (got - exact) / se)
    # "reject" reports the table's P(phi >= theta): within 0.1 SE at 1e9
    sc_r = scenario(
        surfaces=(SurfaceVariant("s", normal_angles(SA)),),
        particle_roughness=normal_angles(SB),
        angles_deg=(theta,),
    )
    mass = build_plan(sc_r).angle_tables(0, theta).shadowed_mass
    assert abs(mass - exact) < tenth_se(exact)


def test_engine_shadowed_fraction_discrete_plus_normal():
    rng = np.random.default_rng(11)
    surf = angles_from_sample(rng.normal(0.0, 12.0, 400))
    theta, sigma_deg, n = 25.0, 5.0, 10**7
    sc = scenario(
        surfaces=(SurfaceVariant("s", surf),),
        particle_roughness=normal_angles(sigma_deg),
        angles_deg=(theta,),
        shadowing="none",
    )
    _, sf = _mixture_oracle(surf.atoms, np.deg2rad(sigma_deg))
    exact = float(sf(np.array([np.deg2rad(theta)]))[0])
    got = _shadowed(build_plan(sc), n) / n
    se = math.sqrt(exact * (1 - exact) / n)
    assert abs(got - exact) < K * se, (got, exact, (got - exact) / se)


# ------------------------------------------------------------------- build time
def test_build_time_is_a_few_seconds():
    """One (surface, particle) table: 4,000 measured-like angles + a normal
    particle, and two normals (measured ~0.4 s each on one core)."""
    rng = np.random.default_rng(0)
    surf = angles_from_sample(np.clip(rng.normal(0.0, 20.0, 4000), -60, 60))
    for a, b in ((surf, normal_angles(2.0)), (normal_angles(8.0), normal_angles(6.0))):
        t = time.perf_counter()
        plan_module.convolve_angles(a, b)
        assert time.perf_counter() - t < 15.0


# ------------------------------------------- discrete + a density with jumps
@pytest.mark.parametrize(
    "law",
    [stats.uniform(-5.0, 10.0), stats.uniform(-1.0, 2.0), stats.truncnorm(-1, 1, 0, 5)],
    ids=["uniform10", "uniform2", "truncnorm"],
)
def test_discrete_plus_a_density_with_jumps_is_exact(law, recwarn):
    """A measured set + a law whose density jumps at its support ends: nodes at
    the jumps with exact probabilities; no accuracy warning, and the table's CDF
    within 0.1 SE at 1e9 of the mixture oracle at nodes and at random points."""
    from microimpact.surface.angles import scipy_angles

    rng = np.random.default_rng(7)
    atoms = np.deg2rad(rng.normal(3.0, 15.0, 300))
    surf = angles_from_sample(np.rad2deg(atoms))
    part = scipy_angles(law)
    table = plan_module.convolve_angles(surf, part)
    assert not [w for w in recwarn if "accuracy target" in str(w.message)]
    core = part._core

    def cdf(x):
        x = np.asarray(x, float)
        return core.cdf(x[:, None] - atoms[None, :]).mean(axis=1)

    def sf(x):
        x = np.asarray(x, float)
        return core.sf(x[:, None] - atoms[None, :]).mean(axis=1)

    err, p = node_errors(table, cdf, sf)
    assert_within(err, p, 1e-2, "nodes")
    _check_random_points(table, cdf, sf)


@pytest.mark.parametrize("std_deg, warns", [(10.0, False), (20.0, True)])
def test_summed_angles_beyond_vertical_are_announced(std_deg, warns):
    """The summed-angle table clips facets beyond +-90 deg to +-90 deg; when that
    mass exceeds 1e-9 the build says so, with its probability: for two N(0, s)
    laws it is 2 Phi(-90 / (s sqrt 2)) (1.5e-3 at s = 20 deg; 1.5e-10 at 10 deg,
    silent)."""
    import warnings

    from microimpact import SurfaceVariant, normal_angles
    from microimpact.engine.plan import build_plan

    sc = scenario(
        surfaces=(SurfaceVariant("s", normal_angles(std_deg)),),
        particle_roughness=normal_angles(std_deg),
        angles_deg=(60.0,),
        shadowing="weighted",
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        build_plan(sc)
    said = [str(w.message) for w in caught if "beyond +-90 deg" in str(w.message)]
    assert bool(said) == warns
    if warns:
        exact = 2 * stats.norm.cdf(-90.0 / (std_deg * math.sqrt(2.0)))
        p = float(said[0].split("probability ")[1].split(" ")[0])
        assert p == pytest.approx(exact, rel=0.05)
        assert "surface 's'" in said[0]
