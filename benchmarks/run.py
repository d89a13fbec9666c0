"""Performance benchmark of the microimpact Monte Carlo engine, in one run.

The kernel measured is the full oblique impact on a rough surface, one sweep point:
diameters normal 52.8 +/- 15.3 um [1]; roughness angles empirical, from the synthetic
Formica profile at a 20 um contact length; apparent incidence 30 deg at 1 m/s;
shadowing "reject"; capture test; rolling/sliding with friction 0.15; Eqs. 7-9;
streaming statistics. Coefficients as the shipped presets: k1 = 4 m/s,
k2 = 0.05 (d/52.8 um)^-1.58 m/s, v_c = 0.20 (d/52.8 um)^-1.58 m/s, p = q = 1.

Measured (impacts per second; median of 3 repetitions: each in its own fresh
process by default, in one fresh process per variant with ``--quick``, in this
process once with ``--smoke``):

1. ``rng_floor_per_s``: only the random numbers the engine draws: per block of 32,768
   impacts and per variable (diameter, angle), ``PCG64(SeedSequence(entropy,
   spawn_key=(point, block, var))).random_raw(n)``; and ``rng_floor_classic_per_s``,
   the classic floor: one ``standard_normal`` and one ``random`` per
   impact from one PCG64 generator, chunked with ``out=``.
2. ``numpy_baseline_per_s``: the same physics in plain whole-array NumPy, as a user
   writes it (checked to agree with the engine within 5 standard errors).
3. ``engine_per_s``: ``microimpact.run(workers=1)``, wall time of the call.
4. ``engine_all_cores_per_s``: ``microimpact.run(workers=os.cpu_count())``.
5. ``peak_rss_mb``: the largest peak RSS [MiB] of a fresh process running
   ``microimpact.run`` at 10^6, 10^7, 10^8 impacts (``peak_rss_mb_by_n``).
6. ``dask_per_s``: ``microimpact.run(backend="dask")`` on a ``LocalCluster`` of
   ``os.cpu_count()`` workers (the cluster start is timed separately).
7. ``qmc_error_ratio``: RMS error of the mean e_m, plain MC over QMC, at 2^14
   impacts per replicate, against an independent quadrature of the exact
   expectation (> 1 means QMC is better).
8. ``paper_reproduction_s``: the four presets at 4,000 impacts per point, if
   ``microimpact.scenario.file.load_preset`` exists.
9. ``grid_per_s``: ``microimpact.run(workers=1)`` over a sweep grid of 100 speeds
   x 100 angles (10^4 points) at 4,000 impacts per point on the same rough surface
   (``grid_all_cores_per_s``: ``workers=os.cpu_count()``); ``grid_ratio`` is
   ``grid_per_s / engine_per_s``, measured in the same run (target >= 0.5).
10. ``wall_law_build_s``: ``microimpact.build_wall_law`` of a 20 x 20 x 20 table
   (diameter x speed x angle) at 4,000 draws per node on the same surface and laws,
   on all cores (issue 13's target: under a minute on two); ``wall_law_per_s`` its
   impacts per second.

Usage::

    python benchmarks/run.py [--quick | --smoke] [--grid-only] [--json PATH]

``--grid-only`` measures items 3, 4 and 9 alone (the grid ratios), and reports the
CPU time of this process and of worker processes during each grid run on all cores
(with the compiled kernel the workers are threads of this process, so its CPU is all
of it).

``--quick`` takes under a minute on 2 cores, ``--smoke`` about 10 s (tiny sizes, no
timing is meaningful; it checks that everything runs). Timings on shared machines are
noisy: trust the ratios measured in one run, not the absolute rates.

References
----------
[1] X. Li, P. F. Dunn, R. M. Brach, Aerosol Sci. Technol. 33:376-386, 2000.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from microimpact.engine.kernel import stream_raw
from microimpact.engine.plan import BLOCK_SIZE, VAR_ANGLE, VAR_DIAMETER

# ------------------------------------------------------------------------ the model
MEAN_UM, STD_UM = 52.8, 15.3  # [1], SST65 size distribution
K1 = 4.0  # [m s-1]
K2_A, VC_A = 0.05, 0.20  # [m s-1] at D_REF_UM
EXPONENT = -1.58  # [-], power law of k2 and v_c against diameter
D_REF_UM = 52.8
FRICTION = 0.15  # [1], Fig. 8 text
SPEED = 1.0  # [m s-1]
ANGLE_DEG = 30.0  # apparent incidence from the nominal plane [deg]
CONTACT_LENGTH_UM = 20.0
BLOCK = BLOCK_SIZE  # the engine's block: one stream per (block, variable)
SEED = 20000376

#: Sizes per mode (``--quick`` and ``--smoke`` override the default ``full``).
#: ``isolate``: measure in fresh processes; ``process_per_repeat``: one per repetition.
FULL = dict(
    n_rng=2 * 10**8,
    n_numpy=10**7,
    n_engine=2 * 10**8,
    repeats=3,
    rss_ns=(10**6, 10**7, 10**8),
    qmc_replicates=32,
    qmc_n=1 << 14,
    reproduce_samples=4000,
    reproduce_presets=None,
    reproduce_cli=True,
    isolate=True,
    process_per_repeat=True,
)
FULL.update(grid=(100, 100), grid_samples=4000)
FULL.update(wall_law=(20, 20, 20), wall_law_samples=4000)
QUICK = {**FULL, "n_rng": 2 * 10**7, "n_numpy": 2 * 10**6, "n_engine": 2 * 10**7}
QUICK.update(grid=(50, 50))
QUICK.update(rss_ns=(10**6, 10**7), qmc_replicates=16)
QUICK.update(reproduce_cli=False, process_per_repeat=False)
SMOKE = {**QUICK, "n_rng": 1 << 18, "n_numpy": 1 << 17, "n_engine": 1 << 17}
SMOKE.update(repeats=1, rss_ns=(10**5,), qmc_replicates=4, qmc_n=1 << 12)
SMOKE.update(reproduce_samples=100, reproduce_presets=1, isolate=False)
SMOKE.update(grid=(4, 5), grid_samples=400)
SMOKE.update(wall_law=(3, 3, 3), wall_law_samples=200)
MODES = {"full": FULL, "quick": QUICK, "smoke": SMOKE}
#: Largest N of the whole-array NumPy baseline (memory: ~1.5 GiB at 10^7).
NUMPY_MAX_N = 10**7
#: Agreement tolerance between the NumPy baseline and the engine [standard errors].
AGREEMENT_SE = 5.0


# ------------------------------------------------------------------ model objects
def formica_angles():
    """(AngleDistribution for the engine, the raw angle sample [rad])."""
    import microimpact as mi
    from microimpact.units import um_to_m

    profile = mi.formica_profile()
    dist = mi.angles_from_profile(profile, contact_length_um=CONTACT_LENGTH_UM)
    raw = mi.surface_angles(profile, contact_length=float(um_to_m(CONTACT_LENGTH_UM)))
    raw = raw[np.abs(raw) < 0.5 * np.pi]
    if raw.size != dist.params["n"]:  # both must describe the same sample
        raise RuntimeError(
            f"angle sample of {raw.size} values but the distribution has "
            f"{dist.params['n']}"
        )
    return dist, raw


def make_scenario(angles=None, **kw):
    """The benchmark's one-point Scenario (keyword overrides go to Scenario)."""
    import microimpact as mi

    if angles is None:
        angles = formica_angles()[0]
    d_ref = D_REF_UM * 1e-6
    coefficients = mi.ImpactCoefficients(
        k1=K1,
        k2=mi.PowerLaw(K2_A, EXPONENT, d_ref=d_ref),
        v_c=mi.PowerLaw(VC_A, EXPONENT, d_ref=d_ref),
        p=1.0,
        q=1.0,
        friction=FRICTION,
    )
    base = dict(
        name="benchmark",
        particles=mi.normal_diameters(MEAN_UM, STD_UM),
        coefficients=coefficients,
        speeds_m_s=(SPEED,),
        angles_deg=(ANGLE_DEG,),
        surfaces=(mi.SurfaceVariant("formica", angles),),
        shadowing="reject",
        seed=SEED,
        reference_angle_deg=None,
    )
    base.update(kw)
    return mi.Scenario(**base)


def _summary_stats(result) -> dict:
    row = result.summary.iloc[0]
    return {
        "n": int(row["n"]),
        "e_mean": float(row["e_mean"]),
        "e_se": float(row["e_se"]),
        "capture_fraction": float(row["capture_fraction"]),
        "mu_mean": float(row["mu_mean"]),
    }


# --------------------------------------------------------------- 1. the RNG floors
def rng_floor(n: int, *, entropy: int = SEED) -> dict:
    """The engine's draws only: one stream per (block, variable), 2 variables."""
    t0 = time.perf_counter()
    for b in range(math.ceil(n / BLOCK)):
        m = min(BLOCK, n - b * BLOCK)
        for var in (VAR_DIAMETER, VAR_ANGLE):
            stream_raw(entropy, 0, b, var, m)
    return {"rate": n / (time.perf_counter() - t0)}


def rng_floor_classic(n: int, *, entropy: int = SEED) -> dict:
    """The classic floor: 1 standard_normal + 1 random per impact, ``out=``."""
    rng = np.random.Generator(np.random.PCG64(entropy))
    z, u = np.empty(BLOCK), np.empty(BLOCK)
    t0 = time.perf_counter()
    for b in range(math.ceil(n / BLOCK)):
        m = min(BLOCK, n - b * BLOCK)
        rng.standard_normal(out=z[:m])
        rng.random(out=u[:m])
    return {"rate": n / (time.perf_counter() - t0)}


# ------------------------------------------------------------- 2. NumPy baseline
def numpy_baseline(n: int, angles_rad, *, rng=None, speed=SPEED, angle_deg=ANGLE_DEG):
    """The benchmark's physics in plain whole-array NumPy, as a user writes it.

    Returns a dict of statistics (``e_mean`` over all impacts with captured
    particles counted as 0, its standard error ``e_se``, ``capture_fraction``,
    ``mu_mean`` over rebounds, ``e_hist`` ...).
    """
    rng = np.random.default_rng(rng)
    d_ref = D_REF_UM * 1e-6
    theta = np.deg2rad(angle_deg)
    # diameters: normal, truncated to d > 0 by redrawing
    d = rng.normal(MEAN_UM * 1e-6, STD_UM * 1e-6, n)
    bad = d <= 0
    while bad.any():
        d[bad] = rng.normal(MEAN_UM * 1e-6, STD_UM * 1e-6, np.count_nonzero(bad))
        bad = d <= 0
    # roughness angles from the measured sample; shadowed facets drawn again
    phi = rng.choice(angles_rad, n)
    shadowed = phi >= theta
    while shadowed.any():
        phi[shadowed] = rng.choice(angles_rad, np.count_nonzero(shadowed))
        shadowed = phi >= theta
    # coefficients per impact
    k2 = K2_A * (d / d_ref) ** EXPONENT
    v_c = VC_A * (d / d_ref) ** EXPONENT
    # facet frame: v_n' = -s sin(theta - phi), v_t' = -s cos(theta - phi)
    v_n = -speed * np.sin(theta - phi)
    v_t = -speed * np.cos(theta - phi)
    u = -v_n
    captured = u <= v_c
    R = K1 / (K1 + u)  # [1], Eq. 4 (p = 1)
    rho = k2 / (k2 + (u - v_c))  # [1], Eq. 5 (q = 1)
    e = np.where(captured, 0.0, R * (1.0 - rho))  # [1], Eq. 6
    mu0 = 2.0 * (v_t / v_n) / (7.0 * (1.0 + e))  # [1], Eq. 3
    mu = np.clip(mu0, -FRICTION, FRICTION)  # sliding when |mu0| > friction
    V_t = v_t - mu * (1.0 + e) * v_n  # [1], Eq. 2
    tan_phi = np.tan(phi)
    e_m = (e - tan_phi * V_t / v_n) / (1.0 + tan_phi * v_t / v_n)  # [1], Eq. 8
    mu_m = (mu - tan_phi) / (mu * tan_phi + 1.0)  # [1], Eq. 9
    e_m = np.where(captured, 0.0, e_m)
    rebound = ~captured
    e_r, mu_r = e_m[rebound], mu_m[rebound]
    e_std = float(e_m.std(ddof=1))
    return {
        "n": n,
        "e_mean": float(e_m.mean()),
        "e_std": e_std,
        "e_se": e_std / float(np.sqrt(n)),
        "capture_fraction": float(captured.mean()),
        "e_rebound_mean": float(e_r.mean()),
        "mu_mean": float(mu_r.mean()),
        "mu_std": float(mu_r.std(ddof=1)),
        "e_hist": np.histogram(e_r, bins=np.linspace(-1.0, 3.0, 401))[0],
        "mu_hist": np.histogram(mu_r, bins=np.linspace(-5.0, 5.0, 1001))[0],
    }


def _numpy_task(n: int, seed: int) -> dict:
    _, raw = formica_angles()
    numpy_baseline(1 << 12, raw, rng=0)  # warm-up
    t0 = time.perf_counter()
    out = numpy_baseline(n, raw, rng=seed)
    dt = time.perf_counter() - t0
    stats = {k: v for k, v in out.items() if not k.endswith("_hist")}
    return {"rate": n / dt, "stats": stats}


# ------------------------------------------------------------ 3.-4. the engine
def _engine_task(n: int, workers: int, seed: int, warmup: bool = True) -> dict:
    import microimpact as mi

    scenario = make_scenario()
    if warmup:
        mi.run(scenario, samples=BLOCK, seed=1, workers=workers, progress=False)
    t0 = time.perf_counter()
    result = mi.run(scenario, samples=n, seed=seed, workers=workers, progress=False)
    dt = time.perf_counter() - t0
    return {
        "rate": n / dt,
        "wall_s": dt,
        "engine_elapsed_s": float(result.elapsed_s),
        "kernel": result.provenance["kernel"],
        "stats": _summary_stats(result),
    }


def grid_scenario(n_speeds: int, n_angles: int, samples: int):
    """The benchmark's surface and laws over a speed x angle grid."""
    speeds = tuple(float(v) for v in np.linspace(0.2, 5.0, n_speeds))
    angles = tuple(float(a) for a in np.linspace(5.0, 90.0, n_angles))
    return make_scenario(speeds_m_s=speeds, angles_deg=angles, samples=samples)


def _grid_task(shape, samples: int, workers: int, seed: int, warmup=True) -> dict:
    import microimpact as mi

    scenario = grid_scenario(*shape, samples)
    if warmup:
        mi.run(grid_scenario(2, 2, samples), seed=1, workers=workers, progress=False)
    kids0 = _children_cpu_s()
    t0 = time.perf_counter()
    c0 = time.process_time()
    mi.run(scenario, seed=seed, workers=workers, progress=False)
    dt = time.perf_counter() - t0
    driver = time.process_time() - c0
    n = shape[0] * shape[1] * samples
    return {
        "rate": n / dt,
        "wall_s": dt,
        "points": shape[0] * shape[1],
        "n": n,
        # CPU of this process (the driver and its threads; with 1 worker also the
        # kernel) and of the pool's worker processes (reaped when the run ends)
        "driver_cpu_s": driver,
        "workers_cpu_s": _children_cpu_s() - kids0,
    }


def _wall_law_task(shape, samples: int, workers: int, seed: int) -> dict:
    """Build a wall law of ``d x v x angle`` nodes on the benchmark's surface and
    laws (one surface), ``samples`` draws per node (issue 13's target: 20 x 20 x 20
    at 4,000 in under a minute on two cores)."""
    from microimpact.wall_law import WallLawSpec, build_wall_law

    n_d, n_v, n_a = shape
    spec = WallLawSpec(
        diameters_um=tuple(np.geomspace(20.0, 120.0, n_d)),
        speeds_m_s=tuple(np.geomspace(0.1, 10.0, n_v)),
        angles_deg=tuple(np.linspace(5.0, 90.0, n_a)),
        samples=samples,
    )
    t0 = time.perf_counter()
    build_wall_law(make_scenario(), spec, workers=workers, seed=seed)
    dt = time.perf_counter() - t0
    n = n_d * n_v * n_a * samples
    return {"rate": n / dt, "wall_s": dt, "nodes": n_d * n_v * n_a, "n": n}


# -------------------------------------------- issue 24: every path at full speed
#: The ratios of issue 24, each measured in one fresh process, one worker, the two
#: sides alternating (``ratio_repeats`` rounds; the median of the rounds' ratios).
#: ``design_row_ratio`` (sensitivity over N design rows against one run) belongs to
#: the ScenarioModel work and is added beside these, in :func:`_ratio_tasks`.
RATIO_SIZES = {
    "full": dict(
        areal_n=2 * 10**7, qmc_n=1 << 24, wall_law=(12, 12, 12), rounds=5, rows=1000
    ),
    "quick": dict(
        areal_n=5 * 10**6, qmc_n=1 << 22, wall_law=(12, 12, 12), rounds=3, rows=1000
    ),
    "smoke": dict(
        areal_n=1 << 17, qmc_n=1 << 15, wall_law=(3, 3, 3), rounds=1, rows=20
    ),
}
RATIO_WALL_LAW_SAMPLES = 4000


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _areal_ratio_task(n: int, rounds: int) -> dict:
    """``areal_ratio``: the marginal rate (impacts per second between a run of
    2^15 and a run of `n` impacts, so that the surface's and the plan's fixed
    costs cancel) of the areal surface of the ``sst76-formica-areal`` preset over
    that of its profile surface, at one point (1 m/s, 30 deg), one worker."""
    import dataclasses

    import microimpact as mi
    from microimpact.scenario.scenario import load_preset

    sc = load_preset("sst76-formica-areal")
    one = dict(angles_deg=(ANGLE_DEG,), speeds_m_s=(SPEED,))
    prof = dataclasses.replace(sc, surfaces=sc.surfaces[:1], **one)
    areal = dataclasses.replace(sc, surfaces=sc.surfaces[1:], **one)
    n0 = BLOCK

    def run(s, k):
        return _timed(lambda: mi.run(s, samples=k, seed=SEED, progress=False))

    for s in (prof, areal):  # warm-up: imports, the areal surface's build
        run(s, n0)
    rates = {"profile": [], "areal": []}
    for _ in range(rounds):
        for name, s in (("profile", prof), ("areal", areal)):
            small, large = run(s, n0), run(s, n)
            rates[name].append((n - n0) / (large - small))
    ratios = [a / p for a, p in zip(rates["areal"], rates["profile"], strict=True)]
    kernel = mi.run(areal, samples=n0, seed=1, progress=False).provenance["kernel"]
    return {
        "ratio": statistics.median(ratios),
        "ratios": ratios,
        "kernel": kernel,
        "profile_per_s": statistics.median(rates["profile"]),
        "areal_per_s": statistics.median(rates["areal"]),
    }


def _qmc_ratio_task(n: int, rounds: int) -> dict:
    """``qmc_ratio``: QMC's rate over plain MC's, the benchmark's point at `n`
    impacts (8 scrambled replicates of n/8), one worker."""
    import microimpact as mi

    mc = make_scenario()
    qmc = make_scenario(sampling="qmc", qmc_replicates=8)

    def run(s, k):
        return _timed(lambda: mi.run(s, samples=k, seed=SEED, progress=False))

    run(mc, BLOCK)
    run(qmc, BLOCK)
    mc_rates, qmc_rates = [], []
    for _ in range(rounds):
        mc_rates.append(n / run(mc, n))
        qmc_rates.append(n / run(qmc, n))
    ratios = [q / m for q, m in zip(qmc_rates, mc_rates, strict=True)]
    return {
        "ratio": statistics.median(ratios),
        "ratios": ratios,
        "mc_per_s": statistics.median(mc_rates),
        "qmc_per_s": statistics.median(qmc_rates),
    }


def _wall_law_ratio_task(shape, samples: int, rounds: int) -> dict:
    """``wall_law_ratio``: ``build_wall_law`` of ``d x v x angle`` nodes at
    `samples` draws per node on the benchmark's surface and laws, over plain
    ``microimpact.run`` calls of the same impacts (one run per diameter, a
    monodisperse population over the speed x angle grid at `samples` per point),
    one worker."""
    import microimpact as mi
    from microimpact.wall_law import WallLawSpec, build_wall_law

    n_d, n_v, n_a = shape
    spec = WallLawSpec(
        diameters_um=tuple(np.geomspace(20.0, 120.0, n_d)),
        speeds_m_s=tuple(np.geomspace(0.1, 10.0, n_v)),
        angles_deg=tuple(np.linspace(5.0, 90.0, n_a)),
        samples=samples,
    )
    sc = make_scenario()
    plain_runs = [
        sc.with_options(
            particles=mi.monodisperse(d),
            speeds_m_s=spec.speeds_m_s,
            angles_deg=spec.angles_deg,
            samples=samples,
        )
        for d in spec.diameters_um
    ]

    def plain():
        for s in plain_runs:
            mi.run(s, seed=SEED, progress=False)

    def wall():
        build_wall_law(sc, spec, seed=SEED)

    plain()
    wall()
    t_plain, t_wall = [], []
    for _ in range(rounds):
        t_plain.append(_timed(plain))
        t_wall.append(_timed(wall))
    ratios = [w / p for w, p in zip(t_wall, t_plain, strict=True)]
    return {
        "ratio": statistics.median(ratios),
        "ratios": ratios,
        "wall_s": statistics.median(t_wall),
        "plain_s": statistics.median(t_plain),
        "nodes": n_d * n_v * n_a,
        "wall_law_per_s": n_d * n_v * n_a * samples / statistics.median(t_wall),
    }


def _ratio_tasks(mode: str, isolate: bool) -> dict:
    """The ratios of issue 24 (see :data:`RATIO_SIZES`) and the RNG floor of the
    same run, each ratio in a fresh process when `isolate`."""
    cfg = RATIO_SIZES[mode]
    r = cfg["rounds"]
    out = {
        "areal": measure("areal_ratio", isolate=isolate, n=cfg["areal_n"], rounds=r),
        "wall_law": measure(
            "wall_law_ratio",
            isolate=isolate,
            shape=cfg["wall_law"],
            samples=RATIO_WALL_LAW_SAMPLES,
            rounds=r,
        ),
        "qmc": measure("qmc_ratio", isolate=isolate, n=cfg["qmc_n"], rounds=r),
    }
    out = {k: v["runs"][0] for k, v in out.items()}
    # the ScenarioModel (issue 20/24): Sobol' sensitivity over 24 design rows of
    # the areal preset against one run of it, each in fresh processes
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from design_rows import design_row_ratio  # benchmarks/design_rows.py

    out["design_rows"] = design_row_ratio(samples=cfg["rows"], repeats=r)
    out["config"] = {**cfg, "wall_law_samples": RATIO_WALL_LAW_SAMPLES}
    return out


def ratio_fields(ratios: dict) -> dict:
    """The ``*_ratio`` fields of :func:`_ratio_tasks`'s measurements."""
    return {
        "areal_ratio": ratios["areal"]["ratio"],
        "wall_law_ratio": ratios["wall_law"]["ratio"],
        "qmc_ratio": ratios["qmc"]["ratio"],
        "design_row_ratio": ratios["design_rows"]["design_row_ratio"],
    }


def print_ratios(ratios: dict, floor_per_s=None) -> None:
    a, w, q = ratios["areal"], ratios["wall_law"], ratios["qmc"]
    shape = "x".join(str(k) for k in ratios["config"]["wall_law"])

    def runs(r):
        return ", ".join(f"{x:.2f}" for x in r["ratios"])

    print(
        f"areal_ratio (areal / profile marginal rate, 1 worker, {a['kernel']} "
        f"kernel): {a['ratio']:.2f}  ({a['areal_per_s'] / 1e6:.1f} vs "
        f"{a['profile_per_s'] / 1e6:.1f} M/s; rounds: {runs(a)}; target >= 0.5)"
    )
    print(
        f"wall_law_ratio ({shape} at {ratios['config']['wall_law_samples']}/node "
        f"over plain runs of the same impacts, 1 worker): {w['ratio']:.2f}  "
        f"({w['wall_s']:.2f} s vs {w['plain_s']:.2f} s; rounds: {runs(w)}; "
        "target <= 3)"
    )
    line = (
        f"qmc_ratio (QMC / MC rate, 1 worker): {q['ratio']:.2f}  "
        f"({q['qmc_per_s'] / 1e6:.1f} vs {q['mc_per_s'] / 1e6:.1f} M/s; rounds: "
        f"{runs(q)}; target >= 0.5)"
    )
    print(line)
    d = ratios["design_rows"]
    print(
        f"design_row_ratio (Sobol' sensitivity over 24 design rows of {d['preset']} "
        f"at {d['samples']} impacts/point over one run of it): "
        f"{d['design_row_ratio']:.2f}  ({d['sensitivity_s']:.2f} s vs "
        f"{d['one_run_s']:.2f} s; target <= 3)"
    )
    if floor_per_s:
        print(
            "against the RNG floor (engine streams): profile "
            f"{a['profile_per_s'] / floor_per_s:.2f}, areal "
            f"{a['areal_per_s'] / floor_per_s:.2f}, wall law "
            f"{w['wall_law_per_s'] / floor_per_s:.2f}, MC "
            f"{q['mc_per_s'] / floor_per_s:.2f}, QMC "
            f"{q['qmc_per_s'] / floor_per_s:.2f}"
        )


def _children_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _fixed_cost_task(workers: int) -> dict:
    """Wall time of one block with `workers` (the fixed cost of a run)."""
    import microimpact as mi

    scenario = make_scenario()
    mi.run(scenario, samples=BLOCK, seed=1, workers=1, progress=False)  # imports
    t0 = time.perf_counter()
    mi.run(scenario, samples=BLOCK, seed=2, workers=workers, progress=False)
    return {"wall_s": time.perf_counter() - t0}


# ---------------------------------------------------------------------- 6. Dask
def _dask_task(n: int, workers: int, repeats: int) -> dict:
    import logging

    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:
        return {"skipped": f"dask.distributed is not importable ({exc})"}
    import microimpact as mi

    logging.getLogger("distributed").setLevel(logging.ERROR)
    scenario = make_scenario()
    t0 = time.perf_counter()
    cluster = LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
    )
    start_s = time.perf_counter() - t0
    try:
        addr = cluster.scheduler_address
        kw = dict(backend="dask", address=addr, workers=workers, progress=False)
        mi.run(scenario, samples=BLOCK * workers, seed=1, **kw)  # warm-up
        rates, stats = [], None
        for r in range(repeats):
            t0 = time.perf_counter()
            result = mi.run(scenario, samples=n, seed=SEED + r, **kw)
            rates.append(n / (time.perf_counter() - t0))
            stats = _summary_stats(result)
        with Client(addr) as client:
            rss = client.run(_self_maxrss_mb)
    finally:
        cluster.close()
    return {
        "rates": rates,
        "cluster_start_s": start_s,
        "worker_maxrss_mb": sorted(rss.values()),
        "stats": stats,
    }


# ------------------------------------------------------ 7. QMC versus plain MC
def reference_values(angles_rad, *, speed=SPEED, angle_deg=ANGLE_DEG, nodes=4096):
    """Exact expectation of e_m (captured = 0) and of the capture fraction.

    Quadrature, independent of the engine: the angle is the measured sample
    conditioned on phi < theta (equal weights); for each angle the capture
    threshold ``d*`` (``v_c(d*) = s sin(theta - phi)``) splits the diameter
    integral exactly, the capture probability is the truncated-normal CDF at ``d*``
    (closed form) and the rebound part is a midpoint rule with `nodes` points in
    probability over ``[F(d*), 1]``.
    """
    from scipy.special import ndtr, ndtri

    theta = np.deg2rad(angle_deg)
    phi = np.asarray(angles_rad, dtype=float)
    phi = phi[phi < theta]
    mean, std, d_ref = MEAN_UM * 1e-6, STD_UM * 1e-6, D_REF_UM * 1e-6
    p0 = ndtr(-mean / std)  # normal mass below d = 0 (truncated away)

    def cdf(d):
        return (ndtr((d - mean) / std) - p0) / (1.0 - p0)

    def ppf(q):
        return mean + std * ndtri(p0 + q * (1.0 - p0))

    mid = (np.arange(nodes) + 0.5) / nodes
    e_sum, cap_sum = 0.0, 0.0
    for lo in range(0, phi.size, 64):
        ph = phi[lo : lo + 64, None]
        u = speed * np.sin(theta - ph)  # |v_n'|
        d_star = d_ref * (u / VC_A) ** (1.0 / EXPONENT)  # v_c(d*) = u
        q_star = cdf(d_star)
        cap_sum += float(q_star.sum())
        d = ppf(q_star + mid[None, :] * (1.0 - q_star))
        v_c = VC_A * (d / d_ref) ** EXPONENT
        k2 = K2_A * (d / d_ref) ** EXPONENT
        e = (K1 / (K1 + u)) * (1.0 - k2 / (k2 + u - v_c))
        cot = 1.0 / np.tan(theta - ph)
        mu = np.clip(2.0 * cot / (7.0 * (1.0 + e)), -FRICTION, FRICTION)
        t = np.tan(ph)
        e_m = (e - t * (cot - mu * (1.0 + e))) / (1.0 + t * cot)
        e_sum += float((e_m.mean(axis=1) * (1.0 - q_star[:, 0])).sum())
    return {"e_mean": e_sum / phi.size, "capture_fraction": cap_sum / phi.size}


def qmc_error_ratio(n: int, replicates: int, reference: float, angles) -> dict:
    """RMS error of the mean e_m over `replicates` estimates of `n` impacts each."""
    import microimpact as mi

    qmc = make_scenario(angles, sampling="qmc", qmc_replicates=replicates)
    qmc_est = {}
    for br in mi.iter_blocks(qmc, samples=n * replicates, seed=SEED, progress=False):
        if br.done:
            qmc_est[br.replicate] = br.total.e_all().mean
    mc = make_scenario(angles)
    mc_est = [
        _summary_stats(mi.run(mc, samples=n, seed=SEED + 1 + r, progress=False))[
            "e_mean"
        ]
        for r in range(replicates)
    ]
    rms_qmc = math.sqrt(np.mean((np.array(list(qmc_est.values())) - reference) ** 2))
    rms_mc = math.sqrt(np.mean((np.array(mc_est) - reference) ** 2))
    return {
        "ratio": rms_mc / rms_qmc,
        "rms_mc": rms_mc,
        "rms_qmc": rms_qmc,
        "n_per_replicate": n,
        "replicates": replicates,
    }


# ------------------------------------------------------- 8. paper reproduction
def paper_reproduction(samples: int, *, max_presets=None, cli_out=None) -> dict:
    """Time the presets (all, or the first `max_presets`) at `samples` impacts per
    point (engine only) and, with `cli_out`, ``microimpact reproduce`` as a user
    runs it."""
    try:
        from microimpact.scenario.file import PRESETS
        from microimpact.scenario.scenario import load_preset
    except ImportError as exc:
        return {"skipped": f"presets not available ({exc})"}
    import microimpact as mi

    out = {"samples": samples, "presets": {}}
    t_all = time.perf_counter()
    for name in list(PRESETS)[:max_presets]:
        t0 = time.perf_counter()
        result = mi.run(load_preset(name), samples=samples, workers=1, progress=False)
        out["presets"][name] = {
            "points": len(result.summary),
            "s": time.perf_counter() - t0,
        }
    out["engine_s"] = time.perf_counter() - t_all
    if cli_out is not None:
        cmd = [
            sys.executable,
            "-c",
            "import sys; from microimpact.cli import main; sys.exit(main())",
            "reproduce",
            "--out",
            str(cli_out),
            "--quiet",
            "--samples",
            str(samples),
            "--formats",
            "png",
        ]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if proc.returncode == 0:
            out["cli_s"] = time.perf_counter() - t0
        else:
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:]
            out["cli_note"] = f"reproduce exited {proc.returncode}: {' '.join(tail)}"
    return out


# ------------------------------------------------------------ process plumbing
def _self_maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB->MiB


TASKS = {
    "rng": lambda p: rng_floor(p["n"]),
    "rng_classic": lambda p: rng_floor_classic(p["n"]),
    "numpy": lambda p: _numpy_task(p["n"], p["seed"]),
    "engine": lambda p: _engine_task(
        p["n"], p["workers"], p["seed"], p.get("warmup", True)
    ),
    "fixed_cost": lambda p: _fixed_cost_task(p["workers"]),
    "grid": lambda p: _grid_task(
        p["shape"], p["samples"], p["workers"], p["seed"], p.get("warmup", True)
    ),
    "dask": lambda p: _dask_task(p["n"], p["workers"], p["repeats"]),
    "wall_law": lambda p: _wall_law_task(
        p["shape"], p["samples"], p["workers"], p["seed"]
    ),
    "areal_ratio": lambda p: _areal_ratio_task(p["n"], p["rounds"]),
    "qmc_ratio": lambda p: _qmc_ratio_task(p["n"], p["rounds"]),
    "wall_law_ratio": lambda p: _wall_law_ratio_task(
        p["shape"], p["samples"], p["rounds"]
    ),
}


def _run_task(p: dict) -> dict:
    """Run task ``p["task"]`` ``p["reps"]`` times (seeds ``seed, seed + 1, ...``;
    the warm-up, if any, only before the first)."""
    runs = []
    for r in range(p.get("reps", 1)):
        q = dict(
            p, seed=p.get("seed", SEED) + r, warmup=p.get("warmup", True) and r == 0
        )
        runs.append(TASKS[p["task"]](q))
    return {"runs": runs}


def _child(spec: str) -> int:
    out = _run_task(json.loads(spec))
    out["maxrss_mb"] = _self_maxrss_mb()
    out["children_maxrss_mb"] = (
        resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    )
    print("@@RESULT " + json.dumps(out))
    return 0


def measure(task: str, *, isolate: bool, **params) -> dict:
    """Run a measurement (``reps`` times), in a fresh process when `isolate`.

    Returns ``{"runs": [...], "maxrss_mb": ..., "children_maxrss_mb": ...}``.
    """
    params["task"] = task
    if not isolate:
        out = _run_task(params)
        out["maxrss_mb"] = out["children_maxrss_mb"] = None
        return out
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", json.dumps(params)]
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env)
    for line in proc.stdout.splitlines():
        if line.startswith("@@RESULT "):
            return json.loads(line[len("@@RESULT ") :])
    raise RuntimeError(
        f"benchmark child {task} failed (exit {proc.returncode}):\n{proc.stderr}"
    )


def repeated(
    task: str, repeats: int, *, isolate: bool, per_process: bool, **params
) -> dict:
    """Median rate of `repeats` measurements (each with its own seed), each in its
    own fresh process (`per_process`) or all in one."""
    if per_process:
        procs = [
            measure(task, isolate=isolate, seed=SEED + r, **params)
            for r in range(repeats)
        ]
    else:
        procs = [measure(task, isolate=isolate, seed=SEED, reps=repeats, **params)]
    runs = [run for p in procs for run in p["runs"]]
    rates = [r["rate"] for r in runs]
    rss = [p["maxrss_mb"] for p in procs if p["maxrss_mb"] is not None]
    kids = [p["children_maxrss_mb"] for p in procs if p["children_maxrss_mb"]]
    return {
        "rate": statistics.median(rates),
        "rates": rates,
        "maxrss_mb": max(rss) if rss else None,
        "workers_maxrss_mb": max(kids) if kids else None,
        "runs": runs,
    }


def agreement(a: dict, b: dict) -> dict:
    """z-scores of the differences of e_mean and capture_fraction of two estimates."""
    z_e = (a["e_mean"] - b["e_mean"]) / math.hypot(a["e_se"], b["e_se"])
    pa, pb = a["capture_fraction"], b["capture_fraction"]
    se_c = math.sqrt(pa * (1 - pa) / a["n"] + pb * (1 - pb) / b["n"])
    return {"z_e_mean": z_e, "z_capture_fraction": (pa - pb) / se_c}


def check_agreement(a: dict, b: dict, what: str) -> dict:
    z = agreement(a, b)
    bad = {k: v for k, v in z.items() if not abs(v) <= AGREEMENT_SE}
    if bad:
        raise RuntimeError(
            f"{what}: differ by more than {AGREEMENT_SE} standard errors: {bad}"
        )
    return z


def write_json_atomic(path, data) -> None:
    from microimpact._core.files import atomic_write

    text = json.dumps(data, indent=2) + "\n"
    atomic_write(path, lambda tmp: Path(tmp).write_text(text))


# ------------------------------------------------------------------------ main
def _fmt(x, spec):
    width = int(spec.split(".")[0] or 0)
    return f"{'-':>{width}}" if x is None else format(x, spec)


def print_table(res: dict) -> None:
    floor = res["rng_floor_per_s"]
    classic = res["rng_floor_classic_per_s"]
    base = res["numpy_baseline_per_s"]
    rss = res["details"]["variant_peak_rss_mb"]
    shape = "x".join(str(k) for k in res["grid_shape"])
    rows = [
        ("RNG floor: engine streams (2 x random_raw)", floor),
        ("RNG floor: classic (normal + uniform, out=)", classic),
        ("NumPy whole arrays (user baseline)", base),
        ("microimpact.run, 1 process", res["engine_per_s"]),
        (
            f"microimpact.run, {res['cpu_count']} workers",
            res["engine_all_cores_per_s"],
        ),
        (f"microimpact.run, Dask LocalCluster ({res['cpu_count']})", res["dask_per_s"]),
        (f"grid {shape}, {res['grid_samples']}/point, 1 process", res["grid_per_s"]),
        (
            f"grid {shape}, {res['cpu_count']} workers",
            res["grid_all_cores_per_s"],
        ),
    ]
    keys = ["rng", "rng_classic", "numpy", "engine", "engine_all_cores", "dask"]
    keys += ["grid", "grid_all_cores"]
    print(
        f"{'variant':<46} {'M/s':>7} {'floor/x':>8} {'classic/x':>9} "
        f"{'x/numpy':>8} {'peak RSS MiB':>13}"
    )
    for (name, rate), key in zip(rows, keys, strict=True):
        print(
            f"{name:<46} {_fmt(rate and rate / 1e6, '7.2f')} "
            f"{_fmt(rate and floor / rate, '8.2f')} "
            f"{_fmt(rate and classic / rate, '9.2f')} "
            f"{_fmt(rate and rate / base, '8.2f')} {rss.get(key) or '-':>13}"
        )
    print(
        "floor/x, classic/x: times slower than each RNG floor; x/numpy: speed-up over "
        "the NumPy baseline.\nPeak RSS of the measuring process ('+X/wkr': the "
        "largest process-pool or Dask worker, which shares most pages with it)."
    )
    print(
        f"wall law {'x'.join(str(k) for k in res['details']['wall_law_shape'])} "
        f"nodes at {res['wall_law_samples']}/node, {res['cpu_count']} processes: "
        f"{res['wall_law_build_s']:.1f} s ({res['wall_law_per_s'] / 1e6:.2f} M/s)"
    )
    by_n = ", ".join(
        f"{int(n):.0e}: {v:.0f}" for n, v in res["peak_rss_mb_by_n"].items()
    )
    print(f"peak RSS of a fresh run [MiB] by N: {by_n}")
    print(
        f"grid / one large point: {res['grid_ratio']:.2f} (1 process), "
        f"{res['grid_all_cores_ratio']:.2f} ({res['cpu_count']} workers)"
    )
    q = res["details"].get("qmc")
    if q:
        print(
            f"QMC: RMS error of mean e_m at N={q['n_per_replicate']}, "
            f"{q['replicates']} replicates: MC {q['rms_mc']:.2e}, QMC "
            f"{q['rms_qmc']:.2e}, ratio {q['ratio']:.2f}"
        )
    if res.get("dask_cluster_start_s") is not None:
        print(f"Dask LocalCluster start: {res['dask_cluster_start_s']:.2f} s")
    if res.get("paper_reproduction_s") is not None:
        n_presets = len(res["details"]["paper_reproduction"]["presets"])
        print(
            f"paper reproduction ({n_presets} presets, "
            f"{res['paper_reproduction_samples']} "
            f"per point, engine only): {res['paper_reproduction_s']:.2f} s"
        )
    if res.get("paper_reproduction_cli_s") is not None:
        print(f"microimpact reproduce (CLI): {res['paper_reproduction_cli_s']:.2f} s")
    if res["details"].get("ratios"):
        print_ratios(res["details"]["ratios"], res["rng_floor_per_s"])
    for note in res["notes"]:
        print(f"note: {note}")


def engine_and_grid(cfg: dict, workers: int, kw: dict) -> tuple:
    """The single large point and a sweep grid of many small points, each on 1
    process and on `workers`: ``(engine, engine_all_cores, grid,
    grid_all_cores)`` of :func:`repeated`."""
    iso, reps = cfg["isolate"], cfg["repeats"]
    eng = repeated("engine", reps, n=cfg["n_engine"], workers=1, **kw)
    allc = repeated(
        "engine", reps, n=cfg["n_engine"], workers=workers, warmup=iso, **kw
    )
    gkw = dict(shape=cfg["grid"], samples=cfg["grid_samples"])
    grid1 = repeated("grid", reps, workers=1, **gkw, **kw)
    grid_all = repeated("grid", reps, workers=workers, warmup=iso, **gkw, **kw)
    return eng, allc, grid1, grid_all


def engine_and_grid_fields(cfg: dict, eng, allc, grid1, grid_all) -> dict:
    """The rates and grid ratios of :func:`engine_and_grid`'s measurements."""
    return {
        "engine_per_s": eng["rate"],
        "engine_all_cores_per_s": allc["rate"],
        "grid_per_s": grid1["rate"],
        "grid_all_cores_per_s": grid_all["rate"],
        "grid_ratio": grid1["rate"] / eng["rate"],
        "grid_all_cores_ratio": grid_all["rate"] / allc["rate"],
        "grid_shape": list(cfg["grid"]),
        "grid_samples": cfg["grid_samples"],
    }


def run_grid_benchmark(mode: str) -> dict:
    """Only the single large point and the sweep grid, on 1 process and on all
    cores (``--grid-only``: the ratios of item 9 without the rest)."""
    cfg = MODES[mode]
    iso, reps = cfg["isolate"], cfg["repeats"]
    kw = dict(isolate=iso, per_process=cfg["process_per_repeat"])
    workers = os.cpu_count() or 1
    t_start = time.perf_counter()
    eng, allc, grid1, grid_all = engine_and_grid(cfg, workers, kw)
    return {
        **engine_and_grid_fields(cfg, eng, allc, grid1, grid_all),
        "mode": mode,
        "n_engine": cfg["n_engine"],
        "repeats": reps,
        "cpu_count": workers,
        "wall_s": time.perf_counter() - t_start,
        "details": {
            "rates": {
                "engine": eng["rates"],
                "engine_all_cores": allc["rates"],
                "grid": grid1["rates"],
                "grid_all_cores": grid_all["rates"],
            },
            "grid_driver_cpu_s": [r["driver_cpu_s"] for r in grid_all["runs"]],
            "grid_workers_cpu_s": [r["workers_cpu_s"] for r in grid_all["runs"]],
        },
    }


def print_grid_table(res: dict) -> None:
    shape = "x".join(str(k) for k in res["grid_shape"])
    P = res["cpu_count"]
    rates = res["details"]["rates"]
    for name, key in (
        ("microimpact.run, 1 process", "engine"),
        (f"microimpact.run, {P} workers", "engine_all_cores"),
        (f"grid {shape}, {res['grid_samples']}/point, 1 process", "grid"),
        (f"grid {shape}, {P} workers", "grid_all_cores"),
    ):
        runs = ", ".join(f"{r / 1e6:.1f}" for r in rates[key])
        print(f"{name:<46} {res[key + '_per_s'] / 1e6:7.2f} M/s  (runs: {runs})")
    cpu = res["details"]
    print(
        f"grid on {P} workers: this process's CPU (with worker threads: all of it) "
        + ", ".join(f"{c:.3f}" for c in cpu["grid_driver_cpu_s"])
        + " s; worker processes' CPU "
        + ", ".join(f"{c:.3f}" for c in cpu["grid_workers_cpu_s"])
        + " s"
    )
    print(
        f"grid / one large point: {res['grid_ratio']:.2f} (1 process), "
        f"{res['grid_all_cores_ratio']:.2f} ({P} workers)"
    )


def run_benchmark(mode: str, *, dask: bool = True, reproduce: bool = True) -> dict:
    cfg = MODES[mode]
    iso, reps = cfg["isolate"], cfg["repeats"]
    kw = dict(isolate=iso, per_process=cfg["process_per_repeat"])
    workers = os.cpu_count() or 1
    notes, details = [], {"config": cfg}
    t_start = time.perf_counter()

    rng = repeated("rng", reps, n=cfg["n_rng"], **kw)
    classic = repeated("rng_classic", reps, n=cfg["n_rng"], **kw)
    n_np = min(cfg["n_numpy"], NUMPY_MAX_N)
    npb = repeated("numpy", reps, n=n_np, **kw)
    eng, allc, grid1, grid_all = engine_and_grid(cfg, workers, kw)
    details["wall_law_shape"] = list(cfg["wall_law"])
    wall = measure(
        "wall_law",
        isolate=iso,
        shape=cfg["wall_law"],
        samples=cfg["wall_law_samples"],
        workers=workers,
    )["runs"][0]
    if iso:  # the fixed cost of one run (pool start, plan, result)
        details["fixed_cost_s"] = {
            str(w): measure("fixed_cost", isolate=iso, workers=w)["runs"][0]["wall_s"]
            for w in sorted({1, workers})
        }

    # both compute the same physics: NumPy baseline versus engine, and both versus
    # the independent quadrature of the exact expectation
    angles, raw = formica_angles()
    ref = reference_values(raw)
    np_stats = npb["runs"][0]["stats"]
    eng_stats = eng["runs"][0]["stats"]
    details["agreement"] = {
        "numpy_vs_engine": check_agreement(np_stats, eng_stats, "NumPy vs engine"),
        "reference": ref,
        "engine_e_mean_z_vs_reference": (eng_stats["e_mean"] - ref["e_mean"])
        / eng_stats["e_se"],
        "numpy_e_mean_z_vs_reference": (np_stats["e_mean"] - ref["e_mean"])
        / np_stats["e_se"],
        "engine": eng_stats,
        "numpy": np_stats,
    }

    rss_by_n = {}
    for n in cfg["rss_ns"]:
        r = measure("engine", isolate=True, n=n, workers=1, warmup=False)
        rss_by_n[str(n)] = r["maxrss_mb"]

    dask_rate = dask_start = None
    if dask:
        dp = measure(
            "dask", isolate=iso, n=cfg["n_engine"], workers=workers, repeats=reps
        )
        d = dict(dp["runs"][0], maxrss_mb=dp["maxrss_mb"])
        if "skipped" in d:
            notes.append(f"Dask skipped: {d['skipped']}")
        else:
            dask_rate = statistics.median(d["rates"])
            dask_start = d["cluster_start_s"]
            details["dask"] = d
    else:
        notes.append("Dask skipped (--no-dask)")

    q = qmc_error_ratio(cfg["qmc_n"], cfg["qmc_replicates"], ref["e_mean"], angles)
    details["qmc"] = q
    ratios = _ratio_tasks(mode, iso)
    details["ratios"] = ratios

    repro = None
    if reproduce:
        with tempfile.TemporaryDirectory() as tmp:
            cli_out = Path(tmp) / "reproduce" if cfg["reproduce_cli"] else None
            repro = paper_reproduction(
                cfg["reproduce_samples"],
                max_presets=cfg["reproduce_presets"],
                cli_out=cli_out,
            )
        if "skipped" in repro:
            notes.append(f"paper reproduction skipped: {repro['skipped']}")
            repro = None
        else:
            details["paper_reproduction"] = repro
            if "cli_note" in repro:
                notes.append(repro["cli_note"])
    if mode == "smoke":
        notes.append("smoke mode: tiny sizes, the timings mean nothing")

    details["variant_peak_rss_mb"] = {
        "rng": _rss_str(rng),
        "rng_classic": _rss_str(classic),
        "numpy": _rss_str(npb),
        "engine": _rss_str(eng),
        "engine_all_cores": _rss_str(allc, pool=True),
        "grid": _rss_str(grid1),
        "grid_all_cores": _rss_str(grid_all, pool=True),
        "dask": _dask_rss_str(details.get("dask")),
    }
    details["rates"] = {
        k: v["rates"]
        for k, v in (
            ("rng", rng),
            ("rng_classic", classic),
            ("numpy", npb),
            ("engine", eng),
            ("engine_all_cores", allc),
            ("grid", grid1),
            ("grid_all_cores", grid_all),
        )
    }
    details["engine_elapsed_s"] = [r["engine_elapsed_s"] for r in eng["runs"]]
    from microimpact.engine.result import versions

    return {
        "rng_floor_per_s": rng["rate"],
        "numpy_baseline_per_s": npb["rate"],
        **engine_and_grid_fields(cfg, eng, allc, grid1, grid_all),
        "wall_law_build_s": wall["wall_s"],
        "wall_law_per_s": wall["rate"],
        "wall_law_nodes": wall["nodes"],
        "wall_law_samples": cfg["wall_law_samples"],
        "dask_per_s": dask_rate,
        "peak_rss_mb": max(rss_by_n.values()),
        "qmc_error_ratio": q["ratio"],
        **ratio_fields(ratios),
        "rng_floor_classic_per_s": classic["rate"],
        "peak_rss_mb_by_n": rss_by_n,
        "dask_cluster_start_s": dask_start,
        "paper_reproduction_s": None if repro is None else repro["engine_s"],
        "paper_reproduction_cli_s": None if repro is None else repro.get("cli_s"),
        "paper_reproduction_samples": None if repro is None else repro["samples"],
        "mode": mode,
        "n": {
            "rng": cfg["n_rng"],
            "numpy": n_np,
            "engine": cfg["n_engine"],
            "qmc_per_replicate": cfg["qmc_n"],
        },
        "repeats": reps,
        "cpu_count": workers,
        "kernel": eng["runs"][0]["kernel"],
        "machine": {**versions(), **_machine()},
        "wall_s": time.perf_counter() - t_start,
        "notes": notes,
        "details": details,
    }


def _machine() -> dict:
    """The platform, and the CPU model and vector extensions (``/proc/cpuinfo``)."""
    out = {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
    }
    model, flags = None, []
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and model is None:
                    model = value.strip()
                elif key.strip() == "flags" and not flags:
                    flags = value.split()
    except OSError:
        pass
    simd = [f for f in ("sse4_2", "avx", "avx2", "fma") if f in flags]
    simd += sorted(f for f in flags if f.startswith("avx512"))
    out["cpu_model"] = model or platform.processor() or "unknown"
    out["vector_extensions"] = simd
    out["cpu"] = f"{out['cpu_model']} ({os.cpu_count()} CPUs; {', '.join(simd[:4])}"
    out["cpu"] += f"{', ...' if len(simd) > 4 else ''})"
    return out


def _rss_str(rep, pool=False):
    if rep["maxrss_mb"] is None:
        return None
    s = f"{rep['maxrss_mb']:.0f}"
    if pool and rep["workers_maxrss_mb"]:
        s += f" +{rep['workers_maxrss_mb']:.0f}/wkr"
    return s


def _dask_rss_str(d):
    if not d or not d.get("worker_maxrss_mb"):
        return None
    driver = "-" if d.get("maxrss_mb") is None else f"{d['maxrss_mb']:.0f}"
    return f"{driver} +{max(d['worker_maxrss_mb']):.0f}/wkr"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true", help="about one minute")
    size.add_argument(
        "--smoke", action="store_true", help="about 10 s, tiny sizes (CI)"
    )
    parser.add_argument("--json", type=Path, metavar="PATH", help="write results")
    parser.add_argument("--no-dask", action="store_true", help="skip the Dask run")
    parser.add_argument(
        "--no-reproduce", action="store_true", help="skip the paper reproduction"
    )
    parser.add_argument(
        "--grid-only",
        action="store_true",
        help="only engine_per_s and grid_per_s (1 process and all cores)",
    )
    parser.add_argument(
        "--ratios-only",
        action="store_true",
        help="only the RNG floor and issue 24's ratios (areal, wall law, QMC)",
    )
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return _child(args.child)
    mode = "smoke" if args.smoke else "quick" if args.quick else "full"
    if args.ratios_only:
        cfg = MODES[mode]
        t0 = time.perf_counter()
        rng = repeated(
            "rng",
            cfg["repeats"],
            n=cfg["n_rng"],
            isolate=cfg["isolate"],
            per_process=cfg["process_per_repeat"],
        )
        ratios = _ratio_tasks(mode, cfg["isolate"])
        res = {
            "rng_floor_per_s": rng["rate"],
            **ratio_fields(ratios),
            "mode": mode,
            "machine": _machine(),
            "wall_s": time.perf_counter() - t0,
            "details": {"ratios": ratios},
        }
        print(
            f"# microimpact issue-24 ratios, mode {mode}, {res['machine']['cpu']}; "
            f"RNG floor {rng['rate'] / 1e6:.1f} M/s; {res['wall_s']:.0f} s in all"
        )
        print_ratios(ratios, rng["rate"])
        if args.json:
            write_json_atomic(args.json, res)
        return 0
    if args.grid_only:
        res = run_grid_benchmark(mode)
        print(
            f"# microimpact grid benchmark, mode {mode}, {res['cpu_count']} CPUs; "
            f"N engine {res['n_engine']:.3g}; median of {res['repeats']}; "
            f"{res['wall_s']:.0f} s in all"
        )
        print_grid_table(res)
        if args.json:
            write_json_atomic(args.json, res)
        return 0
    res = run_benchmark(mode, dask=not args.no_dask, reproduce=not args.no_reproduce)
    print(
        f"# microimpact benchmark, mode {mode}, {res['cpu_count']} CPUs, "
        f"Python {res['machine']['python']}, NumPy {res['machine']['numpy']}; "
        f"N engine {res['n']['engine']:.3g}, NumPy {res['n']['numpy']:.3g}; "
        f"median of {res['repeats']}; {res['kernel']} kernel; "
        f"{res['wall_s']:.0f} s in all"
    )
    print_table(res)
    if args.json:
        write_json_atomic(args.json, res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
