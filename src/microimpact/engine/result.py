"""The result of a run: one CF-1.10 Dataset, and what derives from it.

:class:`SimulationResult` wraps the canonical :class:`xarray.Dataset` (see
:mod:`.dataset`): the summary table, the histograms, the capture speed and the
relative coefficients are all derived from it, so a result loaded back from
``results.nc`` with :func:`open_result` behaves exactly like a fresh one.
"""

from __future__ import annotations

import datetime as _dt
import functools
import html
import json
import math
import platform
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np

from .._core.files import atomic_write
from .._core.json import dumps as json_dumps
from .._core.json import restore_nonfinite
from .._core.progress import stage
from .._core.validation import check_choice
from ..errors import InputError
from ..scenario.grid import DIMS, SweepGrid
from .accumulators import E_EDGES, LATERAL_EDGES, MU_EDGES
from .capture import ESTIMATORS
from .dataset import (
    INPUT_QUANTILES,
    LATERAL_VARIABLES,
    SUMMARY_COLUMNS,
    TAIL_VARIABLES,
    VARIABLES,
    build_dataset,
    encoding,
    history_line,
    point_histogram,
    small_chunk_cache,
    summary_columns_of,
    summary_frame,
    summary_frame_of,
    surfaces_from_cf,
    surfaces_to_cf,
    write_csv,
)
from .kernel import KERNEL
from .plan import BLOCK_SIZE
from .statistics import capture_speed, relative_coefficients
from .summary import (
    Stacked,
    point_statistics,
    relative_to_reference,
    release_memory,
    replicate_statistics,
)

__all__ = ["SUMMARY_COLUMNS", "ScenarioRecord", "SimulationResult", "open_result"]

#: Provenance keys stored as JSON text in the NetCDF attributes.
_JSON_ATTRS = ("scenario", "versions")

#: The summary columns the capture-speed estimator reads (the sweep axes, the
#: counts and fractions, and for QMC the standard error and replicates).
CAPTURE_COLUMNS = (
    *DIMS,
    "n_impacts",
    "capture_fraction",
    "capture_se",
    "replicates",
)

#: Sweeps of at least this many points give the freed temporaries of their
#: statistics and of writing results.nc back to the system
#: (``summary.release_memory``).
TRIM_POINTS = 2**16

#: Rows of the summary a notebook shows (the rest stay in ``.summary``).
HTML_ROWS = 12


def versions() -> dict[str, str]:
    """Versions of Python and the packages that determine the numbers (read once
    per process: reading package metadata costs ~25 ms)."""
    return dict(_versions())


@functools.lru_cache(maxsize=1)
def _versions() -> tuple:
    out = {"python": platform.python_version()}
    for pkg in ("microimpact", "numpy", "scipy", "pandas", "xarray", "netCDF4"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "not installed"
    return tuple(out.items())


# ---------------------------------------------------------------- scenario record
@dataclass(frozen=True)
class SurfaceRecord:
    """A surface of a saved result: its name, smoothness, whether it is areal (3-D)
    and its stored description."""

    name: str
    smooth: bool
    info: dict = field(default_factory=dict, compare=False)
    areal: bool = False

    def describe(self) -> dict:
        return dict(self.info)


@dataclass(frozen=True)
class ScenarioRecord:
    """What a saved result knows of its scenario (read from ``results.nc``).

    It has the attributes the outputs use (the same names as
    :class:`~microimpact.scenario.scenario.Scenario`), not the model objects: a result
    loaded with :func:`open_result` can be summarised, plotted and reported, not re-run.
    """

    name: str
    description: str
    confidence: float
    reference_angle_deg: float | None
    capture_quantiles: tuple
    speeds_m_s: tuple
    angles_deg: tuple
    surfaces: tuple
    speed_spread: float = 0.0
    samples: int | None = None
    precision: dict | None = None
    sampling: str = "mc"
    shadowing: str = "reject"
    seed: int | None = None
    source: str | None = None
    info: dict = field(default_factory=dict, compare=False, repr=False)

    def describe(self) -> dict:
        return dict(self.info)


def _record_of(ds) -> ScenarioRecord:
    attrs = ds.attrs
    info = restore_nonfinite(json.loads(attrs.get("scenario", "{}") or "{}"))
    smooth = (
        ds["surface_is_smooth"].values.astype(bool)
        if "surface_is_smooth" in ds
        else np.zeros(ds.sizes["surface"], dtype=bool)
    )
    areal = (
        ds["surface_is_areal"].values.astype(bool)
        if "surface_is_areal" in ds
        else np.zeros(ds.sizes["surface"], dtype=bool)
    )
    by_name = {
        s.get("name"): s for s in info.get("surfaces", []) if isinstance(s, dict)
    }
    surfaces = tuple(
        SurfaceRecord(str(n), bool(sm), by_name.get(str(n), {"name": str(n)}), bool(ar))
        for n, sm, ar in zip(ds["surface"].values, smooth, areal, strict=True)
    )
    ref = attrs.get("reference_angle_deg", info.get("reference_angle_deg"))
    ref = None if ref is None or (isinstance(ref, float) and math.isnan(ref)) else ref
    quantiles = np.atleast_1d(
        attrs.get("capture_quantiles", info.get("capture_quantiles", [0.5]))
    )
    return ScenarioRecord(
        name=str(info.get("name") or attrs.get("scenario_name") or "result"),
        description=str(info.get("description") or ""),
        confidence=float(attrs.get("confidence", info.get("confidence", 0.95))),
        reference_angle_deg=None if ref is None else float(ref),
        capture_quantiles=tuple(float(q) for q in quantiles),
        speeds_m_s=tuple(float(v) for v in ds["speed_m_s"].values),
        angles_deg=tuple(float(v) for v in ds["angle_deg"].values),
        surfaces=surfaces,
        speed_spread=float(info.get("speed_spread") or 0.0),
        samples=info.get("samples"),
        precision=info.get("precision"),
        sampling=str(info.get("sampling", attrs.get("sampling", "mc"))),
        shadowing=str(info.get("shadowing", attrs.get("shadowing", "reject"))),
        seed=info.get("seed"),
        source=info.get("source"),
        info=info,
    )


# ---------------------------------------------------------------- the result
class _RowAccumulators(Mapping):
    """``point -> PointAccumulator``, each built on access from the rows of a
    :class:`~.summary.Stacked` (a sweep of 10^4 points builds none unless asked)."""

    def __init__(self, stacked):
        self._stacked = stacked

    def __getitem__(self, point):
        if not isinstance(point, int | np.integer) or not 0 <= point < len(self):
            raise KeyError(point)
        return self._stacked.accumulator(int(point))

    def __iter__(self):
        return iter(range(len(self._stacked)))

    def __len__(self):
        return len(self._stacked)

    def __repr__(self):
        return f"<{len(self)} accumulators>"


def _stored(deferred: _Deferred):
    return _storable(deferred.value())


def _storable(value):
    """A provenance value as a NetCDF attribute (str, number or number array)."""
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, int | float | str | np.integer | np.floating):
        return value
    if isinstance(value, list | tuple) and all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in value
    ):
        return np.asarray(value, dtype=float)
    return json_dumps(value, keep_nonfinite=True)


class _Deferred:
    """A value computed on first use, once: the scenario's description of a
    short run, whose quadratures (~20 ms for a truncated distribution) a
    calibration's model run or a design row would pay without ever reading its
    provenance (issue 31). Pickled as its value."""

    __slots__ = ("_fn", "_value")

    def __init__(self, fn):
        self._fn, self._value = fn, None

    def value(self):
        if self._fn is not None:
            self._value, self._fn = self._fn(), None
        return self._value

    def __reduce__(self):
        return (_computed, (self.value(),))


def _computed(value) -> _Deferred:
    out = _Deferred(None)
    out._value = value
    return out


def _resolve(mapping: dict | None) -> dict | None:
    """`mapping` with its deferred values computed, in place (keys keep their
    order)."""
    if mapping is not None:
        for key, value in list(mapping.items()):
            if isinstance(value, _Deferred):
                mapping[key] = value.value()
    return mapping


class SimulationResult:
    """Everything a run produced: the canonical Dataset and what derives from it.

    Attributes
    ----------
    dataset : xarray.Dataset
        The canonical result (CF-1.10): per-point statistics on the sweep grid
        (``surface`` x ``speed_m_s`` x ``angle_deg``), the histograms of e_m and
        mu_m, the accumulator state and the provenance in its attributes.
    scenario : Scenario or ScenarioRecord
        The scenario (a :class:`ScenarioRecord` for a result read from a file).
    accumulators : Mapping or None
        ``point index -> pooled PointAccumulator`` for a fresh run (built on
        access); None for a result read from a file.
    """

    def __init__(self, dataset, scenario=None, accumulators=None, provenance=None):
        self._dataset = dataset
        self._build = None
        self.scenario = _record_of(dataset) if scenario is None else scenario
        self.accumulators = accumulators
        self._provenance = provenance
        self._summary = None
        self._attrs = None
        self._capture = {}  # quantile -> capture-speed table (see capture_speed)
        self._statistics = None  # a fresh run's columns, computed on first use
        self._columns_value = None
        self._subsets = {}  # see _subset_statistics

    @property
    def _columns(self) -> dict:
        """A fresh run's per-point statistics (computed on first use)."""
        if self._columns_value is None:
            statistics, self._statistics = self._statistics, None
            with stage(f"statistics of {self._grid.size:,} sweep points"):
                self._columns_value = statistics()
            if self._grid.size >= TRIM_POINTS:  # the slices' temporaries
                release_memory()
        return self._columns_value

    @property
    def dataset(self):
        """The canonical Dataset (built on first access for a fresh run: xarray,
        and with it dask where installed, is imported only by what needs it)."""
        if self._dataset is None:
            _resolve(self._attrs)  # the attributes the builder was given
            self._dataset = self._build(self._columns)
            self._build = None
        return self._dataset

    @dataset.setter
    def dataset(self, value):
        self._dataset = value
        self._build = None
        self._capture = {}

    def _attr(self, key, default=None):
        """A global attribute of the Dataset, without building it."""
        attrs = self._attrs if self._dataset is None else self._dataset.attrs
        value = attrs.get(key, default)
        if isinstance(value, _Deferred):
            value = attrs[key] = value.value()
        return value

    # -------------------------------------------------------------- builders
    @classmethod
    def from_accumulators(
        cls,
        scenario,
        plan,
        totals,
        *,
        elapsed,
        samples=None,
        workers=1,
        backend="process",
        provenance=None,
    ) -> SimulationResult:
        """Build the result of a run from its accumulators.

        Parameters
        ----------
        scenario : Scenario
        plan : Plan
            The run's plan (points, tables, seed entropy).
        totals : dict
            ``(point, replicate) -> PointAccumulator``.
        elapsed : float
            Wall time [s].
        samples, workers, backend :
            As passed to :func:`~microimpact.run` (recorded in the provenance).
        provenance : dict, optional
            Further provenance (e.g. resumed blocks), merged in.
        """
        R = plan.replicates
        rows = Stacked.of(totals[(sp.index, r)] for sp in plan.points for r in range(R))
        return cls.from_stacked(
            scenario,
            plan,
            rows,
            elapsed=elapsed,
            samples=samples,
            workers=workers,
            backend=backend,
            provenance=provenance,
        )

    @staticmethod
    def prepare(scenario, *, describe=True) -> dict:
        """What the result takes from the scenario alone (its description, the
        input quantile functions, the grid): :func:`~microimpact.run` computes it
        while the workers run and passes it to :meth:`from_stacked`. `describe`
        False: the description is computed when the result's provenance, one of
        its attributes or its Dataset is first read (a short run, prepared in
        the caller)."""
        return {
            "description": (
                scenario.describe() if describe else _Deferred(scenario.describe)
            ),
            "inputs": _input_quantiles(scenario),
            "smooth": [_is_smooth(s) for s in scenario.surfaces],
            "areal": [is_areal_surface(s) for s in scenario.surfaces],
            "grid": SweepGrid.from_scenario(scenario),
            "versions": versions(),
        }

    @classmethod
    def from_stacked(
        cls,
        scenario,
        plan,
        stacked,
        *,
        elapsed,
        samples=None,
        workers=1,
        backend="process",
        provenance=None,
        prepared=None,
    ) -> SimulationResult:
        """Build the result of a run from the accumulators of every (point,
        replicate) as the rows of a :class:`~.summary.Stacked` (point-major: row
        ``point * replicates + replicate``); otherwise as :meth:`from_accumulators`.
        `prepared` is :meth:`prepare`'s value for `scenario` (computed if None)."""
        with stage(f"statistics of {len(plan.points):,} sweep points"):
            return cls._from_stacked(
                scenario,
                plan,
                stacked,
                elapsed=elapsed,
                samples=samples,
                workers=workers,
                backend=backend,
                provenance=provenance,
                prepared=prepared,
            )

    @classmethod
    def _from_stacked(
        cls,
        scenario,
        plan,
        stacked,
        *,
        elapsed,
        samples,
        workers,
        backend,
        provenance,
        prepared,
    ) -> SimulationResult:
        if prepared is None:
            prepared = cls.prepare(scenario)
        grid = prepared["grid"]
        R = plan.replicates
        confidence = float(scenario.confidence)
        if R > 1:
            pooled = []
            for p in range(len(plan.points)):
                acc = stacked.accumulator(p * R)
                for r in range(1, R):
                    acc = acc.merge(stacked.accumulator(p * R + r))
                pooled.append(acc)
            pooled_rows = Stacked.of(pooled)
            accumulators = dict(enumerate(pooled))
        else:
            pooled_rows = stacked
            accumulators = _RowAccumulators(stacked)
        shadowed = None
        if plan.shadowing != "none":
            # the facets removed ('reject') or re-weighted ('weighted') were never
            # sampled: report their exact probability from the table (1 where no
            # facet can be reached: then every sample was counted as shadowed)
            *_, table, keys = plan.point_columns()
            mass = np.array([plan.angle_tables(*key).shadowed_mass for key in keys])
            shadowed = mass[table]
        ref = scenario.reference_angle_deg
        # the statistics are computed on first use (the summary, the files): by
        # then the run's plan and driver state are gone, so a sweep of 10^6 points
        # never holds them and its ~60 columns at once
        statistics = functools.partial(
            _statistics,
            pooled_rows,
            stacked if R > 1 else None,
            R,
            confidence,
            shadowed,
            grid,
            ref,
        )
        kernel = getattr(plan, "kernel", None)
        if kernel is None:
            kernel = KERNEL
        vers = prepared["versions"]
        prov = {
            "scenario": prepared["description"],
            "seed_entropy": str(plan.entropy),
            "versions": vers,
            "samples_per_point": None if samples is None else int(samples),
            "sampling": plan.sampling,
            "replicates": plan.replicates,
            "shadowing": plan.shadowing,
            "block_size": BLOCK_SIZE,
            "table_size": int(plan.diameter.size),
            "kernel": kernel,
            "workers": workers,
            "backend": backend,
            "elapsed_s": elapsed,
            "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            **(provenance or {}),
        }
        attrs = {
            "title": f"microimpact Monte Carlo results: {scenario.name}",
            "history": history_line(f"Monte Carlo run of scenario {scenario.name!r}"),
            "source": f"microimpact {vers.get('microimpact', '?')}",
            "references": "Li, Dunn & Brach (2000), Aerosol Sci. Technol. 33:376-386",
            "scenario_name": scenario.name,
            "confidence": confidence,
            "capture_quantiles": np.asarray(scenario.capture_quantiles, dtype=float),
            "e_edges": f"{E_EDGES[0]}:{E_EDGES[-1]}:{E_EDGES.size - 1} bins",
            "mu_edges": f"{MU_EDGES[0]}:{MU_EDGES[-1]}:{MU_EDGES.size - 1} bins",
            "lateral_edges": f"{LATERAL_EDGES[0]}:{LATERAL_EDGES[-1]}:"
            f"{LATERAL_EDGES.size - 1} bins",
        }
        if ref is not None:
            attrs["reference_angle_deg"] = float(ref)
        for key, value in prov.items():
            if isinstance(value, _Deferred):  # computed with the provenance
                attrs[key] = _Deferred(functools.partial(_stored, value))
            elif value is not None:
                attrs[key] = _storable(value)
        out = cls.__new__(cls)
        cls.__init__(out, None, scenario, accumulators, prov)
        out._attrs = attrs
        out._build = functools.partial(
            _build_dataset,
            grid,
            pooled_rows,
            attrs=attrs,
            inputs=prepared["inputs"],
            smooth=prepared["smooth"],
            areal=prepared.get("areal"),
        )
        out._grid, out._statistics = grid, statistics
        return out

    @classmethod
    def from_dataset(cls, dataset, scenario=None) -> SimulationResult:
        """A result from its Dataset (e.g. ``xarray.open_dataset("results.nc")``)."""
        if "capture_fraction" not in dataset:
            raise ValueError(
                "`dataset` is not a microimpact result (no `capture_fraction`)."
            )
        # either form of the surfaces (names as the coordinate, or CF's index with
        # the names in `surface_name`) gives the names as the coordinate
        return cls(_with_lateral(surfaces_from_cf(dataset)), scenario)

    # -------------------------------------------------------------- metadata
    @property
    def provenance(self) -> dict:
        """Scenario description, versions, seed entropy, sample counts, backend."""
        if self._provenance is not None:
            return _resolve(self._provenance)
        out = {}
        skip = {
            "title",
            "institution",
            "history",
            "source",
            "references",
            "Conventions",
        }
        for key, value in self.dataset.attrs.items():
            if key in skip:
                continue
            if key in _JSON_ATTRS and isinstance(value, str):
                value = restore_nonfinite(json.loads(value))
            elif isinstance(value, np.ndarray):
                value = value.tolist()
            elif isinstance(value, np.generic):
                value = value.item()
            out[key] = value
        self._provenance = out
        return out

    @property
    def seed_entropy(self) -> int:
        """Root entropy of the run; pass it as ``seed`` to reproduce it exactly."""
        return int(self._attr("seed_entropy"))

    @property
    def elapsed_s(self) -> float:
        """Wall time of the run [s]."""
        return float(self._attr("elapsed_s", math.nan))

    @property
    def name(self) -> str:
        return self.scenario.name

    @property
    def confidence(self) -> float:
        """Confidence level of every interval."""
        return float(self._attr("confidence", self.scenario.confidence))

    @property
    def grid(self) -> SweepGrid:
        """The sweep grid (coordinates and point order)."""
        ds = self.dataset
        return SweepGrid(
            tuple(str(s) for s in ds["surface"].values),
            tuple(float(v) for v in ds["speed_m_s"].values),
            tuple(float(v) for v in ds["angle_deg"].values),
        )

    @property
    def summary(self):
        """One row per sweep point (grid order): derived from :attr:`dataset`."""
        if self._summary is None:
            if self._dataset is None:  # a fresh run: from its columns
                df = summary_frame_of(self._grid, self._columns)
            else:
                df = summary_frame(self.dataset)
            df.attrs["confidence"] = self.confidence
            self._summary = df
        return self._summary

    def summary_columns(self, names) -> dict[str, np.ndarray]:
        """Columns `names` of :attr:`summary` as arrays, with the sweep axes
        (``surface``, ``speed_m_s``, ``angle_deg``): the summary's values, rows
        and dtypes. A fresh run whose summary is not made yet computes only the
        statistics these columns need, without the table (a design row of a
        sensitivity study or a calibration's model run reads a few columns:
        issue 31). Raises KeyError for a column the summary does not have."""
        if isinstance(names, str):
            raise TypeError(
                f"`names` is a list of summary columns, e.g. [{names!r}]; got the "
                f"string {names!r}"
            )
        names = list(names)
        fresh = self._statistics is not None and self._columns_value is None
        if self._summary is None and fresh:
            columns = self._subset_statistics(frozenset(names))
            data = summary_columns_of(self._grid, columns)
        else:
            frame = self.summary
            data = {c: frame[c].to_numpy() for c in frame.columns}
        axes = [a for a in ("surface", "speed_m_s", "angle_deg") if a in data]
        missing = [n for n in names if n not in data]
        if missing:
            have = self.summary.columns if fresh else list(data)
            raise KeyError(
                f"not summary columns: {', '.join(map(str, missing))}; the summary "
                f"has {', '.join(map(str, have))}"
            )
        return {c: data[c] for c in dict.fromkeys([*axes, *names])}

    def _subset_statistics(self, want: frozenset) -> dict:
        """The statistics of a fresh run that columns `want` need (kept: each
        set is computed once)."""
        got = self._subsets.get(want)
        if got is None:
            got = self._subsets[want] = self._statistics(want=set(want))
        return got

    def _repr_html_(self) -> str:
        """The repr line, then the first rows of the summary (notebooks)."""
        cols = [
            c
            for c in (
                "surface",
                "speed_m_s",
                "angle_deg",
                "n",
                "capture_fraction",
                "capture_ci_low",
                "capture_ci_high",
                "e_rebound_mean",
                "mu_mean",
            )
            if c in self.summary
        ]
        table = self.summary[cols]
        more = len(table) - HTML_ROWS
        note = f"<p>… {more} more rows in <code>.summary</code></p>" if more > 0 else ""
        return (
            f"<p>{html.escape(repr(self))}</p>"
            + table.head(HTML_ROWS).to_html(index=False, float_format="{:.4g}".format)
            + note
        )

    def __repr__(self) -> str:
        ds = self.dataset
        n = ds["n"].values
        shape = " x ".join(f"{ds.sizes[d]} {d}" for d in ds["capture_fraction"].dims)
        return (
            f"<SimulationResult {self.name!r}: {shape} points, "
            f"{int(n.min()):,}-{int(n.max()):,} samples per point, "
            f"seed entropy {self.seed_entropy}>"
        )

    # -------------------------------------------------------------- derived
    def capture_speed(self, quantile: float | None = None, *, estimator: str = "auto"):
        """Speed at a capture fraction (default: the scenario's quantiles), with its
        interval; see :func:`microimpact.engine.statistics.capture_speed`.

        `estimator` (``"auto"``, ``"probit"`` or ``"monotone"``) chooses the
        estimator as there (docs/capture-speed.md). Each (quantile, estimator)
        table is estimated once per result and kept (a sweep of 1000 angles has
        1000 curves to fit; the CSV, the terminal, the report and the capture
        figure all ask for it); a copy is returned."""
        # deferred: pandas loads only where a table is made (import time)
        import pandas as pd

        check_choice(estimator, "estimator", ESTIMATORS)
        qs = self.scenario.capture_quantiles if quantile is None else (quantile,)
        # the estimator's columns only: it copies and groups what it is given
        # (the whole table cost 10x the memory: ~450 MB at 10^6 points)
        summary = self.summary
        curves = summary[[c for c in CAPTURE_COLUMNS if c in summary]]
        tables = []
        for q in qs:
            key = (float(q), estimator)
            if key not in self._capture:
                self._capture[key] = capture_speed(
                    curves, q, confidence=self.confidence, estimator=estimator
                )
            tables.append(self._capture[key])
        return pd.concat(tables, ignore_index=True)

    def relative(self, reference_angle_deg: float = 85.0):
        """The paper's relative coefficients against `reference_angle_deg`."""
        return relative_coefficients(self.summary, reference_angle_deg)

    def histogram(self, point: int, name: str = "e"):
        """``(counts, edges)`` of e_m, mu_m or the folded lateral angle [deg]
        (`name` ``"e"``, ``"mu"`` or ``"lateral"``) over rebounds at sweep point
        `point` (in-range bins only; the under/overflow counts are in the dataset).
        """
        edges = {"e": E_EDGES, "mu": MU_EDGES, "lateral": LATERAL_EDGES}
        if name not in edges:
            raise ValueError(f"`name` must be 'e', 'mu' or 'lateral'; got {name!r}.")
        if f"{name}_bin" not in self.dataset.dims:
            raise ValueError(
                f"this result has no {name} histogram (written by an older version)"
            )
        index = self.grid.unravel(int(point))
        counts = point_histogram(self.dataset, index, name)
        return counts, edges[name]

    # -------------------------------------------------------------- files
    def to_netcdf(self, path) -> Path:
        """Write the Dataset to `path` (NetCDF-4, compressed), atomically."""
        ds = surfaces_to_cf(self.dataset)  # CF: a numeric index, names aside
        with small_chunk_cache():  # not every variable held until the file closes
            out = atomic_write(
                Path(path),
                lambda t: ds.to_netcdf(t, engine="netcdf4", encoding=encoding(ds)),
            )
        if ds["capture_fraction"].size >= TRIM_POINTS:  # the writer's freed buffers
            release_memory()
        return out

    def to_csv(self, path) -> Path:
        """Write the summary table to `path`, atomically."""
        return atomic_write(Path(path), self.write_summary)

    def write_summary(self, path) -> None:
        """Write the summary table to `path` (not atomically: :meth:`to_csv` is),
        exactly as ``self.summary.to_csv(path, index=False)`` would, in chunks of
        rows from the columns (:func:`~.dataset.write_csv`; a fresh run's summary
        table is not built for it)."""
        if self._summary is None and self._dataset is None:
            columns = summary_columns_of(self._grid, self._columns)
        else:
            columns = self.summary
        write_csv(path, columns)

    def to_files(self, out_dir) -> dict[str, Path]:
        """Write ``summary.csv`` and ``results.nc`` (each atomically) to `out_dir`."""
        out_dir = Path(out_dir)
        return {
            "summary": self.to_csv(out_dir / "summary.csv"),
            "results": self.to_netcdf(out_dir / "results.nc"),
        }


def _statistics(
    rows, replicates, R, confidence, shadowed, grid, ref, want=None
) -> dict:
    """The per-point columns of a fresh run (see :meth:`SimulationResult.from_stacked`):
    the statistics of the pooled `rows` (QMC: their intervals from the `replicates`
    rows), the shadowed fraction of the tables, the relative coefficients. `want`:
    a set of columns; those computed only where wanted are then left out where
    none of theirs is (:func:`~.summary.point_statistics`)."""
    if R > 1:
        columns = replicate_statistics(rows, replicates, R, confidence)
    else:
        columns = point_statistics(rows, confidence, want=want)
    if shadowed is not None:
        columns["shadowed_fraction"] = shadowed
    relative = ("e_relative", "e_relative_se", "mu_relative", "mu_relative_se")
    if want is not None and want.isdisjoint(relative):
        return columns
    if ref is not None and np.isclose(grid.angles_deg, ref).any():
        for stat, se, name in (
            ("e_rebound_mean", "e_rebound_se", "e_relative"),
            ("mu_mean", "mu_se", "mu_relative"),
        ):
            rel, rel_se = relative_to_reference(
                grid.reshape(columns[stat]),
                grid.reshape(columns[se]),
                grid.angles_deg,
                ref,
            )
            columns[name] = rel.ravel()
            columns[f"{name}_se"] = rel_se.ravel()
    return columns


def _build_dataset(grid, rows, columns, **kwargs):
    """:func:`~.dataset.build_dataset` with the columns given last (they are
    computed on first use)."""
    return build_dataset(grid, columns, rows, **kwargs)


def _with_lateral(ds):
    """`ds`, with the lateral and heavy-tail summary variables as NaN if it was
    written before they existed (its summary then has those columns, all NaN)."""
    missing = [v for v in (*LATERAL_VARIABLES, *TAIL_VARIABLES) if v not in ds]
    if not missing or "capture_fraction" not in ds:
        return ds
    ds = ds.copy()
    like = ds["capture_fraction"]
    for name in missing:
        units, long_name = VARIABLES[name]
        ds[name] = (
            like.dims,
            np.full(like.shape, np.nan),
            {
                "units": units,
                "long_name": long_name,
                "comment": "not recorded: written by an older microimpact",
            },
        )
    return ds


def dataset_surface_flags(result, variable: str) -> dict[str, bool] | None:
    """``{surface name: flag}`` from the result Dataset's per-surface boolean
    `variable` (``surface_is_smooth``, ``surface_is_areal``), or None when the
    result has no Dataset or the Dataset not that variable (an older file)."""
    ds = getattr(result, "dataset", None)
    if ds is None or variable not in ds:
        return None
    return {
        str(n): bool(v)
        for n, v in zip(ds["surface"].values, ds[variable].values, strict=True)
    }


def is_areal_surface(surface) -> bool:
    """An areal (3-D) surface, recognised by structure: its angle distribution is
    a joint facet-angle one (``is_areal``)."""
    return bool(getattr(getattr(surface, "angles", None), "is_areal", False))


def _is_smooth(surface) -> bool:
    """Molecularly smooth, recognised by structure: no angle distribution, or one
    whose only atom is exactly 0."""
    angles = getattr(surface, "angles", None)
    if angles is None:
        return True
    flag = getattr(angles, "is_smooth", None)
    if flag is not None:
        return bool(flag)
    try:
        lo, hi = angles.support()
    except (AttributeError, TypeError, ValueError):
        return False
    return lo == 0.0 and hi == 0.0


def _input_quantiles(scenario) -> dict:
    """The input distributions' quantile functions at :data:`INPUT_QUANTILES`
    mid-probabilities (for the input figures of a saved result)."""
    q = (np.arange(INPUT_QUANTILES) + 0.5) / INPUT_QUANTILES
    out = {}
    try:
        out["diameter_quantile"] = np.asarray(scenario.particles.ppf(q), dtype=float)
    except (AttributeError, TypeError, ValueError):
        pass
    rows = []
    for s in scenario.surfaces:
        angles = getattr(s, "angles", None)
        try:
            rows.append(
                np.full(q.size, np.nan)
                if angles is None or _is_smooth(s)
                else np.asarray(angles.ppf(q), dtype=float)
            )
        except (AttributeError, TypeError, ValueError):
            rows.append(np.full(q.size, np.nan))
    out["roughness_angle_quantile"] = np.stack(rows)
    return out


def open_result(path) -> SimulationResult:
    """Load a saved result (``results.nc``, or a run folder holding one).

    The result has the full behaviour of a fresh one: summary, capture speed,
    relative coefficients, histograms, figures and report.

    Raises
    ------
    InputError
        If the file is missing or is not a microimpact result.
    """
    # deferred: xarray loads only where a dataset is read (import time)
    import xarray as xr

    path = Path(path)
    if path.is_dir():
        path = path / "results.nc"
    if not path.is_file():
        raise InputError(
            "no results file here (give results.nc or the folder of a run)",
            source=path,
        )
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            ds = surfaces_from_cf(ds.load())  # the names as the coordinate again
    except (OSError, ValueError) as exc:
        raise InputError(f"not a readable NetCDF file ({exc})", source=path) from None
    if "capture_fraction" not in ds or "seed_entropy" not in ds.attrs:
        raise InputError(
            "not a microimpact results file (no capture_fraction or seed_entropy)",
            source=path,
        )
    return SimulationResult.from_dataset(ds)
