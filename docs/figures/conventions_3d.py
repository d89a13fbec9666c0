r"""
Draw the 3-D frame of ``docs/conventions.md`` §8 (areal roughness).

The drawing shows the nominal frame :math:`(t, b, n) = (x, y, z)`, a facet with
slopes :math:`\tan\phi_\parallel` along t and :math:`\tan\phi_\perp` along b and its
normal :math:`n' \propto (-\tan\phi_\parallel, -\tan\phi_\perp, 1)`, the incoming
path :math:`u = s(-\cos\theta, 0, -\sin\theta)`, the rebound U computed by
:func:`microimpact.apparent_rebound`, its projection on the nominal plane and the
lateral angle :math:`\psi = \operatorname{atan2}(U_y, -U_x)`.

Run ``python docs/figures/conventions_3d.py [OUT_DIR]``; the default output
directory is ``docs/img``. ``main(out_dir)`` returns the path of the PNG written.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

import microimpact as mi
from microimpact._core.files import atomic_write

FILENAME = "conventions_3d.png"
THETA_DEG = 35.0  # apparent incidence angle, from the nominal plane
PHI_PAR_DEG = -12.0  # in-plane facet angle (< 0: facing the particle)
PHI_PERP_DEG = 25.0  # out-of-plane facet angle (> 0: rises along +b)
SPEED = 1.0

NOMINAL = "#1f4e9c"
FACET = "#c0392b"
PATH = "#222222"
REBOUND = "#1e8449"


def _arrow(ax, start, vec, color, *, lw=2.0, ls="-"):
    ax.quiver(*start, *vec, color=color, lw=lw, linestyle=ls, arrow_length_ratio=0.12)


def draw(
    ax, *, theta_deg=THETA_DEG, phi_par_deg=PHI_PAR_DEG, phi_perp_deg=PHI_PERP_DEG
):
    """Draw the 3-D frame on the 3-D axes `ax` and return it."""
    res = mi.apparent_rebound(
        SPEED, theta_deg, phi_par_deg, out_of_plane_angle_deg=phi_perp_deg,
        k1=3.0, k2=0.0, v_c=0.0, friction=0.2,
    )  # fmt: skip
    th = math.radians(theta_deg)
    px, py = math.tan(math.radians(phi_par_deg)), math.tan(math.radians(phi_perp_deg))
    n_f = np.array([-px, -py, 1.0]) / math.sqrt(1 + px * px + py * py)
    u = SPEED * np.array([-math.cos(th), 0.0, -math.sin(th)])
    U = np.array([float(res.V_t), float(res.V_b), float(res.V_n)])
    o = np.zeros(3)

    # nominal plane and the facet through the impact point
    s = 1.3
    ax.add_collection3d(
        Poly3DCollection([[(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)]],
                         facecolor="#d9e2f3", edgecolor=NOMINAL, alpha=0.35)
    )  # fmt: skip
    f = 0.6
    corners = [(a * f, b * f, px * a * f + py * b * f) for a, b in
               ((-1, -1), (1, -1), (1, 1), (-1, 1))]  # fmt: skip
    ax.add_collection3d(
        Poly3DCollection([corners], facecolor=FACET, edgecolor=FACET, alpha=0.3)
    )
    # nominal frame at a corner, facet normal at the impact point
    c = np.array([-1.25, -1.25, 0.0])
    for vec, label in (((0.6, 0, 0), "t (x)"), ((0, 0.6, 0), "b = n×t (y)"),
                       ((0, 0, 0.6), "n (z)")):  # fmt: skip
        _arrow(ax, c, vec, NOMINAL)
        ax.text(*(c + 1.12 * np.array(vec)), label, color=NOMINAL, fontsize=10)
    _arrow(ax, o, 0.8 * n_f, FACET)
    ax.text(*(0.85 * n_f), "n′", color=FACET, fontsize=12)
    # incoming path (ends at the impact point) and rebound
    _arrow(ax, -1.3 * u, 1.3 * u, PATH, lw=2.2)
    ax.text(*(-1.3 * u + [0, 0, 0.08]), "u (towards −t)", color=PATH, fontsize=10)
    _arrow(ax, o, 1.3 * U, REBOUND, lw=2.2)
    ax.text(*(1.35 * U), "U", color=REBOUND, fontsize=12)
    # projection of U on the nominal plane and the lateral angle from -t
    P = 1.3 * np.array([U[0], U[1], 0.0])
    ax.plot([0, P[0]], [0, P[1]], [0, 0], color=REBOUND, ls="--", lw=1.2)
    ax.plot([P[0], P[0]], [P[1], P[1]], [0, 1.3 * U[2]], color=REBOUND, ls=":", lw=1)
    ax.plot([0, -1.2], [0, 0], [0, 0], color=PATH, ls=":", lw=1.0)  # forward, -t
    psi = math.atan2(U[1], -U[0])
    a = np.linspace(0.0, psi, 30)
    r = 0.45
    ax.plot(-r * np.cos(a), r * np.sin(a), 0 * a, color=REBOUND, lw=1.4)
    ax.text(-0.55 * math.cos(psi / 2), 0.55 * math.sin(psi / 2), 0.02, "ψ",
            color=REBOUND, fontsize=13)  # fmt: skip
    ax.set_title(
        f"θ = {theta_deg:g}°, φ∥ = {phi_par_deg:g}°, φ⊥ = {phi_perp_deg:g}°: "
        f"ψ = {float(res.lateral_angle_deg):.1f}°, e_m = {float(res.e_m):.2f}",
        fontsize=11,
    )
    ax.set_xlim(-1.3, 1.3)
    ax.set_ylim(-1.3, 1.3)
    ax.set_zlim(-0.3, 1.0)
    ax.set_box_aspect((2.6, 2.6, 1.3), zoom=1.05)
    ax.view_init(elev=20, azim=-40)
    ax.set_axis_off()
    return ax


def main(out_dir=None) -> Path:
    """Draw the 3-D frame figure into `out_dir` (default ``docs/img``)."""
    if out_dir is None:
        out_dir = Path(__file__).resolve().parents[1] / "img"
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(8.0, 6.0))
    draw(fig.add_subplot(projection="3d"))
    path = out_dir / FILENAME
    atomic_write(
        path,
        lambda tmp: fig.savefig(tmp, dpi=150, bbox_inches="tight", format="png"),
    )
    return path


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
