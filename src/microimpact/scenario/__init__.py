"""The scenario layer: the validated description of a study (physics only), its
sweep grid, output settings, the wall law's and the sensitivity study's tables, and
the scenario file (TOML -> these objects, read once)."""

from .scenario import (
    PRECISION_STATISTICS,
    SAMPLING_OPTIONS,
    SHADOWING_OPTIONS,
    Precision,
    Scenario,
    SurfaceVariant,
    as_scenario,
    scenario_file,
)

__all__ = [
    "PRECISION_STATISTICS",
    "SAMPLING_OPTIONS",
    "SHADOWING_OPTIONS",
    "Precision",
    "Scenario",
    "SurfaceVariant",
    "as_scenario",
    "scenario_file",
]
