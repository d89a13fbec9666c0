"""The result of a run: summary table, histograms, provenance, and output files."""

from __future__ import annotations

import datetime as _dt
import json
import platform
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd

from .._files import atomic_write
from .accumulators import E_EDGES, MU_EDGES, PointAccumulator
from .kernel import KERNEL
from .plan import BLOCK_SIZE
from .statistics import (
    capture_speed,
    point_row,
    relative_coefficients,
    replicate_row,
)

#: Columns that lead the summary table, in this order (a public contract).
SUMMARY_COLUMNS = (
    "surface",
    "speed_m_s",
    "angle_deg",
    "n",
    "capture_fraction",
    "capture_ci_low",
    "capture_ci_high",
    "e_mean",
    "e_ci_low",
    "e_ci_high",
    "e_rebound_mean",
    "mu_mean",
    "mu_ci_low",
    "mu_ci_high",
    "shadowed_fraction",
    "reimpact_fraction",
)


def versions() -> dict[str, str]:
    """Versions of Python and the packages that determine the numbers."""
    out = {"python": platform.python_version()}
    for pkg in ("microimpact", "numpy", "scipy", "pandas", "xarray", "netCDF4"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "not installed"
    return out


@dataclass
class SimulationResult:
    """Everything a run produced.

    Attributes
    ----------
    scenario : Scenario
    summary : pandas.DataFrame
        One row per sweep point; see :data:`SUMMARY_COLUMNS` and ``docs/engine.md``.
    accumulators : dict
        ``point index -> pooled PointAccumulator`` (histograms included).
    seed_entropy : int
        Root entropy of the run; pass it as ``seed`` to reproduce the run exactly.
    elapsed_s : float
        Wall time of the run [s].
    provenance : dict
        Scenario description, versions, seed entropy, sample counts, backend.
    """

    scenario: object
    summary: pd.DataFrame
    accumulators: dict
    seed_entropy: int
    elapsed_s: float
    provenance: dict = field(default_factory=dict)
    _dataset: object = field(default=None, repr=False)

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
    ):
        rows, pooled = [], {}
        for sp in plan.points:
            accs = [totals[(sp.index, r)] for r in range(plan.replicates)]
            if plan.replicates > 1:
                row = replicate_row(accs, scenario.confidence)
            else:
                row = point_row(accs[0], scenario.confidence)
            acc = accs[0]
            for a in accs[1:]:
                acc = acc.merge(a)
            pooled[sp.index] = acc
            if plan.shadowing != "none":
                # the facets removed ('reject') or re-weighted ('weighted') were
                # never sampled: report their exact probability from the table
                row["shadowed_fraction"] = plan.angle_tables(
                    sp.surface, sp.angle_deg
                ).shadowed_mass
            rows.append(
                {
                    "surface": sp.surface_name,
                    "speed_m_s": sp.speed,
                    "angle_deg": sp.angle_deg,
                    **row,
                }
            )
        summary = pd.DataFrame(rows)
        ref = scenario.reference_angle_deg
        if ref is not None and np.isclose(summary["angle_deg"], ref).any():
            summary = relative_coefficients(summary, ref)
        lead = [c for c in SUMMARY_COLUMNS if c in summary]
        summary = summary[lead + [c for c in summary.columns if c not in lead]]
        provenance = {
            "scenario": scenario.describe(),
            "seed_entropy": str(plan.entropy),
            "versions": versions(),
            "samples_per_point": None if samples is None else int(samples),
            "sampling": plan.sampling,
            "replicates": plan.replicates,
            "shadowing": plan.shadowing,
            "block_size": BLOCK_SIZE,
            "table_size": int(plan.diameter.size),
            "kernel": KERNEL,
            "workers": workers,
            "backend": backend,
            "elapsed_s": elapsed,
            "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            **(provenance or {}),
        }
        return cls(scenario, summary, pooled, plan.entropy, elapsed, provenance)

    # ------------------------------------------------------------------ derived
    def capture_speed(self, quantile: float | None = None) -> pd.DataFrame:
        """Speed at a capture fraction (default: the scenario's quantiles)."""
        qs = self.scenario.capture_quantiles if quantile is None else (quantile,)
        return pd.concat(
            [capture_speed(self.summary, q) for q in qs], ignore_index=True
        )

    def relative(self, reference_angle_deg: float = 85.0) -> pd.DataFrame:
        """The paper's relative coefficients against `reference_angle_deg`."""
        return relative_coefficients(self.summary, reference_angle_deg)

    def histogram(self, point: int, name: str = "e"):
        """``(counts, edges)`` of e_m or mu_m over rebounds at sweep point `point`
        (in-range bins only; the under/overflow counts are in the dataset)."""
        acc: PointAccumulator = self.accumulators[point]
        if name == "e":
            return acc.e_hist[1:-1], E_EDGES
        if name == "mu":
            return acc.mu_hist[1:-1], MU_EDGES
        raise ValueError(f"`name` must be 'e' or 'mu'; got {name!r}.")

    # ------------------------------------------------------------------ dataset
    @property
    def dataset(self):
        """xarray Dataset on a (surface, speed, angle) grid with the histograms and
        the provenance in its attributes."""
        if self._dataset is None:
            self._dataset = self._build_dataset()
        return self._dataset

    def _build_dataset(self):
        import xarray as xr

        sc = self.scenario
        surfaces = [s.name for s in sc.surfaces]
        speeds = list(sc.speeds_m_s)
        angles = list(sc.angles_deg)
        shape = (len(surfaces), len(speeds), len(angles))
        dims = ("surface", "speed_m_s", "angle_deg")
        data_vars = {}
        numeric = [
            c
            for c in self.summary.columns
            if c not in dims and pd.api.types.is_numeric_dtype(self.summary[c])
        ]
        for c in numeric:
            data_vars[c] = (dims, self.summary[c].to_numpy(dtype=float).reshape(shape))
        e_h = np.stack([self.accumulators[i].e_hist for i in range(len(self.summary))])
        mu_h = np.stack(
            [self.accumulators[i].mu_hist for i in range(len(self.summary))]
        )
        data_vars["e_hist"] = ((*dims, "e_bin"), e_h[:, 1:-1].reshape(*shape, -1))
        data_vars["mu_hist"] = ((*dims, "mu_bin"), mu_h[:, 1:-1].reshape(*shape, -1))
        for nm, h in (("e", e_h), ("mu", mu_h)):
            data_vars[f"{nm}_hist_underflow"] = (dims, h[:, 0].reshape(shape))
            data_vars[f"{nm}_hist_overflow"] = (dims, h[:, -1].reshape(shape))
        coords = {
            "surface": surfaces,
            "speed_m_s": (
                "speed_m_s",
                speeds,
                {"units": "m s-1", "long_name": "nominal incident speed"},
            ),
            "angle_deg": (
                "angle_deg",
                angles,
                {
                    "units": "degree",
                    "long_name": "apparent incidence angle from the plane",
                },
            ),
            "e_bin": (
                "e_bin",
                0.5 * (E_EDGES[1:] + E_EDGES[:-1]),
                {"long_name": "e_m bin centre"},
            ),
            "mu_bin": (
                "mu_bin",
                0.5 * (MU_EDGES[1:] + MU_EDGES[:-1]),
                {"long_name": "mu_m bin centre"},
            ),
        }
        ds = xr.Dataset(data_vars, coords=coords)
        ds["e_hist"].attrs["long_name"] = "histogram of e_m over rebounds"
        ds["mu_hist"].attrs["long_name"] = "histogram of mu_m over rebounds"
        p = self.provenance
        ds.attrs.update(
            {
                "title": f"microimpact Monte Carlo results: {sc.name}",
                "references": "Li, Dunn & Brach (2000), "
                "Aerosol Sci. Technol. 33:376-386",
                "scenario": json.dumps(p["scenario"], default=str),
                "seed_entropy": p["seed_entropy"],
                "versions": json.dumps(p["versions"]),
                "sampling": p["sampling"],
                "replicates": p["replicates"],
                "shadowing": p["shadowing"],
                "block_size": p["block_size"],
                "table_size": p["table_size"],
                "kernel": p["kernel"],
                "elapsed_s": p["elapsed_s"],
                "created": p["created"],
                "e_edges": f"{E_EDGES[0]}:{E_EDGES[-1]}:{E_EDGES.size - 1} bins",
                "mu_edges": f"{MU_EDGES[0]}:{MU_EDGES[-1]}:{MU_EDGES.size - 1} bins",
            }
        )
        return ds

    # ------------------------------------------------------------------ files
    def to_files(self, out_dir) -> dict[str, Path]:
        """Write ``summary.csv`` and ``results.nc`` (each atomically) to `out_dir`."""
        out_dir = Path(out_dir)
        csv = atomic_write(
            out_dir / "summary.csv", lambda t: self.summary.to_csv(t, index=False)
        )
        nc = atomic_write(
            out_dir / "results.nc",
            lambda t: self.dataset.to_netcdf(
                t,
                engine="netcdf4",
                encoding={
                    v: {"zlib": True, "complevel": 4} for v in self.dataset.data_vars
                },
            ),
        )
        return {"summary": csv, "results": nc}
