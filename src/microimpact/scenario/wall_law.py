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

from .._core.validation import as_field_error, check_choice
from ..errors import ScenarioError
from ..population.distributions import _plausible_um
from .parts import _integer, _plausible_speeds, _positive_tuple

__all__ = ["DEFAULT_QUANTILES", "SPEED_AXES", "WallLawSpec"]

#: The kinds of speed axis of a table: nodes at fixed speeds [m s-1], or at fixed
#: reduced speeds v / v_c(d), which follow the capture edge (docs/wall-law.md).
SPEED_AXES = ("absolute", "reduced")

#: The ratios v / v_c(d) a reduced speed axis accepts, (low, high]: capture turns
#: into rebound at r = 1, and far beyond a thousandfold either side a table only
#: repeats its end nodes (the speeds r v_c(d) must also be plausible, checked where
#: v_c is known: ``wall_law.build``).
REDUCED_SPEED_RANGE = (1e-3, 1e3)

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


def _axis(
    values, field, *, low, high=math.inf, high_inclusive=False, log=False
) -> tuple:
    """A node axis: the scenario's checked numbers, then sorted, each once (the
    nodes of an interpolation table). On a `log` axis (the table interpolates in
    the logarithm, and its readers refuse nodes equal there) two numbers whose
    logarithms are equal are refused: e.g. 80 and 79.99999999999999."""
    checked = _positive_tuple(
        values, field, lo=low, hi=high, hi_inclusive=high_inclusive
    )
    nodes = np.unique(checked)
    if log and nodes.size > 1:
        same = np.flatnonzero(np.diff(np.log(nodes)) <= 0)
        if same.size:
            a, b = float(nodes[same[0]]), float(nodes[same[0] + 1])
            raise ScenarioError(
                f"{a!r} and {b!r} are one node on the table's logarithmic axis "
                "(their logarithms are equal); allowed: nodes that differ in log",
                field=field,
            )
    return tuple(float(v) for v in nodes)


@dataclass(frozen=True)
class WallLawSpec:
    """Nodes and sample sizes of a wall law.

    Parameters
    ----------
    diameters_um : sequence of float
        Particle diameters of the nodes [µm] (> 0). Sorted; repeats are dropped.
    speeds_m_s : sequence of float or None
        Nominal incident speeds [m s-1] (> 0) of an ``"absolute"`` speed axis;
        None with a ``"reduced"`` one.
    angles_deg : sequence of float
        Apparent incidence angles from the wall plane [deg], in (0, 90].
    reservoir : int
        Joint rebound samples K kept per node for the sampler (default 256).
    samples : int, optional
        Draws per node (default: the scenario's ``samples``).
    quantiles : sequence of float
        Probability levels of the tabulated quantiles, in (0, 1).
    speed_axis : {"absolute", "reduced"}
        ``"absolute"`` (default): the speed nodes are `speeds_m_s`, the same at
        every diameter. ``"reduced"``: the speed nodes are ``r v_c(d)`` for each
        ratio r of `reduced_speeds` at each diameter node d, with v_c(d) the
        scenario's critical (capture) speed at normal incidence on a smooth
        surface (paper Eq. 5, the coefficient law ``v_c``), so that the nodes
        follow the capture edge.
    reduced_speeds : sequence of float, optional
        The ratios r = v / v_c(d) (> 0) of a ``"reduced"`` speed axis.
    fallback_at : dict, optional
        ``{"diameter_um": ..., "speed_m_s": ..., "angle_deg": ...}`` (any of
        them): the condition whose node the compiler-less OpenFOAM fallback
        applies (``microimpact wall-law``'s ``--diameter-um`` etc. win over it);
        default: the mean rebound over the whole table.
    """

    diameters_um: tuple
    speeds_m_s: tuple
    angles_deg: tuple
    reservoir: int = 256
    samples: int | None = None
    quantiles: tuple = DEFAULT_QUANTILES
    speed_axis: str = "absolute"
    reduced_speeds: tuple | None = None
    fallback_at: dict | None = None

    def __post_init__(self):
        set_ = object.__setattr__
        set_(
            self,
            "diameters_um",
            _axis(self.diameters_um, "wall_law.diameter_um", low=0, log=True),
        )
        for d in self.diameters_um:  # a unit mistake, refused before any build
            try:
                _plausible_um(d, "diameter_um")
            except ValueError as exc:
                raise ScenarioError(
                    str(exc).rstrip("."), field="wall_law.diameter_um"
                ) from None
        with as_field_error("wall_law.speed_axis", ScenarioError):
            set_(
                self,
                "speed_axis",
                check_choice(self.speed_axis, "wall_law.speed_axis", SPEED_AXES),
            )
        if self.speed_axis == "reduced":
            if self.reduced_speeds is None:
                raise ScenarioError(
                    'speed_axis = "reduced" needs the ratios v / v_c(d) of its '
                    "nodes: give reduced_speed (a list or a range table)",
                    field="wall_law.reduced_speed",
                )
            if self.speeds_m_s is not None:
                raise ScenarioError(
                    'with speed_axis = "reduced" the speed nodes are '
                    "reduced_speed x v_c(d); drop speed_m_s (got "
                    f"{self.speeds_m_s!r})",
                    field="wall_law.speed_m_s",
                )
            set_(
                self,
                "reduced_speeds",
                _axis(
                    self.reduced_speeds,
                    "wall_law.reduced_speed",
                    low=REDUCED_SPEED_RANGE[0],
                    high=REDUCED_SPEED_RANGE[1],
                    high_inclusive=True,
                    log=True,
                ),
            )
        else:
            if self.reduced_speeds is not None:
                raise ScenarioError(
                    'reduced_speed is the speed axis of speed_axis = "reduced"; '
                    f'set speed_axis = "reduced" (got "{self.speed_axis}") or drop '
                    "reduced_speed",
                    field="wall_law.reduced_speed",
                )
            if self.speeds_m_s is None:
                raise ScenarioError(
                    "missing: the speed nodes [m/s] of the absolute speed axis",
                    field="wall_law.speed_m_s",
                )
            set_(
                self,
                "speeds_m_s",
                _axis(self.speeds_m_s, "wall_law.speed_m_s", low=0, log=True),
            )
            _plausible_speeds(self.speeds_m_s, "wall_law.speed_m_s")
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
    def speed_nodes(self) -> tuple:
        """The speed axis' values: `speeds_m_s` [m s-1] or `reduced_speeds` [1]."""
        return self.reduced_speeds if self.speed_axis == "reduced" else self.speeds_m_s

    @property
    def shape(self) -> tuple[int, int, int]:
        """(diameters, speeds, angles)."""
        return (len(self.diameters_um), len(self.speed_nodes), len(self.angles_deg))

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
