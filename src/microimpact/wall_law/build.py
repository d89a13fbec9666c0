"""Build a wall law: run the engine at every node and tabulate the outcomes.

At a node (surface, diameter, speed, angle) the diameter is fixed and every other
random input keeps its distribution: the roughness angle of the surface (paper
Eqs. 7-9 on a facet tilted by it), the particle's own roughness, the speed scatter,
under the scenario's shadowing rule. The impacts are those of the engine's NumPy
kernel (:func:`microimpact.engine.kernel.simulate_block` with ``store=True``, the
draws :func:`microimpact.run` makes), so the physics is the paper's Eqs. 1-9 as
implemented in :mod:`microimpact.physics.impact` and checked there.

Common random numbers: every diameter of a (surface, speed, angle) uses the same
draws (the engine's stream of that sweep point), so the table is smooth in the
diameter, and the seed reproduces the table bit for bit for any worker count.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import shutil
import time
from concurrent.futures import as_completed
from pathlib import Path

import numpy as np

from .. import __version__
from .._core.files import atomic_write
from .._core.json import dumps
from .._core.progress import Progress
from ..engine.montecarlo import iter_point_samples
from ..engine.parallel import cap_workers, process_pool
from ..engine.plan import ArealSampler, build_plan, diameter_sampler, resolve_entropy
from ..errors import ScenarioError
from ..population.distributions import monodisperse
from ..scenario.grid import SweepGrid
from ..scenario.scenario import Scenario, read_scenario
from ..scenario.wall_law import REBOUND_VARIABLES, RESERVOIR_VARIABLES, WallLawSpec
from .law import WallLaw, wall_law_dataset

__all__ = ["build_wall_law", "node_outcomes"]


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


def _node(plan, point: int, angle_deg: float, spec: WallLawSpec, samples: int):
    """Counts, statistics and reservoir of one node."""

    parts = list(iter_point_samples(plan, point, samples))
    draws = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    struck = ~draws["shadowed"]
    captured = draws["captured"] & struck
    rebound = struck & ~captured
    areal = isinstance(plan.surfaces[plan.points[point].surface], ArealSampler)
    # on an areal surface the rebound leaves the plane of incidence
    psi = draws["lateral_angle_deg"][rebound] if areal else None
    out = node_outcomes(draws["e_m"][rebound], draws["mu_m"][rebound], angle_deg, psi)
    n_reb = int(np.count_nonzero(rebound))
    q = np.asarray(spec.quantiles)
    row = {
        "n_samples": samples,
        "n_impacts": int(np.count_nonzero(struck)),
        "n_captured": int(np.count_nonzero(captured)),
        "n_rebounds": n_reb,
        "n_reimpacts": int(np.count_nonzero(out["e_n"] < 0.0)),
    }
    for name in REBOUND_VARIABLES:
        x = out[name]
        if n_reb == 0 or np.isnan(x).all():
            row[f"{name}_mean"] = row[f"{name}_std"] = np.nan
            row[f"{name}_quantile"] = np.full(q.size, np.nan)
        else:
            row[f"{name}_mean"] = float(np.mean(x))
            row[f"{name}_std"] = float(np.std(x, ddof=1)) if n_reb > 1 else np.nan
            row[f"{name}_quantile"] = np.quantile(x, q)
    k = min(spec.reservoir, n_reb)
    row["reservoir_count"] = k
    for name in RESERVOIR_VARIABLES:
        res = np.full(spec.reservoir, np.nan)
        res[:k] = out[name][:k]
        row[f"reservoir_{name}"] = res
    return row


def _diameter_task(plan, scenario, spec, samples, j):
    """Every node of diameter ``spec.diameters_um[j]``: a dict of stacked arrays
    over the sweep points (surface x speed x angle, in :class:`SweepGrid` order)."""
    d_plan = dataclasses.replace(
        plan,
        diameters=diameter_sampler(scenario, monodisperse(spec.diameters_um[j])),
    )
    rows = [
        _node(d_plan, i, p.angle_deg, spec, samples) for i, p in enumerate(plan.points)
    ]
    return {k: np.stack([np.asarray(r[k]) for r in rows]) for k in rows[0]}


_WORKER: dict = {}


def _init_worker(plan, scenario, spec, samples):
    _WORKER.update(plan=plan, scenario=scenario, spec=spec, samples=samples)


def _worker_task(j):
    w = _WORKER
    return _diameter_task(w["plan"], w["scenario"], w["spec"], w["samples"], j)


def _results(plan, scenario, spec, samples, workers, executor, indices):
    """Yield ``(j, arrays)`` for the diameter indices `indices`, as they finish
    (in index order with an `executor`)."""
    if not indices:
        return
    if executor is not None:
        args = (plan, scenario, spec, samples)
        futures = {j: executor.submit(_diameter_task, *args, j) for j in indices}
        for j, f in futures.items():
            yield j, f.result()
        return
    if workers <= 1 or len(indices) == 1:
        for j in indices:
            yield j, _diameter_task(plan, scenario, spec, samples, j)
        return

    with process_pool(
        min(workers, len(indices)),
        initializer=_init_worker,
        initargs=(plan, scenario, spec, samples),
    ) as pool:
        futures = {pool.submit(_worker_task, j): j for j in indices}
        try:
            for f in as_completed(futures):
                yield futures[f], f.result()
        except BaseException:
            for f in futures:
                f.cancel()
            raise


class _Partial:
    """Finished diameters of an interrupted build, one ``.npz`` per diameter in a
    folder; a re-run with the same scenario, nodes and seed loads them instead of
    simulating them again. The folder's ``meta.json`` holds the fingerprint (and
    the entropy drawn for a scenario without a seed, so that the re-run continues
    the same table)."""

    def __init__(self, folder, fingerprint: str):

        self.folder = Path(folder)
        self.fingerprint = fingerprint
        #: The entropy of the interrupted build, or None for a fresh one.
        self.entropy = None
        try:
            old = json.loads((self.folder / "meta.json").read_text())
            if old.get("fingerprint") == fingerprint:
                self.entropy = int(old["entropy"])
        except (OSError, ValueError, TypeError, KeyError, AttributeError):
            pass
        if self.entropy is None and self.folder.exists():
            shutil.rmtree(self.folder)  # another build's, or unreadable

    def start(self, entropy: int) -> None:
        """Record the build's entropy (a fresh build only)."""

        if self.entropy is not None:
            return
        self.entropy = entropy
        self.folder.mkdir(parents=True, exist_ok=True)
        atomic_write(
            self.folder / "meta.json",
            lambda t: Path(t).write_text(
                json.dumps({"fingerprint": self.fingerprint, "entropy": str(entropy)})
            ),
        )

    def _file(self, j):
        return self.folder / f"diameter_{j:05d}.npz"

    def load(self, j):
        try:
            with np.load(self._file(j)) as f:
                return {k: f[k] for k in f.files}
        except (OSError, ValueError, EOFError):
            return None

    def save(self, j, arrays):

        def write(tmp):
            with open(tmp, "wb") as fh:
                np.savez(fh, **arrays)

        atomic_write(self._file(j), write)

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
        Local processes (capped at the available cores).
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

    Returns
    -------
    WallLaw
    """
    if not isinstance(scenario, Scenario):
        file = read_scenario(scenario)  # a path or a preset name, read once
    elif spec is None and scenario.source is not None:
        file = read_scenario(scenario.source)  # its [wall_law] table
    else:
        file = None
    source_text = None
    if file is not None:
        scenario = file.scenario if not isinstance(scenario, Scenario) else scenario
        spec = file.wall_law if spec is None else spec
        source_text = file.text
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
    nodes_scenario = scenario.with_options(
        speeds_m_s=spec.speeds_m_s,
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
    plan = build_plan(nodes_scenario, seed=seed, kernel="numpy")
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
    )
    if partial is not None:
        partial.remove()
    return WallLaw(ds)
