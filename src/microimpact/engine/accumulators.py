"""Mergeable streaming statistics for the Monte Carlo engine.

Each block of impacts is reduced to a :class:`PointAccumulator`: counts, the first
three central moments of ``e_m`` and ``mu_m`` over rebounds (Chan et al. / Pebay
update formulas) and fixed-edge integer histograms. Accumulators are merged on the
driver in block-key order, so the result does not depend on how blocks were grouped
into tasks or which worker ran them.

The statistics over all impacts with captured particles counted as ``e_m = 0``
(``e_mean``) are derived exactly from the rebound moments and the capture count, so the
kernel never computes them separately.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Fixed histogram edges of the apparent coefficient of restitution e_m [-]: 0.01
#: bins on [-2, 10] (at grazing angles on rough surfaces e_m far exceeds 1).
E_EDGES = np.linspace(-2.0, 10.0, 1201)
#: Fixed histogram edges of the apparent impulse ratio mu_m [-]: 0.01 bins on [-10, 10].
MU_EDGES = np.linspace(-10.0, 10.0, 2001)


@dataclass
class Moments:
    """Count, mean and central moment sums M2, M3 of a stream of values."""

    n: int = 0
    mean: float = 0.0
    m2: float = 0.0
    m3: float = 0.0

    @classmethod
    def from_shifted_sums(cls, n, shift, s1, s2, s3) -> Moments:
        """Moments from the shifted sums ``S_r = sum (x - shift)^r`` of `n` values.

        This is how the kernels reduce a block in one pass (Chan, Golub & LeVeque
        1983, "shifted data"): with the shift equal to one of the values (the
        kernels take the first), ``|mean - shift|`` is of the order of the standard
        deviation and the subtraction below loses no more than a two-pass
        algorithm; a constant stream gives exactly zero.
        """
        if n == 0:
            return cls()
        delta = s1 / n
        m2 = s2 - s1 * delta
        m3 = s3 - 3.0 * delta * s2 + 2.0 * n * delta**3
        return cls(int(n), float(shift + delta), float(max(m2, 0.0)), float(m3))

    @classmethod
    def of(cls, x: np.ndarray) -> Moments:
        """Moments of the finite 1-d array `x`, exactly as the compiled kernel
        reduces a block (same bits): shifted sums about ``x[0]``, each summed
        sequentially left to right (``np.add.accumulate``)."""
        if x.size == 0:
            return cls()
        shift = float(x[0])
        d = x - shift
        d2 = d * d
        s1 = float(np.add.accumulate(d)[-1])
        s2 = float(np.add.accumulate(d2)[-1])
        d2 *= d
        return cls.from_shifted_sums(
            x.size, shift, s1, s2, float(np.add.accumulate(d2)[-1])
        )

    def merge(self, other: Moments) -> Moments:
        """Combine two disjoint streams (Pebay 2008, Eqs. 1.1-1.3)."""
        if other.n == 0:
            return Moments(self.n, self.mean, self.m2, self.m3)
        if self.n == 0:
            return Moments(other.n, other.mean, other.m2, other.m3)
        na, nb = self.n, other.n
        n = na + nb
        delta = other.mean - self.mean
        mean = self.mean + delta * nb / n
        m2 = self.m2 + other.m2 + delta * delta * na * nb / n
        m3 = (
            self.m3
            + other.m3
            + delta**3 * na * nb * (na - nb) / (n * n)
            + 3.0 * delta * (na * other.m2 - nb * self.m2) / n
        )
        return Moments(n, mean, m2, m3)

    @property
    def variance(self) -> float:
        """Unbiased sample variance (NaN for n < 2)."""
        return self.m2 / (self.n - 1) if self.n > 1 else float("nan")

    @property
    def std(self) -> float:
        return float(np.sqrt(self.variance))

    @property
    def skewness(self) -> float:
        """Sample skewness g1 = sqrt(n) M3 / M2^1.5 (NaN if undefined)."""
        if self.n < 3 or self.m2 <= 0:
            return float("nan")
        return float(np.sqrt(self.n) * self.m3 / self.m2**1.5)

    def as_array(self) -> np.ndarray:
        return np.array([self.n, self.mean, self.m2, self.m3], dtype=float)

    @classmethod
    def from_array(cls, a) -> Moments:
        return cls(int(a[0]), float(a[1]), float(a[2]), float(a[3]))


def histogram_counts(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Counts of `x` in uniform `edges`, with an underflow (index 0) and an overflow
    (index -1) bin: length ``len(edges) + 1``. Integer arithmetic plus bincount."""
    nb = edges.size - 1
    lo = edges[0]
    inv_w = nb / (edges[-1] - lo)
    idx = np.floor((x - lo) * inv_w)
    np.clip(idx, -1, nb, out=idx)
    return np.bincount(idx.astype(np.intp) + 1, minlength=nb + 2)


@dataclass
class PointAccumulator:
    """Everything the engine keeps of the impacts at one sweep point.

    Attributes
    ----------
    n : int
        Samples drawn.
    shadowed : int
        Samples whose facet could not be reached (only with ``shadowing="none"``).
    captured : int
        Impacts with ``|v_n'| <= v_c``.
    reimpact : int
        Rebounds that still head into the nominal surface.
    rolling : int
        Rebounds that leave the facet rolling.
    e, mu : Moments
        Moments of ``e_m`` and ``mu_m`` over rebounds.
    e_hist, mu_hist : ndarray of int64
        Histograms of ``e_m`` and ``mu_m`` over rebounds on :data:`E_EDGES`,
        :data:`MU_EDGES` with under- and overflow bins.
    """

    n: int = 0
    shadowed: int = 0
    captured: int = 0
    reimpact: int = 0
    rolling: int = 0
    e: Moments = field(default_factory=Moments)
    mu: Moments = field(default_factory=Moments)
    e_hist: np.ndarray = field(
        default_factory=lambda: np.zeros(E_EDGES.size + 1, dtype=np.int64)
    )
    mu_hist: np.ndarray = field(
        default_factory=lambda: np.zeros(MU_EDGES.size + 1, dtype=np.int64)
    )

    def merge(self, other: PointAccumulator) -> PointAccumulator:
        """A new accumulator for the union of two disjoint sets of impacts."""
        return PointAccumulator(
            n=self.n + other.n,
            shadowed=self.shadowed + other.shadowed,
            captured=self.captured + other.captured,
            reimpact=self.reimpact + other.reimpact,
            rolling=self.rolling + other.rolling,
            e=self.e.merge(other.e),
            mu=self.mu.merge(other.mu),
            e_hist=np.add(self.e_hist, other.e_hist, dtype=np.int64),
            mu_hist=np.add(self.mu_hist, other.mu_hist, dtype=np.int64),
        )

    @property
    def impacts(self) -> int:
        """Samples that struck a facet (drawn minus shadowed)."""
        return self.n - self.shadowed

    @property
    def rebounds(self) -> int:
        return self.impacts - self.captured

    def e_all(self) -> Moments:
        """Moments of e_m over all impacts, captured counted as 0 (exact merge)."""
        return Moments(self.captured, 0.0, 0.0, 0.0).merge(self.e)

    # serialisation for checkpoints and worker transport
    def to_arrays(self) -> dict[str, np.ndarray]:
        counts = np.array(
            [self.n, self.shadowed, self.captured, self.reimpact, self.rolling],
            dtype=np.int64,
        )
        return {
            "counts": counts,
            "e": self.e.as_array(),
            "mu": self.mu.as_array(),
            "e_hist": self.e_hist,
            "mu_hist": self.mu_hist,
        }

    @classmethod
    def from_arrays(cls, d) -> PointAccumulator:
        c = [int(v) for v in d["counts"]]
        return cls(
            n=c[0],
            shadowed=c[1],
            captured=c[2],
            reimpact=c[3],
            rolling=c[4],
            e=Moments.from_array(d["e"]),
            mu=Moments.from_array(d["mu"]),
            e_hist=np.asarray(d["e_hist"], dtype=np.int64).copy(),
            mu_hist=np.asarray(d["mu_hist"], dtype=np.int64).copy(),
        )


def histogram_quantile(counts: np.ndarray, edges: np.ndarray, q) -> np.ndarray:
    """Quantiles from a histogram with under/overflow bins, linear within a bin.

    Resolution is one bin width; quantiles falling in the under- or overflow bin are
    returned as -inf / +inf (honestly out of the histogram's range).
    """
    q = np.atleast_1d(np.asarray(q, dtype=float))
    total = counts.sum()
    out = np.full(q.shape, np.nan)
    if total == 0:
        return out
    cum = np.cumsum(counts) / total  # cum[i]: fraction <= upper edge of slot i
    for k, qk in enumerate(q):
        i = int(np.searchsorted(cum, qk, side="left"))
        if i == 0:
            out[k] = -np.inf
        elif i >= counts.size - 1:
            out[k] = np.inf
        else:
            lo, hi = edges[i - 1], edges[i]
            before = cum[i - 1]
            frac = (qk - before) / (cum[i] - before) if cum[i] > before else 0.5
            out[k] = lo + frac * (hi - lo)
    return out
