"""Readers of the user's files: diameters, profiles, height maps, impact data,
experiments."""

from .areal import (
    HeightMap,
    read_height_map,
)
from .diameters import (
    read_diameters,
    read_histogram,
)
from .experiments import (
    COORDINATES,
    STATISTICS,
    combine_experiments,
    read_experiments,
    scenario_experiments,
)
from .impact_data import (
    E_MAX,
    REQUIRED_COLUMNS,
    read_impact_data,
)
from .profiles import (
    Profile,
    ProfileSet,
    read_profile,
    read_profiles,
)
from .size_bins import (
    SIZE_LAYOUTS,
    read_size_bins,
    read_size_data,
)

__all__ = [
    "COORDINATES",
    "E_MAX",
    "REQUIRED_COLUMNS",
    "SIZE_LAYOUTS",
    "STATISTICS",
    "HeightMap",
    "Profile",
    "ProfileSet",
    "combine_experiments",
    "read_diameters",
    "read_experiments",
    "read_height_map",
    "read_histogram",
    "read_impact_data",
    "read_profile",
    "read_profiles",
    "read_size_bins",
    "read_size_data",
    "scenario_experiments",
]
