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


def test_the_distribution_speed_can_be_chosen(forty_speeds, tmp_path, monkeypatch):
    """[outputs] distribution_speed_m_s (and run --distribution-speed-m-s) choose
    the swept speed of Figs. 9-10; one the sweep does not have is the user's
    error, before the run."""
    import microimpact.pipeline.study as study_module
    from microimpact.cli import main
    from microimpact.errors import InputError
    from microimpact.pipeline.figures import figure_caption

    v = float(np.unique(forty_speeds.summary["speed_m_s"])[30])
    assert distribution_speed(forty_speeds, v) == v
    assert f"{v:g} m s⁻¹" in figure_caption(
        "distributions_10deg", forty_speeds, distribution_speed_m_s=v
    )
    with pytest.raises(InputError, match="not a swept speed"):
        distribution_speed(forty_speeds, 123.0)

    def no_run(*a, **k):
        raise AssertionError("the engine ran")

    monkeypatch.setattr(study_module, "run", no_run)
    toml = tmp_path / "s.toml"
    toml.write_text(
        "samples = 100\n[outputs]\ndistribution_speed_m_s = 7.0\n[particles]\n"
        'distribution = "normal"\nmean_um = 50\nstd_um = 5\n[coefficients]\n'
        "k1 = 4.0\nk2 = 0.05\nv_c = 0.2\n[sweep]\nspeed_m_s = [0.5, 1.0]\n"
    )
    assert mi.Study(toml).outputs.distribution_speed_m_s == 7.0
    assert main(["run", str(toml), "--out", str(tmp_path / "o")]) == 2
    assert (
        main(
            [
                "run",
                str(toml),
                "--out",
                str(tmp_path / "p"),
                "--distribution-speed-m-s",
                "3",
            ]
        )
        == 2
    )
