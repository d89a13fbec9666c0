"""The figures of a Bayesian calibration: the corner plot of the posterior and the
posterior predictive against the experiments.

Both draw plain arrays and tables (the interface): this module imports nothing from
:mod:`microimpact.analysis`.
"""

from __future__ import annotations

import numpy as np

from ._style import STYLE, colour

__all__ = ["plot_corner", "plot_posterior_predictive"]


def plot_corner(flat, keys, *, truths=None, bins=40):
    """Corner plot of a posterior sample `flat` (draws x parameters): each
    parameter's histogram on the diagonal, each pair's 2-D histogram below it;
    `truths` (optional) marked by lines."""
    # deferred: matplotlib loads only when a figure is drawn (import time)
    import matplotlib.pyplot as plt

    flat = np.asarray(flat, dtype=float)
    n = flat.shape[1]
    size = 2.2 * n + 0.6
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(n, n, figsize=(size, size), squeeze=False)
        for i in range(n):
            for j in range(n):
                ax = axes[i, j]
                if j > i:
                    ax.set_visible(False)
                    continue
                if i == j:
                    ax.hist(
                        flat[:, i], bins=bins, color=colour(0), histtype="stepfilled"
                    )
                    ax.set_yticks([])
                    if truths is not None:
                        ax.axvline(truths[i], color=colour(1))
                else:
                    ax.hist2d(flat[:, j], flat[:, i], bins=bins, cmap="Blues")
                    if truths is not None:
                        ax.axvline(truths[j], color=colour(1), lw=0.8)
                        ax.axhline(truths[i], color=colour(1), lw=0.8)
                if i == n - 1:
                    ax.set_xlabel(keys[j], fontsize=7)
                else:
                    ax.set_xticklabels([])
                if j == 0 and i > 0:
                    ax.set_ylabel(keys[i], fontsize=7)
        fig.suptitle("posterior (after burn-in)")
        fig.tight_layout()
    return fig


def plot_posterior_predictive(table):
    """Measured values with their intervals against the posterior predictive: one
    panel per ``panel`` of `table` (columns ``panel``, ``x``, ``xlabel``, ``obs``,
    ``obs_low``, ``obs_high``, ``pred_median``, ``pred_low``, ``pred_high``)."""
    # deferred: matplotlib loads only when a figure is drawn (import time)
    import matplotlib.pyplot as plt

    panels = list(dict.fromkeys(table["panel"]))
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(
            1,
            max(len(panels), 1),
            figsize=(4.2 * max(len(panels), 1), 3.4),
            squeeze=False,
        )
        for ax, name in zip(axes[0], panels, strict=False):
            t = table[table["panel"] == name].sort_values("x")
            x = t["x"].to_numpy(float)
            ax.fill_between(
                x,
                t["pred_low"].to_numpy(float),
                t["pred_high"].to_numpy(float),
                color=colour(0),
                alpha=0.3,
                label="posterior predictive",
            )
            ax.plot(x, t["pred_median"].to_numpy(float), color=colour(0))
            obs = t["obs"].to_numpy(float)
            err = np.vstack(
                [
                    obs - t["obs_low"].to_numpy(float),
                    t["obs_high"].to_numpy(float) - obs,
                ]
            )
            ax.errorbar(
                x, obs, yerr=err, fmt="o", color=colour(1), ms=4, label="measured"
            )
            ax.set_xlabel(t["xlabel"].iloc[0])
            ax.set_ylabel(name)
            ax.legend(fontsize=7)
        fig.tight_layout()
    return fig
