"""Benchmark: diameters drawn per second from an empirical QuantileTable, one core.

Compares, for a PDPA-like empirical sample of 10,000 diameters tabulated into
``QuantileTable`` (2**16 equiprobable atoms):

* ``random floor``     -- ``rng.random(out=buf)``: the uniform random-number floor;
* ``integers floor``   -- ``rng.integers(0, M, out-of-place)``: the index floor;
* ``table.sample``     -- ``QuantileTable.sample(n, rng=rng)`` as the engine calls it;
* ``table.sample out`` -- the same with a preallocated ``out=`` buffer;
* ``raw bits + take``  -- index from the high bits of ``random_raw`` (no bounding);
* ``np.interp``        -- inverse-CDF interpolation of the sorted sample.

All variants draw in chunks of ``--chunk`` values (default 2**16, L2-sized). Each figure
is the median over ``--repeat`` runs.

``--pairs`` measures instead the compiled kernel on a rough particle whose pair of
angles is drawn from two measured sets (the *Lycopodium* preset's Formica angles
with themselves, 16 M pairs), impacts per second of ``kernel.simulate_specs`` (keyed
Monte Carlo, draws included) on one core at ``--theta`` (default 30 deg), 2 m/s:

* ``search``: ``"weighted"`` shadowing, the exact pair search (``plan.PairSearch``);
* ``equal pairs``: ``"reject"``, the equiprobable pair ranks (``plan.PairSampler``);
* ``old table``: ``"weighted"`` on the reduced 1,024-atom convolution the search
  replaced (not exact; for reference).

The three are timed round by round (``--repeat`` rounds, medians); the search's
expected acceptance rate is printed where the tables report it. Usage::

    python benchmarks/sampling.py [--quick] [--n N] [--chunk C] [--repeat R]
    python benchmarks/sampling.py --pairs [--blocks B] [--repeat R] [--theta DEG]
"""

from __future__ import annotations

import argparse
import platform
import sys
import time

import numpy as np

from microimpact.population.distributions import empirical_diameters

TARGET = 50e6  # diameters per second


def _rate(fn, n_total: int, chunk: int, repeat: int) -> float:
    """Median draws per second of ``fn(chunk)`` called n_total / chunk times."""
    calls = max(1, n_total // chunk)
    fn(chunk)  # warm-up
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn(chunk)
        times.append(time.perf_counter() - t0)
    return calls * chunk / float(np.median(times))


def _pair_plans(theta_deg: float):
    """The three plans of ``--pairs`` (see the module docstring)."""
    import dataclasses

    from microimpact.engine import plan as plan_module
    from microimpact.scenario.scenario import Scenario

    sc = Scenario.from_preset("lycopodium-formica-oblique")
    sc = dataclasses.replace(
        sc, angles_deg=(theta_deg,), speeds_m_s=(2.0,), speed_spread=0.0
    )
    weighted = dataclasses.replace(sc, shadowing="weighted")
    plans = {
        "search": plan_module.build_plan(weighted, kernel="compiled"),
        "equal pairs": plan_module.build_plan(
            dataclasses.replace(sc, shadowing="reject"), kernel="compiled"
        ),
    }
    keep = plan_module.MAX_SUM_ATOMS
    plan_module.MAX_SUM_ATOMS = 1 << 62  # the reduced convolution, as before
    try:
        plans["old table"] = plan_module.build_plan(weighted, kernel="compiled")
    finally:
        plan_module.MAX_SUM_ATOMS = keep
    return plans


def pairs(blocks: int, repeat: int, theta_deg: float) -> dict:
    """Impacts per second of the three pair cases, medians of `repeat` rounds."""
    from microimpact.engine import kernel

    plans = _pair_plans(theta_deg)
    search = plans["search"].angle_tables(0, theta_deg)
    if not search.pair_search:
        raise SystemExit("the 'search' plan does not draw its pairs by a search")
    n = plans["search"].block_size
    specs = [(0, 0, b, n) for b in range(blocks)]
    for plan in plans.values():
        kernel.simulate_specs(plan, specs[:4])  # warm-up: tables, parsing
    rates = {name: [] for name in plans}
    for _ in range(repeat):
        for name, plan in plans.items():
            t0 = time.perf_counter()
            kernel.simulate_specs(plan, specs)
            rates[name].append(blocks * n / (time.perf_counter() - t0))
    out = {name: float(np.median(r)) for name, r in rates.items()}
    acceptance = getattr(search, "pair_acceptance", None)
    print(
        f"# Formica x Formica at {theta_deg:g} deg, 2 m/s; {blocks} blocks of {n} "
        f"impacts, median of {repeat} rounds (one core)"
    )
    for name, r in out.items():
        print(f"{name:<12} {r / 1e6:8.1f} M impacts/s {1e9 / r:8.2f} ns/impact")
    if acceptance is not None:
        print(f"search acceptance rate {acceptance:.4f}")
    out["acceptance"] = acceptance
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small run (~1 s)")
    parser.add_argument(
        "--pairs", action="store_true", help="the pair search (see above)"
    )
    parser.add_argument("--blocks", type=int, default=200, help="--pairs: blocks")
    parser.add_argument("--theta", type=float, default=30.0, help="--pairs: deg")
    parser.add_argument("--n", type=int, default=None, help="draws per run")
    parser.add_argument("--chunk", type=int, default=1 << 16, help="draws per call")
    parser.add_argument("--repeat", type=int, default=None, help="runs per variant")
    args = parser.parse_args(argv)
    if args.pairs:
        pairs(args.blocks, args.repeat or 5, args.theta)
        return 0
    n = args.n or (1 << 21 if args.quick else 1 << 24)
    repeat = args.repeat or (3 if args.quick else 5)
    chunk = args.chunk

    rng = np.random.default_rng(20000101)
    measured_um = rng.normal(52.8, 15.3, 10_000)  # [1] SST65-like PDPA sample
    measured_um = measured_um[measured_um > 0]
    dist = empirical_diameters(measured_um)
    table = dist.table()
    xs = np.sort(dist.atoms)
    ps = (np.arange(xs.size) + 0.5) / xs.size
    size, shift = table.size, np.uint64(64 - table.bits)
    ubuf = np.empty(chunk)
    obuf = np.empty(chunk)
    bitgen = rng.bit_generator

    variants = {
        "random floor": lambda k: rng.random(out=ubuf[:k]),
        "integers floor": lambda k: rng.integers(0, size, size=k, dtype=np.intp),
        "table.sample": lambda k: table.sample(k, rng=rng),
        "table.sample out": lambda k: table.sample(k, rng=rng, out=obuf[:k]),
        "raw bits + take": lambda k: np.take(
            table.values, (bitgen.random_raw(k) >> shift).astype(np.intp), out=obuf[:k]
        ),
        "np.interp": lambda k: np.interp(rng.random(out=ubuf[:k]), ps, xs),
    }
    print(
        f"# {platform.python_implementation()} {platform.python_version()}, "
        f"NumPy {np.__version__}, {platform.machine()}; n={n}, chunk={chunk}, "
        f"repeat={repeat}, table size={size}"
    )
    print(f"{'variant':<18} {'M draws/s':>10} {'ns/draw':>9} {'vs floor':>9}")
    floor = None
    rates = {}
    for name, fn in variants.items():
        r = _rate(fn, n, chunk, repeat)
        rates[name] = r
        floor = floor or r
        print(f"{name:<18} {r / 1e6:10.1f} {1e9 / r:9.2f} {floor / r:8.2f}x")
    ok = rates["table.sample"] >= TARGET
    print(
        f"table.sample target {TARGET / 1e6:.0f} M/s: {'met' if ok else 'NOT met'}; "
        f"np.interp is {rates['table.sample'] / rates['np.interp']:.1f}x slower"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
