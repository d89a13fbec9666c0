"""Studies over studies: the scenario model at parameter values, comparison with
experiments, Sobol' sensitivity, calibration."""

from .calibration import (
    CalibrationResult,
    calibrate,
    default_bounds,
    parse_parameter,
)
from .compare import (
    SIMULATED,
    compare,
)
from .model import (
    ScenarioModel,
)
from .sensitivity import (
    COLUMNS,
    EngineModel,
    SensitivityResult,
    sobol_analysis,
    sobol_sensitivity,
)

__all__ = [
    "COLUMNS",
    "SIMULATED",
    "CalibrationResult",
    "EngineModel",
    "ScenarioModel",
    "SensitivityResult",
    "calibrate",
    "compare",
    "default_bounds",
    "parse_parameter",
    "sobol_analysis",
    "sobol_sensitivity",
]
