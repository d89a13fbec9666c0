"""Plot total Sobol' indices against speed (or angle): one panel per statistic.

The table is :attr:`microimpact.analysis.sensitivity.SensitivityResult.table` (or the
``sensitivity.csv`` read back with pandas).
"""

from __future__ import annotations

import math

import numpy as np

from ._style import colour, styled

__all__ = ["plot_sensitivity"]

_LABELS = {
    "capture_fraction": "capture fraction",
    "e_rebound_mean": "mean e (rebounds)",
    "mu_mean": "mean mu",
    "capture_speed_m_s": "50 % capture speed",
}


def _axis(table) -> str:
    """The sweep axis to draw against: speed, unless the sweep has one speed."""
    speeds = table["speed_m_s"].dropna().unique()
    return "speed_m_s" if len(speeds) > 1 else "angle_deg"


def plot_sensitivity(table, *, statistic=None, index="ST", ax=None):
    """Sobol' index `index` (``"ST"`` or ``"S1"``) of each parameter against speed
    (angle when the sweep has a single speed), with its confidence interval as a
    band; one panel per statistic.

    Curves are drawn per parameter and, when there are several, per surface
    (line style) and per value of the other sweep axis (marker). A statistic
    without a speed (``capture_speed_m_s``) is drawn against the angle.

    Parameters
    ----------
    table : pandas.DataFrame
        The columns of :data:`microimpact.analysis.sensitivity.COLUMNS`.
    statistic : str or sequence of str, optional
        Statistics to draw (default: all in the table, in order).
    index : {"ST", "S1"}
    ax : matplotlib.axes.Axes or array of Axes, optional
        One Axes per statistic; a new figure is made if omitted.

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
    """
    # deferred: matplotlib loads only when a figure is drawn

    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    if index not in ("ST", "S1"):
        raise ValueError(f"`index` must be 'ST' or 'S1'; got {index!r}.")
    stats = list(dict.fromkeys(table["statistic"]))
    if statistic is not None:
        wanted = [statistic] if isinstance(statistic, str) else list(statistic)
        bad = [s for s in wanted if s not in stats]
        if bad:
            raise ValueError(
                f"`statistic` {bad[0]!r} is not in the table; it has "
                f"{', '.join(repr(s) for s in stats)}."
            )
        stats = wanted
    params = list(dict.fromkeys(table["parameter"]))
    surfaces = list(dict.fromkeys(table["surface"])) if "surface" in table else [None]
    styles = ("-", "--", ":", "-.")
    markers = ("o", "s", "^", "v", "D", "P", "X")
    with styled():
        if ax is None:
            n = len(stats)
            cols = min(n, 3)
            rows = math.ceil(n / cols)
            _, ax = plt.subplots(
                rows, cols, figsize=(3.3 * cols, 2.8 * rows), squeeze=False
            )
            for extra in ax.flat[n:]:
                extra.set_visible(False)
        axes = np.atleast_1d(ax).ravel()
        if len(axes) < len(stats):
            raise ValueError(
                f"`ax` must hold one Axes per statistic ({len(stats)}); got "
                f"{len(axes)}."
            )
        notes = {}
        for a, stat in zip(axes, stats, strict=False):
            sub = table[table["statistic"] == stat]
            x_col = "angle_deg" if sub["speed_m_s"].isna().all() else _axis(sub)
            other = "angle_deg" if x_col == "speed_m_s" else "speed_m_s"
            others = list(dict.fromkeys(sub[other].dropna())) or [None]
            for i, p in enumerate(params):
                for j, surf in enumerate(surfaces):
                    for k, o in enumerate(others):
                        sel = sub[sub["parameter"] == p]
                        if surf is not None:
                            sel = sel[sel["surface"] == surf]
                        if o is not None:
                            sel = sel[sel[other] == o]
                        sel = sel.sort_values(x_col)
                        if sel.empty:
                            continue
                        label = p if (j == 0 and k == 0) else None
                        x = sel[x_col].to_numpy(float)
                        a.plot(
                            x,
                            sel[index].to_numpy(float),
                            linestyle=styles[j % len(styles)],
                            marker=markers[k % len(markers)]
                            if len(others) > 1
                            else "o",
                            ms=3,
                            color=colour(i),
                            label=label,
                        )
                        a.fill_between(
                            x,
                            sel[f"{index}_ci_low"].to_numpy(float),
                            sel[f"{index}_ci_high"].to_numpy(float),
                            color=colour(i),
                            alpha=0.15,
                            lw=0,
                        )
            a.set_xlabel(
                "incident speed [m/s]" if x_col == "speed_m_s" else "angle [deg]"
            )
            a.set_ylabel(f"{'total' if index == 'ST' else 'first-order'} index {index}")
            a.set_title(_LABELS.get(stat, stat))
            top = np.nanmax(sub[index].to_numpy(float), initial=1.0)
            a.set_ylim(-0.05, max(1.05, top + 0.05))
            if len(others) > 1:
                unit = "deg" if other == "angle_deg" else "m/s"
                notes[stat] = "markers: " + ", ".join(
                    f"{o:g} {unit} ({markers[k % len(markers)]})"
                    for k, o in enumerate(others)
                )
        axes[0].legend(loc="best")
        notes = list(dict.fromkeys(notes.values()))
        if len(surfaces) > 1:
            notes.append(
                "line style: "
                + ", ".join(f"{s} ({styles[j % 4]})" for j, s in enumerate(surfaces))
            )
        if notes:
            axes[0].figure.text(0.01, 0.005, "; ".join(notes), fontsize=7)
        axes[0].figure.tight_layout(rect=(0, 0.04 if notes else 0, 1, 1))
    return axes
