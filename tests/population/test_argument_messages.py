"""Every refusal of the population API, word for word.

A user's mistake in a size distribution's arguments must come back naming the
argument, the bad value and what is allowed (docs/conventions.md, "Bad input").
Each row below is one refusal, with the whole message written out by hand from
that rule (the validators' documented format: "`name` must be a number > 0
(finite); got -1."), so that a message that loses its field, its value, its
bound or its wording — or a bound that moves (> for >=, a minimum dropped, which
then reaches a later and different check) — turns a row red.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from ids import ascii_id

from microimpact.population import (
    chi2_binned,
    chi2_normality,
    cunningham_correction,
    fit_binned_lognormal,
    fit_binned_normal,
    hatch_choate_mass_median,
    lognormal_diameters,
    monodisperse,
    normal_diameters,
    uniform_diameters,
)
from microimpact.population.aerosol import (
    aerodynamic_diameter,
    count_median_diameter,
    volume_equivalent_diameter,
)

EDGES = np.geomspace(1.0, 100.0, 11)
COUNTS = np.array([1, 4, 12, 30, 52, 60, 45, 25, 9, 2], dtype=float)
DIAMETERS = np.random.default_rng(3).normal(50.0, 5.0, 200)


def _chi2_binned(**kw):
    return chi2_binned(EDGES, COUNTS, fit_binned_lognormal(EDGES, COUNTS), **kw)


def _positive(name, got, *, finite=True):
    end = " (finite)" if finite else ""
    return f"`{name}` must be a number > 0{end}; got {got}."


CASES = [
    # --- distributions: the factories' arguments
    (lambda: normal_diameters(50.0, 0), ValueError, _positive("std_um", "0")),
    (lambda: normal_diameters(50.0, -1.5), ValueError, _positive("std_um", "-1.5")),
    (
        lambda: normal_diameters(float("nan"), 5.0),
        ValueError,
        "`mean_um` must be a number (finite); got nan.",
    ),
    (
        lambda: normal_diameters(50.0, 5.0, min_um=-1),
        ValueError,
        "`min_um` must be a number >= 0 (finite); got -1.",
    ),
    (
        lambda: normal_diameters(50.0, 5.0, max_um=0),
        ValueError,
        _positive("max_um", "0", finite=False),
    ),
    (lambda: lognormal_diameters(0, 1.5), ValueError, _positive("median_um", "0")),
    (lambda: lognormal_diameters(-5, 1.5), ValueError, _positive("median_um", "-5")),
    (
        lambda: lognormal_diameters(50.0, 0),
        ValueError,
        _positive("geometric_std", "0"),
    ),
    (
        lambda: lognormal_diameters(50.0, 1.0),
        ValueError,
        "`geometric_std` must be > 1; got 1.0 (for a single diameter use "
        "`monodisperse`).",
    ),
    (
        lambda: uniform_diameters(-1, 10.0),
        ValueError,
        "`min_um` must be a number >= 0 (finite); got -1.",
    ),
    (lambda: uniform_diameters(1.0, 0), ValueError, _positive("max_um", "0")),
    (lambda: monodisperse(0), ValueError, _positive("diameter_um", "0")),
    (
        lambda: monodisperse("50"),
        TypeError,
        "`diameter_um` must be numeric (a real number); got '50'.",
    ),
    # --- the plausibility of a diameter in micrometres, each unit guessed
    (
        lambda: monodisperse(5e-6),
        ValueError,
        "`diameter_um` = 5e-06 is below 10 nm (0.01 um), not a particle diameter; "
        "was it given in metres? 5e-06 m is 5 um; diameters are in micrometres "
        "here (allowed: 0.01 to 10000 um).",
    ),
    (
        lambda: monodisperse(0.005),
        ValueError,
        "`diameter_um` = 0.005 is below 10 nm (0.01 um), not a particle diameter; "
        "was it given in millimetres? 0.005 mm is 5 um; diameters are in "
        "micrometres here (allowed: 0.01 to 10000 um).",
    ),
    (
        lambda: lognormal_diameters(50000.0, 1.5),
        ValueError,
        "`median_um` = 50000 is above 10 mm (10000 um), not a particle diameter; "
        "was it given in nanometres? 50000 nm is 50 um; diameters are in "
        "micrometres here (allowed: 0.01 to 10000 um).",
    ),
    # --- the chi-squared tests' level
    (
        lambda: chi2_normality(DIAMETERS, alpha=0),
        ValueError,
        _positive("alpha", "0"),
    ),
    (
        lambda: chi2_normality(DIAMETERS, alpha=1),
        ValueError,
        "`alpha` must be in (0, 1); got 1.0.",
    ),
    (
        lambda: chi2_normality(np.full(40, 50.0)),
        ValueError,
        "`diameters_um` are all equal; a Gaussian cannot be tested.",
    ),
    (
        lambda: chi2_normality(DIAMETERS[:5]),
        ValueError,
        "too few diameters for the chi-squared test: n=5 leaves 1 classes with "
        "expected count >= 5; need at least 4 (about 30 or more diameters).",
    ),
    (lambda: _chi2_binned(alpha=0), ValueError, _positive("alpha", "0")),
    (lambda: _chi2_binned(alpha=-0.1), ValueError, _positive("alpha", "-0.1")),
    (
        lambda: _chi2_binned(alpha=1.5),
        ValueError,
        "`alpha` must be in (0, 1); got 1.5.",
    ),
    # --- binned fits: the edges and counts
    (
        lambda: fit_binned_lognormal("abc", COUNTS),
        TypeError,
        "`edges_um` must be numeric (array_like); got 'abc'.",
    ),
    (
        lambda: fit_binned_normal([1.0], [3.0]),
        ValueError,
        "`edges_um` must hold at least 2 finite edges > 0; got [1.].",
    ),
    (
        lambda: fit_binned_normal([1.0, 3.0, 2.0], [3.0, 4.0]),
        ValueError,
        "`edges_um` must be strictly increasing; got [1. 3. 2.].",
    ),
    (
        lambda: fit_binned_normal([1.0, 2.0, 3.0], [3.0]),
        ValueError,
        "`counts` needs 2 values (one per bin); got 1.",
    ),
    (
        lambda: fit_binned_normal([1.0, 2.0, 3.0], [0.0, 0.0]),
        ValueError,
        "`counts` must be finite, >= 0 and not all 0.",
    ),
    # --- aerosol conversions (SI: metres, kg/m^3)
    (
        lambda: cunningham_correction(0.0),
        ValueError,
        "`diameter_m` must be finite and > 0; got 0.0.",
    ),
    (
        lambda: cunningham_correction(1e-6, mean_free_path_m=0),
        ValueError,
        _positive("mean_free_path_m", "0"),
    ),
    (
        lambda: aerodynamic_diameter(1e-6, 0),
        ValueError,
        _positive("density_kg_m3", "0"),
    ),
    (
        lambda: aerodynamic_diameter(1e-6, 1000.0, shape_factor=0),
        ValueError,
        _positive("shape_factor", "0"),
    ),
    (
        lambda: volume_equivalent_diameter(0, 1000.0),
        ValueError,
        _positive("aerodynamic_m", "0"),
    ),
    (
        lambda: volume_equivalent_diameter(1e-6, -1),
        ValueError,
        _positive("density_kg_m3", "-1"),
    ),
    (
        lambda: hatch_choate_mass_median(0, 2.0),
        ValueError,
        _positive("count_median", "0"),
    ),
    (
        lambda: hatch_choate_mass_median(1e-6, 0.5),
        ValueError,
        "`geometric_std` must be a number >= 1 (finite); got 0.5.",
    ),
    (
        lambda: count_median_diameter(0, 2.0),
        ValueError,
        _positive("median_m", "0"),
    ),
    (
        lambda: count_median_diameter(1e-6, 0.9),
        ValueError,
        "`geometric_std` must be a number >= 1 (finite); got 0.9.",
    ),
    (
        lambda: count_median_diameter(1e-6, 2.0, convention="volume"),
        ValueError,
        "`convention` must be one of count, mass, mmad; got 'volume'.",
    ),
    (
        lambda: count_median_diameter(1e-6, 2.0, convention="mmad"),
        ValueError,
        "an MMAD needs the particle density `density_kg_m3`.",
    ),
    (
        lambda: count_median_diameter(1e-6, 2.0, density_kg_m3=1000.0),
        ValueError,
        "`density_kg_m3` applies to an MMAD only (a count or mass median is "
        "already a volume-equivalent diameter).",
    ),
]


@pytest.mark.parametrize(
    ("call", "error", "message"), CASES, ids=[ascii_id(c[2][:48]) for c in CASES]
)
def test_each_refusal_names_the_field_the_value_and_what_is_allowed(
    call, error, message
):
    with pytest.raises(error, match=f"^{re.escape(message)}$"):
        call()


@pytest.mark.parametrize(
    ("call", "value"),
    [
        (lambda v: lognormal_diameters(v, 1.5), 1e-2),
        (lambda v: lognormal_diameters(v, 1.5), 1e4),
        (lambda v: monodisperse(v), 1e-2),
        (lambda v: monodisperse(v), 1e4),
        (lambda v: normal_diameters(v, 1e-3), 1e-2),
    ],
)
def test_the_plausible_range_includes_its_ends(call, value):
    """0.01 um and 10,000 um are diameters (the range is closed at both ends)."""
    assert call(value) is not None
