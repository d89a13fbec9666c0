"""The data and likelihood of a Bayesian calibration (:mod:`.bayes`).

Three kinds of measurement, each a CSV told apart by its header (coordinates
``speed_m_s`` and/or ``angle_deg``, optional ``surface``, as in the experiment file
of ``docs/outputs.md``):

* **means** (``statistic``, ``mean`` and an interval): read by
  :func:`~microimpact.io.experiments.read_experiments`. Gaussian likelihood
  ``N(m_exp; m_sim(θ), s_exp² + s_sim(θ)²)``: the model's own Monte Carlo
  variance is added to the measurement's. The mean ``e`` and the mean ``mu`` of
  one file at one point (surface, speed, angle) are taken as measured on the same
  impacts: per impact, ``e_m`` and ``mu_m`` are strongly correlated on a rough
  surface (0.82-0.98 in the coverage study's cases), and so are their means, in
  the data and in the model (common random numbers). Such a pair has a bivariate
  Gaussian likelihood with correlation ``rho``, the correlation of ``e_m`` and
  ``mu_m`` over the rebounds the model simulates there at the parameters being
  evaluated (its own impacts: common random numbers). ``rho`` moves with the
  parameters (at 30 deg, 0.967 at a spread of 10 deg, 0.956 at 12), and near 1
  the pair's information depends on ``1 - rho^2``: a ``rho`` fixed at other
  parameters than the truth would misstate it by a quarter. Treated as
  independent, the pair misstates its information either way (here e and mu
  respond differently to the spread, and the pair constrains it more than the
  two apart). Put ``e`` and ``mu`` measured on different impacts in different
  files.
* **capture counts** (``captured``, ``n``): ``captured`` of ``n`` particles stuck.
  Exact binomial likelihood ``Binom(k; n, p_sim(θ))``, with ``p_sim`` clipped to
  ``[0.5/N, 1 - 0.5/N]`` (``N`` simulated impacts), so a count the simulation did
  not reproduce by chance is improbable, not impossible.
* **per-impact rebounds** (``e``, one row per rebounding impact): the density of
  ``e`` simulated at that sweep point, a Gaussian kernel density estimate over the
  engine's e histogram (bins of 0.01) with Silverman's bandwidth ``h`` (at least one
  bin), mixed with ``0.5/N_r`` of a uniform density over the histogram's range so
  that no measured value has density 0. Its bias: the estimate is the density of
  ``e + h Z``, so the fitted distribution is the model's widened by ``h²`` in
  variance (a spread parameter comes out low by about ``h²/(2 var e)`` relative),
  and ``log`` of a noisy density is biased low by about ``1/(2 N_r h f)`` per impact
  (largest in the tails). Captured impacts belong in a counts file.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..engine.accumulators import E_EDGES
from ..errors import InputError
from ..io.experiments import read_experiments
from .calibration_inputs import _read_experiments
from .compare import SIMULATED, _select, compare
from .pairs import (
    gaussian_loglik,
    pair_correlations,
    pair_covariance,
    same_impact_pairs,
)

__all__ = ["CalibrationData", "read_calibration_data"]

#: Largest acceptable ratio of the model's Monte Carlo variance to the data's at
#: any point: below it the Monte Carlo error is negligible (it widens the
#: posterior by at most sqrt(1.1) - 1 = 5 %).
MC_VARIANCE_RATIO = 0.1

_COORDS = ("speed_m_s", "angle_deg")


@dataclass
class CalibrationData:
    """The measurements, by kind (pandas tables; each may be empty)."""

    means: object  #: the experiment table (read_experiments), or None
    counts: object  #: surface, speed_m_s, angle_deg, captured, n, line, source
    impacts: object  #: surface, speed_m_s, angle_deg, e, line, source
    sources: list

    @property
    def n_points(self) -> int:
        return sum(0 if t is None else len(t) for t in (self.means, self.counts)) + (
            0 if self.impacts is None else len(self.impacts)
        )


def _group_keys(t):
    """One label per row for its (surface, speed, angle) point."""
    return [
        f"{s}|{v!r}|{a!r}"
        for s, v, a in zip(t["surface"], t["speed_m_s"], t["angle_deg"], strict=True)
    ]


def _csv(path):
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    try:
        t = pd.read_csv(path, comment="#", skipinitialspace=True)
    except FileNotFoundError:
        raise InputError("no such file", source=path) from None
    except (ValueError, pd.errors.ParserError) as exc:
        raise InputError(f"not a readable CSV ({exc})", source=path) from None
    t.columns = [str(c).strip() for c in t.columns]
    return t


def _numbers(t, col, path, *, test, allowed):
    vals = []
    for i, v in enumerate(t[col].tolist()):
        try:
            x = float(v)
        except (TypeError, ValueError):
            x = math.nan
        if not (math.isfinite(x) and test(x)):
            raise InputError(
                f"{v} is not {allowed}", source=path, field=col, line=i + 2
            )
        vals.append(x)
    return np.asarray(vals)


def _located(t, path, kind):
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    if not any(c in t for c in _COORDS):
        raise InputError(
            f"a {kind} file needs speed_m_s and/or angle_deg columns; "
            f"has {', '.join(t.columns)}",
            source=path,
        )
    out = pd.DataFrame(index=range(len(t)))
    out["surface"] = t["surface"].astype(str).tolist() if "surface" in t else None
    out["speed_m_s"] = (
        _numbers(t, "speed_m_s", path, test=lambda v: v > 0, allowed="a speed > 0")
        if "speed_m_s" in t
        else math.nan
    )
    out["angle_deg"] = (
        _numbers(t, "angle_deg", path, test=lambda v: 0 < v <= 90, allowed="in (0, 90]")
        if "angle_deg" in t
        else math.nan
    )
    out["line"] = np.arange(2, len(t) + 2)
    out["source"] = str(path)
    return out


def _read_counts(t, path):
    for c in ("captured", "n"):
        if c not in t:
            raise InputError(
                "a capture-count file needs both `captured` and `n` columns",
                source=path,
                field=c,
            )
    out = _located(t, path, "capture-count")
    n = _numbers(
        t,
        "n",
        path,
        test=lambda v: v >= 1 and v == int(v),
        allowed="a whole number >= 1",
    )
    k = _numbers(
        t,
        "captured",
        path,
        test=lambda v: v >= 0 and v == int(v),
        allowed="a whole number >= 0",
    )
    bad = np.flatnonzero(k > n)
    if bad.size:
        i = int(bad[0])
        raise InputError(
            f"{k[i]:.0f} captured of n = {n[i]:.0f}; captured must be <= n",
            source=path,
            field="captured",
            line=i + 2,
        )
    out["captured"] = k.astype(int)
    out["n"] = n.astype(int)
    return out


def _read_impacts(t, path):
    out = _located(t, path, "per-impact")
    out["e"] = _numbers(
        t,
        "e",
        path,
        test=lambda v: 0 < v <= 1.5,
        allowed="a rebound e in (0, 1.5] (captured impacts go in a counts file)",
    )
    return out


def read_calibration_data(sources) -> CalibrationData:
    """The measurements of `sources` (one or several paths or experiment tables),
    each file's kind told by its header: ``captured`` -> capture counts; ``e``
    without ``statistic`` -> per-impact rebounds; else means with intervals."""
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    if isinstance(sources, str | os.PathLike | pd.DataFrame):
        sources = [sources]
    means, counts, impacts, names = [], [], [], []
    for s in sources:
        if isinstance(s, pd.DataFrame):
            if "captured" in s:
                counts.append(_read_counts(s, "the counts table"))
            elif "e" in s and "statistic" not in s:
                impacts.append(_read_impacts(s, "the impacts table"))
            else:
                means.append(_read_experiments(s)[0].assign(impact_set=len(means)))
            continue
        path = str(s)
        names.append(path)
        if not os.path.exists(path):
            raise InputError("no such file", source=path)
        t = _csv(path)
        if "captured" in t:
            counts.append(_read_counts(t, path))
        elif "e" in t and "statistic" not in t:
            impacts.append(_read_impacts(t, path))
        else:
            t = _read_experiments(read_experiments(path))[0]
            means.append(t.assign(impact_set=len(means)))
    if not (means or counts or impacts):
        raise InputError("give at least one measurement file", field="experiments")

    def cat(ts):
        return pd.concat(ts, ignore_index=True) if ts else None

    return CalibrationData(cat(means), cat(counts), cat(impacts), names)


def _as_experiment(t, stat):
    """A located table as rows of an experiment table (for compare's matching)."""
    e = t[["surface", "speed_m_s", "angle_deg", "line"]].copy()
    e["statistic"] = stat
    e["mean"] = e["ci_low"] = e["ci_high"] = 0.0
    e["se"] = 1.0
    e["n"] = math.nan
    return e


class _Matcher:
    """The simulated statistic at experimental points, as ``compare`` matches them
    (exact sweep point, or linear interpolation along one axis), with the rows and
    weights found once: the sweep does not change with the parameters, and pandas
    per evaluation would cost more than the engine run."""

    def __init__(self, summary, exp):
        try:
            t = compare(summary, exp)  # the one-line errors of unmatched points
        except ValueError as exc:
            raise InputError(str(exc)) from None
        bad = np.flatnonzero(t["note"].str.contains("not ", regex=False).to_numpy())
        if bad.size:
            i = int(bad[0])
            raise InputError(
                f"experimental point (line {exp['line'].iloc[i]}): {t['note'].iloc[i]}",
                source=exp["source"].iloc[i] if "source" in exp else None,
            )
        pos = {label: k for k, label in enumerate(summary.index)}
        self.cols, self.rows, self.weights = [], [], []
        for _, row in exp.iterrows():
            col, se_col = SIMULATED[row["statistic"]]
            _, g, axis = _select(summary, row)
            if not axis:
                rows, w = [pos[g.index[0]]], [1.0]
            else:
                (ax,) = axis
                g = g.sort_values(ax)
                v = g[ax].to_numpy(dtype=float)
                i = int(np.searchsorted(v, row[ax])) - 1
                w0 = (v[i + 1] - row[ax]) / (v[i + 1] - v[i])
                rows, w = [pos[g.index[i]], pos[g.index[i + 1]]], [w0, 1.0 - w0]
            self.cols.append((col, se_col))
            self.rows.append(np.asarray(rows))
            self.weights.append(np.asarray(w))

    def __call__(self, summary):
        """``(mean, se)`` at every point (NaN where a used sweep point has none)."""
        cache = {}
        m = np.empty(len(self.rows))
        s = np.empty(len(self.rows))
        for k, ((col, se_col), rows, w) in enumerate(
            zip(self.cols, self.rows, self.weights, strict=True)
        ):
            if col not in cache:
                cache[col] = summary[col].to_numpy(float)
                cache[se_col] = summary[se_col].to_numpy(float)
            m[k] = w @ cache[col][rows]
            s[k] = math.sqrt(np.sum((w * cache[se_col][rows]) ** 2))
        return m, s


def _kde_logpdf(e, counts, h):
    """log of the kernel density estimate of the histogram `counts` (on
    E_EDGES) at `e`, with the uniform floor of the module docstring."""
    centres = 0.5 * (E_EDGES[:-1] + E_EDGES[1:])
    nz = np.flatnonzero(counts)
    n = counts.sum()
    span = E_EDGES[-1] - E_EDGES[0]
    if n == 0:
        return np.full(len(e), -math.log(span))
    z = (e[:, None] - centres[nz][None, :]) / h
    f = (np.exp(-0.5 * z * z) @ counts[nz]) / (n * h * math.sqrt(2 * math.pi))
    eps = 0.5 / n
    return np.log((1 - eps) * f + eps / span)


def _bandwidth(counts):
    """Silverman's rule of thumb from the histogram, at least one bin."""
    centres = 0.5 * (E_EDGES[:-1] + E_EDGES[1:])
    n = counts.sum()
    width = E_EDGES[1] - E_EDGES[0]
    if n < 2:
        return width
    mean = counts @ centres / n
    sd = math.sqrt(max(counts @ (centres - mean) ** 2 / (n - 1), 0.0))
    cdf = np.cumsum(counts) / n
    q1, q3 = centres[np.searchsorted(cdf, [0.25, 0.75])]
    spread = min(sd, (q3 - q1) / 1.34) or sd
    return max(0.9 * spread * n ** (-0.2), width)


class Likelihood:
    """The log-likelihood of the data given one engine result (the model at a
    parameter vector, common random numbers), and the predictions stored with
    each draw (``blob``: the simulated means and their SEs at the mean points,
    the capture probabilities at the count points, the mean e at the impact
    points)."""

    def __init__(self, data: CalibrationData, samples: int):
        if data.n_points == 0:
            raise InputError(
                "no measured point with a nonzero error", field="experiments"
            )
        self.data = data
        self.samples = samples
        m, c, i = data.means, data.counts, data.impacts
        self.n_means = 0 if m is None else len(m)
        self.n_counts = 0 if c is None else len(c)
        self.impact_groups = []
        if i is not None:
            keys = _group_keys(i)
            for _, idx in i.groupby(keys, sort=False).groups.items():
                self.impact_groups.append(np.asarray(idx))
        self.count_exp = None if c is None else _as_experiment(c, "capture_fraction")
        self.points: list | None = None  # impact group -> grid point
        self.match_means = self.match_counts = None
        #: rows (i, j) of the means that are e and mu on one set of impacts, and
        #: their correlation (set by :meth:`set_correlations`; 0 until then)
        self.pairs = same_impact_pairs(m) if self.n_means else np.zeros((0, 2), int)
        self.rho = np.zeros(len(self.pairs))

    def setup(self, summary):
        """Match every point to the sweep once (one-line errors for those that do
        not match)."""
        if self.n_means:
            self.match_means = _Matcher(summary, self.data.means)
        if self.n_counts:
            self.match_counts = _Matcher(summary, self.count_exp)
        if self.impact_groups:
            self.points = self._grid_points(summary)

    @property
    def blob_size(self) -> int:
        return 2 * self.n_means + self.n_counts + len(self.impact_groups)

    def _grid_points(self, summary):
        """The sweep point (summary row) of every impact group: an exact match."""
        imp = self.data.impacts
        pts = []
        for idx in self.impact_groups:
            r = imp.iloc[idx[0]]
            sel = np.ones(len(summary), bool)
            if r["surface"] is not None and str(r["surface"]) != "None":
                sel &= (summary["surface"].astype(str) == str(r["surface"])).to_numpy()
            for c in _COORDS:
                if math.isfinite(r[c]):
                    sel &= np.isclose(summary[c].to_numpy(float), r[c], rtol=1e-9)
            hits = np.flatnonzero(sel)
            if len(hits) != 1:
                raise InputError(
                    "per-impact data must sit exactly on one sweep point of the "
                    f"scenario; {len(hits)} match speed {r['speed_m_s']:g} m/s, "
                    f"angle {r['angle_deg']:g} deg",
                    source=r["source"],
                    line=int(r["line"]),
                )
            pts.append(int(hits[0]))
        return pts

    def evaluate(self, result, rho=None):
        """``(log-likelihood, blob)`` of the data given the engine `result`; `rho`:
        each pair's correlation at the run's parameters (default :attr:`rho`)."""
        rho = self.rho if rho is None else np.asarray(rho, float)
        summary = result.summary
        if (
            self.match_means is None
            and self.match_counts is None
            and (self.points is None)
        ):
            self.setup(summary)
        blob = np.full(self.blob_size, np.nan)
        ll = 0.0
        if self.n_means:
            exp = self.data.means
            m, s_sim = self.match_means(summary)
            blob[: self.n_means] = m
            blob[self.n_means : 2 * self.n_means] = s_sim
            if not np.isfinite(m).all():
                return -math.inf, blob
            s_exp = exp["se"].to_numpy(float)
            s_sim = np.nan_to_num(s_sim)
            var = s_exp**2 + s_sim**2
            ll += gaussian_loglik(
                m - exp["mean"].to_numpy(float),
                var,
                self.pairs,
                pair_covariance(self.pairs, rho, s_exp, s_sim),
            )
        if self.n_counts:
            p, _ = self.match_counts(summary)
            blob[2 * self.n_means : 2 * self.n_means + self.n_counts] = p
            if not np.isfinite(p).all():
                return -math.inf, blob
            lo = 0.5 / self.samples
            p = np.clip(p, lo, 1 - lo)
            c = self.data.counts
            ll += float(np.sum(stats.binom.logpmf(c["captured"], c["n"], p)))
        if self.impact_groups:
            e_all = self.data.impacts["e"].to_numpy(float)
            off = 2 * self.n_means + self.n_counts
            for g, (idx, pt) in enumerate(
                zip(self.impact_groups, self.points, strict=True)
            ):
                counts, _ = result.histogram(pt, "e")
                counts = np.asarray(counts, float)
                if counts.sum() == 0:
                    return -math.inf, blob
                centres = 0.5 * (E_EDGES[:-1] + E_EDGES[1:])
                blob[off + g] = counts @ centres / counts.sum()
                ll += float(np.sum(_kde_logpdf(e_all[idx], counts, _bandwidth(counts))))
        return ll, blob

    def set_correlations(self, model, row, *, plan=None) -> None:
        """:attr:`rho` of every pair (:func:`~.pairs.pair_correlations`) at
        parameters `row` of `model` (a :class:`~.model.ScenarioModel`)."""
        if len(self.pairs) and self.match_means is not None:
            self.rho = pair_correlations(
                model, row, self.pairs, self.match_means, plan=plan
            )

    def mc_variance_ratio(self, blob):
        """The largest ratio of the model's Monte Carlo variance to the data's, over
        every point (the check of :data:`MC_VARIANCE_RATIO`), and by kind."""
        out = {}
        if self.n_means:
            s_sim = blob[self.n_means : 2 * self.n_means]
            s_exp = self.data.means["se"].to_numpy(float)
            with np.errstate(divide="ignore", invalid="ignore"):
                out["means"] = float(np.nanmax((s_sim / s_exp) ** 2))
        if self.n_counts:
            # binomial variances p(1-p)/N against p(1-p)/n: n/N
            out["counts"] = float(self.data.counts["n"].max() / self.samples)
        if self.impact_groups:
            sizes = [len(g) for g in self.impact_groups]
            out["impacts"] = float(max(sizes) / self.samples)
        return out
