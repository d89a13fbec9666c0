"""Issue 22 (item 5): figures readable at any size."""

from __future__ import annotations

import warnings

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import microimpact as mi
from microimpact.pipeline.figures import distribution_speed, result_figures


@pytest.fixture(scope="module")
def forty_speeds():
    s = mi.Scenario.from_preset("sst76-formica-oblique").with_options(
        speeds_m_s=tuple(np.geomspace(0.01, 3.0, 40)),
        angles_deg=(10.0, 45.0, 85.0),
    )
    return mi.run(s, samples=200, seed=1, progress=False)


def test_a_40_speed_sweep_draws_without_layout_warnings(forty_speeds):
    """Before: 160 legend entries, the panels collapsed and matplotlib's
    'constrained_layout not applied' warning reached the user."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        figs = result_figures(forty_speeds)
        for _, _, fig in figs:
            fig.canvas.draw()
    for stem, _, fig in figs:
        if stem.startswith("coefficients"):
            (legend,) = [a.get_legend() for a in fig.axes if a.get_legend()]
            assert len(legend.get_texts()) == 2  # the two surfaces, not the speeds
            assert any(a.get_label() == "<colorbar>" for a in fig.axes)
        plt.close(fig)


def test_distributions_take_a_speed_with_rebounds(forty_speeds):
    """The sweep starts below capture: the slowest speed drew empty panels."""
    s = forty_speeds.summary
    v = distribution_speed(forty_speeds)
    rough = s[(s["surface"] == "formica") & np.isclose(s["speed_m_s"], v)]
    assert rough["e_rebound_mean"].notna().all()
    slower = s[(s["surface"] == "formica") & (s["speed_m_s"] < v)]
    assert (
        slower.groupby("speed_m_s")["e_rebound_mean"]
        .apply(lambda e: e.isna().any())
        .all()
    )
    assert v > s["speed_m_s"].min()
