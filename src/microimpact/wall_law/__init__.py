"""A stochastic wall law for CFD and particle-tracking codes (docs/wall-law.md).

:func:`build_wall_law` runs the engine at every node (surface, diameter, speed,
angle) of a ``[wall_law]`` table and returns a :class:`WallLaw`: capture
probabilities with Wilson intervals, quantiles of the rebound, and reservoirs of
joint rebound samples that :meth:`WallLaw.sample` (and the C sampler it exports)
draw from.
"""

from ..scenario.wall_law import WallLawSpec
from .build import build_wall_law
from .law import WallLaw, WallLawSample

__all__ = ["WallLaw", "WallLawSample", "WallLawSpec", "build_wall_law"]
