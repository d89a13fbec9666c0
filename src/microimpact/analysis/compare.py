"""Compare simulated means with experimental means ("agree at the 95 % level").

The rule, for one experimental point (see ``docs/outputs.md``):

* the simulated estimate ``m_s`` with standard error ``s_s`` is taken from the
  summary at the point's surface, speed and angle, interpolated linearly between
  the two neighbouring sweep points when the point falls between them;
* the experimental mean ``m_e`` has standard error ``s_e`` (from its interval, see
  :func:`microimpact.io.experiments.read_experiments`);
* the difference ``d = m_s - m_e`` has the combined standard error
  ``s = sqrt(s_s² + s_e²)`` (independent estimates), ``z = d / s``;
* the two **agree** when ``|d| <= z_c s``, with ``z_c`` the two-sided normal
  quantile of `confidence` (1.96 at 95 %): the difference lies inside the combined
  interval, i.e. a two-sided z-test does not reject equality at level
  ``1 - confidence``.

The parity figure of the table is :func:`microimpact.plotting.comparison.
plot_comparison`.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..engine.statistics import interval_se, z_value
from ..errors import InputError
from ..io.experiments import read_experiments
from ..scenario.grid import SweepGrid

__all__ = ["SIMULATED", "check_experiments", "compare"]

#: experimental statistic -> (summary column of the estimate, column of its SE).
#: The capture fraction's SE is the summary's ``capture_se``; a summary without it
#: (built by hand, or written before the column existed) gets the Wilson interval's
#: width over ``2 z`` (:func:`microimpact.engine.statistics.interval_se`, the
#: definition the engine uses).
SIMULATED = {
    "e": ("e_rebound_mean", "e_rebound_se"),
    "mu": ("mu_mean", "mu_se"),
    "e_relative": ("e_relative", "e_relative_se"),
    "mu_relative": ("mu_relative", "mu_relative_se"),
    "capture_fraction": ("capture_fraction", "capture_se"),
}

_EXP_COLUMNS = ("statistic", "mean", "ci_low", "ci_high")
_COORDS = ("speed_m_s", "angle_deg")


def _summary_iv(summary_or_result):
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    if isinstance(summary_or_result, pd.DataFrame):
        summary = summary_or_result
        sim_conf = float(summary.attrs.get("confidence", 0.95))
    elif hasattr(summary_or_result, "summary"):
        summary = summary_or_result.summary
        sim_conf = float(getattr(summary_or_result, "confidence", 0.95))
    else:
        raise TypeError(
            "`summary_or_result` must be a SimulationResult or a summary DataFrame; "
            f"got {type(summary_or_result).__name__}."
        )
    need = {"surface", *_COORDS}
    if not need <= set(summary.columns):
        raise ValueError(
            f"`summary_or_result` lacks columns {sorted(need - set(summary.columns))}."
        )
    summary = summary.reset_index(drop=True).copy()
    if "capture_se" not in summary and "capture_ci_low" in summary:
        summary["capture_se"] = interval_se(
            summary["capture_ci_low"], summary["capture_ci_high"], sim_conf
        )
    return summary


def _experiments_iv(experiments):
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    if isinstance(experiments, str | os.PathLike):
        experiments = read_experiments(experiments)
    if not isinstance(experiments, pd.DataFrame):
        raise TypeError(
            "`experiments` must be a path or a DataFrame from read_experiments; "
            f"got {type(experiments).__name__}."
        )
    missing = [c for c in _EXP_COLUMNS if c not in experiments]
    if missing or not any(c in experiments for c in _COORDS):
        raise ValueError(
            f"`experiments` must have columns {list(_EXP_COLUMNS)} and speed_m_s "
            f"and/or angle_deg; got {list(experiments.columns)}."
        )
    exp = experiments.reset_index(drop=True).copy()
    if "source" not in exp and "source" in experiments.attrs:
        exp["source"] = experiments.attrs["source"]  # named in messages
    for c in (*_COORDS, "se", "n"):
        if c not in exp:
            exp[c] = math.nan
    if "surface" not in exp:
        exp["surface"] = None
    if "line" not in exp:
        exp["line"] = np.arange(1, len(exp) + 1)
    # rows built by hand may lack a standard error: take the interval as 95 % normal
    no_se = exp["se"].isna()
    exp.loc[no_se, "se"] = (exp["ci_high"] - exp["ci_low"])[no_se] / (
        2.0 * z_value(0.95)
    )
    return exp


def _where(row):
    return f"experimental point (line {row['line']})"


def _mismatch(row, message):
    """An experimental point the simulation cannot serve: the user's input
    (:class:`~microimpact.errors.InputError`, exit 2 on the command line), naming
    the experiments file and the row where they are known."""
    source = row.get("source")
    if isinstance(source, str):
        return InputError(message.lstrip(": "), source=source, line=int(row["line"]))
    return InputError(f"{_where(row)}{message}")


def _select(summary, row):
    """Rows of `summary` for this point, the axis to interpolate on (or None)."""
    surface = row["surface"]
    surfaces = list(dict.fromkeys(summary["surface"]))
    if surface is None or (isinstance(surface, float) and math.isnan(surface)):
        if len(surfaces) != 1:
            raise _mismatch(
                row,
                f": names no surface but the simulation has surfaces {surfaces}; "
                "add a `surface` column to the experiments",
            )
        surface = surfaces[0]
    g = summary[summary["surface"] == surface]
    if g.empty:
        raise _mismatch(
            row, f": surface {surface!r} is not simulated; choose one of {surfaces}"
        )
    axis = []
    for c in _COORDS:
        x = row[c]
        values = np.unique(g[c].to_numpy(dtype=float))
        if np.isnan(x):
            if values.size != 1:
                raise _mismatch(
                    row,
                    f": has no {c} but the simulation sweeps {c} over "
                    f"{values.tolist()}; add a `{c}` column to the experiments",
                )
            continue
        exact = np.isclose(g[c].to_numpy(dtype=float), x, rtol=1e-9, atol=1e-12)
        if exact.any():
            g = g[exact]
        else:
            axis.append(c)
    return surface, g, axis


def _interpolate(g, axis, x, col, se_col):
    """Linear interpolation of an estimate and its SE at ``axis = x``."""
    g = g.sort_values(axis)
    v = g[axis].to_numpy(dtype=float)
    m = g[col].to_numpy(dtype=float)
    s = g[se_col].to_numpy(dtype=float)
    if v.size < 2 or not v[0] < x < v[-1]:
        return (
            math.nan,
            math.nan,
            (
                f"{axis} = {x:g} is outside the simulated range "
                f"[{v.min():g}, {v.max():g}]; not extrapolated"
            ),
        )
    i = int(np.searchsorted(v, x)) - 1
    missing = [v[j] for j in (i, i + 1) if math.isnan(m[j])]
    if missing:  # e.g. e of rebounds at a fully captured speed
        at = " and ".join(f"{axis} = {a:g}" for a in missing)
        return (
            math.nan,
            math.nan,
            (
                f"no simulated value at {at} ({col} is NaN there, e.g. no rebounds); "
                f"not interpolated"
            ),
        )
    w = (v[i + 1] - x) / (v[i + 1] - v[i])  # weight of the lower point
    mean = w * m[i] + (1.0 - w) * m[i + 1]
    se = math.sqrt((w * s[i]) ** 2 + ((1.0 - w) * s[i + 1]) ** 2)
    return mean, se, f"interpolated in {axis} between {v[i]:g} and {v[i + 1]:g}"


def compare(summary_or_result, experiments, *, confidence=0.95):
    """Compare simulated means with experimental means, point by point.

    Parameters
    ----------
    summary_or_result : SimulationResult or pandas.DataFrame
        A result, or its ``summary`` table. The relative statistics need the
        ``e_relative``/``mu_relative`` columns (reference angle in the sweep).
    experiments : pandas.DataFrame or path-like
        Output of :func:`~microimpact.io.experiments.read_experiments`, or a path to
        such a CSV file. A row without ``surface`` matches a simulation with one
        surface; a row without ``speed_m_s`` (``angle_deg``) matches a simulation
        with one speed (angle).
    confidence : float, default 0.95
        Level of the agreement test and of the simulated interval reported.

    Returns
    -------
    pandas.DataFrame
        One row per experimental point: ``surface``, ``speed_m_s``, ``angle_deg``,
        ``statistic``, ``exp_mean``, ``exp_ci_low``, ``exp_ci_high``, ``exp_se``,
        ``sim_mean``, ``sim_se``, ``sim_ci_low``, ``sim_ci_high``
        (``sim_mean ± z_c sim_se``), ``interpolated`` (bool), ``difference``
        (simulated minus experimental), ``combined_se``, ``z``, ``agree`` (bool),
        ``note`` (how the simulated value was obtained, or why it is missing) and
        ``line``. Where the point lies outside the simulated sweep the simulated
        columns are NaN and ``agree`` is False.

    Notes
    -----
    ``agree`` is ``|difference| <= z_c * combined_se`` with
    ``combined_se = sqrt(sim_se² + exp_se²)`` and ``z_c`` the two-sided normal
    quantile of `confidence`. Interpolating between sweep points ``a`` and ``b``
    with weight ``w`` on ``a`` gives ``w m_a + (1 - w) m_b`` and standard error
    ``sqrt(w² s_a² + (1 - w)² s_b²)`` (independent points); the error of the
    linear interpolation itself is not included.
    """
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    if not (isinstance(confidence, float | int) and 0 < confidence < 1):
        raise ValueError(f"`confidence` must be in (0, 1); got {confidence!r}.")
    summary = _summary_iv(summary_or_result)
    exp = _experiments_iv(experiments)
    zc = z_value(confidence)
    rows = []
    for _, row in exp.iterrows():
        stat = row["statistic"]
        if stat not in SIMULATED:
            raise _mismatch(
                row,
                f": unknown statistic {stat!r}; allowed: {', '.join(SIMULATED)}",
            )
        col, se_col = SIMULATED[stat]
        if col not in summary or se_col not in summary:
            raise _mismatch(
                row,
                f": the simulation has no {col!r} column"
                + (
                    "; relative coefficients need the reference angle "
                    "(reference_angle_deg) in the sweep's angles"
                    if "relative" in stat
                    else ""
                ),
            )
        surface, g, axis = _select(summary, row)
        coords = {c: float(row[c]) for c in _COORDS}
        interpolated = False
        if not axis:
            if len(g) != 1:
                raise _mismatch(
                    row,
                    f": matches {len(g)} simulated points; give both speed_m_s and "
                    "angle_deg",
                )
            sim, sim_se, note = float(g[col].iloc[0]), float(g[se_col].iloc[0]), ""
            for c in _COORDS:
                coords[c] = float(g[c].iloc[0])
        elif len(axis) == 2:
            sim, sim_se = math.nan, math.nan
            note = "between sweep points in both speed and angle; not interpolated"
        else:
            (ax_name,) = axis
            other = next(c for c in _COORDS if c != ax_name)
            if np.unique(g[other].to_numpy(dtype=float)).size != 1:
                raise _mismatch(row, f": matches several {other} values; give {other}")
            coords[other] = float(g[other].iloc[0])
            sim, sim_se, note = _interpolate(g, ax_name, coords[ax_name], col, se_col)
            interpolated = not math.isnan(sim)
        if math.isnan(sim) and not note:
            note = f"no simulated value ({col} is NaN)"
        d = sim - float(row["mean"])
        comb = math.hypot(sim_se, float(row["se"]))
        if math.isnan(d) or math.isnan(comb):
            z = math.nan  # no simulated value: nothing to test
        elif comb > 0:
            z = d / comb
        else:
            z = 0.0 if d == 0 else math.copysign(math.inf, d)
        agree = bool(abs(d) <= zc * comb) if not math.isnan(d) else False
        rows.append(
            {
                "surface": surface,
                **coords,
                "statistic": stat,
                "exp_mean": float(row["mean"]),
                "exp_ci_low": float(row["ci_low"]),
                "exp_ci_high": float(row["ci_high"]),
                "exp_se": float(row["se"]),
                "sim_mean": sim,
                "sim_se": sim_se,
                "sim_ci_low": sim - zc * sim_se,
                "sim_ci_high": sim + zc * sim_se,
                "interpolated": interpolated,
                "difference": d,
                "combined_se": comb,
                "z": z,
                "agree": agree,
                "note": note,
                "line": row["line"],
            }
        )
    table = pd.DataFrame(rows)
    table.attrs["confidence"] = confidence
    if "source" in exp.attrs:
        table.attrs["source"] = exp.attrs["source"]
    return table


def check_experiments(scenario, experiments):
    """Check experiments against a scenario's sweep before any impact is drawn.

    Every experimental point must name a simulated surface, a statistic the run
    will have (the relative ones need the reference angle in the sweep) and a
    speed and angle inside the swept ranges (the comparison interpolates between
    sweep points, never beyond them).

    Raises
    ------
    InputError
        For the first point that does not match, naming the experiments file, the
        row and what would match.
    """
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    exp = _experiments_iv(experiments)
    grid = SweepGrid.from_scenario(scenario)
    rows = [
        {"surface": s, "speed_m_s": v, "angle_deg": a}
        for s in grid.surfaces
        for v in grid.speeds_m_s
        for a in grid.angles_deg
    ]
    skeleton = pd.DataFrame(rows)
    ref = getattr(scenario, "reference_angle_deg", None)
    relative = ref is not None and any(math.isclose(a, ref) for a in grid.angles_deg)
    for stat, (col, se_col) in SIMULATED.items():
        if "relative" in stat and not relative:
            continue
        skeleton[col], skeleton[se_col] = 0.5, 0.01
    table = compare(skeleton, exp)
    for k, note in enumerate(table["note"]):
        if not math.isnan(table["sim_mean"].iloc[k]):
            continue
        raise _mismatch(exp.iloc[k], f": {note}; the sweep cannot serve it")
