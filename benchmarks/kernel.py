"""Kernel-only benchmark: the compiled block of the benchmark point, beside its floor.

Measures in one process, interleaved round by round (so that the shared machine's
noise hits every figure alike), for the one-point scenario of ``benchmarks/run.py``
(normal diameters, Formica angles, 30 deg, 1 m/s, ``"reject"``):

* ``floor``: the engine's own draws, ``kernel.stream_raw`` for the diameter and the
  angle of every block (what ``rng_floor_per_s`` measures);
* ``kernel``: ``kernel.simulate_block`` over the same blocks (draws included);
* ``block``: the compiled block alone on pre-drawn draws, in ns per impact.

Prints the medians over ``--rounds`` rounds and ``kernel / floor``. Usage::

    python benchmarks/kernel.py [--blocks 300] [--rounds 5] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from run import SEED, make_scenario

from microimpact.engine import kernel
from microimpact.engine.plan import (
    BLOCK_SIZE,
    VAR_ANGLE,
    VAR_DIAMETER,
    build_plan,
)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    plan = build_plan(make_scenario(), seed=SEED, kernel="compiled")
    nb, n = args.blocks, BLOCK_SIZE
    sp = plan.points[0]
    tables = plan.angle_tables(sp.surface, sp.angle_deg)
    raws = [
        {
            VAR_DIAMETER: kernel.stream_raw(plan.entropy, 0, b, VAR_DIAMETER, n),
            VAR_ANGLE: kernel.stream_raw(plan.entropy, 0, b, VAR_ANGLE, n),
        }
        for b in range(min(nb, 32))
    ]
    kernel.simulate_block(plan, 0, 0, 0, n)  # warm-up

    def floor():
        for b in range(nb):
            for var in (VAR_DIAMETER, VAR_ANGLE):
                kernel.stream_raw(plan.entropy, 0, b, var, n)

    def full():
        for b in range(nb):
            kernel.simulate_block(plan, 0, 0, b, n)

    def block():
        for b in range(nb):
            kernel._simulate_compiled(plan, sp, tables, raws[b % len(raws)], n)

    rates = {"floor": [], "kernel": [], "block": []}
    for _ in range(args.rounds):
        for name, fn in (("floor", floor), ("kernel", full), ("block", block)):
            t0 = time.perf_counter()
            fn()
            rates[name].append(nb * n / (time.perf_counter() - t0))
    med = {k: statistics.median(v) for k, v in rates.items()}
    out = {
        "floor_per_s": med["floor"],
        "kernel_per_s": med["kernel"],
        "block_per_s": med["block"],
        "block_ns_per_impact": 1e9 / med["block"],
        "kernel_ratio": med["kernel"] / med["floor"],
        "rates": rates,
    }
    print(
        f"floor {med['floor'] / 1e6:.1f} M/s, kernel {med['kernel'] / 1e6:.1f} M/s "
        f"(ratio {out['kernel_ratio']:.3f}), block alone {med['block'] / 1e6:.1f} M/s "
        f"= {out['block_ns_per_impact']:.2f} ns/impact; median of {args.rounds}"
    )
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
