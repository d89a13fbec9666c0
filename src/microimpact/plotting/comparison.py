"""The comparison figure: simulated against experimental means (parity plot).

Draws the table of :func:`microimpact.analysis.compare.compare`. matplotlib is imported
only when a figure is made. This module imports nothing from
:mod:`microimpact.analysis.compare` (the table is the interface), so comparing never
loads plotting and plotting never
imports the comparison at module level.
"""

from __future__ import annotations

import numpy as np

from ._style import colour, styled

__all__ = ["plot_comparison"]

_STAT_LABELS = {
    "e": "e",
    "mu": "μ",
    "e_relative": "e relative",
    "mu_relative": "μ relative",
    "capture_fraction": "capture fraction",
}


def plot_comparison(table, *, ax=None):
    """Simulated against experimental means with their intervals (parity plot).

    Parameters
    ----------
    table : pandas.DataFrame
        Output of :func:`microimpact.analysis.compare.compare`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; a new figure is made if omitted.

    Returns
    -------
    matplotlib.axes.Axes
        Each point has horizontal (experimental) and vertical (simulated) interval
        bars; filled markers agree, open markers do not. The dashed line is
        simulated = experimental.
    """
    # deferred: matplotlib loads only when a figure is drawn

    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    need = {"statistic", "exp_mean", "sim_mean", "agree"}
    if not hasattr(table, "columns") or not need <= set(table.columns):
        raise ValueError(f"`table` must be the output of compare(); got {table!r}.")
    with styled():
        if ax is None:
            _, ax = plt.subplots(figsize=(4.2, 4.0), layout="constrained")
        ok = table.dropna(subset=["sim_mean"])
        for k, (stat, g) in enumerate(ok.groupby("statistic", sort=False)):
            c = colour(k)
            for agree, h in g.groupby("agree"):
                ax.errorbar(
                    h["exp_mean"],
                    h["sim_mean"],
                    xerr=[
                        h["exp_mean"] - h["exp_ci_low"],
                        h["exp_ci_high"] - h["exp_mean"],
                    ],
                    yerr=[
                        h["sim_mean"] - h["sim_ci_low"],
                        h["sim_ci_high"] - h["sim_mean"],
                    ],
                    fmt="o" if agree else "s",
                    ms=5,
                    color=c,
                    mfc=c if agree else "white",
                    capsize=2,
                    lw=0.9,
                    label=f"{_STAT_LABELS.get(stat, stat)}"
                    + ("" if agree else " (disagree)"),
                )
        if len(ok):
            lo = float(np.nanmin(ok[["exp_ci_low", "sim_ci_low"]].to_numpy()))
            hi = float(np.nanmax(ok[["exp_ci_high", "sim_ci_high"]].to_numpy()))
            pad = 0.05 * (hi - lo or 1.0)
            ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], "k--", lw=0.8)
            ax.set_xlim(lo - pad, hi + pad)
            ax.set_ylim(lo - pad, hi + pad)
            ax.set_aspect("equal", adjustable="box")
        compared = (
            table["compared"].astype(bool)
            if "compared" in table
            else table["sim_mean"].notna()
        )
        n_ok = int((table["agree"].astype(bool) & compared).sum())
        n, missing = int(compared.sum()), int((~compared).sum())
        conf = table.attrs.get("confidence", 0.95)
        title = f"{n_ok} of {n} compared points agree at the {conf:.0%} level"
        if missing:
            title += f"\n{missing} not compared (see the table's note)"
        ax.set_title(title, fontsize="medium")
        ax.set_xlabel("Experimental mean [–]")
        ax.set_ylabel("Simulated mean [–]")
        if len(ok):
            ax.legend(loc="upper left", fontsize="small")
        else:  # nothing to draw: say so on the axes, not with an empty legend
            ax.text(
                0.5,
                0.5,
                "no point was compared",
                ha="center",
                va="center",
                transform=ax.transAxes,
            )
    return ax
