"""What a wall law's node spacing costs between nodes, from the table itself.

Between nodes the sampler mixes the corners' distributions, so its capture
probability is the linear interpolation of the nodes' in the axis' variable
(docs/wall-law.md, "The sampling rule"). Where the true capture probability is
monotone between two neighbouring nodes (in speed it is: faster impacts rebound
more), both it and the interpolated value lie between the two nodes' values, so
the interpolation error within that cell is at most the change of capture across
it. The largest such change on an axis bounds the sampler's capture error
between nodes there; it sits at the capture edge, where capture falls from 1 to
0. ``benchmarks/wall_law.py capture`` measures the actual error against direct
runs; this bound needs no run and is printed by ``microimpact wall-law``.
Monte Carlo noise of the nodes (at most 0.5 / sqrt(impacts)) adds to it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["CaptureStep", "capture_steps"]

_UNITS = {
    "diameter_um": "um",
    "speed_m_s": "m/s",
    "reduced_speed": "v/v_c",
    "angle_deg": "deg",
}


@dataclass(frozen=True)
class CaptureStep:
    """The largest change of capture probability between neighbouring nodes of
    one axis: a bound on the sampler's capture error between nodes there, where
    capture is monotone.

    Attributes
    ----------
    axis : str
        The axis (``"diameter_um"``, ``"speed_m_s"`` or ``"reduced_speed"``,
        ``"angle_deg"``).
    step : float
        The change of capture probability across the cell (NaN where the axis has
        one node or no cell has two nodes with impacts).
    between : tuple of float
        The two node values of the cell, in the axis' unit.
    at : dict
        The cell's other coordinates: surface and the other two axes' nodes.
    """

    axis: str
    step: float
    between: tuple
    at: dict

    def describe(self) -> str:
        """One phrase: the step, the cell and where it lies."""
        if not math.isfinite(self.step):
            return f"{self.axis}: no cell"
        unit = _UNITS.get(self.axis, "")
        where = ", ".join(
            f"{k} {v:g}" if isinstance(v, float) else f"{k} {v!r}"
            for k, v in self.at.items()
        )
        name = self.axis.removesuffix("_um").removesuffix("_m_s").removesuffix("_deg")
        return (
            f"{self.step:.2g} across {name} {self.between[0]:g}-{self.between[1]:g} "
            f"{unit} ({where})"
        )


def capture_steps(law) -> list[CaptureStep]:
    """The largest capture change between neighbouring nodes along each axis of
    `law` (a WallLaw or its Dataset): diameter, speed, angle, in that order."""
    ds = getattr(law, "dataset", law)
    speed = "reduced_speed" if "reduced_speed" in ds.dims else "speed_m_s"
    dims = ("surface", "diameter_um", speed, "angle_deg")
    p = np.asarray(ds["capture_probability"].transpose(*dims).values, dtype=float)
    coords = {d: ds[d].values for d in dims}
    out = []
    for k, axis in enumerate(dims[1:], start=1):
        if p.shape[k] < 2:
            out.append(CaptureStep(axis, math.nan, (math.nan, math.nan), {}))
            continue
        step = np.abs(np.diff(p, axis=k))
        if not np.isfinite(step).any():
            out.append(CaptureStep(axis, math.nan, (math.nan, math.nan), {}))
            continue
        index = np.unravel_index(int(np.nanargmax(step)), step.shape)
        i = index[k]
        at = {"surface": str(coords["surface"][index[0]])}
        for j, other in enumerate(dims[1:], start=1):
            if j != k:
                at[other] = float(coords[other][index[j]])
        out.append(
            CaptureStep(
                axis,
                float(step[index]),
                (float(coords[axis][i]), float(coords[axis][i + 1])),
                at,
            )
        )
    return out
