"""Roughness plots: the angle PDF (paper Fig. 4) and a surface profile (paper Fig. 7).

matplotlib is imported only when a plot is made. Each function takes ``ax=None``
(a new figure) or an Axes, and returns the Axes.
"""

from __future__ import annotations

import numpy as np

from ..units import m_to_um, rad_to_deg

__all__ = ["plot_angle_pdf", "plot_profile"]


def _axes(ax):
    if ax is None:
        # deferred: matplotlib loads only when a figure is drawn
        import matplotlib.pyplot as plt

        _, ax = plt.subplots()
    return ax


def plot_angle_pdf(angles_deg_or_result, *, ax=None, bins="sturges", **kwargs):
    """
    Empirical probability density of the local roughness angles (paper Fig. 4).

    Parameters
    ----------
    angles_deg_or_result : array_like or RoughnessCharacterisation
        Angles [deg], or a :func:`~microimpact.surface.roughness.characterise`
        result (its stored histogram is drawn).
    ax : matplotlib Axes, optional
    bins : int or str
        Histogram bins for raw angles (default Sturges' rule, as the result uses).
    **kwargs
        Passed to ``Axes.stairs``.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if hasattr(angles_deg_or_result, "pdf_density"):
        r = angles_deg_or_result
        density = np.asarray(r.pdf_density) * (np.pi / 180.0)  # [rad⁻¹] -> [deg⁻¹]
        edges = rad_to_deg(np.asarray(r.pdf_edges))
        label = f"{r.method} method, L = {m_to_um(r.contact_length):.3g} µm"
    else:
        try:
            a = np.asarray(angles_deg_or_result, dtype=float).ravel()
        except (TypeError, ValueError):
            raise TypeError(
                "`angles_deg_or_result` must be angles [deg] or the result of "
                "characterise(); got a "
                f"{type(angles_deg_or_result).__name__} (a simulation's input "
                "angles are drawn by microimpact.pipeline.report.input_figures)"
            ) from None
        a = a[np.isfinite(a)]
        if a.size == 0:
            raise ValueError("`angles_deg_or_result` has no finite angles to plot.")
        density, edges = np.histogram(a, bins=bins, density=True)
        label = f"n = {a.size}"
    ax = _axes(ax)
    kwargs.setdefault("fill", True)
    kwargs.setdefault("alpha", 0.6)
    kwargs.setdefault("label", label)
    ax.stairs(density, edges, **kwargs)
    ax.set_xlabel("Local surface angle φ [°]")
    ax.set_ylabel("Probability density [1/°]")
    ax.set_xlim(-90, 90)
    return ax


def plot_profile(profile, *, ax=None, **kwargs):
    """
    Heights along a scan (paper Fig. 7), µm on both axes.

    Parameters
    ----------
    profile : Profile or ProfileSet
        One scan; for a ProfileSet its first scan is drawn.
    ax : matplotlib Axes, optional
    **kwargs
        Passed to ``Axes.plot``.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if hasattr(profile, "profiles"):
        profile = profile.profiles[0]
    if not (hasattr(profile, "x") and hasattr(profile, "z")):
        raise TypeError(
            f"`profile` must be a Profile or ProfileSet; got {type(profile).__name__}."
        )
    ax = _axes(ax)
    kwargs.setdefault("lw", 0.6)
    x_um = m_to_um(profile.x)
    ax.plot(x_um, m_to_um(profile.z), **kwargs)
    ax.set_xlabel("Position along the scan x [µm]")
    ax.set_ylabel("Height z [µm]")
    ax.set_xlim(x_um[0], x_um[-1])
    scan = getattr(profile, "scan", None)
    if scan is not None:
        ax.set_title(f"Scan {scan}")
    return ax
