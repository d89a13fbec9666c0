"""The scenario layer: the validated description of a study (physics only), its
sweep grid, output settings, the wall law's and the sensitivity study's tables, and
the scenario file (TOML -> these objects, read once)."""

from .._core.toml import (
    coefficients_snippet,
    particles_snippet,
    surface_snippet,
)
from .file import (
    PAPER_PRESETS,
    PRESET_DIR,
    PRESETS,
    ParsedScenario,
    list_presets,
    outputs_from_dict,
    outputs_from_toml,
    parse_scenario,
    preset_path,
    read_toml,
    read_toml_text,
    wall_law_from_dict,
    wall_law_from_toml,
)
from .grid import (
    GridPoint,
    SweepGrid,
)
from .outputs import (
    Outputs,
)
from .parameters import (
    NOT_PARAMETERS,
    check_parameter_key,
    get_value,
    numeric_keys,
    with_values,
)
from .parts import (
    PRECISION_STATISTICS,
    SAMPLING_OPTIONS,
    SHADOWING_OPTIONS,
)
from .resuspension import (
    ResuspensionSpec,
    resuspension_from_dict,
)
from .scenario import (
    Precision,
    Scenario,
    ScenarioFile,
    SurfaceVariant,
    as_scenario,
    load_preset,
    read_scenario,
    scenario_file,
    scenario_file_from_dict,
    scenario_from_dict,
    scenario_from_toml,
)
from .sensitivity import (
    DEFAULT_BASE_SIZE,
    DEFAULT_RESAMPLES,
    DEFAULT_STATISTICS,
    DISTRIBUTIONS,
    SENSITIVITY_KEYS,
    STATISTICS,
    SensitivitySettings,
    parameter_distribution,
    sensitivity_from_dict,
)
from .wall_law import (
    DEFAULT_QUANTILES,
    WallLawSpec,
)

__all__ = [
    "DEFAULT_BASE_SIZE",
    "DEFAULT_QUANTILES",
    "DEFAULT_RESAMPLES",
    "DEFAULT_STATISTICS",
    "DISTRIBUTIONS",
    "NOT_PARAMETERS",
    "PAPER_PRESETS",
    "PRECISION_STATISTICS",
    "PRESETS",
    "PRESET_DIR",
    "SAMPLING_OPTIONS",
    "SENSITIVITY_KEYS",
    "SHADOWING_OPTIONS",
    "STATISTICS",
    "GridPoint",
    "Outputs",
    "ParsedScenario",
    "Precision",
    "ResuspensionSpec",
    "Scenario",
    "ScenarioFile",
    "SensitivitySettings",
    "SurfaceVariant",
    "SweepGrid",
    "WallLawSpec",
    "as_scenario",
    "check_parameter_key",
    "coefficients_snippet",
    "get_value",
    "list_presets",
    "load_preset",
    "numeric_keys",
    "outputs_from_dict",
    "outputs_from_toml",
    "parameter_distribution",
    "parse_scenario",
    "particles_snippet",
    "preset_path",
    "read_scenario",
    "read_toml",
    "read_toml_text",
    "resuspension_from_dict",
    "scenario_file",
    "scenario_file_from_dict",
    "scenario_from_dict",
    "scenario_from_toml",
    "sensitivity_from_dict",
    "surface_snippet",
    "wall_law_from_dict",
    "wall_law_from_toml",
    "with_values",
]
