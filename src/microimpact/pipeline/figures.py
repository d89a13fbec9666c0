"""Which figures a result gets, their file names and captions: the pipeline's
choice over the figure functions of :mod:`microimpact.plotting` (which draw one
figure each and choose nothing)."""

from __future__ import annotations

import numpy as np

from ..analysis.compare import compare
from ..errors import InputError
from ..io.experiments import combine_experiments
from ..plotting.areal import CAPTION, has_areal_surface, plot_profile_vs_areal
from ..plotting.comparison import plot_comparison
from ..plotting.results import (
    _conf_label,
    _smooth,
    _summary,
    drawn_speeds,
    plot_capture,
    plot_coefficients_vs_angle,
    plot_distributions,
    save_figures,
)

__all__ = [
    "distribution_speed",
    "figure_caption",
    "figures_for_result",
    "result_figures",
]


def _angle_tag(a: float) -> str:
    return f"{a:g}".replace(".", "p") + "deg"


def swept_speed(speeds, wanted) -> float:
    """The swept speed among `speeds` [m/s] that is `wanted` (to 1e-9 relative).

    Raises
    ------
    InputError
        `wanted` is not among them (the swept ones are named).
    """
    swept = np.unique(np.asarray(speeds, dtype=float))
    hit = swept[np.isclose(swept, float(wanted), rtol=1e-9, atol=0.0)]
    if not hit.size:
        shown = ", ".join(f"{v:g}" for v in swept[:12])
        more = ", ..." if swept.size > 12 else ""
        raise InputError(
            f"{float(wanted):g} m/s is not a swept speed; allowed: one of "
            f"{shown}{more}",
            field="distribution_speed_m_s",
        )
    return float(hit[0])


def distribution_speed(result, wanted=None) -> float:
    """The speed of the distribution figures: `wanted` (one of the swept speeds),
    else the slowest swept speed at which the rough surfaces (every surface, if
    none is rough) have rebounds at every swept angle, else the one with the most
    rebounds (a sweep that starts below capture drew empty panels at its slowest
    speed).

    Raises
    ------
    InputError
        `wanted` is not a swept speed (the swept ones are named).
    """
    summary = _summary(result)
    if wanted is not None:
        return swept_speed(summary["speed_m_s"], wanted)
    names = [n for n in dict.fromkeys(summary["surface"]) if not _smooth(result, n)]
    # the three columns read below only (a filtered copy of the whole table
    # held ~230 MB at 10^6 points)
    rows = summary[["speed_m_s", "e_rebound_mean", "capture_fraction"]]
    if names:
        rows = rows[summary["surface"].isin(names)]
    rebounds = rows["e_rebound_mean"].notna().groupby(rows["speed_m_s"]).all()
    speeds = rebounds.index.to_numpy(dtype=float)
    if rebounds.any():
        return float(speeds[rebounds.to_numpy()][0])
    share = (1.0 - rows["capture_fraction"]).groupby(rows["speed_m_s"]).mean()
    return float(share.idxmax())


def figure_caption(
    stem, result, *, distribution_speed_m_s=None, experiments=False
) -> str:
    """Caption of the figure file `stem` (see :func:`figures_for_result`);
    `experiments`: whether the figure shows experiments (their legend entry)."""
    sc = result.scenario
    data = "; squares: experiments." if experiments else "."
    conf = _conf_label(result)
    ref = getattr(sc, "reference_angle_deg", None)
    if stem == "capture":
        return (
            "Normal (90°) impact against speed (paper Figs. 5, 6). Upper: mean "
            "coefficient of restitution of the rebounding particles; lower: "
            f"percentage captured. Bands: {conf} confidence intervals; diamond: "
            "speed of 50 % capture with its interval (dotted with an arrow: a side "
            "the data do not bound; no diamond: no estimate, the legend says "
            "why)" + data
        )
    if stem in ("coefficients", "coefficients_relative"):
        text = _coefficients_caption(stem, result, conf, ref)
        if stem == "coefficients_relative":
            text = text.removesuffix(".") + data
        return text + _speed_subset(result)
    if stem.startswith("distributions_"):
        a = stem.removeprefix("distributions_").removesuffix("deg").replace("p", ".")
        return (
            f"Frequency distributions of e_m and μ_m at θ = {a}°, "
            f"{distribution_speed(result, distribution_speed_m_s):g} m s⁻¹ (paper "
            "Figs. 9, 10"
            + (
                "; the slowest swept speed at which particles rebound"
                if distribution_speed_m_s is None
                else ""
            )
            + "); rough surfaces only when there are any."
        )
    if stem == "profile_vs_areal":
        return CAPTION
    if stem == "size_distribution":
        return "Particle diameter distribution (paper Fig. 2)."
    if stem.startswith("angle_pdf_"):
        return (
            f"Roughness-angle distribution of the surface "
            f"{stem.removeprefix('angle_pdf_')} (paper Fig. 4)."
        )
    if stem == "comparison":
        return (
            "Simulated against experimental means with their intervals; "
            "filled markers agree at the 95 % level."
        )
    return stem.replace("_", " ")


def _coefficients_caption(stem, result, conf, ref) -> str:
    """Caption of ``coefficients_relative`` (relative) or ``coefficients``."""
    if stem == "coefficients_relative":
        return (
            f"Relative coefficients e − e({ref:g}°) and μ − μ({ref:g}°) "
            "against apparent incidence angle (paper Figs. 8, 11). Solid: rough "
            f"surface; dashed: molecularly smooth. Bands: {conf} intervals; "
            "dotted and hatched: the median and the 5–95 % range of the rough "
            "surface's rebounds, shifted by the median at the reference angle "
            "(a mean far from its median is pulled by a tail; the panel's scale "
            "holds the means and medians, the hatched range may leave it)."
        )
    return (
        "Mean apparent coefficient of restitution and impulse ratio of the "
        "rebounding particles against apparent incidence angle. Solid: rough "
        f"surface; dashed: molecularly smooth. Bands: {conf} intervals; "
        "dotted and hatched: the median and the 5–95 % range of the rough "
        "surface's rebounds."
    )


def _speed_subset(result) -> str:
    """The caption's sentence when a coefficients figure draws a subset of the
    speeds (:func:`~microimpact.plotting.results.drawn_speeds`)."""
    speeds = list(dict.fromkeys(_summary(result)["speed_m_s"]))
    drawn = drawn_speeds(speeds)
    if len(drawn) == len(speeds):
        return ""
    return (
        f" {len(drawn)} of the {len(speeds)} swept speeds are drawn, evenly spaced "
        "in sweep order (the colour bar spans all); every point is in "
        "summary.csv and results.nc."
    )


def result_figures(result, *, experiments=None, distribution_speed_m_s=None):
    """The figures that apply to `result`, made in memory.

    Returns a list of ``(stem, caption, Figure)``; see :func:`figures_for_result`
    for the rules and names. Only `result` and `experiments` are used (a fresh
    result and one opened from ``results.nc`` give the same figures). The caller
    closes the figures.
    """
    summary = _summary(result)
    speeds = np.unique(summary["speed_m_s"].to_numpy(dtype=float))
    angles = np.unique(summary["angle_deg"].to_numpy(dtype=float))
    exp = combine_experiments(experiments)
    out = []

    def add(stem, axes):
        fig = np.ravel(axes)[0].figure
        out.append(
            (
                stem,
                figure_caption(
                    stem, result, distribution_speed_m_s=distribution_speed_m_s
                ),
                fig,
            )
        )

    if speeds.size >= 2 and np.isclose(angles, 90.0).any():
        add("capture", plot_capture(result, experiments=exp))
    if angles.size >= 2:
        relative = "e_relative" in summary and summary["e_relative"].notna().any()
        if relative:
            add(
                "coefficients_relative",
                plot_coefficients_vs_angle(result, relative=True, experiments=exp),
            )
        add(
            "coefficients",
            plot_coefficients_vs_angle(result, relative=False, experiments=exp),
        )
        rough = [n for n in dict.fromkeys(summary["surface"]) if not _smooth(result, n)]
        ref = getattr(result.scenario, "reference_angle_deg", None)
        high = angles.max()
        if ref is not None and np.isclose(angles, ref).any():
            high = float(angles[np.isclose(angles, ref)][0])  # the paper's 85°
        for a in dict.fromkeys((float(angles.min()), float(high))):
            add(
                f"distributions_{_angle_tag(a)}",
                plot_distributions(
                    result,
                    angle_deg=a,
                    speed_m_s=distribution_speed(result, distribution_speed_m_s),
                    surface=rough or None,
                ),
            )

        if has_areal_surface(result):  # not in the paper (issue 14)
            add("profile_vs_areal", plot_profile_vs_areal(result))
    if exp is not None and len(exp):
        add("comparison", plot_comparison(compare(result, exp)))
    return out


def figures_for_result(
    result,
    out_dir,
    *,
    formats=("png", "pdf"),
    experiments=None,
    distribution_speed_m_s=None,
):
    """Make and save every figure that applies to `result`.

    ===============================  =============================================
    file stem                        made when; what it shows
    ===============================  =============================================
    ``capture``                      ≥ 2 speeds and 90° simulated: Figs. 5/6
    ``coefficients_relative``        ≥ 2 angles and the reference angle in the
                                     sweep: Figs. 8/11, relative e and μ
    ``coefficients``                 ≥ 2 angles: absolute e_m and μ_m vs angle
    ``distributions_<a>deg``         ≥ 2 angles, at the smallest angle and at the
                                     reference angle (the largest if it is not
                                     swept), first speed, rough surfaces only if
                                     any: Figs. 9/10 (``12p5deg`` for 12.5°)
    ``profile_vs_areal``             ≥ 2 angles and an areal surface: e_m, μ_m,
                                     capture and lateral scatter against angle,
                                     one line per surface (not in the paper)
    ``comparison``                   experiments given
    ===============================  =============================================

    Parameters
    ----------
    result : SimulationResult
    out_dir : str or path-like
        Folder for the files (created if needed).
    formats : sequence of {"png", "pdf", "svg"}
    experiments : DataFrame, path or sequence of them, optional
        Experimental points to overlay and compare (default: none).
    distribution_speed_m_s : float, optional
        The swept speed of the distribution figures (default:
        :func:`distribution_speed`'s choice).

    Returns
    -------
    list of pathlib.Path
        Every file written, in the order of the table above.
    """
    figures = result_figures(
        result, experiments=experiments, distribution_speed_m_s=distribution_speed_m_s
    )
    return save_figures([(stem, fig) for stem, _, fig in figures], out_dir, formats)
