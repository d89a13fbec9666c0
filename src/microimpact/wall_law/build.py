"""Build a wall law: run the engine at every node and tabulate the outcomes.

At a node (surface, diameter, speed, angle) the diameter is fixed and every other
random input keeps its distribution: the roughness angle of the surface (paper
Eqs. 7-9 on a facet tilted by it), the particle's own roughness, the speed scatter,
under the scenario's shadowing rule. The impacts are the engine's (the draws
:func:`microimpact.run` makes; the compiled kernel writes each impact's outcome to
one array per quantity for a group of nodes,
:func:`microimpact.engine.kernel.simulate_specs_impacts`, the NumPy kernel gives
the same values through ``simulate_block(..., store=True)``), so the physics is the
paper's Eqs. 1-9 as implemented in :mod:`microimpact.physics.impact` and checked
there. The statistics of all the nodes of a group are formed at once, from those
arrays.

Common random numbers: every diameter of a (surface, speed, angle) uses the same
draws (the engine's stream of that sweep point), so the table is smooth in the
diameter, and the seed reproduces the table bit for bit for any worker count.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import math
import shutil
import threading
import time
from pathlib import Path

import numpy as np

from .. import __version__
from .._core.json import dumps
from .._core.progress import Progress
from .._core.validation import implausible_speed
from ..engine import _compiled
from ..engine.checkpoint import CheckpointMismatch, load_arrays, save_arrays
from ..engine.kernel import atan2_deg, prepare_plan, simulate_specs_impacts
from ..engine.montecarlo import TASKS_PER_WORKER, iter_point_samples, tail_size
from ..engine.parallel import cap_workers, map_tasks
from ..engine.plan import (
    ArealSampler,
    atom_columns,
    atom_sampler,
    build_plan,
    resolve_entropy,
)
from ..engine.tasks import BlockTask
from ..errors import ScenarioError
from ..scenario.grid import GridPoints, SweepGrid
from ..scenario.resuspension import ResuspensionSpec, resuspension_from_dict
from ..scenario.scenario import Scenario, read_scenario
from ..scenario.wall_law import REBOUND_VARIABLES, RESERVOIR_VARIABLES, WallLawSpec
from ..units import um_to_m
from .checks import MAX_LATERAL_DEG
from .law import WallLaw, wall_law_dataset

__all__ = [
    "build_wall_law",
    "critical_speed_m_s",
    "node_outcomes",
    "stay_probability_at_nodes",
]


def critical_speed_m_s(scenario, diameter_um) -> np.ndarray:
    """The critical (capture) speed v_c(d) [m s-1] of the scenario's particles at
    diameters `diameter_um` [µm]: the largest normal speed captured at normal
    incidence on a smooth surface, the ``v_c`` of paper Eq. 5 (the scenario's
    coefficient law, :class:`~microimpact.physics.coefficients.ImpactCoefficients`;
    the capture rule is :func:`microimpact.physics.impact.rebound`'s). The nodes
    of a ``"reduced"`` speed axis are ``r v_c(d)``.

    Raises :class:`~microimpact.errors.ScenarioError` where v_c is not finite and
    > 0 (a reduced speed needs it).
    """
    d = np.atleast_1d(np.asarray(diameter_um, dtype=float))
    v_c = np.broadcast_to(
        np.asarray(scenario.coefficients.v_c(um_to_m(d)), dtype=float), d.shape
    )
    bad = ~(np.isfinite(v_c) & (v_c > 0))
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ScenarioError(
            f"the critical speed law v_c gives {float(v_c[i])!r} m/s at diameter "
            f"{d[i]:g} um; a reduced speed axis (v / v_c) needs v_c finite and > 0 "
            'at every diameter node: use speed_axis = "absolute"',
            source=scenario.source,
            field="wall_law.speed_axis",
        )
    return np.array(v_c, dtype=float)


def _resuspension(scenario, data, resuspension):
    """The ResuspensionSpec of a build: `resuspension` (a spec, or a dict read as
    the ``[resuspension]`` table), else the scenario file's table (`data`, None
    where no file was read), else None; ``False`` for none at all."""
    if resuspension is False:
        return None
    if isinstance(resuspension, ResuspensionSpec):
        return resuspension
    law = scenario.coefficients.v_c
    if isinstance(resuspension, dict):
        return resuspension_from_dict(
            {**(data or {}), "resuspension": resuspension},
            source=scenario.source,
            capture_law=law,
        )
    if resuspension is not None:
        raise TypeError(
            "`resuspension` must be a ResuspensionSpec, a dict, None or False; got "
            f"{type(resuspension).__name__}"
        )
    if data is None:
        return None
    return resuspension_from_dict(data, source=scenario.source, capture_law=law)


def stay_probability_at_nodes(resuspension, diameters_um, *, source=None):
    """The probability that a particle captured at each diameter node [µm] stays
    on the wall after the ``[resuspension]`` ramp: the Rock'n'Roll remaining
    fraction of a fresh deposit of that diameter (the quadrature of
    :func:`~microimpact.physics.resuspension.remaining_fraction_ramp`, last step).

    It depends on the diameter only (the adhesion of a captured particle does not
    depend here on how it struck); the table carries it per (d, v, theta) node.
    A diameter where the Biasi (2001) correlation has no distribution is refused
    (:class:`~microimpact.errors.ScenarioError` naming ``resuspension.adhesion``
    and ``wall_law.diameter_um``); one outside its fitted range warns."""
    d = np.asarray(diameters_um, dtype=float)
    return resuspension.remaining_fraction(
        0.5 * um_to_m(d), source=source, field="wall_law.diameter_um"
    )


def _check_reduced_speeds(scenario, spec, critical) -> None:
    """ScenarioError naming ``wall_law.reduced_speed`` where a node's speed
    ``r v_c(d)`` is no plausible impact speed (``implausible_speed``)."""
    for d, v_c in zip(spec.diameters_um, critical, strict=True):
        for r in (spec.reduced_speeds[0], spec.reduced_speeds[-1]):
            why = implausible_speed(r * float(v_c), unit_hint=False)
            if why is not None:
                raise ScenarioError(
                    f"the node r = {r:g} at diameter {d:g} um (v_c = {v_c:g} m/s) "
                    f"is at {r * v_c:g} m/s: {why}",
                    source=scenario.source,
                    field="wall_law.reduced_speed",
                )


def node_outcomes(e_m, mu_m, angle_deg: float, psi_deg=None) -> dict:
    """Wall-law variables of rebounds with apparent restitution `e_m` and impulse
    ratio `mu_m` at apparent incidence angle `angle_deg` (docs/wall-law.md):

    * ``e_n = e_m`` (paper Eq. 8 seen on the nominal surface);
    * ``e_t = U_x / u_x = 1 - mu_m (1 + e_m) tan(theta)``, from the impulse ratio
      of paper Eq. 9 in the frame of docs/conventions.md (NaN at theta = 90 deg,
      where there is no incoming tangential velocity);
    * the rebound angle ``atan2(U_z, U_x)`` from the wall plane [deg];
    * the lateral angle ``atan2(U_y, hypot(U_x, U_z))`` [deg]: 0 for the paper's
      profile roughness (`psi_deg` None); on an areal surface from the engine's
      lateral angle ``psi = atan2(V_b, -V_t)`` of :func:`microimpact.apparent_rebound`
      (frame t, b = n x t, n), where the wall law's ``y = z x x = -b``, so
      ``U_y = -U_b = -U_x tan(psi)``;
    * the speed ratio ``|U| / s`` of the rebound (at most 1: no energy is gained).
    """
    theta = math.radians(angle_deg)
    s, c = math.sin(theta), math.cos(theta)
    if angle_deg == 90.0:
        c = 0.0  # cos(pi/2) is 6e-17 in floating point: the impact is normal
    u_z = e_m * s  # per unit speed
    u_x = c - mu_m * (1.0 + e_m) * s
    if psi_deg is None:
        u_y = np.zeros_like(e_m)
    else:
        psi = np.radians(psi_deg)
        # psi = 0 or 180 deg exactly: in the plane of incidence (tan(pi) != 0)
        u_y = np.where(np.sin(psi) == 0.0, 0.0, -u_x * np.tan(psi))
    with np.errstate(invalid="ignore", divide="ignore"):
        e_t = u_x / c if c > 0 else np.full_like(e_m, np.nan)
    return {
        "e_n": e_m,
        "e_t": e_t,
        "mu": mu_m,
        "rebound_angle_deg": np.degrees(np.arctan2(u_z, u_x)),
        "lateral_angle_deg": np.degrees(np.arctan2(u_y, np.hypot(u_x, u_z))),
        "speed_ratio": np.sqrt(u_x * u_x + u_y * u_y + u_z * u_z),
    }


#: Impacts simulated per kernel call of a wall-law build (a group of nodes; ~25
#: bytes each while their statistics are formed).
GROUP_IMPACTS = 1 << 19
#: The fewest impacts of a group split for several workers (:func:`_group_nodes`;
#: ~3 ms of kernel and sort: a group's Python costs ~0.1 ms).
MIN_GROUP_IMPACTS = 1 << 17


def _impacts(plan, points, samples: int, buffers=None) -> dict:
    """The first `samples` impacts of each sweep point of `points` (the draws
    :func:`microimpact.run` makes there, block by block) as ``(points, samples)``
    arrays: ``e_m``, ``mu_m`` (valid for rebounds), ``lateral_angle_deg`` (valid
    for rebounds on an areal surface) and ``outcome`` (0 a rebound, 1 captured,
    2 shadowed). The compiled kernel writes them in one call
    (:func:`~microimpact.engine.kernel.simulate_specs_impacts`); the NumPy kernel
    gives the same values (``simulate_block(..., store=True)``)."""
    shape = (len(points), samples)
    if plan.kernel == "compiled":
        # every point's blocks as one group each, as arrays (no tuple per block)
        bs = plan.block_size
        per = math.ceil(samples / bs)  # blocks per point
        pts = np.asarray(points, dtype=np.int64)
        task = BlockTask(
            pts,
            np.zeros_like(pts),
            np.full_like(pts, per - 1),
            per,
            bs,
            samples - (per - 1) * bs,
        )
        got = simulate_specs_impacts(plan, task, buffers)
        return {k: v.reshape(shape) for k, v in got.items()}
    out = {
        "e_m": np.zeros(shape),
        "mu_m": np.zeros(shape),
        "lateral_angle_deg": np.zeros(shape),
        "outcome": np.zeros(shape, dtype=np.int8),
    }
    for r, i in enumerate(points):
        at = 0
        for part in iter_point_samples(plan, i, samples):
            sl = slice(at, at + part["e_m"].size)
            at = sl.stop
            code = np.where(part["shadowed"], 2, np.where(part["captured"], 1, 0))
            reb = code == 0
            out["outcome"][r, sl] = code
            for k in ("e_m", "mu_m", "lateral_angle_deg"):
                out[k][r, sl] = np.where(reb, part[k], 0.0)
    return out


#: The outcome variables of :func:`_wall_rows`, in its order (the first five are
#: :data:`REBOUND_VARIABLES`, which get statistics).
_ROW_VARIABLES = (*REBOUND_VARIABLES, "speed_ratio")
#: Its per-node columns: impacts, captured, rebounds, reimpacts, then the means
#: and standard deviations of the five rebound variables.
_STAT_COLUMNS = 14
#: The reservoir variables as rows of :func:`_wall_rows`'s output, in its order,
#: each with how ``_ckernel.wall_rows`` bounds them (0 not, 1 the lateral angle
#: to +-MAX_LATERAL_DEG, 2 the speed ratio to at most 1).
_RESERVOIR_ROWS = tuple(
    v for v, name in enumerate(_ROW_VARIABLES) if name in RESERVOIR_VARIABLES
)
_RESERVOIR_SLOTS = np.array(
    [
        (v, {"lateral_angle_deg": 1, "speed_ratio": 2}.get(_ROW_VARIABLES[v], 0))
        for v in _RESERVOIR_ROWS
    ],
    dtype=np.int64,
)


def _wall_rows_numpy(imp, geom, out, stats):
    """What ``_ckernel.wall_rows`` computes, in NumPy (an install without the
    compiled kernel): the same definitions and, but for ``sin`` and ``tan`` of the
    lateral angle on areal surfaces (NumPy's and the C library's can differ in
    the last bit), the same operations."""
    code = imp["outcome"]
    rebound = code == 0
    m = np.count_nonzero(rebound, axis=1)
    order = np.argsort(~rebound, axis=1, kind="stable")  # rebounds first, in order
    kept = np.arange(code.shape[1])[None, :] < m[:, None]

    def first(x):
        return np.where(kept, np.take_along_axis(x, order, axis=1), 0.0)

    e, mu, psi = first(imp["e_m"]), first(imp["mu_m"]), first(imp["lateral_angle_deg"])
    s, c, areal = geom[:, 0:1], geom[:, 1:2], geom[:, 2:3] != 0.0
    u_z = e * s
    u_x = c - mu * (1.0 + e) * s
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        pr = psi * (np.pi / 180.0)
        u_y = np.where(areal & (np.sin(pr) != 0.0), -u_x * np.tan(pr), 0.0)
        e_t = np.where(c > 0, u_x / np.where(c > 0, c, 1.0), np.nan)
        values = (
            e,
            e_t,
            mu,
            atan2_deg(u_z, u_x),
            atan2_deg(u_y, np.sqrt(u_x * u_x + u_z * u_z)),
            np.sqrt(u_x * u_x + u_y * u_y + u_z * u_z),
        )
    for v, x in enumerate(values):
        out[v] = np.where(kept, x, np.inf)
    stats[:, 0] = np.count_nonzero(code != 2, axis=1)
    stats[:, 1] = np.count_nonzero(code == 1, axis=1)
    stats[:, 2] = m
    stats[:, 3] = np.count_nonzero(kept & (e < 0.0), axis=1)
    div = np.where(m > 0, m, 1).astype(float)
    dof = np.where(m > 1, m - 1, 1).astype(float)
    with np.errstate(invalid="ignore"):
        for v in range(5):
            x = np.where(kept, out[v], 0.0)
            mean = np.cumsum(x, axis=1)[:, -1] / div  # sequential sums, as in C
            d = np.where(kept, x - mean[:, None], 0.0)
            stats[:, 4 + v] = mean
            stats[:, 9 + v] = np.sqrt(np.cumsum(d * d, axis=1)[:, -1] / dof)


def _wall_rows(imp, geom, force_numpy=False, buffers=None, reservoir=None):
    """``(out, stats)`` of ``_ckernel.wall_rows`` (or its NumPy form); `buffers`
    (a dict) keeps the output array from call to call. With `reservoir` (an
    array ``(len(_RESERVOIR_SLOTS), P, R)``) the compiled kernel also writes the
    nodes' reservoirs there (:data:`_RESERVOIR_SLOTS`), and ``True`` comes
    third; else ``False`` (the caller takes them from `out`)."""
    p, n = imp["outcome"].shape
    size = len(_ROW_VARIABLES) * p * n
    if buffers is not None and buffers.get("rows", np.empty(0)).size >= size:
        out = buffers["rows"][:size].reshape(len(_ROW_VARIABLES), p, n)
    else:
        out = np.empty((len(_ROW_VARIABLES), p, n))
        if buffers is not None:
            buffers["rows"] = out.reshape(-1)
    stats = np.empty((p, _STAT_COLUMNS))
    if _compiled.ckernel is None or n == 0 or force_numpy:
        _wall_rows_numpy(imp, geom, out, stats)
        return out, stats, False
    extra = () if reservoir is None else (reservoir, _RESERVOIR_SLOTS, MAX_LATERAL_DEG)
    _compiled.ckernel.wall_rows(
        p,
        n,
        np.ascontiguousarray(imp["e_m"]),
        np.ascontiguousarray(imp["mu_m"]),
        np.ascontiguousarray(imp["lateral_angle_deg"]),
        np.ascontiguousarray(imp["outcome"]),
        geom,
        out,
        stats,
        *extra,
    )
    return out, stats, reservoir is not None


def _quantile_rows(srt, n, q):
    """``np.quantile(row[:n], q)`` of each sorted row (method "linear", its
    operations: virtual index ``(n - 1) q``, its floor and the two-sided lerp).
    `srt` is ``(..., P, width)``: the rows of P nodes, for any leading axes (the
    variables of a node share its `n`)."""
    nf = n.astype(float)[:, None]
    v = (nf - 1.0) * q[None, :]
    prev = np.floor(v)
    last = v >= nf - 1.0
    width = srt.shape[-1]
    top = width - 1
    i0 = np.clip(np.where(last, nf - 1.0, prev), 0, top).astype(np.intp)
    i1 = np.clip(np.where(last, nf - 1.0, prev + 1.0), 0, top).astype(np.intp)
    # each row's first element in the flat array: the values are gathered by
    # np.take, which frees the GIL while it waits on memory (the rows were just
    # sorted, and most are out of the cache)
    base = np.arange(0, srt.size, width, dtype=np.intp).reshape((*srt.shape[:-1], 1))
    flat = srt.reshape(-1)
    a = np.take(flat, base + i0)
    b = np.take(flat, base + i1)
    g = v - np.where(last, -1.0, prev)  # numpy's gamma (previous index -1 above)
    with np.errstate(invalid="ignore"):
        diff = b - a
        return np.where(g >= 0.5, b - diff * (1 - g), a + diff * g)


def _geometry(plan) -> np.ndarray:
    """Per sweep point of `plan`: ``sin(theta)``, ``cos(theta)`` (0 at normal
    incidence: cos(pi/2) is 6e-17 in floating point) and whether its surface is
    areal, as ``_ckernel.wall_rows`` reads them; computed once per (surface,
    angle) with the math module's functions, once for every diameter's plan
    that keeps the points (:meth:`~microimpact.engine.plan.Plan.shared`)."""
    return plan.shared("wall_rows geometry", _make_geometry)


def _make_geometry(plan) -> np.ndarray:
    *_, table, keys = plan.point_columns()
    geom = np.empty((len(keys), 3))
    for r, (surface, angle_deg) in enumerate(keys):
        theta = math.radians(angle_deg)
        geom[r, 0] = math.sin(theta)
        geom[r, 1] = 0.0 if angle_deg == 90.0 else math.cos(theta)
        geom[r, 2] = float(isinstance(plan.surfaces[surface], ArealSampler))
    return geom[table]


def _node_rows(plan, points, spec: WallLawSpec, samples: int, buffers=None) -> dict:
    """Counts, statistics and reservoirs of the nodes at sweep points `points`
    (arrays with a leading axis over them), from one array of impacts per
    quantity (no Python array per node): each node's rebounds in draw order
    (``_ckernel.wall_rows``), the first ``spec.reservoir`` of them its reservoir,
    then sorted in place for the quantiles (``np.quantile``'s linear rule, the
    same operations). Means and standard deviations are sequential sums."""
    imp = _impacts(plan, points, samples, buffers)
    p = len(points)
    res = np.empty((len(_RESERVOIR_ROWS), p, spec.reservoir))
    out, stats, filled = _wall_rows(
        imp, _geometry(plan)[np.asarray(points)], buffers=buffers, reservoir=res
    )
    counts = stats[:, :4].T.astype(np.int64)
    n_reb = counts[2]
    rows = {
        "n_samples": np.full(p, samples, dtype=np.int64),
        "n_impacts": counts[0],
        "n_captured": counts[1],
        "n_rebounds": n_reb,
        "n_reimpacts": counts[3],
    }
    k = np.minimum(spec.reservoir, n_reb)
    rows["reservoir_count"] = k
    if not filled:  # the NumPy form: before the sort, in draw order
        width = min(spec.reservoir, samples)
        keep = np.arange(width)[None, :] < k[:, None]
        res[:] = np.nan
        res[:, :, :width] = np.where(
            keep, out[list(_RESERVOIR_ROWS), :, :width], np.nan
        )
        for i, (_, kind) in enumerate(_RESERVOIR_SLOTS.tolist()):
            # within the readers' ranges (wall_law/checks.py) also at round-off:
            # a lateral angle that rounds to 90 degrees, a ratio 1 + 1 ulp
            if kind == 1:
                np.clip(res[i], -MAX_LATERAL_DEG, MAX_LATERAL_DEG, out=res[i])
            elif kind == 2:
                np.minimum(res[i], 1.0, out=res[i])
    for i, v in enumerate(_RESERVOIR_ROWS):
        rows[f"reservoir_{_ROW_VARIABLES[v]}"] = res[i]
    V = len(REBOUND_VARIABLES)
    out[:V].sort(axis=2)
    q = np.asarray(spec.quantiles, dtype=float)
    if filled:  # the quantiles, means and deviations in one kernel call
        means, stds = np.empty((V, p)), np.empty((V, p))
        quant = np.empty((V, p, q.size))
        _compiled.ckernel.wall_quantiles(
            p, samples, V, out, stats, q, means, stds, quant
        )
    else:
        means, stds, quant = _summary_rows(out[:V], stats, n_reb, q)
    for v, name in enumerate(REBOUND_VARIABLES):
        rows[f"{name}_mean"] = means[v]
        rows[f"{name}_std"] = stds[v]
        rows[f"{name}_quantile"] = quant[v]
    return rows


def _summary_rows(srt, stats, n_reb, q):
    """What ``_ckernel.wall_quantiles`` computes, in NumPy: each variable's mean,
    standard deviation and quantiles per node (NaN without rebounds)."""
    V = srt.shape[0]
    mean, std = stats[:, 4 : 4 + V].T, stats[:, 9 : 9 + V].T  # (V, P)
    empty = (n_reb == 0)[None, :] | np.isnan(mean)
    means = np.where(empty, np.nan, mean)
    stds = np.where(empty | (n_reb < 2)[None, :], np.nan, std)
    quant = np.where(empty[:, :, None], np.nan, _quantile_rows(srt, n_reb, q))
    return means, stds, quant


def _diameter_plan(plan, scenario, spec, j, columns=None):
    """The plan of diameter node ``spec.diameters_um[j]``: `plan` with that one
    diameter. On a reduced speed axis the plan's speeds are the ratios r, and
    this diameter's points are at ``r v_c(d)``; the points keep their numbers,
    hence their random streams. `columns`: the diameter's row of
    :func:`~microimpact.engine.plan.atom_columns` (evaluated here if None)."""
    d = um_to_m(spec.diameters_um[j])
    if columns is None:
        columns = atom_columns(scenario, d)[0]
    # the cells of monodisperse(d) and the laws at d, bit for bit, without
    # building the distribution
    d_plan = dataclasses.replace(plan, diameters=atom_sampler(d, columns))
    if spec.speed_axis == "reduced":
        # v_c(d): the law's column (build_wall_law checked it is > 0 at every
        # diameter, critical_speed_m_s)
        v_c = float(columns[2])
        if isinstance(plan.points, GridPoints):  # the grid's speeds, scaled
            grid = plan.points.grid
            speeds = tuple(v * v_c for v in grid.speeds_m_s)
            points = GridPoints(dataclasses.replace(grid, speeds_m_s=speeds))
        else:
            points = tuple(
                dataclasses.replace(pt, speed=pt.speed * v_c) for pt in plan.points
            )
        d_plan = dataclasses.replace(d_plan, points=points)
    return d_plan


def _diameter_task(plan, scenario, spec, samples, j):
    """Every node of diameter ``spec.diameters_um[j]``: a dict of stacked arrays
    over the sweep points (surface x speed x angle, in :class:`SweepGrid` order),
    built a group of nodes at a time (:data:`GROUP_IMPACTS`), with the diameter's
    plan made here (a task of a process pool or an executor)."""
    d_plan = _diameter_plan(plan, scenario, spec, j)
    n = len(plan.points)
    per = _group_nodes(n, samples)
    buffers = _buffer_set(per * samples)
    parts = [
        _node_rows(d_plan, range(lo, min(n, lo + per)), spec, samples, buffers)
        for lo in range(0, n, per)
    ]
    return _joined(parts)


def _group_task(spec, samples, prepared, buffers, item):
    """The nodes ``range(lo, hi)`` of diameter ``j`` for ``item = (j, lo, hi)``
    (a part of :func:`_diameter_task`'s work, on a worker thread: `prepared`
    holds every diameter's plan, `buffers` the :class:`_Buffers`)."""
    j, lo, hi = item
    with buffers.lend() as arrays:
        return _node_rows(prepared[j], range(lo, hi), spec, samples, arrays)


def _joined(parts):
    if len(parts) == 1:
        return parts[0]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _group_nodes(n: int, samples: int, diameters: int = 1, workers: int = 1) -> int:
    """Nodes per group (per kernel call) of a diameter's `n` nodes at `samples`
    impacts: :data:`GROUP_IMPACTS` worth, or, where `workers` threads share the
    groups of `diameters` diameters, fewer, so that there are at least
    :data:`~microimpact.engine.montecarlo.TASKS_PER_WORKER` groups per worker
    (16 diameters on 16 workers were one round of one diameter each: the
    slowest diameter set the time), but not fewer impacts than
    :data:`MIN_GROUP_IMPACTS`; at most `n`. A node's values do not depend on its
    group."""
    per = max(1, GROUP_IMPACTS // max(samples, 1))
    if workers > 1:
        groups = -(-TASKS_PER_WORKER * workers // max(diameters, 1))
        per = min(per, max(_floor_nodes(samples), -(-n // groups)))
    return min(per, max(n, 1))


def _floor_nodes(samples: int) -> int:
    """Nodes of :data:`MIN_GROUP_IMPACTS` at `samples` impacts each (at least 1)."""
    return max(1, MIN_GROUP_IMPACTS // max(samples, 1))


def _buffer_set(size: int) -> dict:
    """Arrays for a group's impacts (:func:`_impacts`' `buffers`)."""
    return {
        "e_m": np.empty(size),
        "mu_m": np.empty(size),
        "lateral_angle_deg": np.empty(size),
        "outcome": np.empty(size, dtype=np.int8),
    }


def _group_items(indices, n: int, per: int, samples: int, workers: int) -> list:
    """The ``(j, lo, hi)`` groups of the diameters `indices` (`n` nodes each), in
    order: `per` nodes each, and toward the end, on several workers, at most the
    nodes left over ``TAIL_SPLIT x workers`` (down to :data:`MIN_GROUP_IMPACTS`
    worth), so the last round's groups are short and the workers finish
    together (as :func:`~microimpact.engine.montecarlo.task_sizes` for a run).
    A node's values do not depend on its group."""
    left = len(indices) * n
    floor = _floor_nodes(samples)
    items = []
    for j in indices:
        lo = 0
        while lo < n:
            hi = min(n, lo + tail_size(per, floor, left, workers))
            items.append((j, lo, hi))
            left -= hi - lo
            lo = hi
    return items


class _Buffers:
    """The groups' impact arrays, one set per worker at work, reused from group
    to group (fresh pages for every group cost more than the arithmetic on
    them) and freed with the build (kept past it, they made the table's checks
    fault in fresh pages: ~10 ms)."""

    def __init__(self, size: int):
        self._size = size
        self._free: list = []

    @contextlib.contextmanager
    def lend(self):
        try:
            held = self._free.pop()  # atomic: no lock needed
        except IndexError:
            held = _buffer_set(self._size)
        try:
            yield held
        finally:
            self._free.append(held)


def _results(plan, scenario, spec, samples, workers, executor, indices):
    """Yield ``(j, arrays)`` for the diameter indices `indices`, in index order,
    spread as every engine caller spreads work
    (:func:`~microimpact.engine.parallel.map_tasks`: the executor, else threads
    where the compiled kernel frees the GIL, as do NumPy's sorts, else
    processes). On threads the tasks are groups of nodes (:func:`_group_nodes`),
    joined into their diameter's arrays in order; elsewhere one diameter each
    (a process builds the diameter's plan for each task)."""
    if plan.kernel != "compiled" or executor is not None:
        task = functools.partial(_diameter_task, plan, scenario, spec, samples)
        results = map_tasks(
            task,
            indices,
            workers=workers,
            executor=executor,
            threads=plan.kernel == "compiled",
        )
        yield from zip(indices, results, strict=True)
        return
    prepared = _PreparedPlans(plan, scenario, spec, indices)
    n = len(plan.points)
    per = _group_nodes(n, samples, len(indices), workers)
    items = _group_items(indices, n, per, samples, workers)
    task = functools.partial(
        _group_task, spec, samples, prepared, _Buffers(per * samples)
    )
    parts = []
    for (j, _, hi), arrays in zip(
        items, map_tasks(task, items, workers=workers, threads=True), strict=True
    ):
        parts.append(arrays)
        if hi == n:  # the diameter's last group
            yield j, _joined(parts)
            parts = []
            del prepared[j]  # its plan's tables are no longer needed


class _PreparedPlans:
    """The plans of diameters `indices`, each with the compiled kernel's
    arguments parsed, dropped once the diameter is done.

    - Each diameter's own part (its one-atom sampler and the kernel's common
      arguments) is made here, in the driver, for all of them at once: the
      coefficient laws evaluated once over every diameter
      (:func:`~microimpact.engine.plan.atom_columns`), ~40 us per diameter.
      Made one by one by the workers, after their kernel calls had emptied
      the caches, they held the GIL ~0.3 ms each (issue 31).
    - The points (parsed once for all diameters where they share them,
      :meth:`Plan.shared`; a reduced speed axis gives each diameter its own)
      and the geometry are made on first use by the worker that needs them,
      under a lock of the diameter's own: the others wait for it, not for the
      GIL. Made in the driver before the workers started, all 16 of a reduced
      16^3 table would hold every worker back."""

    def __init__(self, plan, scenario, spec, indices):
        d = um_to_m(np.asarray(spec.diameters_um, dtype=float)[list(indices)])
        self._plans: dict = {}
        for j, columns in zip(indices, atom_columns(scenario, d), strict=True):
            self._plans[j] = got = _diameter_plan(plan, scenario, spec, j, columns)
            prepare_plan(got, points=False)
        self._ready: set = set()
        self._locks = {j: threading.Lock() for j in indices}

    def __getitem__(self, j):
        got = self._plans[j]
        if j not in self._ready:
            with self._locks[j]:
                if j not in self._ready:
                    prepare_plan(got)
                    _geometry(got)
                    self._ready.add(j)
        return got

    def __delitem__(self, j):
        self._plans.pop(j, None)


class _Partial:
    """Finished diameters of an interrupted build, kept as the engine keeps a
    run's finished work (:func:`~microimpact.engine.checkpoint.save_arrays`: one
    fingerprinted, atomically written file per diameter in a folder); a re-run
    with the same scenario, nodes and seed loads them instead of simulating them
    again. The folder's ``build.npz`` holds the entropy drawn for a scenario
    without a seed, so that the re-run continues the same table. Another build's
    files, or unreadable ones, are discarded."""

    def __init__(self, folder, fingerprint: str):
        self.folder = Path(folder)
        self.fingerprint = fingerprint
        #: The entropy of the interrupted build, or None for a fresh one.
        self.entropy = None
        try:
            meta = load_arrays(self.folder / "build.npz", fingerprint)
            if meta is not None:
                self.entropy = int(str(meta["entropy"]))
        except (CheckpointMismatch, KeyError, ValueError):
            pass
        if self.entropy is None and self.folder.exists():
            shutil.rmtree(self.folder)  # another build's, or unreadable

    def start(self, entropy: int) -> None:
        """Record the build's entropy (a fresh build only)."""
        if self.entropy is not None:
            return
        self.entropy = entropy
        self.folder.mkdir(parents=True, exist_ok=True)
        save_arrays(
            self.folder / "build.npz",
            self.fingerprint,
            {"entropy": np.array(str(entropy))},
        )

    def _file(self, j):
        return self.folder / f"diameter_{j:05d}.npz"

    def load(self, j):
        try:
            return load_arrays(self._file(j), self.fingerprint)
        except CheckpointMismatch:
            return None  # simulated again

    def save(self, j, arrays):
        save_arrays(self._file(j), self.fingerprint, arrays)

    def remove(self):
        shutil.rmtree(self.folder, ignore_errors=True)


def _fingerprint(scenario, spec, seed) -> str:

    text = dumps(
        {
            "scenario": scenario.describe(),
            "spec": dataclasses.asdict(spec),
            "seed": None if seed is None else str(seed),
            "version": __version__,
        }
    )
    return hashlib.sha256(text.encode()).hexdigest()


def build_wall_law(
    scenario,
    spec: WallLawSpec | None = None,
    *,
    workers: int = 1,
    seed=None,
    executor=None,
    progress=None,
    checkpoint=None,
    resuspension=None,
):
    """Tabulate the wall law of `scenario` at the nodes of `spec`.

    Parameters
    ----------
    scenario : ScenarioFile, Scenario, path or preset name
        The physics: coefficient laws against diameter, surfaces, particle
        roughness, speed scatter, shadowing, seed. Its particle size distribution
        is not used (the diameter is a node coordinate). A path or a preset name
        is read once (:func:`~microimpact.scenario.scenario.read_scenario`).
    spec : WallLawSpec, optional
        The nodes (default: the scenario file's ``[wall_law]`` table).
    workers : int
        Local workers (capped at the available cores): threads with the compiled
        kernel, else processes.
    seed : int, optional
        Root seed (default: the scenario's; fresh entropy if it has none, recorded
        in the table's ``seed`` attribute).
    executor : concurrent.futures.Executor, optional
        Any executor with ``submit`` (e.g. ``dask.distributed.Client``); the table
        is the same as with local workers.
    progress : bool or callable, optional
        ``True`` shows a progress bar of the diameters (tqdm, on stderr), a
        callable is called with ``(done, total)`` diameters after each one;
        ``False`` or None shows nothing.
    checkpoint : path-like, optional
        A folder where each finished diameter is kept until the table is complete:
        an interrupted build re-run with the same arguments simulates only the
        diameters that were not finished (and gives the same table).
    resuspension : ResuspensionSpec, dict or False, optional
        The ``[resuspension]`` table (a dict is read as that table): the table
        then carries ``stay_probability``, the probability that a particle
        captured at a node stays after the ramp
        (:func:`stay_probability_at_nodes`). Default: the scenario file's
        table, where a file was read (a path, a preset, a ScenarioFile, or a
        Scenario without `spec`); False: none.

    Returns
    -------
    WallLaw
    """
    source_text = data = None
    if not isinstance(scenario, Scenario):  # a file, path or preset name: read once
        file = read_scenario(scenario)
        scenario, source_text, data = file.scenario, file.text, file.data
        spec = file.wall_law if spec is None else spec
    elif spec is None and scenario.source is not None:  # its file's [wall_law]
        file = read_scenario(scenario.source)
        spec, source_text, data = file.wall_law, file.text, file.data
    if spec is None:
        raise ScenarioError(
            "no wall-law nodes: give `spec=WallLawSpec(...)` or a [wall_law] table "
            "in the scenario file",
            source=scenario.source,
            field="wall_law",
        )
    if not isinstance(spec, WallLawSpec):
        raise TypeError(f"`spec` must be a WallLawSpec; got {type(spec).__name__}")
    samples = spec.samples if spec.samples is not None else scenario.samples
    spec.check_size(len(scenario.surfaces))
    critical = None
    if spec.speed_axis == "reduced":  # refused before any simulation
        critical = critical_speed_m_s(scenario, spec.diameters_um)
        _check_reduced_speeds(scenario, spec, critical)
    res = _resuspension(scenario, data, resuspension)
    stay = None
    if res is not None:  # a few quadratures; refused before any simulation
        stay = stay_probability_at_nodes(res, spec.diameters_um, source=scenario.source)
    nodes_scenario = scenario.with_options(
        # the ratios r on a reduced axis: each diameter multiplies them by v_c(d)
        speeds_m_s=spec.speed_nodes,
        angles_deg=spec.angles_deg,
        samples=samples,
        precision=None,
        sampling="mc",
    )
    started = time.perf_counter()
    seed = nodes_scenario.seed if seed is None else seed
    partial = None
    if checkpoint is not None:
        partial = _Partial(checkpoint, _fingerprint(nodes_scenario, spec, seed))
        if partial.entropy is None:  # fresh entropy when the scenario has no seed
            partial.start(resolve_entropy(seed))
        seed = partial.entropy
    plan = build_plan(nodes_scenario, seed=seed)
    grid = SweepGrid.from_scenario(nodes_scenario)
    workers = cap_workers(int(workers))
    total = len(spec.diameters_um)
    columns: dict = {}

    def keep(j, arrays):
        for k, v in arrays.items():
            if k not in columns:
                columns[k] = np.empty((total, *v.shape), dtype=v.dtype)
            columns[k][j] = v

    todo = []
    for j in range(total):
        arrays = partial.load(j) if partial is not None else None
        if arrays is None:
            todo.append(j)
        else:
            keep(j, arrays)
    with Progress(
        progress, total=total, unit="diameters", initial=total - len(todo)
    ) as bar:
        for j, arrays in _results(
            plan, nodes_scenario, spec, samples, workers, executor, todo
        ):
            keep(j, arrays)
            if partial is not None:
                partial.save(j, arrays)
            bar.update()
    ds = wall_law_dataset(
        grid,
        spec,
        columns,
        scenario=nodes_scenario,
        entropy=plan.entropy,
        source_text=source_text,
        seconds=time.perf_counter() - started,
        critical_speed_m_s=critical,
        stay_probability=stay,
        resuspension=res,
    )
    if partial is not None:
        partial.remove()
    return WallLaw(ds)
