r"""The one distribution core behind the size and the angle distributions.

Two private classes, both in SI units (metres for diameters, radians for angles),
serve :class:`~microimpact.population.distributions.SizeDistribution` and
:class:`~microimpact.surface.angles.AngleDistribution`, which are thin wrappers
(kind, parameters in interface units, ``describe()``, unit conversion):

* :class:`TruncatedContinuous`: a frozen continuous ``scipy.stats`` distribution
  restricted to ``[lower, upper]`` (or the open interval) through its CDF and
  survival function;
* :class:`DiscreteAtoms`: sorted atoms with equal weights (a measured sample, a
  single value) or explicit weights.

Both offer the same vectorised protocol: ``ppf``, ``isf``, ``cdf``, ``sf``, ``pdf``,
``rvs``, ``mean``, ``std``, ``median``, ``support``, ``table`` and the attributes
``is_discrete``, ``atoms``, ``weights`` and ``truncated_mass``. :class:`CoreMethods`
gives a wrapper that protocol by delegating to its ``_core``.

Truncation
----------
With :math:`F`, :math:`S = 1 - F` the parent's CDF and survival function,
:math:`F_a = F(a)`, :math:`S_b = S(b)` and the kept probability :math:`K`,

.. math::

    F_t^{-1}(q) = F^{-1}(F_a + qK), \qquad
    S_t^{-1}(q) = S^{-1}(S_b + qK),

each evaluated from the side where its argument is small (through :math:`S^{-1}`
and :math:`F^{-1}` respectively when the kept interval lies in the parent's other
half), so that ``ppf`` is accurate for small ``q`` and ``isf`` for small ``q`` at
the other end: ``isf(q)`` is ``ppf(1 - q)`` without the rounding of ``1 - q``. The cut
probability is ``truncated_mass = F_a + S_b``. A distribution that loses nothing to
truncation (``F_a == S_b == 0``) is the parent itself: every method is SciPy's.

Discrete atoms
--------------
``ppf`` is the left-continuous inverse of the CDF, ``min{x : F(x) >= q}``, and
``isf(q) = min{x : S(x) <= q}``, computed from the upper tail sums; ``pdf`` is
``inf`` at the atoms (a Dirac delta) and 0 elsewhere; ``mean`` and ``std`` are exact
sums.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy import integrate

from .tables import TABLE_SIZE, QuantileTable
from .validation import as_float_array

#: The methods a continuous parent distribution must have (a frozen scipy.stats
#: distribution has them all).
CONTINUOUS_METHODS = ("cdf", "sf", "ppf", "isf", "pdf", "support", "rvs", "mean", "std")


def _probabilities(q):
    """`q` as a float array, the mask of values outside [0, 1] (NaN included), and
    `q` with those replaced by 0.5."""
    q = as_float_array(q, "q")
    bad = ~((q >= 0) & (q <= 1))
    return q, bad, np.where(bad, 0.5, q)


# ------------------------------------------------------------------- truncation
class Truncation(NamedTuple):
    """CDF and survival function of a parent distribution at the truncation limits."""

    fa: float  # F(lower)
    fb: float  # F(upper)
    sa: float  # S(lower)
    sb: float  # S(upper)
    kept: float  # probability kept, from the more accurate side
    upper_tail: bool  # F(lower) > 1/2: the kept interval lies in the upper half
    cut: float  # probability cut away, F(lower) + S(upper), in [0, 1]


def truncation(
    dist, lower, upper, *, what="the distribution", where=None, hint=""
) -> Truncation:
    """The one computation of the kept and the cut probability of `dist` on
    ``[lower, upper]``; ``ValueError`` if nothing is kept.

    `what` and `where` name the distribution and the interval in the message
    (``"truncating {what} to {where} cuts away all of the probability{hint}."``).
    """
    lo, hi = float(lower), float(upper)
    fa, fb = float(dist.cdf(lo)), float(dist.cdf(hi))
    sa, sb = float(dist.sf(lo)), float(dist.sf(hi))
    upper_tail = fa > 0.5
    kept = sa - sb if upper_tail else fb - fa
    if not kept > 0:
        where = f"[{lo:g}, {hi:g}]" if where is None else where
        raise ValueError(
            f"truncating {what} to {where} cuts away all of the probability{hint}."
        )
    cut = max(0.0, min(1.0, fa + sb))
    return Truncation(fa, fb, sa, sb, kept, upper_tail, cut)


class TruncatedContinuous:
    """A continuous distribution truncated to ``[lower, upper]`` through its CDF.

    Parameters
    ----------
    dist : frozen scipy.stats continuous distribution
        The parent distribution, in SI units; it needs :data:`CONTINUOUS_METHODS`.
    lower, upper : float
        Truncation limits (``-inf``/``inf`` for none), ``lower < upper``.
    open_interval : bool
        Restrict to the open interval ``(lower, upper)`` (the roughness angle on
        ``(-pi/2, pi/2)``): quantiles are clipped to the largest floats inside it and
        the density is 0 at the limits.
    what, where, hint : str
        Wording of the error raised when nothing is kept (see :func:`truncation`).

    Attributes
    ----------
    dist, lower, upper
        As given.
    truncated_mass : float
        Probability of the parent cut away, ``F(lower) + S(upper)``.
    kept : float
        Probability of the parent kept.
    """

    is_discrete = False
    atoms = None
    weights = None

    def __init__(
        self,
        dist,
        lower=-math.inf,
        upper=math.inf,
        *,
        open_interval=False,
        what="the distribution",
        where=None,
        hint="",
    ):
        lower, upper = float(lower), float(upper)
        if not lower < upper:
            raise ValueError(
                f"the truncation limits must satisfy lower < upper; got {lower!r} "
                f"and {upper!r}."
            )
        self.dist, self.lower, self.upper = dist, lower, upper
        self.open_interval = bool(open_interval)
        t = truncation(dist, lower, upper, what=what, where=where, hint=hint)
        self._t = t
        self.kept = t.kept
        self.truncated_mass = t.cut
        self._whole = t.fa == 0 and t.sb == 0  # nothing cut: the parent itself
        lo, hi = (float(v) for v in dist.support())
        lo, hi = max(lo, lower), min(hi, upper)
        if self.open_interval:
            lo = max(lo, math.nextafter(lower, math.inf))
            hi = min(hi, math.nextafter(upper, -math.inf))
        self._support = (lo, hi)
        self._moments = None

    # -- quantiles ---------------------------------------------------------------
    def _quantile(self, q, parent, kept):
        """``parent(q)`` when nothing is cut, else ``kept(q)``, clipped to the
        support; ``nan`` for `q` outside [0, 1]."""
        q, bad, qq = _probabilities(q)
        x = parent(qq) if self._whole else kept(qq)
        x = np.clip(x, *self._support)
        return np.where(bad, np.nan, x)[()]

    def ppf(self, q):
        """Quantile function; ``nan`` for `q` outside [0, 1].

        ``F^{-1}(F_a + qK)``, or ``S^{-1}(S_a - qK)`` when the kept interval lies in
        the parent's upper half: accurate for small `q`.
        """
        t, d = self._t, self.dist
        if t.upper_tail:
            return self._quantile(q, d.ppf, lambda u: d.isf(t.sa - u * t.kept))
        return self._quantile(q, d.ppf, lambda u: d.ppf(t.fa + u * t.kept))

    def isf(self, q):
        """Inverse survival function, ``ppf(1 - q)`` accurate for small `q`;
        ``nan`` for `q` outside [0, 1].

        ``S^{-1}(S_b + qK)``, or ``F^{-1}(F_b - qK)`` when the kept interval lies in
        the parent's lower half.
        """
        t, d = self._t, self.dist
        if t.sb > 0.5:
            return self._quantile(q, d.isf, lambda u: d.ppf(t.fb - u * t.kept))
        return self._quantile(q, d.isf, lambda u: d.isf(t.sb + u * t.kept))

    # -- probabilities -------------------------------------------------------------
    def _probability(self, x, parent, kept):
        """``parent(x)`` when nothing is cut, else ``kept(x) / K`` with `x` clipped
        to the limits, in [0, 1]; ``nan`` where `x` is NaN."""
        x = as_float_array(x, "x")
        if self._whole:
            p = np.asarray(parent(x), dtype=float)
        else:
            xc = np.clip(x, self.lower, self.upper)
            p = np.clip(kept(xc) / self.kept, 0.0, 1.0)
        return np.where(np.isnan(x), np.nan, p)[()]

    def cdf(self, x):
        """P(X <= x): ``(F(x) - F_a) / K``, or ``(S_a - S(x)) / K`` in the parent's
        upper half; ``nan`` where `x` is NaN."""
        t, d = self._t, self.dist
        if t.upper_tail:
            return self._probability(x, d.cdf, lambda xc: t.sa - d.sf(xc))
        return self._probability(x, d.cdf, lambda xc: d.cdf(xc) - t.fa)

    def sf(self, x):
        """P(X > x), accurate in the upper tail: ``(S(x) - S_b) / K``, or
        ``(F_b - F(x)) / K`` in the parent's lower half; ``nan`` where `x` is NaN."""
        t, d = self._t, self.dist
        if t.sb > 0.5:
            return self._probability(x, d.sf, lambda xc: t.fb - d.cdf(xc))
        return self._probability(x, d.sf, lambda xc: d.sf(xc) - t.sb)

    def pdf(self, x):
        """Probability density; 0 outside the kept interval, ``nan`` at NaN."""
        x = as_float_array(x, "x")
        if self.open_interval:
            inside = (x > self.lower) & (x < self.upper)
        else:
            inside = (x >= self.lower) & (x <= self.upper)
        f = np.asarray(self.dist.pdf(x), dtype=float)
        if not self._whole:
            f = f / self.kept
        f = np.where(inside, f, 0.0)
        return np.where(np.isnan(x), np.nan, f)[()]

    def rvs(self, size, rng):
        """Draws with the Generator `rng`: SciPy's sampler when nothing is cut,
        otherwise by inversion, ``ppf(rng.random(size))``."""
        if self._whole:
            return np.asarray(self.dist.rvs(size=size, random_state=rng), dtype=float)
        return np.asarray(self.ppf(rng.random(size)), dtype=float)

    # -- moments -----------------------------------------------------------------
    def _quad_moments(self) -> tuple[float, float]:
        """(mean, std) by quadrature in ``y = (x - median) / iqr``, split at the
        median, with the density normalised by the kept probability: the
        integrand is of order one whatever the units."""
        if self._moments is None:
            c = float(self.ppf(0.5))
            w = float(self.ppf(0.75) - self.ppf(0.25))
            lo, hi = self._support
            if not w > 0:
                w = abs(c) if c != 0 else 1.0
            pdf, k = self.dist.pdf, self.kept

            def density(y):
                return pdf(c + w * y) * (w / k)

            bounds = (((lo - c) / w, 0.0), (0.0, (hi - c) / w))
            parts = [(a, b) for a, b in bounds if b > a]

            def expect(func):
                return sum(
                    integrate.quad(
                        lambda y: func(y) * density(y),
                        a,
                        b,
                        limit=200,
                        epsabs=1e-14,
                        epsrel=1e-13,
                    )[0]
                    for a, b in parts
                )

            m1 = expect(lambda y: y)
            m2 = expect(lambda y: (y - m1) ** 2)
            self._moments = (c + w * m1, w * math.sqrt(max(m2, 0.0)))
        return self._moments

    def mean(self) -> float:
        """Mean (SciPy's when nothing is cut, else by quadrature)."""
        if self._whole:
            return float(self.dist.mean())
        return self._quad_moments()[0]

    def std(self) -> float:
        """Standard deviation, ``ddof=0`` (SciPy's when nothing is cut)."""
        if self._whole:
            return float(self.dist.std())
        return self._quad_moments()[1]

    def median(self) -> float:
        return float(self.ppf(0.5))

    def support(self) -> tuple[float, float]:
        """(lower, upper) limits of the values."""
        return self._support

    def table(self, size: int = TABLE_SIZE) -> QuantileTable:
        """:meth:`QuantileTable.from_ppf` of :meth:`ppf`."""
        return QuantileTable.from_ppf(self.ppf, size=size)


# ----------------------------------------------------------------------- atoms
class DiscreteAtoms:
    """A discrete distribution on sorted atoms, equiprobable or weighted.

    Parameters
    ----------
    atoms : array_like
        Finite values, at least one; duplicates are kept (a sample's repeated
        values each carry their weight).
    weights : array_like, optional
        Finite weights >= 0 with a positive sum, one per atom; normalised to sum
        to 1. Atoms of weight 0 are dropped. Default: equal weights ``1/n``.

    Attributes
    ----------
    atoms : ndarray
        The atoms, sorted (stably, with their weights), read-only.
    weights : ndarray
        The normalised weights of :attr:`atoms`, read-only.
    is_equiprobable : bool
        All weights equal.
    """

    is_discrete = True
    truncated_mass = 0.0

    def __init__(self, atoms, weights=None):
        a = as_float_array(atoms, "atoms").ravel()
        if a.size == 0 or not np.all(np.isfinite(a)):
            raise ValueError(
                f"`atoms` must be a non-empty array of finite values; got {atoms!r}."
            )
        w = None
        if weights is not None:
            w = as_float_array(weights, "weights").ravel()
            if w.shape != a.shape:
                raise ValueError(
                    f"`weights` needs one value per atom ({a.size}); got {w.size}."
                )
            if not np.all(np.isfinite(w) & (w >= 0)) or not w.sum() > 0:
                raise ValueError(
                    f"`weights` must be finite, >= 0 and not all 0; got {weights!r}."
                )
            keep = w > 0
            a, w = a[keep], w[keep]
            order = np.argsort(a, kind="stable")
            a, w = a[order], w[order] / w.sum()
            if np.all(w == w[0]):
                w = None  # equiprobable: the exact integer formulas below
        else:
            a = np.sort(a)
        a.setflags(write=False)
        self.atoms = a
        n = a.size
        if w is None:
            self._w = None
            w = np.full(n, 1.0 / n)
        else:
            self._w = w
            # F at the atoms; below 1 but at the top atom, so that ppf(1) is the
            # largest atom even when the weights above are below round-off
            cw = np.minimum(np.cumsum(w), np.nextafter(1.0, 0.0))
            cw[-1] = 1.0
            self._cw = cw
            # tail[k] = sum of the weights above atom k, summed from the top
            self._tail = np.append(np.cumsum(w[::-1])[::-1][1:], 0.0)
        w.setflags(write=False)
        self.weights = w

    @property
    def is_equiprobable(self) -> bool:
        return self._w is None

    # -- quantiles ---------------------------------------------------------------
    def ppf(self, q):
        """Left-continuous inverse of the CDF, ``min{x : F(x) >= q}``
        (``atoms[ceil(q n) - 1]`` for equal weights); ``nan`` outside [0, 1]."""
        q, bad, qq = _probabilities(q)
        n = self.atoms.size
        if self._w is None:
            k = np.ceil(qq * n).astype(np.intp) - 1
        else:
            k = np.searchsorted(self._cw, qq, side="left")
        x = self.atoms[np.clip(k, 0, n - 1)]
        return np.where(bad, np.nan, x)[()]

    def isf(self, q):
        """``min{x : S(x) <= q}``, i.e. ``ppf(1 - q)`` without rounding ``1 - q``
        (``atoms[n - 1 - floor(q n)]`` for equal weights); ``nan`` outside [0, 1]."""
        q, bad, qq = _probabilities(q)
        n = self.atoms.size
        if self._w is None:
            k = n - 1 - np.floor(qq * n).astype(np.intp)
        else:
            k = n - np.searchsorted(self._tail[::-1], qq, side="right")
        x = self.atoms[np.clip(k, 0, n - 1)]
        return np.where(bad, np.nan, x)[()]

    # -- probabilities -------------------------------------------------------------
    def _count(self, x):
        """Number of atoms <= x."""
        return np.searchsorted(self.atoms, x, side="right")

    def cdf(self, x):
        """Sum of the weights of the atoms <= x; ``nan`` where `x` is NaN."""
        x = as_float_array(x, "x")
        k = self._count(x)
        n = self.atoms.size
        if self._w is None:
            p = k / n
        else:
            p = np.where(k == 0, 0.0, self._cw[np.maximum(k - 1, 0)])
        return np.where(np.isnan(x), np.nan, p)[()]

    def sf(self, x):
        """Sum of the weights of the atoms > x (from the top: accurate in the upper
        tail); ``nan`` where `x` is NaN."""
        x = as_float_array(x, "x")
        k = self._count(x)
        n = self.atoms.size
        if self._w is None:
            s = (n - k) / n
        else:
            s = np.where(k == 0, 1.0, self._tail[np.maximum(k - 1, 0)])
        return np.where(np.isnan(x), np.nan, s)[()]

    def pdf(self, x):
        """``inf`` at the atoms (a Dirac delta), 0 elsewhere, ``nan`` at NaN."""
        x = as_float_array(x, "x")
        f = np.where(np.isin(x, self.atoms), np.inf, 0.0)
        return np.where(np.isnan(x), np.nan, f)[()]

    def rvs(self, size, rng):
        """Draws with the Generator `rng`: a uniform index for equal weights, the
        inverse of the cumulative weights otherwise."""
        n = self.atoms.size
        if self._w is None:
            return self.atoms[rng.integers(0, n, size=size)]
        k = np.searchsorted(self._cw, rng.random(size), side="right")
        return self.atoms[np.minimum(k, n - 1)]

    # -- moments -----------------------------------------------------------------
    def mean(self) -> float:
        """Exact mean, ``sum(w x)``."""
        if self._w is None:
            return float(self.atoms.mean())
        return float(np.dot(self._w, self.atoms))

    def std(self) -> float:
        """Exact standard deviation, ``ddof=0``."""
        if self._w is None:
            return float(self.atoms.std())
        m = self.mean()
        return float(math.sqrt(np.dot(self._w, (self.atoms - m) ** 2)))

    def median(self) -> float:
        return float(self.ppf(0.5))

    def support(self) -> tuple[float, float]:
        """(smallest, largest) atom."""
        return float(self.atoms[0]), float(self.atoms[-1])

    def table(self, size: int = TABLE_SIZE) -> QuantileTable:
        """The atoms as a :class:`QuantileTable` (``from_sample`` for equal weights,
        ``from_weights`` otherwise)."""
        if self._w is None:
            return QuantileTable.from_sample(self.atoms, size=size)
        return QuantileTable.from_weights(self.atoms, self._w, size=size)


# ------------------------------------------------------------------ unit change
class Rescaled:
    """The distribution of ``factor * X`` for a continuous `dist` of ``X``, factor > 0.

    Converts a distribution given in interface units (degrees) to SI (radians)
    without rebuilding it, so any object with :data:`CONTINUOUS_METHODS` can be
    wrapped.
    """

    def __init__(self, dist, factor):
        self.dist, self.factor = dist, float(factor)
        if not self.factor > 0:
            raise ValueError(f"`factor` must be > 0; got {factor!r}.")

    def cdf(self, x):
        return self.dist.cdf(np.asarray(x) / self.factor)

    def sf(self, x):
        return self.dist.sf(np.asarray(x) / self.factor)

    def pdf(self, x):
        return self.dist.pdf(np.asarray(x) / self.factor) / self.factor

    def ppf(self, q):
        return self.dist.ppf(q) * self.factor

    def isf(self, q):
        return self.dist.isf(q) * self.factor

    def support(self):
        lo, hi = self.dist.support()
        return lo * self.factor, hi * self.factor

    def rvs(self, size=None, random_state=None):
        return self.dist.rvs(size=size, random_state=random_state) * self.factor

    def mean(self):
        return self.dist.mean() * self.factor

    def std(self):
        return self.dist.std() * self.factor

    def __repr__(self):
        return f"Rescaled({self.dist!r}, {self.factor!r})"


# ------------------------------------------------------------------ the wrappers
class CoreMethods:
    """The distribution protocol of a wrapper, delegated to its ``_core``
    (a :class:`TruncatedContinuous` or a :class:`DiscreteAtoms`), in SI units."""

    @property
    def is_discrete(self) -> bool:
        """True for a discrete distribution (atoms, no density)."""
        return bool(self._core.is_discrete)

    @property
    def weights(self):
        """Normalised weights of the atoms (discrete), else ``None``."""
        return self._core.weights

    def ppf(self, q):
        """Quantile function at probability `q`; ``nan`` outside [0, 1].

        Discrete: the left-continuous inverse of the CDF.
        """
        return self._core.ppf(q)

    def isf(self, q):
        """Inverse survival function, ``ppf(1 - q)`` computed accurately for small
        `q` (the upper tail); ``nan`` outside [0, 1]."""
        return self._core.isf(q)

    def cdf(self, x):
        """Cumulative distribution function, P(X <= x)."""
        return self._core.cdf(x)

    def sf(self, x):
        """Survival function, P(X > x), accurate in the upper tail."""
        return self._core.sf(x)

    def pdf(self, x):
        """Probability density (``inf`` at discrete atoms, a Dirac delta)."""
        return self._core.pdf(x)

    def rvs(self, size=None, *, rng=None):
        """Random draws with the generator `rng` (SPEC 7)."""
        rng = np.random.default_rng(rng)
        return np.asarray(self._core.rvs(size, rng), dtype=float)[()]

    def mean(self) -> float:
        """Mean of the (truncated) distribution."""
        return float(self._core.mean())

    def std(self) -> float:
        """Standard deviation of the (truncated) distribution (``ddof=0``)."""
        return float(self._core.std())

    def median(self) -> float:
        """Median, ``ppf(0.5)``."""
        return float(self._core.median())

    def support(self) -> tuple[float, float]:
        """(lower, upper) limits of the values."""
        return self._core.support()

    def _describe(self, convert, unit: str) -> dict:
        """The wrapper's ``describe()``: ``kind``, ``params``, the mean, standard
        deviation, median and support converted from SI by `convert` (keys suffixed
        ``_{unit}``), ``truncated_mass`` and, if discrete, ``n_atoms``."""
        lo, hi = self.support()
        out = {
            "kind": self.kind,
            "params": dict(self.params),
            f"mean_{unit}": float(convert(self.mean())),
            f"std_{unit}": float(convert(self.std())),
            f"median_{unit}": float(convert(self.median())),
            f"support_{unit}": (float(convert(lo)), float(convert(hi))),
            "truncated_mass": float(self.truncated_mass),
        }
        if self.is_discrete:
            out["n_atoms"] = int(self.atoms.size)
        return out

    def table(self, size: int = TABLE_SIZE) -> QuantileTable:
        """The equiprobable :class:`~microimpact._core.tables.QuantileTable` the engine
        samples: a discrete distribution's own atoms (``from_sample``, or
        ``from_weights``), otherwise ``from_ppf(self.ppf)``."""
        return self._core.table(size)
