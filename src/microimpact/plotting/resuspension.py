"""Remaining fraction of a deposited population against the friction velocity.

The Dataset is :attr:`microimpact.analysis.resuspension.ResuspensionResult.dataset`
(or ``resuspension.nc`` opened with xarray).
"""

from __future__ import annotations

import numpy as np

from ._style import STYLE, colour

__all__ = ["plot_resuspension"]


def plot_resuspension(dataset, *, ax=None, max_curves=6):
    """Remaining fraction after each ramp step against that step's friction
    velocity: the population (solid, with the Monte Carlo estimate's ±2 SE bars
    where present) and each diameter class (thin). For a captured population,
    one solid curve per sweep point, at most `max_curves` of them, evenly spread.

    Parameters
    ----------
    dataset : xarray.Dataset
        ``remaining_fraction`` on ``step`` (and the sweep point's dimensions),
        ``remaining_fraction_class``, ``friction_velocity_m_s``, ``diameter``.
    ax : matplotlib.axes.Axes, optional
    max_curves : int
        Most sweep points drawn.

    Returns
    -------
    matplotlib.axes.Axes
    """
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib as mpl

    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    with mpl.rc_context(STYLE):
        if ax is None:
            _, ax = plt.subplots(figsize=(5.0, 3.4))
        u = np.asarray(dataset["friction_velocity_m_s"].values, float)
        order = np.argsort(u, kind="stable")
        per = dataset["remaining_fraction_class"]
        d_um = 1e6 * np.asarray(dataset["diameter"].values, float)  # m -> µm label
        if per.sizes["diameter_class"] > 1:
            for k in range(per.sizes["diameter_class"]):
                ax.plot(
                    u[order],
                    per.isel(diameter_class=k).values[order],
                    color="0.7",
                    lw=0.6,
                    label="diameter classes" if k == 0 else None,
                )
        whole = dataset["remaining_fraction"]
        point_dims = [d for d in whole.dims if d != "step"]
        stacked = (
            whole.stack(point=point_dims)
            if point_dims
            else whole.expand_dims(point=[0])
        )
        n = stacked.sizes["point"]
        picks = np.unique(np.linspace(0, n - 1, min(n, max_curves)).round().astype(int))
        mc = dataset.get("remaining_fraction_mc")
        mc_se = dataset.get("remaining_fraction_mc_se")
        if mc is not None:
            mc = mc.stack(point=point_dims) if point_dims else mc.expand_dims(point=[0])
            mc_se = (
                mc_se.stack(point=point_dims)
                if point_dims
                else mc_se.expand_dims(point=[0])
            )
        for j, p in enumerate(picks):
            label = "deposited population"
            if point_dims:
                idx = stacked["point"].values[p]
                idx = idx if isinstance(idx, tuple) else (idx,)
                label = ", ".join(
                    f"{d} {v}" for d, v in zip(point_dims, idx, strict=False)
                )
            y = stacked.isel(point=p).values
            ax.plot(u[order], y[order], "-o", color=colour(j), ms=3, label=label)
            if mc is not None:
                ax.errorbar(
                    u[order],
                    mc.isel(point=p).values[order],
                    yerr=2 * mc_se.isel(point=p).values[order],
                    fmt="none",
                    ecolor=colour(j),
                    capsize=2,
                )
        ax.set_xscale("log")
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("Friction velocity [m/s]")
        ax.set_ylabel("Remaining fraction [-]")
        title = "Resuspension (Rock'n'Roll)"
        if d_um.size == 1:
            title += f", d = {d_um[0]:.3g} µm"
        ax.set_title(title)
        ax.legend(fontsize="small")
    return ax
