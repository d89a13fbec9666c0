"""The calibration figure: measured points with their intervals against the
calibrated model and its band.

Draws a :class:`~microimpact.analysis.calibration.CalibrationResult` through its two
tables (``points``: the experimental points with the fitted model there; ``curves``: the
model at every sweep point with the band of the parameters' uncertainty). This
module imports nothing from :mod:`microimpact.analysis.calibration` (the tables are the
interface).
"""

from __future__ import annotations

import math

import numpy as np

from ..io.experiments import STATISTIC_LABELS as _LABELS
from ._style import STYLE, colour, styled

__all__ = ["plot_calibration"]


def _axis(points, curves):
    """The x column: the angle if the data have several angles, else the speed."""
    for c in ("angle_deg", "speed_m_s"):
        if points[c].dropna().nunique() > 1:
            return c
    return "angle_deg" if curves["angle_deg"].nunique() > 1 else "speed_m_s"


def plot_calibration(result, *, axes=None):
    """Data against the calibrated model: one panel per measured statistic.

    Parameters
    ----------
    result : CalibrationResult
        Output of :func:`microimpact.analysis.calibration.calibrate` (its ``points`` and
        ``curves`` tables and ``confidence``).
    axes : sequence of matplotlib Axes, optional
        One per statistic; a new figure is made if omitted.

    Returns
    -------
    matplotlib.figure.Figure
        Points: measured means with their intervals. Line: the model at the fitted
        parameters (sweep points joined); shaded: the band of the model over the
        bootstrap refits (or parameter draws from the covariance).
    """
    # deferred: matplotlib loads only when a figure is drawn

    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    points, curves = result.points, result.curves
    stats = list(dict.fromkeys(points["statistic"]))
    x_col = _axis(points, curves)
    other = "speed_m_s" if x_col == "angle_deg" else "angle_deg"
    with styled():
        if axes is None:
            fig, axes = plt.subplots(
                1,
                len(stats),
                figsize=(3.4 * len(stats), 3.0),
                layout="constrained",
                squeeze=False,
            )
            axes = axes[0]
        else:
            fig = axes[0].figure
        for ax, stat in zip(axes, stats, strict=False):
            pts = points[points["statistic"] == stat]
            cur = curves[curves["statistic"] == stat]
            # one curve per (surface, other coordinate) that the data visit
            keys = []
            for _, p in pts.iterrows():
                o = p[other]
                if isinstance(o, float) and math.isnan(o):
                    o = None
                k = (p["surface"], o)
                if k not in keys:
                    keys.append(k)
            for i, (surface, o) in enumerate(keys):
                c = colour(i)
                g = cur
                if surface is not None and "surface" in cur:
                    g = g[g["surface"] == surface]
                if o is not None:
                    near = np.isclose(g[other].to_numpy(float), float(o))
                    if near.any():
                        g = g[near]
                g = g.sort_values(x_col)
                label = " ".join(
                    s
                    for s in (
                        str(surface) if surface is not None else "",
                        (f"{o:g} m/s" if other == "speed_m_s" else f"{o:g}°")
                        if o is not None and len(keys) > 1
                        else "",
                    )
                    if s
                )
                ax.plot(g[x_col], g["model"], color=c, label=f"model {label}".strip())
                if g["band_low"].notna().any():
                    ax.fill_between(
                        g[x_col],
                        g["band_low"],
                        g["band_high"],
                        color=c,
                        alpha=0.25,
                        lw=0,
                        label=f"{result.confidence:.0%} band" if i == 0 else None,
                    )
                sel = pts
                if surface is not None:
                    sel = sel[sel["surface"] == surface]
                if o is not None:
                    sel = sel[np.isclose(sel[other].to_numpy(float), float(o))]
                ax.errorbar(
                    sel[x_col],
                    sel["exp_mean"],
                    yerr=[
                        sel["exp_mean"] - sel["exp_ci_low"],
                        sel["exp_ci_high"] - sel["exp_mean"],
                    ],
                    fmt="o",
                    ms=4,
                    color=c,
                    mfc="white",
                    label=f"measured {label}".strip(),
                )
            ax.set_xlabel(
                "apparent incidence angle [deg]"
                if x_col == "angle_deg"
                else "incident speed [m/s]"
            )
            ax.set_ylabel(_LABELS.get(stat, stat))
            ax.legend(loc="best")
        fig.suptitle(
            f"calibrated model (band: {result.confidence:.0%}), "
            f"χ² = {result.chi2:.3g}, dof = {result.dof}",
            fontsize=STYLE["axes.titlesize"],
        )
    return fig
