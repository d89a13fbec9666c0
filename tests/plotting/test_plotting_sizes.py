"""Tests for microimpact.plotting.sizes (Fig. 2-style size distribution plot)."""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from microimpact.plotting.sizes import plot_size_distribution
from microimpact.population.distributions import (
    empirical_diameters,
    histogram_diameters,
    lognormal_diameters,
    monodisperse,
    normal_diameters,
)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _bars(ax):
    return [p for p in ax.patches if isinstance(p, matplotlib.patches.Rectangle)]


def test_sample_with_normal_fit(rng):
    x = rng.normal(52.8, 15.3, 1000)  # SST65-like sample [1]
    ax = plot_size_distribution(x, fit="normal")
    bars = _bars(ax)
    assert len(bars) == math.ceil(1 + math.log2(x.size))  # Sturges' rule
    assert_allclose(sum(b.get_height() for b in bars), x.size, rtol=0)
    assert "µm" in ax.get_xlabel() and ax.get_ylabel() == "Frequency"
    (line,) = ax.get_lines()
    d, y = line.get_data()
    # the curve is the expected count per class of the ML Gaussian (truncated to d > 0)
    width = bars[0].get_width()
    kept = stats.norm.sf(-x.mean() / x.std())
    expect = x.size * width * stats.norm.pdf(d, x.mean(), x.std()) / kept
    assert_allclose(y, expect, rtol=1e-6)
    assert "Gaussian fit" in line.get_label()


def test_given_axes_and_bins_and_lognormal_fit(rng):
    _, ax = plt.subplots()
    x = rng.lognormal(np.log(30), 0.3, 500)
    out = plot_size_distribution(x, fit="lognormal", ax=ax, bins=12)
    assert out is ax and len(_bars(ax)) == 12
    assert len(ax.get_lines()) == 1


def test_continuous_distribution_draws_density():
    dist = lognormal_diameters(30, 1.5)
    ax = plot_size_distribution(dist)
    (line,) = ax.get_lines()
    d_um, y = line.get_data()
    ref = stats.lognorm(np.log(1.5), scale=30).pdf(d_um)  # density per µm
    assert_allclose(y, ref, rtol=1e-9, atol=1e-15)
    assert "µm⁻¹" in ax.get_ylabel() and not _bars(ax)


def test_histogram_and_empirical_and_monodisperse(rng):
    edges, counts = [10, 20, 40, 60], [10, 50, 20]
    ax = plot_size_distribution(histogram_diameters(edges, counts))
    heights = [b.get_height() for b in _bars(ax)]
    # unequal widths: drawn as density, which integrates to one
    assert_allclose(np.sum(np.array(heights) * np.diff(edges)), 1.0, rtol=1e-12)
    ax = plot_size_distribution(
        empirical_diameters(rng.normal(50, 5, 300)), fit=normal_diameters(50, 5)
    )
    assert_allclose(sum(b.get_height() for b in _bars(ax)), 300, rtol=0)
    assert len(ax.get_lines()) == 1
    ax = plot_size_distribution(monodisperse(40))
    assert_allclose(ax.get_lines()[0].get_xdata(), [40, 40])


def test_errors(rng):
    with pytest.raises(ValueError, match="`fit`"):
        plot_size_distribution(rng.normal(50, 5, 100), fit="gamma")
    with pytest.raises(ValueError, match="needs measured diameters"):
        plot_size_distribution(lognormal_diameters(30, 1.5), fit="normal")
    with pytest.raises(ValueError, match="`data`"):
        plot_size_distribution([])


def test_size_quantiles_density_and_monodisperse():
    from scipy import stats

    from microimpact.plotting.sizes import plot_size_quantiles

    p = (np.arange(4096) + 0.5) / 4096
    q = stats.norm(50, 5).ppf(p)
    ax = plot_size_quantiles(np.append(q, np.nan), bins=40)
    (steps,) = ax.patches
    density, edges = steps.get_data().values, steps.get_data().edges
    assert_allclose(np.sum(density * np.diff(edges)), 1.0, rtol=1e-12)
    mid = 0.5 * (edges[1:] + edges[:-1])
    assert_allclose(density[20], stats.norm(50, 5).pdf(mid[20]), rtol=0.05)
    ax = plot_size_quantiles(np.full(4096, 12.5))
    assert "monodisperse, 12.5 µm" in ax.get_legend().get_texts()[0].get_text()
    with pytest.raises(ValueError, match="no finite"):
        plot_size_quantiles([np.nan])
    with pytest.raises(ValueError, match="bins"):
        plot_size_quantiles(q, bins=0)
