"""The sweep grid: the one owner of the order and coordinates of a study's points.

A study simulates every combination of its sweep axes. Today these are the surface
variant, the nominal incident speed and the apparent incidence angle; later axes (a
fixed diameter for a wall law, an impact azimuth for areal roughness) are added here
and nowhere else. Everything that numbers sweep points, reshapes per-point values into
arrays, or names a point's coordinates asks this object:

* the engine numbers its points with :meth:`SweepGrid.points` (point ``i`` is the
  ``i``-th combination in C order of :attr:`SweepGrid.dims`);
* the result reshapes per-point arrays with :meth:`SweepGrid.reshape` into the
  Dataset's ``(surface, speed_m_s, angle_deg)`` dimensions;
* the convergence study and the reports name a point with :meth:`SweepGrid.coords`.

So adding an axis cannot silently scramble ``results.nc``: there is no other copy of
the rule.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["GridPoint", "GridPoints", "SweepGrid"]

#: Names of the sweep dimensions, in the order of the point numbering (C order).
DIMS = ("surface", "speed_m_s", "angle_deg")


@dataclass(frozen=True)
class GridPoint:
    """One sweep point: surface variant x incident speed x apparent angle.

    Attributes
    ----------
    index : int
        The point's number (its row in ``summary.csv``).
    surface : int
        Index of the surface variant.
    surface_name : str
        Its name.
    speed : float
        Nominal incident speed [m s-1].
    angle_deg : float
        Apparent incidence angle from the nominal plane [deg].
    """

    index: int
    surface: int
    surface_name: str
    speed: float
    angle_deg: float


@dataclass(frozen=True)
class SweepGrid:
    """The sweep axes of a study and the numbering of its points.

    Attributes
    ----------
    surfaces : tuple of str
        Surface variant names (the ``surface`` coordinate).
    speeds_m_s : tuple of float
        Nominal incident speeds [m s-1] (the ``speed_m_s`` coordinate).
    angles_deg : tuple of float
        Apparent incidence angles [deg] (the ``angle_deg`` coordinate).
    """

    surfaces: tuple
    speeds_m_s: tuple
    angles_deg: tuple

    def __post_init__(self):
        for name in ("surfaces", "speeds_m_s", "angles_deg"):
            values = tuple(getattr(self, name))
            if not values:
                raise ValueError(f"`{name}` must not be empty.")
            object.__setattr__(self, name, values)

    @classmethod
    def from_scenario(cls, scenario) -> SweepGrid:
        """The grid of a :class:`~microimpact.scenario.scenario.Scenario`."""
        return cls(
            tuple(s.name for s in scenario.surfaces),
            tuple(float(v) for v in scenario.speeds_m_s),
            tuple(float(a) for a in scenario.angles_deg),
        )

    @property
    def dims(self) -> tuple[str, ...]:
        """Dimension names, in the order of the point numbering."""
        return DIMS

    @property
    def shape(self) -> tuple[int, ...]:
        """Number of values along each dimension."""
        return (len(self.surfaces), len(self.speeds_m_s), len(self.angles_deg))

    @property
    def size(self) -> int:
        """Number of sweep points."""
        return math.prod(self.shape)

    def __len__(self) -> int:
        return self.size

    def coordinates(self) -> dict[str, tuple]:
        """``{dimension: values}`` for every dimension."""
        values = (self.surfaces, self.speeds_m_s, self.angles_deg)
        return dict(zip(self.dims, values, strict=True))

    def unravel(self, index: int) -> tuple[int, ...]:
        """The per-dimension indices of point `index`."""
        if not 0 <= index < self.size:
            raise IndexError(f"point {index} is outside 0..{self.size - 1}.")
        _, n_v, n_a = self.shape
        rest, a = divmod(int(index), n_a)
        s, v = divmod(rest, n_v)
        return s, v, a  # C order of dims (numpy's unravel_index, per point)

    def point(self, index: int) -> GridPoint:
        """Point `index` with its coordinates."""
        s, v, a = self.unravel(index)
        return GridPoint(
            index, s, self.surfaces[s], self.speeds_m_s[v], self.angles_deg[a]
        )

    def points(self) -> Iterator[GridPoint]:
        """Every point, in numbering order (C order of :attr:`dims`)."""
        combos = itertools.product(
            enumerate(self.surfaces), self.speeds_m_s, self.angles_deg
        )
        for i, ((s, name), speed, angle) in enumerate(combos):
            yield GridPoint(i, s, name, speed, angle)

    def columns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every point's surface index, speed [m s-1] and angle [deg], as arrays
        in numbering order (the values :meth:`points` gives, without an object
        per point)."""
        s, v, a = np.unravel_index(np.arange(self.size), self.shape)
        speeds = np.asarray(self.speeds_m_s, dtype=float)
        angles = np.asarray(self.angles_deg, dtype=float)
        return s.astype(np.int64), speeds[v], angles[a]

    def coords(self, index: int) -> dict:
        """``{"surface": name, "speed_m_s": v, "angle_deg": a}`` of point `index`."""
        p = self.point(index)
        return {
            "surface": p.surface_name,
            "speed_m_s": p.speed,
            "angle_deg": p.angle_deg,
        }

    def reshape(self, values) -> np.ndarray:
        """Per-point values (leading axis: point number) as an array whose leading
        axes are :attr:`dims`; trailing axes (e.g. histogram bins) are kept."""
        a = np.asarray(values)
        if a.shape[:1] != (self.size,):
            raise ValueError(
                f"expected {self.size} per-point values along the first axis; "
                f"got shape {a.shape}."
            )
        return a.reshape(self.shape + a.shape[1:])

    def flat_columns(self) -> dict[str, np.ndarray]:
        """The coordinate of every point, one array per dimension (numbering
        order): the leading columns of the summary table."""
        idx = np.unravel_index(np.arange(self.size), self.shape)
        return {
            dim: np.asarray(values, dtype=object if dim == "surface" else float)[i]
            for (dim, values), i in zip(self.coordinates().items(), idx, strict=True)
        }


class GridPoints(Sequence):
    """The points of a grid as a sequence, each built when it is asked for: what
    ``tuple(grid.points())`` holds, without 10^6 objects made before a run
    starts (and a small pickle for the workers). :meth:`columns` gives them as
    arrays."""

    __slots__ = ("grid",)

    def __init__(self, grid: SweepGrid):
        self.grid = grid

    def __len__(self) -> int:
        return self.grid.size

    def __getitem__(self, index):
        if isinstance(index, slice):
            return tuple(self[i] for i in range(*index.indices(len(self))))
        index = int(index)
        if index < 0:
            index += len(self)
        return self.grid.point(index)

    def __iter__(self) -> Iterator[GridPoint]:
        return self.grid.points()

    def __reduce__(self):
        return (GridPoints, (self.grid,))

    def __repr__(self) -> str:
        return f"GridPoints({self.grid!r})"

    def columns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`SweepGrid.columns`."""
        return self.grid.columns()

    def tables(self) -> tuple[np.ndarray, list]:
        """``(table, keys)``: each point's index in `keys`, the (surface index,
        angle [deg]) pairs of the grid (surface-major)."""
        n_s, _, n_a = self.grid.shape
        s, _, a = np.unravel_index(np.arange(self.grid.size), self.grid.shape)
        keys = [(i, float(x)) for i in range(n_s) for x in self.grid.angles_deg]
        return (s * n_a + a).astype(np.int64), keys
