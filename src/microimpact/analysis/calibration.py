"""Calibration: scenario parameters fitted to measured rebound statistics (see
``docs/calibration.md``).

The parameters are numbers of the scenario file named by their dotted keys
(:mod:`microimpact.scenario.parameters`). The measurements are an experiment table
(:func:`microimpact.io.experiments.read_experiments`): any of ``e``, ``mu``,
``e_relative``, ``mu_relative`` and ``capture_fraction`` with their intervals, at
speeds and angles of the scenario's sweep, matched to the simulation exactly as
:func:`microimpact.analysis.compare.compare` matches them (interpolated between
neighbouring sweep points).

**Forward model.** The engine with *common random numbers*: every parameter value is
run with the same seed and the same number of impacts per sweep point, so every
impact draws the same 64-bit integers and reads the same table cells; a parameter
moves the drawn values (a normal roughness angle is ``std * z`` for a fixed ``z``)
and the model output moves with it smoothly, except where an impact switches
between capture and rebound (a step of about ``1/N``). See the docs for the
measured smoothness and the finite-difference step this asks for.

**Objective.** For each experimental point ``i`` the residual is
``r_i = (m_sim,i - m_exp,i) / sqrt(s_exp,i² + s_sim,i²)``, with ``s_exp`` the
measurement's standard error (from its interval) and ``s_sim`` the simulation's (the
summary's SE column, the one ``compare`` uses). ``sum r_i²`` is minimised with
:func:`scipy.optimize.least_squares` (trust-region reflective, within the bounds).
``s_sim`` is held fixed during a minimisation (taken at the start point, then once
more at the first optimum and the fit repeated), so the weights do not pull the fit.

**Uncertainty.** The covariance is ``(J^T J)^-1`` of the weighted residuals at the
optimum, *not* scaled by ``chi2/dof``: the weights are known standard errors, so
``chi2`` is a goodness-of-fit test (``p_value``) rather than a variance estimate
(scaling would turn model error into parameter uncertainty and, for a handful of
points, add the noise of ``chi2`` itself). The ``confidence`` intervals are
``estimate ± z sqrt(C_jj)``. A parametric bootstrap checks them: data drawn from
the fitted model with the combined noise ``s_exp² + s_sim²`` (the simulation's
error is frozen by the common random numbers, so it must be drawn here too), each
refitted, percentile intervals.

**Identifiability.** A parameter whose Jacobian column is zero (the data do not
depend on it), or that lies in a direction of the column-normalised Jacobian whose
singular value is below ``rcond`` times the largest (the data fix only a combination
of it with others), or whose interval is wider than its bounds, is reported as not
identifiable: ``estimate`` None, with the reason.
"""

from __future__ import annotations

import contextlib
import copy
import math
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import stats

from .._core import json as _json
from .._core.files import atomic_write
from .._core.progress import Progress, check_progress
from .._core.toml import to_toml
from ..engine.parallel import RunPool, fork_pool, map_held
from ..engine.statistics import z_value
from ..errors import InputError
from ..plotting._style import use_agg
from ..plotting.calibration import plot_calibration
from ..scenario.parameters import with_values
from ..scenario.scenario import scenario_from_dict
from .bayes import BayesResult, calibrate_bayes, split_calibration_table
from .bayes_data import _Matcher
from .calibration_inputs import (
    _parameters,
    _read_experiments,
    default_bounds,
    parse_parameter,
)
from .compare import PointRecipe, compare
from .model import ScenarioModel
from .pairs import (
    correlate,
    pair_correlations,
    pairs_info,
    residual_correlation,
    same_impact_pairs,
    whiten,
)

__all__ = [
    "CalibrationResult",
    "calibrate",
    "default_bounds",
    "parse_parameter",
]

#: Relative finite-difference step of the Jacobian (times the parameter's scale,
#: see :func:`_scale`). It must be well above the granularity of the model under
#: common random numbers (the capture/rebound switches, docs/calibration.md).
DEFAULT_STEP = 0.02
#: Singular values of the column-normalised Jacobian below this times the largest
#: mark a direction the data do not determine.
DEFAULT_RCOND = 1e-2
#: Parametric bootstrap replicates by default.
DEFAULT_BOOTSTRAP = 100
#: Parameter draws for the model band when there is no bootstrap.
BAND_DRAWS = 20
#: Weighted residual of a point whose statistic the model leaves undefined at a
#: trial parameter vector (e.g. ``e`` where every particle is captured).
UNDEFINED_RESIDUAL = 1e3

#: Scenario keys that are not model parameters (sampling, reporting, the design).
#: experimental statistic -> summary column of its model curve
_CURVE = {
    "e": "e_rebound_mean",
    "mu": "mu_mean",
    "e_relative": "e_relative",
    "mu_relative": "mu_relative",
    "capture_fraction": "capture_fraction",
}


# ---------------------------------------------------------------------- the model
def _simulate(task):
    """One engine run (a worker task): ``(scenario model, values)`` -> the summary
    table."""
    model, values = task
    return model.summary(values)


class _Model:
    """The engine at parameter vectors (a
    :class:`~microimpact.analysis.model.ScenarioModel`: common random numbers,
    tables built once), with a cache of summaries and batches mapped on an
    executor."""

    def __init__(self, scenario_model, experiments, mapper):
        self.scenario_model = scenario_model
        self.keys = scenario_model.keys
        self.exp = experiments
        self.map = mapper
        self.cache: dict = {}
        self.runs = 0
        #: rows (i, j) of e and mu measured on one set of impacts, and the
        #: correlation of e_m and mu_m there (bayes_data.same_impact_pairs)
        self.pairs = np.zeros((0, 2), int)
        self.rho = np.zeros(0)
        self._matcher = None  # the pairs' experiment rows -> sweep rows
        self._recipe = None  # the experiment points -> sweep rows (points())

    def set_pairs(self, x) -> None:
        """Find the pairs of :attr:`exp` (once) and their correlation at `x`."""
        if self._matcher is None:
            self.pairs = same_impact_pairs(self.exp)
            if not len(self.pairs):
                return
            self._matcher = _Matcher(self.summaries([x])[0], self.exp)
        if len(self.pairs):
            model = self.scenario_model
            self.rho = pair_correlations(
                model, model.values(x), self.pairs, self._matcher
            )

    def pair_r(self, s_exp, s_sim) -> np.ndarray:
        """Each pair's correlation of its two residuals."""
        return residual_correlation(self.pairs, self.rho, s_exp, s_sim)

    def summaries(self, xs):
        """The summary at every parameter vector of `xs` (cached)."""
        todo = []
        for x in xs:
            k = tuple(np.asarray(x, dtype=float).tolist())
            if k not in self.cache and k not in todo:
                todo.append(k)
        tasks = [(self.scenario_model, self.scenario_model.values(k)) for k in todo]
        for k, s in zip(todo, self.map(_simulate, tasks), strict=True):
            self.cache[k] = s
        self.runs += len(todo)
        return [self.cache[tuple(np.asarray(x, dtype=float).tolist())] for x in xs]

    def points(self, summary):
        """``(m_sim, s_sim)`` at the experimental points: :func:`compare`'s
        values, with each point's rows and weights found at the first call
        (:class:`~.compare.PointRecipe`)."""
        if self._recipe is None:
            self._recipe = PointRecipe(summary, self.exp)
        return self._recipe(summary)


def _serial(func, items):
    """The model runs of one process, one after the other (a bootstrap worker:
    :class:`_Refit`)."""
    return [func(item) for item in items]


@contextlib.contextmanager
def _mapper(workers, executor):
    """A :class:`~microimpact.engine.parallel.RunPool` for the whole fit: the
    optimizer's steps and the Jacobian batches share its pool, shut down when
    the fit ends (or fails)."""
    mapper = RunPool(workers, executor)
    try:
        yield mapper
    finally:
        mapper.close()


# ---------------------------------------------------------------------- result
@dataclass
class CalibrationResult:
    """What :func:`calibrate` found. ``write(out)`` writes ``calibration.json``,
    ``calibration.png`` and ``calibration.md``; :meth:`to_dict` is the JSON."""

    keys: tuple
    estimate: np.ndarray  #: the optimiser's values (also for the unidentifiable)
    identifiable: np.ndarray
    reasons: list
    std_error: np.ndarray
    ci_low: np.ndarray
    ci_high: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    bounds: np.ndarray
    at_bound: np.ndarray
    chi2: float
    dof: int
    p_value: float
    confidence: float
    points: object  #: pandas table of the experimental points at the optimum
    curves: object  #: pandas table of the model at every sweep point with its band
    data: dict  #: the calibrated scenario (parsed TOML data)
    seed: int
    samples: int
    bootstrap: np.ndarray  #: (B, n) refitted values (empty without bootstrap)
    bootstrap_ci_low: np.ndarray
    bootstrap_ci_high: np.ndarray
    info: dict = field(default_factory=dict)
    base_dir: str | None = None

    @property
    def scenario_toml(self) -> str:
        """The calibrated scenario as TOML text (file names made absolute)."""
        notes = [
            f"calibrated by microimpact calibrate: chi2 = {self.chi2:.4g}, "
            f"dof = {self.dof}, p = {_fmt(self.p_value)}"
        ]
        for k, key in enumerate(self.keys):
            if self.identifiable[k]:
                notes.append(
                    f"{key} = {self.estimate[k]:.6g} "
                    f"[{self.ci_low[k]:.4g}, {self.ci_high[k]:.4g}] "
                    f"({self.confidence:.0%})"
                )
            else:
                notes.append(
                    f"{key} = {self.estimate[k]:.6g} is NOT identified by the data "
                    f"({self.reasons[k]}); one value of many that fit as well"
                )
        return to_toml(_absolute_files(self.data, self.base_dir), header=notes)

    def scenario(self):
        """The calibrated :class:`~microimpact.Scenario`."""

        return scenario_from_dict(self.data, base_dir=self.base_dir)

    def parameters_table(self):
        # deferred: pandas loads only where a table is made (import time)
        import pandas as pd

        return pd.DataFrame(
            {
                "parameter": list(self.keys),
                "estimate": [
                    v if ok else math.nan
                    for v, ok in zip(self.estimate, self.identifiable, strict=True)
                ],
                "std_error": self.std_error,
                "ci_low": self.ci_low,
                "ci_high": self.ci_high,
                "bootstrap_ci_low": self.bootstrap_ci_low,
                "bootstrap_ci_high": self.bootstrap_ci_high,
                "identifiable": self.identifiable,
                "reason": self.reasons,
            }
        )

    def to_dict(self) -> dict:
        params = {}
        for k, key in enumerate(self.keys):
            ok = bool(self.identifiable[k])
            params[key] = {
                "estimate": float(self.estimate[k]) if ok else None,
                "std_error": float(self.std_error[k]) if ok else None,
                "ci_low": float(self.ci_low[k]) if ok else None,
                "ci_high": float(self.ci_high[k]) if ok else None,
                "bootstrap_ci_low": float(self.bootstrap_ci_low[k]) if ok else None,
                "bootstrap_ci_high": float(self.bootstrap_ci_high[k]) if ok else None,
                "identifiable": ok,
                "reason": self.reasons[k],
                "value_in_fit": float(self.estimate[k]),
                "bounds": [float(self.bounds[k, 0]), float(self.bounds[k, 1])],
                "at_bound": bool(self.at_bound[k]),
            }
        return {
            "parameters": params,
            "chi2": self.chi2,
            "dof": self.dof,
            "p_value": self.p_value,
            "confidence": self.confidence,
            "covariance_scaled_by_chi2_dof": False,
            "correlation": {
                "keys": list(self.keys),
                "matrix": self.correlation,
            },
            "seed": self.seed,
            "samples": self.samples,
            "bootstrap_replicates": len(self.bootstrap),
            "points": self.points.to_dict(orient="records"),
            "info": self.info,
            "scenario_toml": self.scenario_toml,
        }

    def report(self) -> str:
        """The report section (Markdown)."""
        lines = [
            "## Calibration",
            "",
            f"{len(self.points)} experimental points, {len(self.keys)} parameter(s); "
            f"engine seed {self.seed}, {self.samples} impacts per sweep point "
            "(common random numbers).",
            "",
            f"| parameter | estimate | {self.confidence:.0%} interval (Jacobian) "
            "| bootstrap interval | note |",
            "|---|---|---|---|---|",
        ]
        for k, key in enumerate(self.keys):
            if self.identifiable[k]:
                note = "at a bound" if self.at_bound[k] else ""
                lines.append(
                    f"| `{key}` | {self.estimate[k]:.5g} | "
                    f"[{self.ci_low[k]:.4g}, {self.ci_high[k]:.4g}] | "
                    f"[{_fmt(self.bootstrap_ci_low[k])}, "
                    f"{_fmt(self.bootstrap_ci_high[k])}] | {note} |"
                )
            else:
                lines.append(f"| `{key}` | not identifiable | | | {self.reasons[k]} |")
        lines += [
            "",
            f"chi2 = {self.chi2:.4g} with {self.dof} degrees of freedom, "
            f"p = {_fmt(self.p_value)}."
            + (
                " The model does not describe the data within their errors: the "
                "intervals assume it does and are too optimistic (model error is "
                "not parameter uncertainty)."
                if self.p_value is not None
                and math.isfinite(self.p_value)
                and self.p_value < 0.01
                else ""
            ),
            "",
            "The intervals are the linearised region from the Jacobian at the "
            "optimum (covariance not scaled by chi2/dof: the weights are the "
            "measurements' and the simulation's standard errors), checked by a "
            "parametric bootstrap of "
            f"{len(self.bootstrap)} refits. See docs/calibration.md.",
            "",
            "![data against the calibrated model](calibration.png)",
            "",
        ]
        return "\n".join(lines)

    def write(self, out, *, figure=True) -> Path:
        """Write ``calibration.json``, ``calibration.md`` and (with `figure`)
        ``calibration.png`` to folder `out`, each atomically."""

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        text = _json.dumps(self.to_dict(), indent=2)
        atomic_write(out / "calibration.json", lambda t: Path(t).write_text(text))
        report = self.report()
        atomic_write(out / "calibration.md", lambda t: Path(t).write_text(report))
        if figure:
            use_agg()
            # deferred: matplotlib loads only when a figure is drawn
            import matplotlib.pyplot as plt

            fig = plot_calibration(self)
            try:
                atomic_write(
                    out / "calibration.png",
                    lambda t: fig.savefig(t, format="png", dpi=200),
                )
            finally:
                plt.close(fig)
        return out


def _fmt(x) -> str:
    if x is None or not math.isfinite(float(x)):
        return "n/a"
    return f"{float(x):.4g}"


# ---------------------------------------------------------------------- fitting
def _scale(x0, bounds):
    """A natural scale of each parameter: |start value|, else a 100th of a finite
    range, else 1."""
    s = np.abs(np.asarray(x0, dtype=float))
    width = bounds[:, 1] - bounds[:, 0]
    fallback = np.where(np.isfinite(width), width / 100.0, 1.0)
    return np.where(s > 0, s, fallback)


def _steps(x, h, bounds):
    """Finite-difference points of each parameter: ``(x_plus, x_minus, dx)``;
    central where both fit in the bounds, else one-sided."""
    plus, minus, dx = [], [], []
    for j in range(len(x)):
        up, dn = x.copy(), x.copy()
        hi_ok = x[j] + h[j] <= bounds[j, 1]
        lo_ok = x[j] - h[j] >= bounds[j, 0]
        if hi_ok and lo_ok:
            up[j] += h[j]
            dn[j] -= h[j]
        elif hi_ok:
            up[j] += h[j]
        else:
            dn[j] -= h[j]
        plus.append(up)
        minus.append(dn)
        dx.append(up[j] - dn[j])
    return plus, minus, np.asarray(dx)


class _Objective:
    """Weighted residuals and their finite-difference Jacobian (runs batched)."""

    def __init__(self, model, y, s_exp, s_sim, free, x_full, h, bounds):
        self.model, self.y = model, y
        self.sigma = np.sqrt(s_exp**2 + s_sim**2)
        # e and mu pairs on one set of impacts (none for a model without them)
        self.pairs = getattr(model, "pairs", np.zeros((0, 2), int))
        self.pair_r = model.pair_r(s_exp, s_sim) if len(self.pairs) else np.zeros(0)
        self.free = np.asarray(free)  # indices of the fitted parameters
        self.x_full = np.asarray(x_full, dtype=float)
        self.h, self.bounds = h, bounds

    def full(self, xf):
        x = self.x_full.copy()
        x[self.free] = xf
        return x

    def residual_of(self, summary):
        """Standardised residuals, each pair of e and mu on one set of impacts
        decorrelated (whitened: the sum of squares is then the Gaussian's
        chi-squared with the pair's covariance)."""
        m, _ = self.model.points(summary)
        return whiten((m - self.y) / self.sigma, self.pairs, self.pair_r)

    def __call__(self, xf):
        (s,) = self.model.summaries([self.full(xf)])
        r = self.residual_of(s)
        # a trial point where the model leaves a measured statistic undefined (e.g.
        # every particle captured, so no e): a large residual, so that the
        # optimiser rejects the step instead of failing on NaN
        return np.where(np.isfinite(r), r, UNDEFINED_RESIDUAL)

    def jac(self, xf, *args):
        x = self.full(xf)
        plus, minus, dx = _steps(
            x[self.free], self.h[self.free], self.bounds[self.free]
        )
        pts = [self.full(p) for p in plus] + [self.full(p) for p in minus]
        ss = self.model.summaries(pts)
        n = len(self.free)
        r0 = self.residual_of(self.model.summaries([x])[0])
        cols = []
        for j in range(n):
            rp, rm = self.residual_of(ss[j]), self.residual_of(ss[n + j])
            col = (rp - rm) / dx[j]
            # a side where the model is undefined: one-sided from the centre
            # (half the span), else no slope known
            up = (rp - r0) / (plus[j][j] - x[self.free][j] or dx[j])
            dn = (r0 - rm) / (x[self.free][j] - minus[j][j] or dx[j])
            col = np.where(np.isfinite(col), col, np.where(np.isfinite(up), up, dn))
            cols.append(np.where(np.isfinite(col), col, 0.0))
        return np.column_stack(cols) if cols else np.zeros((len(self.y), 0))


def _least_squares(obj, x0f, bounds_f, scale_f, *, xtol=1e-5):
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.optimize import least_squares

    lo, hi = bounds_f[:, 0], bounds_f[:, 1]
    x0f = np.clip(x0f, lo, hi)
    return least_squares(
        obj,
        x0f,
        jac=obj.jac,
        bounds=(lo, hi),
        x_scale=scale_f,
        method="trf",
        xtol=xtol,
        ftol=1e-8,
        gtol=1e-8,
        max_nfev=100,
    )


def _identify(J, h, width, *, rcond, z, J2=None):
    """``(identifiable, reasons, cov, s_normalised, noise)`` from the weighted
    Jacobian `J`; `J2` (the same at twice the step) measures the finite-difference
    error: a direction whose singular value is below it is not determined."""
    m, n = J.shape
    norms = np.linalg.norm(J, axis=0)
    reasons: list = [None] * n
    ok = np.ones(n, dtype=bool)
    # no effect: the column vanishes (exactly, under common random numbers, when
    # the data do not depend on the parameter) or is round-off against the others
    effect = norms * h
    big = effect.max() if n else 0.0
    for j in range(n):
        if norms[j] == 0 or effect[j] <= 1e-9 * big:
            ok[j] = False
            reasons[j] = (
                "the data do not depend on it (its finite-difference step changes "
                "no residual)"
            )
    cov = np.full((n, n), np.nan)
    svals = np.array([])
    noise = 0.0
    idx = np.flatnonzero(ok)
    if idx.size:
        Jn = J[:, idx] / norms[idx]
        if J2 is not None:
            noise = float(np.linalg.norm(Jn - J2[:, idx] / norms[idx], 2))
        _, svals, Vt = np.linalg.svd(Jn, full_matrices=False)
        if idx.size > m:
            svals = np.concatenate([svals, np.zeros(idx.size - svals.size)])
            _, _, Vt = np.linalg.svd(Jn, full_matrices=True)
        cut = max(rcond * svals[0], noise)
        keep = svals > cut if svals[0] > 0 else np.zeros_like(svals, bool)
        null = Vt[~keep]
        for a, j in enumerate(idx):
            if null.size and np.max(np.abs(null[:, a])) > 0.1:
                ok[j] = False
                partners = [
                    k
                    for b, k in enumerate(idx)
                    if b != a and np.any(np.abs(null[:, b]) > 0.1)
                ]
                reasons[j] = (
                    "the data determine only a combination of it"
                    + (
                        " with " + ", ".join(f"#{k}" for k in partners)
                        if partners
                        else ""
                    )
                    + f" (normalised singular value {svals[~keep].min():.2g} of "
                    f"{svals[0]:.2g}, below the threshold {cut:.2g}: "
                    f"max of {rcond:g} x the largest and the finite-difference "
                    f"error {noise:.2g})"
                )
        Vk, sk = Vt[keep], svals[keep]
        cn = (Vk.T / sk**2) @ Vk
        sub = cn / np.outer(norms[idx], norms[idx])
        cov[np.ix_(idx, idx)] = sub
        for j in np.flatnonzero(ok):
            half = z * math.sqrt(cov[j, j])
            if np.isfinite(width[j]) and 2 * half > width[j]:
                ok[j] = False
                reasons[j] = (
                    f"the data barely constrain it: its {2 * half:.3g} wide interval "
                    f"exceeds its bounds' range {width[j]:.3g}"
                )
    for j in np.flatnonzero(~ok):
        cov[j, :] = np.nan
        cov[:, j] = np.nan
    return ok, reasons, cov, svals, noise


def calibrate(
    scenario,
    experiments,
    parameters: Sequence[str] | Mapping,
    *,
    bounds: Mapping | None = None,
    seed: int | None = None,
    samples: int | None = None,
    workers: int = 1,
    executor=None,
    bootstrap: int = DEFAULT_BOOTSTRAP,
    confidence: float = 0.95,
    rel_step: float = DEFAULT_STEP,
    rcond: float = DEFAULT_RCOND,
    source=None,
    base_dir=None,
    bootstrap_seed: int | None = 0,
    band_draws: int = BAND_DRAWS,
    progress=None,
    method: str = "lsq",
    **bayes_options,
) -> CalibrationResult | BayesResult:
    """Fit scenario parameters to measured rebound statistics.

    Parameters
    ----------
    scenario : ScenarioFile, path, preset name or dict
        The scenario file, read once (or its parsed TOML data, with
        `source`/`base_dir`).
        Its sweep must contain the experimental points' speeds and angles (or
        bracket them: the simulation is interpolated as by ``compare``).
    experiments : path or pandas.DataFrame
        An experiment CSV (``docs/outputs.md``) or the table of
        :func:`~microimpact.io.experiments.read_experiments`.
    parameters : sequence of str, or mapping key -> (low, high) or None
        Dotted scenario keys (``surfaces.formica.std_deg``,
        ``coefficients.v_c.a_m_s``, ...); the file's values are the start.
    bounds : mapping key -> (low, high), optional
        Limits (None for a default limit); else :func:`default_bounds`.
    seed : int, optional
        The engine seed of every model run (common random numbers); default the
        scenario's ``seed``, else a fixed 0.
    samples : int, optional
        Impacts per sweep point (default the scenario's ``samples``; a precision
        target is not used, so every run draws the same impacts).
    workers, executor :
        Model runs of a Jacobian (2 per parameter) and of a batch are mapped on
        `executor` (anything with ``submit`` or ``map``), else on `workers`
        threads (the compiled kernel) or processes. Without an executor, the
        bootstrap refits run at once on `workers` processes forked from this
        one (each an optimiser of its own; where this process cannot fork,
        because another thread runs, they run one after the other).
    bootstrap : int, default 100
        Parametric bootstrap refits (0: none).
    confidence : float, default 0.95
    rel_step : float
        Finite-difference step relative to each parameter's scale.
    rcond : float
        Identifiability threshold on the normalised Jacobian's singular values.
    bootstrap_seed : int, optional
        Seed of the bootstrap's data draws.
    band_draws : int
        Without enough bootstrap refits (fewer than this), the model band comes
        from this many parameter draws from the covariance (0: no band).
    progress : bool or callable, optional
        Progress of the steps (the fit, each bootstrap refit, the band): ``True``
        shows a bar (tqdm, on stderr), a callable is called as
        ``progress(done, total)``; default: a bar only when stderr is a terminal.
    method : {"lsq", "bayes"}
        Least squares (this function), or the posterior by MCMC
        (:func:`~microimpact.analysis.bayes.calibrate_bayes`, which takes the
        `bayes_options` ``priors``, ``walkers``, ``steps``, ...; the least-squares
        options are not used).

    Returns
    -------
    CalibrationResult

    Raises
    ------
    InputError
        A key that is not a number of the scenario (or not a model parameter),
        bounds that are empty or that the scenario rejects, an experiment file
        that cannot be read or whose points are not in the sweep.
    """
    if method == "bayes":
        return calibrate_bayes(
            scenario,
            experiments,
            parameters,
            bounds=bounds,
            seed=seed,
            samples=samples,
            workers=workers,
            executor=executor,
            confidence=confidence,
            source=source,
            base_dir=base_dir,
            progress=progress,
            **bayes_options,
        )
    if method != "lsq" or bayes_options:
        raise InputError(
            f"method {method} takes no option(s) {', '.join(bayes_options)}"
            if method == "lsq"
            else f"must be lsq or bayes; got {method}",
            field="method",
        )
    if not (isinstance(confidence, float | int) and 0 < confidence < 1):
        raise InputError(f"must be in (0, 1); got {confidence!r}", field="confidence")
    if isinstance(bootstrap, bool) or not isinstance(bootstrap, int) or bootstrap < 0:
        raise InputError(
            f"must be an integer >= 0; got {bootstrap!r}", field="bootstrap"
        )
    check_progress(progress)
    # the priors of a [calibration] table are for the Bayesian method only
    scenario, _, source, base_dir = split_calibration_table(scenario, source, base_dir)
    smodel = ScenarioModel(scenario, samples=samples, source=source, base_dir=base_dir)
    source, base_dir = smodel.source, smodel.base_dir
    keys, x0, B = _parameters(smodel, parameters, bounds)
    smodel.set_keys(keys)
    width = B[:, 1] - B[:, 0]
    scale = _scale(x0, B)
    x0 = np.clip(x0, B[:, 0], B[:, 1])
    h = rel_step * scale
    exp, exp_source = _read_experiments(experiments)
    base = smodel.base
    if seed is None:
        seed = base.seed if base.seed is not None else 0
    smodel.seed = seed = int(seed)
    samples = smodel.samples

    steps = Progress(progress, total=2 + bootstrap, unit="steps", desc="calibrate")
    with _mapper(workers, executor) as mapper, steps:
        model = _Model(smodel, exp, mapper)
        y, s_exp, s_sim = _start(model, x0, exp_source)
        exp = model.exp
        model.set_pairs(x0)
        fit, x, sx, s_sim = _fit(model, y, s_exp, s_sim, x0, h, B, scale)
        steps.update()
        u = _uncertainty(
            model, y, s_exp, s_sim, x, h, B, width, scale, confidence, rcond
        )
        boot, boot_curves = _bootstrap(
            model,
            sx,
            y,
            s_exp,
            s_sim,
            x,
            h,
            B,
            scale,
            u["idx"],
            bootstrap,
            bootstrap_seed,
            steps,
        )
        _warn_if_rejected(u["chi2"], u["dof"], u["p_value"], confidence)
        b_lo, b_hi = _bootstrap_intervals(boot, u["idx"], len(keys), confidence)
        band_summaries, band_from = _band(
            model, boot, boot_curves, x, B, u, band_draws, bootstrap_seed
        )
        curves = _curves(sx, band_summaries, exp, 1 - confidence)
        points = _points_table(model, sx, exp, y, s_exp, s_sim)
        steps.update()
        runs = model.runs

    calibrated = with_values(
        smodel.data, dict(zip(keys, x.tolist(), strict=True)), source=source
    )
    svals, undefined = u["svals"], u["undefined"]
    info = {
        "optimizer": {
            "status": int(fit.status),
            "message": str(fit.message),
            "nfev": int(fit.nfev),
            "njev": int(fit.njev) if fit.njev is not None else None,
        },
        "model_runs": int(runs),
        "finite_difference_steps": dict(zip(keys, h.tolist(), strict=True)),
        "singular_values_normalised": (svals / svals[0]).tolist()
        if svals.size and svals[0] > 0
        else [],
        "condition_number": float(svals[0] / svals[-1])
        if svals.size and svals[-1] > 0
        else None,
        "jacobian_fd_error_normalised": u["fd_noise"],
        "band": band_from,
        "undefined_at_optimum": [int(v) for v in exp["line"].to_numpy()[undefined]],
        # e and mu of one file at one point (experiment lines), weighted as one
        # correlated pair (docs/calibration.md)
        "same_impact_pairs": pairs_info(model.pairs, model.rho, exp["line"]),
        "experiments": exp_source,
        "scenario": None if source is None else str(source),
    }
    ok, se = u["ok"], u["se"]
    return CalibrationResult(
        keys=tuple(keys),
        estimate=x,
        identifiable=ok,
        reasons=u["reasons"],
        std_error=se,
        ci_low=np.where(ok, u["ci_low"], np.nan),
        ci_high=np.where(ok, u["ci_high"], np.nan),
        covariance=u["cov"],
        correlation=u["corr"],
        bounds=B,
        at_bound=u["at_bound"],
        chi2=u["chi2"],
        dof=int(u["dof"]),
        p_value=u["p_value"],
        confidence=float(confidence),
        points=points,
        curves=curves,
        data=calibrated,
        seed=seed,
        samples=samples,
        bootstrap=boot,
        bootstrap_ci_low=b_lo,
        bootstrap_ci_high=b_hi,
        info=info,
        base_dir=None if base_dir is None else str(base_dir),
    )


def _start(model, x0, exp_source):
    """The model at the start: ``(y, s_exp, s_sim)`` at the experimental points
    that carry an error (``model.exp`` keeps only those); a point the sweep cannot
    serve is the user's error."""
    exp = model.exp
    (s0,) = model.summaries([x0])
    try:
        _, s_sim = model.points(s0)
    except ValueError as exc:
        raise InputError(str(exc), source=exp_source) from None
    y = exp["mean"].to_numpy(float)
    s_exp = exp["se"].to_numpy(float)
    bad = np.flatnonzero(~np.isfinite(s_sim))
    if bad.size:
        t = compare(s0, exp)
        i = int(bad[0])
        raise InputError(
            f"experimental point (line {exp['line'].iloc[i]}): {t['note'].iloc[i]}",
            source=exp_source,
        )
    use = np.sqrt(s_exp**2 + s_sim**2) > 0  # e.g. e_relative at the reference angle
    if not use.all():
        model.exp = exp[use].reset_index(drop=True)
        y, s_exp, s_sim = y[use], s_exp[use], s_sim[use]
    if len(y) == 0:
        raise InputError(
            "no experimental point with a nonzero error", source=exp_source
        )
    return y, s_exp, s_sim


def _fit(model, y, s_exp, s_sim, x0, h, B, scale):
    """The least-squares fit: weights at the start, then once more at the first
    optimum. Returns ``(fit, x, summary at x, s_sim at x)``."""
    free = np.arange(len(x0))
    x = x0.copy()
    for _ in range(3):
        obj = _Objective(model, y, s_exp, s_sim, free, x, h, B)
        fit = _least_squares(obj, x, B, scale)
        x = fit.x.copy()
        (sx,) = model.summaries([x])
        _, s_new = model.points(sx)
        old_sigma = np.sqrt(s_exp**2 + s_sim**2)
        s_sim = s_new
        # the pairs' correlation at the optimum too (it moves with the parameters)
        old_r = model.pair_r(s_exp, s_sim)
        model.set_pairs(x)
        moved = np.abs(model.pair_r(s_exp, s_sim) - old_r)
        if np.max(
            np.abs(np.sqrt(s_exp**2 + s_sim**2) / old_sigma - 1)
        ) < 0.01 and not np.any(moved > 0.002):
            break  # the weights hardly moved: no refit
    return fit, x, sx, s_sim


def _uncertainty(model, y, s_exp, s_sim, x, h, B, width, scale, confidence, rcond):
    """chi2, identifiability, covariance, intervals and correlations at `x`."""
    keys, n = model.keys, len(x)
    free = np.arange(n)
    obj = _Objective(model, y, s_exp, s_sim, free, x, h, B)
    r = obj.residual_of(model.summaries([x])[0])
    undefined = ~np.isfinite(r)  # no model value at the optimum: not in chi2
    r = r[~undefined]
    J = obj.jac(x)[~undefined]
    obj2 = _Objective(model, y, s_exp, s_sim, free, x, 2 * h, B)
    J2 = obj2.jac(x)[~undefined] if n > 1 else None  # the FD error (n > 1 only)
    chi2 = float(r @ r)
    z = z_value(confidence)
    ok, reasons, cov, svals, fd_noise = _identify(J, h, width, rcond=rcond, z=z, J2=J2)
    for j, why in enumerate(reasons):  # name partners by key, not index
        if why:
            reasons[j] = re.sub(r"#(\d+)", lambda mm: keys[int(mm.group(1))], why)
    n_id = int(ok.sum())
    dof = int((~undefined).sum()) - n_id
    p_value = float(stats.chi2.sf(chi2, dof)) if dof > 0 else math.nan
    se = np.sqrt(np.where(ok, np.diag(cov), np.nan))
    corr = np.full((n, n), np.nan)
    idx = np.flatnonzero(ok)
    if idx.size:
        d = se[idx]
        corr[np.ix_(idx, idx)] = cov[np.ix_(idx, idx)] / np.outer(d, d)
        corr[idx, idx] = 1.0
    at_bound = np.isclose(x, B[:, 0], rtol=0, atol=1e-9 * scale) | np.isclose(
        x, B[:, 1], rtol=0, atol=1e-9 * scale
    )
    return {
        "undefined": undefined,
        "chi2": chi2,
        "ok": ok,
        "reasons": reasons,
        "cov": cov,
        "svals": svals,
        "fd_noise": fd_noise,
        "dof": dof,
        "p_value": p_value,
        "se": se,
        "ci_low": x - z * se,
        "ci_high": x + z * se,
        "corr": corr,
        "idx": idx,
        "at_bound": at_bound,
    }


def _bootstrap(model, sx, y, s_exp, s_sim, x, h, B, scale, idx, bootstrap, seed, steps):
    """Parametric bootstrap: data drawn from the fitted model with the combined
    noise, refitted `bootstrap` times. Returns ``(refits (B, n), their summaries)``.

    The data sets are drawn first, in order; the refits are independent, so on
    the fit's several workers (and no executor of the caller's) they run at once
    in worker processes forked from this one, each holding the model as fitted
    (:func:`~microimpact.engine.parallel.fork_pool`; a refit is an optimiser
    over short runs, mostly Python: threads would wait for one another). Each
    refit's model runs are those of the one-process loop: the same refits, bit
    for bit (the model has common random numbers). Where this process cannot
    fork, one after the other, each refit's Jacobian batches on the fit's pool.
    """
    n = len(x)
    m_hat, _ = model.points(sx)
    sigma = np.sqrt(s_exp**2 + s_sim**2)
    if not (bootstrap and idx.size):
        steps.update(bootstrap)  # nothing identified: no refits to make
        return np.empty((0, n)), []
    rng = np.random.default_rng(seed)
    data = []
    for _b in range(bootstrap):
        # e and mu on one set of impacts: drawn correlated
        z = correlate(
            rng.standard_normal(len(y)), model.pairs, model.pair_r(s_exp, s_sim)
        )
        data.append(m_hat + sigma * z)
    refit = _Refit(model, s_exp, s_sim, idx, x, h, B, scale)
    pool = None
    mapper = model.map
    # the fit's own threads end, so that this process may fork (fork_pool
    # checks that no other thread runs; a pool of processes, without the
    # compiled kernel, is the refits' as it is)
    if isinstance(mapper, RunPool) and mapper.threads and mapper.executor is None:
        mapper.release()
        pool = fork_pool(min(mapper.workers, bootstrap), refit)
    fits, curves = [], []
    try:
        if pool is not None:
            for xb, curve, runs in map_held(pool, data):
                fits.append(xb)
                curves.append(curve)
                model.runs += runs
                steps.update()
        else:
            for yb in data:
                xb, curve = refit.refit(model, yb)
                fits.append(xb)
                curves.append(curve)
                steps.update()
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
    return np.array(fits), curves


class _Refit:
    """One bootstrap refit of data `yb` (:func:`_bootstrap`): called in a worker
    process (:func:`~microimpact.engine.parallel.fork_pool`), it runs the model
    there, one run after the other, and returns ``(refit, its summary, model
    runs made)``."""

    def __init__(self, model, s_exp, s_sim, idx, x, h, B, scale):
        self.model = model
        self.s_exp, self.s_sim, self.idx, self.x = s_exp, s_sim, idx, x
        self.h, self.B, self.scale = h, B, scale

    def fit(self, model, yb) -> np.ndarray:
        idx, x, B = self.idx, self.x, self.B
        ob = _Objective(model, yb, self.s_exp, self.s_sim, idx, x, self.h, B)
        fb = _least_squares(ob, x[idx], B[idx], self.scale[idx], xtol=1e-4)
        return ob.full(fb.x)

    def refit(self, model, yb) -> tuple:
        """``(refit, its summary)`` of data `yb` with `model`."""
        xb = self.fit(model, yb)
        curve = model.summaries([xb])[0]
        if len(model.cache) > 256:  # bound the memory: keep the optimum
            keep = tuple(self.x.tolist())
            model.cache = {keep: model.cache[keep]}
        return xb, curve

    def __call__(self, yb):
        model = self.model  # this process's own (forked) copy
        model.map = _serial
        before = model.runs
        xb, curve = self.refit(model, yb)
        return xb, curve, model.runs - before


def _warn_if_rejected(chi2, dof, p_value, confidence):
    """A warning (shown on the terminal by the CLI) where the goodness-of-fit test
    rejects the fit at level ``1 - confidence``: the intervals assume the model
    describes the data within their errors."""
    if not (math.isfinite(p_value) and p_value < 1.0 - confidence):
        return
    warnings.warn(
        f"the fit is rejected: chi2 = {chi2:.4g} on {dof} degrees of freedom, "
        f"p = {_fmt(p_value)} < {1.0 - confidence:g}; the model does not describe "
        "the data within their errors, so the intervals (which assume it does) are "
        "too narrow; see docs/calibration.md",
        RuntimeWarning,
        stacklevel=3,
    )


def _bootstrap_intervals(boot, idx, n, confidence):
    """Percentile intervals of the bootstrap refits (NaN without refits)."""
    alpha = 1 - confidence
    b_lo = np.full(n, np.nan)
    b_hi = np.full(n, np.nan)
    if len(boot):
        b_lo[idx] = np.quantile(boot[:, idx], alpha / 2, axis=0)
        b_hi[idx] = np.quantile(boot[:, idx], 1 - alpha / 2, axis=0)
    return b_lo, b_hi


def _band(model, boot, boot_curves, x, B, u, band_draws, bootstrap_seed):
    """The summaries the model band at every sweep point comes from, and how."""
    idx, cov = u["idx"], u["cov"]
    if len(boot) >= max(band_draws, 1):
        return boot_curves, "bootstrap refits"
    if idx.size and band_draws > 0:
        rng = np.random.default_rng(1 if bootstrap_seed is None else bootstrap_seed + 1)
        c = cov[np.ix_(idx, idx)]
        draws = rng.multivariate_normal(x[idx], c, size=band_draws, method="svd")
        pts = []
        for dv in draws:
            xd = x.copy()
            xd[idx] = np.clip(dv, B[idx, 0], B[idx, 1])
            pts.append(xd)
        return model.summaries(pts), "parameter draws from the covariance"
    return [], "none"


def _points_table(model, summary, exp, y, s_exp, s_sim):
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    m, _ = model.points(summary)
    sigma = np.sqrt(s_exp**2 + s_sim**2)
    return pd.DataFrame(
        {
            "surface": exp["surface"].where(exp["surface"].notna(), None).tolist()
            if "surface" in exp
            else None,
            "speed_m_s": exp["speed_m_s"].to_numpy(float),
            "angle_deg": exp["angle_deg"].to_numpy(float),
            "statistic": exp["statistic"].tolist(),
            "exp_mean": y,
            "exp_ci_low": exp["ci_low"].to_numpy(float),
            "exp_ci_high": exp["ci_high"].to_numpy(float),
            "exp_se": s_exp,
            "sim_mean": m,
            "sim_se": s_sim,
            "residual": (m - y) / sigma,
            "line": exp["line"].to_numpy(),
        }
    )


def _curves(summary, band_summaries, exp, alpha):
    """The model at every sweep point for each statistic of the data, with the
    band (quantiles over `band_summaries`)."""
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    rows = []
    for stat in dict.fromkeys(exp["statistic"]):
        col = _CURVE[stat]
        if col not in summary:
            continue
        base = summary[["surface", "speed_m_s", "angle_deg", col]].rename(
            columns={col: "model"}
        )
        base = base.assign(statistic=stat)
        if band_summaries:
            stack = np.column_stack([s[col].to_numpy(float) for s in band_summaries])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                base["band_low"] = np.nanquantile(stack, alpha / 2, axis=1)
                base["band_high"] = np.nanquantile(stack, 1 - alpha / 2, axis=1)
        else:
            base["band_low"] = np.nan
            base["band_high"] = np.nan
        rows.append(base)
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()


def _absolute_files(data, base_dir):
    """A copy of `data` whose ``file`` values are absolute paths (the calibrated
    TOML is written elsewhere than the scenario)."""

    if base_dir is None:
        return data
    base = Path(base_dir)

    def fix(node):
        if isinstance(node, dict):
            for k, v in node.items():
                if k == "file" and isinstance(v, str):
                    node[k] = str((base / v).resolve())
                elif k == "file" and isinstance(v, list):
                    node[k] = [
                        str((base / f).resolve()) if isinstance(f, str) else f
                        for f in v
                    ]
                else:
                    fix(v)
        elif isinstance(node, list):
            for e in node:
                fix(e)
        return node

    return fix(copy.deepcopy(data))
