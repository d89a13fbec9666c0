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
from .resuspension import (
    ResuspensionResult,
    resuspend,
    sample_remaining_fraction,
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
    "ResuspensionResult",
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
    "resuspend",
    "robustness_study",
    "sample_remaining_fraction",
    "sobol_analysis",
    "sobol_sensitivity",
    "verdict_word",
]
