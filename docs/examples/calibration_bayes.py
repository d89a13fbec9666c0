"""Worked example of docs/calibration.md: the posterior of a roughness spread and a
v_c law coefficient from synthetic measurements, by both methods.

Writes, to OUT_DIR, a scenario (``bayes.toml``, with a ``[calibration.priors]``
table), "measured" e and mu at 30 and 60 deg and 1 m/s (300 rebounds each,
``means.csv``) and capture counts at 0.235 m/s (300 particles each,
``counts.csv``), all simulated by the engine at the truth (spread 12 deg, v_c
coefficient 0.2 m/s) with another seed; then runs ``microimpact calibrate
--method bayes`` on both files and least squares on the means.

Run: python docs/examples/calibration_bayes.py OUT_DIR
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

import microimpact
from microimpact._core.toml import to_toml
from microimpact.analysis.compare import experiments_from_summary
from microimpact.scenario.parameters import with_values
from microimpact.scenario.scenario import scenario_from_dict

TRUTH = {"surfaces.rough.std_deg": 12.0, "coefficients.v_c.a_m_s": 0.2}

SCENARIO = {
    "name": "bayes-example",
    "seed": 1,
    "samples": 3000,  # 10 x the measured impacts: Monte Carlo variance ratio 0.1
    "particles": {"distribution": "monodisperse", "diameter_um": 50.0},
    "coefficients": {
        "k1": 4.0,
        "k2": {"law": "power", "a_m_s": 0.05, "b": -1.58, "d_ref_um": 52.8},
        "v_c": {"law": "power", "a_m_s": 0.3, "b": -1.58, "d_ref_um": 52.8},
        "p": 1.0,
        "q": 1.0,
        "friction": 0.15,
    },
    "surfaces": [{"name": "rough", "kind": "normal", "std_deg": 10.0}],
    "sweep": {"speed_m_s": [0.235, 1.0], "angle_deg": [30.0, 60.0]},
}

PRIORS = """
[calibration.priors."surfaces.rough.std_deg"]
distribution = "truncnormal"
mean = 10.0
std = 8.0
low = 0.0
high = 45.0
"""


def measurements(out: Path):
    sc = scenario_from_dict(with_values(SCENARIO, TRUTH))
    s = microimpact.run(sc, samples=300, seed=2024, progress=False).summary
    means = experiments_from_summary(s[s["speed_m_s"] == 1.0], by_surface=False)
    cols = ["mean", "ci_low", "ci_high"]
    means[cols] = means[cols].round(5)
    means.to_csv(out / "means.csv", index=False)
    c = s[s["speed_m_s"] == 0.235]
    pd.DataFrame(
        {
            "speed_m_s": c["speed_m_s"],
            "angle_deg": c["angle_deg"],
            "captured": np.rint(c["capture_fraction"] * c["n"]).astype(int),
            "n": c["n"].astype(int),
        }
    ).to_csv(out / "counts.csv", index=False)


def main(out):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "bayes.toml").write_text(to_toml(SCENARIO) + PRIORS)
    measurements(out)
    cli = [sys.executable, "-m", "microimpact", "calibrate", str(out / "bayes.toml")]
    keys = ["--parameter", "surfaces.rough.std_deg=2:30"]
    keys += ["--parameter", "coefficients.v_c.a_m_s=0.1:0.4"]
    common = ["--workers", "2", "--confidence", "0.9"]
    subprocess.run(
        [
            *cli,
            str(out / "means.csv"),
            str(out / "counts.csv"),
            *keys,
            *common,
            "--method",
            "bayes",
            "--out",
            str(out / "bayes"),
        ],
        check=True,
    )
    subprocess.run(
        [
            *cli,
            str(out / "means.csv"),
            "--parameter",
            "surfaces.rough.std_deg=2:30",
            *common,
            "--bootstrap",
            "0",
            "--out",
            str(out / "lsq"),
        ],
        check=True,
    )


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "out/calibration-bayes")
