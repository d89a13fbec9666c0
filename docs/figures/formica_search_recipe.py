"""The recipe of the STUDY ``formica_search.py``: one Formica-like profile set per
point of its grid. NOT the preset's surface (that is the Formica family,
``microimpact.surface.formica``); kept to show which surfaces would make the
paper's statements hold. Until issue 29 this recipe, at the point the search
chose, was the shipped surface: a surface chosen against the statements that
judge it, which is why it no longer ships.

The paper (Li, Dunn & Brach 2000) characterised a Formica surface from ten
Surtronic 3+ scans of 4 mm with two points per micrometre (8,000 points per scan,
80,000 in all) and a height standard deviation of about 45 µm; the data were not
published. Its conclusions say the local roughness angle distribution was
asymmetric. This script makes a stand-in with the same layout and a written-down
physical description:

* 10 scans x 8,000 points at dx = 0.5 µm (4 mm per scan);
* each scan is the sum of two independent parts:

  - **waviness**: the first 8,000 points of a stationary Gaussian random profile of
    32,768 points (so scans are not periodic) with a Gaussian autocorrelation
    ``C(tau) = sigma_w^2 exp(-tau^2 / ell^2)``, ``ell = CORRELATION_LENGTH_UM``
    (:func:`microimpact.surface.synthetic.gaussian_profile`);
  - **asymmetric ripple**: a saw-tooth of random periods (gamma, shape 4, mean
    ``RIPPLE_PERIOD_UM``) that rises at ``RIPPLE_RISE_ANGLE_DEG`` over a fraction
    ``RIPPLE_RISE_FRACTION`` of each period and falls gently over the rest
    (:func:`microimpact.surface.synthetic.ripple_profile`); its steep faces point
    away from particles travelling in -x (positive roughness angles);

* the waviness alone is scaled so that the height standard deviation about each
  scan's mean, pooled over the ten scans, is exactly 45 µm (the ripple keeps its
  slopes);
* seed 20000376 (the paper's year and first page), heights rounded to 1 nm.

The ripple is what makes the slope (roughness-angle) distribution asymmetric; the
waviness sets the height standard deviation and the spread of the gentle facets.
The four numbers (ell, the ripple's rise fraction and angle, and the orientation)
were chosen by the documented search ``docs/figures/formica_search.py`` against the
paper's statements (``microimpact.analysis.statements``); see ``docs/presets.md``.

Run from the repository root::

    python docs/figures/formica_search_recipe.py  # /tmp/formica_search_profile.csv
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from microimpact._core.files import atomic_write
from microimpact.surface.synthetic import (
    gaussian_profile,
    ripple_profile,
)
from microimpact.units import deg_to_rad, m_to_um, um_to_m

SEED = 20000376
N_SCANS = 10
N_POINTS = 8000
DX_UM = 0.5
SIGMA_UM = 45.0
N_GENERATE = 32768
#: Chosen by docs/figures/formica_search.py (see docs/presets.md).
CORRELATION_LENGTH_UM = 500.0
RIPPLE_PERIOD_UM = 250.0
RIPPLE_RISE_FRACTION = 0.10
RIPPLE_RISE_ANGLE_DEG = 35.0
#: +1: steep faces point away from the particles (positive angles); -1: mirrored.
RIPPLE_ORIENTATION = 1


def make_heights(
    seed=SEED,
    *,
    correlation_length_um=CORRELATION_LENGTH_UM,
    ripple_period_um=RIPPLE_PERIOD_UM,
    rise_fraction=RIPPLE_RISE_FRACTION,
    rise_angle_deg=RIPPLE_RISE_ANGLE_DEG,
    orientation=RIPPLE_ORIENTATION,
    sigma_um=SIGMA_UM,
):
    """Heights [µm], shape (N_SCANS, N_POINTS), of the recipe above (any
    parameters, for the search; the defaults make the shipped file)."""
    rng = np.random.default_rng(seed)
    wav = np.empty((N_SCANS, N_POINTS))
    rip = np.empty((N_SCANS, N_POINTS))
    for s in range(N_SCANS):
        p = gaussian_profile(
            N_GENERATE,
            float(um_to_m(DX_UM)),
            rms_height=float(um_to_m(sigma_um)),
            correlation_length=float(um_to_m(correlation_length_um)),
            rng=rng,
        )
        wav[s] = m_to_um(p.z[:N_POINTS])
        r = ripple_profile(
            N_POINTS,
            float(um_to_m(DX_UM)),
            period=float(um_to_m(ripple_period_um)),
            rise_fraction=rise_fraction,
            rise_angle=float(deg_to_rad(rise_angle_deg)),
            rng=rng,
        )
        rip[s] = orientation * m_to_um(r.z)
    wav -= wav.mean(axis=1, keepdims=True)
    rip -= rip.mean(axis=1, keepdims=True)
    # pooled mean square of (c wav + rip) = sigma^2: a quadratic in c
    a, b, c0 = np.mean(wav * wav), 2.0 * np.mean(wav * rip), np.mean(rip * rip)
    c0 -= sigma_um**2
    if c0 >= 0:
        raise ValueError(
            "the ripple alone has a height std of at least "
            f"{sigma_um} um; lower its angle or period."
        )
    scale = (-b + np.sqrt(b * b - 4.0 * a * c0)) / (2.0 * a)
    return scale * wav + rip


def main(path=None):
    path = Path(path) if path else Path("/tmp") / "formica_search_profile.csv"
    z = make_heights()
    x = np.arange(N_POINTS) * DX_UM
    lines = [
        "# SYNTHETIC Formica-like surface profile -- NOT a measurement.",
        "# Generated by microimpact/surface/data/make_formica_profile.py "
        f"(seed {SEED}): Gaussian waviness",
        f"# (Gaussian autocorrelation, correlation length {CORRELATION_LENGTH_UM:g} um)"
        f" plus an asymmetric saw-tooth ripple",
        f"# (mean period {RIPPLE_PERIOD_UM:g} um, rising at "
        f"{RIPPLE_RISE_ANGLE_DEG:g} deg over {RIPPLE_RISE_FRACTION:g} of each period, "
        f"orientation {RIPPLE_ORIENTATION:+d}),",
        f"# height std {SIGMA_UM:g} um (pooled about each scan's mean), after the "
        "layout of Li, Dunn & Brach (2000):",
        f"# {N_SCANS} scans x {N_POINTS} points at {DX_UM:g} um spacing "
        f"({N_POINTS * DX_UM / 1000:g} mm per scan).",
        "# Columns: scan id, position x [um], height z [um].",
        "scan,x_um,z_um",
    ]
    body = [
        f"{s},{xi:.1f},{zi:.3f}"
        for s in range(N_SCANS)
        for xi, zi in zip(x, z[s], strict=True)
    ]
    text = "\n".join(lines + body) + "\n"
    return atomic_write(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


if __name__ == "__main__":
    main()
