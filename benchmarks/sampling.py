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
is the median over ``--repeat`` runs. Usage::

    python benchmarks/sampling.py [--quick] [--n N] [--chunk C] [--repeat R]
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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small run (~1 s)")
    parser.add_argument("--n", type=int, default=None, help="draws per run")
    parser.add_argument("--chunk", type=int, default=1 << 16, help="draws per call")
    parser.add_argument("--repeat", type=int, default=None, help="runs per variant")
    args = parser.parse_args(argv)
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
