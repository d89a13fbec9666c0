"""Wall law: build time of a 20 x 20 x 20 table, and the interpolation error between
nodes against direct runs of the engine (docs/wall-law.md).

    python benchmarks/wall_law.py build         # seconds for 20^3 nodes x 4,000
    python benchmarks/wall_law.py interpolation # error at mid-cell points
    python benchmarks/wall_law.py spacing       # the speed step a tolerance needs
    python benchmarks/wall_law.py axes          # diameter step: speed vs v/v_c(d)
    python benchmarks/wall_law.py capture       # both table axes, several spacings

The interpolation study builds tables of one preset's physics (sst76 Formica) at
three node spacings and, at the centres of 16 random cells of each spacing and at 16
random points common to all spacings, compares the sampler's capture fraction and
its mean e_n, mean e_t and mean rebound angle (from 200,000 draws of the sampler)
with a direct engine run at that point (40,000 impacts, another seed).

The capture study (``capture``) builds real tables on both speed axes, the
absolute one (speed nodes in m/s) and the reduced one (nodes at r v_c(d),
``speed_axis = "reduced"``), at several node spacings, and measures the largest
error of the sampler's capture probability over a fine grid of queries between
the nodes against a direct computation at each query.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

import microimpact as mi
from microimpact.scenario.scenario import load_preset
from microimpact.wall_law import WallLawSpec, build_wall_law, critical_speed_m_s
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


#: The presets of the capture study (their first surface, Formica).
CAPTURE_PRESETS = ("sst76-formica-oblique", "lycopodium-formica-oblique")
#: The diameter nodes of the capture study's tables (ratio 1.196).
CAPTURE_DIAMETERS_UM = tuple(float(d) for d in np.geomspace(20.0, 120.0, 11))
#: The capture edge's nodes of the "reduced-edge" scheme: r = 1 + 0.0002 k^2,
#: k = 0 ... 15 (1 to 1.045), graded towards r = 1, where capture at and near
#: normal incidence falls like 1 - c sqrt(r - 1) (docs/wall-law.md).
EDGE_NODES = tuple(1.0 + 0.0002 * k * k for k in range(16))
#: The node schemes of the capture study: (speed axis, nodes, ratio). "absolute":
#: speeds ratio**k [m/s]; "reduced": r = ratio**k (1 a node); "reduced-edge":
#: :data:`EDGE_NODES` and ratio**k outside them.
CAPTURE_SCHEMES = (
    *(("absolute", r) for r in (1.01, 1.02, 1.05, 1.1, 1.27)),
    *(("reduced", r) for r in (1.005, 1.01, 1.02, 1.05, 1.1, 1.27)),
    *(("reduced-edge", r) for r in (1.05, 1.1)),
)
#: The documented spacing (docs/wall-law.md): capture within 0.05.
DOCUMENTED_SCHEME = ("reduced-edge", 1.1)


def expected_capture(law, d_um, v_m_s, angle_index: int) -> np.ndarray:
    """The sampler's capture probability at queries (d, v) on the angle node
    `angle_index`: the expectation over its uniform numbers, i.e. the bilinear
    mix of the cell corners' capture probabilities with the weights of
    docs/wall-law.md, "The sampling rule" (log d; log v, or log(v / v_c(d)) with
    log v_c linear in log d, on a reduced axis). Written out here from the rule."""
    ds = law.dataset.isel(surface=0)
    reduced = law.speed_axis == "reduced"
    speed_dim = "reduced_speed" if reduced else "speed_m_s"
    ds = ds.transpose("diameter_um", speed_dim, "angle_deg", ...)
    p = ds.capture_probability.values[:, :, angle_index]
    ld = np.log(ds.diameter_um.values)
    lv = np.log(ds[speed_dim].values)
    x_d = np.log(np.asarray(d_um, dtype=float))
    i = np.clip(np.searchsorted(ld, x_d, side="right") - 1, 0, ld.size - 2)
    t = np.clip((x_d - ld[i]) / (ld[i + 1] - ld[i]), 0.0, 1.0)
    x_v = np.log(np.asarray(v_m_s, dtype=float))
    if reduced:
        lvc = np.log(ds.critical_speed_m_s.values)
        x_v = x_v - (lvc[i] + t * (lvc[i + 1] - lvc[i]))
    j = np.clip(np.searchsorted(lv, x_v, side="right") - 1, 0, lv.size - 2)
    s = np.clip((x_v - lv[j]) / (lv[j + 1] - lv[j]), 0.0, 1.0)
    return (
        (1 - t) * (1 - s) * p[i, j]
        + (1 - t) * s * p[i, j + 1]
        + t * (1 - s) * p[i + 1, j]
        + t * s * p[i + 1, j + 1]
    )


def _nodes(lo: float, hi: float, ratio: float) -> np.ndarray:
    """Nodes ratio**k (k integer: 1 is a node) from below lo to above hi (the
    queries strictly inside)."""
    step = math.log(ratio)
    first = math.floor(math.log(lo) / step) - 1
    k = np.arange(first, math.ceil(math.log(hi) / step) + 2)
    return np.exp(k * step)


def scheme_nodes(kind: str, ratio: float, lo: float, hi: float) -> np.ndarray:
    """The speed-axis nodes of a scheme of :data:`CAPTURE_SCHEMES` over [lo, hi]
    (m/s on the absolute axis, r on the reduced ones)."""
    nodes = _nodes(lo, hi, ratio)
    if kind != "reduced-edge":
        return nodes
    edge = np.array(EDGE_NODES)
    # the coarse nodes outside the edge's, none closer than half a step to it
    keep = (nodes < edge[0]) | (nodes > edge[-1] * math.sqrt(ratio))
    return np.unique(np.concatenate([nodes[keep], edge]))


def capture_interpolation(
    presets=CAPTURE_PRESETS,
    angles=(90.0, 80.0, 45.0, 20.0),
    schemes=CAPTURE_SCHEMES,
    diameters_um=CAPTURE_DIAMETERS_UM,
    query_cells=(1, 4, 8),
    r_range=(0.5, 4.0),
    n_query=240,
    n_edge=80,
    samples: int = 20_000,
    workers: int = 2,
    seed: int = 1,
    quiet: bool = False,
) -> list[dict]:
    """Largest capture-probability error of the sampler between nodes, for tables
    on the absolute and on the reduced speed axis with the node schemes
    `schemes` (the diameter nodes `diameters_um`, ratio 1.196, the same for
    all), per preset (first surface) and angle.

    Queries: at the log-middle of the diameter cells `query_cells` (where the
    absolute axis interpolates across diameters most), speeds r v_c(d) for
    `n_query` reduced speeds r geometrically spaced over `r_range` (ratio 1.009
    for 240 over 0.5-4) and `n_edge` more at r = 1 + 1e-5 ... 1 + 0.06
    (geometric in r - 1: the steep capture edge at and near normal incidence),
    at the angle nodes. The direct computation at every query is the engine's
    run at that (d, v, angle) with `samples` impacts: a wall-law build whose
    nodes are the queries themselves (no interpolation), with another seed than
    the tables. Its Monte Carlo standard error, and the nodes', is at most
    0.5 / sqrt(samples) (0.0035 for 20,000); the errors reported include that
    noise (about 0.015 at most over the grid)."""
    rows = []
    d_nodes = np.asarray(diameters_um, dtype=float)
    d_q = np.sqrt(d_nodes[list(query_cells)] * d_nodes[[c + 1 for c in query_cells]])
    r_q = np.unique(
        np.concatenate(
            [np.geomspace(*r_range, n_query), 1.0 + np.geomspace(1e-5, 0.06, n_edge)]
        )
    )
    for preset in presets:
        scenario = load_preset(preset)
        scenario = scenario.with_options(surfaces=scenario.surfaces[:1])  # Formica
        v_c_q = critical_speed_m_s(scenario, d_q)
        v_q = v_c_q[:, None] * r_q[None, :]  # (query diameter, r)
        t0 = time.perf_counter()
        direct = build_wall_law(
            scenario,
            WallLawSpec(
                d_q,
                None,
                angles,
                reservoir=1,
                samples=samples,
                speed_axis="reduced",
                reduced_speeds=r_q,
            ),
            workers=workers,
            seed=seed + 1000,
        )
        p_direct = direct.dataset.capture_probability.isel(surface=0).values
        d_grid = np.broadcast_to(d_q[:, None], v_q.shape)
        for kind, ratio in schemes:
            if kind == "absolute":
                nodes = scheme_nodes(kind, ratio, float(v_q.min()), float(v_q.max()))
                spec = WallLawSpec(d_nodes, nodes, angles, reservoir=1, samples=samples)
            else:
                nodes = scheme_nodes(kind, ratio, *r_range)
                spec = WallLawSpec(
                    d_nodes,
                    None,
                    angles,
                    reservoir=1,
                    samples=samples,
                    speed_axis="reduced",
                    reduced_speeds=nodes,
                )
            law = build_wall_law(scenario, spec, workers=workers, seed=seed)
            for k, angle in enumerate(law.angles_deg):
                mix = expected_capture(law, d_grid.ravel(), v_q.ravel(), k)
                err = np.abs(mix - p_direct[:, :, k].ravel())
                row = {
                    "preset": preset,
                    "angle_deg": float(angle),
                    "scheme": kind,
                    "ratio": ratio,
                    "speed_nodes": int(nodes.size),
                    "capture_max_err": round(float(err.max()), 4),
                    "capture_rms_err": round(float(np.sqrt(np.mean(err**2))), 4),
                    "worst_r": round(float(r_q[int(np.argmax(err)) % r_q.size]), 5),
                }
                rows.append(row)
                if not quiet:
                    print(json.dumps(row), flush=True)
        if not quiet:
            print(
                json.dumps(
                    {"preset": preset, "seconds": round(time.perf_counter() - t0, 1)}
                ),
                flush=True,
            )
    return rows


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "what", choices=("build", "interpolation", "spacing", "axes", "capture")
    )
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args()
    if args.what == "build":
        print(json.dumps(build_seconds(args.workers)))
    elif args.what == "spacing":
        speed_spacing()
    elif args.what == "axes":
        speed_axes()
    elif args.what == "capture":
        capture_interpolation(workers=args.workers)
    else:
        interpolation()


if __name__ == "__main__":
    main()
