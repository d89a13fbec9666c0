"""Figure functions (matplotlib loads only when a figure is drawn)."""

from .areal import (
    plot_profile_vs_areal,
)
from .calibration import (
    plot_calibration,
)
from .comparison import (
    plot_comparison,
)
from .results import (
    FIGURE_FORMATS,
    plot_capture,
    plot_coefficients_vs_angle,
    plot_convergence,
    plot_distributions,
    save_figure,
    save_figures,
    smooth_surfaces,
)
from .resuspension import (
    plot_resuspension,
)
from .roughness import (
    plot_angle_pdf,
    plot_profile,
)
from .sensitivity import (
    plot_sensitivity,
)
from .sizes import (
    plot_size_distribution,
    plot_size_quantiles,
)

__all__ = [
    "FIGURE_FORMATS",
    "plot_angle_pdf",
    "plot_calibration",
    "plot_capture",
    "plot_coefficients_vs_angle",
    "plot_comparison",
    "plot_convergence",
    "plot_distributions",
    "plot_profile",
    "plot_profile_vs_areal",
    "plot_resuspension",
    "plot_sensitivity",
    "plot_size_distribution",
    "plot_size_quantiles",
    "save_figure",
    "save_figures",
    "smooth_surfaces",
]
