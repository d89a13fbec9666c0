"""Profile (2-D) against areal (3-D) roughness: the figure ``profile_vs_areal``.

Not in the paper: Li, Dunn & Brach (2000) model a profile, whose facets tilt in the
plane of incidence only. An areal surface's facets also tilt across it, which
changes the normal speed on the facet and deflects the rebound sideways (issue 14,
``docs/roughness.md``). This figure sets the two predictions side by side.
"""

from __future__ import annotations

import numpy as np

from ..engine.result import dataset_surface_flags, is_areal_surface
from ._style import STYLE, colour, styled

#: Caption of the figure (also used by the report).
CAPTION = (
    "Profile (2-D) against areal (3-D) roughness, against the apparent incidence "
    "angle: mean e_m and μ_m of the rebounds, percentage captured (bands: "
    "confidence intervals) and the lateral scatter, the standard deviation of the "
    "folded lateral rebound angle ψ_f (exactly 0 on a profile). Solid: areal "
    "surface; dashed: profile or smooth. A model prediction, not in the paper."
)


def areal_surfaces(result) -> dict[str, bool]:
    """``{surface name: areal}``, recognised by structure, never by name: the
    Dataset's ``surface_is_areal`` flag, else the scenario surfaces' ``areal``
    attribute or angle distribution (``is_areal``); otherwise not areal."""

    flags = dataset_surface_flags(result, "surface_is_areal")
    if flags is not None:
        return flags

    out = {}
    for s in getattr(result.scenario, "surfaces", ()):
        flag = getattr(s, "areal", None)
        out[str(s.name)] = bool(flag) if flag is not None else is_areal_surface(s)
    return out


def has_areal_surface(result) -> bool:
    """The result has at least one areal surface."""
    return any(areal_surfaces(result).values())


def plot_profile_vs_areal(result, *, speed_m_s=None, axes=None):
    """e_m, μ_m, capture and lateral scatter against angle, one line per surface.

    Parameters
    ----------
    result : SimulationResult
        A run with an angle sweep and at least one areal surface.
    speed_m_s : float, optional
        The speed to draw (default: the first swept speed).
    axes : sequence of four Axes, optional
        Panels e_m, μ_m, capture, lateral scatter; a new figure if omitted.

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
        The four panels.

    Raises
    ------
    ValueError
        If the result has no areal surface.
    """
    # deferred: matplotlib loads only when a figure is drawn

    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    areal = areal_surfaces(result)
    if not any(areal.values()):
        raise ValueError(
            "`result` has no areal surface (surface_is_areal); the profile-vs-areal "
            "figure compares an areal surface with profile ones."
        )
    summary = result.summary.reset_index(drop=True)
    speeds = list(dict.fromkeys(summary["speed_m_s"].to_numpy(dtype=float)))
    sp = speeds[0]
    if speed_m_s is not None:
        hit = [v for v in speeds if np.isclose(v, float(speed_m_s), rtol=1e-9)]
        if not hit:
            raise ValueError(
                f"`speed_m_s` must be one of the simulated values {speeds}; "
                f"got {speed_m_s!r}."
            )
        sp = hit[0]
    summary = summary[np.isclose(summary["speed_m_s"], sp)]
    names = list(dict.fromkeys(summary["surface"]))
    if "e_rebound_mean" in summary:
        e_spec = ("e_rebound_mean", "e_rebound_ci_low", "e_rebound_ci_high")
        e_label = "Restitution $e_m$ of rebounds [–]"
    else:
        e_spec = ("e_mean", "e_ci_low", "e_ci_high")
        e_label = "Restitution $e_m$ [–]"
    panels = (
        (e_spec, 1.0, e_label),
        (("mu_mean", "mu_ci_low", "mu_ci_high"), 1.0, "Impulse ratio $μ_m$ [–]"),
        (
            ("capture_fraction", "capture_ci_low", "capture_ci_high"),
            100.0,
            "Captured [%]",
        ),
        (("lateral_std_deg", None, None), 1.0, "Lateral scatter std $ψ_f$ [°]"),
    )
    with styled():
        if axes is None:
            _, axes = plt.subplots(
                2, 2, figsize=(7.6, 5.6), sharex=True, layout="constrained"
            )
        axs = np.atleast_1d(np.asarray(axes, dtype=object)).ravel()
        if axs.size != 4:
            raise ValueError(f"`axes` must hold 4 Axes; got {axs.size}.")
        for ax, ((col, lo_col, hi_col), scale, ylabel) in zip(axs, panels, strict=True):
            for i, name in enumerate(names):
                g = summary[summary["surface"] == name].sort_values("angle_deg")
                x = g["angle_deg"].to_numpy(dtype=float)
                m = g[col].to_numpy(dtype=float) * scale
                if col == "lateral_std_deg":
                    # no plane of incidence at normal incidence: no lateral angle
                    m = np.where(np.isclose(x, 90.0), np.nan, m)
                kind = "areal" if areal.get(str(name), False) else "profile"
                style = dict(
                    color=colour(i),
                    ls="-" if kind == "areal" else "--",
                    label=f"{name} ({kind})",
                )
                if lo_col is None:
                    ax.plot(x, m, marker="o", ms=3, **style)
                else:
                    lo = g[lo_col].to_numpy(dtype=float) * scale
                    hi = g[hi_col].to_numpy(dtype=float) * scale
                    ax.fill_between(x, lo, hi, color=style["color"], alpha=0.22, lw=0)
                    ax.plot(x, m, **style)
            ax.set_ylabel(ylabel)
        axs[3].set_ylim(bottom=0.0)
        for ax in axs[2:]:
            ax.set_xlabel("Apparent incidence angle θ [°]")
            ax.set_xlim(0, 90)
            ax.set_xticks(np.arange(0, 91, 15))
        axs[0].legend(loc="best")
        fig = axs[0].figure
        fig.suptitle(
            f"{result.scenario.name}: profile (2-D) vs areal (3-D) roughness, "
            f"{sp:g} m s⁻¹, {100 * float(result.confidence):g} % bands "
            "(not in the paper)",
            fontsize=STYLE["axes.titlesize"],
        )
    return axs
