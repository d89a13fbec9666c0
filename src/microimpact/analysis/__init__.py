"""Studies over studies: the scenario model at parameter values, comparison with
experiments, Sobol' sensitivity, calibration (least squares and Bayesian, with the
posterior's wall law), and the paper's statements checked against results and judged
over the unknown Formica surface."""

from .bayes import (
    BayesResult,
    calibrate_bayes,
)
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
from .priors import (
    Prior,
    make_prior,
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
from .wall_law_posterior import (
    posterior_draws,
    posterior_wall_law,
)

__all__ = [
    "COLUMNS",
    "SIMULATED",
    "STATEMENTS",
    "BayesResult",
    "CalibrationResult",
    "EngineModel",
    "Evidence",
    "Prior",
    "ResuspensionResult",
    "RobustnessStudy",
    "ScenarioModel",
    "SensitivityResult",
    "Statement",
    "Verdict",
    "calibrate",
    "calibrate_bayes",
    "compare",
    "default_bounds",
    "evaluate",
    "make_prior",
    "parse_parameter",
    "posterior_draws",
    "posterior_wall_law",
    "resuspend",
    "robustness_study",
    "sample_remaining_fraction",
    "sobol_analysis",
    "sobol_sensitivity",
    "verdict_word",
]
