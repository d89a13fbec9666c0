"""Generate ``formica_synthetic_profile.csv``: one realization of the Formica family.

The paper's Formica scans are not published. The shipped profile set is the first
realization of the Formica family (:mod:`microimpact.surface.formica`, seed
``20000376/<index>``) whose angles are asymmetric, in the paper's layout (10 scans
x 8,000 points at 0.5 µm). It is one draw of an unknown, not a fit: the preset's
roughness pools all 16 realizations (``presets/make_preset_data.py``) and the
statements are judged over them (``microimpact.analysis.robustness``). No parameter
was chosen against the paper's statements.

Run from the repository root::

    python src/microimpact/surface/data/make_formica_profile.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from microimpact._core.files import atomic_write
from microimpact.surface.formica import DX_UM, N_POINTS, N_SCANS, formica_ensemble
from microimpact.surface.synthetic import FORMICA_FILE
from microimpact.units import m_to_um


def main(path=None):
    path = Path(path) if path else Path(__file__).with_name(FORMICA_FILE)
    r = formica_ensemble(1)[0]
    prm = ", ".join(
        f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
        for k, v in r.parameters.items()
    )
    lines = [
        "# SYNTHETIC Formica-like surface profile -- NOT a measurement.",
        f"# One realization of the Formica family (microimpact.surface.formica), "
        f"seed {r.seed_text}:",
        f"# {prm}.",
        f"# Measured: height std {r.measured['height_std_um']:.2f} um, Ra (0.8 mm) "
        f"{r.measured['ra_um']:.2f} um, 20 um angle std "
        f"{r.measured['angle_std_deg']:.2f} deg, skewness "
        f"{r.measured['angle_skewness']:+.2f}.",
        f"# {N_SCANS} scans x {N_POINTS} points at {DX_UM:g} um spacing "
        f"({N_POINTS * DX_UM / 1000:g} mm per scan), after Li, Dunn & Brach (2000).",
        "# Columns: scan id, position x [um], height z [um].",
        "scan,x_um,z_um",
    ]
    x = np.arange(N_POINTS) * DX_UM
    body = [
        f"{s},{xi:.1f},{zi:.3f}"
        for s, p in enumerate(r.profiles.profiles)
        for xi, zi in zip(x, m_to_um(p.z), strict=True)
    ]
    text = "\n".join(lines + body) + "\n"
    return atomic_write(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


if __name__ == "__main__":
    main()
