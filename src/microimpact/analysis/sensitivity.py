"""Global sensitivity: Sobol' indices of the engine's statistics (see
``docs/sensitivity.md``).

Each uncertain input is a number of the scenario file named by its dotted key
(:mod:`microimpact.scenario.parameters`) with a distribution. A Sobol' design of base
size n (matrices A, B and the d matrices AB_i, Saltelli et al. 2010) gives
``n * (d + 2)`` design rows; each row is one *model evaluation*. For the engine
(:class:`EngineModel`) an evaluation builds the scenario with the row's values
(:func:`~microimpact.scenario.file.scenario_from_dict` validates them) and runs every
sweep point at once with the same seed for every row (common random numbers), keeping
only
the statistics. First-order (S1) and total (ST) indices and their bootstrap (BCa)
intervals come from :func:`scipy.stats.sobol_indices` (Saltelli 2010 estimator for
S1, Jansen for ST) on those evaluations.

The model is pluggable: :func:`sobol_analysis` takes any picklable callable with an
``outputs`` table (see :class:`EngineModel`), so that a stand-in with known indices
(the Ishigami function, in the tests) runs through exactly the code the engine does.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .._core.files import atomic_write
from .._core.progress import Progress
from .._core.validation import check_int, did_you_mean
from ..engine.parallel import (
    cap_workers,
    fork_pool,
    map_held,
    map_tasks,
    runs_release_gil,
)
from ..errors import InputError, ScenarioError
from ..plotting.sensitivity import plot_sensitivity
from ..scenario.grid import SweepGrid
from ..scenario.parameters import check_parameter_key
from ..scenario.sensitivity import (
    DEFAULT_BASE_SIZE,
    DEFAULT_RESAMPLES,
    DEFAULT_STATISTICS,
    STATISTICS,
    parameter_distribution,
)
from .model import ScenarioModel

__all__ = [
    "COLUMNS",
    "EngineModel",
    "SensitivityResult",
    "sobol_analysis",
    "sobol_sensitivity",
]

#: Columns of :attr:`SensitivityResult.table` (``surface`` is inserted after
#: ``statistic`` when the scenario has several surfaces).
COLUMNS = (
    "parameter",
    "statistic",
    "speed_m_s",
    "angle_deg",
    "S1",
    "S1_ci_low",
    "S1_ci_high",
    "ST",
    "ST_ci_low",
    "ST_ci_high",
)
#: Design rows per task sent to a worker, at most (a task is a few engine runs).
MAX_ROWS_PER_TASK = 16
#: An output whose standard deviation over the design is at most this times
#: ``max(1, max |output|)`` is constant (rounding only): its indices are NaN.
CONSTANT_RTOL = 1e-12
#: Sweep points whose output's standard deviation over the design is at most this
#: times the statistic's largest carry no weight in :meth:`SensitivityResult.
#: aggregated` (the output hardly varies there: its indices are mostly noise).
AGGREGATE_MIN_STD = 0.01
#: The capture fraction whose speed the ``capture_speed_m_s`` statistic is.
CAPTURE_SPEED_QUANTILE = 0.5


# ---------------------------------------------------------------------- the model
class EngineModel:
    """The engine as a model for :func:`sobol_analysis`: design rows -> statistics.

    ``model(rows)`` takes an array of shape ``(m, d)`` (one row of parameter values
    per evaluation, in the order of `keys`) and returns an array of shape
    ``(m, len(model.outputs))``: each row is run by the
    :class:`~microimpact.analysis.model.ScenarioModel` (the file read once, each of
    its tables built once and again only when a parameter changes it; one worker,
    no progress bar) and reduced to its statistics; the run itself is dropped, so
    memory stays bounded whatever the design size.

    Parameters
    ----------
    scenario : ScenarioModel, ScenarioFile, path, preset name or dict
        The scenario (a dict is parsed TOML data; its ``[sensitivity]`` table is
        ignored).
    keys : sequence of str
        Dotted keys of the parameters, in the column order of the rows.
    statistics : sequence of str
        Names among :data:`microimpact.scenario.sensitivity.STATISTICS`.
    seed : int
        The engine seed. With `common_random_numbers` (the default) every row is
        run with this same seed; otherwise each row gets its own seed, derived from
        `seed` and the row's values (to measure what common random numbers save).
    samples : int, optional
        Impacts per sweep point (default: the scenario's ``samples``).
    source, base_dir :
        For a dict `scenario`, as for
        :func:`~microimpact.scenario.scenario.scenario_from_dict`.

    Attributes
    ----------
    outputs : pandas.DataFrame
        One row per output column: ``statistic``, ``surface``, ``speed_m_s``,
        ``angle_deg`` (``speed_m_s`` is NaN for ``capture_speed_m_s``).
    """

    def __init__(
        self,
        scenario,
        keys,
        statistics=DEFAULT_STATISTICS,
        *,
        seed: int,
        samples: int | None = None,
        source=None,
        base_dir=None,
        common_random_numbers: bool = True,
    ):
        if isinstance(scenario, ScenarioModel):
            self.model = scenario
        else:
            self.model = ScenarioModel(
                scenario, keys, samples=samples, source=source, base_dir=base_dir
            )
        self.keys = tuple(keys)
        self.statistics = _check_statistics(statistics)
        self.seed = int(seed)
        self.source = self.model.source
        self.samples = self.model.samples
        self.common_random_numbers = bool(common_random_numbers)
        grid = SweepGrid.from_scenario(self.model.base)
        if "capture_speed_m_s" in self.statistics and len(grid.speeds_m_s) < 2:
            raise ScenarioError(
                "the statistic 'capture_speed_m_s' needs a sweep of at least two "
                "speeds",
                source=self.source,
                field="sensitivity.statistics",
            )
        rows = []
        for stat in self.statistics:
            for surface in grid.surfaces:
                if stat == "capture_speed_m_s":
                    rows += [(stat, surface, math.nan, a) for a in grid.angles_deg]
                    continue
                for s in grid.speeds_m_s:
                    rows += [(stat, surface, s, a) for a in grid.angles_deg]
        self.outputs = pd.DataFrame(
            rows, columns=["statistic", "surface", "speed_m_s", "angle_deg"]
        )
        # each statistic's outputs as the keys a run's summary rows have
        # (surface, speed, angle; the capture speed's without the speed)
        self._keys = {
            stat: [
                r[1:] if stat != "capture_speed_m_s" else (r[1], r[3])
                for r in rows
                if r[0] == stat
            ]
            for stat in self.statistics
        }

    def scenario(self, values):
        """The validated scenario at parameter `values` (a row, or a mapping of
        key -> value)."""
        return self.model.scenario(values)

    def check_rows(self, rows):
        """Build the scenario at each parameter's smallest and largest value in
        `rows` (the others at their file values) before any run, so that a range
        the scenario does not allow fails at once with its one-line error."""
        rows = np.atleast_2d(np.asarray(rows, dtype=float))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for j, key in enumerate(self.keys):
                for value in (rows[:, j].min(), rows[:, j].max()):
                    self.scenario({key: float(value)})

    def _seed(self, row) -> int:
        if self.common_random_numbers:
            return self.seed
        words = np.asarray(row, dtype=float).view(np.uint32).tolist()
        return int(np.random.SeedSequence([self.seed, *words]).generate_state(1)[0])

    def _statistics(self, result) -> np.ndarray:
        """The output vector of one run, in the order of :attr:`outputs` (each
        output's row of the summary found by its exact (surface, speed, angle),
        as ``summary.set_index(...).loc`` finds it, without building the index;
        and only the columns the outputs read, without the summary table:
        ``result.summary_columns``. A design row's Python is then small beside
        its engine run)."""
        summary = result.summary_columns(
            [s for s in dict.fromkeys(self.statistics) if s != "capture_speed_m_s"]
        )
        where = {
            key: i
            for i, key in enumerate(
                zip(
                    summary["surface"].tolist(),
                    summary["speed_m_s"].tolist(),
                    summary["angle_deg"].tolist(),
                    strict=True,
                )
            )
        }
        out = []
        for stat in self.statistics:
            if stat == "capture_speed_m_s":
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    cs = result.capture_speed(CAPTURE_SPEED_QUANTILE)
                cs = cs.set_index(["surface", "angle_deg"])["speed_m_s"]
                out.append(cs.loc[self._keys[stat]])
            else:
                rows = [where[key] for key in self._keys[stat]]  # KeyError: absent
                out.append(np.asarray(summary[stat], dtype=float)[rows])
        return np.concatenate([np.asarray(v, dtype=float) for v in out])

    def __call__(self, rows) -> np.ndarray:
        rows = np.atleast_2d(np.asarray(rows, dtype=float))
        out = np.empty((len(rows), len(self.outputs)))
        for k, row in enumerate(rows):
            result = self.model.run(row, seed=self._seed(row))
            out[k] = self._statistics(result)
            del result
        return out


def _check_statistics(statistics) -> tuple:
    if isinstance(statistics, str):
        statistics = (statistics,)
    statistics = tuple(dict.fromkeys(statistics))
    if not statistics:
        raise InputError("must name at least one statistic", field="statistics")

    for s in statistics:
        if s not in STATISTICS:
            raise InputError(
                f"unknown statistic {s!r}{did_you_mean(s, STATISTICS)}; allowed: "
                f"{', '.join(STATISTICS)}",
                field="statistics",
            )
    return statistics


# ---------------------------------------------------------------------- the result
@dataclass
class SensitivityResult:
    """Sobol' indices of every output with their bootstrap intervals.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per (parameter, output): the columns of :data:`COLUMNS`
        (``surface`` after ``statistic`` when there are several surfaces). S1 and
        ST are NaN where an index is undefined: the output does not vary over the
        design, or is not finite at some design row (e.g. ``e_rebound_mean`` where
        every particle is captured).
    outputs : pandas.DataFrame
        One row per output: its coordinates, ``mean`` and ``std`` over the A and B
        evaluations, and ``defined`` (whether its indices are).
    parameters : dict
        Dotted key -> frozen distribution.
    base_size : int
        Base size n of the design.
    evaluations : int
        Model evaluations, ``n * (d + 2)``.
    seed : int
        Root seed (the design, the engine and the bootstrap derive from it).
    confidence : float
        Level of the intervals.
    info : dict
        Further provenance (engine seed, impacts per point ``samples``, common
        random numbers).
    """

    table: object
    outputs: object
    parameters: dict
    base_size: int
    evaluations: int
    seed: int
    confidence: float
    info: dict = field(default_factory=dict)

    def aggregated(self, statistic=None, *, min_std=AGGREGATE_MIN_STD):
        """Indices of each parameter over all the sweep points of a statistic,
        weighted by each point's output variance (the aggregated Sobol' indices
        of Gamboa, Janon, Klein & Lagnoux 2014: ``sum_p Var_p S_p / sum_p Var_p``,
        the share of the total output variance over the sweep that the parameter
        explains), each point's index clipped to [0, 1] first.

        Points whose output hardly varies over the design (standard deviation at
        most `min_std` times the largest of that statistic) or whose indices are
        undefined carry no weight, so a noisy index where capture hardly changes
        cannot lead the ranking.

        Returns
        -------
        pandas.DataFrame
            ``statistic``, ``parameter``, ``S1``, ``ST`` (each in [0, 1]) and
            ``points`` (the sweep points weighed), sorted by ``ST`` within each
            statistic, largest first.
        """
        out = []
        stats = (
            [statistic]
            if statistic is not None
            else list(dict.fromkeys(self.outputs["statistic"]))
        )
        coords = [c for c in ("surface", "speed_m_s", "angle_deg") if c in self.table]
        for stat in stats:
            o = self.outputs[self.outputs["statistic"] == stat]
            std = o["std"].to_numpy(dtype=float)
            top = np.nanmax(std) if np.isfinite(std).any() else 0.0
            use = o["defined"].to_numpy(bool) & (std > min_std * top)
            w = pd.Series(np.where(use, std**2, 0.0), index=o.index)
            weights = o.assign(weight=w.to_numpy())[[*coords, "weight"]]
            t = self.table[self.table["statistic"] == stat].merge(
                weights, on=coords, how="left"
            )
            for name, g in t.groupby("parameter", sort=False):
                wt = g["weight"].to_numpy(float)
                total = wt.sum()
                row = {
                    "statistic": stat,
                    "parameter": name,
                    "points": int((wt > 0).sum()),
                }
                for col in ("S1", "ST"):
                    v = np.clip(np.nan_to_num(g[col].to_numpy(float)), 0.0, 1.0)
                    row[col] = float((wt * v).sum() / total) if total > 0 else np.nan
                out.append(row)
        res = pd.DataFrame(
            out, columns=["statistic", "parameter", "S1", "ST", "points"]
        )
        order = res.groupby("statistic", sort=False).cumcount()
        res = res.assign(_o=order).sort_values(
            ["statistic", "ST"], ascending=[True, False], kind="stable"
        )
        return res.drop(columns="_o").reset_index(drop=True)

    def to_csv(self, path) -> Path:
        """Write :attr:`table` to `path` (CSV), atomically."""

        return atomic_write(path, lambda t: self.table.to_csv(t, index=False))

    def plot(self, statistic=None, *, ax=None):
        """ST against speed (or angle); see
        :func:`microimpact.plotting.sensitivity.plot_sensitivity`."""

        return plot_sensitivity(self.table, statistic=statistic, ax=ax)


# ---------------------------------------------------------------------- the design
def _design(dists, n: int, rng) -> np.ndarray:
    """The ``n * (d + 2)`` design rows: A, B, then AB_1 ... AB_d (A with column i
    from B), from one scrambled Sobol' sequence of 2d columns (as
    ``scipy.stats.sobol_indices`` draws A and B)."""
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.stats import qmc

    d = len(dists)
    u = qmc.Sobol(d=2 * d, scramble=True, rng=rng).random(n)
    u = np.clip(u, 2.0**-53, 1.0 - 2.0**-53)  # ppf(0) may be -inf
    x = np.empty_like(u)
    for i, dist in enumerate(dists):
        x[:, i] = dist.ppf(u[:, i])
        x[:, d + i] = dist.ppf(u[:, d + i])
    A, B = x[:, :d], x[:, d:]
    pages = []
    for i in range(d):
        AB = A.copy()
        AB[:, i] = B[:, i]
        pages.append(AB)
    return np.concatenate([A, B, *pages])


def _chunks(rows: np.ndarray, workers: int) -> list[np.ndarray]:
    """Consecutive chunks of design rows: about four per worker, at most
    :data:`MAX_ROWS_PER_TASK` rows each."""
    size = max(1, min(MAX_ROWS_PER_TASK, math.ceil(len(rows) / (4 * workers))))
    return [rows[i : i + size] for i in range(0, len(rows), size)]


def _evaluate(model, rows, *, workers, executor, progress) -> np.ndarray:
    """The model at every design row: an array ``(len(rows), n_outputs)``, chunks of
    rows spread on the executor, else on `workers` processes forked from this
    one, each holding the model as built
    (:func:`~microimpact.engine.parallel.fork_pool`: a design row holds the GIL
    for ~40 % of its time, so threads wait for one another), else as every
    engine caller spreads work (:func:`~microimpact.engine.parallel.map_tasks`:
    threads where the runs free the GIL, else processes). Each row's value
    depends on the row alone: the same bits on any of them."""
    n_out = len(model.outputs)
    out = np.empty((len(rows), n_out))
    parallel = executor is not None or workers > 1
    chunks = _chunks(rows, workers if parallel else 1)
    pool = None
    if executor is None:
        pool = fork_pool(min(workers, len(chunks)), model)
    try:
        if pool is not None:
            results = map_held(pool, chunks)
        else:
            threads = isinstance(model, EngineModel) and runs_release_gil()
            results = map_tasks(
                model, chunks, workers=workers, executor=executor, threads=threads
            )
        k = 0
        with Progress(progress, total=len(rows), unit="rows") as bar:
            for chunk, y in zip(chunks, results, strict=True):
                y = np.asarray(y, dtype=float).reshape(len(chunk), n_out)
                out[k : k + len(chunk)] = y
                k += len(chunk)
                bar.update(len(chunk))
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
    return out


# ---------------------------------------------------------------------- the indices
def _indices(f_A, f_B, f_AB, *, confidence, n_resamples, seed):
    """S1, ST and their BCa intervals, each of shape (s, d), for outputs whose
    evaluations are all finite and vary (NaN elsewhere)."""
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.stats import sobol_indices

    d, s, n = f_AB.shape
    nan = np.full((s, d), np.nan)
    s1, st, s1_lo, s1_hi, st_lo, st_hi = (nan.copy() for _ in range(6))
    finite = (
        np.isfinite(f_A).all(axis=1)
        & np.isfinite(f_B).all(axis=1)
        & np.isfinite(f_AB).all(axis=(0, 2))
    )
    ab = np.concatenate([f_A, f_B], axis=1)
    std = np.full(s, np.nan)
    scale = np.ones(s)
    std[finite] = np.std(ab[finite], axis=1)
    scale[finite] = np.maximum(1.0, np.abs(ab[finite]).max(axis=1))
    # constant up to rounding (e.g. mu_mean ~ 1e-17 at normal incidence): no
    # variance to apportion, the indices are undefined
    ok = finite & (std > CONSTANT_RTOL * scale)
    if not ok.any():
        return s1, st, s1_lo, s1_hi, st_lo, st_hi, ok
    m = int(ok.sum())
    res = sobol_indices(func={"f_A": f_A[ok], "f_B": f_B[ok], "f_AB": f_AB[:, ok]}, n=n)
    s1[ok] = np.reshape(res.first_order, (m, d))
    st[ok] = np.reshape(res.total_order, (m, d))
    # scipy's bootstrap draws from NumPy's global generator when not given one:
    # seed it for reproducible intervals and put the caller's state back after
    state = np.random.get_state()  # noqa: NPY002
    try:
        np.random.seed(seed)  # noqa: NPY002
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # degenerate resamples: handled below
            boot = res.bootstrap(confidence_level=confidence, n_resamples=n_resamples)
    finally:
        np.random.set_state(state)  # noqa: NPY002
    for point, lo, hi, part in (
        (s1, s1_lo, s1_hi, boot.first_order),
        (st, st_lo, st_hi, boot.total_order),
    ):
        low = np.reshape(part.confidence_interval.low, (m, d)).copy()
        high = np.reshape(part.confidence_interval.high, (m, d)).copy()
        dist = np.reshape(part.bootstrap_distribution, (m, d, -1))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices
            # BCa fails where resamples are undefined (a resample without
            # variance, near 0 % or 100 % capture): percentile interval of the
            # defined resamples instead
            alpha = 100 * (1 - confidence) / 2
            bad = ~(np.isfinite(low) & np.isfinite(high))
            if bad.any():
                q = np.nanpercentile(dist[bad], [alpha, 100 - alpha], axis=-1)
                low[bad], high[bad] = q[0], q[1]
            # an index that no resample changes (e.g. ST = 0 exactly for an input
            # without effect): BCa is undefined, the interval is the point itself
            flat = np.nanmax(dist, axis=-1) == np.nanmin(dist, axis=-1)
        low[flat], high[flat] = point[ok][flat], point[ok][flat]
        lo[ok], hi[ok] = low, high
    return s1, st, s1_lo, s1_hi, st_lo, st_hi, ok


def sobol_analysis(
    model,
    parameters: Mapping,
    *,
    base_size: int = DEFAULT_BASE_SIZE,
    workers: int = 1,
    executor=None,
    seed=None,
    confidence: float = 0.95,
    n_resamples: int = DEFAULT_RESAMPLES,
    progress=None,
    info=None,
) -> SensitivityResult:
    """Sobol' indices of every output of `model` (the engine or a stand-in).

    Parameters
    ----------
    model : callable
        ``model(rows)`` with `rows` of shape ``(m, d)`` (columns in the order of
        `parameters`) returns ``(m, len(model.outputs))``; ``model.outputs`` is a
        DataFrame with ``statistic``, ``speed_m_s``, ``angle_deg`` and optionally
        ``surface`` per output column. On several `workers` it runs in worker
        processes forked from this one, which inherit it (it need not be
        picklable); on an `executor`, or where this process cannot fork (another
        thread runs, e.g. a notebook's kernel or a Dask client: then threads for
        the engine, else processes), it must be picklable. See
        :class:`EngineModel`.
    parameters : mapping
        Name -> distribution: a table ``{low, high}`` or ``{distribution = ...}``
        (see :func:`~microimpact.scenario.sensitivity.parameter_distribution`) or a
        frozen ``scipy.stats`` distribution.
    base_size : int
        Base size n of the design, a power of 2; the model is evaluated
        ``n * (d + 2)`` times.
    workers : int
        Processes evaluating design rows, forked from this one (capped at the
        available cores); ignored when `executor` is given.
    executor : object with ``submit`` or ``map``, optional
        A ``concurrent.futures`` executor, Dask's ``client.get_executor()``, an
        emcee-style pool...
    seed : int or None
        Root seed of the design (scrambled Sobol'), of `model` (not used here) and
        of the bootstrap; None draws fresh entropy, recorded in the result.
    confidence : float
        Level of the bootstrap (BCa) intervals.
    n_resamples : int
        Bootstrap resamples.
    progress : bool or callable, optional
        ``True`` shows a progress bar of the design rows (tqdm, on stderr), a
        callable is called as ``progress(done, total)`` after each chunk of rows;
        default: a bar only when stderr is a terminal.
    info : dict, optional
        Provenance stored in :attr:`SensitivityResult.info`.

    Returns
    -------
    SensitivityResult
    """
    if not parameters:
        raise InputError("must name at least one parameter", field="parameters")
    names = list(parameters)
    dists = [parameter_distribution(parameters[k], k) for k in names]
    n = check_int(base_size, "base_size", minimum=2)
    if n & (n - 1):
        raise InputError(
            f"must be a power of 2 (the balance of Sobol' points); got {n}",
            field="base_size",
        )
    if not 0 < confidence < 1:
        raise InputError(f"must be in (0, 1); got {confidence!r}", field="confidence")
    n_resamples = check_int(n_resamples, "n_resamples", minimum=10)
    if executor is None:
        workers = cap_workers(check_int(workers, "workers", minimum=1))
    root = np.random.SeedSequence(seed)
    design_ss, boot_ss = root.spawn(2)
    d = len(names)
    rows = _design(dists, n, np.random.default_rng(design_ss))
    if hasattr(model, "check_rows"):
        model.check_rows(rows)
    y = _evaluate(model, rows, workers=workers, executor=executor, progress=progress)
    f_A, f_B = y[:n].T, y[n : 2 * n].T
    f_AB = y[2 * n :].reshape(d, n, -1).transpose(0, 2, 1)  # (d, s, n)
    s1, st, s1_lo, s1_hi, st_lo, st_hi, ok = _indices(
        f_A,
        f_B,
        f_AB,
        confidence=confidence,
        n_resamples=n_resamples,
        seed=int(boot_ss.generate_state(1)[0]),
    )

    outputs = model.outputs.reset_index(drop=True).copy()
    several = "surface" in outputs and outputs["surface"].nunique() > 1
    coords = ["statistic", *(["surface"] if several else []), "speed_m_s", "angle_deg"]
    ab = np.concatenate([f_A, f_B], axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN outputs
        outputs["mean"] = np.nanmean(ab, axis=1)
        outputs["std"] = np.nanstd(ab, axis=1)
    outputs["defined"] = ok
    parts = []
    for j, name in enumerate(names):
        part = outputs[coords].copy()
        part.insert(0, "parameter", name)
        for col, values in (
            ("S1", s1),
            ("S1_ci_low", s1_lo),
            ("S1_ci_high", s1_hi),
            ("ST", st),
            ("ST_ci_low", st_lo),
            ("ST_ci_high", st_hi),
        ):
            part[col] = values[:, j]
        parts.append(part)
    table = pd.concat(parts, ignore_index=True)
    return SensitivityResult(
        table=table,
        outputs=outputs,
        parameters=dict(zip(names, dists, strict=True)),
        base_size=n,
        evaluations=len(rows),
        seed=int(root.entropy) if isinstance(root.entropy, int) else root.entropy,
        confidence=float(confidence),
        info=dict(info or {}),
    )


# ---------------------------------------------------------------------- the engine
def sobol_sensitivity(
    scenario,
    parameters: Mapping | None = None,
    *,
    base_size: int | None = None,
    samples: int | None = None,
    statistics=None,
    workers: int = 1,
    executor=None,
    seed=None,
    confidence: float = 0.95,
    n_resamples: int | None = None,
    common_random_numbers: bool = True,
    base_dir=None,
    progress=None,
) -> SensitivityResult:
    """Sobol' indices of the engine's statistics at every sweep point.

    Parameters
    ----------
    scenario : ScenarioFile, path, preset name or dict
        A scenario file (or its parsed TOML data), read once. Its
        ``[sensitivity]`` table, if any, gives the defaults of `parameters`,
        `base_size`, `statistics` and `n_resamples`.
    parameters : mapping, optional
        Dotted scenario key -> distribution (``{"low": 8, "high": 12}``,
        ``{"distribution": "normal", "mean": ..., "std": ...}``, a frozen
        ``scipy.stats`` distribution...). Required unless the file has a
        ``[sensitivity.parameters]`` table.
    base_size : int, optional
        Base size n of the Sobol' design (a power of 2; default the file's, else
        1024). The engine runs ``n * (d + 2)`` times, each time every sweep point.
    samples : int, optional
        Impacts per sweep point and design row (default: the scenario's
        ``samples``), as in :func:`microimpact.run`.
    statistics : sequence of str, optional
        Default ``("capture_fraction", "e_rebound_mean", "mu_mean")``; see
        :data:`microimpact.scenario.sensitivity.STATISTICS`.
    workers, executor :
        Processes forked from this one (or any executor with
        ``submit``/``map``, e.g. Dask's ``client.get_executor()``) running
        batches of design rows; each engine run inside uses one core. Where this
        process cannot fork (another thread runs), threads.
    seed : int, optional
        Root seed of the design, the engine and the bootstrap (default: the
        scenario's ``seed``, else fresh entropy, recorded in the result).
    confidence : float
        Level of the bootstrap intervals.
    n_resamples : int, optional
        Bootstrap resamples (default the file's, else 999).
    common_random_numbers : bool
        Run every design row with the same engine seed (default). False gives each
        row its own seed; only useful to see the noise this avoids.
    base_dir : path, optional
        Folder of relative paths of a dict scenario.
    progress : bool or callable, optional
        As for :func:`sobol_analysis` (design rows).

    Returns
    -------
    SensitivityResult

    Raises
    ------
    ScenarioError
        A parameter key that is not a number of the scenario, a bad distribution,
        or a value of the design the scenario does not allow (naming the key).
    """
    # the file is read once, its tables built once: physics and [sensitivity]
    scenario_model = ScenarioModel(scenario, samples=samples, base_dir=base_dir)
    file = scenario_model.file
    settings, source = file.sensitivity, file.source
    data = {k: v for k, v in file.data.items() if k != "sensitivity"}
    if parameters is None:
        if settings is None:
            raise ScenarioError(
                "no parameters: give `parameters` or a [sensitivity.parameters] "
                "table in the scenario",
                source=source,
                field="sensitivity.parameters",
            )
        parameters = settings.parameters
    else:
        for key in parameters:
            check_parameter_key(data, key, source=source)
    if base_size is None:
        base_size = settings.base_size if settings else DEFAULT_BASE_SIZE
    if statistics is None:
        statistics = settings.statistics if settings else DEFAULT_STATISTICS
    if n_resamples is None:
        n_resamples = settings.resamples if settings else DEFAULT_RESAMPLES
    if seed is None and isinstance(data.get("seed"), int):
        seed = data["seed"]
    root = np.random.SeedSequence(seed)
    engine_seed = int(root.spawn(3)[2].generate_state(1)[0])
    scenario_model.set_keys(parameters)
    model = EngineModel(
        scenario_model,
        list(parameters),
        statistics,
        seed=engine_seed,
        common_random_numbers=common_random_numbers,
    )
    dists = {
        k: parameter_distribution(v, k, source=source) for k, v in parameters.items()
    }
    return sobol_analysis(
        model,
        dists,
        base_size=base_size,
        workers=workers,
        executor=executor,
        seed=root.entropy,
        confidence=confidence,
        n_resamples=n_resamples,
        progress=progress,
        info={
            "source": None if source is None else str(source),
            "engine_seed": engine_seed,
            "samples": model.samples,
            "common_random_numbers": model.common_random_numbers,
            "statistics": list(model.statistics),
        },
    )
