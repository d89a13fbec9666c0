"""Bayesian calibration: the posterior of scenario parameters given measurements
(``calibrate(..., method="bayes")``, ``microimpact calibrate --method bayes``; see
``docs/calibration.md``).

**Model.** The engine at a parameter vector with *common random numbers*
(:class:`~microimpact.analysis.model.ScenarioModel`: the same seed and impacts per
sweep point at every evaluation), so the likelihood is a smooth function of the
parameters but for steps of about ``1/N`` where an impact switches between capture
and rebound. The likelihoods are those of :mod:`.bayes_data`.

**Priors** (:mod:`.priors`): uniform over ``KEY=LOW:HIGH`` (or the default bounds
of :func:`~microimpact.analysis.calibration_inputs.default_bounds`), or given per key
in the scenario's ``[calibration.priors]`` table or the `priors` argument.

**Sampler.** emcee's affine-invariant ensemble sampler (Goodman & Weare 2010;
Foreman-Mackey et al. 2013), walkers started from prior draws, run in batches of
`check_every` steps until converged or `steps` are spent. The walkers' log-posterior
evaluations (one engine run each) are spread by the project's one mechanism
(:func:`~microimpact.engine.parallel.map_tasks`: an executor, else threads where the
runs free the GIL, else processes).

**Burn-in rule.** Discard the first ``ceil(5 τ_max)`` steps, ``τ_max`` the largest
integrated autocorrelation time over the parameters measured on the whole run, and
at most half of the run.

**Convergence** (all three, on the steps after burn-in, each walker a chain):
the run is at least ``50 τ_max`` steps (emcee's rule for a reliable ``τ``); the
rank-normalised split R̂ (Vehtari et al. 2021, ArviZ) is at most 1.01 for every
parameter; the bulk effective sample size is at least `min_ess` (400). Where they
fail the result says so, and how many more steps it needs: the most of
``1.5 (50 τ_max + burn-in) - steps`` (``τ`` measured on a short run is low), the
steps that bring the ESS to `min_ess` at the measured rate, and for R̂ the run
after burn-in lengthened by ``1.5 (R̂ - 1)/0.01``: with the walkers taken as chains,
``R̂ - 1`` falls like ``τ`` over the steps after burn-in (the within-walker variance
of a short run is biased low by about ``1/ESS`` per split chain), so R̂ <= 1.01
needs about ``100 τ`` steps after burn-in.
"""

from __future__ import annotations

import math
import os
import tomllib
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core.progress import Progress, check_progress
from ..engine.parallel import RunPool, fork_pool, map_held
from ..errors import InputError
from .bayes_data import MC_VARIANCE_RATIO, Likelihood, read_calibration_data
from .bayes_output import (
    inference_data,
    report_html,
    report_markdown,
    write_result,
)
from .calibration_inputs import _parameters
from .model import ScenarioModel
from .pairs import pair_correlations, pairs_info
from .priors import make_prior, uniform_prior

__all__ = ["BayesResult", "calibrate_bayes"]

#: Largest R̂ of a converged run.
RHAT_MAX = 1.01
#: Smallest bulk effective sample size of a converged run.
MIN_ESS = 400
#: Steps per autocorrelation time a converged run needs (emcee's rule).
TAU_FACTOR = 50
#: Burn-in: this many autocorrelation times (at most half the run).
BURN_TAU = 5
#: Default most steps, and steps between convergence checks.
DEFAULT_STEPS = 5000
CHECK_EVERY = 100
#: A posterior whose central interval is at least this fraction of the prior's is
#: reported as prior-dominated (the data do not constrain it).
PRIOR_DOMINATED = 0.8
#: Pairs correlated beyond this are named.
CORRELATED = 0.9


# ---------------------------------------------------------------------- the model
class LogPosterior:
    """``theta -> (log posterior, blob)``: prior plus the likelihood of the engine
    run at ``theta`` (picklable: a worker task)."""

    def __init__(self, model: ScenarioModel, likelihood: Likelihood, priors):
        self.model, self.likelihood, self.priors = model, likelihood, priors

    def log_prior(self, theta) -> float:
        return float(sum(p.logpdf(v) for p, v in zip(self.priors, theta, strict=True)))

    def __call__(self, theta):
        blob = np.full(self.likelihood.blob_size, np.nan)
        lp = self.log_prior(theta)
        if not math.isfinite(lp):
            return -math.inf, blob
        lk = self.likelihood
        try:
            # e and mu on one set of impacts: their correlation from the run's own
            # tables (built once for both)
            plan = self.model.plan(theta) if len(lk.pairs) else None
            result = self.model.run(theta, plan=plan)
        except InputError:  # a value the scenario refuses: outside the support
            return -math.inf, blob
        rho = None
        if plan is not None:
            if lk.match_means is None:
                lk.setup(result.summary)  # the points matched once, on the first run
            rho = pair_correlations(
                self.model, theta, lk.pairs, lk.match_means, plan=plan
            )
        ll, blob = lk.evaluate(result, rho)
        return (lp + ll if math.isfinite(ll) else -math.inf), blob


class _Pool(RunPool):
    """emcee's ``pool``: the fit's :class:`~microimpact.engine.parallel.RunPool`.
    Without an executor, on several workers, the walkers' log posteriors run
    in worker processes forked from this one, each holding `held` (the
    :class:`LogPosterior`, its tables built:
    :func:`~microimpact.engine.parallel.fork_pool`; a run holds the GIL for
    much of its time, so threads waited for one another); where this process
    cannot fork, on the run pool."""

    def __init__(self, workers, executor, held=None):
        super().__init__(workers, executor)
        self.held = held
        self.forked = None
        if executor is None and held is not None:
            self.forked = fork_pool(self.workers, held)

    def map(self, func, items):
        # emcee wraps the log posterior (its _FunctionWrapper keeps it as `f`)
        plain = not (getattr(func, "args", None) or getattr(func, "kwargs", None))
        if self.forked is not None and getattr(func, "f", func) is self.held and plain:
            return list(map_held(self.forked, list(items)))
        return super().map(func, items)

    def close(self):
        super().close()
        if self.forked is not None:
            self.forked.shutdown(wait=True, cancel_futures=True)


# ---------------------------------------------------------------------- diagnostics
@dataclass
class Diagnostics:
    """The run's convergence: burn-in, ``tau`` per parameter, R̂, bulk ESS."""

    steps: int
    burn_in: int
    tau: np.ndarray
    r_hat: np.ndarray
    ess: np.ndarray
    converged: bool
    more_steps: int
    reasons: list


def diagnose(chain, *, min_ess=MIN_ESS) -> Diagnostics:
    """Diagnostics of an emcee chain ``(steps, walkers, n)`` by the rules of the
    module docstring."""
    # deferred: emcee and ArviZ load only for a Bayesian calibration (import time)
    import arviz as az
    import emcee

    steps = chain.shape[0]
    with np.errstate(invalid="ignore", divide="ignore"):  # a walker that never moved
        tau0 = emcee.autocorr.integrated_time(chain, tol=0)
    tau0 = np.where(np.isfinite(tau0), tau0, steps)
    burn = int(min(math.ceil(BURN_TAU * np.max(tau0)), steps // 2))
    kept = chain[burn:]
    with np.errstate(invalid="ignore", divide="ignore"):
        tau = emcee.autocorr.integrated_time(kept, tol=0)
    tau = np.where(np.isfinite(tau), tau, kept.shape[0])
    ds = az.convert_to_dataset(np.swapaxes(kept, 0, 1))  # (chain, draw, n)
    r_hat = np.atleast_1d(az.rhat(ds)["x"].to_numpy()).astype(float)
    ess = np.atleast_1d(az.ess(ds, method="bulk")["x"].to_numpy()).astype(float)
    reasons = []
    more = 0
    need_tau = TAU_FACTOR * float(np.max(tau))
    if kept.shape[0] < need_tau:
        reasons.append(
            f"{kept.shape[0]} steps after burn-in, fewer than {TAU_FACTOR} "
            f"autocorrelation times ({need_tau:.0f})"
        )
        # tau measured on a short run is low: ask for half as much again
        more = max(more, math.ceil(1.5 * (need_tau + burn) - steps))
    if not np.all(r_hat <= RHAT_MAX):
        r = float(np.nanmax(r_hat)) if np.isfinite(r_hat).any() else math.inf
        reasons.append(f"R-hat {r:.3f} > {RHAT_MAX}")
        # R-hat - 1 of walkers as chains falls like tau / (steps after burn-in)
        grow = 1.5 * (r - 1.0) / (RHAT_MAX - 1.0) if math.isfinite(r) else 2.0
        more = max(more, math.ceil(burn + grow * kept.shape[0] - steps))
    if not np.all(ess >= min_ess):
        e = float(np.nanmin(ess))
        reasons.append(f"bulk ESS {e:.0f} < {min_ess}")
        rate = e / max(kept.shape[0], 1)
        more = max(more, math.ceil((min_ess - e) / rate) if rate > 0 else steps)
    if more:
        more = int(math.ceil(more / CHECK_EVERY) * CHECK_EVERY)
    return Diagnostics(
        steps, burn, tau, r_hat, ess, not reasons, more if reasons else 0, reasons
    )


def moves():
    """emcee's moves: differential evolution with a snooker share, which in these
    low-dimensional posteriors mixes in fewer steps than the stretch move (emcee's
    documentation, "Using different moves")."""
    # deferred: emcee loads only for a Bayesian calibration (import time)
    import emcee

    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


def run_sampler(
    log_prob,
    p0,
    *,
    pool=None,
    steps=DEFAULT_STEPS,
    check_every=CHECK_EVERY,
    min_ess=MIN_ESS,
    seed=0,
    progress=False,
):
    """Run emcee from the walkers `p0` (walkers x parameters) in batches of
    `check_every` steps until :func:`diagnose` finds the run converged or `steps`
    are spent. `log_prob` returns the log posterior, or ``(log posterior, blob)``.
    Returns ``(sampler, diagnostics, steps run)``."""
    # deferred: emcee loads only for a Bayesian calibration (import time)
    import emcee

    walkers, n = p0.shape
    sampler = emcee.EnsembleSampler(walkers, n, log_prob, pool=pool, moves=moves())
    # emcee's moves draw from the sampler's own RandomState: seed it
    sampler.random_state = np.random.RandomState(seed).get_state()
    state, done, diag = p0, 0, None
    bar = Progress(progress, total=steps, unit="steps", desc="posterior")
    with bar:
        while done < steps:
            batch = min(check_every, steps - done)
            state = sampler.run_mcmc(state, batch, progress=False)
            done += batch
            bar.update(batch)
            diag = diagnose(sampler.get_chain(), min_ess=min_ess)
            if diag.converged:
                break
    return sampler, diag, done


# ---------------------------------------------------------------------- result
@dataclass
class BayesResult:
    """What :func:`calibrate_bayes` found: the posterior sample after burn-in
    (``chain``: walkers x draws x parameters), the diagnostics, and summaries.
    ``write(out)`` writes ``calibration.json``, ``posterior.nc``,
    ``calibration.md`` and the figures."""

    keys: tuple
    priors: list
    chain: np.ndarray
    log_prob: np.ndarray
    blobs: np.ndarray  #: walkers x draws x blob (the predictions at each draw)
    diagnostics: Diagnostics
    acceptance: float
    confidence: float
    data: object  #: CalibrationData
    likelihood: object
    seed: int
    samples: int
    walkers: int
    info: dict = field(default_factory=dict)

    method = "bayes"

    @property
    def flat(self) -> np.ndarray:
        return self.chain.reshape(-1, len(self.keys))

    @property
    def posterior_median(self):
        return np.median(self.flat, axis=0)

    def credible(self, confidence=None):
        a = 1 - (self.confidence if confidence is None else confidence)
        return np.quantile(self.flat, [a / 2, 1 - a / 2], axis=0)

    @property
    def correlation(self):
        if len(self.keys) == 1:
            return np.ones((1, 1))
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.corrcoef(self.flat, rowvar=False)

    @property
    def prior_dominated(self):
        """Per parameter: is its central interval at least :data:`PRIOR_DOMINATED`
        of its prior's (same level)?"""
        lo, hi = self.credible()
        a = 1 - self.confidence
        out = []
        for j, p in enumerate(self.priors):
            plo, phi = p.dist.ppf([a / 2, 1 - a / 2])
            out.append(bool((hi[j] - lo[j]) >= PRIOR_DOMINATED * (phi - plo)))
        return np.array(out)

    def correlated_pairs(self):
        c = self.correlation
        n = len(self.keys)
        return [
            (self.keys[i], self.keys[j], float(c[i, j]))
            for i in range(n)
            for j in range(i + 1, n)
            if abs(c[i, j]) > CORRELATED
        ]

    def to_dict(self) -> dict:
        lo, hi = self.credible()
        med = self.posterior_median
        d = self.diagnostics
        dom = self.prior_dominated
        params = {}
        for j, key in enumerate(self.keys):
            params[key] = {
                "posterior_median": float(med[j]),
                "credible_low": float(lo[j]),
                "credible_high": float(hi[j]),
                "r_hat": float(d.r_hat[j]),
                "ess": float(d.ess[j]),
                "autocorrelation_time": float(d.tau[j]),
                "posterior_mean": float(np.mean(self.flat[:, j])),
                "posterior_std": float(np.std(self.flat[:, j], ddof=1)),
                "prior": self.priors[j].to_dict(),
                "prior_dominated": bool(dom[j]),
            }
        return {
            "method": "bayes",
            "parameters": params,
            "confidence": self.confidence,
            "converged": d.converged,
            "not_converged_because": d.reasons,
            "more_steps_needed": d.more_steps,
            "steps": d.steps,
            "burn_in": d.burn_in,
            "walkers": self.walkers,
            "draws": int(self.flat.shape[0]),
            "acceptance_fraction": self.acceptance,
            "correlation": {"keys": list(self.keys), "matrix": self.correlation},
            "correlated_pairs": [
                {"keys": [a, b], "correlation": r}
                for a, b, r in self.correlated_pairs()
            ],
            "seed": self.seed,
            "samples": self.samples,
            "info": self.info,
        }

    def summary_lines(self) -> list:
        """The terminal summary: each parameter's median and interval, the
        prior-dominated ones, the correlated pairs, the convergence verdict."""
        lo, hi = self.credible()
        med = self.posterior_median
        d = self.diagnostics
        dom = self.prior_dominated
        lines = []
        for j, key in enumerate(self.keys):
            lines.append(
                f"  {key} = {med[j]:.5g} [{lo[j]:.4g}, {hi[j]:.4g}] "
                f"({self.confidence:.0%} credible; R-hat {d.r_hat[j]:.3f}, "
                f"ESS {d.ess[j]:.0f})"
            )
            if dom[j]:
                lines.append(
                    f"    {key}: the posterior is its prior "
                    f"({self.priors[j].describe()}): the data do not constrain it"
                )
        for a, b, r in self.correlated_pairs():
            lines.append(
                f"  {a} and {b} are correlated (r = {r:+.2f}): the data fix a "
                "combination of them"
            )
        if d.converged:
            lines.append(
                f"  converged: {d.steps} steps x {self.walkers} walkers, burn-in "
                f"{d.burn_in}, max autocorrelation time {np.max(d.tau):.1f} steps"
            )
        else:
            lines.append(
                f"  NOT converged after {d.steps} steps ({'; '.join(d.reasons)}): "
                f"run about {d.more_steps} more steps (--steps "
                f"{d.steps + d.more_steps})"
            )
        return lines

    def inference_data(self):
        """The ArviZ InferenceData: posterior, sample_stats, observed_data,
        posterior_predictive."""
        return inference_data(self)

    def report(self) -> str:
        return report_markdown(self)

    def report_html(self, *, figures_dir="") -> str:
        """The report section as HTML (see :func:`.bayes_output.report_html`)."""
        return report_html(self, figures_dir=figures_dir)

    def write(self, out, *, figure=True) -> Path:
        """Write ``calibration.json``, ``posterior.nc``, ``calibration.md`` and
        (with `figure`) ``corner.png`` and ``posterior_predictive.png`` to `out`,
        each atomically."""
        return write_result(self, out, figure=figure)


# ---------------------------------------------------------------------- the run
def split_calibration_table(scenario, source=None, base_dir=None):
    """``(scenario, [calibration] table or None, source, base_dir)``: a scenario
    file's ``[calibration]`` table taken out (the scenario reader does not know
    it); a scenario without one is returned as given."""
    if isinstance(scenario, str | os.PathLike) and Path(scenario).is_file():
        path = Path(scenario)
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError):
            return scenario, None, source, base_dir  # the reader's own error
        # the file is read once: its data go on to the model, [calibration] out
        table = data.pop("calibration", None)
        return data, table, str(path), path.resolve().parent
    if isinstance(scenario, Mapping) and "calibration" in scenario:
        data = dict(scenario)
        return data, data.pop("calibration"), source, base_dir
    return scenario, None, source, base_dir


def _priors(keys, B, table, priors, source):
    given = {}
    if table is not None:
        if not isinstance(table, Mapping) or not set(table) <= {"priors"}:
            raise InputError(
                "the [calibration] table takes only a `priors` table",
                source=source,
                field="calibration",
            )
        given.update(table.get("priors", {}))
    given.update(priors or {})
    unknown = sorted(set(given) - set(keys))
    if unknown:
        raise InputError(
            f"priors for keys that are not parameters: {', '.join(unknown)}",
            source=source,
            field="calibration.priors",
        )
    return [
        make_prior(k, given[k], source=source)
        if k in given
        else uniform_prior(k, B[j, 0], B[j, 1])
        for j, k in enumerate(keys)
    ]


def _warn_if_mc_error(ratios, samples):
    """A warning where the model's Monte Carlo variance exceeds
    :data:`~.bayes_data.MC_VARIANCE_RATIO` of the data's at some point, with the
    impacts per point that would bring it below."""
    worst = max(ratios.values(), default=0.0)
    if not worst > MC_VARIANCE_RATIO:
        return
    kind = max(ratios, key=ratios.get)
    need = math.ceil(samples * worst / MC_VARIANCE_RATIO)
    warnings.warn(
        f"the model's Monte Carlo variance is {worst:.2g} of the data's ({kind}), "
        f"above the {MC_VARIANCE_RATIO:g} that makes it negligible; "
        f"use --samples {need} or more (now {samples}); see docs/calibration.md",
        RuntimeWarning,
        stacklevel=3,
    )


def calibrate_bayes(
    scenario,
    experiments,
    parameters,
    *,
    bounds=None,
    priors=None,
    seed=None,
    samples=None,
    workers=1,
    executor=None,
    confidence=0.95,
    walkers=None,
    steps=DEFAULT_STEPS,
    check_every=CHECK_EVERY,
    min_ess=MIN_ESS,
    sampler_seed=0,
    source=None,
    base_dir=None,
    progress=None,
) -> BayesResult:
    """The posterior of scenario parameters given measurements (the module
    docstring; ``calibrate(..., method="bayes")`` calls this).

    Parameters
    ----------
    scenario, parameters, bounds, seed, samples, workers, executor, confidence :
        As for :func:`~microimpact.analysis.calibration.calibrate`; a scenario file
        may hold a ``[calibration.priors]`` table (:mod:`.priors`).
    experiments : path, table, or a list of them
        Means with intervals, capture counts (``captured``, ``n``) or per-impact
        rebounds (``e``), each told by its header (:mod:`.bayes_data`).
    priors : mapping key -> prior table, optional
        Priors (``{"distribution": "normal", "mean": 12, "std": 3}``); a key
        without one is uniform over its bounds.
    walkers : int, optional
        Ensemble size (even, at least ``2 n + 2``; default ``max(8, 4 n)``).
    steps : int
        The most steps; the run stops at the first check that finds it converged.
    check_every : int
        Steps between convergence checks.
    min_ess : int
        Smallest bulk ESS of a converged run.
    sampler_seed : int
        Seed of the walkers' start and moves (the engine's is `seed`).

    Returns
    -------
    BayesResult
    """
    # deferred: emcee loads only for a Bayesian calibration (import time)
    import emcee

    if not (isinstance(confidence, float | int) and 0 < confidence < 1):
        raise InputError(f"must be in (0, 1); got {confidence}", field="confidence")
    for name, v, least in (("steps", steps, 1), ("check_every", check_every, 1)):
        if isinstance(v, bool) or not isinstance(v, int) or v < least:
            raise InputError(f"must be an integer >= {least}; got {v}", field=name)
    check_progress(progress)
    data_, table, source, base_dir = split_calibration_table(scenario, source, base_dir)
    smodel = ScenarioModel(data_, samples=samples, source=source, base_dir=base_dir)
    keys, x0, B = _parameters(smodel, parameters, bounds)
    smodel.set_keys(keys)
    prior_list = _priors(keys, B, table, priors, smodel.source)
    if seed is None:
        seed = smodel.base.seed if smodel.base.seed is not None else 0
    smodel.seed = seed = int(seed)
    n = len(keys)
    if walkers is None:
        walkers = max(8, 4 * n)
    if isinstance(walkers, bool) or not isinstance(walkers, int) or walkers < 2 * n + 2:
        raise InputError(
            f"must be an integer >= {2 * n + 2} (2 per parameter + 2); got {walkers}",
            field="walkers",
        )
    walkers += walkers % 2
    data = read_calibration_data(experiments)
    like = Likelihood(data, smodel.samples)
    post = LogPosterior(smodel, like, prior_list)
    _, blob0 = post(np.clip(x0, B[:, 0], B[:, 1]))  # checks the points at the start
    dropped = []
    if like.n_means:  # a point with no error at all (e_relative at its reference)
        s_sim = blob0[like.n_means : 2 * like.n_means]
        zero = (data.means["se"].to_numpy(float) == 0) & (np.nan_to_num(s_sim) == 0)
        if zero.any():
            dropped = [int(v) for v in data.means["line"].to_numpy()[zero]]
            data.means = data.means[~zero].reset_index(drop=True)
            if data.means.empty:
                data.means = None
            like = Likelihood(data, smodel.samples)
            post = LogPosterior(smodel, like, prior_list)
            _, blob0 = post(np.clip(x0, B[:, 0], B[:, 1]))
    ratios = like.mc_variance_ratio(blob0)
    _warn_if_mc_error(ratios, smodel.samples)
    rng = np.random.default_rng(sampler_seed)
    p0 = np.column_stack(
        [p.dist.rvs(size=walkers, random_state=rng) for p in prior_list]
    )
    pool = _Pool(workers, executor, held=post)
    try:
        sampler, diag, done = run_sampler(
            post,
            p0,
            pool=pool,
            steps=steps,
            check_every=check_every,
            min_ess=min_ess,
            seed=sampler_seed,
            progress=progress,
        )
    finally:
        pool.close()
    chain = sampler.get_chain()[diag.burn_in :]
    blobs = sampler.get_blobs()[diag.burn_in :]
    if len(like.pairs):  # recorded at the posterior median (it moves with theta)
        like.set_correlations(
            smodel, np.median(chain.reshape(-1, chain.shape[-1]), axis=0)
        )
    info = {
        "points_without_error_left_out": dropped,
        # e and mu of one file at one point (experiment lines) and the
        # correlation of their impacts in the model at the posterior median
        # (each evaluation uses its own)
        "same_impact_pairs": pairs_info(
            like.pairs,
            like.rho,
            [] if data.means is None else data.means["line"],
        ),
        "mc_variance_ratio": ratios,
        "mc_variance_ratio_limit": MC_VARIANCE_RATIO,
        "model_runs": int(done * walkers),
        "sampler": f"emcee {emcee.__version__} EnsembleSampler (DE 0.8, snooker 0.2)",
        "burn_in_rule": f"ceil({BURN_TAU} tau_max), at most half the run",
        "convergence_rule": (
            f"steps after burn-in >= {TAU_FACTOR} tau_max, R-hat <= {RHAT_MAX}, "
            f"bulk ESS >= {min_ess}"
        ),
        "scenario": None if source is None else str(source),
        "experiments": data.sources,
    }
    return BayesResult(
        keys=tuple(keys),
        priors=prior_list,
        chain=np.swapaxes(chain, 0, 1),
        log_prob=np.swapaxes(sampler.get_log_prob()[diag.burn_in :], 0, 1),
        blobs=np.swapaxes(np.asarray(blobs, float), 0, 1),
        diagnostics=diag,
        acceptance=float(np.mean(sampler.acceptance_fraction)),
        confidence=float(confidence),
        data=data,
        likelihood=like,
        seed=seed,
        samples=smodel.samples,
        walkers=walkers,
        info=info,
    )
