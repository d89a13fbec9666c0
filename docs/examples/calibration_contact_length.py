"""Worked example of docs/calibration.md: recover the contact length of the Formica
surface from relative e and mu "measured" (simulated with another seed) at 30 um.

The sst76-formica-oblique preset, with its Formica surface drawn from the shipped
synthetic Formica profile (kind "synthetic") so that the contact length is a number of
the scenario. Run: python docs/examples/calibration_contact_length.py OUT_DIR
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pandas as pd

import microimpact
from microimpact.analysis.calibration import calibrate
from microimpact.scenario.file import preset_path, read_toml
from microimpact.scenario.parameters import with_values
from microimpact.scenario.scenario import scenario_from_dict

KEY = "surfaces.formica.contact_length_um"
TRUTH = 30.0


def scenario_data():
    path = preset_path("sst76-formica-oblique")
    data = read_toml(path)
    data["surfaces"] = [
        {"name": "formica", "kind": "synthetic", "contact_length_um": 20.0}
    ]
    data["sweep"]["angle_deg"] = [20, 30, 40, 50, 60, 70, 85]
    return data, path.parent


def measurements(data, base_dir, seed=2):
    sc = scenario_from_dict(with_values(data, {KEY: TRUTH}), base_dir=base_dir)
    s = microimpact.run(sc, seed=seed, progress=False).summary
    rows = []
    for _, r in s[s.angle_deg < 85].iterrows():
        for stat in ("e_relative", "mu_relative"):
            m, se = r[stat], r[f"{stat}_se"]
            rows.append(
                {
                    "angle_deg": r.angle_deg,
                    "statistic": stat,
                    "mean": m,
                    "ci_low": m - 1.96 * se,
                    "ci_high": m + 1.96 * se,
                }
            )
    return pd.DataFrame(rows)


def main(out):
    data, base_dir = scenario_data()
    exp = measurements(data, base_dir)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    exp.to_csv(out / "measured.csv", index=False)
    t0 = time.perf_counter()
    res = calibrate(
        data,
        exp,
        {KEY: (5.0, 100.0)},
        base_dir=base_dir,
        seed=20000376,
        bootstrap=40,
        workers=2,
    )
    res.write(out)
    print(res.parameters_table().T)
    print("chi2", res.chi2, "dof", res.dof, "p", res.p_value)
    print(res.info)
    print(f"{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "calibration_example")
