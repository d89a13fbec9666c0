"""Equiprobable quantile tables: the fast sampler behind every random input.

A distribution with quantile function :math:`F^{-1}` is replaced by ``M`` equiprobable
atoms placed at the mid-probabilities of a uniform grid,

.. math:: x_j = F^{-1}\\big((j + 1/2)/M\\big), \\qquad j = 0, \\dots, M-1,

and a draw is ``x[floor(u * M)]`` for a uniform ``u`` (or an index taken straight from
the high bits of a random integer). This is an inverse-CDF sampler on a uniform
probability grid: no ``np.interp`` (~7x slower than a table lookup), no search, one
gather per draw. Quantities that depend only on the drawn value (``k1(d)``,
``sin(phi)``, ...) can be tabulated on the same atoms and gathered with the same index.

Accuracy: the Kolmogorov-Smirnov distance between the table and the target is at most
``1/(2M)`` (``7.6e-6`` for the default ``M = 2**16``); only the extreme tail beyond the
last mid-probability ``1 - 1/(2M)`` is not represented. For an empirical (discrete)
sample the atoms are the sample's own values, so nothing is smoothed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: log2 of the default number of atoms.
TABLE_BITS = 16
#: Default number of equiprobable atoms.
TABLE_SIZE = 1 << TABLE_BITS
#: Probabilities per call of a quantile function in :meth:`QuantileTable.from_ppf`.
PPF_SLICE = 4096


def mid_probabilities(size: int = TABLE_SIZE) -> np.ndarray:
    """The ``size`` mid-probabilities ``(j + 1/2) / size``."""
    return (np.arange(size, dtype=float) + 0.5) / size


@dataclass(frozen=True, eq=False)
class QuantileTable:
    """``M`` equiprobable atoms of a one-dimensional distribution.

    Attributes
    ----------
    values : ndarray, shape (M,)
        The atoms, non-decreasing, in SI units.
    """

    values: np.ndarray

    def __post_init__(self):
        v = np.ascontiguousarray(self.values, dtype=float)
        if v.ndim != 1 or v.size == 0:
            raise ValueError("`values` must be a non-empty 1-d array.")
        if v.size & (v.size - 1):
            raise ValueError(f"table size must be a power of two; got {v.size}.")
        if not np.all(np.isfinite(v)):
            raise ValueError("quantile table has non-finite atoms.")
        v.setflags(write=False)
        object.__setattr__(self, "values", v)

    @property
    def size(self) -> int:
        return self.values.size

    @property
    def bits(self) -> int:
        return self.values.size.bit_length() - 1

    @classmethod
    def from_ppf(cls, ppf, *, size: int = TABLE_SIZE) -> QuantileTable:
        """Tabulate a vectorised, element-wise quantile function ``ppf(q)``.

        It is evaluated in slices of :data:`PPF_SLICE` probabilities, so that the
        temporaries of SciPy's quantile functions stay small (a whole-table call of
        ``truncnorm.ppf`` peaks at ~16 MiB); the values do not depend on the slicing.
        """
        q = mid_probabilities(size)
        out = np.empty(q.size)
        for i in range(0, q.size, PPF_SLICE):
            out[i : i + PPF_SLICE] = ppf(q[i : i + PPF_SLICE])
        return cls(out)

    @classmethod
    def from_sample(cls, sample, *, size: int = TABLE_SIZE) -> QuantileTable:
        """Atoms of the empirical (discrete) distribution of `sample`.

        Atom ``j`` is the sample's order statistic ``x_(k)`` with
        ``k = floor((j + 1/2) n / M)``: the exact empirical quantile, so the table draws
        the sample's own values with equal probability (up to ``1/M``).
        """
        s = np.sort(np.asarray(sample, dtype=float).ravel())
        if s.size == 0:
            raise ValueError("cannot build a quantile table from an empty sample.")
        k = np.floor(mid_probabilities(size) * s.size).astype(np.intp)
        return cls(s[np.minimum(k, s.size - 1)])

    @classmethod
    def from_weights(cls, atoms, weights, *, size: int = TABLE_SIZE) -> QuantileTable:
        """Re-discretise a weighted discrete distribution into equiprobable atoms.

        Atom ``j`` is the weighted quantile at mid-probability ``(j + 1/2)/M``.
        """
        x = np.asarray(atoms, dtype=float).ravel()
        w = np.asarray(weights, dtype=float).ravel()
        if x.shape != w.shape:
            raise ValueError("`atoms` and `weights` must have the same length.")
        if np.any(w < 0) or not np.isfinite(w).all():
            raise ValueError("`weights` must be finite and >= 0.")
        order = np.argsort(x, kind="stable")
        x, w = x[order], w[order]
        total = w.sum()
        if not total > 0:
            raise ValueError("`weights` sum to zero: nothing to sample.")
        cw = np.cumsum(w) / total
        k = np.searchsorted(cw, mid_probabilities(size), side="right")
        return cls(x[np.minimum(k, x.size - 1)])

    def indices(self, u) -> np.ndarray:
        """Table indices for uniforms ``u`` in [0, 1)."""
        idx = (np.asarray(u, dtype=float) * self.size).astype(np.intp)
        return np.clip(idx, 0, self.size - 1, out=idx)

    def ppf(self, q) -> np.ndarray:
        """The table's own quantile function (a step function)."""
        return self.values[self.indices(q)]

    def sample(self, n: int, *, rng=None, out=None) -> np.ndarray:
        """Draw `n` values with the generator `rng` (SPEC 7)."""
        rng = np.random.default_rng(rng)
        idx = rng.integers(0, self.size, size=n, dtype=np.intp)
        return np.take(self.values, idx, out=out)

    def mean(self) -> float:
        """Mean of the atoms."""
        return float(self.values.mean())

    def std(self) -> float:
        """Standard deviation of the atoms (``ddof=0``)."""
        return float(self.values.std())


# ----------------------------------------------------------------- cell tables
#: Dyadic levels per side of a refined quantile grid: the probabilities
#: ``[2^-(k+2), 2^-(k+1))`` for ``k = 0 .. GRID_LEVELS - 1`` each hold
#: :data:`GRID_CELLS` cells, so the relative probability resolution is the same in
#: the body and in both tails (down to ``2^-(GRID_LEVELS+1)``, about 4.5e-13).
GRID_LEVELS = 40
#: Cells per dyadic level (the cell width relative to its probability is at most
#: ``1/GRID_CELLS``).
GRID_CELLS = 512
#: Largest log2 size of the guide table of a :class:`CellTable`.
GUIDE_BITS_MAX = 16
#: Flag bit of a guide entry: the slot holds the start of another cell.
GUIDE_SEARCH = np.uint32(1 << 31)
_TWO64 = float(2**64)
#: Largest double below 2^64 (integer probabilities are clamped to it).
_TOP = np.nextafter(_TWO64, 0.0)


def refined_probabilities(levels: int = GRID_LEVELS, cells: int = GRID_CELLS):
    """Nodes ``(p, s)`` of the refined grid, ``s = 1 - p`` (both exact dyadics).

    Increasing ``p`` from 0 to 1: ``cells`` nodes per dyadic level in each half,
    uniform within the level, geometric from level to level.
    """
    j = np.arange(cells, dtype=float)
    lower = [2.0 ** -(k + 2) * (1.0 + j / cells) for k in range(levels)]
    half = np.concatenate([[0.0], *lower[::-1]])  # 0, deepest level, ..., < 1/2
    p = np.concatenate([half, [0.5], 1.0 - half[::-1]])
    s = np.concatenate([1.0 - half, [0.5], half[::-1]])
    return p, s


@dataclass(frozen=True, eq=False)
class CellTable:
    """A sampler that is exact in probability: cells of known mass, linear inside.

    Cell ``j`` holds the probability ``[cum[j], cum[j+1]) / 2^64`` (64-bit integers:
    the cumulative error of the cell probabilities is below ``2^-64``) and the values
    from ``left[j]`` to ``right[j]``. A 64-bit uniform integer ``r`` selects the cell
    with ``cum[j] <= r < cum[j+1]`` and the fraction ``f = (r - cum[j]) * inv_width[j]``
    in [0, 1); the value is ``left + f * (right - left)``: inverse-CDF sampling of a
    piecewise-linear quantile function, i.e. of a density that is constant within
    each cell. A discrete distribution is a table of zero-length cells
    (``left == right``): its atoms are drawn with their exact probabilities and
    nothing is interpolated.

    The continuous distributions are tabulated on :func:`refined_probabilities`
    (:meth:`from_quantile`): the quantile function is exact at every node and
    the CDF error inside a cell of probability width ``h`` is about
    ``h^2 |f'| / (8 f^2)``, a relative error below ``1 / (8 GRID_CELLS^2)`` in the
    tails.

    Attributes
    ----------
    cum : ndarray of uint64, shape (n + 1,)
        Cell starts ``cum[0] = 0 < cum[1] < ...``, then a sentinel ``2^64 - 1``
        (the last cell ends at ``2^64``).
    inv_width : ndarray, shape (n,)
        ``1 / (cum[j+1] - cum[j])`` (the fraction's scale; ``cum[n] = 2^64``).
    left, right : ndarray, shape (n,)
        Values at the two ends of each cell.
    guide : ndarray of uint32, shape (2^g + 1,)
        ``guide[t]`` (without its flag bit :data:`GUIDE_SEARCH`) is the cell holding
        ``t << (64 - g)``, and ``guide[2^g] = n - 1``: the cell of ``r`` is in
        ``[guide[r >> (64-g)], guide[(r >> (64-g)) + 1]]``. The flag is set where
        that range holds more than one cell; elsewhere the guide entry is the
        answer.
    guide_shift : int
        ``64 - g``.
    kind : int
        How the compiled kernel finds a cell (:data:`GENERAL`, :data:`EQUAL`,
        :data:`DYADIC`); every kind gives the cell :meth:`locate` gives.
    """

    cum: np.ndarray
    inv_width: np.ndarray
    left: np.ndarray
    right: np.ndarray
    guide: np.ndarray
    guide_shift: int
    kind: int = 0
    levels: int = 0
    cells_log2: int = 0

    #: :attr:`kind`: cells found through the guide (any cell probabilities)
    GENERAL = 0
    #: :attr:`kind`: ``n`` equal cells, the cell of ``r`` is ``floor(r n / 2^64)``
    EQUAL = 1
    #: :attr:`kind`: exactly :func:`refined_probabilities` (``levels``,
    #: ``2^cells_log2``): the cell follows from the position of the leading bit
    DYADIC = 2

    @property
    def size(self) -> int:
        """Number of cells."""
        return self.left.size

    @property
    def starts(self) -> np.ndarray:
        """``cum[:n]``, the cell starts (uint64)."""
        return self.cum[:-1]

    def widths(self) -> np.ndarray:
        """Cell probabilities (float64, from the exact integer widths)."""
        w = _integer_widths(self.starts).astype(float)
        if self.starts[-1] == 0:
            w[-1] = _TWO64
        return w / _TWO64

    def probabilities(self) -> np.ndarray:
        """Cell starts as probabilities (float64, rounded)."""
        return self.starts.astype(float) / _TWO64

    # -- construction ---------------------------------------------------------------
    @classmethod
    def from_cells(
        cls, cum, left, right, *, scale=None, kind=0, levels=0, cells_log2=0
    ) -> CellTable:
        """Table of cells starting at the integers `cum` (uint64, increasing from 0,
        zero-length cells dropped) with values `left`, `right`; `scale` optionally
        multiplies each cell's fraction (a cell used only on ``[0, scale)``)."""
        cum = np.asarray(cum, dtype=np.uint64)
        left = np.asarray(left, dtype=float)
        right = np.asarray(right, dtype=float)
        keep = nonempty_cells(cum)
        if cum.size == 0 or cum[0] != 0 or np.any(cum[1:] < cum[:-1]):
            raise ValueError("cell starts must increase from 0 (internal).")
        cum, left, right = cum[keep], left[keep], right[keep]
        if scale is not None:
            scale = np.asarray(scale, dtype=float)[keep]
        n = cum.size
        w = _integer_widths(cum).astype(float)  # exact widths, then rounded
        if n == 1:
            w[0] = _TWO64  # the one cell: its width 2^64 wrapped to 0
        iw = 1.0 / w
        if scale is not None:
            iw *= scale
        if kind and not keep.all():
            kind = levels = cells_log2 = 0  # cells dropped: search the guide
        # the arithmetic kinds need no guide (a minimal one keeps the layout)
        bits = 4
        if not kind:
            bits = int(min(GUIDE_BITS_MAX, max(4, np.ceil(np.log2(n)) + 4)))
        t = np.arange(1 << bits, dtype=np.uint64) << np.uint64(64 - bits)
        first = np.searchsorted(cum, t, side="right") - 1
        last = np.searchsorted(cum, t | np.uint64(2 ** (64 - bits) - 1), "right") - 1
        guide = np.empty((1 << bits) + 1, dtype=np.uint32)
        guide[:-1] = first
        guide[:-1] |= np.where(last > first, GUIDE_SEARCH, np.uint32(0))
        guide[-1] = n - 1
        full = np.empty(n + 1, dtype=np.uint64)
        full[:-1] = cum
        full[-1] = np.uint64(2**64 - 1)
        for a in (full, iw, left, right, guide):
            a.setflags(write=False)
        return cls(full, iw, left, right, guide, 64 - bits, kind, levels, cells_log2)

    @classmethod
    def from_quantile(
        cls,
        ppf,
        isf=None,
        *,
        breaks=(),
        levels: int = GRID_LEVELS,
        cells: int = GRID_CELLS,
    ) -> CellTable:
        """Tabulate a continuous quantile function on the refined grid.

        Parameters
        ----------
        ppf : callable
            Vectorised quantile function, used for ``p <= 1/2``.
        isf : callable, optional
            Inverse survival function, used for ``p > 1/2`` (as ``isf(1 - p)``, so
            the upper tail keeps its relative accuracy); without it ``ppf(1 - s)``
            (accurate to ~1e-16 in absolute probability, which is all the sampler
            needs).
        breaks : sequence of float
            Extra node probabilities, e.g. where the quantile function has a kink
            (the bin edges of a histogram), so that no cell straddles one.

        Notes
        -----
        The outermost cells (``p < 2^-(levels+1)`` and ``1 - p < 2^-(levels+1)``) are
        atoms at their mid-probabilities (a CDF error below ``2^-(levels+2)``, about
        2e-13 with the defaults).
        """
        p, s = refined_probabilities(levels, cells)
        b = np.asarray(breaks, dtype=float).ravel()
        b = b[(b > 0.0) & (b < 1.0)]
        if b.size:
            p = np.concatenate([p, b])
            s = np.concatenate([s, 1.0 - b])
            order = np.argsort(p, kind="stable")
            p, s = p[order], s[order]
        x = _evaluate_nodes(ppf, isf, p, s)
        # the outermost cells (probability 2^-(levels+1) each) are atoms at their
        # mid-probability: the ends of the support may be infinite, or singular for
        # a derived quantity (v_c(d) at d = 0)
        ends = _evaluate_nodes(
            ppf, isf, np.array([p[1] / 2, 1.0 - s[-2] / 2]), np.array([1.0, s[-2] / 2])
        )
        x[0], x[-1] = ends
        if not np.all(np.isfinite(x)):
            raise ValueError("the quantile function is not finite on (0, 1).")
        x = np.maximum.accumulate(x)
        cum = _integer_probabilities(p[:-1], s[:-1])
        left, right = x[:-1].copy(), x[1:].copy()
        right[0], left[-1] = left[0], right[-1]
        dyadic = (
            b.size == 0
            and cells & (cells - 1) == 0
            and levels - 1 + cells.bit_length() - 1 <= 62
        )
        if not dyadic:
            return cls.from_cells(cum, left, right)
        return cls.from_cells(
            cum,
            left,
            right,
            kind=cls.DYADIC,
            levels=levels,
            cells_log2=cells.bit_length() - 1,
        )

    @classmethod
    def from_atoms(cls, atoms, weights=None) -> CellTable:
        """The discrete distribution on `atoms` (equal masses, or `weights`), exactly:
        each atom a zero-length cell (with weights, equal atoms merged; with equal
        masses, cell ``j`` is the ``j``-th smallest atom and holds the draws with
        ``floor(r n / 2^64) = j``)."""
        x = np.asarray(atoms, dtype=float).ravel()
        if x.size == 0 or not np.all(np.isfinite(x)):
            raise ValueError("atoms must be a non-empty array of finite values.")
        if weights is None:
            x = np.sort(x)
            if x.size >= 2**31:
                raise ValueError("too many atoms (at most 2^31 - 1).")
            cum = _equal_starts(np.arange(x.size), x.size)
            return cls.from_cells(cum, x, x, kind=cls.EQUAL)
        w = np.asarray(weights, dtype=float).ravel()
        if w.shape != x.shape or np.any(w < 0) or not np.isfinite(w).all():
            raise ValueError("`weights` must be finite, >= 0, one per atom.")
        order = np.argsort(x, kind="stable")
        x, w = x[order], w[order]
        if not w.sum() > 0:
            raise ValueError("`weights` sum to zero: nothing to sample.")
        keep = w > 0
        x, w = x[keep], w[keep]
        start = np.flatnonzero(np.r_[True, x[1:] != x[:-1]])
        c = np.cumsum(w)
        before = np.r_[0.0, c[:-1]][start]
        cum = fraction_to_integer(before / c[-1])
        v = x[start]
        return cls.from_cells(cum, v, v)

    # -- evaluation -----------------------------------------------------------------
    def cells(self, r) -> np.ndarray:
        """The cell of each 64-bit draw `r`: ``cum[j] <= r < cum[j+1]``."""
        r = np.asarray(r, dtype=np.uint64)
        if self.kind == self.EQUAL:
            return mulhi64(r, self.size).astype(np.intp)
        if self.kind == self.DYADIC:
            return self._dyadic_cells(r)
        return np.searchsorted(self.starts, r, side="right") - 1

    def _dyadic_cells(self, r) -> np.ndarray:
        """The refined grid's cell from the draw's leading bit (what the compiled
        kernel does; the same cells as a search of ``cum``)."""
        up = (r >> np.uint64(63)).astype(bool)
        big = np.where(up, ~r, r)  # the upper half mirrored: < 2^63
        levels, cbits = self.levels, self.cells_log2
        # the leading bit: from the float exponent, corrected where it rounded up
        lead = np.frexp(big.astype(float))[1].astype(np.int64) - 1
        lead = np.maximum(lead, 0)
        lead -= (big >> lead.astype(np.uint64)) == 0
        lead = np.maximum(lead, 0)
        k = np.minimum(62 - lead, levels - 1)  # the level
        sub = (big >> (62 - k - cbits).astype(np.uint64)) & np.uint64((1 << cbits) - 1)
        cell = 1 + ((levels - 1 - k) << cbits) + sub.astype(np.int64)
        cell[(big >> np.uint64(63 - levels)) == 0] = 0  # the outermost cell
        return np.where(up, self.size - 1 - cell, cell).astype(np.intp)

    def locate(self, r) -> tuple[np.ndarray, np.ndarray]:
        """``(cell, fraction)`` of 64-bit uniform integers `r` (what the kernels do)."""
        r = np.asarray(r, dtype=np.uint64)
        j = self.cells(r)
        f = (r - self.cum[j]).astype(float)
        f *= self.inv_width[j]
        return j, f

    def interpolate(self, lo, hi, r) -> np.ndarray:
        """Per-cell linear columns `lo`, `hi` at the draws `r`."""
        j, f = self.locate(r)
        lo, span = linear_columns(lo, hi)
        return lo[j] + f * span[j]

    def quantile(self, q) -> np.ndarray:
        """The table's own quantile function at probabilities `q` in [0, 1)."""
        return self.interpolate(self.left, self.right, fraction_to_integer(q))

    def probability_at_least(self, lo, hi, value) -> float:
        """Exact probability (to ~1e-16) that the column interpolated from `lo` to
        `hi` in each cell is ``>= value``: what the table assigns to that event."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        w = self.widths()
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (value - lo) / (hi - lo)  # the crossing fraction
        flat = hi == lo
        rising = hi > lo
        frac = np.where(
            flat,
            (lo >= value).astype(float),
            np.where(rising, 1.0 - np.clip(t, 0.0, 1.0), np.clip(t, 0.0, 1.0)),
        )
        return float(np.sum(w * frac))


def nonempty_cells(cum) -> np.ndarray:
    """Mask of the cells of positive probability among cells starting at `cum`
    (what :meth:`CellTable.from_cells` keeps)."""
    keep = np.ones(len(cum), dtype=bool)
    keep[:-1] = cum[1:] > cum[:-1]
    return keep


def linear_columns(lo, hi):
    """``(lo, hi - lo)`` for the kernels' ``lo + f * span`` (span 0 where the cell is
    an atom or an end is not finite)."""
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    with np.errstate(invalid="ignore"):
        span = np.where((hi == lo) | ~np.isfinite(lo) | ~np.isfinite(hi), 0.0, hi - lo)
    return lo, span


def _evaluate_nodes(ppf, isf, p, s):
    """Quantiles at nodes ``p`` (``s = 1 - p`` given accurately for the upper half),
    in slices of :data:`PPF_SLICE`."""
    out = np.empty(p.size)
    with np.errstate(all="ignore"):
        for i in range(0, p.size, PPF_SLICE):
            pp = p[i : i + PPF_SLICE]
            upper = pp > 0.5
            v = np.empty(pp.size)
            if np.any(~upper):
                v[~upper] = ppf(pp[~upper])
            if np.any(upper):
                ss = s[i : i + PPF_SLICE][upper] if s is not None else 1.0 - pp[upper]
                v[upper] = isf(ss) if isf is not None else ppf(1.0 - ss)
            out[i : i + PPF_SLICE] = v
    return out


def _integer_widths(cum) -> np.ndarray:
    """Exact cell widths ``cum[j+1] - cum[j]`` (uint64; the last cell ends at 2^64,
    its width wraps to 0 when it is the only cell)."""
    with np.errstate(over="ignore"):
        return np.diff(np.append(cum, np.uint64(0)))


def fraction_to_integer(x) -> np.ndarray:
    """Probabilities in [0, 1) as 64-bit integers ``round(x * 2^64)``."""
    return np.minimum(np.asarray(x, dtype=float) * _TWO64, _TOP).astype(np.uint64)


def _integer_probabilities(p, s) -> np.ndarray:
    """Nodes ``(p, s = 1 - p)`` as integers: ``p * 2^64`` in the lower half and
    ``2^64 - s * 2^64`` in the upper (both exact for the dyadic grid)."""
    lower = p <= 0.5
    out = np.empty(p.size, dtype=np.uint64)
    out[lower] = fraction_to_integer(p[lower])
    out[~lower] = np.uint64(0) - fraction_to_integer(s[~lower])  # 2^64 - s 2^64
    return np.maximum.accumulate(out)


def _equal_starts(start, n) -> np.ndarray:
    """``ceil(start * 2^64 / n)`` exactly, for integer indices ``start < n``: the
    smallest ``r`` with ``floor(r n / 2^64) = start``."""
    k = np.asarray(start, dtype=np.uint64)
    if n == 1:
        return np.zeros(1, dtype=np.uint64)
    q, r = divmod(2**64, int(n))
    if n > 2**32:
        return np.array([-((-int(i) << 64) // n) for i in k], dtype=np.uint64)
    with np.errstate(over="ignore"):
        kr = k * np.uint64(r)  # < n^2 <= 2^64
        up = (kr + np.uint64(n - 1)) // np.uint64(n)
        return k * np.uint64(q) + up


def mulhi64(a, b) -> np.ndarray:
    """``floor(a * b / 2^64)`` for uint64 arrays/scalars (exact, 32-bit halves):
    the compiled kernel's 128-bit multiply-high."""
    a = np.asarray(a, dtype=np.uint64)
    b = np.asarray(b, dtype=np.uint64)
    m = np.uint64(0xFFFFFFFF)
    s32 = np.uint64(32)
    a_lo, a_hi = a & m, a >> s32
    b_lo, b_hi = b & m, b >> s32
    cross = ((a_lo * b_lo) >> s32) + ((a_hi * b_lo) & m) + a_lo * b_hi
    return ((a_hi * b_lo) >> s32) + (cross >> s32) + a_hi * b_hi
