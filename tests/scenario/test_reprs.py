"""Issue 22 (item 8): readable reprs in the user's units and rich notebook reprs."""

from __future__ import annotations

import re

import microimpact as mi


def test_scenario_repr_is_in_the_users_units():
    s = mi.Scenario.from_preset("sst65-silicon-normal")
    text = repr(s)
    assert text.startswith("<Scenario 'sst65-silicon-normal':")
    assert "d_ref_um=52.8" in text and "mean_um=52.8" in text
    assert "0.05-1.5 m/s (37)" in text and "90 deg (1)" in text
    assert not re.search(r"\de-0\d", text)  # no SI floats such as 5.28e-05
    assert "np.float64" not in text
    html = s._repr_html_()
    assert "<table>" in html and "coefficients" in html and "description" in html


def test_result_reprs_have_no_numpy_scalar_wrappers():
    r = mi.apparent_rebound(1.0, 30.0, -20.0, k1=10.0, k2=0.02, v_c=0.2, friction=0.15)
    text = repr(r)
    assert "np.float64" not in text and "np.False_" not in text
    assert text.startswith("ApparentReboundResult(e_m=1.60568, mu_m=0.513981,")
    assert "np." not in repr(mi.rebound(1.0, 0.5, k1=10.0, k2=0.02, v_c=0.2))


def test_simulation_result_has_a_rich_repr():
    res = mi.run(
        mi.Scenario.from_preset("sst65-silicon-normal"), samples=100, progress=False
    )
    html = res._repr_html_()
    assert html.startswith("<p>&lt;SimulationResult 'sst65-silicon-normal'") or (
        "SimulationResult" in html
    )
    assert html.count("</tr>") == 1 + 12  # the header and the first 12 points
    assert "25 more rows" in html
