"""The nodes of a wall law: the scenario's ``[wall_law]`` table.

A wall law tabulates, at every node (surface, diameter, speed, angle), the outcome
of an impact at that *fixed* diameter, with every other random input (the roughness
angle, the particle's roughness, the speed scatter) kept at its distribution. The
nodes are the product of three sorted axes; :class:`WallLawSpec` holds them and
validates itself (the TOML layer, :mod:`microimpact.config`, only maps its errors
onto key paths).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ScenarioError

__all__ = ["DEFAULT_QUANTILES", "WallLawSpec"]

#: Probability levels of the tabulated quantiles.
DEFAULT_QUANTILES = (0.01, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.99)

#: Variables tabulated over the rebounds of a node (quantiles, mean, std).
REBOUND_VARIABLES = ("e_n", "e_t", "mu", "rebound_angle_deg", "lateral_angle_deg")
#: Variables held in the reservoirs (joint samples, in draw order).
RESERVOIR_VARIABLES = ("e_n", "mu", "e_t", "lateral_angle_deg", "speed_ratio")

#: Largest reservoir: values per node kept for the sampler.
MAX_RESERVOIR = 1_000_000

#: Largest table: reservoir values (nodes x K x 4 variables) held in memory.
MAX_RESERVOIR_VALUES = 2**30 // 8  # 1 GiB of float64


def _axis(values, field, *, low, high=math.inf, high_inclusive=False) -> tuple:
    try:
        arr = np.asarray(values, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ScenarioError(f"must be numbers; got {values!r}", field=field) from None
    if arr.size == 0:
        raise ScenarioError("must not be empty", field=field)
    for i, v in enumerate(arr):
        ok = low < v and (v <= high if high_inclusive else v < high)
        if not (ok and math.isfinite(v)):
            bound = f"<= {high:g}" if high_inclusive else f"< {high:g}"
            rng = f"> {low:g}" + ("" if math.isinf(high) else f" and {bound}")
            raise ScenarioError(f"must be {rng}; got {v:g} (value {i})", field=field)
    # the nodes of an interpolation table: sorted, each once
    return tuple(float(v) for v in np.unique(arr))


@dataclass(frozen=True)
class WallLawSpec:
    """Nodes and sample sizes of a wall law.

    Parameters
    ----------
    diameters_um : sequence of float
        Particle diameters of the nodes [µm] (> 0). Sorted; repeats are dropped.
    speeds_m_s : sequence of float
        Nominal incident speeds [m s-1] (> 0).
    angles_deg : sequence of float
        Apparent incidence angles from the wall plane [deg], in (0, 90].
    reservoir : int
        Joint rebound samples K kept per node for the sampler (default 256).
    samples : int, optional
        Draws per node (default: the scenario's ``samples``).
    quantiles : sequence of float
        Probability levels of the tabulated quantiles, in (0, 1).
    """

    diameters_um: tuple
    speeds_m_s: tuple
    angles_deg: tuple
    reservoir: int = 256
    samples: int | None = None
    quantiles: tuple = DEFAULT_QUANTILES

    def __post_init__(self):
        set_ = object.__setattr__
        set_(
            self,
            "diameters_um",
            _axis(self.diameters_um, "wall_law.diameter_um", low=0),
        )
        set_(self, "speeds_m_s", _axis(self.speeds_m_s, "wall_law.speed_m_s", low=0))
        set_(
            self,
            "angles_deg",
            _axis(
                self.angles_deg,
                "wall_law.angle_deg",
                low=0,
                high=90,
                high_inclusive=True,
            ),
        )
        set_(
            self,
            "quantiles",
            _axis(self.quantiles, "wall_law.quantiles", low=0, high=1),
        )
        for name, value, top in (
            ("reservoir", self.reservoir, MAX_RESERVOIR),
            ("samples", self.samples, None),
        ):
            if value is None and name == "samples":
                continue
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise ScenarioError(
                    f"must be an integer >= 1; got {value!r}", field=f"wall_law.{name}"
                )
            if value < 1 or (top is not None and value > top):
                allowed = ">= 1" if top is None else f"in [1, {top:,}]"
                raise ScenarioError(
                    f"must be an integer {allowed}; got {value!r}",
                    field=f"wall_law.{name}",
                )
            set_(self, name, int(value))

    @property
    def shape(self) -> tuple[int, int, int]:
        """(diameters, speeds, angles)."""
        return (len(self.diameters_um), len(self.speeds_m_s), len(self.angles_deg))

    @property
    def nodes(self) -> int:
        """Nodes per surface."""
        d, v, a = self.shape
        return d * v * a

    def check_size(self, surfaces: int) -> None:
        """Refuse a table whose reservoirs would not fit in memory."""
        values = surfaces * self.nodes * self.reservoir * 5
        if values > MAX_RESERVOIR_VALUES:
            raise ScenarioError(
                f"{surfaces} surface(s) x {self.nodes:,} nodes x {self.reservoir:,} "
                f"samples x 5 variables = {values:,} values, more than "
                f"{MAX_RESERVOIR_VALUES:,} (1 GiB); use fewer nodes or a smaller "
                "reservoir",
                field="wall_law.reservoir",
            )
