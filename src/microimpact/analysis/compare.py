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

__all__ = ["SIMULATED", "check_experiments", "compare", "experiments_from_summary"]

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


def experiments_from_summary(
    summary, statistics=("e", "mu"), *, confidence=0.95, surface=None, by_surface=True
):
    """An experiments table (:func:`~microimpact.io.experiments.read_experiments`'s
    columns) made from a simulated summary: each point's mean of each statistic
    of :data:`SIMULATED` with its normal interval at `confidence`. For synthetic
    measurements with a known truth (calibration tests, examples, benchmarks).

    Parameters
    ----------
    summary : pandas.DataFrame
        ``SimulationResult.summary``.
    statistics : sequence of str
        Keys of :data:`SIMULATED`.
    confidence : float
        Level of the intervals.
    surface : str, optional
        Only this surface's rows.
    by_surface : bool
        Keep the ``surface`` column (the rows then match by surface).
    """
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    z = z_value(confidence)
    rows = []
    for _, r in summary.iterrows():
        if surface is not None and r["surface"] != surface:
            continue
        for stat in statistics:
            col, se = SIMULATED[stat]
            row = {"surface": r["surface"]} if by_surface else {}
            row.update(
                speed_m_s=r["speed_m_s"],
                angle_deg=r["angle_deg"],
                statistic=stat,
                mean=r[col],
                ci_low=r[col] - z * r[se],
                ci_high=r[col] + z * r[se],
            )
            rows.append(row)
    return pd.DataFrame(rows)


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
                ": names no surface but the simulation has surfaces "
                f"{', '.join(map(str, surfaces))}; "
                "add a `surface` column to the experiments",
            )
        surface = surfaces[0]
    g = summary[summary["surface"] == surface]
    if g.empty:
        raise _mismatch(
            row,
            f": surface {surface!r} is not simulated; choose one of "
            f"{', '.join(map(str, surfaces))}",
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


def _bracket(values, x, axis):
    """Index ``i`` with ``values[i] < x < values[i + 1]``, or the reason there is
    none (the point lies outside the sweep: never extrapolated)."""
    if values.size < 2 or not values[0] < x < values[-1]:
        return None, (
            f"{axis} = {x:g} is outside the simulated range "
            f"[{values.min():g}, {values.max():g}]; not extrapolated"
        )
    return int(np.searchsorted(values, x)) - 1, ""


def _linear_error(v, m, i, x):
    """Bound of the error of linear interpolation between ``v[i]`` and ``v[i+1]``
    at `x`: ``|f''|/2 (x - v_i)(v_{i+1} - x)`` (the Lagrange remainder), with
    ``f''/2`` taken as the largest second divided difference of the neighbouring
    triples ``(i-1, i, i+1)`` and ``(i, i+1, i+2)``; NaN where the axis has no
    third point to tell the curvature."""
    curvatures = []
    for a in (i - 1, i):
        if a < 0 or a + 2 >= v.size:
            continue
        f0, f1, f2 = m[a : a + 3]
        d01 = (f1 - f0) / (v[a + 1] - v[a])
        d12 = (f2 - f1) / (v[a + 2] - v[a + 1])
        curvatures.append(abs((d12 - d01) / (v[a + 2] - v[a])))  # f[a, a+1, a+2]
    curvatures = [c for c in curvatures if math.isfinite(c)]
    if not curvatures:
        return math.nan
    return max(curvatures) * (x - v[i]) * (v[i + 1] - x)


def _interpolate(g, axes, coords, col, se_col):
    """Linear (one axis) or bilinear (speed and angle) interpolation of an estimate
    and its SE at `coords`, with the interpolation's error bound.

    Returns ``(mean, se, error_bound, note)``; `mean` is NaN where the point lies
    outside the sweep or a neighbouring point has no value (`note` says why)."""
    if len(axes) == 1:
        (axis,) = axes
        g = g.sort_values(axis)
        v = g[axis].to_numpy(dtype=float)
        m, s = g[col].to_numpy(dtype=float), g[se_col].to_numpy(dtype=float)
        i, why = _bracket(v, coords[axis], axis)
        if i is None:
            return math.nan, math.nan, math.nan, why
        corners = {(i,): m[i], (i + 1,): m[i + 1]}
        w = (v[i + 1] - coords[axis]) / (v[i + 1] - v[i])  # weight of the lower
        weights = {(i,): w, (i + 1,): 1.0 - w}
        ses = {(i,): s[i], (i + 1,): s[i + 1]}
        error = _linear_error(v, m, i, coords[axis])
        between = f"interpolated in {axis} between {v[i]:g} and {v[i + 1]:g}"
        at = {(j,): f"{axis} = {v[j]:g}" for j in (i, i + 1)}
    else:
        vs, va = (np.unique(g[a].to_numpy(dtype=float)) for a in axes)
        means = np.full((vs.size, va.size), np.nan)
        sds = np.full((vs.size, va.size), np.nan)
        j = np.searchsorted(vs, g[axes[0]].to_numpy(dtype=float))
        k = np.searchsorted(va, g[axes[1]].to_numpy(dtype=float))
        means[j, k] = g[col].to_numpy(dtype=float)
        sds[j, k] = g[se_col].to_numpy(dtype=float)
        (i, why_s), (j, why_a) = (
            _bracket(vs, coords[axes[0]], axes[0]),
            _bracket(va, coords[axes[1]], axes[1]),
        )
        if i is None or j is None:
            return math.nan, math.nan, math.nan, why_s or why_a
        ws = (vs[i + 1] - coords[axes[0]]) / (vs[i + 1] - vs[i])
        wa = (va[j + 1] - coords[axes[1]]) / (va[j + 1] - va[j])
        weights, corners, ses, at = {}, {}, {}, {}
        for a, wa_ in ((i, ws), (i + 1, 1 - ws)):
            for b, wb_ in ((j, wa), (j + 1, 1 - wa)):
                weights[a, b] = wa_ * wb_
                corners[a, b], ses[a, b] = means[a, b], sds[a, b]
                at[a, b] = f"{axes[0]} = {vs[a]:g}, {axes[1]} = {va[b]:g}"
        # the bilinear error is at most the sum of the linear errors along each
        # axis (on the two grid lines that bound the cell)
        e_s = [_linear_error(vs, means[:, b], i, coords[axes[0]]) for b in (j, j + 1)]
        e_a = [_linear_error(va, means[a, :], j, coords[axes[1]]) for a in (i, i + 1)]
        known = not np.isnan(e_s + e_a).any()
        error = max(e_s) + max(e_a) if known else math.nan
        between = (
            f"interpolated in {axes[0]} between {vs[i]:g} and {vs[i + 1]:g} and in "
            f"{axes[1]} between {va[j]:g} and {va[j + 1]:g}"
        )
    missing = [at[k] for k, value in corners.items() if math.isnan(value)]
    if missing:  # e.g. e of rebounds at a fully captured speed
        return (
            math.nan,
            math.nan,
            math.nan,
            f"no simulated value at {' and '.join(missing)} ({col} is NaN there, "
            "e.g. no rebounds); not interpolated",
        )
    mean = sum(weights[k] * corners[k] for k in corners)
    se = math.sqrt(sum((weights[k] * ses[k]) ** 2 for k in corners))
    if math.isnan(error):
        note = f"{between}; interpolation error unknown (no third sweep point)"
    else:
        note = f"{between}; interpolation error at most about {error:.2g}"
    return mean, se, error, note


class PointRecipe:
    """:func:`compare`'s ``sim_mean`` and ``sim_se`` at every experimental point,
    with the summary rows and weights each point uses found once: a calibration
    compares hundreds of runs of one sweep with one experiments table, and
    matching every point with pandas costs more than a small run of the engine
    (issue 31). The same operations on the same values as :func:`compare`, so
    the same bits (tests/analysis/test_compare.py holds it to compare).

    Built from one summary of the sweep (which must match every point, as
    :func:`compare` requires of a calibration's data); called with any summary
    of the same sweep (the same surfaces, speeds and angles, in the same
    order; another raises ValueError)."""

    def __init__(self, summary_or_result, experiments):
        summary = _summary_iv(summary_or_result)
        exp = _experiments_iv(experiments)
        compare(summary, exp)  # compare's own errors for points it cannot match
        self._coords = _coordinates(summary)
        self.cols: list[tuple[str, str]] = []
        #: per point: ("exact", row), ("none", None) or ("mix", [(weight, row)])
        self.terms: list[tuple] = []
        for _, row in exp.iterrows():
            self.cols.append(SIMULATED[row["statistic"]])
            _, g, axis = _select(summary, row)
            coords = {c: float(row[c]) for c in _COORDS}
            if not axis:
                self.terms.append(("exact", int(g.index[0])))
            elif len(axis) == 1:
                (ax,) = axis
                g = g.sort_values(ax)
                v = g[ax].to_numpy(dtype=float)
                i, _ = _bracket(v, coords[ax], ax)
                if i is None:
                    self.terms.append(("none", None))
                    continue
                w = (v[i + 1] - coords[ax]) / (v[i + 1] - v[i])  # as _interpolate
                rows = (int(g.index[i]), int(g.index[i + 1]))
                self.terms.append(("mix", [(w, rows[0]), (1.0 - w, rows[1])]))
            else:
                vs, va = (np.unique(g[a].to_numpy(dtype=float)) for a in axis)
                j = np.searchsorted(vs, g[axis[0]].to_numpy(dtype=float)).tolist()
                k = np.searchsorted(va, g[axis[1]].to_numpy(dtype=float)).tolist()
                at = dict(zip(zip(j, k, strict=True), g.index.tolist(), strict=True))
                (i, _), (j, _) = (
                    _bracket(vs, coords[axis[0]], axis[0]),
                    _bracket(va, coords[axis[1]], axis[1]),
                )
                if i is None or j is None:
                    self.terms.append(("none", None))
                    continue
                ws = (vs[i + 1] - coords[axis[0]]) / (vs[i + 1] - vs[i])
                wa = (va[j + 1] - coords[axis[1]]) / (va[j + 1] - va[j])
                mix = []
                for a, wa_ in ((i, ws), (i + 1, 1 - ws)):
                    for b, wb_ in ((j, wa), (j + 1, 1 - wa)):
                        mix.append((wa_ * wb_, at.get((a, b))))  # None: no row
                self.terms.append(("mix", mix))

    def __call__(self, summary_or_result) -> tuple[np.ndarray, np.ndarray]:
        """``(sim_mean, sim_se)`` at every experimental point, as arrays."""
        summary = getattr(summary_or_result, "summary", summary_or_result)
        if not all(
            np.array_equal(a, b)
            for a, b in zip(_coordinates(summary), self._coords, strict=True)
        ):
            raise ValueError("PointRecipe: the summary is of another sweep")
        values: dict[str, np.ndarray] = {}
        m = np.empty(len(self.terms))
        s = np.empty(len(self.terms))
        for n, ((col, se_col), (kind, how)) in enumerate(
            zip(self.cols, self.terms, strict=True)
        ):
            for c in (col, se_col):
                if c not in values:
                    values[c] = _column(summary, c)
            mean, se = values[col], values[se_col]
            if kind == "exact":
                m[n], s[n] = float(mean[how]), float(se[how])
                continue
            corners = [mean[r] if r is not None else math.nan for _, r in how or ()]
            if kind == "none" or any(math.isnan(c) for c in corners):
                m[n] = s[n] = math.nan
                continue
            m[n] = sum(w * c for (w, _), c in zip(how, corners, strict=True))
            s[n] = math.sqrt(sum((w * se[r]) ** 2 for w, r in how))
        return m, s


def _coordinates(summary) -> tuple:
    return tuple(summary[c].to_numpy() for c in ("surface", *_COORDS))


def _column(summary, name) -> np.ndarray:
    """Column `name` of a summary as :func:`compare` reads it (``capture_se``
    from the capture interval where the summary has none, as _summary_iv)."""
    if name in summary:
        return summary[name].to_numpy(dtype=float)
    if name == "capture_se" and "capture_ci_low" in summary:
        conf = float(summary.attrs.get("confidence", 0.95))
        se = interval_se(summary["capture_ci_low"], summary["capture_ci_high"], conf)
        return np.asarray(se, dtype=float)
    raise KeyError(name)


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
        (``sim_mean ± z_c sim_se``), ``interpolated`` (bool),
        ``interpolation_error`` (the bound of the interpolation's error: 0 at a
        sweep point, NaN where unknown), ``compared`` (bool: the point had a
        simulated value), ``difference`` (simulated minus experimental),
        ``combined_se``, ``z``, ``agree`` (bool), ``note`` (how the simulated value
        was obtained, or why the point was not compared) and ``line``. Where the
        point lies outside the simulated sweep, or a neighbouring sweep point has
        no value, the simulated columns are NaN, ``compared`` is False and so is
        ``agree``: count disagreement as ``compared & ~agree``, never ``~agree``.

    Notes
    -----
    ``agree`` is ``|difference| <= z_c * combined_se + interpolation_error`` with
    ``combined_se = sqrt(sim_se² + exp_se²)`` and ``z_c`` the two-sided normal
    quantile of `confidence`. Interpolating between sweep points ``a`` and ``b``
    with weight ``w`` on ``a`` gives ``w m_a + (1 - w) m_b`` and standard error
    ``sqrt(w² s_a² + (1 - w)² s_b²)`` (independent points); a point between sweep
    points in both speed and angle is interpolated bilinearly from the four
    corners of its cell, the weights the products of the two axes' weights.
    The interpolation's error bound is the Lagrange remainder
    ``|f''| / 2 (x - a)(b - x)`` with ``|f''| / 2`` the largest second divided
    difference of the neighbouring sweep points (bilinear: the sum of the two
    axes' bounds); it needs a third sweep point on the axis, else it is NaN and
    the note says it is unknown.
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
        error = 0.0
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
        else:
            if len(axis) == 1:
                other = next(c for c in _COORDS if c != axis[0])
                if np.unique(g[other].to_numpy(dtype=float)).size != 1:
                    raise _mismatch(
                        row, f": matches several {other} values; give {other}"
                    )
                coords[other] = float(g[other].iloc[0])
            sim, sim_se, error, note = _interpolate(g, axis, coords, col, se_col)
        interpolated = bool(axis) and not math.isnan(sim)
        if math.isnan(sim) and not note:
            note = f"no simulated value ({col} is NaN)"
        compared = not math.isnan(sim)
        if not compared:
            note = f"not compared: {note}"
        d = sim - float(row["mean"])
        comb = math.hypot(sim_se, float(row["se"]))
        if not compared or math.isnan(comb):
            z = math.nan  # no simulated value: nothing to test
        elif comb > 0:
            z = d / comb
        else:
            z = 0.0 if d == 0 else math.copysign(math.inf, d)
        # the interpolation's error bound widens the tolerance (a bias, not noise);
        # an unknown bound (two sweep points on the axis) is said in the note
        tolerance = zc * comb + (error if math.isfinite(error) else 0.0)
        agree = bool(compared and abs(d) <= tolerance)
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
                "interpolation_error": error,
                "compared": compared,
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
        note = note.removeprefix("not compared: ")
        raise _mismatch(exp.iloc[k], f": {note}; the sweep cannot serve it")
