"""Tests for microimpact.plotting.results (paper Figs. 5, 6, 8-11)."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib
import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from engine_helpers import PowerCoefficients, rough, scenario

from microimpact.engine.montecarlo import run
from microimpact.pipeline.figures import figures_for_result
from microimpact.plotting.results import (
    plot_capture,
    plot_coefficients_vs_angle,
    plot_convergence,
    plot_distributions,
    rebin,
    save_figure,
)
from microimpact.scenario.scenario import SurfaceVariant


@pytest.fixture(scope="module")
def capture_result():
    sc = scenario(
        name="normal",
        coefficients=PowerCoefficients(friction=0.15),
        speeds_m_s=(0.1, 0.15, 0.2, 0.3, 0.5, 1.0),
        angles_deg=(90,),
        seed=11,
    )
    return run(sc, samples=1500)


@pytest.fixture(scope="module")
def angle_result():
    sc = scenario(
        name="oblique",
        coefficients=PowerCoefficients(friction=0.15),
        speeds_m_s=(1.0,),
        angles_deg=(10, 30, 60, 85),
        surfaces=(rough(), SurfaceVariant("smooth")),
        seed=12,
    )
    return run(sc, samples=1500)


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_plot_capture(capture_result):
    rc_before = dict(matplotlib.rcParams)
    s = capture_result.summary
    exp = pd.DataFrame(
        {
            "speed_m_s": [0.5],
            "angle_deg": [np.nan],
            "statistic": ["e"],
            "mean": [0.7],
            "ci_low": [0.65],
            "ci_high": [0.75],
            "surface": [None],
        }
    )
    ax_e, ax_c = plot_capture(capture_result, experiments=exp)
    assert "[m s⁻¹]" in ax_c.get_xlabel() and "[%]" in ax_c.get_ylabel()
    assert "[–]" in ax_e.get_ylabel()
    line = ax_e.get_lines()[0]
    assert_allclose(line.get_xdata(), s["speed_m_s"], rtol=0)
    assert_allclose(
        np.asarray(line.get_ydata(), dtype=float),
        s["e_rebound_mean"].to_numpy(dtype=float),
        rtol=0,
        equal_nan=True,
    )
    cap = ax_c.get_lines()[0]
    assert_allclose(cap.get_ydata(), 100 * s["capture_fraction"], rtol=1e-12)
    # the 50 % marker sits at the tabulated capture speed, at 50 %
    v50 = capture_result.capture_speed(0.5)["speed_m_s"].iloc[0]
    assert np.isfinite(v50)
    diamonds = [ln for ln in ax_c.get_lines() if ln.get_marker() == "D"]
    assert_allclose(np.asarray(diamonds[0].get_xdata(), float), [v50], rtol=1e-12)
    assert_allclose(np.asarray(diamonds[0].get_ydata(), float), [50.0], rtol=0)
    # one experimental point with its error bar
    squares = [ln for ln in ax_e.get_lines() if ln.get_marker() == "s"]
    assert_allclose(np.asarray(squares[0].get_xdata(), float), [0.5], rtol=0)
    assert dict(matplotlib.rcParams) == rc_before  # the style is local
    with pytest.raises(ValueError, match="angle_deg"):
        plot_capture(capture_result, angle_deg=45)
    with pytest.raises(ValueError, match="surface"):
        plot_capture(capture_result, surface="glass")


def test_plot_coefficients_vs_angle(angle_result):
    ax_e, ax_mu = plot_coefficients_vs_angle(angle_result, relative=True)
    styles = {ln.get_label(): ln.get_linestyle() for ln in ax_e.get_lines()}
    assert styles["Monte Carlo, rough"] == "-"
    assert styles["Monte Carlo, smooth"] == "--"
    s = angle_result.summary
    rough = s[s["surface"] == "rough"].sort_values("angle_deg")
    line = next(ln for ln in ax_mu.get_lines() if ln.get_label().endswith("rough"))
    assert_allclose(line.get_ydata(), rough["mu_relative"], rtol=0)
    # relative values vanish at the reference angle
    assert_allclose(line.get_ydata()[-1], 0.0, atol=1e-15)
    assert "[°]" in ax_mu.get_xlabel()
    ax_e, _ = plot_coefficients_vs_angle(angle_result, relative=False)
    assert "e_m" in ax_e.get_ylabel()
    no_ref = SimpleNamespace(
        summary=s.drop(columns=[c for c in s if "relative" in c]),
        scenario=angle_result.scenario,
    )
    with pytest.raises(ValueError, match="relative=False"):
        plot_coefficients_vs_angle(no_ref, relative=True)


def test_coefficient_figures_draw_median_and_band_on_the_means_scale(angle_result):
    """Issue 25: beside the rough surface's mean, its median (dotted, e_p50) and its
    5-95 % range (hatched, e_p05..e_p95); relative: shifted by the median at the
    reference angle. The panel's y-range holds the means and medians."""
    s = angle_result.summary
    rough = s[s["surface"] == "rough"].sort_values("angle_deg")
    ax_e, ax_mu = plot_coefficients_vs_angle(angle_result, relative=False)
    med = next(ln for ln in ax_e.get_lines() if ln.get_label() == "median of rebounds")
    assert med.get_linestyle() == ":"
    assert_allclose(med.get_ydata(), rough["e_p50"], rtol=0)
    band = [c for c in ax_e.collections if c.get_label() == "5–95 % of rebounds"]
    assert len(band) == 1 and band[0].get_hatch()
    ys = band[0].get_paths()[0].vertices[:, 1]
    assert_allclose(ys.min(), rough["e_p05"].min(), rtol=1e-12)
    assert_allclose(ys.max(), rough["e_p95"].max(), rtol=1e-12)
    # no median for the smooth surface
    meds = [ln for ln in ax_e.get_lines() if ln.get_label() == "median of rebounds"]
    assert len(meds) == 1
    lo, hi = ax_e.get_ylim()
    for col in ("e_rebound_mean", "e_p50"):
        v = s[col].to_numpy(float)
        v = v[np.isfinite(v)]
        assert lo <= v.min() and v.max() <= hi
    _, ax_mu = plot_coefficients_vs_angle(angle_result, relative=True)
    med = next(ln for ln in ax_mu.get_lines() if ln.get_label() == "median of rebounds")
    ref = float(angle_result.scenario.reference_angle_deg)
    p50_ref = rough.loc[np.isclose(rough["angle_deg"], ref), "mu_p50"].iloc[0]
    assert_allclose(med.get_ydata(), rough["mu_p50"] - p50_ref, rtol=0, atol=1e-15)


def test_rebin_hand_computed():
    edges = np.linspace(0.0, 1.0, 11)  # 10 bins of 0.1
    counts = np.array([0, 1, 2, 3, 4, 5, 6, 7, 8, 0])
    (merged,), new_edges, outside = rebin([counts], edges, target_bins=4, tail=0.0)
    # occupied bins 1..8 -> 8 bins, factor 2, aligned at 0: [0,1],[2,3],...,[8,9]
    assert_allclose(new_edges, [0.0, 0.2, 0.4, 0.6, 0.8, 1.0], atol=1e-12)
    assert_allclose(merged, [1, 5, 9, 13, 8], rtol=0)
    assert outside == 0.0
    # a spike is shown on at least target_bins original bins
    spike = np.zeros(100)
    spike[50] = 10
    (m,), e, _ = rebin([spike], np.linspace(0, 1, 101), target_bins=30, tail=0.0)
    assert m.size == 30 and m.sum() == 10
    assert e[1] - e[0] == pytest.approx(0.01)


def test_plot_distributions(angle_result):
    s = angle_result.summary
    axs = plot_distributions(angle_result, angle_deg=10, surface="rough")
    assert len(axs) == 2
    p = int(np.flatnonzero((s["surface"] == "rough") & (s["angle_deg"] == 10))[0])
    for ax, name in zip(axs, ("e", "mu"), strict=True):
        counts, _ = angle_result.histogram(p, name)
        (patch,) = ax.patches
        heights = np.asarray(patch.get_data().values)
        # percentages of all rebounds: at most 100, at least the in-histogram share
        # less the trimmed tails (0.2 %)
        shown = 100 * counts.sum() / s.loc[p, "n_rebounds"]
        total = heights.sum()
        assert total <= 100 + 1e-9
        assert total >= shown - 0.2 - 1e-9
        assert heights.max() > 0
        assert "[%" in ax.get_ylabel()
    with pytest.raises(ValueError, match="angle_deg"):
        plot_distributions(angle_result, angle_deg=12)


def test_save_figure_atomic_and_deterministic(tmp_path):
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    paths = save_figure(fig, tmp_path / "f", formats=("png", "pdf"))
    assert [p.name for p in paths] == ["f.png", "f.pdf"]
    assert paths[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert paths[1].read_bytes()[:5] == b"%PDF-"
    first = paths[1].read_bytes()
    save_figure(fig, tmp_path / "f", formats=("pdf",))
    assert paths[1].read_bytes() == first  # no creation date
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.pdf", "f.png"]
    with pytest.raises(ValueError, match="formats"):
        save_figure(fig, tmp_path / "f", formats=("jpg",))


def test_figures_for_result_names(capture_result, angle_result, tmp_path):
    paths = figures_for_result(capture_result, tmp_path / "a", formats=("png",))
    assert [p.name for p in paths] == ["capture.png"]
    paths = figures_for_result(angle_result, tmp_path / "b", formats=("png", "pdf"))
    names = [p.name for p in paths]
    assert names == [
        "coefficients_relative.png",
        "coefficients_relative.pdf",
        "coefficients.png",
        "coefficients.pdf",
        "distributions_10deg.png",
        "distributions_10deg.pdf",
        "distributions_85deg.png",
        "distributions_85deg.pdf",
    ]
    assert all(p.stat().st_size > 1000 for p in paths)
    assert plt.get_fignums() == []  # figures are closed


def test_plot_convergence():
    n = np.array([10, 100, 1000])
    res = SimpleNamespace(
        table=pd.DataFrame(
            {
                "n": n,
                "capture_fraction": [0.5, 0.45, 0.44],
                "ci_low": [0.2, 0.35, 0.41],
                "ci_high": [0.8, 0.55, 0.47],
            }
        ),
        final=0.44,
        tolerance=0.03,
        confidence=0.95,
        n_settled=100,
        n_required=1050,
    )
    ax = plot_convergence(res)
    assert ax.get_xscale() == "log"
    assert_allclose(ax.get_lines()[0].get_ydata(), [50, 45, 44], rtol=1e-12)
    with pytest.raises(TypeError, match="ConvergenceResult"):
        plot_convergence(object())


def test_save_figures_closes_every_figure(tmp_path):
    from microimpact.plotting.results import save_figures

    def draw():
        _, ax = plt.subplots()
        ax.plot([0, 1], [1, 0])
        return ax

    fig, _ = plt.subplots()
    paths = save_figures(
        [("a", fig), ("b", draw), ("c", plt.subplots(1, 2)[1])], tmp_path, ("png",)
    )
    assert [p.name for p in paths] == ["a.png", "b.png", "c.png"]
    assert plt.get_fignums() == []
    # a failure closes the figure being saved and those not saved yet
    figs = [plt.subplots()[0] for _ in range(3)]
    with pytest.raises(ValueError, match="formats"):
        save_figures([(str(k), f) for k, f in enumerate(figs)], tmp_path, ("jpg",))
    assert plt.get_fignums() == []

    def broken():
        raise RuntimeError("cannot draw")

    with pytest.raises(RuntimeError, match="cannot draw"):
        save_figures([("x", broken), ("y", plt.subplots()[0])], tmp_path, ("png",))
    assert plt.get_fignums() == []
    assert not (tmp_path / "x.png").exists() and not (tmp_path / "y.png").exists()


def test_result_figures_take_experiments_explicitly(capture_result, tmp_path):
    """Experiments are an argument; a scenario's own ``experiments`` are never read."""
    from microimpact.pipeline.figures import result_figures

    exp = tmp_path / "exp.csv"
    exp.write_text("speed_m_s,statistic,mean,half_width\n0.5,e,0.7,0.05\n")
    res = SimpleNamespace(
        summary=capture_result.summary,
        dataset=capture_result.dataset,
        scenario=SimpleNamespace(
            name="x", confidence=0.95, reference_angle_deg=None, experiments=(exp,)
        ),
    )
    stems = [stem for stem, _, _ in result_figures(res)]
    assert stems == ["capture"]
    stems = [stem for stem, _, _ in result_figures(capture_result, experiments=exp)]
    assert stems == ["capture", "comparison"]
