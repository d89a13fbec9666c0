"""Result figures: capture (paper Figs. 5, 6), coefficients against angle (Figs. 8,
11) and frequency distributions of e_m and mu_m (Figs. 9, 10).

matplotlib is imported only when a figure is made. Each ``plot_*`` function takes
``axes=None`` (a new figure) or the Axes to draw on, and returns the Axes. Bands are
the confidence intervals of the summary table; experimental points are drawn with
their interval bars. The style is applied around each figure only (``_style.styled``).

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, "Monte Carlo Analysis of Polydisperse
   Microparticle Impacts with Surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

from .._core.files import atomic_write
from .._core.formats import FIGURE_FORMATS
from .._core.validation import check_subset
from ..engine.result import dataset_surface_flags
from ..engine.statistics import capture_speed, z_value
from ..io.experiments import combine_experiments
from ._style import STYLE, colour, styled

__all__ = [
    "FIGURE_FORMATS",
    "drawn_speeds",
    "plot_capture",
    "plot_coefficients_vs_angle",
    "plot_convergence",
    "plot_distributions",
    "save_figure",
    "save_figures",
    "smooth_surfaces",
]

#: Speeds drawn as lines of their own (with a legend entry each); beyond, one
#: colour scale (a colour bar) shows the speed.
MAX_SPEED_LINES = 6
#: Points at most of a curve drawn with a marker each (beyond, the line alone).
MAX_MARKERS = 60
#: Speeds drawn at most on a coefficients figure: beyond, this many evenly spaced
#: ones (:func:`drawn_speeds`), on the colour bar of all of them (a sweep of 1000
#: speeds would draw 1000 overlapping curves, unreadable and slow).
MAX_SPEED_CURVES = 24
_EXP_STYLE = {"fmt": "s", "ms": 5, "mfc": "white", "color": "black", "lw": 0.9}
_BAND_ALPHA = 0.22


def _mpl():
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib as mpl

    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    return mpl, plt


# --------------------------------------------------------------------- helpers
def _summary(result):
    if not hasattr(result, "summary") or not hasattr(result, "scenario"):
        raise TypeError(
            f"`result` must be a SimulationResult; got {type(result).__name__}."
        )
    return result.summary.reset_index(drop=True)


def _confidence(result) -> float:
    """Confidence level of the result's intervals (the Dataset's, else the
    scenario's, else 0.95)."""
    conf = getattr(result, "confidence", None)
    if conf is None:
        conf = getattr(result.scenario, "confidence", 0.95)
    return float(conf)


def _z(result) -> float:

    return z_value(_confidence(result))


def smooth_surfaces(result) -> dict[str, bool]:
    """``{surface name: molecularly smooth}``, recognised by structure, never by
    name: the Dataset's ``surface_is_smooth`` flag, else the scenario surfaces'
    ``smooth`` attribute; a surface with neither counts as rough."""

    flags = dataset_surface_flags(result, "surface_is_smooth")
    if flags is not None:
        return flags
    return {
        str(s.name): bool(getattr(s, "smooth", False))
        for s in getattr(result.scenario, "surfaces", ())
    }


def _smooth(result, name) -> bool:
    return smooth_surfaces(result).get(str(name), False)


def _listed(values, limit=8) -> str:
    """ "1, 2, 3" or, for many values, "1, 2, 3, ..., 90 (1000 values)"."""
    text = [f"{float(v):g}" for v in values]
    if len(text) <= limit:
        return ", ".join(text)
    return f"{', '.join(text[:3])}, ..., {text[-1]} ({len(text)} values)"


def _pick(values, wanted, name):
    """The element of `values` close to `wanted`, or ValueError listing them."""
    values = np.unique(np.asarray(values, dtype=float))
    hit = values[np.isclose(values, float(wanted), rtol=1e-9, atol=1e-9)]
    if hit.size == 0:
        raise ValueError(
            f"`{name}` must be one of the simulated values {_listed(values)}; "
            f"got {float(wanted):g}."
        )
    return float(hit[0])


def _nearest(values, target) -> float:
    """The element of `values` nearest `target` (a default that always exists)."""
    values = np.unique(np.asarray(values, dtype=float))
    return float(values[np.argmin(np.abs(values - target))])


def _surfaces(summary, surface):
    names = list(dict.fromkeys(summary["surface"]))
    if surface is None:
        return names
    wanted = [surface] if isinstance(surface, str) else list(surface)
    bad = [w for w in wanted if w not in names]
    if bad or not wanted:
        raise ValueError(
            f"`surface` must be one of {', '.join(map(str, names))}; got "
            f"{', '.join(map(str, bad)) or 'none'}."
        )
    return wanted


def _draw_experiments(ax, exp, statistic, x_col, *, scale=1.0, label=None):
    if exp is None:
        return
    g = exp[(exp["statistic"] == statistic) & exp[x_col].notna()]
    if g.empty:
        return
    m = g["mean"].to_numpy(dtype=float) * scale
    lo = g["ci_low"].to_numpy(dtype=float) * scale
    hi = g["ci_high"].to_numpy(dtype=float) * scale
    ax.errorbar(
        g[x_col].to_numpy(dtype=float),
        m,
        yerr=[m - lo, hi - m],
        label=label or "Experiment (95 % CI)",
        zorder=5,
        **_EXP_STYLE,
    )


def _band(ax, x, mean, lo, hi, *, color, ls="-", label=None, marker=None):
    ax.fill_between(x, lo, hi, color=color, alpha=_BAND_ALPHA, lw=0)
    ax.plot(x, mean, color=color, ls=ls, label=label, marker=marker, ms=3)


def _new_axes(axes, nrows, ncols, figsize, *, sharex=False):
    _, plt = _mpl()
    if axes is None:
        _, axes = plt.subplots(
            nrows, ncols, figsize=figsize, sharex=sharex, layout="constrained"
        )
    axes = np.atleast_1d(np.asarray(axes, dtype=object)).ravel()
    if axes.size != nrows * ncols:
        raise ValueError(f"`axes` must hold {nrows * ncols} Axes; got {axes.size}.")
    return axes


# --------------------------------------------------------------------- capture
def plot_capture(result, *, surface=None, angle_deg=None, experiments=None, axes=None):
    """Coefficient of restitution and capture percentage against impact speed.

    The paper's Figs. 5 and 6 [1]_: the upper panel is the mean coefficient of
    restitution of the rebounding particles with its confidence band; the lower
    panel is the percentage captured with its Wilson band, and a diamond marks the
    speed at which 50 % are captured, with the interval where the band crosses 50 %.

    Parameters
    ----------
    result : SimulationResult
        A run with at least one speed at `angle_deg`.
    surface : str, optional
        Surface to draw (default: every simulated surface, one colour each).
    angle_deg : float, optional
        Apparent incidence angle [deg]; at 90° the speed is the normal impact
        speed. Default: the swept angle nearest 90°.
    experiments : DataFrame, path or sequence of them, optional
        Experimental points (:func:`~microimpact.io.experiments.read_experiments`);
        rows with ``statistic`` ``e`` go to the upper panel, ``capture_fraction``
        to the lower one (as percentages).
    axes : sequence of two Axes, optional
        Upper and lower panel; a new figure is made if omitted.

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
        The two panels.
    """

    _mpl()
    summary = _summary(result)
    if angle_deg is None:
        angle = _nearest(summary["angle_deg"], 90.0)
    else:
        angle = _pick(summary["angle_deg"], angle_deg, "angle_deg")
    names = _surfaces(summary, surface)
    exp = combine_experiments(experiments)
    if exp is not None:
        exp = exp[exp["angle_deg"].isna() | np.isclose(exp["angle_deg"], angle)]
    if hasattr(result, "capture_speed"):  # a SimulationResult: its own confidence
        cap = result.capture_speed(0.5)
    else:
        cap = capture_speed(summary, 0.5)
    with styled():
        ax_e, ax_c = _new_axes(axes, 2, 1, (5.0, 5.6), sharex=True)
        for k, name in enumerate(names):
            g = summary[
                (summary["surface"] == name) & np.isclose(summary["angle_deg"], angle)
            ].sort_values("speed_m_s")
            v = g["speed_m_s"].to_numpy(dtype=float)
            c = colour(k)
            label = "Monte Carlo" + (f" ({name})" if len(names) > 1 else "")
            _band(
                ax_e,
                v,
                g["e_rebound_mean"].to_numpy(dtype=float),
                g["e_rebound_ci_low"],
                g["e_rebound_ci_high"],
                color=c,
                label=label,
                marker="o" if v.size <= MAX_MARKERS else None,
            )
            _band(
                ax_c,
                v,
                100 * g["capture_fraction"],
                100 * g["capture_ci_low"],
                100 * g["capture_ci_high"],
                color=c,
                label=label,
                marker="o" if v.size <= MAX_MARKERS else None,
            )
            row = cap[(cap["surface"] == name) & np.isclose(cap["angle_deg"], angle)]
            for _, r in row.iterrows():
                _capture_marker(
                    ax_c, r, v, color=c, name=name if len(names) > 1 else None
                )
        _draw_experiments(ax_e, exp, "e", "speed_m_s")
        _draw_experiments(ax_c, exp, "capture_fraction", "speed_m_s", scale=100.0)
        ax_c.axhline(50.0, color="0.5", lw=0.7, ls=":")
        speeds = summary["speed_m_s"].to_numpy(dtype=float)
        if speeds.min() > 0 and speeds.max() / speeds.min() > 20:
            # deferred: matplotlib loads only when a figure is drawn
            from matplotlib import ticker

            ax_c.set_xscale("log")
            ax_c.xaxis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
            ax_c.xaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
            ax_c.xaxis.set_minor_formatter(ticker.NullFormatter())
        xl = (
            "Normal impact speed $v_n$ [m s⁻¹]"
            if math.isclose(angle, 90.0)
            else f"Incident speed at θ = {angle:g}° [m s⁻¹]"
        )
        ax_c.set_xlabel(xl)
        ax_e.set_ylabel("Coefficient of restitution $e$ [–]")
        ax_c.set_ylabel("Capture [%]")
        ax_c.set_ylim(-3, 103)
        if np.isfinite(summary["e_rebound_mean"].to_numpy(dtype=float)).any():
            ax_e.set_ylim(bottom=0)
        ax_e.set_title(
            f"{result.scenario.name}: mean ({_conf_label(result)} band), "
            "median, 5–95 %",
            fontsize=9,
        )
        ax_e.legend(loc="lower right")
        ax_c.legend(loc="upper right")
    return np.array([ax_e, ax_c], dtype=object)


def _capture_marker(ax, row, speeds, *, color, name=None):
    """The capture-speed estimate of one curve and its interval, at the quantile.

    `row` is a row of :func:`~microimpact.engine.statistics.capture_speed`. The
    interval is drawn from its own limits (never as offsets from the estimate, so
    no limit can make a negative bar); an open side (NaN limit) is a dotted line
    to the end of the simulated speeds with an arrow head; a refused estimate (NaN)
    has no marker, and its ``note`` is stated in the legend instead.
    """
    q = float(row.get("quantile", 0.5))
    y = 100.0 * q
    where = f" ({name})" if name else ""
    v = _finite(row.get("speed_m_s"))
    lo, hi = _finite(row.get("speed_ci_low")), _finite(row.get("speed_ci_high"))
    if v is None:
        note = str(row.get("note") or "").strip() or "the sweep does not support one"
        label = textwrap.fill(
            f"{100 * q:g} % capture{where}: no estimate; {note}", width=48
        )
        ax.plot([], [], ls="none", marker="D", mfc="white", color=color, label=label)
        return
    speeds = np.asarray(speeds, dtype=float)
    speeds = speeds[np.isfinite(speeds)]
    left = lo if lo is not None else min(v, float(speeds.min(initial=v)))
    right = hi if hi is not None else max(v, float(speeds.max(initial=v)))
    for a, b, closed, head in (
        (left, v, lo is not None, "<"),
        (v, right, hi is not None, ">"),
    ):
        a, b = min(a, b), max(a, b)
        ax.plot(
            [a, b], [y, y], color=color, lw=1.2, ls="-" if closed else ":", zorder=6
        )
        end = a if head == "<" else b
        if closed:
            ax.plot([end], [y], marker="|", ms=7, color=color, zorder=6)
        else:
            ax.plot([end], [y], marker=head, ms=5, color=color, zorder=6)
    text = f"[{_g3(lo)}, {_g3(hi)}]"
    ax.plot(
        [v],
        [y],
        ls="none",
        marker="D",
        ms=6,
        color=color,
        mec="black",
        mew=0.6,
        zorder=7,
        label=f"{100 * q:g} % capture{where}: {v:.3g} m s⁻¹ {text}",
    )


def _finite(x):
    """`x` as a float, or None when it is missing or not finite."""
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _g3(x) -> str:
    return "open" if x is None else f"{x:.3g}"


def _conf_label(result) -> str:
    return f"{100 * _confidence(result):g} %"


# --------------------------------------------------------------------- angles
def plot_coefficients_vs_angle(
    result, *, relative=None, experiments=None, axes=None, speed_m_s=None
):
    """Coefficient of restitution and impulse ratio against incidence angle.

    The paper's Figs. 8 and 11 [1]_: one line per surface (solid for a rough
    surface, dashed for a molecularly smooth one) and, if several speeds are swept,
    per speed (one colour each), with confidence bands.

    Parameters
    ----------
    result : SimulationResult
        A run with an angle sweep.
    relative : bool, optional
        Draw the paper's relative coefficients ``e - e(θ_ref)`` and
        ``μ - μ(θ_ref)`` (band ``± z SE``), else the means of rebounds
        ``e`` and ``μ`` (band: their confidence interval). Default: the relative
        ones where the reference angle (``reference_angle_deg``, 85° by default)
        is in the sweep, else the means.
    experiments : DataFrame, path or sequence of them, optional
        Rows with ``statistic`` ``e_relative``/``mu_relative`` (or ``e``/``mu``
        when ``relative=False``) and an ``angle_deg``.
    axes : sequence of two Axes, optional
        Upper (e) and lower (μ) panel; a new figure is made if omitted.
    speed_m_s : float, optional
        Draw one speed only (default: all).

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
    """
    _mpl()
    summary = _summary(result)
    if speed_m_s is not None:
        sp = _pick(summary["speed_m_s"], speed_m_s, "speed_m_s")
        summary = summary[np.isclose(summary["speed_m_s"], sp)]
    ref = getattr(result.scenario, "reference_angle_deg", None)
    if relative is None:  # the paper's relative form where the sweep allows it
        relative = "e_relative" in summary
    if relative and "e_relative" not in summary:
        where = "no reference angle" if ref is None else f"reference angle {ref:g} deg"
        raise ValueError(
            f"`relative=True` needs the {where} in the angle sweep "
            f"({_listed(summary['angle_deg'].unique())}); pass `relative=False`."
        )
    z = _z(result)
    if relative:
        specs = (
            ("e_relative", "e_relative_se", None, None),
            ("mu_relative", "mu_relative_se", None, None),
        )
        stats = ("e_relative", "mu_relative")
        ylabels = (
            f"Relative restitution $e - e_{{{ref:g}°}}$ [–]",
            f"Relative impulse ratio $μ - μ_{{{ref:g}°}}$ [–]",
        )
    else:
        specs = (
            ("e_rebound_mean", "e_rebound_se", "e_rebound_ci_low", "e_rebound_ci_high"),
            ("mu_mean", "mu_se", "mu_ci_low", "mu_ci_high"),
        )
        stats = ("e", "mu")
        ylabels = ("Coefficient of restitution $e_m$ [–]", "Impulse ratio $μ_m$ [–]")
    exp = combine_experiments(experiments)
    speeds = list(dict.fromkeys(summary["speed_m_s"]))
    names = list(dict.fromkeys(summary["surface"]))
    # beyond a few speeds: one colour scale for speed (a colour bar), the legend
    # names the surfaces only, and the medians and 5-95 % bands are left out
    many = len(speeds) > MAX_SPEED_LINES
    speed_colour = _speed_colours(speeds) if many else None
    drawn = drawn_speeds(speeds)
    smooth = {name: _smooth(result, name) for name in names}
    curves = _angle_curves(summary, names, drawn)
    with styled():
        axs = _new_axes(axes, 2, 1, (5.0, 5.6), sharex=True)
        scale_of = {ax: [] for ax in axs}
        for ax, (col, se_col, lo_col, hi_col) in zip(axs, specs, strict=True):
            for i, name in enumerate(names):
                for j, sp in enumerate(drawn):
                    g = curves.get((name, sp))
                    if g is None:
                        continue
                    m = g[col].to_numpy(dtype=float)
                    if lo_col is None:
                        lo = m - z * g[se_col].to_numpy(dtype=float)
                        hi = m + z * g[se_col].to_numpy(dtype=float)
                    else:
                        lo, hi = g[lo_col], g[hi_col]
                    label = f"Monte Carlo, {name}"
                    if len(speeds) > 1:
                        label += f", {sp:g} m s⁻¹"
                    x = g["angle_deg"].to_numpy(dtype=float)
                    c = colour(j if len(speeds) > 1 else i)
                    if many:
                        c, label = speed_colour[1](speed_colour[0](sp)), None
                    _band(
                        ax,
                        x,
                        m,
                        lo,
                        hi,
                        color=c,
                        ls="--" if smooth[name] else "-",
                        label=label,
                    )
                    scale_of[ax].append(m)
                    if not smooth[name] and not many:
                        scale_of[ax].append(
                            _spread(ax, g, col, ref, relative, x, color=c)
                        )
        for ax in axs:  # the paper's scale: the means and medians, not the tails
            _paper_scale(ax, scale_of[ax])
        for ax, stat, yl in zip(axs, stats, ylabels, strict=True):
            _draw_experiments(ax, exp, stat, "angle_deg")
            if relative:
                ax.axhline(0.0, color="0.4", lw=0.6)
            ax.set_ylabel(yl)
        axs[1].set_xlabel("Apparent incidence angle θ [°]")
        axs[1].set_xlim(0, 90)
        axs[1].set_xticks(np.arange(0, 91, 15))
        axs[0].set_title(
            f"{result.scenario.name}: mean ({_conf_label(result)} band)"
            + (", colour: speed" if many else ", median, 5–95 %"),
            fontsize=9,
        )
        if many:
            label = "speed [m s⁻¹]"
            if len(drawn) < len(speeds):
                label += f" ({len(drawn)} of {len(speeds)} drawn)"
            _surface_legend_and_colour_bar(axs, names, result, speed_colour, label)
        else:  # beside the data, not on it
            axs[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)
    return axs


def drawn_speeds(speeds, limit=None) -> list:
    """The speeds of `speeds` (sweep order) that :func:`plot_coefficients_vs_angle`
    draws: all up to `limit` (default :data:`MAX_SPEED_CURVES`), else `limit`
    evenly spaced in sweep order (first and last included; a logarithmic sweep
    stays logarithmic); the colour bar spans them all."""
    speeds = list(speeds)
    limit = MAX_SPEED_CURVES if limit is None else limit
    if len(speeds) <= limit:
        return speeds
    idx = np.unique(np.round(np.linspace(0, len(speeds) - 1, limit)).astype(int))
    return [speeds[i] for i in idx]


def _angle_curves(summary, names, speeds) -> dict:
    """``{(surface, speed): rows sorted by angle}`` for the given surfaces and
    speeds: one pass over the table (not one mask per curve)."""
    rows = summary[summary["surface"].isin(names) & summary["speed_m_s"].isin(speeds)]
    return {
        key: g.sort_values("angle_deg")
        for key, g in rows.groupby(["surface", "speed_m_s"], sort=False)
    }


def _speed_colours(speeds):
    """``(norm, colormap)`` of the speeds (logarithmic where they span a decade)."""
    mpl, _ = _mpl()
    lo, hi = min(speeds), max(speeds)
    if hi > 10 * lo:
        norm = mpl.colors.LogNorm(lo, hi)
    else:
        norm = mpl.colors.Normalize(lo, hi if hi > lo else lo * 1.001)
    return norm, mpl.colormaps["viridis"]


def _surface_legend_and_colour_bar(axs, names, result, speed_colour, label):
    """The legend of the surfaces (line styles) beside the axes, and the colour bar
    of the speeds (labelled `label`)."""
    mpl, _ = _mpl()
    handles = [
        mpl.lines.Line2D(
            [], [], color="0.2", ls="--" if _smooth(result, n) else "-", label=n
        )
        for n in names
    ]
    axs[0].legend(
        handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7
    )
    norm, cmap = speed_colour
    mappable = mpl.cm.ScalarMappable(norm=norm, cmap=cmap)
    axs[0].figure.colorbar(mappable, ax=list(axs), label=label, shrink=0.6)


def _spread(ax, g, col, ref, relative, x, *, color):
    """Median (dotted) and 5-95 % band (hatched, unfilled) of the rebounds' e_m or
    mu_m beside the mean: heavy tails pull the mean away from the median. In the
    relative panel both are shifted by the median at the reference angle."""
    base = "e" if col.startswith("e") else "mu"
    cols = [f"{base}_p05", f"{base}_p50", f"{base}_p95"]
    if not all(c in g for c in cols):
        return np.array([])
    p05, p50, p95 = (g[c].to_numpy(dtype=float) for c in cols)
    if relative:
        at = np.isclose(x, float(ref)) if ref is not None else np.zeros(x.size, bool)
        if not at.any():
            return np.array([])
        shift = p50[at][0]
        p05, p50, p95 = p05 - shift, p50 - shift, p95 - shift
    ax.fill_between(
        x,
        p05,
        p95,
        facecolor="none",
        edgecolor=color,
        hatch="////",
        lw=0,
        alpha=0.35,
        label="5–95 % of rebounds",
    )
    ax.plot(x, p50, color=color, ls=":", lw=1.4, label="median of rebounds")
    return p50


def _paper_scale(ax, curves):
    """y-limits that hold the mean and median curves with a margin (the 5-95 %
    band may run off the panel, as in the paper's figures, which show means)."""
    vals = np.concatenate([np.ravel(c) for c in curves]) if curves else np.array([])
    vals = vals[np.isfinite(vals)]
    if vals.size == 0:
        return
    lo, hi = float(min(vals.min(), 0.0)), float(max(vals.max(), 0.0))
    pad = 0.08 * max(hi - lo, 0.1)
    ax.set_ylim(lo - pad, hi + pad)


# --------------------------------------------------------------------- histograms
def rebin(counts, edges, *, target_bins=30, tail=0.002):
    """Merge uniform histogram bins into about `target_bins` readable classes.

    The shown range drops a fraction `tail` of the pooled counts (half each side)
    and is at least `target_bins` original bins wide; bins are merged in groups of
    ``ceil(range / target_bins)`` aligned on the original grid.

    Parameters
    ----------
    counts : sequence of 1-D arrays
        Histograms on the same uniform `edges`.
    edges : 1-D array
        Uniform bin edges.

    Returns
    -------
    list of ndarray, ndarray, float
        Merged counts (one per input), the merged edges, and the fraction of the
        pooled counts outside the shown range.
    """
    counts = [np.asarray(c, dtype=float) for c in counts]
    edges = np.asarray(edges, dtype=float)
    nb = edges.size - 1
    total = np.sum(counts, axis=0)
    s = total.sum()
    if s <= 0:
        return [c[:0] for c in counts], edges[:1], 0.0
    cdf = np.cumsum(total) / s
    i0 = int(np.searchsorted(cdf, tail / 2.0, side="right"))
    i1 = int(np.searchsorted(cdf, 1.0 - tail / 2.0, side="left")) + 1
    i1 = min(max(i1, i0 + 1), nb)
    if i1 - i0 < target_bins:  # a spike: show at least target_bins fine bins
        mid = (i0 + i1) // 2
        i0 = max(0, mid - target_bins // 2)
        i1 = min(nb, i0 + target_bins)
    factor = max(1, math.ceil((i1 - i0) / target_bins))
    i0 = (i0 // factor) * factor
    n_new = math.ceil((i1 - i0) / factor)
    i1 = i0 + n_new * factor
    dw = edges[1] - edges[0]
    new_edges = edges[0] + dw * np.arange(i0, i1 + 1, factor)
    merged = []
    for c in counts:
        part = np.zeros(n_new * factor)
        stop = min(i1, nb)
        part[: stop - i0] = c[i0:stop]
        merged.append(part.reshape(n_new, factor).sum(axis=1))
    shown = np.sum(merged, axis=0).sum()
    return merged, new_edges, float(1.0 - shown / s)


def _n_rebounds(summary, point, counts):
    if "n_rebounds" in summary and np.isfinite(summary.loc[point, "n_rebounds"]):
        return summary.loc[point, "n_rebounds"]
    return np.asarray(counts).sum()


def plot_distributions(result, *, angle_deg, speed_m_s=None, surface=None, axes=None):
    """Frequency distributions of e_m and μ_m over rebounds at one angle.

    The paper's Figs. 9 and 10 [1]_, from the run's fixed-bin histograms merged
    into about 30 classes (:func:`rebin`). The frequency is the percentage of the
    rebounding particles in each class.

    Parameters
    ----------
    result : SimulationResult
    angle_deg : float
        Apparent incidence angle [deg], one of the simulated angles.
    speed_m_s : float, optional
        Incident speed [m s⁻¹]; required when several are simulated.
    surface : str or sequence of str, optional
        Surfaces to overlay (default: all).
    axes : sequence of two Axes, optional
        Left (e_m) and right (μ_m) panel; a new figure is made if omitted.

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
    """
    _mpl()
    summary = _summary(result)
    angle = _pick(summary["angle_deg"], angle_deg, "angle_deg")
    speeds = np.unique(summary["speed_m_s"].to_numpy(dtype=float))
    if speed_m_s is None:
        if speeds.size != 1:
            raise ValueError(
                "`speed_m_s` must be given when several speeds are simulated: one "
                f"of {_listed(speeds)}."
            )
        speed = float(speeds[0])
    else:
        speed = _pick(speeds, speed_m_s, "speed_m_s")
    names = _surfaces(summary, surface)
    points = []
    for name in names:
        idx = np.flatnonzero(
            (summary["surface"] == name).to_numpy()
            & np.isclose(summary["angle_deg"], angle)
            & np.isclose(summary["speed_m_s"], speed)
        )
        points.append((name, int(idx[0])))
    with styled():
        axs = _new_axes(axes, 1, 2, (7.4, 3.2))
        for ax, stat, xl in zip(
            axs,
            ("e", "mu"),
            ("Apparent restitution $e_m$ [–]", "Apparent impulse ratio $μ_m$ [–]"),
            strict=True,
        ):
            hists = [result.histogram(p, stat) for _, p in points]
            edges = hists[0][1]
            merged, new_edges, _ = rebin([h[0] for h in hists], edges)
            n_tot, n_shown = 0, 0.0
            for k, ((name, p), c) in enumerate(zip(points, merged, strict=True)):
                # all rebounds, including those beyond the histogram's edges
                n_reb = int(_n_rebounds(summary, p, hists[k][0]))
                if n_reb == 0:
                    continue
                n_tot += n_reb
                n_shown += float(c.sum())
                mean_col = "e_rebound_mean" if stat == "e" else "mu_mean"
                mean = float(summary.loc[p, mean_col])
                ax.stairs(
                    100.0 * c / n_reb,
                    new_edges,
                    fill=k == 0,
                    alpha=0.55 if k == 0 else 1.0,
                    color=colour(k),
                    lw=1.2,
                    label=f"{name}: n = {n_reb:,}, mean = {mean:.3f}",
                )
            if n_tot == 0:
                ax.text(
                    0.5,
                    0.5,
                    "no rebounds",
                    transform=ax.transAxes,
                    ha="center",
                    va="center",
                )
            else:
                outside = 1.0 - n_shown / n_tot
                title = (
                    f"{100 * outside:.2g} % outside the range shown"
                    if outside > 5e-5
                    else None
                )
                ax.legend(
                    loc="best",
                    fontsize="x-small",
                    title=title,
                    title_fontsize="x-small",
                )
            ax.set_xlabel(xl)
            ax.set_ylabel("Frequency [% of rebounds]")
            ax.set_ylim(bottom=0)
        axs[0].set_title(f"θ = {angle:g}°, {speed:g} m s⁻¹", loc="left")
    return axs


# --------------------------------------------------------------------- convergence
def plot_convergence(convergence, *, ax=None):
    """Running capture percentage against the number of impacts N.

    The paper's convergence study: the estimate with its Wilson band, the band
    ``final ± tolerance`` (the paper's ±3 %), and the N at which the estimate settles
    inside it and the N at which the Wilson half-width reaches it.

    Parameters
    ----------
    convergence : ConvergenceResult
        Output of :func:`microimpact.engine.convergence.convergence_study`.
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    _, plt = _mpl()
    t = getattr(convergence, "table", None)
    if t is None or not {"n", "capture_fraction", "ci_low", "ci_high"} <= set(
        t.columns
    ):
        raise TypeError(
            "`convergence` must be a ConvergenceResult; "
            f"got {type(convergence).__name__}."
        )
    with styled():
        if ax is None:
            _, ax = plt.subplots(figsize=(5.0, 3.4), layout="constrained")
        n = t["n"].to_numpy(dtype=float)
        conf = f"{100 * float(convergence.confidence):g} %"
        _band(
            ax,
            n,
            100 * t["capture_fraction"],
            100 * t["ci_low"],
            100 * t["ci_high"],
            color=colour(0),
            label=f"running estimate, {conf} Wilson band",
        )
        f, tol = 100 * convergence.final, 100 * convergence.tolerance
        ax.axhspan(
            f - tol, f + tol, color="0.5", alpha=0.15, lw=0, label=f"final ± {tol:g} %"
        )
        if convergence.n_settled is not None:
            ax.axvline(
                convergence.n_settled,
                color=colour(1),
                ls="--",
                lw=1,
                label=f"settled: N = {convergence.n_settled:,}",
            )
        ax.axvline(
            convergence.n_required,
            color=colour(2),
            ls=":",
            lw=1.2,
            label=f"half-width ≤ {tol:g} %: N = {convergence.n_required:,}",
        )
        ax.set_xscale("log")
        ax.set_xlabel("Number of simulated impacts N [–]")
        ax.set_ylabel("Capture [%]")
        ax.legend(loc="lower right")
    return ax


# --------------------------------------------------------------------- files
def save_figure(fig, path_without_ext, formats=("png", "pdf")):
    """Write `fig` as ``<path_without_ext>.<format>`` for each format, atomically.

    Each file is written to a temporary file in the same folder and renamed onto
    its name, so a reader never sees a half-written figure. PDF and SVG files
    carry no creation date, so reruns give identical files.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path_without_ext : str or path-like
    formats : sequence of {"png", "pdf", "svg"}

    Returns
    -------
    list of pathlib.Path
    """

    formats = check_subset(formats, "formats", FIGURE_FORMATS)
    base = Path(path_without_ext)
    meta = {"png": {}, "pdf": {"CreationDate": None}, "svg": {"Date": None}}
    out = []
    for fmt in formats:
        path = atomic_write(
            base.with_name(f"{base.name}.{fmt}"),
            lambda tmp, fmt=fmt: fig.savefig(
                tmp, format=fmt, dpi=STYLE["savefig.dpi"], metadata=meta[fmt]
            ),
        )
        out.append(path)
    return out


def _figure_of(obj):
    """The Figure of a Figure, an Axes or an array of Axes."""
    if hasattr(obj, "savefig"):
        return obj
    if not hasattr(obj, "figure"):
        obj = np.ravel(np.asarray(obj, dtype=object))[0]
    return obj.figure


def save_figures(items, out_dir, formats=("png", "pdf")):
    """Save each ``(stem, figure)`` of `items` as ``out_dir/<stem>.<format>`` and
    close it (:func:`save_figure` for each).

    A figure is a matplotlib Figure, an Axes or an array of Axes, or a function of
    no arguments that draws and returns one (called just before it is saved). Every
    figure is closed, also when saving fails (then the figures not yet saved are
    closed too, and the error is raised).

    Parameters
    ----------
    items : iterable of (str, figure)
    out_dir : str or path-like
        Folder for the files (created if needed).
    formats : sequence of {"png", "pdf", "svg"}

    Returns
    -------
    list of pathlib.Path
        Every file written, in the order of `items`.
    """
    _, plt = _mpl()
    out_dir = Path(out_dir)
    pending = list(items)
    paths = []
    try:
        while pending:
            stem, fig = pending.pop(0)
            fig = _figure_of(fig() if callable(fig) else fig)
            try:
                paths.extend(save_figure(fig, out_dir / stem, formats))
            finally:
                plt.close(fig)
    finally:
        for _stem, fig in pending:  # only after a failure
            if not callable(fig):
                plt.close(_figure_of(fig))
    return paths
