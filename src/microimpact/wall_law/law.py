"""The wall law: a CF-1.10 table of impact outcomes and its stochastic sampler.

:class:`WallLaw` wraps the ``wall_law.nc`` Dataset (its schema is in
docs/wall-law.md) and samples it the way the C sampler (``c/swl.c``) does: pick a
corner of the query's cell with probability equal to its trilinear weight in
(log d, log v, angle), decide capture with that corner's capture probability, and
otherwise take one of the corner's reservoir samples (on a reduced speed axis,
``speed_axis = "reduced"``, the speed variable is log(v / v_c(d)): the nodes
follow the capture edge). Each node's distribution, and
the correlation of e_n, e_t and the lateral angle within it, are kept; nothing is
averaged across nodes. A table built with a ``[resuspension]`` table also carries
each node's ``stay_probability``: a captured particle stays where the capture
uniform is below ``capture_probability * stay_probability`` (no extra uniform).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from .._core.files import atomic_write
from .._core.json import dumps
from ..engine.dataset import (
    CONVENTIONS,
    encoding,
    history_line,
    surfaces_from_cf,
    surfaces_to_cf,
)
from ..engine.statistics import wilson_interval
from ..errors import DataFormatError
from ..scenario.wall_law import REBOUND_VARIABLES, RESERVOIR_VARIABLES
from .checks import dataset_problem, node_values, wrong_unit
from .export_c import write_c
from .openfoam import write_openfoam, write_stochastic_model
from .openfoam_stochastic import _demo_family_iv

__all__ = ["WallLaw", "WallLawSample", "wall_law_dataset"]

DIMS = ("surface", "diameter_um", "speed_m_s", "angle_deg")
#: The dimensions of a table on a reduced speed axis (v / v_c(d)).
REDUCED_DIMS = ("surface", "diameter_um", "reduced_speed", "angle_deg")

#: A query is flagged clamped only where it lies outside an axis' end nodes by
#: more than this, relative, in the axis' variable (log d, log v or log(v/v_c),
#: and the angle relative to its end node): a query at an end node up to
#: round-off (a diameter converted from metres, a speed r v_c(d)) is not clamped.
CLAMP_TOLERANCE = 1e-9

#: Frame, angle convention and interpolation rule (the file's attributes).
FRAME = (
    "wall frame: z the outward normal of the nominal wall, x the incoming "
    "particle's tangential direction of travel, y = z cross x (lateral)"
)
ANGLE_CONVENTION = (
    "angle_deg: apparent incidence angle measured from the wall plane (90 = normal "
    "impact); rebound_angle_deg = atan2(U_z, U_x) from the wall plane; "
    "lateral_angle_deg = atan2(U_y, hypot(U_x, U_z))"
)
INTERPOLATION = (
    "stochastic: pick the corner of the (log diameter, log speed, angle) cell (log "
    "reduced speed log(v / v_c(d)) on a reduced speed axis, with log v_c "
    "interpolated linearly in log d between the diameter nodes) with "
    "probability equal to its trilinear weight (upper node on each axis where the "
    "axis' uniform < its fraction), capture where a uniform < that corner's "
    "capture_probability, else draw reservoir sample floor(u * reservoir_count); "
    "queries outside the axes (by more than 1e-9 relative) are clamped to the "
    "end nodes; velocity U_z = e_n s "
    "sin(theta), U_x = s cos(theta) - mu (1 + e_n) s sin(theta), "
    "U_y = tan(psi) hypot(U_x, U_z), then U scaled to |U| = speed_ratio s"
)

#: What ``stay_probability`` assumes (its attribute ``assumptions``).
STAY_ASSUMPTIONS = (
    "quasi-steady flow at the stated friction velocity of each step for its "
    "stated exposure, steps acting in order on what the earlier ones left; "
    "particles independent of each other (a monolayer); the quasi-static "
    "Rock'n'Roll rate with the stated adhesion, surface energy and fluid, at the "
    "node's diameter; the adhesion of a captured particle does not depend on how "
    "it struck"
)

_UNITS = {
    "e_n": ("1", "normal restitution e_n = U_z / (s sin theta) (apparent e_m)"),
    "e_t": ("1", "tangential restitution e_t = U_x / (s cos theta)"),
    "mu": ("1", "apparent impulse ratio mu_m (paper Eq. 9)"),
    "rebound_angle_deg": ("degree", "rebound angle from the wall plane"),
    "lateral_angle_deg": ("degree", "lateral (out-of-plane) rebound angle"),
    "speed_ratio": ("1", "rebound speed over incident speed |U| / s"),
}

VARIABLES: dict[str, tuple[str, str]] = {
    "n_samples": ("1", "draws made at the node"),
    "n_impacts": ("1", "draws that struck a facet (not shadowed)"),
    "n_captured": ("1", "impacts captured"),
    "n_rebounds": ("1", "impacts not captured"),
    "n_reimpacts": ("1", "rebounds heading into the nominal wall (U_z < 0)"),
    "capture_probability": ("1", "probability that an impact is captured"),
    "capture_ci_low": ("1", "lower Wilson confidence limit of capture_probability"),
    "capture_ci_high": ("1", "upper Wilson confidence limit of capture_probability"),
    "reimpact_probability": ("1", "fraction of rebounds with U_z < 0"),
    "reservoir_count": ("1", "rebound samples held in the reservoir"),
    "stay_probability": (
        "1",
        "probability that a particle captured at the node stays on the wall after "
        "the [resuspension] exposure (Rock'n'Roll quadrature at the node's "
        "diameter; quasi-steady flow, independent particles)",
    ),
    "critical_speed_m_s": (
        "m s-1",
        "critical (capture) speed v_c(d) at normal incidence on a smooth surface "
        "(paper Eq. 5): the reduced speed axis is v / v_c(d)",
    ),
}
for _name, (_u, _long) in _UNITS.items():
    VARIABLES[f"{_name}_mean"] = (_u, f"mean over rebounds of the {_long}")
    VARIABLES[f"{_name}_std"] = (_u, f"standard deviation over rebounds of the {_long}")
    VARIABLES[f"{_name}_quantile"] = (_u, f"quantiles over rebounds of the {_long}")
for _name in RESERVOIR_VARIABLES:
    _u, _long = _UNITS[_name]
    VARIABLES[f"reservoir_{_name}"] = (
        _u,
        f"reservoir of joint rebound samples: {_long}",
    )

COORDS = {
    "surface": (None, "surface variant"),
    "diameter_um": ("um", "particle diameter"),
    "speed_m_s": ("m s-1", "nominal incident speed"),
    "reduced_speed": ("1", "reduced incident speed v / v_c(d)"),
    "angle_deg": ("degree", "apparent incidence angle from the wall plane"),
    "quantile": ("1", "probability level of the quantile variables"),
    "sample": ("1", "index in a node's reservoir"),
}


def wall_law_dataset(
    grid,
    spec,
    columns,
    *,
    scenario,
    entropy,
    source_text=None,
    seconds=None,
    critical_speed_m_s=None,
    stay_probability=None,
    resuspension=None,
):
    """The wall law's CF-1.10 Dataset from per-diameter stacked node columns.

    `columns` maps each node variable to an array of shape (diameters, points,
    ...) with the points in ``grid`` order (surface x speed x angle). On a
    reduced speed axis (``spec.speed_axis == "reduced"``, the grid's speeds the
    ratios r) `critical_speed_m_s` holds v_c at each diameter node: the speed
    dimension is ``reduced_speed``, with ``critical_speed_m_s`` (diameter) and the
    node speeds ``speed_m_s`` = r v_c(d) (diameter, reduced_speed) as variables.
    `stay_probability` (one value per diameter node) and `resuspension` (the
    :class:`~microimpact.scenario.resuspension.ResuspensionSpec` it came from)
    add ``stay_probability`` on every node, with the flow in its attributes.
    """
    reduced = spec.speed_axis == "reduced"
    dims = REDUCED_DIMS if reduced else DIMS
    # deferred: xarray loads only where a dataset is made (import time)
    import xarray as xr

    n_s, n_v, n_a = len(grid.surfaces), len(grid.speeds_m_s), len(grid.angles_deg)
    n_d = len(spec.diameters_um)

    def nodes(a):
        a = np.asarray(a).reshape((n_d, n_s, n_v, n_a, *a.shape[2:]))
        return np.moveaxis(a, 0, 1)  # (surface, diameter, speed, angle, ...)

    data = {}
    for name, arr in columns.items():
        a = nodes(arr)
        extra = ()
        if name.endswith("_quantile"):
            extra = ("quantile",)
        elif name.startswith("reservoir_") and name != "reservoir_count":
            extra = ("sample",)
        if name.startswith("n_") or name == "reservoir_count":
            a = a.astype(np.int64 if name != "reservoir_count" else np.int32)
        data[name] = (dims + extra, a)
    k = data["n_captured"][1]
    n = data["n_impacts"][1]
    with np.errstate(invalid="ignore", divide="ignore"):
        p = np.where(n > 0, k / np.maximum(n, 1), np.nan)
        reb = data["n_rebounds"][1]
        reimp = np.where(reb > 0, data["n_reimpacts"][1] / np.maximum(reb, 1), np.nan)
    low, high = wilson_interval(k, n, scenario.confidence)
    data["capture_probability"] = (dims, p)
    data["capture_ci_low"] = (dims, np.where(n > 0, low, np.nan))
    data["capture_ci_high"] = (dims, np.where(n > 0, high, np.nan))
    data["reimpact_probability"] = (dims, reimp)
    if stay_probability is not None:  # a function of d only, carried per node
        q = np.asarray(stay_probability, dtype=float).reshape(1, n_d, 1, 1)
        data["stay_probability"] = (dims, np.broadcast_to(q, p.shape).copy())
    coords = {
        "surface": np.array(grid.surfaces, dtype=object),
        "diameter_um": np.array(spec.diameters_um),
        dims[2]: np.array(grid.speeds_m_s),
        "angle_deg": np.array(grid.angles_deg),
        "quantile": np.array(spec.quantiles),
        "sample": np.arange(spec.reservoir, dtype=np.int32),
    }
    if reduced:
        v_c = np.asarray(critical_speed_m_s, dtype=float)
        data["critical_speed_m_s"] = (("diameter_um",), v_c)
        coords["speed_m_s"] = (
            ("diameter_um", "reduced_speed"),
            v_c[:, None] * np.array(grid.speeds_m_s)[None, :],  # the build's speeds
        )
    order = [v for v in VARIABLES if v in data]
    ds = xr.Dataset({v: data[v] for v in order}, coords=coords)
    # the attributes set on the variables themselves (``ds[v]`` would build a
    # DataArray for each: ~40 us of Python apiece, issue 31)
    variables = ds.variables
    for v in ds.data_vars:
        units, long_name = VARIABLES[v]
        variables[v].attrs.update(units=units, long_name=long_name)
    for c, (units, long_name) in COORDS.items():
        if c not in ds.coords:
            continue
        variables[c].attrs["long_name"] = long_name
        if units is not None:
            variables[c].attrs["units"] = units
    if "stay_probability" in ds and resuspension is not None:
        ds["stay_probability"].attrs.update(
            friction_velocity_m_s=np.asarray(resuspension.friction_velocities_m_s),
            exposure_s=np.asarray(resuspension.exposures_s),
            assumptions=STAY_ASSUMPTIONS,
        )
        ds.attrs["resuspension"] = dumps(resuspension.describe())
    ds["diameter_um"].attrs["axis_spacing"] = "interpolated in log"
    ds[dims[2]].attrs["axis_spacing"] = "interpolated in log"
    ds.attrs.update(
        speed_axis=spec.speed_axis,
        Conventions=CONVENTIONS,
        title=f"microimpact wall law: {scenario.name}",
        history=history_line(f"wall law of scenario {scenario.name!r}"),
        source=f"microimpact {__version__} (Li, Dunn & Brach 2000 Monte Carlo)",
        frame=FRAME,
        angle_convention=ANGLE_CONVENTION,
        interpolation=INTERPOLATION,
        scenario=source_text if source_text is not None else "",
        scenario_description=dumps(_description(scenario, reduced)),
        seed=str(entropy),
        samples_per_node=int(columns["n_samples"].flat[0]),
        reservoir=int(spec.reservoir),
        confidence=float(scenario.confidence),
        shadowing=scenario.shadowing,
        microimpact_version=__version__,
        common_random_numbers=f"every diameter of a (surface, {dims[2]}, angle) uses "
        "the same draws",
    )
    if seconds is not None:
        ds.attrs["build_seconds"] = float(seconds)
    return ds


def _description(scenario, reduced: bool) -> dict:
    """The scenario's provenance description; on a reduced speed axis the build's
    speeds are the ratios r = v / v_c(d), recorded as ``reduced_speeds``."""
    out = scenario.describe()
    if reduced:
        out["reduced_speeds"] = out.pop("speeds_m_s")
        out["speeds_m_s"] = "r v_c(d): the variable speed_m_s"
    return out


@dataclass(frozen=True)
class WallLawSample:
    """Outcomes of sampled impacts (arrays of length N).

    Attributes
    ----------
    captured : ndarray of bool
        The particle sticks (its velocity is zero).
    velocity : ndarray, shape (N, 3)
        Rebound velocity in the wall frame [m s-1] (x along the incoming tangential
        direction of travel, y lateral, z out of the wall); zero where captured,
        NaN where not valid.
    reimpact : ndarray of bool
        Rebounds heading back into the wall (U_z < 0): strike it again.
    clamped : ndarray of bool
        The query lay outside the table on some axis and was clamped to its end.
    valid : ndarray of bool
        False where the chosen node has no impact to draw from (every draw there
        shadowed).
    resuspended : ndarray of bool
        Captured, but removed by the flow of the ``[resuspension]`` table: the
        capture uniform lay in ``[p q, p)`` with p the chosen node's capture
        probability and q its ``stay_probability``. All False for a table
        without ``stay_probability``. A captured particle stays where
        ``captured & ~resuspended``.
    """

    captured: np.ndarray
    velocity: np.ndarray
    reimpact: np.ndarray
    clamped: np.ndarray
    valid: np.ndarray
    resuspended: np.ndarray


def _bracket(coord: np.ndarray, x: np.ndarray, tol_low: float, tol_high: float):
    """Lower node index, fraction in [0, 1] and clamped flag along one axis: a
    query is clamped where it lies below ``coord[0] - tol_low`` or above
    ``coord[-1] + tol_high`` (:data:`CLAMP_TOLERANCE`)."""
    n = coord.size
    if n == 1:
        out = (x < coord[0] - tol_low) | (x > coord[0] + tol_high)
        return np.zeros(x.shape, np.intp), np.zeros(x.shape), out
    i = np.clip(np.searchsorted(coord, x, side="right") - 1, 0, n - 2)
    lo, hi = coord[i], coord[i + 1]
    t = (x - lo) / (hi - lo)
    clamped = (x < coord[0] - tol_low) | (x > coord[-1] + tol_high)
    return i, np.clip(t, 0.0, 1.0), clamped


def _tolerances(coord: np.ndarray, log: bool) -> tuple[float, float]:
    """The clamping tolerances below and above an axis (:data:`CLAMP_TOLERANCE`
    relative: in a log variable that is the tolerance itself)."""
    if log:
        return CLAMP_TOLERANCE, CLAMP_TOLERANCE
    return CLAMP_TOLERANCE * abs(coord[0]), CLAMP_TOLERANCE * abs(coord[-1])


def _check_query(name, value, n, positive):
    a = np.asarray(value, dtype=float)
    if a.ndim > 1:
        raise ValueError(f"`{name}` must be a scalar or 1-D; got shape {a.shape}")
    a = np.broadcast_to(a, (n,)) if a.ndim == 0 else a
    if a.shape != (n,):
        raise ValueError(f"`{name}` has {a.size} values; expected {n}")
    bad = ~np.isfinite(a) | ((a <= 0) if positive else (a <= 0) | (a > 90))
    if np.any(bad):
        i = int(np.argmax(bad))
        allowed = "> 0" if positive else "in (0, 90]"
        raise ValueError(f"`{name}` must be finite and {allowed}; got {a[i]!r}")
    return a


class WallLaw:
    """A tabulated stochastic wall law (see docs/wall-law.md).

    Build one with :func:`microimpact.build_wall_law` or load a saved one with
    :meth:`WallLaw.open`. The Dataset is :attr:`dataset`.
    """

    def __init__(self, dataset):
        dataset = surfaces_from_cf(dataset)  # names in `surface_name` or `surface`
        missing = [
            v
            for v in (
                "capture_probability",
                "reservoir_count",
                "n_impacts",
                *tuple(f"reservoir_{n}" for n in RESERVOIR_VARIABLES),
            )
            if v not in dataset
        ]
        if missing:
            raise DataFormatError(
                f"not a wall-law table: missing variables {', '.join(missing)}"
            )
        reduced = "reduced_speed" in dataset.dims
        self._dims = REDUCED_DIMS if reduced else DIMS
        for c in self._dims[1:]:
            if c not in dataset.coords:
                raise DataFormatError(f"not a wall-law table: no coordinate {c}")
            x = np.asarray(dataset[c].values, dtype=float)
            if (
                x.ndim != 1
                or x.size == 0
                or np.any(np.diff(x) <= 0)
                or not np.all(np.isfinite(x))
            ):
                raise DataFormatError(
                    f"not a wall-law table: coordinate {c} must be finite and "
                    "strictly increasing"
                )
        if reduced:
            v_c = (
                np.asarray(dataset["critical_speed_m_s"].values, dtype=float)
                if "critical_speed_m_s" in dataset
                else np.empty(0)
            )
            if v_c.shape != (dataset.sizes["diameter_um"],) or not np.all(
                np.isfinite(v_c) & (v_c > 0)
            ):
                raise DataFormatError(
                    "not a wall-law table: a reduced speed axis needs "
                    "critical_speed_m_s (diameter_um), finite and > 0"
                )
        # the value ranges every reader and writer checks (wall_law/checks.py)
        problem = dataset_problem(dataset, self._dims)
        if problem:
            raise DataFormatError(f"not a valid wall-law table: {problem}")
        self.dataset = dataset

        def values(name):  # in node order, from the variable (no Dataset built)
            return node_values(dataset, name, self._dims)

        self._log_d = np.log(values("diameter_um").astype(float))
        self._log_v = np.log(values(self._dims[2]).astype(float))
        self._log_vc = (
            np.log(values("critical_speed_m_s").astype(float)) if reduced else None
        )
        self._angle = values("angle_deg").astype(float)
        self._tol = (
            _tolerances(self._log_d, True),
            _tolerances(self._log_v, True),
            _tolerances(self._angle, False),
        )
        self._p = values("capture_probability").astype(float)
        self._q = (
            values("stay_probability").astype(float)
            if "stay_probability" in dataset
            else None
        )
        self._count = values("reservoir_count").astype(np.int64)
        self._res = {
            n: values(f"reservoir_{n}").astype(float) for n in RESERVOIR_VARIABLES
        }

    # ---------------------------------------------------------------- loading
    @classmethod
    def open(cls, path):
        """Load a ``wall_law.nc`` (or the folder holding one)."""
        # deferred: xarray loads only where a dataset is made (import time)
        import xarray as xr

        path = Path(path)
        if path.is_dir():
            path = path / "wall_law.nc"
        if not path.is_file():
            raise DataFormatError("no such file", source=str(path))
        try:
            with xr.open_dataset(path) as ds:
                ds = ds.load()
        except (OSError, ValueError) as err:
            raise DataFormatError(
                f"not a readable NetCDF file ({err})", source=str(path)
            ) from None
        try:
            return cls(ds)
        except DataFormatError as err:
            raise DataFormatError(err.message, source=str(path)) from None

    # ------------------------------------------------------------- properties
    @property
    def surfaces(self) -> tuple[str, ...]:
        return tuple(str(s) for s in self.dataset["surface"].values)

    @property
    def diameters_um(self) -> np.ndarray:
        return self.dataset["diameter_um"].values

    @property
    def speed_axis(self) -> str:
        """``"absolute"`` (speed nodes in m/s) or ``"reduced"`` (v / v_c(d))."""
        return "reduced" if self._log_vc is not None else "absolute"

    @property
    def speeds_m_s(self) -> np.ndarray:
        """The speed nodes [m s-1]: 1-D on an absolute axis, (diameter,
        reduced_speed) on a reduced one (r v_c(d))."""
        return self.dataset["speed_m_s"].values

    @property
    def reduced_speeds(self) -> np.ndarray | None:
        """The reduced speed nodes v / v_c(d) (None on an absolute axis)."""
        if self._log_vc is None:
            return None
        return self.dataset["reduced_speed"].values

    @property
    def critical_speeds_m_s(self) -> np.ndarray | None:
        """v_c at each diameter node [m s-1] (None on an absolute axis)."""
        if self._log_vc is None:
            return None
        return self.dataset["critical_speed_m_s"].values

    @property
    def angles_deg(self) -> np.ndarray:
        return self.dataset["angle_deg"].values

    @property
    def has_stay_probability(self) -> bool:
        """Whether the table carries ``stay_probability`` (built with a
        ``[resuspension]`` table)."""
        return self._q is not None

    @property
    def reservoir(self) -> int:
        return int(self.dataset.sizes["sample"])

    def surface_index(self, surface) -> int:
        """Index of `surface` (an index or a surface name)."""
        names = self.surfaces
        if isinstance(surface, str):
            if surface not in names:
                raise ValueError(
                    f"unknown surface {surface!r}; the table has {', '.join(names)}"
                )
            return names.index(surface)
        if isinstance(surface, bool) or not isinstance(surface, int | np.integer):
            raise TypeError(f"`surface` must be a name or an index; got {surface!r}")
        if not 0 <= surface < len(names):
            raise ValueError(f"`surface` must be in [0, {len(names)}); got {surface}")
        return int(surface)

    def __repr__(self):
        d, v, a = self.diameters_um, self.speeds_m_s, self.angles_deg
        if self.speed_axis == "reduced":
            r = self.reduced_speeds
            speeds = f"{r.size} reduced speeds v/v_c(d) [{r[0]:g}, {r[-1]:g}]"
        else:
            speeds = f"{v.size} speeds [{v[0]:g}, {v[-1]:g}] m/s"
        return (
            f"<WallLaw {len(self.surfaces)} surface(s) x {d.size} diameters "
            f"[{d[0]:g}, {d[-1]:g}] um x {speeds} x "
            f"{a.size} angles [{a[0]:g}, {a[-1]:g}] deg, K={self.reservoir}>"
        )

    # ---------------------------------------------------------------- sampling
    def sample_uniform(self, diameter_um, speed_m_s, angle_deg, u, *, surface=0):
        """Outcomes for caller-supplied uniform numbers (the C sampler's rule).

        Parameters
        ----------
        diameter_um, speed_m_s, angle_deg : float or array_like
            The impacts' diameters [µm], speeds [m s-1] and apparent incidence
            angles from the wall plane [deg], broadcast to N = ``len(u)``. On a
            reduced speed axis the speed variable is log(v / v_c(d)), v_c
            interpolated linearly in log-log between the diameter nodes.
        u : array_like, shape (N, 5)
            Uniform numbers in [0, 1): u[:, 0..2] pick the cell corner along the
            diameter, speed and angle axes, u[:, 3] decides capture (and, on a
            table with ``stay_probability``, whether a captured particle stays:
            ``u[:, 3] < p q``), u[:, 4] picks the reservoir sample
            (docs/wall-law.md, "The sampling rule").
        surface : int or str
            The surface (index or name).

        Returns
        -------
        WallLawSample
        """
        s = self.surface_index(surface)
        u = np.asarray(u, dtype=float)
        if u.ndim != 2 or u.shape[1] != 5:
            raise ValueError(f"`u` must have shape (N, 5); got {u.shape}")
        if u.size and (np.any(~(u >= 0.0)) or np.any(~(u < 1.0))):
            raise ValueError("`u` must hold uniform numbers in [0, 1)")
        n = u.shape[0]
        d, v, a = self._queries(diameter_um, speed_m_s, angle_deg, n)
        cells, clamped = self._cells(d, v, a)
        idx = [np.where(u[:, k] < t, i + 1, i) for k, (i, t) in enumerate(cells)]
        node = (s, idx[0], idx[1], idx[2])
        p = self._p[node]
        valid = ~np.isnan(p)
        captured = valid & (u[:, 3] < p)
        count = self._count[node]
        rebound = valid & ~captured
        k = np.minimum(np.floor(u[:, 4] * count).astype(np.int64), count - 1)
        k = np.where(rebound, k, 0)
        e_n = self._res["e_n"][(*node, k)]
        mu = self._res["mu"][(*node, k)]
        psi = self._res["lateral_angle_deg"][(*node, k)]
        ratio = self._res["speed_ratio"][(*node, k)]
        th = a * (math.pi / 180.0)
        sin_t, cos_t = np.sin(th), np.cos(th)
        vel = np.zeros((n, 3))
        # the direction per unit speed (the reader bounds e_n, mu and the lateral
        # angle: no overflow), then |U| = speed_ratio * s (no energy gained when
        # the corner's angle differs from the query's); as swl.c, component by
        # component u / |u| (at most 1) times speed_ratio * s
        u_z = e_n * sin_t
        u_x = cos_t - mu * (1.0 + e_n) * sin_t
        u_y = np.tan(psi * (math.pi / 180.0)) * np.hypot(u_x, u_z)
        norm = np.hypot(np.hypot(u_x, u_z), u_y)
        with np.errstate(invalid="ignore", divide="ignore"):
            safe = np.where(norm > 0.0, norm, 1.0)
            scale = np.where(norm > 0.0, ratio * v, 0.0)
            u_x, u_y, u_z = u_x / safe * scale, u_y / safe * scale, u_z / safe * scale
        vel[:, 0] = np.where(rebound, u_x, 0.0)
        vel[:, 1] = np.where(rebound, u_y, 0.0)
        vel[:, 2] = np.where(rebound, u_z, 0.0)
        vel[~valid] = np.nan
        if self._q is None:
            resuspended = np.zeros(n, bool)
        else:  # as swl.c: the capture uniform in [p q, p)
            resuspended = captured & ~(u[:, 3] < p * self._q[node])
        return WallLawSample(
            captured=captured,
            velocity=vel,
            reimpact=rebound & (u_z < 0.0),
            clamped=clamped,
            valid=valid,
            resuspended=resuspended,
        )

    def _queries(self, diameter_um, speed_m_s, angle_deg, n):
        """The checked queries as three arrays of length `n` (as swl.c refuses)."""
        d = _check_query("diameter_um", diameter_um, n, True)
        v = _check_query("speed_m_s", speed_m_s, n, True)
        a = _check_query("angle_deg", angle_deg, n, False)
        if np.any(v < np.finfo(float).tiny):  # as swl.c: |U| <= s needs a normal s
            raise ValueError(
                f"`speed_m_s` must be at least {np.finfo(float).tiny:g} (a normal "
                f"number); got {float(v[v < np.finfo(float).tiny][0])!r}"
            )
        # a unit slip (metres as um, mm/s as m/s), refused as the C sampler does
        top = self._log_v[-1] + (0.0 if self._log_vc is None else self._log_vc.max())
        problem = wrong_unit(d, v, math.exp(top))  # the fastest node [m/s]
        if problem:
            raise ValueError(problem)
        return d, v, a

    def _cells(self, d, v, a):
        """``([(lower node, fraction t) per axis], clamped)`` of the queries:
        step 1 of the sampling rule (docs/wall-law.md)."""
        cells, clamped = [], np.zeros(d.shape, bool)
        log_v = np.log(v)
        for axis, coord in enumerate((self._log_d, self._log_v, self._angle)):
            x = (np.log(d), log_v, a)[axis]
            i, t, c = _bracket(coord, x, *self._tol[axis])
            if axis == 0 and self._log_vc is not None:
                # reduced axis: x = log v - log v_c(d), log v_c linear in log d
                # between the diameter nodes (the query's own fraction, clipped)
                lvc = self._log_vc
                if lvc.size > 1:
                    lvc = lvc[i] + t * (lvc[i + 1] - lvc[i])
                log_v = log_v - lvc
            cells.append((i, t))
            clamped |= c
        return cells, clamped

    def stay_probability(self, diameter_um, speed_m_s, angle_deg, *, surface=0):
        """Probability that a particle captured at each query stays on the wall.

        Under the sampling rule the corner c of the query's cell is picked with
        its trilinear weight w_c, and a particle is captured there with the
        corner's capture probability p_c and then stays with its
        ``stay_probability`` q_c, so

        ``P(stay | captured) = sum_c w_c p_c q_c / sum_c w_c p_c``

        over the corners with w_c > 0 and p_c not NaN, summed in the corner
        order (diameter, speed, angle; lower node first) of ``swl.c``'s
        ``swl_stay_probability``, which gives the same bits. Where no corner
        can capture (the denominator is 0) it is ``sum_c w_c q_c / sum_c w_c``
        over those corners; NaN where no corner has data.

        Raises ValueError for a table without ``stay_probability`` and for the
        queries :meth:`sample_uniform` refuses.
        """
        if self._q is None:
            raise ValueError(
                "this wall law carries no stay_probability: build it from a "
                "scenario with a [resuspension] table (docs/resuspension.md)"
            )
        s = self.surface_index(surface)
        shape = np.broadcast_shapes(
            np.shape(diameter_um), np.shape(speed_m_s), np.shape(angle_deg)
        )
        if len(shape) > 1:
            raise ValueError(f"queries must be scalars or 1-D; got shape {shape}")
        n = shape[0] if shape else 1
        d, v, a = self._queries(
            np.broadcast_to(diameter_um, (n,)),
            np.broadcast_to(speed_m_s, (n,)),
            np.broadcast_to(angle_deg, (n,)),
            n,
        )
        cells, _ = self._cells(d, v, a)
        num, den = np.zeros(n), np.zeros(n)
        w_num, w_den = np.zeros(n), np.zeros(n)
        for corner in range(8):  # bits: diameter 4, speed 2, angle 1 (as swl.c)
            w = np.ones(n)
            index = []
            for axis, (i, t) in enumerate(cells):
                up = (corner >> (2 - axis)) & 1
                w = w * (t if up else 1.0 - t)
                index.append(np.minimum(i + up, self._p.shape[axis + 1] - 1))
            node = (s, *index)
            p, q = self._p[node], self._q[node]
            use = (w > 0.0) & ~np.isnan(p)
            num = np.where(use, num + w * p * q, num)
            den = np.where(use, den + w * p, den)
            w_num = np.where(use, w_num + w * q, w_num)
            w_den = np.where(use, w_den + w, w_den)
        with np.errstate(invalid="ignore", divide="ignore"):
            out = np.where(
                den > 0.0, num / den, np.where(w_den > 0.0, w_num / w_den, np.nan)
            )
        return out if shape else out[0]

    def sample(self, diameter_um, speed_m_s, angle_deg, *, rng, surface=0):
        """Sample impacts (vectorised): ``rng.random((N, 5))`` drives
        :meth:`sample_uniform`, N the broadcast length of the queries.

        `rng` is a :class:`numpy.random.Generator` (or an int seed).
        """
        rng = np.random.default_rng(rng)
        shape = np.broadcast_shapes(
            np.shape(diameter_um), np.shape(speed_m_s), np.shape(angle_deg)
        )
        if len(shape) > 1:
            raise ValueError(f"queries must be scalars or 1-D; got shape {shape}")
        n = shape[0] if shape else 1
        return self.sample_uniform(
            np.broadcast_to(diameter_um, (n,)),
            np.broadcast_to(speed_m_s, (n,)),
            np.broadcast_to(angle_deg, (n,)),
            rng.random((n, 5)),
            surface=surface,
        )

    # ----------------------------------------------------------------- tables
    def to_frame(self):
        """The long table of ``wall_law.csv``: one row per node."""
        # deferred: pandas loads only where a table is made (import time)
        import pandas as pd

        dims = self._dims
        ds = self.dataset.transpose(*dims, ...)
        q = list(ds["quantile"].values)
        cols = {}
        grids = np.meshgrid(*(np.arange(ds.sizes[dim]) for dim in dims), indexing="ij")
        for dim, g in zip(dims, grids, strict=True):
            cols[dim] = ds[dim].values[g.ravel()]
        if self.speed_axis == "reduced":  # the node's speed and v_c(d), in m/s
            i, j = grids[1].ravel(), grids[2].ravel()
            cols["speed_m_s"] = ds["speed_m_s"].values[i, j]
            cols["critical_speed_m_s"] = ds["critical_speed_m_s"].values[i]
        for v in (
            "n_samples",
            "n_impacts",
            "n_captured",
            "n_rebounds",
            "capture_probability",
            "capture_ci_low",
            "capture_ci_high",
            "reimpact_probability",
            *(("stay_probability",) if self._q is not None else ()),
        ):
            cols[v] = ds[v].values.ravel()
        for name in REBOUND_VARIABLES:
            cols[f"{name}_mean"] = ds[f"{name}_mean"].values.ravel()
            cols[f"{name}_std"] = ds[f"{name}_std"].values.ravel()
            qa = ds[f"{name}_quantile"].values.reshape(-1, len(q))
            for level, tag in ((0.05, "p05"), (0.5, "p50"), (0.95, "p95")):
                if level in q:
                    cols[f"{name}_{tag}"] = qa[:, q.index(level)]
        return pd.DataFrame(cols)

    def write(
        self, out_dir, *, c=True, openfoam=True, condition=None, demo_family="kinematic"
    ) -> list[Path]:
        """Write ``wall_law.nc``, ``wall_law.csv`` and (by default) the C sampler
        with its binary table (``c/``) and the OpenFOAM dictionaries
        (``openfoam/``) into `out_dir`; every file is written whole or not at all.

        `condition` is a dict with any of ``diameter_um``, ``speed_m_s``,
        ``angle_deg``: where the OpenFOAM constant coefficients are taken.
        `demo_family`: ``openfoam/demoCase/``'s solvers (:func:`write_demo_case`).
        Returns the paths written.
        """
        _demo_family_iv(demo_family)  # before anything is written
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        written = [
            atomic_write(out / "wall_law.nc", self._write_netcdf),
            atomic_write(
                out / "wall_law.csv",
                lambda tmp: self.to_frame().to_csv(
                    tmp, index=False, float_format="%.9g"
                ),
            ),
        ]
        if c:
            written.extend(write_c(self, out))
        if openfoam:
            try:
                foam = {"demo_family": demo_family, **(condition or {})}
                written.extend(write_openfoam(self, out, **foam))
            except ValueError as err:
                if condition:  # the caller's condition: their error to fix
                    raise
                warnings.warn(
                    f"no OpenFOAM localInteraction dictionaries written: {err}",
                    RuntimeWarning,
                    stacklevel=2,
                )
                foam = {"demo_family": demo_family}
                written.extend(write_stochastic_model(self, out, **foam))
        return written

    def _write_netcdf(self, path):
        ds = self.dataset.copy()
        ds["surface"] = ds["surface"].astype(str)
        ds = surfaces_to_cf(ds)  # CF: a numeric index, the names aside
        ds.to_netcdf(path, engine="netcdf4", encoding=encoding(ds))
