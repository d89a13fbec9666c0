"""Files and the report section of a resuspension study.

:func:`write_resuspension` writes ``resuspension.csv``, ``resuspension.nc``,
``resuspension.png`` and ``report.html`` (each atomically);
:func:`resuspension_section_html` gives the
report's section as an HTML fragment (an ``<section>`` element), for
``pipeline/report.py`` to place in a study's report.
"""

from __future__ import annotations

import base64
import html
import io
import json
from pathlib import Path

import numpy as np

from .._core.files import atomic_write
from ..engine.dataset import encoding
from ..plotting._style import STYLE
from ..plotting.resuspension import plot_resuspension
from .report import write_section_page

__all__ = ["RESUSPENSION_FILES", "resuspension_section_html", "write_resuspension"]

#: What :func:`write_resuspension` writes: key -> file name.
RESUSPENSION_FILES = {
    "csv": "resuspension.csv",
    "netcdf": "resuspension.nc",
    "figure": "resuspension.png",
    "report": "report.html",
}


def _figure(result):
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib.pyplot as plt

    ax = plot_resuspension(result.dataset)
    fig = ax.figure
    fig.tight_layout()
    return fig, plt


def write_resuspension(result, out_dir) -> dict[str, Path]:
    """Write `result`'s table, Dataset and figure into `out_dir`, each atomically.

    Returns
    -------
    dict
        ``{"csv": path, "netcdf": path, "figure": path, "report": path}``.
    """
    out = Path(out_dir)
    table = result.table
    ds = result.dataset
    paths = {
        "csv": atomic_write(
            out / RESUSPENSION_FILES["csv"], lambda t: table.to_csv(t, index=False)
        ),
        "netcdf": atomic_write(
            out / RESUSPENSION_FILES["netcdf"],
            lambda t: ds.to_netcdf(t, engine="netcdf4", encoding=encoding(ds)),
        ),
    }
    fig, plt = _figure(result)
    try:
        paths["figure"] = atomic_write(
            out / RESUSPENSION_FILES["figure"],
            lambda t: fig.savefig(t, format="png", dpi=STYLE["savefig.dpi"]),
        )
    finally:
        plt.close(fig)
    paths["report"] = write_section_page(
        out / RESUSPENSION_FILES["report"],
        "microimpact report: resuspension",
        resuspension_section_html(result),
        subtitle=str(result.dataset.attrs.get("scenario", "")),
    )
    return paths


def resuspension_section_html(result) -> str:
    """The report's resuspension section: inputs, the remaining fraction after
    each step (with the Monte Carlo estimate ± SE where computed) and the figure,
    as one ``<section>`` HTML fragment."""
    e = html.escape
    spec = json.loads(result.dataset.attrs["resuspension"])
    ds = result.dataset
    rows = "".join(
        f"<tr><th>{e(k.replace('_', ' '))}</th><td>{e(_text(v))}</td></tr>"
        for k, v in spec.items()
    )
    whole = ds["remaining_fraction"]
    point_dims = [d for d in whole.dims if d != "step"]
    final = whole.isel(step=-1).values
    lines = [
        f"<p>Seed entropy {e(ds.attrs.get('seed', ''))}. After the last step "
        f"({_text(float(ds['friction_velocity_m_s'].values[-1]))} m/s, "
        f"{_text(float(ds['elapsed_s'].values[-1]))} s in all) the remaining "
        f"fraction is {np.nanmin(final):.4g}"
        + (f" to {np.nanmax(final):.4g} over the sweep points" if point_dims else "")
        + ".</p>"
    ]
    if not point_dims:
        head = "<tr><th>step</th><th>u* [m/s]</th><th>t [s]</th><th>remaining</th>"
        has_mc = "remaining_fraction_mc" in ds
        head += "<th>Monte Carlo ± SE</th></tr>" if has_mc else "</tr>"
        body = ""
        for s in range(ds.sizes["step"]):
            cells = [
                str(s),
                _text(float(ds["friction_velocity_m_s"].values[s])),
                _text(float(ds["exposure_s"].values[s])),
                f"{float(whole.values[s]):.4f}",
            ]
            if has_mc:
                m = float(ds["remaining_fraction_mc"].values[s])
                se = float(ds["remaining_fraction_mc_se"].values[s])
                cells.append(f"{m:.4f} ± {se:.4f}")
            body += "<tr>" + "".join(f"<td>{e(c)}</td>" for c in cells) + "</tr>"
        lines.append(f"<table>{head}{body}</table>")
    fig, plt = _figure(result)
    try:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=STYLE["savefig.dpi"] * 0.75)
    finally:
        plt.close(fig)
    uri = "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")
    caption = "Remaining fraction against friction velocity (Rock'n'Roll model)."
    return (
        '<section id="resuspension"><h2>Resuspension</h2>'
        "<p>Quasi-static Rock'n'Roll model (Reeks &amp; Hall 2001) with log-normal "
        "adhesion (Biasi et al. 2001 unless given); see docs/resuspension.md.</p>"
        f"<table>{rows}</table>{''.join(lines)}"
        f'<figure><img src="{uri}" alt="{e(caption)}">'
        f"<figcaption>{e(caption)}</figcaption></figure></section>"
    )


def _text(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list):
        return ", ".join(_text(x) for x in v)
    return str(v)
