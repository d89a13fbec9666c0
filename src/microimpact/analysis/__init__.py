"""Studies over studies: the scenario model at parameter values, comparison with
experiments, Sobol' sensitivity, calibration, and the paper's statements checked
against results and judged over the unknown Formica surface."""

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
from .robustness import (
    RobustnessStudy,
    robustness_study,
    verdict_word,
)
from .sensitivity import (
    COLUMNS,
    EngineModel,
    SensitivityResult,
    sobol_analysis,
    sobol_sensitivity,
)
from .statements import (
    STATEMENTS,
    Evidence,
    Statement,
    Verdict,
    evaluate,
)

__all__ = [
    "COLUMNS",
    "SIMULATED",
    "STATEMENTS",
    "CalibrationResult",
    "EngineModel",
    "Evidence",
    "RobustnessStudy",
    "ScenarioModel",
    "SensitivityResult",
    "Statement",
    "Verdict",
    "calibrate",
    "compare",
    "default_bounds",
    "evaluate",
    "parse_parameter",
    "robustness_study",
    "sobol_analysis",
    "sobol_sensitivity",
    "verdict_word",
]
