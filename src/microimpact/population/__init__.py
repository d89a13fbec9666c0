"""Particle size distributions, their fits and the normality test."""

from .._core.tables import (
    QuantileTable,
)
from .aerosol import (
    MEAN_FREE_PATH_AIR_M,
    UNIT_DENSITY_KG_M3,
    aerodynamic_diameter,
    cunningham_correction,
    hatch_choate_mass_median,
)
from .binned import (
    BIN_VALUES,
    RANGE_FLOOR,
    BinnedSizes,
    Chi2BinnedResult,
    binned_median,
    chi2_binned,
    edges_from_midpoints,
    fit_binned_lognormal,
    fit_binned_normal,
    number_per_bin,
)
from .binned_report import (
    BINNED_SCHEMA,
    BinnedSizesReport,
    describe_binned_sizes,
)
from .distributions import (
    Chi2NormalityResult,
    FitResult,
    SizeDistribution,
    chi2_normality,
    empirical_diameters,
    fit_lognormal,
    fit_normal,
    histogram_diameters,
    lognormal_diameters,
    monodisperse,
    normal_diameters,
    scipy_diameters,
    uniform_diameters,
)
from .sizes_report import (
    SCHEMA,
    SizesReport,
    describe_sizes,
)

__all__ = [
    "BINNED_SCHEMA",
    "BIN_VALUES",
    "MEAN_FREE_PATH_AIR_M",
    "RANGE_FLOOR",
    "SCHEMA",
    "UNIT_DENSITY_KG_M3",
    "BinnedSizes",
    "BinnedSizesReport",
    "Chi2BinnedResult",
    "Chi2NormalityResult",
    "FitResult",
    "QuantileTable",
    "SizeDistribution",
    "SizesReport",
    "aerodynamic_diameter",
    "binned_median",
    "chi2_binned",
    "chi2_normality",
    "cunningham_correction",
    "describe_binned_sizes",
    "describe_sizes",
    "edges_from_midpoints",
    "empirical_diameters",
    "fit_binned_lognormal",
    "fit_binned_normal",
    "fit_lognormal",
    "fit_normal",
    "hatch_choate_mass_median",
    "histogram_diameters",
    "lognormal_diameters",
    "monodisperse",
    "normal_diameters",
    "number_per_bin",
    "scipy_diameters",
    "uniform_diameters",
]
