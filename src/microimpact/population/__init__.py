"""Particle size distributions, their fits and the normality test."""

from .._core.tables import (
    QuantileTable,
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
    "SCHEMA",
    "Chi2NormalityResult",
    "FitResult",
    "QuantileTable",
    "SizeDistribution",
    "SizesReport",
    "chi2_normality",
    "describe_sizes",
    "empirical_diameters",
    "fit_lognormal",
    "fit_normal",
    "histogram_diameters",
    "lognormal_diameters",
    "monodisperse",
    "normal_diameters",
    "scipy_diameters",
    "uniform_diameters",
]
