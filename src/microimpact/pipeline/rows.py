"""Which rows of a large table the report and the terminal show.

A sweep of 10^6 points has 10^6 summary rows and one capture-speed row per
(surface, angle); a page or a terminal holds a few dozen. The full tables are in
``summary.csv``, ``capture_speed.csv`` and ``results.nc``; here the readable part is
chosen, vectorised over the whole table (no Python loop over the points):

* the **capture transition**: on each capture curve (a surface and an angle,
  along speed) the point whose capture fraction is nearest 50 %, for an evenly
  spaced subset of the curves;
* the **extremes**: per surface, the points of the smallest and largest capture
  fraction, mean restitution of the rebounds and mean impulse ratio;
* an **evenly spaced** subset of the rest (every k-th row), up to the cap.

Every chosen row keeps its row number (its line in ``summary.csv``, the point
index of ``result.histogram``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_TABLE_ROWS", "capture_rows", "summary_rows"]

#: Rows at most of a summary or capture-speed table in the report.
MAX_TABLE_ROWS = 100
#: Columns whose extremes (per surface) are always shown.
EXTREME_COLUMNS = ("capture_fraction", "e_rebound_mean", "mu_mean")


def even(n: int, k: int) -> np.ndarray:
    """`k` (at most `n`) evenly spaced indices of ``range(n)``, first and last
    included."""
    if k >= n:
        return np.arange(n)
    if k <= 1:
        return np.zeros(min(k, n), dtype=np.int64)
    return np.unique(np.round(np.linspace(0, n - 1, k)).astype(np.int64))


def grid_shape(summary) -> tuple[int, int, int] | None:
    """``(surfaces, speeds, angles)`` of a summary table in grid order (C order of
    surface x speed x angle), or None when the table is not such a grid."""
    n = len(summary)
    if not n or not {"surface", "speed_m_s", "angle_deg"} <= set(summary.columns):
        return None
    shape = tuple(
        int(summary[c].nunique(dropna=False))
        for c in ("surface", "speed_m_s", "angle_deg")
    )
    if shape[0] * shape[1] * shape[2] != n:
        return None
    speed = summary["speed_m_s"].to_numpy(dtype=float).reshape(shape)
    angle = summary["angle_deg"].to_numpy(dtype=float).reshape(shape)
    if not (
        (speed == speed[:, :, :1]).all() and (angle == angle[:, :1, :]).all()
    ):  # not C order of the three axes
        return None
    return shape


def _transition(summary, shape, k) -> np.ndarray:
    """Per capture curve, the row nearest 50 % capture; at most `k` curves (evenly
    spaced), only curves with a finite capture fraction."""
    cf = summary["capture_fraction"].to_numpy(dtype=float).reshape(shape)
    dist = np.abs(cf - 0.5)
    dist[~np.isfinite(dist)] = np.inf
    j = dist.argmin(axis=1)  # (surfaces, angles): the speed index
    s_idx, a_idx = np.indices(j.shape)
    flat = (s_idx * shape[1] + j) * shape[2] + a_idx
    ok = np.isfinite(np.take_along_axis(dist, j[:, None, :], axis=1)[:, 0, :])
    rows = flat[ok]
    return rows[even(rows.size, k)]


def _extremes(summary) -> np.ndarray:
    """Per surface, the rows of the smallest and largest value of each
    :data:`EXTREME_COLUMNS` column (NaN ignored)."""
    codes = summary["surface"].astype("category").cat.codes.to_numpy()
    out = []
    for col in EXTREME_COLUMNS:
        if col not in summary:
            continue
        v = summary[col].to_numpy(dtype=float)
        for code in np.unique(codes):
            idx = np.flatnonzero((codes == code) & np.isfinite(v))
            if idx.size:
                out += [idx[np.argmin(v[idx])], idx[np.argmax(v[idx])]]
    return np.asarray(out, dtype=np.int64)


def summary_rows(summary, limit: int = MAX_TABLE_ROWS):
    """The rows of `summary` a report shows: all if there are at most `limit`,
    else at most `limit` informative ones (module notes), in table order.

    Parameters
    ----------
    summary : DataFrame
        A summary table (``summary.csv``'s columns).
    limit : int

    Returns
    -------
    rows : ndarray of int
        Row numbers, increasing.
    why : dict of int -> str
        For a capped table, the reason each row is shown (``"50 % capture"``,
        ``"extreme"``, ``"every k-th"``); empty when every row is shown.
    """
    n = len(summary)
    if n <= limit:
        return np.arange(n), {}
    why: dict[int, str] = {}
    shape = grid_shape(summary)
    if shape is not None and "capture_fraction" in summary:
        for r in _transition(summary, shape, limit // 3):
            why.setdefault(int(r), "≈ 50 % capture")
    for r in _extremes(summary)[: limit // 3]:
        why.setdefault(int(r), "extreme")
    rest = limit - len(why)
    step = max(1, -(-n // max(rest, 1)))
    for r in even(n, rest):
        if len(why) >= limit:
            break
        why.setdefault(int(r), f"every {step:,}th")
    rows = np.array(sorted(why), dtype=np.int64)
    return rows, why


def capture_rows(table, limit: int = MAX_TABLE_ROWS) -> np.ndarray:
    """The rows of a capture-speed table a report shows: all if there are at most
    `limit`, else `limit` evenly spaced ones (first and last included)."""
    return even(len(table), limit)
