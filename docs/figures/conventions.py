r"""
Draw the frames and sign conventions of ``docs/conventions.md``.

The drawing shows the nominal surface with its frame :math:`(n, t)`, a facet tilted
by the roughness angle :math:`\phi` with its frame :math:`(n', t')`, the incoming
velocity at the apparent incidence angle :math:`\theta`, the true incidence angle
:math:`\theta' = \theta - \phi`, and the rebound computed by
:func:`microimpact.apparent_rebound` (Li, Dunn & Brach 2000, Figs. 1 and 3).

Run ``python docs/figures/conventions.py [OUT_DIR]``; the default output directory is
``docs/img``. ``main(out_dir)`` returns the path of the PNG written.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Arc, Circle, FancyArrowPatch, Polygon

import microimpact as mi
from microimpact._core.files import atomic_write

FILENAME = "conventions.png"
THETA_DEG = 40.0  # apparent incidence angle, from the nominal plane
PHI_DEG = 15.0  # facet angle; > 0 turns the facet away from the particle
SPEED = 1.0

NOMINAL = "#1f4e9c"
FACET = "#c0392b"
PATH = "#222222"
REBOUND = "#1e8449"


def _off(point, dx, dy):
    """`point` shifted by (dx, dy)."""
    return np.asarray(point, float) + np.array([dx, dy])


def _unit(angle_deg):
    a = math.radians(angle_deg)
    return np.array([math.cos(a), math.sin(a)])


def _arrow(ax, start, vec, color, *, lw=2.0, style="-|>", ls="-", z=3):
    start = np.asarray(start, float)
    ax.add_patch(
        FancyArrowPatch(
            start, start + np.asarray(vec, float), arrowstyle=style,
            mutation_scale=16, color=color, lw=lw, linestyle=ls, zorder=z,
        )
    )  # fmt: skip


def _angle(ax, centre, radius, start_deg, end_deg, label, color, *, label_r=1.18,
           label_deg=None):  # fmt: skip
    ax.add_patch(
        Arc(centre, 2 * radius, 2 * radius, theta1=start_deg, theta2=end_deg,
            color=color, lw=1.4, zorder=2)
    )  # fmt: skip
    mid = 0.5 * (start_deg + end_deg) if label_deg is None else label_deg
    pos = np.asarray(centre) + label_r * radius * _unit(mid)
    ax.text(*pos, label, color=color, fontsize=12, ha="center", va="center")


def draw(ax, *, theta_deg=THETA_DEG, phi_deg=PHI_DEG):
    """Draw the conventions on `ax` and return it."""
    hit = np.array([0.0, 0.0])
    res = mi.apparent_rebound(
        SPEED, theta_deg, phi_deg, k1=3.0, k2=0.0, v_c=0.0, friction=0.15
    )
    t_f, n_f = _unit(phi_deg), _unit(phi_deg + 90.0)

    # nominal surface, hatched below
    ax.add_patch(
        Polygon([[-3.6, 0], [3.3, 0], [3.3, -0.35], [-3.6, -0.35]], closed=True,
                facecolor="#e8e8e8", edgecolor="none", hatch="///", zorder=0)
    )  # fmt: skip
    ax.plot([-3.6, 3.3], [0, 0], color=NOMINAL, lw=2, zorder=1)
    ax.text(-3.5, -0.55, "nominal (apparent) surface", color=NOMINAL, fontsize=10)
    # the facet, a segment of the rough profile through the impact point hit
    a, b = hit - 1.6 * t_f, hit + 1.9 * t_f
    ax.add_patch(
        Polygon([a, b, [b[0], 0], [a[0], 0]], closed=True, facecolor=FACET,
                alpha=0.12, edgecolor="none", zorder=0)
    )  # fmt: skip
    ax.plot([a[0], b[0]], [a[1], b[1]], color=FACET, lw=2.5, zorder=1)
    ax.text(*_off(b, 0.05, -0.05), "facet", color=FACET, fontsize=10, va="top")

    # frames: nominal (n, t) on the left, facet (n', t') at hit
    origin = np.array([-3.3, 0.0])
    _arrow(ax, origin, [0.8, 0], NOMINAL)
    _arrow(ax, origin, [0, 0.8], NOMINAL)
    ax.text(*_off(origin, 0.82, 0.08), "$t$", color=NOMINAL, fontsize=14)
    ax.text(*_off(origin, -0.22, 0.8), "$n$", color=NOMINAL, fontsize=14)
    _arrow(ax, hit, 0.95 * t_f, FACET)
    _arrow(ax, hit, 0.95 * n_f, FACET)
    ax.text(*_off(hit + 1.0 * t_f, 0.05, -0.24), "$t'$", color=FACET, fontsize=14,
            zorder=5)  # fmt: skip
    ax.text(*_off(hit + 1.02 * n_f, -0.25, 0.0), "$n'$", color=FACET, fontsize=14)

    # incoming path: travels in -t, at theta from the nominal plane, through hit
    u_in = -_unit(theta_deg)
    start = hit - 2.6 * u_in
    _arrow(ax, start, 2.45 * u_in, PATH, lw=2.2)
    ax.text(*_off(start, 0.05, 0.12), r"$v$ (travels towards $-t$)", fontsize=11)
    ax.plot([0, 2.7], [0, 0], color=NOMINAL, lw=0.8, ls=":", zorder=1)

    # angles at hit: theta from the plane, phi from t to t', theta' from t' to the path
    _angle(ax, hit, 1.75, 0.0, theta_deg, r"$\theta$", PATH, label_r=1.09)
    _angle(ax, hit, 1.3, 0.0, phi_deg, r"$\phi$", FACET, label_r=1.13)
    _angle(ax, hit, 0.78, phi_deg, theta_deg, r"$\theta'$", PATH, label_r=1.3)

    # rebound (nominal components from apparent_rebound)
    V = np.array([float(res.V_t), float(res.V_n)])
    _arrow(ax, hit, 1.6 * V / SPEED, REBOUND, lw=2.2)
    tip = hit + 1.6 * V / SPEED
    ax.text(*_off(tip, -0.1, 0.12), "$V$ (rebound)", color=REBOUND, fontsize=11)

    # the sphere in flight on its path, and the sense of positive spin
    r = 0.3
    centre = hit - 1.55 * u_in
    ax.add_patch(
        Circle(centre, r, facecolor="white", edgecolor="0.3", lw=1.2, zorder=4)
    )
    ax.add_patch(
        Arc(centre, 1.2 * r, 1.2 * r, theta1=20, theta2=160, color="0.3", lw=1.1,
            zorder=5)
    )  # fmt: skip
    ax.annotate(
        "", xy=centre + 0.6 * r * _unit(20) + [0.0, -0.02],
        xytext=centre + 0.6 * r * _unit(35), zorder=6,
        arrowprops={"arrowstyle": "-|>", "color": "0.3", "lw": 1.1},
    )  # fmt: skip
    ax.text(*_off(centre, 0.0, 0.0), r"$\omega$", fontsize=10, ha="center",
            va="center", zorder=6)  # fmt: skip
    ax.text(
        -3.5, 3.05,
        r"$\omega>0$: clockwise here, about $n\times t$ (into the page);"
        "\n" r"contact slip $= v_t - r\omega$",
        fontsize=10, va="top",
    )  # fmt: skip
    ax.text(
        0.45, 3.05,
        r"$\phi>0$: facet turned away from the particle" "\n"
        r"true incidence angle $\theta' = \theta - \phi$" "\n"
        r"$\phi \geq \theta$: facet shadowed (cannot be hit)" "\n"
        r"$v_n<0$ approaching, $V_n>0$ rebounding",
        fontsize=10, va="top",
    )  # fmt: skip
    ax.set_xlim(-3.6, 3.3)
    ax.set_ylim(-0.75, 3.1)
    ax.set_aspect("equal")
    ax.axis("off")
    return ax


def main(out_dir=None) -> Path:
    """Draw the conventions figure into `out_dir` (default ``docs/img``)."""
    if out_dir is None:
        out_dir = Path(__file__).resolve().parents[1] / "img"
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(9.0, 4.8))
    draw(fig.add_subplot())
    path = out_dir / FILENAME
    atomic_write(
        path,
        lambda tmp: fig.savefig(tmp, dpi=150, bbox_inches="tight", format="png"),
    )
    return path


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
