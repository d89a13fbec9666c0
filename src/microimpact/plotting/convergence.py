"""Plot of the paper's convergence study (running capture percentage against N)."""

from __future__ import annotations


def plot_convergence(result, *, ax=None):
    """Running capture percentage with its confidence band and the ±tolerance band.

    Parameters
    ----------
    result : ConvergenceResult
        From :func:`microimpact.convergence_study`.
    ax : matplotlib Axes, optional

    Returns
    -------
    Axes
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 3.8), layout="constrained")
    t = result.table
    pct = 100.0
    ax.fill_between(
        t["n"],
        t["ci_low"] * pct,
        t["ci_high"] * pct,
        color="C0",
        alpha=0.25,
        lw=0,
        label=f"{result.confidence:.0%} Wilson band",
    )
    ax.plot(
        t["n"], t["capture_fraction"] * pct, color="C0", lw=1.5, label="running capture"
    )
    lo, hi = (
        (result.final - result.tolerance) * pct,
        (result.final + result.tolerance) * pct,
    )
    ax.axhspan(
        lo,
        hi,
        color="0.5",
        alpha=0.15,
        lw=0,
        label=f"final ± {result.tolerance * pct:.0f} %",
    )
    if result.n_settled:
        ax.axvline(
            result.n_settled,
            color="C3",
            ls="--",
            lw=1,
            label=f"settled at N = {result.n_settled}",
        )
    ax.set_xscale("log")
    ax.set_xlabel("number of simulated impacts N [-]")
    ax.set_ylabel("capture [%]")
    p = result.point
    ax.set_title(
        f"{p['surface']}, {p['speed_m_s']:g} m/s, {p['angle_deg']:g}°", fontsize=10
    )
    ax.legend(fontsize=8, loc="best")
    return ax
