"""Figures as notebook users make them (issue 33, item 4): every plotting function
that takes a result draws with its defaults on any sweep shape, or says in one line
which argument to set; and no figure function resets the ``interactive`` flag that
a notebook's inline backend sets, which left only the first figure of a kernel
session inline (matplotlib#25041)."""

from __future__ import annotations

import warnings

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pytest
from engine_helpers import rough, scenario

import microimpact as mi
from microimpact.plotting import (
    plot_angle_pdf,
    plot_capture,
    plot_coefficients_vs_angle,
    plot_comparison,
)

matplotlib.use("Agg")

#: Sweep shapes a user may run: (speeds, angles).
SHAPES = {
    "one point at 30 deg": ((0.5,), (30.0,)),
    "speeds at 30 deg": ((0.2, 0.5, 1.0), (30.0,)),
    "angles without 85 or 90": ((0.5,), (20.0, 40.0, 60.0)),
    "angles with 85": ((0.3, 0.6), (30.0, 60.0, 85.0)),
}


@pytest.fixture(scope="module", params=list(SHAPES))
def result(request):
    speeds, angles = SHAPES[request.param]
    sc = scenario(
        speeds_m_s=speeds,
        angles_deg=angles,
        surfaces=(rough(), mi.SurfaceVariant("smooth")),
        samples=300,
    )
    return mi.run(sc, progress=False)


def _one_line_naming_an_argument(err):
    text = str(err)
    return "\n" not in text and "`" in text and "np.float64" not in text


@pytest.mark.parametrize("plot", [plot_capture, plot_coefficients_vs_angle])
def test_defaults_draw_or_say_what_to_set(result, plot):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no library warning reaches the user
        try:
            out = plot(result)
        except ValueError as err:
            assert _one_line_naming_an_argument(err), str(err)
        else:
            assert np.ravel(np.asarray(out, dtype=object))[0].figure is not None
    plt.close("all")


def test_a_wrong_kind_of_result_is_named_in_one_line(result):
    with pytest.raises(TypeError, match="got a SimulationResult") as info:
        plot_angle_pdf(result)
    assert _one_line_naming_an_argument(info.value)


def test_coefficients_vs_angle_without_85_draws_the_means(result):
    if 85.0 in result.summary["angle_deg"].to_numpy():
        pytest.skip("the reference angle is swept here")
    axes = plot_coefficients_vs_angle(result)  # issue 33: raised ValueError before
    assert "Coefficient of restitution" in axes[0].get_ylabel()
    with pytest.raises(ValueError, match="`relative=True` needs the reference angle"):
        plot_coefficients_vs_angle(result, relative=True)
    plt.close("all")


def test_capture_defaults_to_the_angle_nearest_normal(result):
    axes = plot_capture(result)
    angles = result.summary["angle_deg"].unique()
    nearest = angles[np.argmin(np.abs(angles - 90))]
    label = axes[1].get_xlabel()
    assert "Normal impact speed" in label if nearest == 90 else f"{nearest:g}°" in label
    with pytest.raises(ValueError, match="must be one of the simulated values"):
        plot_capture(result, angle_deg=7.5)
    plt.close("all")


def _table():
    import pandas as pd

    return pd.DataFrame(
        {
            "statistic": ["e"],
            "exp_mean": [0.5],
            "exp_ci_low": [0.4],
            "exp_ci_high": [0.6],
            "sim_mean": [0.52],
            "sim_ci_low": [0.5],
            "sim_ci_high": [0.54],
            "agree": [True],
            "compared": [True],
        }
    )


@pytest.mark.parametrize(
    "draw",
    [
        lambda r: plot_capture(r),
        lambda r: plot_coefficients_vs_angle(r, relative=False),
        lambda r: plot_comparison(_table()),
    ],
    ids=["capture", "coefficients", "comparison"],
)
def test_a_figure_keeps_the_interactive_flag_its_backend_set(result, draw, monkeypatch):
    """A notebook resolves its inline backend when the first figure is made,
    inside our style block, and that turns ``interactive`` on; restoring every
    rcParam afterwards (``rc_context``) turned it off again, and the inline
    backend then shows no later figure. Emulated here: the first ``subplots``
    switches ``interactive`` on, as the backend's activation does."""
    matplotlib.interactive(False)
    subplots = plt.subplots

    def resolving(*args, **kwargs):
        matplotlib.interactive(True)  # what the inline backend's activation does
        return subplots(*args, **kwargs)

    monkeypatch.setattr(plt, "subplots", resolving)
    try:
        draw(result)
        assert matplotlib.is_interactive()
    finally:
        matplotlib.interactive(False)
        plt.close("all")


def test_the_style_does_not_outlive_the_figure(result):
    before = matplotlib.rcParams["font.size"]
    plot_capture(result)
    assert matplotlib.rcParams["font.size"] == before
    plt.close("all")
