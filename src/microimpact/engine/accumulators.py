"""Mergeable streaming statistics for the Monte Carlo engine.

Each block of impacts is reduced to a :class:`PointAccumulator`: counts, the first
three central moments of ``e_m``, ``mu_m`` and the folded lateral angle over rebounds
(Chan et al. / Pebay update formulas) and fixed-edge integer histograms. Accumulators
are merged on the driver in block-key order, so the result does not depend on how
blocks were grouped into tasks or which worker ran them.

The statistics over all impacts with captured particles counted as ``e_m = 0``
(``e_mean``) are derived exactly from the rebound moments and the capture count, so the
kernel never computes them separately.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Fixed histogram edges of the apparent coefficient of restitution e_m [-]: 0.01
#: bins on [-2, 10] (at grazing angles on rough surfaces e_m far exceeds 1).
E_EDGES = np.linspace(-2.0, 10.0, 1201)
#: Fixed histogram edges of the apparent impulse ratio mu_m [-]: 0.01 bins on [-10, 10].
MU_EDGES = np.linspace(-10.0, 10.0, 2001)
#: Fixed histogram edges of the folded lateral angle psi_f [deg]: 0.5 degree bins on
#: [-90, 90], the last edge inclusive (psi_f = 90 counts in the last bin).
LATERAL_EDGES = np.linspace(-90.0, 90.0, 361)


@dataclass(slots=True)
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


def folded_lateral_deg(psi_deg):
    """The folded lateral angle ``psi_f = atan2(V_b, |V_t|)`` [deg] in [-90, 90] from
    the lateral angle ``psi = atan2(V_b, -V_t)`` of
    :func:`microimpact.apparent_rebound` (docs/outputs.md): ``psi`` itself for a
    forward rebound (``|psi| <= 90``), ``sign(psi) 180 - psi`` for a backward one;
    0 for every rebound in the plane of incidence (``psi`` = 0 or 180)."""
    psi = np.asarray(psi_deg, dtype=float)
    back = np.abs(psi) > 90.0
    out = np.where(back, np.copysign(180.0, psi) - psi, psi)
    return out + 0.0  # no -0


def lateral_histogram_counts(x: np.ndarray) -> np.ndarray:
    """:func:`histogram_counts` of folded lateral angles on :data:`LATERAL_EDGES`,
    the last edge inclusive (90 counts in the last bin, not the overflow bin)."""
    x = np.asarray(x, dtype=float)
    counts = histogram_counts(x, LATERAL_EDGES)
    top = int(np.count_nonzero(x == LATERAL_EDGES[-1]))
    if top:  # from the overflow bin into the last bin
        counts[-1] -= top
        counts[-2] += top
    return counts


#: Bins of the dense histograms (edges plus the under- and overflow bins).
E_BINS = E_EDGES.size + 1
MU_BINS = MU_EDGES.size + 1
LATERAL_BINS = LATERAL_EDGES.size + 1
#: The dense bin of psi_f = 0 (every rebound of a profile or smooth surface).
LATERAL_ZERO_BIN = int(np.floor((0.0 - LATERAL_EDGES[0]) * 2.0)) + 1
_EMPTY = np.zeros(0, dtype=np.int64)
_EMPTY.setflags(write=False)


def _span(dense) -> tuple[int, np.ndarray]:
    """``(offset, counts)``: the occupied span of a dense histogram (a copy)."""
    nz = (dense != 0).nonzero()[0]  # faster than flatnonzero on int64
    if nz.size == 0:
        return 0, _EMPTY
    lo, hi = int(nz[0]), int(nz[-1]) + 1
    return lo, np.array(dense[lo:hi], dtype=np.int64)


def _add_spans(lo_a, a, lo_b, b) -> tuple[int, np.ndarray]:
    """The sum of two histogram spans, as a span covering both."""
    if b.size == 0:
        return lo_a, a
    if a.size == 0:
        return lo_b, b
    lo = min(lo_a, lo_b)
    hi = max(lo_a + a.size, lo_b + b.size)
    if lo == lo_a and hi == lo_a + a.size:
        out = a.copy()
    else:
        out = np.zeros(hi - lo, dtype=np.int64)
        out[lo_a - lo : lo_a - lo + a.size] = a
    out[lo_b - lo : lo_b - lo + b.size] += b
    return lo, out


def _dense(lo, counts, size) -> np.ndarray:
    out = np.zeros(size, dtype=np.int64)
    out[lo : lo + counts.size] = counts
    return out


def in_plane_lateral(rebounds: int) -> tuple[Moments, tuple[int, np.ndarray]]:
    """``(moments, span)`` of `rebounds` folded lateral angles all exactly 0 (a
    profile or smooth surface): exactly what ``Moments.of`` and
    :func:`lateral_histogram_counts` give for ``np.zeros(rebounds)``."""
    rebounds = int(rebounds)
    if rebounds == 0:
        return Moments(), (0, _EMPTY)
    m = Moments.from_shifted_sums(rebounds, 0.0, 0.0, 0.0, 0.0)
    return m, (LATERAL_ZERO_BIN, np.array([rebounds], dtype=np.int64))


class PointAccumulator:
    """Everything the engine keeps of the impacts at one sweep point.

    The histograms are held compactly, as the occupied span of bins (an offset and
    the counts from the first to the last nonzero bin): a point whose ``e_m`` all
    fall in a few bins costs a few bytes, not the 26 kB of the two dense arrays.
    :attr:`e_hist` and :attr:`mu_hist` give the dense arrays on access.

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
    lateral : Moments
        Moments of the folded lateral angle ``psi_f`` [deg] over the same rebounds
        (exactly 0 for each rebound on a profile or smooth surface).
    e_hist, mu_hist, lateral_hist : ndarray of int64
        Histograms of ``e_m``, ``mu_m`` and ``psi_f`` over rebounds on
        :data:`E_EDGES`, :data:`MU_EDGES`, :data:`LATERAL_EDGES` with under- and
        overflow bins (dense copies, built on access: length ``len(edges) + 1``).
    e_span, mu_span, lateral_span : (int, ndarray of int64)
        The same histograms as ``(offset, counts)``: bins ``offset ..
        offset + len(counts) - 1`` of the dense array (read-only views).
    """

    __slots__ = (
        "_e_counts",
        "_e_lo",
        "_lat_counts",
        "_lat_lo",
        "_mu_counts",
        "_mu_lo",
        "captured",
        "e",
        "lateral",
        "mu",
        "n",
        "reimpact",
        "rolling",
        "shadowed",
    )

    def __init__(
        self,
        n=0,
        shadowed=0,
        captured=0,
        reimpact=0,
        rolling=0,
        e=None,
        mu=None,
        e_hist=None,
        mu_hist=None,
        *,
        e_span=None,
        mu_span=None,
        lateral=None,
        lateral_hist=None,
        lateral_span=None,
    ):
        self.n = int(n)
        self.shadowed = int(shadowed)
        self.captured = int(captured)
        self.reimpact = int(reimpact)
        self.rolling = int(rolling)
        self.e = Moments() if e is None else e
        self.mu = Moments() if mu is None else mu
        self._e_lo, self._e_counts = _span_arg(e_hist, e_span, E_BINS, "e_hist")
        self._mu_lo, self._mu_counts = _span_arg(mu_hist, mu_span, MU_BINS, "mu_hist")
        self.lateral = Moments() if lateral is None else lateral
        self._lat_lo, self._lat_counts = _span_arg(
            lateral_hist, lateral_span, LATERAL_BINS, "lateral_hist"
        )

    @property
    def e_hist(self) -> np.ndarray:
        return _dense(self._e_lo, self._e_counts, E_BINS)

    @property
    def mu_hist(self) -> np.ndarray:
        return _dense(self._mu_lo, self._mu_counts, MU_BINS)

    @property
    def lateral_hist(self) -> np.ndarray:
        return _dense(self._lat_lo, self._lat_counts, LATERAL_BINS)

    @property
    def lateral_span(self) -> tuple[int, np.ndarray]:
        return self._lat_lo, _readonly(self._lat_counts)

    @property
    def e_span(self) -> tuple[int, np.ndarray]:
        return self._e_lo, _readonly(self._e_counts)

    @property
    def mu_span(self) -> tuple[int, np.ndarray]:
        return self._mu_lo, _readonly(self._mu_counts)

    def span_of(self, name: str) -> tuple[int, np.ndarray]:
        """``(offset, counts)`` of histogram `name` (``"e"``, ``"mu"`` or
        ``"lateral"``), without a read-only view (for serialisation; do not modify
        the counts)."""
        if name == "e":
            return self._e_lo, self._e_counts
        if name == "lateral":
            return self._lat_lo, self._lat_counts
        return self._mu_lo, self._mu_counts

    @property
    def nbytes(self) -> int:
        """Bytes held by the histogram spans."""
        return self._e_counts.nbytes + self._mu_counts.nbytes + self._lat_counts.nbytes

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
            e_span=_add_spans(self._e_lo, self._e_counts, other._e_lo, other._e_counts),
            mu_span=_add_spans(
                self._mu_lo, self._mu_counts, other._mu_lo, other._mu_counts
            ),
            lateral=self.lateral.merge(other.lateral),
            lateral_span=_add_spans(
                self._lat_lo, self._lat_counts, other._lat_lo, other._lat_counts
            ),
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

    def counts_array(self) -> np.ndarray:
        """``[n, shadowed, captured, reimpact, rolling]`` as int64."""
        return np.array(
            [self.n, self.shadowed, self.captured, self.reimpact, self.rolling],
            dtype=np.int64,
        )

    def __eq__(self, other):
        if not isinstance(other, PointAccumulator):
            return NotImplemented
        return (
            np.array_equal(self.counts_array(), other.counts_array())
            and self.e == other.e
            and self.mu == other.mu
            and np.array_equal(self.e_hist, other.e_hist)
            and np.array_equal(self.mu_hist, other.mu_hist)
            and self.lateral == other.lateral
            and np.array_equal(self.lateral_hist, other.lateral_hist)
        )

    __hash__ = None

    def __repr__(self):
        return (
            f"PointAccumulator(n={self.n}, shadowed={self.shadowed}, "
            f"captured={self.captured}, reimpact={self.reimpact}, "
            f"rolling={self.rolling}, e={self.e!r}, mu={self.mu!r}, "
            f"lateral={self.lateral!r})"
        )

    def __getstate__(self):
        return tuple(getattr(self, k) for k in self.__slots__)

    def __setstate__(self, state):
        for k, v in zip(self.__slots__, state, strict=True):
            setattr(self, k, v)

    # serialisation (dense arrays; the checkpoint stores the spans itself)
    def to_arrays(self) -> dict[str, np.ndarray]:
        return {
            "counts": self.counts_array(),
            "e": self.e.as_array(),
            "mu": self.mu.as_array(),
            "e_hist": self.e_hist,
            "mu_hist": self.mu_hist,
            "lateral": self.lateral.as_array(),
            "lateral_hist": self.lateral_hist,
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
            e_hist=np.asarray(d["e_hist"], dtype=np.int64),
            mu_hist=np.asarray(d["mu_hist"], dtype=np.int64),
            lateral=Moments.from_array(d["lateral"]) if "lateral" in d else None,
            lateral_hist=(
                np.asarray(d["lateral_hist"], dtype=np.int64)
                if "lateral_hist" in d
                else None
            ),
        )


def _readonly(a):
    v = a.view()
    v.setflags(write=False)
    return v


def _span_arg(dense, span, size, name):
    """The stored ``(offset, counts)`` from a dense histogram or a span."""
    if dense is not None and span is not None:
        raise TypeError(f"give `{name}` or its span, not both")
    if span is not None:
        lo, counts = span
        counts = np.asarray(counts, dtype=np.int64)
        lo = int(lo)
        if counts.ndim != 1 or lo < 0 or lo + counts.size > size:
            raise ValueError(f"`{name}` span ({lo}, {counts.size} bins) exceeds {size}")
        return (lo, counts) if counts.size else (0, _EMPTY)
    if dense is None:
        return 0, _EMPTY
    dense = np.asarray(dense)
    if dense.shape != (size,):
        raise ValueError(f"`{name}` must have {size} bins; got shape {dense.shape}")
    return _span(dense)


def histogram_quantile(counts: np.ndarray, edges: np.ndarray, q) -> np.ndarray:
    """Quantiles from a histogram with under/overflow bins, linear within a bin.

    Resolution is one bin width; quantiles falling in the under- or overflow bin are
    returned as -inf / +inf (honestly out of the histogram's range). The one-row
    definition behind :func:`microimpact.engine.statistics.point_row` (the tests'
    oracle); a run uses the vectorised
    :func:`microimpact.engine.summary.histogram_quantiles`.
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
