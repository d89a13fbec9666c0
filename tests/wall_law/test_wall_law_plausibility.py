"""Both sides of the reduced speed axis' plausibility check, at every node
(issue 34, item 3).

A reduced speed node r at diameter d is the impact speed r v_c(d); the build
refuses it where that is no plausible impact speed (1 µm/s to 10 km/s,
``microimpact._core.validation.PLAUSIBLE_SPEED_M_S``) before simulating anything.
A check of the top node alone, or of one diameter alone, lets a table of
impossible speeds through: each case below puts the one implausible node
elsewhere (the lowest ratio, the largest diameter, a middle diameter of a law
that is not monotone) and also just inside the limit, where the build runs.
"""

from __future__ import annotations

import numpy as np
import pytest

import microimpact as mi
from microimpact.errors import ScenarioError
from microimpact.wall_law import WallLawSpec, build_wall_law

LOW, HIGH = 1e-6, 1e4  # m/s


def _scenario(v_c):
    return mi.Scenario(
        name="plausible",
        particles=mi.lognormal_diameters(10.0, 1.5),
        coefficients=mi.ImpactCoefficients(k1=4.0, k2=0.05, v_c=v_c, friction=0.2),
        surfaces=(mi.SurfaceVariant("smooth"),),
        seed=3,
        samples=8,
    )


def _v_c_at(table: dict):
    """A v_c law [m/s] with the value table[d_um] at those diameters (1 m/s
    elsewhere): any shape, monotone or not."""

    def v_c(d_m):
        d_um = np.round(np.asarray(d_m) * 1e6, 9)
        return np.array([table.get(float(x), 1.0) for x in np.atleast_1d(d_um)])

    return mi.CallableLaw(v_c, name="v_c table")


def _spec(diameters, ratios):
    return WallLawSpec(
        diameters_um=diameters,
        speeds_m_s=None,
        angles_deg=(90.0,),
        reservoir=2,
        speed_axis="reduced",
        reduced_speeds=ratios,
    )


#: (case, v_c at the diameters, diameters, ratios, the refused node (r, d) or
#: None where every node is just inside the limits)
CASES = [
    (
        "top ratio too fast at the first diameter",
        {1.0: 5000.0},
        (1.0, 5.0),
        (1.0, 2.0 + 1e-6),
        (2.0, 1.0),
    ),
    (
        "top ratio too fast at the last diameter",
        {5.0: 5000.0},
        (1.0, 5.0),
        (1.0, 2.0 + 1e-6),
        (2.0, 5.0),
    ),
    (
        "top ratio too fast at a middle diameter",
        {3.0: 5000.0},
        (1.0, 3.0, 5.0),
        (1.0, 2.0 + 1e-6),
        (2.0, 3.0),
    ),
    (
        "lowest ratio too slow at the first diameter",
        {1.0: 1e-5},
        (1.0, 5.0),
        (0.1 - 1e-9, 1.0),
        (0.1, 1.0),
    ),
    (
        "lowest ratio too slow at the last diameter",
        {5.0: 1e-5},
        (1.0, 5.0),
        (0.1 - 1e-9, 1.0),
        (0.1, 5.0),
    ),
    (
        "lowest ratio too slow at a middle diameter",
        {3.0: 1e-5},
        (1.0, 3.0, 5.0),
        (0.1 - 1e-9, 1.0),
        (0.1, 3.0),
    ),
    ("just inside at the top", {3.0: 5000.0}, (1.0, 3.0, 5.0), (1.0, 2.0), None),
    ("just inside at the bottom", {3.0: 1e-5}, (1.0, 3.0, 5.0), (0.1, 1.0), None),
]


@pytest.mark.parametrize(
    ("case", "table", "diameters", "ratios", "refused"),
    CASES,
    ids=[c[0] for c in CASES],
)
def test_every_reduced_node_is_checked_on_both_sides(
    case, table, diameters, ratios, refused
):
    scenario = _scenario(_v_c_at(table))
    spec = _spec(diameters, ratios)
    if refused is None:
        law = build_wall_law(scenario, spec)
        speeds = law.speeds_m_s
        assert np.all((speeds >= LOW) & (speeds <= HIGH))
        assert speeds.max() == pytest.approx(HIGH) or speeds.min() == pytest.approx(LOW)
        return
    with pytest.raises(ScenarioError) as err:
        build_wall_law(scenario, spec)
    r, d = refused
    message = str(err.value)
    assert err.value.field == "wall_law.reduced_speed"
    assert f"r = {r:g} at diameter {d:g} um" in message, message
    assert ("above 10 km/s" in message) == (r > 1.0), message
