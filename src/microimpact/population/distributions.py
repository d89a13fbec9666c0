"""Particle size distributions: the diameter population of a Monte Carlo run.

A :class:`SizeDistribution` is a distribution of particle **diameter in metres**, a
thin wrapper over the package's one distribution core
(:mod:`microimpact._core.distributions`, shared with the roughness-angle distributions):
a SciPy frozen distribution (``norm``,
``lognorm``, ``uniform``, ``rv_histogram`` or one supplied by the user) truncated
through its CDF, or, for the discrete kinds (``empirical``, ``monodisperse``), the
sorted atoms themselves. Its vectorised :meth:`~SizeDistribution.ppf` and
:meth:`~SizeDistribution.isf` (``ppf(1 - q)``, accurate in the upper tail) are what
the Monte Carlo engine tabulates; a discrete kind is sampled from its
:attr:`~SizeDistribution.atoms` and :attr:`~SizeDistribution.weights`.

The paper [1]_ lets the diameter be normal, log-normal, uniform or empirical (a Phase
Doppler sample) and chooses between Gaussian and empirical with a chi-squared test;
:func:`chi2_normality` implements that test.

Truncation (see ``docs/populations.md``): every distribution is restricted to
``lower <= d <= upper`` with ``lower >= 0`` plus any user limits, through the CDF,
``F_t^{-1}(q) = F^{-1}(F(a) + q [F(b) - F(a)])`` (via ``sf``/``isf`` in an upper tail);
the cut probability is ``truncated_mass``. Cutting more than
:data:`CUT_WARN_THRESHOLD` warns (``UserWarning``); cutting everything raises
``ValueError``. The normal kind is ``scipy.stats.norm`` truncated this way (the
truncated normal, as ``scipy.stats.truncnorm``, with an accurate upper tail).

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, "Monte Carlo Analysis of Polydisperse
   Microparticle Impacts with Surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
.. [2] J. R. Taylor, *An Introduction to Error Analysis*, University Science Books,
   1982, ch. 12 (the chi-squared test for a distribution).
.. [3] H. A. Sturges, "The Choice of a Class Interval," *J. Am. Stat. Assoc.*
   21:65-66, 1926.
"""

from __future__ import annotations

import math
import numbers
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from .._core.distributions import CoreMethods, DiscreteAtoms, TruncatedContinuous
from .._core.validation import as_float_array, check_choice, check_scalar
from ..units import length_factor, m_to_um, um_to_m

#: The distribution kinds.
KINDS = (
    "normal",
    "lognormal",
    "uniform",
    "empirical",
    "histogram",
    "monodisperse",
    "scipy",
)
#: Truncating away more than this probability issues a ``UserWarning``.
CUT_WARN_THRESHOLD = 1e-3
#: Minimum expected count per class in :func:`chi2_normality` ([2], ch. 12).
MIN_EXPECTED = 5.0

_WIDEN = "; widen `min_um`/`max_um`"


@dataclass(frozen=True, eq=False)
class SizeDistribution(CoreMethods):
    """A distribution of particle diameter [m].

    Build it with a factory (:func:`normal_diameters`, :func:`lognormal_diameters`,
    :func:`uniform_diameters`, :func:`monodisperse`, :func:`empirical_diameters`,
    :func:`histogram_diameters`, :func:`scipy_diameters`), not directly.

    The methods (``ppf``, ``isf``, ``cdf``, ``sf``, ``pdf``, ``rvs``, ``mean``,
    ``std``, ``median``, ``support``, ``table``) take and return diameters in metres;
    they are those of :class:`microimpact._core.distributions.CoreMethods`, shared with
    :class:`~microimpact.surface.angles.AngleDistribution`.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    dist : scipy.stats frozen distribution or rv_histogram, or None
        The untruncated continuous distribution of diameter [m]; ``None`` for the
        discrete kinds.
    atoms : ndarray or None
        Sorted atoms [m] of a discrete kind (the kept measured diameters of an
        empirical sample; the single diameter of a monodisperse population), each
        with probability ``1/n``; ``None`` for the continuous kinds.
    weights : ndarray or None
        Probabilities of `atoms` (``1/n`` each); ``None`` for the continuous kinds.
    is_discrete : bool
        True for the empirical and monodisperse kinds.
    lower, upper : float
        Truncation limits [m] applied to `dist` through its CDF.
    truncated_mass : float
        Probability cut away by truncation (0.0 if none); by default the cut of
        `dist` on ``[lower, upper]``.
    params : dict
        The defining parameters in interface units (``mean_um``, ...), for provenance.

    Notes
    -----
    The discrete kinds have no density: :meth:`pdf` returns ``inf`` at the atoms (a
    Dirac delta) and 0 elsewhere.
    """

    kind: str
    dist: object = None
    atoms: np.ndarray | None = None
    lower: float = 0.0
    upper: float = math.inf
    truncated_mass: float | None = None
    params: dict = field(default_factory=dict)

    def __post_init__(self):
        check_choice(self.kind, "kind", KINDS)
        if (self.dist is None) == (self.atoms is None):
            raise ValueError("give exactly one of `dist` and `atoms`.")
        if self.atoms is not None:
            core = DiscreteAtoms(self.atoms)
            a = core.atoms
            if not np.all(a > 0):
                raise ValueError("`atoms` must be a non-empty array of finite d > 0.")
            object.__setattr__(self, "atoms", a)
        else:
            core = TruncatedContinuous(
                self.dist,
                self.lower,
                self.upper,
                what=_what(self.kind, self.params),
                where=_where(self.lower, self.upper),
                hint=_WIDEN,
            )
        object.__setattr__(self, "_core", core)
        if self.truncated_mass is None:
            object.__setattr__(self, "truncated_mass", float(core.truncated_mass))

    def describe(self) -> dict:
        """Summary in interface units (µm) for reports and provenance."""
        return self._describe(m_to_um, "um")

    def __repr__(self) -> str:
        shown = ", ".join(
            f"{k}={v:.6g}" if isinstance(v, float) else f"{k}={v!r}"
            for k, v in self.params.items()
            if isinstance(v, numbers.Number | str)
        )
        return (
            f"SizeDistribution(kind={self.kind!r}, {shown}, "
            f"truncated_mass={self.truncated_mass:.3g})"
        )


# -- validation helpers ----------------------------------------------------------------
def _limits_iv(min_um, max_um) -> tuple[float, float]:
    """User limits [µm] -> (lower, upper) [m]; diameters are always > 0."""
    lo = 0.0 if min_um is None else check_scalar(min_um, "min_um", minimum=0)
    hi = (
        math.inf
        if max_um is None
        else check_scalar(max_um, "max_um", minimum=0, strict=True, allow_inf=True)
    )
    if not hi > lo:
        raise ValueError(
            f"`max_um` must be > `min_um`; got min_um={min_um!r}, max_um={max_um!r}."
        )
    return float(um_to_m(lo)), float(um_to_m(hi))


def _diameters_iv(diameters_um, name="diameters_um", *, minimum=1) -> np.ndarray:
    """Measured diameters [µm] as a 1-d float array of finite values > 0."""
    x = as_float_array(diameters_um, name).ravel()
    if x.size < minimum:
        raise ValueError(f"`{name}` needs at least {minimum} values; got {x.size}.")
    bad = ~(np.isfinite(x) & (x > 0))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"`{name}` must contain finite diameters > 0; "
            f"got {float(x[i])!r} at index {i}."
        )
    return x


def _warn_cut(mass: float, where: str, stacklevel: int) -> None:
    if mass > CUT_WARN_THRESHOLD:
        warnings.warn(
            f"truncation to {where} cuts away {mass:.3g} of the probability "
            f"(more than {CUT_WARN_THRESHOLD:g}); the sampled population is the "
            "truncated one.",
            UserWarning,
            stacklevel=stacklevel + 1,
        )


def _where(lower, upper) -> str:
    return f"[{m_to_um(lower):g}, {m_to_um(upper):g}] um"


def _what(kind, params) -> str:
    """The distribution as named when truncation cuts away everything: ``N(mean um,
    std um)`` for a normal one with its parameters, else ``the {kind} distribution``."""
    mean, std = params.get("mean_um"), params.get("std_um")
    if kind == "normal" and all(isinstance(v, numbers.Real) for v in (mean, std)):
        return f"N({mean:g} um, {std:g} um)"
    return f"the {kind} distribution"


def _continuous(kind, dist, lower, upper, params, stacklevel) -> SizeDistribution:
    """Truncate `dist` [m] to [lower, upper] through its CDF, report the cut."""
    out = SizeDistribution(kind, dist=dist, lower=lower, upper=upper, params=params)
    _warn_cut(out.truncated_mass, _where(lower, upper), stacklevel + 1)
    return out


# -- factories -------------------------------------------------------------------------
#: Plausible particle diameters [µm]: 10 nm to 10 mm. A location parameter (mean,
#: median, single diameter, largest bin edge, median of measurements) outside is
#: refused as a probable unit mistake (metres or millimetres typed as µm).
PLAUSIBLE_DIAMETER_UM = (0.01, 10_000.0)


def _plausible_um(value_um: float, name: str, what: str = "") -> None:
    """ValueError naming `name` if `value_um` is not a plausible diameter [µm]."""
    lo, hi = PLAUSIBLE_DIAMETER_UM
    if lo <= value_um <= hi:
        return
    if value_um < lo:
        guess = (
            f"was it given in metres? {value_um:g} m is {value_um * 1e6:g} um"
            if value_um < 1e-3
            else f"was it given in millimetres? {value_um:g} mm is "
            f"{value_um * 1e3:g} um"
        )
        side = "below 10 nm (0.01 um)"
    else:
        guess = f"was it given in nanometres? {value_um:g} nm is {value_um / 1e3:g} um"
        side = "above 10 mm (10000 um)"
    raise ValueError(
        f"`{name}` = {value_um:g}{what} is {side}, not a particle diameter; {guess}; "
        f"diameters are in micrometres here (allowed: {lo:g} to {hi:g} um)."
    )


def _normal(mean_um, std_um, min_um, max_um, stacklevel) -> SizeDistribution:
    mean_um = check_scalar(mean_um, "mean_um")
    std_um = check_scalar(std_um, "std_um", minimum=0, strict=True)
    if mean_um > 0:  # a mean <= 0 is the truncation's business (its own message)
        _plausible_um(mean_um, "mean_um")
    lower, upper = _limits_iv(min_um, max_um)
    dist = stats.norm(loc=float(um_to_m(mean_um)), scale=float(um_to_m(std_um)))
    params = {"mean_um": mean_um, "std_um": std_um, "min_um": min_um, "max_um": max_um}
    return _continuous("normal", dist, lower, upper, params, stacklevel + 1)


def normal_diameters(mean_um, std_um, *, min_um=None, max_um=None) -> SizeDistribution:
    """Gaussian diameters, truncated to ``max(min_um, 0) <= d <= max_um``.

    Parameters
    ----------
    mean_um, std_um : float
        Mean and standard deviation [µm] of the untruncated Gaussian (the paper's
        SST65 fit is 52.8 and 15.3 µm [1]_).
    min_um, max_um : float, optional
        Truncation limits [µm]; diameters are always > 0.

    Returns
    -------
    SizeDistribution
        ``dist`` is ``scipy.stats.norm(loc=mean, scale=std)`` (SI), truncated to
        ``[lower, upper]`` through its CDF: the distribution of
        ``scipy.stats.truncnorm(a, b, loc=mean, scale=std)`` with
        ``a = (lower - mean)/std``, ``b = (upper - mean)/std``, with an accurate
        :meth:`~SizeDistribution.isf`. ``mean()`` is the truncated mean; ``params``
        keeps the given values.

    Warns
    -----
    UserWarning
        If more than :data:`CUT_WARN_THRESHOLD` of the probability is cut away.
    """
    return _normal(mean_um, std_um, min_um, max_um, stacklevel=2)


def lognormal_diameters(
    median_um, geometric_std, *, min_um=None, max_um=None
) -> SizeDistribution:
    """Log-normal diameters: ``ln d ~ N(ln median, ln geometric_std)``.

    Parameters
    ----------
    median_um : float
        Median (count median diameter) [µm], SciPy's ``scale``.
    geometric_std : float
        Geometric standard deviation [-], > 1; SciPy's ``s = ln(geometric_std)``.
    min_um, max_um : float, optional
        Truncation limits [µm], applied through the CDF (see module notes).
    """
    median_um = check_scalar(median_um, "median_um", minimum=0, strict=True)
    _plausible_um(median_um, "median_um")
    gsd = check_scalar(geometric_std, "geometric_std", minimum=0, strict=True)
    if not gsd > 1:
        raise ValueError(
            f"`geometric_std` must be > 1; got {geometric_std!r} "
            "(for a single diameter use `monodisperse`)."
        )
    lower, upper = _limits_iv(min_um, max_um)
    dist = stats.lognorm(math.log(gsd), scale=float(um_to_m(median_um)))
    params = {
        "median_um": median_um,
        "geometric_std": gsd,
        "min_um": min_um,
        "max_um": max_um,
    }
    return _continuous("lognormal", dist, lower, upper, params, stacklevel=2)


def uniform_diameters(min_um, max_um) -> SizeDistribution:
    """Diameters uniform on ``[min_um, max_um]`` [µm] (``scipy.stats.uniform``)."""
    lo = check_scalar(min_um, "min_um", minimum=0)
    hi = check_scalar(max_um, "max_um", minimum=0, strict=True)
    _plausible_um(hi, "max_um")
    if not hi > lo:
        raise ValueError(
            f"`max_um` must be > `min_um`; got min_um={min_um!r}, max_um={max_um!r}."
        )
    lower, upper = float(um_to_m(lo)), float(um_to_m(hi))
    dist = stats.uniform(loc=lower, scale=upper - lower)
    params = {"min_um": lo, "max_um": hi}
    return _continuous("uniform", dist, 0.0, math.inf, params, stacklevel=2)


def monodisperse(diameter_um) -> SizeDistribution:
    """A single diameter [µm]: the degenerate distribution (``ppf`` is constant)."""
    d = check_scalar(diameter_um, "diameter_um", minimum=0, strict=True)
    _plausible_um(d, "diameter_um")
    return SizeDistribution(
        "monodisperse", atoms=np.array([um_to_m(d)]), params={"diameter_um": d}
    )


def empirical_diameters(diameters_um, *, min_um=None, max_um=None) -> SizeDistribution:
    """The discrete empirical distribution of measured diameters (e.g. a PDPA export).

    Each kept measurement has probability ``1/n``; nothing is smoothed, and the
    quantile table's atoms are the measured values.

    Parameters
    ----------
    diameters_um : array_like
        Measured diameters [µm], finite and > 0.
    min_um, max_um : float, optional
        Keep only ``min_um <= d <= max_um``; the dropped fraction is
        ``truncated_mass``.
    """
    x = _diameters_iv(diameters_um)
    _plausible_um(float(np.median(x)), "diameters_um", " (their median)")
    lower, upper = _limits_iv(min_um, max_um)
    d = um_to_m(x)
    keep = (d >= lower) & (d <= upper)
    n_kept = int(keep.sum())
    if n_kept == 0:
        raise ValueError(
            f"no measured diameter lies in {_where(lower, upper)}; "
            "widen `min_um`/`max_um`."
        )
    cut = 1.0 - n_kept / x.size
    params = {"n": int(x.size), "n_kept": n_kept, "min_um": min_um, "max_um": max_um}
    out = SizeDistribution(
        "empirical", atoms=d[keep], params=params, truncated_mass=cut
    )
    _warn_cut(cut, _where(lower, upper), stacklevel=2)
    return out


def histogram_diameters(edges_um, counts) -> SizeDistribution:
    """Diameters from a histogram: ``scipy.stats.rv_histogram`` with density=False.

    Parameters
    ----------
    edges_um : array_like, shape (k + 1,)
        Strictly increasing bin edges [µm], >= 0.
    counts : array_like, shape (k,)
        Counts or relative frequencies per bin, >= 0, not all zero. Within a bin the
        diameter is uniform.
    """
    e = as_float_array(edges_um, "edges_um").ravel()
    c = as_float_array(counts, "counts").ravel()
    if e.size < 2 or not np.all(np.isfinite(e)) or np.any(e < 0):
        raise ValueError(
            f"`edges_um` must hold at least 2 finite edges >= 0; got {edges_um!r}."
        )
    if np.any(np.diff(e) <= 0):
        i = int(np.flatnonzero(np.diff(e) <= 0)[0])
        raise ValueError(
            f"`edges_um` must be strictly increasing; got {e[i]!r} then {e[i + 1]!r} "
            f"at index {i}."
        )
    if c.size != e.size - 1:
        raise ValueError(
            f"`counts` needs len(edges_um) - 1 = {e.size - 1} values; got {c.size}."
        )
    if not np.all(np.isfinite(c)) or np.any(c < 0) or not c.sum() > 0:
        raise ValueError(
            f"`counts` must be finite, >= 0 and not all 0; got {counts!r}."
        )
    dist = stats.rv_histogram((c, um_to_m(e)), density=False)
    params = {"edges_um": e.tolist(), "counts": c.tolist()}
    return _continuous("histogram", dist, 0.0, math.inf, params, stacklevel=2)


def scipy_diameters(frozen_dist, *, unit="um") -> SizeDistribution:
    """Wrap a user's continuous SciPy distribution of diameter in `unit`.

    Parameters
    ----------
    frozen_dist : scipy.stats frozen continuous distribution or rv_histogram
        E.g. ``scipy.stats.gamma(4, scale=12)`` for diameters in µm.
    unit : str
        Length unit of `frozen_dist` (see :data:`microimpact.units.LENGTH_UNITS`).

    Notes
    -----
    The distribution is rebuilt in metres by scaling ``loc`` and ``scale``, then
    truncated to d > 0 (``scipy.stats.norm`` puts some mass below zero).
    """
    factor = length_factor(unit)
    if isinstance(frozen_dist, stats.rv_continuous) and frozen_dist.numargs == 0:
        gen, args, kwds = frozen_dist, (), {}
    elif isinstance(getattr(frozen_dist, "dist", None), stats.rv_continuous):
        gen, args, kwds = frozen_dist.dist, frozen_dist.args, dict(frozen_dist.kwds)
    else:
        raise TypeError(
            "`frozen_dist` must be a frozen continuous scipy.stats distribution "
            f"(e.g. scipy.stats.gamma(4, scale=12)); got {frozen_dist!r}. For measured "
            "diameters use `empirical_diameters`."
        )
    shapes, rest = args[: gen.numargs], args[gen.numargs :]
    loc = rest[0] if len(rest) > 0 else kwds.pop("loc", 0.0)
    scale = rest[1] if len(rest) > 1 else kwds.pop("scale", 1.0)
    kwds.pop("loc", None), kwds.pop("scale", None)
    dist = gen(*shapes, **kwds, loc=loc * factor, scale=scale * factor)
    params = {
        "name": gen.name,
        "args": list(args),
        "kwds": dict(getattr(frozen_dist, "kwds", {})),
        "unit": unit,
    }
    return _continuous("scipy", dist, 0.0, math.inf, params, stacklevel=2)


# -- fits ------------------------------------------------------------------------------
@dataclass(frozen=True)
class FitResult:
    """A maximum-likelihood fit of a diameter sample.

    Attributes
    ----------
    distribution : SizeDistribution
        The fitted population.
    params : dict
        Fitted parameters in interface units (``mean_um``/``std_um`` or
        ``median_um``/``geometric_std``).
    stderr : dict
        Asymptotic standard errors of `params` (inverse Fisher information, delta
        method for derived parameters), same keys.
    n : int
        Sample size.
    log_likelihood : float
        Log-likelihood of the sample with densities in µm⁻¹ (of the bins, for
        the binned fits).
    notes : tuple of str
        Caveats of the fit (e.g. a binned fit held at a bound).
    """

    distribution: SizeDistribution
    params: dict
    stderr: dict
    n: int
    log_likelihood: float
    notes: tuple = ()


def fit_normal(diameters_um) -> FitResult:
    """Maximum-likelihood Gaussian fit (``scipy.stats.norm.fit``).

    The estimates are the sample mean and the ddof=0 standard deviation; their
    standard errors are ``std/sqrt(n)`` and ``std/sqrt(2n)``.
    """
    x = _diameters_iv(diameters_um, minimum=2)
    mu, sigma = stats.norm.fit(x)
    if np.ptp(x) == 0:
        raise ValueError(
            "`diameters_um` are all equal; cannot fit a Gaussian (use `monodisperse`)."
        )
    n = x.size
    return FitResult(
        distribution=_normal(mu, sigma, None, None, stacklevel=2),
        params={"mean_um": float(mu), "std_um": float(sigma)},
        stderr={
            "mean_um": float(sigma / math.sqrt(n)),
            "std_um": float(sigma / math.sqrt(2 * n)),
        },
        n=n,
        log_likelihood=float(stats.norm.logpdf(x, mu, sigma).sum()),
    )


def fit_lognormal(diameters_um) -> FitResult:
    """Maximum-likelihood log-normal fit (``scipy.stats.lognorm.fit``, ``floc=0``).

    With ``s = std(ln d)`` (ddof=0), ``median = exp(mean(ln d))`` and
    ``geometric_std = exp(s)``, the standard errors (delta method) are
    ``median s/sqrt(n)`` and ``geometric_std s/sqrt(2n)``.
    """
    x = _diameters_iv(diameters_um, minimum=2)
    s, _, scale = stats.lognorm.fit(x, floc=0)
    if np.ptp(x) == 0:
        raise ValueError(
            "`diameters_um` are all equal; cannot fit a log-normal (use "
            "`monodisperse`)."
        )
    n = x.size
    gsd = math.exp(s)
    return FitResult(
        distribution=lognormal_diameters(scale, gsd),
        params={"median_um": float(scale), "geometric_std": gsd},
        stderr={
            "median_um": float(scale * s / math.sqrt(n)),
            "geometric_std": float(gsd * s / math.sqrt(2 * n)),
        },
        n=n,
        log_likelihood=float(stats.lognorm.logpdf(x, s, scale=scale).sum()),
    )


# -- the chi-squared test of the paper ---------------------------------------------
@dataclass(frozen=True, eq=False)
class Chi2NormalityResult:
    """Result of :func:`chi2_normality`.

    Attributes
    ----------
    statistic : float
        ``sum((observed - expected)**2 / expected)`` over the merged classes.
    dof : int
        Degrees of freedom, ``classes - 1 - 2`` (mean and std were estimated).
    pvalue : float
        ``scipy.stats.chi2.sf(statistic, dof)``.
    reject : bool
        ``pvalue < alpha``: the Gaussian is rejected.
    alpha : float
        Significance level.
    edges_um : ndarray
        Class edges [µm] after merging; the first and last are ``-inf`` and ``inf``
        (open-ended tail classes).
    observed, expected : ndarray
        Observed counts (summing to n) and expected Gaussian counts per class.
    mean_um, std_um : float
        The fitted (maximum-likelihood) Gaussian [µm].
    decision : str
        ``"gaussian"`` (not rejected) or ``"empirical"`` (rejected), as in [1]_.
    n_classes_initial : int
        Number of classes from Sturges' rule, before merging.
    """

    statistic: float
    dof: int
    pvalue: float
    reject: bool
    alpha: float
    edges_um: np.ndarray
    observed: np.ndarray
    expected: np.ndarray
    mean_um: float
    std_um: float
    decision: str
    n_classes_initial: int


def _merge(edges, observed, expected):
    """Merge tail classes inward, then any class left below MIN_EXPECTED."""
    edges, observed, expected = list(edges), list(observed), list(expected)

    def join(i):  # merge class i with class i + 1
        del edges[i + 1]
        observed[i : i + 2] = [observed[i] + observed[i + 1]]
        expected[i : i + 2] = [expected[i] + expected[i + 1]]

    while len(expected) > 1 and expected[0] < MIN_EXPECTED:
        join(0)
    while len(expected) > 1 and expected[-1] < MIN_EXPECTED:
        join(len(expected) - 2)
    while len(expected) > 1 and min(expected) < MIN_EXPECTED:  # rare: interior class
        i = int(np.argmin(expected))
        if i == 0 or (i < len(expected) - 1 and expected[i + 1] < expected[i - 1]):
            join(i)
        else:
            join(i - 1)
    return np.array(edges), np.array(observed), np.array(expected)


def chi2_normality(
    diameters_um, *, alpha=0.05, classes="equal-width"
) -> Chi2NormalityResult:
    """Chi-squared test of a diameter sample against its fitted Gaussian ([1]_, [2]_).

    The paper uses this test to decide whether a measured diameter distribution is
    represented by a Gaussian or must be used as an empirical distribution.

    Procedure
    ---------
    1. Fit the Gaussian by maximum likelihood: sample mean and ddof=0 std.
    2. Number of classes by Sturges' rule [3]_: ``k = ceil(1 + log2 n)``.
    3. Classes: ``"equal-width"`` (default, the textbook procedure of [2]_) divides the
       data range ``[min, max]`` into `k` equal classes and makes the first and last
       open-ended (``-inf``, ``inf``), so the expected counts cover the whole Gaussian;
       ``"equiprobable"`` uses the fitted Gaussian's ``i/k`` quantiles as edges.
    4. Expected count per class ``n [Φ(z_hi) - Φ(z_lo)]``; observed counts of the data
       (class ``i`` is ``[e_i, e_{i+1})``).
    5. Merge the tail classes inward until every expected count is >= 5 (any interior
       class still below 5 is merged with its smaller neighbour).
    6. ``statistic = Σ (O - E)² / E``, ``dof = classes - 1 - 2``,
       ``pvalue = chi2.sf(statistic, dof)``; reject the Gaussian if ``pvalue < alpha``.

    Parameters
    ----------
    diameters_um : array_like
        Measured diameters [µm], finite and > 0.
    alpha : float
        Significance level, in (0, 1).
    classes : {"equal-width", "equiprobable"}
        How the classes are formed (step 3).

    Returns
    -------
    Chi2NormalityResult

    Raises
    ------
    ValueError
        If fewer than 4 classes remain after merging (dof < 1): too few data.

    Notes
    -----
    The mean and std are estimated from the raw data, not the grouped counts, so the
    statistic lies between chi2(k - 3) and chi2(k - 1) (Chernoff and Lehmann, 1954):
    the test is slightly liberal, as in the textbook procedure the paper follows.
    """
    x = _diameters_iv(diameters_um, minimum=2)
    alpha = check_scalar(alpha, "alpha", minimum=0, strict=True)
    if not alpha < 1:
        raise ValueError(f"`alpha` must be in (0, 1); got {alpha!r}.")
    check_choice(classes, "classes", ("equal-width", "equiprobable"))
    n = x.size
    mu, sigma = float(x.mean()), float(x.std())
    if not sigma > 0:
        raise ValueError("`diameters_um` are all equal; a Gaussian cannot be tested.")
    k = math.ceil(1 + math.log2(n))  # Sturges' rule [3]
    if classes == "equal-width":
        inner = np.linspace(x.min(), x.max(), k + 1)[1:-1]
    else:
        inner = mu + sigma * stats.norm.ppf(np.arange(1, k) / k)
    edges = np.concatenate([[-np.inf], inner, [np.inf]])
    cdf = stats.norm.cdf((edges - mu) / sigma)
    expected = n * np.diff(cdf)
    observed = np.bincount(np.searchsorted(inner, x, side="right"), minlength=k)
    edges, observed, expected = _merge(edges, observed, expected)
    dof = expected.size - 3
    if dof < 1:
        raise ValueError(
            f"too few diameters for the chi-squared test: n={n} leaves "
            f"{expected.size} classes with expected count >= {MIN_EXPECTED:g}; "
            "need at least 4 (about 30 or more diameters)."
        )
    statistic = float(np.sum((observed - expected) ** 2 / expected))
    pvalue = float(stats.chi2.sf(statistic, dof))
    reject = bool(pvalue < alpha)
    return Chi2NormalityResult(
        statistic=statistic,
        dof=int(dof),
        pvalue=pvalue,
        reject=reject,
        alpha=alpha,
        edges_um=edges,
        observed=observed.astype(np.int64),
        expected=expected,
        mean_um=mu,
        std_um=sigma,
        decision="empirical" if reject else "gaussian",
        n_classes_initial=k,
    )
