"""Builders of the synthetic size exports of the tests (issue 22)."""

from __future__ import annotations

import numpy as np
from scipy import stats

#: The APS 3321 channels: 32 per decade from the lower bound 0.523 µm.
APS_LOWER_UM = 0.523
APS_PER_DECADE = 32


def aps_channels(first, n=32):
    """Edges and geometric midpoints [µm] of APS channels first..first + n - 1."""
    k = np.arange(first, first + n + 1)
    edges = APS_LOWER_UM * 10.0 ** (k / APS_PER_DECADE)
    return edges, np.sqrt(edges[:-1] * edges[1:])


def aps_issue_export(cmd_um=3.49, gsd=1.69, total_cm3=850.0) -> str:
    """The APS export of issue 22 as an AIM column export: the 32 channels around
    the count median with dN/dlogDp of a log-normal (count median `cmd_um`, GSD
    `gsd`), midpoints rounded to 4 digits as AIM prints them."""
    centre = round(float(APS_PER_DECADE * np.log10(cmd_um / APS_LOWER_UM)))
    _, mids = aps_channels(centre - 16)
    dist = stats.lognorm(np.log(gsd), scale=cmd_um)
    dndlog = total_cm3 * dist.pdf(mids) * mids * np.log(10)
    lines = [
        "Sample File,C:\\AIM\\issue22_aps.A21",
        "Instrument,3321 APS",
        "Channels/Decade,32",
        "Units,dw/dlogDp",
        "Weight,Number",
        "Sample #,1",
        "Date,06/12/26",
        "Start Time,10:00:00",
        "Diameter Midpoint",
    ]
    lines += [f"{m:.4g},{v:.6g}" for m, v in zip(mids, dndlog, strict=True)]
    lines += [
        "Lower Size(µm),0.523",
        "Upper Size(µm),20.53",
        "Density(g/cc),1",
        "Total Conc.(#/cm³)," + f"{total_cm3:.6g}",
    ]
    return "\n".join(lines) + "\n"
