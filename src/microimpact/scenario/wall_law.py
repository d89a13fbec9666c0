"""The nodes of a wall law: the scenario's ``[wall_law]`` table.

A wall law tabulates, at every node (surface, diameter, speed, angle), the outcome
of an impact at that *fixed* diameter, with every other random input (the roughness
angle, the particle's roughness, the speed scatter) kept at its distribution. The
nodes are the product of three sorted axes; :class:`WallLawSpec` holds them and
validates itself (the TOML layer, :mod:`microimpact.scenario.file`, only maps its errors
onto key paths).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ScenarioError
from .parts import _integer, _positive_tuple

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
    """A node axis: the scenario's checked numbers, then sorted, each once (the
    nodes of an interpolation table)."""
    checked = _positive_tuple(
        values, field, lo=low, hi=high, hi_inclusive=high_inclusive
    )
    return tuple(float(v) for v in np.unique(checked))


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
        set_(self, "reservoir", _integer(self.reservoir, "wall_law.reservoir", 1))
        if self.reservoir > MAX_RESERVOIR:
            raise ScenarioError(
                f"must be an integer in [1, {MAX_RESERVOIR:,}]; got {self.reservoir!r}",
                field="wall_law.reservoir",
            )
        if self.samples is not None:
            set_(self, "samples", _integer(self.samples, "wall_law.samples", 1))

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
