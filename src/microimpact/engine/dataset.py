"""The canonical result: one CF-1.10 :class:`xarray.Dataset` built from accumulators.

Dimensions are those of the sweep grid (:class:`microimpact.scenario.grid.SweepGrid`:
``surface`` x ``speed_m_s`` x ``angle_deg``) plus the histogram bins. Every variable
carries ``units`` and ``long_name``; counts are integers; the global attributes hold
the provenance. ``summary.csv`` is derived from this Dataset
(:func:`summary_frame`), never the other way round.
"""

from __future__ import annotations

import contextlib
import csv
import datetime as _dt
import math

import numpy as np

from .. import __version__
from ..scenario.grid import DIMS, SweepGrid
from .accumulators import E_EDGES, LATERAL_EDGES, MU_EDGES
from .summary import LATERAL_COLUMNS, TAIL_COLUMNS, compact_counts

#: CF conventions version the files follow.
CONVENTIONS = "CF-1.10"

#: Per-point variables: name -> (units, long_name). Dimensionless: "1".
VARIABLES: dict[str, tuple[str, str]] = {
    "n": ("1", "number of samples drawn"),
    "n_impacts": ("1", "number of samples that struck a facet"),
    "n_rebounds": ("1", "number of impacts not captured"),
    "capture_fraction": ("1", "fraction of impacts captured"),
    "capture_ci_low": ("1", "lower confidence limit of the capture fraction"),
    "capture_ci_high": ("1", "upper confidence limit of the capture fraction"),
    "capture_se": ("1", "standard error of the capture fraction"),
    "e_mean": ("1", "mean apparent restitution e_m over all impacts (captured = 0)"),
    "e_std": ("1", "standard deviation of e_m over all impacts"),
    "e_se": ("1", "standard error of e_mean"),
    "e_ci_low": ("1", "lower confidence limit of e_mean"),
    "e_ci_high": ("1", "upper confidence limit of e_mean"),
    "e_rebound_mean": ("1", "mean apparent restitution e_m over rebounds"),
    "e_rebound_std": ("1", "standard deviation of e_m over rebounds"),
    "e_rebound_se": ("1", "standard error of e_rebound_mean"),
    "e_rebound_ci_low": ("1", "lower confidence limit of e_rebound_mean"),
    "e_rebound_ci_high": ("1", "upper confidence limit of e_rebound_mean"),
    "e_skewness": ("1", "sample skewness of e_m over rebounds"),
    "mu_mean": ("1", "mean apparent impulse ratio mu_m over rebounds"),
    "mu_std": ("1", "standard deviation of mu_m over rebounds"),
    "mu_se": ("1", "standard error of mu_mean"),
    "mu_ci_low": ("1", "lower confidence limit of mu_mean"),
    "mu_ci_high": ("1", "upper confidence limit of mu_mean"),
    "mu_skewness": ("1", "sample skewness of mu_m over rebounds"),
    "shadowed_fraction": ("1", "fraction of facets the particle cannot reach"),
    "reimpact_fraction": ("1", "fraction of rebounds heading into the nominal plane"),
    "rolling_fraction": ("1", "fraction of rebounds leaving the facet rolling"),
    "e_p05": ("1", "5 % quantile of e_m over rebounds (histogram)"),
    "e_p50": ("1", "median of e_m over rebounds (histogram)"),
    "e_p95": ("1", "95 % quantile of e_m over rebounds (histogram)"),
    "mu_p05": ("1", "5 % quantile of mu_m over rebounds (histogram)"),
    "mu_p50": ("1", "median of mu_m over rebounds (histogram)"),
    "mu_p95": ("1", "95 % quantile of mu_m over rebounds (histogram)"),
    "replicates": ("1", "independent QMC scrambles behind the intervals"),
    "e_relative": ("1", "relative restitution e - e(reference angle), rebounds"),
    "e_relative_se": ("1", "standard error of e_relative"),
    "mu_relative": ("1", "relative impulse ratio mu - mu(reference angle)"),
    "mu_relative_se": ("1", "standard error of mu_relative"),
    # the folded lateral angle psi_f = atan2(V_b, |V_t|) over rebounds (0 for every
    # rebound in the plane of incidence; docs/outputs.md)
    "lateral_mean_deg": (
        "degree",
        "mean folded lateral rebound angle psi_f over rebounds",
    ),
    "lateral_std_deg": (
        "degree",
        "standard deviation of the folded lateral rebound angle over rebounds",
    ),
    "lateral_se_deg": ("degree", "standard error of lateral_mean_deg"),
    "lateral_ci_low_deg": ("degree", "lower confidence limit of lateral_mean_deg"),
    "lateral_ci_high_deg": ("degree", "upper confidence limit of lateral_mean_deg"),
    "lateral_p05_deg": (
        "degree",
        "5 % quantile of the folded lateral rebound angle (histogram)",
    ),
    "lateral_p50_deg": (
        "degree",
        "median of the folded lateral rebound angle (histogram)",
    ),
    "lateral_p95_deg": (
        "degree",
        "95 % quantile of the folded lateral rebound angle (histogram)",
    ),
    # heavy tails (docs/outputs.md): share of the squared deviations from the mean
    # held by the 0.1 % of rebounds farthest from it, and the flag of the rule
    "e_tail_share": (
        "1",
        "share of the squared deviations of e_m held by its 0.1 % farthest values",
    ),
    "mu_tail_share": (
        "1",
        "share of the squared deviations of mu_m held by its 0.1 % farthest values",
    ),
    "e_tail_shift": (
        "1",
        "mean of e_m minus its mean without the 0.1 % farthest values",
    ),
    "mu_tail_shift": (
        "1",
        "mean of mu_m minus its mean without the 0.1 % farthest values",
    ),
    "heavy_tail": (
        "1",
        "1 if e_tail_share or mu_tail_share exceeds 0.25 (the mean's spread rests "
        "on a few impacts), else 0",
    ),
}
#: The lateral summary variables (NaN in a result written before they existed).
LATERAL_VARIABLES = LATERAL_COLUMNS
#: The heavy-tail variables (NaN in a result written before they existed).
TAIL_VARIABLES = TAIL_COLUMNS
#: The state of the pooled accumulators not already in the summary (so that a saved
#: result can be merged with more samples): counts and central moment sums.
STATE: dict[str, tuple[str, str]] = {
    "n_shadowed": ("1", "number of shadowed samples"),
    "n_captured": ("1", "number of captured impacts"),
    "n_reimpact": ("1", "number of rebounds heading into the nominal plane"),
    "n_rolling": ("1", "number of rebounds leaving the facet rolling"),
    "e_m2": ("1", "sum of squared deviations of e_m over rebounds"),
    "e_m3": ("1", "sum of cubed deviations of e_m over rebounds"),
    "mu_m2": ("1", "sum of squared deviations of mu_m over rebounds"),
    "mu_m3": ("1", "sum of cubed deviations of mu_m over rebounds"),
    "lateral_m2": (
        "degree2",
        "sum of squared deviations of the folded lateral angle over rebounds",
    ),
    "lateral_m3": (
        "degree3",
        "sum of cubed deviations of the folded lateral angle over rebounds",
    ),
}
#: Integer (count) variables.
INTEGER = frozenset(
    {"n", "n_impacts", "n_rebounds", "replicates"}
    | {k for k in STATE if k.startswith("n_")}
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
#: Sweeps with at most this many histogram cells (points x bins) keep dense
#: histograms (``e_hist``, ``mu_hist``); bigger ones keep the occupied bins only, as
#: a CF contiguous ragged array (memory proportional to what is kept).
DENSE_HISTOGRAM_CELLS = 2**22
#: Probabilities at which the input distributions' quantile functions are stored
#: (the input figures, paper Figs. 2 and 4, are drawn from them).
INPUT_QUANTILES = 4096
_COORD_ATTRS = {
    "surface": {"long_name": "surface variant"},
    "speed_m_s": {"units": "m s-1", "long_name": "nominal incident speed"},
    "angle_deg": {
        "units": "degree",
        "long_name": "apparent incidence angle from the nominal plane",
    },
}


def _edges_attrs(edges) -> dict:
    return {"first_edge": float(edges[0]), "last_edge": float(edges[-1])}


#: Histograms: name -> (edges, what is counted, units of the bins).
_HISTOGRAMS = {
    "e": (E_EDGES, "e_m", "1"),
    "mu": (MU_EDGES, "mu_m", "1"),
    "lateral": (LATERAL_EDGES, "the folded lateral angle psi_f", "degree"),
}


def build_dataset(
    grid, columns, stacked, *, attrs, inputs=None, smooth=None, areal=None
):
    """The result Dataset.

    Parameters
    ----------
    grid : SweepGrid
        Owns the dimensions, coordinates and point order.
    columns : dict of str -> ndarray
        Per-point statistics (point order), see :data:`VARIABLES`.
    stacked : Stacked
        The pooled accumulators (histograms and state).
    attrs : dict
        Global attributes (provenance); values must be NetCDF-storable.
    inputs : dict, optional
        ``{"diameter_quantile": array (INPUT_QUANTILES,) [m],
        "roughness_angle_quantile": array (surfaces, INPUT_QUANTILES) [rad]}``.
    smooth : sequence of bool, optional
        Per surface: molecularly smooth (phi = 0 exactly).
    areal : sequence of bool, optional
        Per surface: an areal (3-D) surface of joint facet angles.
    """
    # deferred: xarray loads only where a dataset is made (import time)
    import xarray as xr

    data_vars = _statistics_vars(grid, columns)
    data_vars |= _state_vars(grid, stacked)
    dense = grid.size * (E_EDGES.size + MU_EDGES.size + 2) <= DENSE_HISTOGRAM_CELLS
    data_vars |= _histogram_vars(grid, stacked, dense)
    coords = {
        dim: (dim, list(values), _COORD_ATTRS[dim])
        for dim, values in grid.coordinates().items()
    }
    bins, bounds = _bin_coords()
    coords |= bins
    data_vars |= bounds
    data_vars |= _surface_flags(smooth, areal)
    if inputs:
        input_coords, input_vars = _input_quantiles(inputs)
        coords |= input_coords
        data_vars |= input_vars
    ds = xr.Dataset(data_vars, coords=coords)
    ds.attrs.update(
        {
            "Conventions": CONVENTIONS,
            **attrs,
            "histograms": "dense" if dense else "ragged",
        }
    )
    return ds


def _statistics_vars(grid, columns) -> dict:
    """The per-point statistics (:data:`VARIABLES`) on the grid's dimensions."""
    data_vars = {}
    for name, values in columns.items():
        units, long_name = VARIABLES[name]
        dtype = np.int64 if name in INTEGER else float
        data_vars[name] = (
            grid.dims,
            grid.reshape(np.asarray(values, dtype=dtype)),
            {"units": units, "long_name": long_name},
        )
    return data_vars


def _state_vars(grid, stacked) -> dict:
    """The accumulators' state that the statistics do not keep (:data:`STATE`):
    counts and central moments, so that a result read back merges and derives
    as a fresh one does."""
    c, e, mu = stacked.counts, stacked.e, stacked.mu
    state = {
        "n_shadowed": c[:, 1],
        "n_captured": c[:, 2],
        "n_reimpact": c[:, 3],
        "n_rolling": c[:, 4],
        "e_m2": e[:, 2],
        "e_m3": e[:, 3],
        "mu_m2": mu[:, 2],
        "mu_m3": mu[:, 3],
        "lateral_m2": stacked.lateral[:, 2],
        "lateral_m3": stacked.lateral[:, 3],
    }
    data_vars = {}
    for name, values in state.items():
        units, long_name = STATE[name]
        data_vars[name] = (
            grid.dims,
            grid.reshape(values),
            {"units": units, "long_name": long_name},
        )
    return data_vars


def _histogram_vars(grid, stacked, dense) -> dict:
    """The e_m, mu_m and lateral histograms with their under- and overflow:
    dense, or the occupied bins only as a CF contiguous ragged array (memory and
    file size proportional to what the histograms hold)."""
    dims = grid.dims
    data_vars = {}
    for nm, spans in (
        ("e", stacked.e_spans),
        ("mu", stacked.mu_spans),
        ("lateral", stacked.lateral_spans),
    ):
        edges, what, _ = _HISTOGRAMS[nm]
        ends = _span_ends(spans)
        data_vars[f"{nm}_hist_underflow"] = (
            dims,
            grid.reshape(ends[0]),
            {"units": "1", "long_name": f"rebounds with {what} below {edges[0]:g}"},
        )
        data_vars[f"{nm}_hist_overflow"] = (
            dims,
            grid.reshape(ends[1]),
            {"units": "1", "long_name": f"rebounds with {what} above {edges[-1]:g}"},
        )
        long_name = f"histogram of {what} over rebounds (counts per bin)"
        if dense:
            h = spans.dense()  # int32 where every count fits
            data_vars[f"{nm}_hist"] = (
                (*dims, f"{nm}_bin"),
                grid.reshape(h[:, 1:-1]),
                {"units": "1", "long_name": long_name, **_edges_attrs(edges)},
            )
            continue
        obs = f"{nm}_hist_obs"
        data_vars[f"{nm}_hist_counts"] = (
            (obs,),
            compact_counts(spans.counts),  # uint8 for a few hundred impacts
            {"units": "1", "long_name": long_name, **_edges_attrs(edges)},
        )
        data_vars[f"{nm}_hist_offset"] = (
            dims,
            grid.reshape(spans.offset.astype(np.int32, copy=False)),
            {
                "units": "1",
                "long_name": f"index of the first stored {what} bin of each point "
                "(0 = the underflow bin, 1 = the first bin of " + f"{nm}_bin)",
            },
        )
        data_vars[f"{nm}_hist_length"] = (
            dims,
            grid.reshape(spans.length.astype(np.int32, copy=False)),
            {
                "units": "1",
                "long_name": f"number of stored {what} bins of each point "
                "(points in grid order)",
                "sample_dimension": obs,
            },
        )
    return data_vars


def _bin_coords() -> tuple[dict, dict]:
    """``(coordinates, bounds variables)`` of the histograms' bins."""
    coords, data_vars = {}, {}
    for nm, (edges, what, units) in _HISTOGRAMS.items():
        coords[f"{nm}_bin"] = (
            f"{nm}_bin",
            0.5 * (edges[1:] + edges[:-1]),
            {
                "units": units,
                "long_name": f"{what} bin centre",
                "bounds": f"{nm}_bin_bounds",
            },
        )
        data_vars[f"{nm}_bin_bounds"] = (
            (f"{nm}_bin", "nv"),
            np.stack([edges[:-1], edges[1:]], axis=1),
            # CF 7.1: bounds carry their variable's units and long_name (or none)
            {"units": units, "long_name": f"{what} bin centre"},
        )
    return coords, data_vars


def _surface_flags(smooth, areal) -> dict:
    """Which surfaces are molecularly smooth and which areal (CF flags)."""
    data_vars = {}
    if smooth is not None:
        data_vars["surface_is_smooth"] = (
            ("surface",),
            np.asarray(smooth, dtype=np.int8),
            {
                "units": "1",
                "long_name": "molecularly smooth surface (roughness angle 0)",
                "flag_values": np.array([0, 1], dtype=np.int8),
                "flag_meanings": "rough smooth",
            },
        )
    if areal is not None:
        data_vars["surface_is_areal"] = (
            ("surface",),
            np.asarray(areal, dtype=np.int8),
            {
                "units": "1",
                "long_name": "areal (3-D) surface of joint facet angles",
                "flag_values": np.array([0, 1], dtype=np.int8),
                "flag_meanings": "profile_or_smooth areal",
            },
        )
    return data_vars


def _input_quantiles(inputs) -> tuple[dict, dict]:
    """``(coordinates, variables)`` of the input distributions' quantile functions
    (the input figures, paper Figs. 2 and 4, are drawn from them)."""
    prob = (np.arange(INPUT_QUANTILES) + 0.5) / INPUT_QUANTILES
    coords = {
        "probability": (
            "probability",
            prob,
            {"units": "1", "long_name": "cumulative probability"},
        )
    }
    data_vars = {}
    if inputs.get("diameter_quantile") is not None:
        data_vars["diameter_quantile"] = (
            ("probability",),
            np.asarray(inputs["diameter_quantile"], dtype=float),
            {"units": "m", "long_name": "quantile function of particle diameter"},
        )
    if inputs.get("roughness_angle_quantile") is not None:
        data_vars["roughness_angle_quantile"] = (
            ("surface", "probability"),
            np.asarray(inputs["roughness_angle_quantile"], dtype=float),
            {
                "units": "radian",
                "long_name": "quantile function of the roughness angle "
                "(NaN for a smooth surface)",
            },
        )
    return coords, data_vars


def _span_ends(spans):
    """Per point, the underflow (first dense bin) and overflow (last) counts."""
    start, length, off = spans.start, spans.length, spans.offset
    under = np.zeros(spans.rows, dtype=np.int64)
    over = np.zeros(spans.rows, dtype=np.int64)
    has = length > 0
    first = has & (off == 0)
    under[first] = spans.counts[start[first]]
    last = has & (off + length == spans.size)
    over[last] = spans.counts[start[last] + length[last] - 1]
    return under, over


def point_histogram(ds, index: tuple, name: str) -> np.ndarray:
    """The in-range histogram of `name` (``"e"``, ``"mu"`` or ``"lateral"``) at the
    grid index `index`, from the dense or the ragged representation."""
    if f"{name}_hist" in ds:
        return np.asarray(ds[f"{name}_hist"].values[index], dtype=np.int64)
    lengths = ds[f"{name}_hist_length"].values
    point = int(np.ravel_multi_index(index, lengths.shape))
    flat = lengths.ravel().astype(np.int64)
    start = int(flat[:point].sum())
    n = int(flat[point])
    offset = int(ds[f"{name}_hist_offset"].values.ravel()[point])
    size = ds.sizes[f"{name}_bin"] + 2
    dense = np.zeros(size, dtype=np.int64)
    dense[offset : offset + n] = ds[f"{name}_hist_counts"].values[start : start + n]
    return dense[1:-1]


def scalar_variables(ds) -> list[str]:
    """The per-point summary variables of `ds`, in summary-column order."""
    dims = set(ds["capture_fraction"].dims)
    names = [v for v in VARIABLES if v in ds.data_vars and set(ds[v].dims) == dims]
    lead = [c for c in SUMMARY_COLUMNS if c in names]
    return lead + [c for c in names if c not in lead]


def summary_frame(ds):
    """``summary.csv``'s table: one row per sweep point (grid order), derived from the
    Dataset."""
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    names = scalar_variables(ds)
    dims = list(ds["capture_fraction"].dims)
    if tuple(dims) == DIMS:  # the grid's order: flat columns, no MultiIndex
        grid = SweepGrid(*(tuple(ds[d].values.tolist()) for d in DIMS))
        columns = {n: ds[n].transpose(*DIMS).values.ravel() for n in names}
        return summary_frame_of(grid, columns)
    df = ds[names].to_dataframe().reset_index()
    df = df[dims + names]
    lead = [c for c in SUMMARY_COLUMNS if c in df.columns]
    df = df[lead + [c for c in df.columns if c not in lead]]
    df["surface"] = df["surface"].astype(str)
    return pd.DataFrame(df).reset_index(drop=True)


def summary_frame_of(grid, columns):
    """:func:`summary_frame` of ``build_dataset(grid, columns, ...)`` from the
    columns themselves, without building the Dataset (nor importing xarray): the
    same columns, order, dtypes and values (tests/engine/test_engine.py compares
    them). The frame holds the columns' own arrays (no copy: a sweep of 10^6
    points has 60 columns of 8 MB)."""
    # deferred: pandas (~30 MiB) loads only where a table is made
    import pandas as pd

    data = summary_columns_of(grid, columns)
    df = pd.DataFrame(data, copy=False)
    df["surface"] = df["surface"].astype(str)
    return df


def summary_columns_of(grid, columns) -> dict[str, np.ndarray]:
    """The columns of :func:`summary_frame_of`, in its order and dtypes, as arrays
    (the sweep axes first, each repeated to one value per point; the statistics
    as they are, without a copy where their dtype is already the column's)."""
    names = [v for v in VARIABLES if v in columns]
    lead = [c for c in SUMMARY_COLUMNS if c in names]
    names = lead + [c for c in names if c not in lead]
    coords = grid.coordinates()
    shape = grid.shape
    data = {}
    for k, dim in enumerate(grid.dims):
        values = list(coords[dim])
        reps = int(np.prod(shape[k + 1 :], dtype=np.int64))
        tiles = int(np.prod(shape[:k], dtype=np.int64))
        index = np.tile(np.repeat(np.arange(len(values)), reps), tiles)
        # names as references to the few name objects (not a str per point)
        kind = object if dim == "surface" else None
        data[dim] = np.array(values, dtype=kind)[index]
    for name in names:
        dtype = np.int64 if name in INTEGER else float
        data[name] = np.asarray(columns[name], dtype=dtype)
    lead = [c for c in SUMMARY_COLUMNS if c in data]
    return {c: data[c] for c in lead + [c for c in data if c not in lead]}


#: Rows :func:`write_csv` formats at a time: its memory is ~60 columns of 8,192
#: Python values (~25 MB), whatever the table (65,536 rows held ~200 MB).
CSV_ROWS = 2**13


def write_csv(path, columns) -> None:
    """Write `columns` (name -> 1-d array, or a DataFrame) to `path` as
    ``DataFrame.to_csv(path, index=False)`` writes them, byte for byte: the
    header, then one line per row, ``,``-separated and ``\n``-terminated, fields
    quoted only where they must be (:data:`csv.QUOTE_MINIMAL`), floats as their
    shortest repr (``repr``: what pandas writes), NaN as an empty field.

    The rows are formatted :data:`CSV_ROWS` at a time from the arrays themselves
    (no table of strings for the whole file, no pandas): a 10^6-point summary
    (~600 MB) is written in seconds rather than half a minute.
    """
    if hasattr(columns, "columns"):  # a DataFrame
        columns = {c: columns[c].to_numpy() for c in columns.columns}
    names = list(columns)
    arrays = [np.asarray(columns[c]) for c in names]
    rows = arrays[0].shape[0] if arrays else 0
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(names)
        for lo in range(0, rows, CSV_ROWS):
            hi = min(rows, lo + CSV_ROWS)
            writer.writerows(zip(*(_csv_values(a[lo:hi]) for a in arrays), strict=True))


def _csv_values(values) -> list:
    """`values` as the Python objects the csv module writes as pandas does: NaN
    as None (an empty field)."""
    out = values.tolist()
    if values.dtype.kind == "f":
        for i in np.flatnonzero(np.isnan(values)).tolist():
            out[i] = None
    elif values.dtype.kind == "O":
        for i, v in enumerate(out):
            if v is None or (isinstance(v, float) and math.isnan(v)):
                out[i] = None
    return out


#: The chunk cache of each variable while ``results.nc`` is written [bytes]. The
#: netCDF-C default (64 MiB per variable) keeps every compressed variable of a
#: sweep in memory until the file is closed: ~570 MiB more at 10^6 points (70
#: variables of 8 MB). The file is the same.
NETCDF_CHUNK_CACHE = 2**20


@contextlib.contextmanager
def small_chunk_cache(size: int = NETCDF_CHUNK_CACHE):
    """netCDF4's default chunk cache set to `size` bytes per variable for the
    files opened inside the block (restored after)."""
    try:
        import netCDF4  # deferred: the NetCDF writer's own dependency
    except ImportError:  # pragma: no cover - the writer will say what is missing
        yield
        return
    saved = netCDF4.get_chunk_cache()
    netCDF4.set_chunk_cache(size, saved[1], saved[2])
    try:
        yield
    finally:
        netCDF4.set_chunk_cache(*saved)


def encoding(ds) -> dict:
    """NetCDF encoding: zlib-compressed data variables; no ``_FillValue`` on
    coordinates, cell bounds or any variable without a missing value (CF 1.10
    §2.5.1 and §7.1: xarray would otherwise write NaN as the fill value of every
    float variable)."""
    bounds = {ds[v].attrs["bounds"] for v in ds.variables if "bounds" in ds[v].attrs}
    out = {}
    for name in ds.variables:
        var = ds[name]
        enc = {"zlib": True, "complevel": 4} if name in ds.data_vars else {}
        if var.dtype.kind in "SUO":
            out[name] = enc
            continue
        missing = var.dtype.kind == "f" and bool(np.isnan(var.values).any())
        if name in ds.coords or name in bounds or not missing:
            enc["_FillValue"] = None
        out[name] = enc
    return out


#: The variable of the surface names in the files: a CF auxiliary coordinate (CF
#: 1.10 §5), while the dimension coordinate ``surface`` holds the surfaces' index
#: (§1.3: coordinate variables are numeric and strictly monotonic).
SURFACE_NAME = "surface_name"


def surfaces_to_cf(ds):
    """`ds` as it is written: the string ``surface`` coordinate becomes the index
    ``0 .. n-1`` and the names move to the auxiliary coordinate ``surface_name``
    (a Dataset without string surfaces is returned as it is)."""
    if "surface" not in ds.dims or ds["surface"].dtype.kind not in "OUS":
        return ds
    names = np.array([str(s) for s in ds["surface"].values], dtype=object)
    attrs = dict(ds["surface"].attrs)
    long_name = attrs.pop("long_name", "surface variant")
    out = ds.drop_vars("surface")
    return out.assign_coords(
        surface=(
            "surface",
            np.arange(names.size, dtype=np.int32),
            {**attrs, "long_name": f"{long_name} index", "units": "1"},
        ),
        **{SURFACE_NAME: ("surface", names, {"long_name": f"{long_name} name"})},
    )


def surfaces_from_cf(ds):
    """`ds` as it is used: the surfaces' names as the ``surface`` coordinate, so that
    ``ds.sel(surface="formica")`` works. Reads both forms: the names in the
    ``surface_name`` auxiliary coordinate (files since 0.1.0 of issue 33) or in
    ``surface`` itself (older files)."""
    if SURFACE_NAME not in ds.variables or "surface" not in ds.dims:
        return ds
    names = np.array([str(s) for s in ds[SURFACE_NAME].values], dtype=object)
    attrs = {
        k: v for k, v in ds["surface"].attrs.items() if k not in ("units", "long_name")
    }
    long_name = str(ds[SURFACE_NAME].attrs.get("long_name", "surface variant name"))
    long_name = long_name.removesuffix(" name")
    out = ds.drop_vars([SURFACE_NAME, "surface"], errors="ignore")
    return out.assign_coords(
        surface=("surface", names, {**attrs, "long_name": long_name})
    )


def history_line(command: str) -> str:
    """A CF ``history`` entry: the UTC time and what wrote the file."""
    now = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    return f"{now}: {command} (microimpact {__version__})"
