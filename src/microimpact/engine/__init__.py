"""The Monte Carlo engine: plan, kernels, accumulators, scheduling, resume, and the
result."""

from .capture import (
    LACK_OF_FIT_LEVEL,
    WINDOW_MARGIN,
    CaptureSpeedEstimate,
    crossing_window,
    estimate_capture_speed,
)
from .checkpoint import (
    Checkpoint,
    CheckpointWarning,
)
from .convergence import (
    ConvergenceResult,
    convergence_study,
)
from .dataset import (
    SUMMARY_COLUMNS,
    VARIABLES,
)
from .montecarlo import (
    BlockResult,
    estimate_duration,
    iter_blocks,
    run,
    sample_point,
)
from .parallel import (
    dask_client,
)
from .plan import (
    Plan,
    build_plan,
)
from .result import (
    ScenarioRecord,
    SimulationResult,
    open_result,
)
from .statistics import (
    capture_speed,
    relative_coefficients,
    wilson_interval,
    z_value,
)

__all__ = [
    "LACK_OF_FIT_LEVEL",
    "SUMMARY_COLUMNS",
    "VARIABLES",
    "WINDOW_MARGIN",
    "BlockResult",
    "CaptureSpeedEstimate",
    "Checkpoint",
    "CheckpointWarning",
    "ConvergenceResult",
    "Plan",
    "ScenarioRecord",
    "SimulationResult",
    "build_plan",
    "capture_speed",
    "convergence_study",
    "crossing_window",
    "dask_client",
    "estimate_capture_speed",
    "estimate_duration",
    "iter_blocks",
    "open_result",
    "relative_coefficients",
    "run",
    "sample_point",
    "wilson_interval",
    "z_value",
]
