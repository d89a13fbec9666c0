"""microimpact: Monte Carlo analysis of polydisperse microparticle impacts with rough
surfaces, after Li, Dunn & Brach (2000), *Aerosol Sci. Technol.* 33:376-386.

The public names are importable from the top level; they are loaded lazily so that
``import microimpact`` stays fast and the physics core needs only NumPy.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

# public name -> module that defines it (relative to this package). This is the
# curated public API (see docs/architecture.md); engine internals and mutable
# registries stay in their modules (e.g. microimpact.physics.adhesion.MATERIALS).
_EXPORTS: dict[str, str] = {
    # physics: one impact (paper Eqs. 1-9)
    "rebound": "physics.impact",
    "apparent_rebound": "physics.impact",
    "ReboundResult": "physics.impact",
    "ApparentReboundResult": "physics.impact",
    # coefficient laws against diameter, fitting, adhesion
    "PowerLaw": "physics.coefficients",
    "PolynomialLaw": "physics.coefficients",
    "TableLaw": "physics.coefficients",
    "ConstantLaw": "physics.coefficients",
    "CallableLaw": "physics.coefficients",
    "ThorntonNingLaw": "physics.coefficients",
    "ImpactCoefficients": "physics.coefficients",
    "law_from_dict": "physics.coefficients",
    "CoefficientValues": "physics.coefficients",
    "fit_restitution": "physics.fitting",
    "fit_impact_coefficients": "physics.fitting",
    "fit_law": "physics.fitting",
    "fit_coefficient_laws": "physics.fitting",
    "RestitutionFit": "physics.fitting",
    "LawFit": "physics.fitting",
    "contact_modulus": "physics.adhesion",
    "thornton_ning_sticking_velocity": "physics.adhesion",
    "hertz_max_compression": "physics.adhesion",
    "hertz_contact_radius": "physics.adhesion",
    "material": "physics.adhesion",
    "Material": "physics.adhesion",
    "read_impact_data": "io.impact_data",
    # particle populations
    "SizeDistribution": "population.distributions",
    "normal_diameters": "population.distributions",
    "lognormal_diameters": "population.distributions",
    "uniform_diameters": "population.distributions",
    "monodisperse": "population.distributions",
    "empirical_diameters": "population.distributions",
    "histogram_diameters": "population.distributions",
    "scipy_diameters": "population.distributions",
    "fit_normal": "population.distributions",
    "fit_lognormal": "population.distributions",
    "chi2_normality": "population.distributions",
    "FitResult": "population.distributions",
    "Chi2NormalityResult": "population.distributions",
    "read_diameters": "io.diameters",
    "read_histogram": "io.diameters",
    # surface roughness
    "read_profile": "io.profiles",
    "read_profiles": "io.profiles",
    "Profile": "io.profiles",
    "ProfileSet": "io.profiles",
    "profile_angles": "surface.roughness",
    "surface_angles": "surface.roughness",
    "detrend": "surface.roughness",
    "gaussian_filter_profile": "surface.roughness",
    "characterise": "surface.roughness",
    "profile_parameters": "surface.roughness",
    "RoughnessCharacterisation": "surface.roughness",
    "write_angle_file": "surface.roughness",
    "read_angle_file": "surface.roughness",
    "AngleDistribution": "surface.angles",
    "angles_from_sample": "surface.angles",
    "angles_from_file": "surface.angles",
    "angles_from_profile": "surface.angles",
    "normal_angles": "surface.angles",
    "scipy_angles": "surface.angles",
    "smooth_surface": "surface.angles",
    "gaussian_profile": "surface.synthetic",
    "ripple_profile": "surface.synthetic",
    "weierstrass_mandelbrot_profile": "surface.synthetic",
    "formica_profile": "surface.synthetic",
    "formica_realization": "surface.formica",
    "formica_ensemble": "surface.formica",
    "FormicaRealization": "surface.formica",
    "hertz_contact_diameter": "surface.contact",
    # areal surfaces (height maps): readers, parameters, joint facet angles
    "read_height_map": "io.areal",
    "HeightMap": "io.areal",
    "level_plane": "surface.areal",
    "areal_parameters": "surface.areal",
    "ArealParameters": "surface.areal",
    "contact_patch_means": "surface.areal",
    "facet_angles": "surface.areal",
    "FacetAngles": "surface.areal",
    "facet_angle_statistics": "surface.areal",
    "FacetAngleStatistics": "surface.areal",
    "gaussian_areal_surface": "surface.areal",
    "ArealAngles": "surface.areal_angles",
    "areal_angles_from_sample": "surface.areal_angles",
    "areal_angles_from_facets": "surface.areal_angles",
    "areal_angles_from_height_map": "surface.areal_angles",
    "gaussian_areal_angles": "surface.areal_angles",
    # a study: scenario, sweep grid, engine, results
    "Scenario": "scenario.scenario",
    "SurfaceVariant": "scenario.scenario",
    "Precision": "scenario.scenario",
    "scenario_from_dict": "scenario.scenario",
    "list_presets": "scenario.file",
    "SweepGrid": "scenario.grid",
    "GridPoint": "scenario.grid",
    "QuantileTable": "population",
    "run": "engine.montecarlo",
    "iter_blocks": "engine.montecarlo",
    "BlockResult": "engine.montecarlo",
    "sample_point": "engine.montecarlo",
    "SimulationResult": "engine.result",
    "ScenarioRecord": "engine.result",
    "open_result": "engine.result",
    "wilson_interval": "engine.statistics",
    "capture_speed": "engine.statistics",
    "relative_coefficients": "engine.statistics",
    "convergence_study": "engine.convergence",
    "ConvergenceResult": "engine.convergence",
    # the pipeline: run -> files -> figures -> report
    "Study": "pipeline.study",
    "Outputs": "scenario.outputs",
    "reproduce": "pipeline.study",
    "robustness_study": "analysis.robustness",
    "BayesResult": "analysis.bayes",
    "RobustnessStudy": "analysis.robustness",
    # a stochastic wall law for CFD and particle tracking
    "build_wall_law": "wall_law.build",
    "WallLaw": "wall_law.law",
    "WallLawSample": "wall_law.law",
    "WallLawSpec": "scenario.wall_law",
    # global sensitivity (Sobol' indices of the statistics)
    "sobol_sensitivity": "analysis.sensitivity",
    "sobol_analysis": "analysis.sensitivity",
    "SensitivityResult": "analysis.sensitivity",
    # calibration against measurements
    "calibrate": "analysis.calibration",
    "CalibrationResult": "analysis.calibration",
    "plot_calibration": "plotting.calibration",
    # resuspension after capture (Rock'n'Roll)
    "resuspend": "analysis.resuspension",
    "ResuspensionResult": "analysis.resuspension",
    "plot_resuspension": "plotting.resuspension",
    # figures
    "plot_capture": "plotting.results",
    "plot_coefficients_vs_angle": "plotting.results",
    "plot_distributions": "plotting.results",
    "plot_convergence": "plotting.results",
    "plot_comparison": "plotting.comparison",
    "compare": "analysis.compare",
    "plot_size_distribution": "plotting.sizes",
    "plot_angle_pdf": "plotting.roughness",
    "plot_profile": "plotting.roughness",
    "plot_sensitivity": "plotting.sensitivity",
    # errors and warnings
    "InputError": "errors",
    "ScenarioError": "errors",
    "ScenarioErrors": "errors",
    "ProfileFormatError": "errors",
    "DataFormatError": "errors",
    "ConvergenceWarning": "errors",
    "CheckpointWarning": "engine.checkpoint",
    "OutputFolderBusy": "pipeline.folder",
}


def __getattr__(name: str):
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(
            f"module 'microimpact' has no attribute {name!r}"
        ) from None
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(list(globals()) + list(_EXPORTS))


__all__ = ["__version__", *_EXPORTS]
