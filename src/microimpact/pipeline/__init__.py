"""The pipeline of `microimpact run`: study, output folder, figures, report."""

from .figures import (
    distribution_speed,
    figure_caption,
    figures_for_result,
    result_figures,
)
from .folder import (
    CHECKPOINT_NAME,
    LOCK_NAME,
    MANIFEST_NAME,
    OutputFolder,
    OutputFolderBusy,
)
from .report import (
    summary_text,
    write_report,
)
from .resuspension import (
    RESUSPENSION_FILES,
    resuspension_section_html,
    write_resuspension,
)
from .study import (
    Outputs,
    Study,
    reproduce,
)

__all__ = [
    "CHECKPOINT_NAME",
    "LOCK_NAME",
    "MANIFEST_NAME",
    "RESUSPENSION_FILES",
    "OutputFolder",
    "OutputFolderBusy",
    "Outputs",
    "Study",
    "distribution_speed",
    "figure_caption",
    "figures_for_result",
    "reproduce",
    "result_figures",
    "resuspension_section_html",
    "summary_text",
    "write_report",
    "write_resuspension",
]
