r"""Binned size distributions (APS, SMPS, OPC exports): conversion to number per
bin, maximum-likelihood fits to the bins and the chi-squared test on the bins.

An instrument reports, per size bin ``[b_i, b_{i+1})``, a number (or mass, or
volume) per bin or a density over ``log10 d``, ``ln d`` or ``d``. Everything here
works on the **number per bin** ``n_i`` (:func:`number_per_bin`):

* ``count`` / ``dN``: ``n_i = v_i``;
* ``dN/dlogDp``: ``n_i = v_i log10(b_{i+1}/b_i)``;
  ``dN/dlnDp``: ``v_i ln(b_{i+1}/b_i)``;
  ``dN/dDp``: ``v_i (b_{i+1} - b_i)``;
* a mass or volume weighting (``dM/dlogDp``, ``dV/dlogDp``, ``dM/dDp``, ``mass``,
  ``volume``, ...): first the mass or volume per bin as above, then divided by the
  d³ moment of the bin, ``n_i = m_i / d_i^3`` with the bin's geometric midpoint
  ``d_i = sqrt(b_i b_{i+1})`` (the particle density cancels from the shape of the
  number distribution).

Binned likelihood. Particles counted in the instrument's range are a multinomial
sample of the population truncated to ``[b_0, b_k]``; the fits maximise

.. math:: \ln L = \sum_i n_i \ln \frac{F(b_{i+1}) - F(b_i)}{F(b_k) - F(b_0)}

over the normal (``F`` of ``d``) or log-normal (``F`` of ``ln d``) parameters with
:func:`scipy.optimize.minimize`. When the range holds the whole population the
denominator is 1 and this is ``Σ n_i ln(F(b_{i+1}) - F(b_i))``. Standard errors are
from the observed information (the numerical Hessian of ``-ln L``); they are
meaningful only when ``n_i`` are counted particles, not concentrations.

The chi-squared test on the bins (:func:`chi2_binned`): expected counts
``E_i = N p_i`` of the fit, sparse bins merged as in
:func:`~.distributions.chi2_normality` (every ``E >= 5``), ``dof = bins - 1 - 2``.

References
----------
.. [1] W. C. Hinds, *Aerosol Technology*, 2nd ed., Wiley, 1999, ch. 4.
.. [2] J. R. Taylor, *An Introduction to Error Analysis*, 1982, ch. 12.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._core.validation import as_float_array, check_choice, check_scalar
from .distributions import (
    MIN_EXPECTED,
    FitResult,
    SizeDistribution,
    _merge,
    histogram_diameters,
)

__all__ = [
    "BIN_VALUES",
    "RANGE_FLOOR",
    "BinnedSizes",
    "Chi2BinnedResult",
    "binned_median",
    "chi2_binned",
    "edges_from_midpoints",
    "fit_binned_lognormal",
    "fit_binned_normal",
    "number_per_bin",
]

#: What a bin's value may be: ``(weighting, per)``; ``per`` is ``"bin"`` (an amount
#: per bin) or the variable of a density (``"log10"``, ``"ln"``, ``"d"``).
BIN_VALUES = {
    "count": ("number", "bin"),
    "dN": ("number", "bin"),
    "dN/dlogDp": ("number", "log10"),
    "dN/dlnDp": ("number", "ln"),
    "dN/dDp": ("number", "d"),
    "mass": ("mass", "bin"),
    "dM": ("mass", "bin"),
    "dM/dlogDp": ("mass", "log10"),
    "dM/dlnDp": ("mass", "ln"),
    "dM/dDp": ("mass", "d"),
    "volume": ("volume", "bin"),
    "dV": ("volume", "bin"),
    "dV/dlogDp": ("volume", "log10"),
    "dV/dlnDp": ("volume", "ln"),
    "dV/dDp": ("volume", "d"),
}
_N_PARAMS = 2
#: The binned fits keep the location (mean, ln median) above ``x_0 - RANGE_FLOOR *
#: scale``, ``x_0`` the lowest edge (``d`` or ``ln d``): the population's bulk is
#: not entirely below the instrument's range.
RANGE_FLOOR = 3.0
#: ln(1e300): a log-normal fit's ln median or ln GSD beyond it has diverged.
_LOG_HUGE = math.log(1e300)
#: ln(1000): a log-normal fit's GSD beyond 1000 has diverged (aerosols: 1 to ~4).
_LOG_GSD_HUGE = math.log(1e3)


def _edges_iv(edges_um) -> np.ndarray:
    e = as_float_array(edges_um, "edges_um").ravel()
    if e.size < 2 or not np.all(np.isfinite(e) & (e > 0)):
        raise ValueError(f"`edges_um` must hold at least 2 finite edges > 0; got {e}.")
    if np.any(np.diff(e) <= 0):
        raise ValueError(f"`edges_um` must be strictly increasing; got {e}.")
    return e


def _counts_iv(counts, k) -> np.ndarray:
    c = as_float_array(counts, "counts").ravel()
    if c.size != k:
        raise ValueError(f"`counts` needs {k} values (one per bin); got {c.size}.")
    if not np.all(np.isfinite(c) & (c >= 0)) or not c.sum() > 0:
        raise ValueError("`counts` must be finite, >= 0 and not all 0.")
    return c


def edges_from_midpoints(midpoints_um, *, rtol=0.05):
    """Bin edges from bin midpoints, taken as geometric (log) midpoints.

    Interior edges are the geometric means of neighbouring midpoints,
    ``b_i = sqrt(m_{i-1} m_i)``; the outer edges continue the neighbouring ratio,
    ``b_0 = m_0^2 / b_1`` and ``b_k = m_{k-1}^2 / b_{k-1}``.

    Parameters
    ----------
    midpoints_um : array_like
        At least 2 strictly increasing midpoints [µm].
    rtol : float
        Consistency check: every rebuilt bin's geometric midpoint
        ``sqrt(b_i b_{i+1})`` must equal its midpoint within `rtol` (exact for
        log-spaced midpoints; irregular midpoints cannot be binned this way).

    Returns
    -------
    ndarray, shape (k + 1,)
        The edges [µm].

    Raises
    ------
    ValueError
        Fewer than 2 midpoints, not increasing, or the reconstruction is not
        consistent (naming the worst bin).
    """
    m = _edges_iv(midpoints_um)
    inner = np.sqrt(m[:-1] * m[1:])
    edges = np.concatenate([[m[0] ** 2 / inner[0]], inner, [m[-1] ** 2 / inner[-1]]])
    back = np.sqrt(edges[:-1] * edges[1:])
    err = np.abs(back / m - 1.0)
    i = int(np.argmax(err))
    if err[i] > rtol:
        raise ValueError(
            f"the midpoints are not log-spaced: the bin edges derived from them "
            f"(geometric means of neighbours) give bin {i} the midpoint {back[i]:.4g} "
            f"instead of {m[i]:.4g} ({100 * err[i]:.1f} % off, more than "
            f"{100 * rtol:g} %)"
        )
    return edges


def number_per_bin(edges_um, values, kind):
    """Number of particles per bin from an instrument's bin values.

    Parameters
    ----------
    edges_um : array_like, shape (k + 1,)
        Bin edges [µm].
    values : array_like, shape (k,)
        The values per bin, >= 0.
    kind : str
        One of :data:`BIN_VALUES` (``"dN/dlogDp"``, ``"count"``, ``"dM/dlogDp"``...).

    Returns
    -------
    ndarray, shape (k,)
        Number per bin (in the units of `values` times bin width; for a mass or
        volume weighting, divided by ``d_i^3`` [µm³] of the geometric midpoint, so
        only proportional to the number).
    """
    check_choice(kind, "kind", tuple(BIN_VALUES))
    e = _edges_iv(edges_um)
    v = _counts_iv(values, e.size - 1)
    weighting, per = BIN_VALUES[kind]
    width = {
        "bin": np.ones(v.size),
        "log10": np.log10(e[1:] / e[:-1]),
        "ln": np.log(e[1:] / e[:-1]),
        "d": np.diff(e),
    }[per]
    amount = v * width
    if weighting != "number":
        amount = amount / (e[:-1] * e[1:]) ** 1.5  # d_i^3 with d_i = sqrt(b_i b_i+1)
    return amount


@dataclass(frozen=True, eq=False)
class BinnedSizes:
    """A binned size distribution read from an instrument export.

    Attributes
    ----------
    edges_um : ndarray, shape (k + 1,)
        Bin edges [µm].
    number : ndarray, shape (k,)
        Number per bin (:func:`number_per_bin`).
    values : str
        What the file's values were (a key of :data:`BIN_VALUES`).
    counted : bool
        True when `number` are counted particles (``count``/``dN`` with whole
        numbers): standard errors and the chi-squared test need counts.
    notes : tuple of str
        What was derived and assumed (edges from midpoints, the d³ conversion).
    diameter : {None, 'aerodynamic', 'mobility'}
        The diameter the instrument measures, where its export says
        (``Aerodynamic Diameter`` of an APS: never converted to an aerodynamic
        diameter again); None: not stated (taken as geometric).
    """

    edges_um: np.ndarray
    number: np.ndarray
    values: str = "count"
    counted: bool = True
    notes: tuple = field(default_factory=tuple)
    diameter: str | None = None

    @property
    def midpoints_um(self) -> np.ndarray:
        """Geometric midpoints ``sqrt(b_i b_{i+1})`` [µm]."""
        return np.sqrt(self.edges_um[:-1] * self.edges_um[1:])

    @property
    def total(self) -> float:
        """Sum of `number`."""
        return float(self.number.sum())

    def histogram(self) -> SizeDistribution:
        """The bins as a population (:func:`~.distributions.histogram_diameters`)."""
        return histogram_diameters(self.edges_um, self.number)


# -- the binned likelihood ------------------------------------------------------
def _log_interval(za, zb):
    """log(Φ(zb) - Φ(za)) for za < zb, accurate in both tails."""
    # deferred: scipy loads only when a binned fit runs (it took 0.7 s
    # of every command that reads a scenario, before any check)
    from scipy import special

    za, zb = np.asarray(za, float), np.asarray(zb, float)
    upper = za > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        lo_side = special.log_ndtr(zb) + np.log1p(
            -np.exp(special.log_ndtr(za) - special.log_ndtr(zb))
        )
        hi_side = special.log_ndtr(-za) + np.log1p(
            -np.exp(special.log_ndtr(-zb) - special.log_ndtr(-za))
        )
    return np.where(upper, hi_side, lo_side)


def _log_probs(x_edges, loc, scale):
    """Log bin probabilities of N(loc, scale) truncated to [x_0, x_k]."""
    z = (x_edges - loc) / scale
    log_p = _log_interval(z[:-1], z[1:])
    log_total = _log_interval(z[0], z[-1])
    return log_p - log_total


def _neg_ll(theta, x_edges, n):
    loc, log_scale = theta
    log_p = _log_probs(x_edges, loc, math.exp(log_scale))
    used = n > 0
    val = -float(np.sum(n[used] * log_p[used]))
    return val if np.isfinite(val) else 1e300


def _hessian(f, theta, steps):
    """Central-difference Hessian of f at theta."""
    k = len(theta)
    h = np.zeros((k, k))
    for i in range(k):
        for j in range(i, k):
            ei = np.eye(k)[i] * steps[i]
            ej = np.eye(k)[j] * steps[j]
            h[i, j] = h[j, i] = (
                f(theta + ei + ej)
                - f(theta + ei - ej)
                - f(theta - ei + ej)
                + f(theta - ei - ej)
            ) / (4 * steps[i] * steps[j])
    return h


def _fit(x_edges, n):
    """ML (loc, scale) of a normal in x from bin counts; covariance of
    (loc, log scale) from the observed information (None if singular); whether
    the location is at its floor.

    The location is kept above ``x_0 - RANGE_FLOOR * scale`` (searched as
    ``loc = x_0 - RANGE_FLOOR * scale + exp(u)``)."""
    # deferred: scipy loads only when a binned fit runs (it took 0.7 s
    # of every command that reads a scenario, before any check)
    from scipy import optimize

    floor = RANGE_FLOOR
    mids = 0.5 * (x_edges[:-1] + x_edges[1:])
    w = n / n.sum()
    loc0 = float(np.sum(w * mids))
    scale0 = float(np.sqrt(np.sum(w * (mids - loc0) ** 2)))
    scale0 = max(scale0, 0.5 * float(np.min(np.diff(x_edges))))

    x0 = float(x_edges[0])

    def to_theta(q):
        return np.array([x0 - floor * math.exp(q[1]) + math.exp(q[0]), q[1]])

    q0 = np.array([math.log(loc0 - x0 + floor * scale0), math.log(scale0)])
    options = {"xatol": 1e-9, "fatol": 1e-10 * float(n.sum()), "maxiter": 4000}
    for _ in range(3):  # restarts refresh a collapsed simplex
        res = optimize.minimize(
            lambda q: _neg_ll(to_theta(q), x_edges, n),
            q0,
            method="Nelder-Mead",
            options=options,
        )
        if res.success:
            break
        q0 = res.x
    stuck = None if res.success else str(res.message).rstrip(".")
    theta = to_theta(res.x)
    scale = math.exp(theta[1])
    hess = _hessian(
        lambda t: _neg_ll(t, x_edges, n), theta, np.array([1e-4 * scale, 1e-4])
    )
    try:
        cov = np.linalg.inv(hess)
        if not np.all(np.diag(cov) > 0):
            cov = None
    except np.linalg.LinAlgError:
        cov = None
    at_floor = bool(math.exp(res.x[0]) < 1e-3 * scale)
    return float(theta[0]), scale, cov, -float(res.fun), at_floor, stuck


def _stuck_note(kind, stuck) -> tuple:
    if stuck is None:
        return ()
    return (
        f"the {kind} fit diverges (the optimiser did not converge: {stuck}): the "
        "bins have no such shape, and its parameters are not estimates",
    )


def _fit_iv(edges_um, counts):
    e = _edges_iv(edges_um)
    n = _counts_iv(counts, e.size - 1)
    if np.count_nonzero(n) < 2:
        raise ValueError(
            "the distribution has particles in fewer than 2 bins; a two-parameter "
            "fit needs at least 2 occupied bins (use a monodisperse population)."
        )
    return e, n


def _population(kind, dist, params) -> SizeDistribution:
    """The fitted population (truncated to d >= 0), built without the factories'
    warnings and plausibility checks: a fit is not a user's typo, and a fit held
    at its bound says so in its notes."""
    return SizeDistribution(kind, dist=dist, lower=0.0, upper=math.inf, params=params)


def _floor_note(kind, where, at_floor) -> tuple:
    if not at_floor:
        return ()
    return (
        f"the {kind} fit is held at its bound ({where} {RANGE_FLOOR:g} scales below "
        "the lowest edge): the bins look like the tail of a population whose bulk "
        "lies below the instrument's range, and its parameters are not estimates",
    )


def fit_binned_normal(edges_um, counts) -> FitResult:
    """Maximum-likelihood Gaussian fit to binned counts (the binned likelihood of
    the module notes, ``F`` the normal CDF of ``d``).

    Parameters
    ----------
    edges_um : array_like, shape (k + 1,)
        Bin edges [µm].
    counts : array_like, shape (k,)
        Number per bin (counts, or concentrations: the estimates are the same, the
        standard errors assume counts).

    Returns
    -------
    FitResult
        ``params`` ``mean_um``/``std_um`` of the untruncated Gaussian; ``n`` the
        rounded total; ``log_likelihood`` the binned one.

    Notes
    -----
    The mean is kept above ``b_0 - RANGE_FLOOR * std``: bins that fall off like
    the tail of a population whose bulk is below the range would otherwise send
    it to minus infinity. A fit held there says so in ``notes``.
    """
    # deferred: scipy loads only when a binned fit runs (it took 0.7 s
    # of every command that reads a scenario, before any check)
    from scipy import stats

    e, n = _fit_iv(edges_um, counts)
    mu, sigma, cov, ll, at_floor, stuck = _fit(e, n)
    se = (math.nan, math.nan)
    if cov is not None:
        se = (math.sqrt(cov[0, 0]), sigma * math.sqrt(cov[1, 1]))
    mu_sd = {"mean_um": mu, "std_um": sigma, "min_um": None, "max_um": None}
    return FitResult(
        distribution=_population("normal", stats.norm(mu * 1e-6, sigma * 1e-6), mu_sd),
        params={"mean_um": mu, "std_um": sigma},
        stderr={"mean_um": se[0], "std_um": se[1]},
        n=round(float(n.sum())),
        log_likelihood=ll,
        notes=_floor_note("normal", "mean", at_floor) + _stuck_note("normal", stuck),
    )


def fit_binned_lognormal(edges_um, counts) -> FitResult:
    """Maximum-likelihood log-normal fit to binned counts (``F`` the normal CDF of
    ``ln d``): the count median diameter and geometric standard deviation.

    Parameters and returns as :func:`fit_binned_normal`, with ``params``
    ``median_um``/``geometric_std``.
    """
    # deferred: scipy loads only when a binned fit runs (it took 0.7 s
    # of every command that reads a scenario, before any check)
    from scipy import stats

    e, n = _fit_iv(edges_um, counts)
    mu, s, cov, ll, at_floor, stuck = _fit(np.log(e), n)
    notes = _floor_note("log-normal", "median", at_floor)
    notes += _stuck_note("log-normal", stuck)
    if abs(mu) > _LOG_HUGE or s > _LOG_GSD_HUGE:  # no log-normal shape in the bins
        notes += (
            f"the log-normal fit diverges (GSD beyond {math.exp(_LOG_GSD_HUGE):g} or "
            "median beyond 1e300 um; shown clipped there): the bins have no "
            "log-normal shape (they rise to the top of the range, or are split in "
            "separate modes), and its parameters are not estimates",
        )
        mu = min(max(mu, -_LOG_HUGE), _LOG_HUGE)
        s, cov = min(s, _LOG_GSD_HUGE), None
    median, gsd = math.exp(mu), math.exp(s)
    se = (math.nan, math.nan)
    if cov is not None:  # delta method: d median = median d mu, d gsd = gsd s d(ln s)
        se = (median * math.sqrt(cov[0, 0]), gsd * s * math.sqrt(cov[1, 1]))
    med_gsd = {
        "median_um": median,
        "geometric_std": gsd,
        "min_um": None,
        "max_um": None,
    }
    return FitResult(
        distribution=_population(
            "lognormal", stats.lognorm(s, scale=median * 1e-6), med_gsd
        ),
        params={"median_um": median, "geometric_std": gsd},
        stderr={"median_um": se[0], "geometric_std": se[1]},
        n=round(float(n.sum())),
        log_likelihood=ll,
        notes=notes,
    )


# -- chi-squared on the bins --------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Chi2BinnedResult:
    """Result of :func:`chi2_binned`.

    Attributes
    ----------
    statistic, dof, pvalue, reject, alpha
        As :class:`~.distributions.Chi2NormalityResult`; ``dof = bins - 1 - 2``
        after merging.
    edges_um : ndarray
        Edges of the merged bins [µm].
    observed, expected : ndarray
        Counts per merged bin and the fit's expected counts (summing to the total).
    n_bins_initial : int
        Number of bins before merging.
    """

    statistic: float
    dof: int
    pvalue: float
    reject: bool
    alpha: float
    edges_um: np.ndarray
    observed: np.ndarray
    expected: np.ndarray
    n_bins_initial: int


def chi2_binned(edges_um, counts, fit, *, alpha=0.05) -> Chi2BinnedResult:
    """Chi-squared goodness of fit of binned counts to a fitted distribution.

    Parameters
    ----------
    edges_um : array_like, shape (k + 1,)
        Bin edges [µm].
    counts : array_like, shape (k,)
        Counted particles per bin.
    fit : FitResult or SizeDistribution
        The fit (of :func:`fit_binned_normal`/:func:`fit_binned_lognormal`); its
        probabilities are conditioned on the range ``[b_0, b_k]``.
    alpha : float
        Significance level in (0, 1).

    Returns
    -------
    Chi2BinnedResult

    Raises
    ------
    ValueError
        Fewer than 4 bins ("too few bins"), or fewer than 4 bins with expected
        count >= 5 remain after merging ("too few particles").
    """
    # deferred: scipy loads only when a binned fit runs (it took 0.7 s
    # of every command that reads a scenario, before any check)
    from scipy import stats

    e = _edges_iv(edges_um)
    n = _counts_iv(counts, e.size - 1)
    alpha = check_scalar(alpha, "alpha", minimum=0, strict=True)
    if not alpha < 1:
        raise ValueError(f"`alpha` must be in (0, 1); got {alpha!r}.")
    dist = getattr(fit, "distribution", fit)
    cdf = np.asarray(dist.cdf(e * 1e-6), float)
    total = float(n.sum())
    if n.size - 1 - _N_PARAMS >= 1 and not cdf[-1] - cdf[0] > 0:
        # a diverged fit with no probability on the bins' range: the counts
        # contradict it with certainty (no expected counts to merge or divide by)
        dof = n.size - 1 - _N_PARAMS
        return Chi2BinnedResult(
            statistic=math.inf,
            dof=int(dof),
            pvalue=0.0,
            reject=True,
            alpha=alpha,
            edges_um=e,
            observed=n.astype(float),
            expected=np.zeros(n.size),
            n_bins_initial=int(n.size),
        )
    p = np.diff(cdf) / (cdf[-1] - cdf[0])
    edges, observed, expected = _merge(e, n, total * p)
    dof = expected.size - 1 - _N_PARAMS
    if n.size - 1 - _N_PARAMS < 1:
        raise ValueError(
            f"too few bins for the chi-squared test on the bins: {n.size} bins leave "
            f"{n.size - 1 - _N_PARAMS} degrees of freedom (bins - 1 - 2 fitted "
            "parameters); need at least 4 bins"
        )
    if dof < 1:
        raise ValueError(
            f"too few particles for the chi-squared test on the bins: {total:g} "
            f"leave {expected.size} bins with expected count >= {MIN_EXPECTED:g}; "
            "need at least 4."
        )
    statistic = float(np.sum((observed - expected) ** 2 / expected))
    pvalue = float(stats.chi2.sf(statistic, dof))
    return Chi2BinnedResult(
        statistic=statistic,
        dof=int(dof),
        pvalue=pvalue,
        reject=bool(pvalue < alpha),
        alpha=alpha,
        edges_um=edges,
        observed=observed,
        expected=expected,
        n_bins_initial=int(n.size),
    )


def binned_median(edges_um, weights) -> float:
    """Median diameter [µm] of a binned distribution, interpolated in ``log d``
    within the bin that holds it (the bin's weight spread uniformly in ``log d``).

    With ``weights = number`` it is the count median diameter; with
    ``number * d_i^3`` the mass median diameter.
    """
    e = _edges_iv(edges_um)
    w = _counts_iv(weights, e.size - 1)
    cum = np.concatenate([[0.0], np.cumsum(w)]) / w.sum()
    i = int(np.searchsorted(cum, 0.5, side="left")) - 1
    i = min(max(i, 0), w.size - 1)
    frac = (0.5 - cum[i]) / (cum[i + 1] - cum[i])
    return float(math.exp(math.log(e[i]) + frac * math.log(e[i + 1] / e[i])))
