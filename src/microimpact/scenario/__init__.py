"""The scenario layer: the validated description of a study (physics only), its
sweep grid, output settings, the wall law's and the sensitivity study's tables, and
the scenario file (TOML -> these objects, read once)."""

from .._core.toml import coefficients_snippet, particles_snippet, surface_snippet
from .file import PRESETS, list_presets, preset_path
from .grid import GridPoint, SweepGrid
from .outputs import Outputs
from .parts import (
    PRECISION_STATISTICS,
    SAMPLING_OPTIONS,
    SHADOWING_OPTIONS,
    Precision,
    SurfaceVariant,
)
from .scenario import (
    Scenario,
    ScenarioFile,
    as_scenario,
    load_preset,
    read_scenario,
    scenario_file,
    scenario_file_from_dict,
    scenario_from_dict,
    scenario_from_toml,
)
from .sensitivity import SensitivitySettings
from .wall_law import WallLawSpec

__all__ = [
    "PRECISION_STATISTICS",
    "PRESETS",
    "SAMPLING_OPTIONS",
    "SHADOWING_OPTIONS",
    "GridPoint",
    "Outputs",
    "Precision",
    "Scenario",
    "ScenarioFile",
    "SensitivitySettings",
    "SurfaceVariant",
    "SweepGrid",
    "WallLawSpec",
    "as_scenario",
    "coefficients_snippet",
    "list_presets",
    "load_preset",
    "particles_snippet",
    "preset_path",
    "read_scenario",
    "scenario_file",
    "scenario_file_from_dict",
    "scenario_from_dict",
    "scenario_from_toml",
    "surface_snippet",
]
