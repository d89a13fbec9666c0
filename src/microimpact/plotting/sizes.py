"""Plot a diameter distribution: frequency histogram and fitted curve ([1], Fig. 2).

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, "Monte Carlo Analysis of Polydisperse
   Microparticle Impacts with Surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
"""

from __future__ import annotations

import numpy as np

from ..population.distributions import (
    SizeDistribution,
    fit_lognormal,
    fit_normal,
)
from ..units import m_to_um, um_to_m

__all__ = ["plot_size_distribution", "plot_size_quantiles"]

_FITS = {"normal": fit_normal, "lognormal": fit_lognormal}


def _fit_iv(fit, sample_um):
    """`fit` -> a SizeDistribution or None."""
    if fit is None or isinstance(fit, SizeDistribution):
        return fit
    if isinstance(fit, str) and fit in _FITS:
        if sample_um is None:
            raise ValueError(
                f"`fit={fit!r}` needs measured diameters; got a continuous "
                "SizeDistribution (pass `fit=None`)."
            )
        return _FITS[fit](sample_um).distribution
    raise ValueError(
        f"`fit` must be None, 'normal', 'lognormal' or a SizeDistribution; got {fit!r}."
    )


def plot_size_distribution(data, *, fit=None, ax=None, bins="sturges"):
    """Frequency distribution of diameters with an optional fitted curve.

    As the paper's Fig. 2 [1]_: bars are the number of particles per diameter class,
    and a fitted distribution is drawn as the expected number per class,
    ``n * Δd * pdf(d)``.

    Parameters
    ----------
    data : array_like or SizeDistribution
        Measured diameters [µm], or a distribution: an empirical one is drawn from its
        atoms, a histogram one from its bins; any other continuous one as its
        probability density [µm⁻¹]; a monodisperse one as a single line.
    fit : None, {"normal", "lognormal"} or SizeDistribution, optional
        Curve to overlay: a maximum-likelihood fit of the data, or a given
        distribution.
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; a new figure is made if omitted.
    bins : int, sequence or str
        Classes for the histogram, as in :func:`numpy.histogram_bin_edges`
        (default Sturges' rule, as the paper's chi-squared test).

    Returns
    -------
    matplotlib.axes.Axes
    """
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt  # lazy: plotting is optional at import time

    if ax is None:
        _, ax = plt.subplots()
    sample_um = None
    edges_um = counts = None
    if isinstance(data, SizeDistribution):
        if data.kind == "empirical":
            sample_um = m_to_um(data.atoms)
        elif data.kind == "histogram":
            edges_um = np.asarray(data.params["edges_um"], dtype=float)
            counts = np.asarray(data.params["counts"], dtype=float)
        elif data.kind == "monodisperse":
            d_um = float(m_to_um(data.atoms[0]))
            ax.axvline(d_um, color="C0", label=f"monodisperse, {d_um:g} µm")
            ax.set_xlabel("Diameter [µm]")
            ax.set_ylabel("Frequency")
            ax.legend()
            return ax
        elif fit is None:
            fit = data
    else:
        sample_um = np.asarray(data, dtype=float).ravel()
        if sample_um.size == 0 or not np.all(np.isfinite(sample_um)):
            raise ValueError("`data` must be a non-empty array of finite diameters.")
    curve = _fit_iv(fit, sample_um)

    if sample_um is not None:
        edges_um = np.histogram_bin_edges(sample_um, bins=bins)
        counts, _ = np.histogram(sample_um, bins=edges_um)
    if counts is not None:
        widths = np.diff(edges_um)
        equal = np.allclose(widths, widths[0], rtol=1e-9)
        heights = counts if equal else counts / (counts.sum() * widths)
        ax.bar(
            edges_um[:-1],
            heights,
            width=widths,
            align="edge",
            edgecolor="k",
            color="0.85",
            label=f"measured (n = {counts.sum():g})",
        )
        ax.set_ylabel("Frequency" if equal else "Probability density [µm⁻¹]")
        scale = counts.sum() * widths[0] if equal else 1.0
        lo, hi = edges_um[0], edges_um[-1]
    else:
        ax.set_ylabel("Probability density [µm⁻¹]")
        scale = 1.0
        lo, hi = m_to_um(curve.ppf([1e-4, 1 - 1e-4]))

    if curve is not None:
        pad = 0.1 * (hi - lo)
        d_um = np.linspace(max(lo - pad, 0.0), hi + pad, 400)
        pdf_um = curve.pdf(um_to_m(d_um)) * um_to_m(1.0)  # [m⁻¹] -> [µm⁻¹]
        name = {"normal": "Gaussian", "lognormal": "log-normal"}.get(
            curve.kind, curve.kind
        )
        label = f"{name} fit" if isinstance(fit, str) else f"{name} distribution"
        ax.plot(d_um, scale * pdf_um, color="C3", label=label)
    ax.set_xlabel("Diameter [µm]")
    ax.legend()
    return ax


def plot_size_quantiles(quantiles_um, *, ax=None, bins=40):
    """Diameter distribution drawn from its quantile function (paper Fig. 2).

    The quantiles at equally spaced mid-probabilities ``(k + 0.5) / n`` are an
    equal-weight description of the distribution, so their histogram (as a
    density) is the distribution's density at the histogram's resolution. This is
    how a result draws its input distribution from the stored
    ``diameter_quantile`` variable, without the distribution object.

    Parameters
    ----------
    quantiles_um : array_like
        Diameters [µm] at equally spaced mid-probabilities; non-finite values are
        dropped.
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; a new figure is made if omitted.
    bins : int, default 40
        Number of equal classes between the smallest and largest quantile.

    Returns
    -------
    matplotlib.axes.Axes
        A density [µm⁻¹] as steps; a single line when every quantile is the same
        diameter (monodisperse).
    """
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    q = np.asarray(quantiles_um, dtype=float).ravel()
    q = q[np.isfinite(q)]
    if q.size == 0:
        raise ValueError("`quantiles_um` has no finite diameters to plot.")
    if not (isinstance(bins, int | np.integer) and bins >= 1):
        raise ValueError(f"`bins` must be an integer >= 1; got {bins!r}.")
    if ax is None:
        _, ax = plt.subplots()
    ax.set_xlabel("Diameter [µm]")
    lo, hi = float(q.min()), float(q.max())
    if hi - lo <= 1e-9 * max(abs(hi), 1e-30):
        ax.axvline(lo, color="C0", label=f"monodisperse, {lo:.4g} µm")
        ax.set_ylabel("Frequency")
        ax.legend()
        return ax
    density, edges = np.histogram(q, bins=int(bins), range=(lo, hi), density=True)
    ax.stairs(
        density,
        edges,
        fill=True,
        alpha=0.6,
        color="C0",
        label=f"from the quantile function ({q.size:,} probabilities)",
    )
    ax.set_ylabel("Probability density [µm⁻¹]")
    ax.set_ylim(bottom=0)
    ax.legend()
    return ax
