"""Per-point statistics of a whole sweep, vectorised over the points.

The engine's accumulators of every sweep point are stacked into arrays
(:class:`Stacked`) and every summary statistic is computed for all points at once
(a 10^4-point sweep grid costs milliseconds here, not seconds). The definitions are
those of ``docs/outputs.md``; plain Monte Carlo:

* ``capture_fraction`` with a Wilson score interval and ``capture_se`` = the
  interval's width over ``2 z``;
* means with normal-theory intervals ``mean +- z s/sqrt(n)``;
* histogram quantiles linear within a 0.01 bin.

Quasi-Monte Carlo (``R`` replicates): pooled estimates, intervals
``+- t_{R-1} SE`` with ``SE`` the standard deviation of the replicate estimates over
``sqrt(R)`` (Owen 1997); the capture interval is clipped to [0, 1], and where the
pooled capture fraction is exactly 0 or 1 (the replicates all agree, their spread is
0) it is the pooled counts' Wilson interval.
"""

from __future__ import annotations

import ctypes
import functools
import gc
import math
from dataclasses import dataclass

import numpy as np

from . import _compiled
from .accumulators import (
    E_EDGES,
    LATERAL_BINS,
    LATERAL_EDGES,
    MU_EDGES,
    Moments,
    PointAccumulator,
)
from .statistics import QUANTILES, interval_se, wilson_interval, z_value


@dataclass(frozen=True)
class Spans:
    """The histograms of ``P`` points as occupied spans, stored flat.

    Row ``i`` is bins ``offset[i] .. offset[i] + length[i] - 1`` of a dense
    histogram of ``size`` bins (under/overflow at the ends); its counts are
    ``counts[start[i]:start[i] + length[i]]``.
    """

    offset: np.ndarray  # (P,) int64
    length: np.ndarray  # (P,) int64
    counts: np.ndarray  # (sum(length),) int64, or narrower (see narrow)
    size: int

    @functools.cached_property
    def start(self) -> np.ndarray:
        start = np.zeros(self.length.size, dtype=np.int64)
        np.cumsum(self.length[:-1], out=start[1:])
        return start

    @property
    def rows(self) -> int:
        return self.offset.size

    def dense(self, dtype=None) -> np.ndarray:
        """The ``(P, size)`` dense histograms (int32 where every count fits)."""
        if dtype is None:
            dtype = np.int64 if self.big else np.int32
        out = np.zeros((self.rows, self.size), dtype=dtype)
        row = np.repeat(np.arange(self.rows), self.length)
        # each stored count's dense bin: its row's offset plus its place in the span
        col = np.repeat(self.offset - self.start, self.length) + np.arange(
            self.counts.size
        )
        out[row, col] = self.counts
        return out

    @property
    def big(self) -> bool:
        """Some count needs 64 bits."""
        return bool(
            self.counts.dtype.itemsize > 4
            and self.counts.size
            and int(self.counts.max()) >= 2**31
        )

    def narrow(self) -> Spans:
        """The same spans with their counts in the narrowest integer type that
        holds every one of them exactly (:func:`compact_counts`: ``uint8`` for a
        sweep of a few hundred impacts per point, ``uint16``, ``int32``, else
        ``int64``): an eighth of the bytes to send, gather and keep."""
        return Spans(self.offset, self.length, compact_counts(self.counts), self.size)

    def slice(self, lo: int, hi: int) -> Spans:
        """Rows ``lo .. hi - 1`` as views (no copy)."""
        first = int(self.start[lo]) if lo < self.rows else int(self.counts.size)
        last = int(self.start[hi - 1] + self.length[hi - 1]) if hi > lo else first
        return Spans(
            self.offset[lo:hi], self.length[lo:hi], self.counts[first:last], self.size
        )

    def row(self, i: int) -> tuple[int, np.ndarray]:
        """``(offset, counts)`` of row `i` (a view of :attr:`counts`)."""
        at = int(self.start[i])
        return int(self.offset[i]), self.counts[at : at + int(self.length[i])]

    def take(self, rows) -> Spans:
        """The rows `rows` (integer indices, in that order) as new spans."""
        rows = np.asarray(rows, dtype=np.intp)
        length = self.length[rows]
        counts = gather_segments(self.counts, self.start[rows], length)
        return Spans(self.offset[rows], length, counts, self.size)

    @classmethod
    def concat(cls, parts) -> Spans:
        """The rows of several :class:`Spans` (of one size), one after the other."""
        parts = list(parts)
        if len(parts) == 1:
            return parts[0]
        return cls(
            np.concatenate([p.offset for p in parts]),
            np.concatenate([p.length for p in parts]),
            np.concatenate([p.counts for p in parts]),
            parts[0].size,
        )

    @classmethod
    def of(cls, spans, size) -> Spans:
        """From a sequence of ``(offset, counts)``."""
        spans = list(spans)
        offset = np.array([o for o, _ in spans], dtype=np.int64)
        length = np.array([c.size for _, c in spans], dtype=np.int64)
        flat = (
            np.concatenate([c for _, c in spans]).astype(np.int64, copy=False)
            if spans
            else np.zeros(0, dtype=np.int64)
        )
        return cls(offset, length, flat, size)


def compact_counts(counts) -> np.ndarray:
    """Histogram `counts` (non-negative integers) in the narrowest of ``uint8``,
    ``uint16``, ``int32`` and ``int64`` that holds them all: the same values
    exactly, in 1/8 to 1/2 of the bytes (a point of 100 impacts never has a bin
    above 255). Returned as they are when already that narrow."""
    counts = np.asarray(counts)
    top = int(counts.max()) if counts.size else 0
    dtype = next((t for most, t in _NARROW if top <= most), np.dtype(np.int64))
    if counts.dtype.itemsize <= dtype.itemsize:
        return counts
    return counts.astype(dtype)


#: ``(largest value, dtype)`` of the narrow count types, narrowest first.
_NARROW = tuple(
    (int(np.iinfo(t).max), np.dtype(t)) for t in (np.uint8, np.uint16, np.int32)
)


def release_memory(*, collect: bool = False) -> None:
    """Give the memory this process freed back to the system: with `collect`, a
    full garbage collection first (the run deferred them), then glibc's
    ``malloc_trim``, as Dask's workers do (elsewhere nothing). A 10^6-point
    sweep's plan, driver state and temporaries otherwise stay in the resident
    set as freed heap (~240 MiB measured after the run)."""
    if collect:
        gc.collect()
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:  # pragma: no cover - not glibc (macOS, Windows, musl)
        return
    libc.malloc_trim(0)


def gather_segments(flat, start, length) -> np.ndarray:
    """The segments ``flat[start[i] : start[i] + length[i]]``, concatenated: a
    view of `flat` where they already follow one another there (one run: a
    single segment, or rows stored in order), else a copy."""
    total = int(length.sum())
    if total == 0:
        return flat[:0]
    first = np.zeros(length.size, dtype=np.int64)
    np.cumsum(length[:-1], out=first[1:])
    shift = start - first  # each segment's place in `flat` minus its place out
    used = shift[length > 0]  # (empty segments may point anywhere)
    if np.all(used == used[0]):
        return flat[int(used[0]) : int(used[0]) + total]
    # each kept value's place in `flat`: its segment's start plus its rank
    return flat[np.repeat(shift, length) + np.arange(total)]


def _span_of(acc, name):
    span = getattr(acc, "span_of", None)
    if span is not None:
        return span(name)
    return _span_of_dense(np.asarray(getattr(acc, f"{name}_hist")))


@dataclass(frozen=True)
class Stacked:
    """The accumulators of ``P`` points as arrays (leading axis: point).

    ``counts`` columns: n, shadowed, captured, reimpact, rolling; ``e``, ``mu`` and
    ``lateral`` columns: n, mean, M2, M3 of the rebounds' e_m, mu_m and folded
    lateral angle; the histograms as :class:`Spans` (memory proportional to the
    occupied bins).
    """

    counts: np.ndarray  # (P, 5) int64
    e: np.ndarray  # (P, 4) float64
    mu: np.ndarray  # (P, 4) float64
    e_spans: Spans
    mu_spans: Spans
    lateral: np.ndarray  # (P, 4) float64
    lateral_spans: Spans

    @classmethod
    def of(cls, accumulators) -> Stacked:
        """Stack a sequence of :class:`~.accumulators.PointAccumulator`."""
        accs = list(accumulators)
        counts = np.array(
            [(a.n, a.shadowed, a.captured, a.reimpact, a.rolling) for a in accs],
            dtype=np.int64,
        ).reshape(-1, 5)
        e = np.array(
            [(a.e.n, a.e.mean, a.e.m2, a.e.m3) for a in accs], dtype=float
        ).reshape(-1, 4)
        mu = np.array(
            [(a.mu.n, a.mu.mean, a.mu.m2, a.mu.m3) for a in accs], dtype=float
        ).reshape(-1, 4)
        e_spans = Spans.of((_span_of(a, "e") for a in accs), E_EDGES.size + 1)
        mu_spans = Spans.of((_span_of(a, "mu") for a in accs), MU_EDGES.size + 1)
        lat = np.array(
            [(a.lateral.n, a.lateral.mean, a.lateral.m2, a.lateral.m3) for a in accs],
            dtype=float,
        ).reshape(-1, 4)
        lat_spans = Spans.of((_span_of(a, "lateral") for a in accs), LATERAL_BINS)
        return cls(counts, e, mu, e_spans, mu_spans, lat, lat_spans)

    def __len__(self) -> int:
        return self.counts.shape[0]

    def accumulator(self, i: int) -> PointAccumulator:
        """Row `i` as a :class:`~.accumulators.PointAccumulator` (the same values:
        ``Stacked.of([acc]).accumulator(0) == acc``)."""
        return PointAccumulator(
            *self.counts[i].tolist(),
            e=Moments.from_array(self.e[i]),
            mu=Moments.from_array(self.mu[i]),
            e_span=self.e_spans.row(i),
            mu_span=self.mu_spans.row(i),
            lateral=Moments.from_array(self.lateral[i]),
            lateral_span=self.lateral_spans.row(i),
        )

    def narrow(self) -> Stacked:
        """The same rows with compact histogram counts (:meth:`Spans.narrow`)."""
        return Stacked(
            self.counts,
            self.e,
            self.mu,
            self.e_spans.narrow(),
            self.mu_spans.narrow(),
            self.lateral,
            self.lateral_spans.narrow(),
        )

    def slice(self, lo: int, hi: int) -> Stacked:
        """Rows ``lo .. hi - 1`` as views (no copy)."""
        return Stacked(
            self.counts[lo:hi],
            self.e[lo:hi],
            self.mu[lo:hi],
            self.e_spans.slice(lo, hi),
            self.mu_spans.slice(lo, hi),
            self.lateral[lo:hi],
            self.lateral_spans.slice(lo, hi),
        )

    def take(self, rows) -> Stacked:
        """The rows `rows` (integer indices, in that order)."""
        rows = np.asarray(rows, dtype=np.intp)
        if rows.size == len(self) and _is_range(rows):
            return self
        return Stacked(
            self.counts[rows],
            self.e[rows],
            self.mu[rows],
            self.e_spans.take(rows),
            self.mu_spans.take(rows),
            self.lateral[rows],
            self.lateral_spans.take(rows),
        )

    @classmethod
    def concat(cls, parts) -> Stacked:
        """The rows of several :class:`Stacked`, one after the other."""
        parts = list(parts)
        if len(parts) == 1:
            return parts[0]
        if not parts:
            return cls.of([])
        return cls(
            np.concatenate([p.counts for p in parts]),
            np.concatenate([p.e for p in parts]),
            np.concatenate([p.mu for p in parts]),
            Spans.concat(p.e_spans for p in parts),
            Spans.concat(p.mu_spans for p in parts),
            np.concatenate([p.lateral for p in parts]),
            Spans.concat(p.lateral_spans for p in parts),
        )


def _is_range(rows) -> bool:
    """`rows` is ``0, 1, ..., len - 1``."""
    return bool(
        rows.size == 0
        or (rows[0] == 0 and rows[-1] == rows.size - 1 and np.all(np.diff(rows) == 1))
    )


def _merge_zero(captured, e):
    """Moments of e_m over all impacts: `captured` zeros merged with the rebound
    moments `e` (Pebay 2008), element by element as ``Moments.merge`` does."""
    na = captured.astype(float)
    nb = e[:, 0]
    n = na + nb
    delta = e[:, 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = delta * nb / n
        m2 = e[:, 2] + delta * delta * na * nb / n
        m3 = e[:, 3] + np.power(delta, 3) * na * nb * (na - nb) / (n * n)
        m3 = m3 + 3.0 * delta * (na * e[:, 2] - nb * 0.0) / n
    only_b = na == 0
    only_a = nb == 0
    mean = np.where(only_b, e[:, 1], np.where(only_a, 0.0, mean))
    m2 = np.where(only_b, e[:, 2], np.where(only_a, 0.0, m2))
    m3 = np.where(only_b, e[:, 3], np.where(only_a, 0.0, m3))
    return np.stack([n, mean, m2, m3], axis=1)


def _mean_stats(m, z):
    """mean, std, se, ci_low, ci_high of moments rows `m` (n, mean, M2, M3)."""
    n, mean, m2 = m[:, 0], m[:, 1], m[:, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        var = np.where(n > 1, m2 / (n - 1), np.nan)
        std = np.sqrt(var)
        se = np.sqrt(var / n)
    mean = np.where(n > 0, mean, np.nan)
    se = np.where(n > 1, se, np.nan)
    return mean, std, se, mean - z * se, mean + z * se


def _pow15_python(m2, ok) -> np.ndarray:
    """``math.pow(m2, 1.5)`` where `ok`, else 1.0 (the fallback and oracle of
    ``_ckernel.pow_into``)."""
    return np.array(
        [
            math.pow(x, 1.5) if k else 1.0
            for x, k in zip(m2.tolist(), ok.tolist(), strict=True)
        ],
        dtype=float,
    )


def _skewness(m):
    n, m2, m3 = m[:, 0], m[:, 2], m[:, 3]
    ok = (n >= 3) & (m2 > 0)
    # M2^1.5 with the C library's pow, as Moments.skewness (NumPy's SIMD power
    # can differ in the last bit): in the compiled kernel, GIL released (a
    # Python loop held it ~1.8 ms for a 3,600-point grid), else math.pow
    ck = _compiled.ckernel
    pow_into = getattr(ck, "pow_into", None)
    if pow_into is not None:
        m2_15 = np.empty(m2.size)
        pow_into(np.ascontiguousarray(m2, dtype=float), 1.5, m2_15)
        m2_15 = np.where(ok, m2_15, 1.0)
    else:
        m2_15 = _pow15_python(m2, ok)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.sqrt(n) * m3 / m2_15
    return np.where(ok, g, np.nan)


def histogram_quantiles(hist, edges, q=QUANTILES) -> np.ndarray:
    """Quantiles of each row of `hist` (with under/overflow bins), linear within
    a bin; ``-inf``/``+inf`` when they fall in the under/overflow bin, NaN for an
    empty row. Returns shape ``(P, len(q))``.

    `hist` is a dense ``(P, bins)`` array or :class:`Spans`. Each row's cumulative
    fraction is its integer cumulative count over its total, as in the per-point
    definition (:func:`~.accumulators.histogram_quantile`): the quantile's bin is the
    number of bins whose fraction is below `q`. That number is found without forming
    the fractions: the fraction ``c / total`` (rounded) grows with the integer
    count ``c``, so the bins below `q` are those whose cumulative count is below the
    least ``c`` with ``c / total >= q`` (found per row and checked with the very
    division), located by a binary search in the cumulative counts of all rows.
    The work is one cumulative sum of the stored counts plus a few operations per
    row: a 10^4-point grid costs milliseconds.
    """
    spans = (
        hist
        if isinstance(hist, Spans)
        else Spans.of(
            (_span_of_dense(row) for row in np.asarray(hist)), np.asarray(hist).shape[1]
        )
    )
    q = np.asarray(q, dtype=float)
    if not np.all((q >= 0.0) & (q <= 1.0)):
        raise ValueError(f"quantiles must lie in [0, 1]; got {q.tolist()}")
    out = np.full((spans.rows, q.size), np.nan)
    if _span_quantiles_compiled(spans, edges, q, out):
        return out
    return _histogram_quantiles_numpy(spans, edges, q, out)


def _histogram_quantiles_numpy(spans: Spans, edges, q, out) -> np.ndarray:
    """:func:`histogram_quantiles` in NumPy, into `out` (NaN-filled): all rows
    at once (the form ``_ckernel.span_quantiles`` follows row by row, and its
    oracle in the tests)."""
    length, counts = spans.length, spans.counts
    ok = length > 0
    if not ok.any():
        return out
    rows = np.flatnonzero(ok)
    st = spans.start[ok]
    ln = length[ok]
    off = spans.offset[ok]
    # exact, and non-decreasing across all rows: in int32 when the whole sum fits
    # (cast first: a cumulative sum that casts as it goes is ~8x slower)
    small = counts.dtype.itemsize <= 4 and int(counts.sum(dtype=np.int64)) < 2**31
    counts = counts.astype(np.int32 if small else np.int64, copy=False)
    csum = np.cumsum(counts)
    base = csum[st] - counts[st]  # the count before each row
    total = csum[st + ln - 1] - base
    if int(total.max()) >= 2**52:  # pragma: no cover - beyond any feasible run
        return _histogram_quantiles_dense_search(spans, edges, q)
    if not total.all():  # a row with no counts: as an empty row
        keep = total > 0
        rows, st, ln, off, base, total = (
            a[keep] for a in (rows, st, ln, off, base, total)
        )
    tf = total.astype(float)
    for k, qk in enumerate(q):
        # least c in [0, total + 1] with float(c) / float(total) >= qk
        c = np.clip(np.floor(qk * tf), 0, tf + 1).astype(np.int64)
        while True:
            down = (c > 0) & ((c - 1) / tf >= qk)
            up = (c <= total) & ~(c / tf >= qk)
            if not (down.any() or up.any()):
                break
            c = c - down + up
        below = _row_search(csum, st, ln, base + c) - st
        out[rows, k] = _interpolate_quantile(
            qk,
            below,
            st,
            off,
            spans.size,
            edges,
            lambda r, at: (csum[at] - base[r]) / total[r],
        )
    return out


def _span_quantiles_compiled(spans: Spans, edges, q, out) -> bool:
    """:func:`histogram_quantiles` into `out` by the compiled kernel
    (``_ckernel.span_quantiles``: the same definitions and operations row by
    row, with the GIL released, and no cumulative sum of every stored bin);
    False where there is none, or a row's total needs the dense search."""
    ck, kind = _kernel_for(spans.counts)
    if ck is None or spans.rows == 0:
        return False
    try:
        ck.span_quantiles(
            np.ascontiguousarray(spans.counts),
            kind,
            np.ascontiguousarray(spans.start, dtype=np.int64),
            np.ascontiguousarray(spans.length, dtype=np.int64),
            np.ascontiguousarray(spans.offset, dtype=np.int64),
            int(spans.size),
            np.ascontiguousarray(edges, dtype=np.float64),
            np.ascontiguousarray(q, dtype=np.float64),
            out,
        )
    except OverflowError:  # pragma: no cover - a row of 2**52 counts or more
        out.fill(np.nan)
        return False
    return True


#: The count dtypes ``_ckernel.span_quantiles`` reads, by (kind, itemsize), as its
#: `kind` characters: uint8, uint16, int32, uint32, int64 (every
#: :func:`compact_counts` type and the kernel's own).
_SPAN_KINDS = {
    ("u", 1): "B",
    ("u", 2): "H",
    ("i", 4): "i",
    ("u", 4): "I",
    ("i", 8): "q",
}


def _kernel_for(counts):
    """``(ckernel, kind)`` for histogram `counts` (the compiled kernel and the
    counts' `kind` character), or ``(None, None)`` where there is no kernel or
    it does not read their dtype."""
    kind = _SPAN_KINDS.get((counts.dtype.kind, counts.dtype.itemsize))
    ck = _compiled.ckernel
    if ck is None or kind is None:
        return None, None
    return ck, kind


def _interpolate_quantile(qk, below, st, off, size, edges, cum):
    """Quantile `qk` of each row, linear within its bin, from `below` (the
    number of the row's stored bins whose cumulative fraction is below `qk`;
    ``searchsorted(dense cum, qk, side="left")`` is ``off + below``); ``cum(r,
    at)`` is the cumulative fraction of rows `r` at the stored places `at`."""
    i = off + below
    inner = (i > 0) & (i < size - 1)
    val = np.where(i == 0, -np.inf, np.inf)
    r = np.flatnonzero(inner)
    ji = below[r]
    at = st[r] + ji
    after = cum(r, at)
    before = np.where(ji > 0, cum(r, np.maximum(at - 1, 0)), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(after > before, (qk - before) / (after - before), 0.5)
    ii = i[r]
    lo, hi = edges[ii - 1], edges[ii]
    val[r] = lo + frac * (hi - lo)
    return val


def _row_search(values, start, length, keys):
    """Per row ``k``: the first index in ``[start[k], start[k] + length[k])`` whose
    value is not below ``keys[k]`` (``start + length`` if none), `values` sorted
    within each row. A bisection of all rows at once: its steps are the log of the
    longest row, and every access stays inside a row (a search of the whole array
    would wander through it)."""
    lo = start.copy()
    hi = start + length
    last = values.size - 1
    for _ in range(int(length.max()).bit_length()):
        mid = (lo + hi) >> 1
        go = lo < hi
        less = values[np.minimum(mid, last)] < keys
        lo = np.where(go & less, mid + 1, lo)
        hi = np.where(go & ~less, mid, hi)
    return lo


def _histogram_quantiles_dense_search(spans, edges, q) -> np.ndarray:
    """:func:`histogram_quantiles` by forming every cumulative fraction (the
    reference form; used only for totals beyond 2^52, where ``c / total`` can
    round equal for neighbouring counts)."""
    out = np.full((spans.rows, q.size), np.nan)
    start, length, counts = spans.start, spans.length, spans.counts
    ok = length > 0
    row = np.repeat(np.arange(spans.rows), length)
    csum = np.cumsum(counts, dtype=np.int64)
    st = start[ok]
    base = np.zeros(spans.rows, dtype=np.int64)
    base[ok] = csum[st] - counts[st]
    total = np.zeros(spans.rows, dtype=np.int64)
    total[ok] = csum[st + length[ok] - 1] - base[ok]
    with np.errstate(invalid="ignore", divide="ignore"):
        cum = (csum - base[row]) / total[row]
    rows = np.flatnonzero(ok)
    off = spans.offset[ok]
    for k, qk in enumerate(q):
        below = np.bincount(row[cum < qk], minlength=spans.rows)
        out[rows, k] = _interpolate_quantile(
            qk, below[ok], st, off, spans.size, edges, lambda _r, at: cum[at]
        )
    return out


def _span_of_dense(row):
    nz = np.flatnonzero(row)
    if nz.size == 0:
        return 0, row[:0]
    return int(nz[0]), row[nz[0] : nz[-1] + 1]


#: The tail rule (docs/outputs.md, "Heavy tails"): the rebounds farthest from the
#: mean, this fraction of them (at least one) ...
TAIL_FRACTION = 0.001
#: ... flag a point when they hold more than this share of the sum of squared
#: deviations (M2) of e_m or mu_m: the standard error, the interval and the
#: skewness then rest on them (a normal law gives 0.013, an exponential 0.049).
TAIL_SHARE_LIMIT = 0.25


def heavy_tail_flag(columns) -> np.ndarray:
    """1.0 where ``e_tail_share`` or ``mu_tail_share`` exceeds
    :data:`TAIL_SHARE_LIMIT`, 0.0 where neither does, NaN where neither is
    defined."""
    e = np.asarray(columns["e_tail_share"], float)
    mu = np.asarray(columns["mu_tail_share"], float)
    with np.errstate(invalid="ignore"):
        flag = np.fmax(e, mu) > TAIL_SHARE_LIMIT
    return np.where(np.isnan(e) & np.isnan(mu), np.nan, flag.astype(float))


def tail_pull(moments, spans: Spans, edges, fraction=TAIL_FRACTION):
    """How far the ``k = ceil(fraction n)`` values farthest from the mean pull it:
    ``(mean - mean without them)``, and the share of ``M2`` (the sum of squared
    deviations) they hold, per point, from the streaming moments and the
    histogram alone.

    Each in-range value is placed at its bin's centre (plus the bin's own spread
    ``w^2/12`` in the squares); the values outside the histogram's range (under-
    and overflow) are taken as the farthest, and their sums are exact: the moments
    give ``sum x`` and ``sum x^2`` over all values, the bins those over the in-range
    ones, and the difference is the out-of-range part. If more than ``k`` values
    are out of range, ``k`` times their mean is used (for the share, a lower
    bound). NaN where there are fewer than two values or ``M2 = 0``; the share is
    also NaN where the standard deviation is below the bin width (the histogram
    cannot resolve the spread: e.g. a smooth surface's sliding mu = 0.15 for every
    rebound).

    Parameters
    ----------
    moments : ndarray, shape (P, 4)
        ``n, mean, M2, M3`` per point.
    spans : Spans
        The histograms (with under/overflow bins) on `edges`.
    edges : ndarray
        Uniform bin edges.
    fraction : float

    Returns
    -------
    shift, share : ndarray, shape (P,)
    """
    shift = np.full(spans.rows, np.nan)
    share = np.full(spans.rows, np.nan)
    rows = np.flatnonzero(
        (moments[:, 0] > 1) & (moments[:, 2] > 0) & (spans.length > 0)
    )
    if rows.size == 0:
        return shift, share
    w = float(edges[1] - edges[0])
    width2 = w * w / 12.0
    size = spans.size
    counts = spans.counts  # read a few at a time, each cast to int64 (no wrap)
    n, mean, m2 = moments[rows, 0], moments[rows, 1], moments[rows, 2]
    st, ln, off = spans.start[rows], spans.length[rows], spans.offset[rows]
    # each row's in-range bins are one contiguous run of its stored span: the
    # underflow bin is dense index 0, the overflow bin the last
    has_under = off == 0
    has_over = off + ln == size
    ia = st + has_under
    ib = st + ln - has_over
    nin = np.maximum(ib - ia, 0)
    first_x = edges[0] + (off + has_under - 0.5) * w  # centre of the first one
    n_out = np.where(has_under, counts[st].astype(np.int64), 0) + np.where(
        has_over & (ln > has_under), counts[st + ln - 1].astype(np.int64), 0
    )
    n_out = n_out.astype(float)
    k = np.ceil(fraction * n)
    # the out-of-range values are the farthest; their sums are exact: the moments'
    # totals less the in-range bins' (computed for those rows only: few)
    d1_out = np.zeros(rows.size)
    d2_out = np.zeros(rows.size)
    for j in np.flatnonzero(n_out > 0).tolist():
        cj = counts[ia[j] : ib[j]].astype(float)
        xj = first_x[j] + w * np.arange(cj.size)
        s1_out = n[j] * mean[j] - cj @ xj
        s2_out = (m2[j] + n[j] * mean[j] ** 2) - cj @ (xj * xj + width2)
        d1_out[j] = s1_out - n_out[j] * mean[j]
        d2_out[j] = max(0.0, s2_out - 2.0 * mean[j] * s1_out + n_out[j] * mean[j] ** 2)
    used = np.minimum(k, n_out)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(n_out > 0, used / n_out, 0.0)  # k/n_out of them if more
    tail1 = d1_out * frac  # sums of (x - mean) and (x - mean)^2 over the tail
    tail2 = d2_out * frac
    need = k - used
    # the in-range values farthest from the mean: the distance |x - mean| falls
    # toward the mean from either end of the run, so they are taken bin by bin
    # from the two ends, the farther first (a tie: the left one); all rows at once,
    # for as many steps as the most bins any row needs (few: the tails are thin)
    left = np.zeros(rows.size, dtype=np.int64)
    right = nin - 1
    args = (ia, first_x, mean, w, width2, need, left, right, tail1, tail2)
    if not _tail_steps_compiled(counts, *args):
        _tail_steps_numpy(counts, *args)
    with np.errstate(invalid="ignore", divide="ignore"):
        # mean - mean of the others = sum over the tail of (x - mean) / (n - k)
        shift[rows] = np.where(n > k, tail1 / (n - k), np.nan)
        ok = m2 / n >= 12.0 * width2  # std >= one bin width
        share[rows] = np.where(ok, np.minimum(1.0, tail2 / m2), np.nan)
    return shift, share


def _tail_steps_numpy(
    counts, ia, first_x, mean, w, width2, need, left, right, tail1, tail2
) -> None:
    """The in-range steps of :func:`tail_pull`, all rows at once, for as many
    steps as the most bins any row needs (few: the tails are thin); `need`,
    `left`, `right`, `tail1` and `tail2` are updated in place (the form
    ``_ckernel.tail_steps`` follows row by row, and its oracle in the tests)."""
    active = np.flatnonzero((need > 0) & (left <= right))
    while active.size:
        mu_a = mean[active]
        dl = first_x[active] + w * left[active] - mu_a
        dr = first_x[active] + w * right[active] - mu_a
        use_r = np.abs(dr) > np.abs(dl)
        at = ia[active] + np.where(use_r, right[active], left[active])
        dev = np.where(use_r, dr, dl)
        take = np.minimum(need[active], counts[at].astype(np.int64))
        tail1[active] += take * dev
        tail2[active] += take * (dev * dev + width2)
        need[active] -= take
        right[active] -= use_r
        left[active] += ~use_r
        active = active[(need[active] > 0) & (left[active] <= right[active])]


def _tail_steps_compiled(
    counts, ia, first_x, mean, w, width2, need, left, right, tail1, tail2
) -> bool:
    """:func:`_tail_steps_numpy` by the compiled kernel (``_ckernel.tail_steps``,
    row by row with the GIL released: the same operations in the same order);
    False where there is none (`need`, `tail1`, `tail2` updated in place, not
    `left` and `right`)."""
    ck, kind = _kernel_for(counts)
    if ck is None:
        return False
    f64 = functools.partial(np.ascontiguousarray, dtype=np.float64)
    i64 = functools.partial(np.ascontiguousarray, dtype=np.int64)
    for a in (need, tail1, tail2):  # written in place: must be the arrays
        if a.dtype != np.float64 or not a.flags.c_contiguous:
            return False
    ck.tail_steps(
        np.ascontiguousarray(counts),
        kind,
        i64(ia),
        f64(first_x),
        f64(mean),
        float(w),
        float(width2),
        need,
        i64(left),
        i64(right),
        tail1,
        tail2,
    )
    return True


def tail_share(moments, spans: Spans, edges, fraction=TAIL_FRACTION) -> np.ndarray:
    """The share of ``M2`` held by the values farthest from the mean
    (:func:`tail_pull`)."""
    return tail_pull(moments, spans, edges, fraction)[1]


#: Points whose statistics :func:`point_statistics` computes together: it bounds
#: the temporaries (a cumulative sum of every stored bin, the tails' int64 counts)
#: to those of 65,536 points, whatever the sweep (each point's statistics depend
#: on its own row alone, so the values are the same).
STATISTICS_ROWS = 2**16


def point_statistics(
    stacked: Stacked, confidence: float, *, rows: int = STATISTICS_ROWS, want=None
) -> dict[str, np.ndarray]:
    """Every per-point summary statistic of plain Monte Carlo (``docs/outputs.md``).

    Computed for `rows` points at a time (views of `stacked`), into columns
    allocated once. Returns ``{column: array of length P}``. `want`: a set of
    column names; the histogram quantiles, the lateral statistics and the tail
    statistics are then computed only where one of their columns is wanted
    (the same values: issue 31, a design row or model run reads a few columns).
    The moments' columns are always there.
    """
    size = len(stacked)
    if size <= rows:
        return _point_statistics(stacked, confidence, want)
    out = {}
    for lo in range(0, size, rows):
        hi = min(size, lo + rows)
        part = _point_statistics(stacked.slice(lo, hi), confidence, want)
        for name, values in part.items():
            if name not in out:
                out[name] = np.empty(size, dtype=values.dtype)
            out[name][lo:hi] = values
    return out


#: The columns :func:`point_statistics` computes only where one is wanted.
QUANTILE_COLUMNS = {
    name: tuple(f"{name}_p{round(q * 100):02d}" for q in QUANTILES)
    for name in ("e", "mu")
}
LATERAL_QUANTILE_COLUMNS = tuple(
    f"lateral_p{round(q * 100):02d}_deg" for q in QUANTILES
)
LATERAL_COLUMNS = (
    "lateral_mean_deg",
    "lateral_std_deg",
    "lateral_se_deg",
    "lateral_ci_low_deg",
    "lateral_ci_high_deg",
    *LATERAL_QUANTILE_COLUMNS,
)
TAIL_COLUMNS = (
    "e_tail_share",
    "mu_tail_share",
    "e_tail_shift",
    "mu_tail_shift",
    "heavy_tail",
)


def _wanted(want, columns) -> bool:
    return want is None or not want.isdisjoint(columns)


def _point_statistics(
    stacked: Stacked, confidence: float, want=None
) -> dict[str, np.ndarray]:
    """:func:`point_statistics` of all rows of `stacked` at once."""
    z = z_value(confidence)
    c = stacked.counts
    n, shadowed, captured, reimpact, rolling = (c[:, k] for k in range(5))
    impacts = n - shadowed
    rebounds = impacts - captured
    low, high = wilson_interval(captured, impacts, confidence)
    e_all = _merge_zero(captured, stacked.e)
    e_mean, e_std, e_se, e_lo, e_hi = _mean_stats(e_all, z)
    er_mean, er_std, er_se, er_lo, er_hi = _mean_stats(stacked.e, z)
    mu_mean, mu_std, mu_se, mu_lo, mu_hi = _mean_stats(stacked.mu, z)
    with np.errstate(invalid="ignore", divide="ignore"):
        capture = np.where(impacts > 0, captured / impacts, np.nan)
        shadowed_fraction = np.where(n > 0, shadowed / n, np.nan)
        reimpact_fraction = np.where(rebounds > 0, reimpact / rebounds, np.nan)
        rolling_fraction = np.where(rebounds > 0, rolling / rebounds, np.nan)
    out = {
        "n": n,
        "n_impacts": impacts,
        "n_rebounds": rebounds,
        "capture_fraction": capture,
        "capture_ci_low": np.asarray(low, dtype=float),
        "capture_ci_high": np.asarray(high, dtype=float),
        "e_mean": e_mean,
        "e_std": e_std,
        "e_se": e_se,
        "e_ci_low": e_lo,
        "e_ci_high": e_hi,
        "e_rebound_mean": er_mean,
        "e_rebound_std": er_std,
        "e_rebound_se": er_se,
        "e_rebound_ci_low": er_lo,
        "e_rebound_ci_high": er_hi,
        "e_skewness": _skewness(stacked.e),
        "mu_mean": mu_mean,
        "mu_std": mu_std,
        "mu_se": mu_se,
        "mu_ci_low": mu_lo,
        "mu_ci_high": mu_hi,
        "mu_skewness": _skewness(stacked.mu),
        "shadowed_fraction": shadowed_fraction,
        "reimpact_fraction": reimpact_fraction,
        "rolling_fraction": rolling_fraction,
    }
    for name, hist, edges in (
        ("e", stacked.e_spans, E_EDGES),
        ("mu", stacked.mu_spans, MU_EDGES),
    ):
        if not _wanted(want, QUANTILE_COLUMNS[name]):
            continue
        qs = histogram_quantiles(hist, edges)
        for k, column in enumerate(QUANTILE_COLUMNS[name]):
            out[column] = qs[:, k]
    out["capture_se"] = interval_se(low, high, confidence)
    if _wanted(want, LATERAL_COLUMNS):
        _lateral_statistics(stacked, z, out)
    if _wanted(want, TAIL_COLUMNS):
        # heavy tails (docs/outputs.md): how far the 0.1 % of rebounds farthest
        # from the mean pull it, and the share of the spread they hold
        e_shift, e_share = tail_pull(stacked.e, stacked.e_spans, E_EDGES)
        mu_shift, mu_share = tail_pull(stacked.mu, stacked.mu_spans, MU_EDGES)
        out["e_tail_share"] = e_share
        out["mu_tail_share"] = mu_share
        out["e_tail_shift"] = e_shift
        out["mu_tail_shift"] = mu_shift
        out["heavy_tail"] = heavy_tail_flag(out)
    return out


def _lateral_statistics(stacked: Stacked, z: float, out: dict) -> None:
    """The folded lateral angle's columns of :func:`point_statistics` into `out`."""
    # the folded lateral angle psi_f [deg] over rebounds (docs/outputs.md)
    lat_mean, lat_std, lat_se, lat_lo, lat_hi = _mean_stats(stacked.lateral, z)
    out["lateral_mean_deg"] = lat_mean
    out["lateral_std_deg"] = lat_std
    out["lateral_se_deg"] = lat_se
    out["lateral_ci_low_deg"] = lat_lo
    out["lateral_ci_high_deg"] = lat_hi
    qs = histogram_quantiles(stacked.lateral_spans, LATERAL_EDGES)
    # a stream without spread (every rebound of a profile surface: psi_f = 0) has
    # its value as every quantile, not a point inside its 0.5 degree bin
    constant = (stacked.lateral[:, 0] > 0) & (stacked.lateral[:, 2] == 0.0)
    qs[constant] = stacked.lateral[constant, 1:2]
    for k, column in enumerate(LATERAL_QUANTILE_COLUMNS):
        out[column] = qs[:, k]


#: QMC: statistic -> (interval columns, SE column).
_REPLICATED = {
    "capture_fraction": ("capture_ci_low", "capture_ci_high", "capture_se"),
    "e_mean": ("e_ci_low", "e_ci_high", "e_se"),
    "e_rebound_mean": ("e_rebound_ci_low", "e_rebound_ci_high", "e_rebound_se"),
    "mu_mean": ("mu_ci_low", "mu_ci_high", "mu_se"),
    "lateral_mean_deg": (
        "lateral_ci_low_deg",
        "lateral_ci_high_deg",
        "lateral_se_deg",
    ),
}


def replicate_statistics(
    pooled: Stacked, replicates: Stacked, n_replicates: int, confidence: float
) -> dict[str, np.ndarray]:
    """QMC statistics: :func:`point_statistics` of the pooled accumulators, with the
    intervals and SEs of the four main statistics from the spread of the
    `n_replicates` independent scrambles (``replicates`` rows are point-major:
    row ``p * R + r``)."""
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.stats import t as student_t

    out = point_statistics(pooled, confidence)
    reps = point_statistics(replicates, confidence)
    r = n_replicates
    tq = float(student_t.ppf(0.5 + confidence / 2.0, r - 1))
    # a pooled capture fraction of exactly 0 or 1 has replicates that all agree:
    # their spread (0) is no interval, so the pooled counts' Wilson interval (the
    # plain Monte Carlo one, never narrower than the counts allow) stands there
    wilson = {
        "lo": out["capture_ci_low"].copy(),
        "hi": out["capture_ci_high"].copy(),
        "se": out["capture_se"].copy(),
    }
    for stat, (lo, hi, se_name) in _REPLICATED.items():
        vals = reps[stat].reshape(-1, r)
        se = np.std(vals, axis=1, ddof=1) / np.sqrt(r)
        out[lo] = out[stat] - tq * se
        out[hi] = out[stat] + tq * se
        out[se_name] = se
    c = out["capture_fraction"]
    edge = (c == 0.0) | (c == 1.0)
    out["capture_ci_low"] = np.where(
        edge, wilson["lo"], np.clip(out["capture_ci_low"], 0, 1)
    )
    out["capture_ci_high"] = np.where(
        edge, wilson["hi"], np.clip(out["capture_ci_high"], 0, 1)
    )
    out["capture_se"] = np.where(edge, wilson["se"], out["capture_se"])
    out["replicates"] = np.full(pooled.counts.shape[0], r, dtype=np.int64)
    return out


def relative_to_reference(values, se, angle_axis_values, reference_angle_deg):
    """The paper's relative coefficient ``x - x(θ_ref)`` on a grid whose last axis is
    the apparent angle, with its standard error.

    The two estimates at different angles are independent, so their SEs combine in
    quadrature; at the reference angle itself the difference is exactly 0 with
    SE 0. NaN everywhere if the reference angle is not swept.
    """
    angles = np.asarray(angle_axis_values, dtype=float)
    hit = np.flatnonzero(np.isclose(angles, reference_angle_deg))
    if hit.size == 0:
        return np.full(values.shape, np.nan), np.full(values.shape, np.nan)
    k = int(hit[0])
    ref = values[..., k : k + 1]
    ref_se = se[..., k : k + 1]
    rel = values - ref
    rel_se = np.hypot(se, ref_se)
    rel[..., k] = np.where(np.isnan(values[..., k]), np.nan, 0.0)
    rel_se[..., k] = np.where(np.isnan(values[..., k]), np.nan, 0.0)
    return rel, rel_se
