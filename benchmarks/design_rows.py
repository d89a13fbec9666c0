"""Sensitivity over design rows against one run (issue 20/24: ``design_row_ratio``).

Both are timed in fresh processes, from the preset's name to the result, so each
pays what a user pays: reading the scenario file, building its tables (for the areal
preset, a 1024 x 1024 synthetic height map) and the impacts.

* ``one_run_s``: ``microimpact.run(PRESET, samples=SAMPLES, workers=1)``;
* ``sensitivity_s``: ``microimpact.sobol_sensitivity(PRESET, 4 parameters of the
  coefficient laws, base_size=4, samples=SAMPLES, workers=1)``: 4 x (4 + 2) = 24
  design rows, each one engine run of every sweep point at SAMPLES impacts;
* ``design_row_ratio = sensitivity_s / one_run_s`` (issue 20's target: <= 3).

Usage::

    python benchmarks/design_rows.py [--samples 1000] [--repeats 3] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
PRESET = "sst76-formica-areal"
#: Parameters the design varies: numbers of the coefficient laws, which leave the
#: surfaces and the size distribution as they were built (ScenarioModel).
PARAMETERS = {
    "coefficients.friction": {"low": 0.1, "high": 0.3},
    "coefficients.k1": {"low": 3.0, "high": 5.0},
    "coefficients.v_c.a_m_s": {"low": 0.15, "high": 0.25},
    "coefficients.k2.a_m_s": {"low": 0.04, "high": 0.06},
}
BASE_SIZE = 4  # 4 * (4 + 2) = 24 design rows


def _one_run(samples: int) -> float:
    import microimpact

    t = time.perf_counter()
    microimpact.run(PRESET, samples=samples, seed=1, workers=1, progress=False)
    return time.perf_counter() - t


def _sensitivity(samples: int) -> float:
    import microimpact

    t = time.perf_counter()
    res = microimpact.sobol_sensitivity(
        PRESET,
        PARAMETERS,
        base_size=BASE_SIZE,
        samples=samples,
        seed=1,
        workers=1,
        n_resamples=10,
        progress=False,
    )
    assert res.evaluations == 24
    return time.perf_counter() - t


def _fresh(task: str, samples: int) -> float:
    code = (
        f"import sys, warnings; sys.path.insert(0, {str(HERE)!r}); "
        "warnings.simplefilter('ignore'); import design_rows as d; "
        f"print(d._{task}({samples}))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    return float(out.stdout.strip().splitlines()[-1])


def design_row_ratio(samples: int = 1000, repeats: int = 3) -> dict:
    """Alternating fresh processes; medians of `repeats` each."""
    one, sens = [], []
    for _ in range(repeats):
        one.append(_fresh("one_run", samples))
        sens.append(_fresh("sensitivity", samples))
    o, s = statistics.median(one), statistics.median(sens)
    return {
        "preset": PRESET,
        "samples": samples,
        "design_rows": 24,
        "one_run_s": o,
        "sensitivity_s": s,
        "design_row_ratio": s / o,
        "one_run_s_all": one,
        "sensitivity_s_all": sens,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--samples", type=int, default=1000)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--json")
    a = p.parse_args(argv)
    res = design_row_ratio(a.samples, a.repeats)
    print(
        f"{PRESET}: one run {res['one_run_s']:.2f} s, sensitivity over 24 design rows "
        f"{res['sensitivity_s']:.2f} s, design_row_ratio {res['design_row_ratio']:.2f}"
    )
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
