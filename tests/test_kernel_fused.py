"""The compiled kernel and the NumPy kernel compute the same bits.

The compiled single-pass kernel (``engine/_fused.py``) exists only for speed; the
NumPy kernel is the readable form (and the fallback without numba). With p = q = 1
they perform the same IEEE operations in the same order, so every count, histogram
and moment must agree exactly; with general p, q they may differ by the last bit of
``pow`` and agree to round-off.
"""

import numpy as np
import pytest
from engine_helpers import PowerCoefficients, rough, scenario
from numpy.testing import assert_allclose, assert_array_equal

from microimpact import SurfaceVariant
from microimpact.engine import _fused, kernel
from microimpact.engine.montecarlo import build_plan

pytestmark = pytest.mark.skipif(not _fused.AVAILABLE, reason="numba not installed")


def _both(plan, point, monkeypatch):
    fused = kernel.simulate_block(plan, point, 0, 3, 30_000)
    with monkeypatch.context() as m:
        m.setattr(_fused, "AVAILABLE", False)
        plain = kernel.simulate_block(plan, point, 0, 3, 30_000)
    return fused.to_arrays(), plain.to_arrays()


@pytest.mark.parametrize("shadowing", ["reject", "none", "weighted"])
@pytest.mark.parametrize("friction", [0.15, np.inf])
def test_bit_identical_for_p_q_one(shadowing, friction, monkeypatch):
    sc = scenario(
        coefficients=PowerCoefficients(friction=friction),
        surfaces=(rough(15.0), SurfaceVariant("smooth")),
        speeds_m_s=(0.3,),
        angles_deg=(20.0, 90.0),
        shadowing=shadowing,
        speed_spread=0.1,
    )
    plan = build_plan(sc)
    for point in range(len(plan.points)):
        a, b = _both(plan, point, monkeypatch)
        for key in a:
            assert_array_equal(a[key], b[key], err_msg=f"{key} at point {point}")


def test_general_exponents_agree_to_round_off(monkeypatch):
    sc = scenario(
        coefficients=PowerCoefficients(p=1.3, q=0.7, friction=0.2),
        surfaces=(rough(12.0),),
        speeds_m_s=(0.4,),
        angles_deg=(35.0,),
    )
    a, b = _both(build_plan(sc), 0, monkeypatch)
    assert_array_equal(a["counts"], b["counts"])
    assert_allclose(a["e"], b["e"], rtol=1e-12)
    assert_allclose(a["mu"], b["mu"], rtol=1e-12)
    assert np.abs(a["e_hist"] - b["e_hist"]).sum() <= 2
