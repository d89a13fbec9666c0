"""A stochastic wall law for CFD and particle-tracking codes (docs/wall-law.md).

:func:`build_wall_law` runs the engine at every node (surface, diameter, speed,
angle) of a ``[wall_law]`` table and returns a :class:`WallLaw`: capture
probabilities with Wilson intervals, quantiles of the rebound, and reservoirs of
joint rebound samples that :meth:`WallLaw.sample` (and the C sampler it exports)
draw from.
"""

from ..scenario.wall_law import WallLawSpec
from .build import (
    build_wall_law,
    critical_speed_m_s,
    node_outcomes,
)
from .export_c import (
    read_binary,
    write_binary,
    write_c,
)
from .law import (
    WallLaw,
    WallLawSample,
    wall_law_dataset,
)
from .openfoam import (
    LOCAL_INTERACTION_FILE,
    LOCAL_PATCHES_FILE,
    STOCHASTIC_FILE,
    fallback_condition,
    openfoam_coefficients,
    write_demo_case,
    write_openfoam,
    write_stochastic_model,
)

__all__ = [
    "LOCAL_INTERACTION_FILE",
    "LOCAL_PATCHES_FILE",
    "STOCHASTIC_FILE",
    "WallLaw",
    "WallLawSample",
    "WallLawSpec",
    "build_wall_law",
    "critical_speed_m_s",
    "fallback_condition",
    "node_outcomes",
    "openfoam_coefficients",
    "read_binary",
    "wall_law_dataset",
    "write_binary",
    "write_c",
    "write_demo_case",
    "write_openfoam",
    "write_stochastic_model",
]
