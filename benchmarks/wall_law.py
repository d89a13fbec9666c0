"""Wall law: build time of a 20 x 20 x 20 table, and the interpolation error between
nodes against direct runs of the engine (docs/wall-law.md).

    python benchmarks/wall_law.py build         # seconds for 20^3 nodes x 4,000
    python benchmarks/wall_law.py interpolation # error at mid-cell points
    python benchmarks/wall_law.py spacing       # the speed step a tolerance needs
    python benchmarks/wall_law.py axes          # diameter step: speed vs v/v_c(d)

The interpolation study builds tables of one preset's physics (sst76 Formica) at
three node spacings and, at the centres of 16 random cells of each spacing and at 16
random points common to all spacings, compares the sampler's capture fraction and
its mean e_n, mean e_t and mean rebound angle (from 200,000 draws of the sampler)
with a direct engine run at that point (40,000 impacts, another seed).
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

import microimpact as mi
from microimpact.scenario.scenario import load_preset
from microimpact.wall_law import WallLawSpec, build_wall_law
from microimpact.wall_law.build import node_outcomes

PRESET = "sst76-formica-oblique"


def build_seconds(workers: int = 2, samples: int = 4000) -> dict:
    """Time to build a 20 x 20 x 20 table (one surface) at `samples` per node."""
    scenario = load_preset(PRESET)
    scenario = scenario.with_options(surfaces=scenario.surfaces[:1])  # Formica
    spec = WallLawSpec(
        diameters_um=np.geomspace(20.0, 120.0, 20),
        speeds_m_s=np.geomspace(0.1, 10.0, 20),
        angles_deg=np.linspace(5.0, 90.0, 20),
        samples=samples,
    )
    t = time.perf_counter()
    law = build_wall_law(scenario, spec, workers=workers, seed=1)
    seconds = time.perf_counter() - t
    impacts = int(law.dataset.n_samples.sum())
    return {
        "nodes": spec.nodes * len(law.surfaces),
        "samples_per_node": samples,
        "workers": workers,
        "seconds": round(seconds, 2),
        "impacts_per_s": round(impacts / seconds),
    }


def _direct(scenario, d, v, a, n, seed):
    sc = scenario.with_options(
        particles=mi.monodisperse(d), speeds_m_s=(v,), angles_deg=(a,), seed=seed
    )
    out = mi.sample_point(sc, 0, n)
    struck = ~out["shadowed"]
    reb = struck & ~out["captured"]
    p = float(np.count_nonzero(out["captured"] & struck)) / np.count_nonzero(struck)
    o = node_outcomes(out["e_m"][reb], out["mu_m"][reb], a)
    return p, {k: float(np.mean(o[k])) for k in ("e_n", "e_t", "rebound_angle_deg")}


def _errors(law, scenario, points, rng) -> dict:
    """Sampler minus direct run at `points` (d, v, angle): capture probability,
    and the means over rebounds of e_n, e_t (angles below 80 deg, where U_x / (s
    cos theta) is not dominated by cos theta -> 0) and the rebound angle."""
    errs = {"capture": [], "e_n": [], "e_t": [], "rebound_angle_deg": []}
    for d, v, a in points:
        p_direct, means = _direct(scenario, d, v, a, 40_000, 77)
        s = law.sample(np.full(200_000, d), v, a, rng=rng)
        errs["capture"].append(s.captured.mean() - p_direct)
        reb = ~s.captured & s.valid
        if reb.sum() < 1000 or not np.isfinite(means["e_n"]) or p_direct > 0.99:
            continue  # too few rebounds on one side to compare means
        th = math.radians(a)
        vel = s.velocity[reb]
        errs["e_n"].append((vel[:, 2] / (v * math.sin(th))).mean() - means["e_n"])
        if a < 80:
            e_t = vel[:, 0] / (v * math.cos(th))
            errs["e_t"].append(e_t.mean() - means["e_t"])
        ang = np.degrees(np.arctan2(vel[:, 2], vel[:, 0]))
        errs["rebound_angle_deg"].append(ang.mean() - means["rebound_angle_deg"])
    out = {}
    for key, e in errs.items():
        e = np.abs(np.asarray(e))
        out[f"{key}_rms"] = round(float(np.sqrt(np.mean(e**2))), 4) if e.size else None
        out[f"{key}_max"] = round(float(e.max()), 4) if e.size else None
    return out


def interpolation(cells: int = 16, seed: int = 5) -> list[dict]:
    """Errors at the centres of `cells` random cells of each spacing, and at one
    common set of random points inside the table for every spacing."""
    scenario = load_preset(PRESET)
    scenario = scenario.with_options(surfaces=scenario.surfaces[:1])  # Formica
    rng = np.random.default_rng(seed)
    common = [
        (
            float(np.exp(rng.uniform(np.log(20.0), np.log(120.0)))),
            float(np.exp(rng.uniform(np.log(0.1), np.log(10.0)))),
            float(rng.uniform(10.0, 90.0)),
        )
        for _ in range(cells)
    ]
    rows = []
    for label, n_d, n_v, n_a in (
        ("coarse", 4, 6, 6),
        ("medium", 7, 11, 11),
        ("fine", 13, 21, 21),
    ):
        spec = WallLawSpec(
            diameters_um=np.geomspace(20.0, 120.0, n_d),
            speeds_m_s=np.geomspace(0.1, 10.0, n_v),
            angles_deg=np.linspace(10.0, 90.0, n_a),
            samples=4000,
            reservoir=1024,
        )
        law = build_wall_law(scenario, spec, workers=2, seed=1)
        mid = []
        for _ in range(cells):
            i, j, k = (
                rng.integers(n_d - 1),
                rng.integers(n_v - 1),
                rng.integers(n_a - 1),
            )
            mid.append(
                (
                    math.sqrt(spec.diameters_um[i] * spec.diameters_um[i + 1]),
                    math.sqrt(spec.speeds_m_s[j] * spec.speeds_m_s[j + 1]),
                    0.5 * (spec.angles_deg[k] + spec.angles_deg[k + 1]),
                )
            )
        row = {
            "spacing": label,
            "d_ratio": round(spec.diameters_um[1] / spec.diameters_um[0], 3),
            "v_ratio": round(spec.speeds_m_s[1] / spec.speeds_m_s[0], 3),
            "angle_step_deg": round(spec.angles_deg[1] - spec.angles_deg[0], 2),
        }
        for where, pts in (("mid", mid), ("common", common)):
            for k, e in _errors(law, scenario, pts, rng).items():
                row[f"{where}_{k}"] = e
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows


def speed_spacing(diameter_um: float = 52.8, samples: int = 20_000) -> list[dict]:
    """The speed step a tolerance needs: capture probability and mean e_n against
    log speed on a dense grid (direct runs at a fixed diameter), and the largest
    error of linear interpolation in log speed between nodes a ratio r apart.

    Capture at a fixed diameter and speed is a steep function of the speed: its
    width is set by the spread of sin(theta - phi) only, so this is where a table
    needs its finest speed (and diameter) steps."""
    scenario = load_preset(PRESET)
    scenario = scenario.with_options(surfaces=scenario.surfaces[:1])  # Formica
    dense = np.geomspace(0.05, 20.0, 601)  # ratio 1.01 between points
    rows = []
    for angle in (90.0, 45.0, 20.0):
        curve = np.array(
            [_direct(scenario, diameter_um, v, angle, samples, 3)[0] for v in dense]
        )
        for step in (1, 2, 5, 10, 24, 47):  # ratios 1.01 ... 1.6
            nodes = np.arange(0, dense.size, step)
            interp = np.interp(np.log(dense), np.log(dense[nodes]), curve[nodes])
            inside = dense <= dense[nodes[-1]]
            err = np.abs(interp - curve)[inside]
            rows.append(
                {
                    "angle_deg": angle,
                    "v_ratio": round(float(dense[step] / dense[0]), 3),
                    "capture_max_err": round(float(err.max()), 4),
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    return rows


def speed_axes(
    d_mid_um: float = 52.8,
    samples: int = 10_000,
    angles=(90.0, 45.0, 20.0),
    d_ratios=(1.1, 1.35, 1.82, 3.0),
) -> list[dict]:
    """Capture interpolation error across one diameter cell, for a table whose
    speed axis is the speed v and for one whose axis is the reduced speed
    r = v / v_c(d) (the nodes of each diameter at r v_c(d)).

    At the cell's middle diameter (log scale) d_mid, for speeds v on a dense grid
    (r = v / v_c(d_mid) from 0.3 to 30), the direct capture probability p(d_mid, v)
    against the sampler's mix at t = 1/2 of the two diameter nodes d_mid / sqrt(q)
    and d_mid sqrt(q): at the same v (speed axis) or at the same r (reduced axis).
    Every direct run uses the same seed (common random numbers), so the
    difference is the interpolation's, not the Monte Carlo noise. Along the speed
    axis at a fixed diameter the two axes are the same up to a scale (ratios of
    r are ratios of v): see ``spacing``."""
    scenario = load_preset(PRESET)
    scenario = scenario.with_options(surfaces=scenario.surfaces[:1])  # Formica

    def v_c(d_um):
        return float(scenario.coefficients.v_c(np.array([d_um * 1e-6]))[0])

    def p(d, v, a):
        return _direct(scenario, d, v, a, samples, 3)[0]

    r_grid = np.geomspace(0.3, 30.0, 81)
    rows = []
    for angle in angles:
        mid = {r: p(d_mid_um, r * v_c(d_mid_um), angle) for r in r_grid}
        for q in d_ratios:
            d_lo, d_hi = d_mid_um / math.sqrt(q), d_mid_um * math.sqrt(q)
            err_v, err_r = [], []
            for r in r_grid:
                v = r * v_c(d_mid_um)
                err_v.append(0.5 * (p(d_lo, v, angle) + p(d_hi, v, angle)) - mid[r])
                mix_r = 0.5 * (
                    p(d_lo, r * v_c(d_lo), angle) + p(d_hi, r * v_c(d_hi), angle)
                )
                err_r.append(mix_r - mid[r])
            rows.append(
                {
                    "angle_deg": angle,
                    "d_ratio": q,
                    "speed_axis_capture_max_err": round(float(np.abs(err_v).max()), 4),
                    "reduced_axis_capture_max_err": round(
                        float(np.abs(err_r).max()), 4
                    ),
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    return rows


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=("build", "interpolation", "spacing", "axes"))
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args()
    if args.what == "build":
        print(json.dumps(build_seconds(args.workers)))
    elif args.what == "spacing":
        speed_spacing()
    elif args.what == "axes":
        speed_axes()
    else:
        interpolation()


if __name__ == "__main__":
    main()
