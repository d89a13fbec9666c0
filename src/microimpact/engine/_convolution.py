r"""The exact table of the sum of two independent roughness angles.

A rough particle's own roughness angle adds to the surface's,
:math:`\phi = \phi_s + \phi_p` (the paper's *Lycopodium* case). When both are
discrete with equal masses the engine draws the pair exactly
(:class:`~microimpact.engine.plan.PairSampler`); otherwise the law of the sum is
tabulated here as a :class:`~microimpact._core.tables.CellTable` on the refined grid,
exact at its nodes to far below 0.1 standard error at 10⁹ impacts:

* **discrete + continuous** (atoms :math:`y_i`, weights :math:`w_i`; continuous
  :math:`C`): the sum's CDF is the mixture :math:`F(x) = \sum_i w_i F_C(x - y_i)`
  and its survival function :math:`S(x) = \sum_i w_i S_C(x - y_i)`, each a sum of
  positive terms from the distribution's own ``cdf`` and ``sf`` (so both tails keep
  their relative accuracy);
* **continuous + continuous**: :math:`F(x) = \int_0^1 F_A(x - Q_B(u))\,du`, with
  ``B`` the narrower of the two (the integrand is then smooth on the scale of
  ``A``), by Gauss–Legendre quadrature in probability on sub-intervals that are
  uniform in the body and dyadic into both tails (down to :math:`2^{-60}`; ``Q_B``
  from ``ppf`` below 1/2 and ``isf`` above): a mixture as above with the quadrature
  nodes as atoms;
* **discrete + discrete** (weighted shadowing, or unequal masses) with at most
  :data:`MAX_SUM_ATOMS` pairs: the exact discrete law of the sums (weights
  :math:`w_i v_j`, equal sums merged). Larger products are drawn exactly as
  pairs by a search (:class:`~microimpact.engine.plan.PairSearch`); the reduced
  convolution (:func:`reduced_convolution`, :data:`REDUCED_ATOMS` equiprobable
  atoms each, Kolmogorov distance up to ~1/1024) is left only for objects without
  atoms or the continuous protocol.

A discrete + continuous law whose density jumps at the ends of its support fails
the inversion check; its table is then built on nodes at every jump with exact
probabilities (:func:`exact_node_table`).

The quantile function is found by inverting the mixture: its ``log F`` (lower half)
and ``log S`` (upper half) and their derivatives ``f/F``, ``-f/S`` are computed
exactly on a uniform grid of spacing ``h = scale / GRID_PER_SCALE`` (``scale`` the
IQR/1.349 of the continuous part kept exact), which brackets every node; inside
the bracketing interval a cubic Hermite interpolant of ``log F`` is solved by
safeguarded Newton iterations. The build then checks itself: the exact CDF (SF) at
every :data:`CHECK_STRIDE`-th node of the refined grid must be within
:data:`CHECK_FRACTION` of 0.1 standard error at 10⁹ impacts of the target
probability; if not, the grid is refined (halved, up to :data:`MAX_REFINE` times).

The sum is not truncated here: as for every angle table, values outside
(-90°, 90°) are clipped to the largest angles inside by the engine's angle sampler
(each input distribution is already restricted to (-90°, 90°); the sum's mass
beyond ±90° sits at ±90°, where a facet is unreachable or grazing).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .._core.tables import (
    CellTable,
    _integer_probabilities,
    mid_probabilities,
    refined_probabilities,
)
from ._cells import cell_table

#: Grid points of the inversion grid per scale of the continuous part.
GRID_PER_SCALE = 32
#: Largest inversion grid (points).
MAX_GRID = 1 << 16
#: Refinements (halvings of the grid spacing) tried when the check fails.
MAX_REFINE = 2
#: Every how many refined-grid nodes the build checks the exact CDF.
CHECK_STRIDE = 64
#: The checked nodes must be within this fraction of 0.1 SE at 1e9 impacts.
CHECK_FRACTION = 0.01
#: In-cell errors of an exact-node table (:func:`exact_node_table`) must be within
#: this fraction of 0.1 SE at 1e9 impacts.
CELL_CHECK_FRACTION = 0.5
#: Geometric nodes (levels of halving, nodes per level) into the outermost jumps
#: of an exact-node table.
GEO_LEVELS, GEO_PER_LEVEL = 44, 8
#: Impacts the check's standard error refers to.
CHECK_N = 1e9
#: Gauss–Legendre order and sub-intervals of the quadrature of the narrower law.
QUAD_ORDER = 8
QUAD_BODY = 32  # sub-intervals of [1/4, 3/4]
QUAD_PER_BAND = 2  # sub-intervals per dyadic band [2^-(k+2), 2^-(k+1)]
QUAD_BANDS = 58  # bands per side: down to 2^-60
#: Largest number of (surface, particle) pairs whose discrete sum is tabulated
#: exactly (its rows: ~70 bytes a pair, per apparent angle for "weighted").
MAX_SUM_ATOMS = 1 << 18
#: Atoms per distribution of the reduced convolution (the fallback).
REDUCED_ATOMS = 1024
#: Elements per block of the mixture evaluation.
_BLOCK = 1 << 19
#: Smallest probability (and its mirror) of an extra node (inside the outermost
#: cells of the refined grid, which are atoms).
_BREAK_MIN = 2.0**-40
#: Probability beyond which the inversion grid starts (each side).
_EDGE = 2.0**-50


def discrete_atoms(dist):
    """``(atoms, weights)`` of a discrete distribution, else None."""
    if not getattr(dist, "is_discrete", False):
        return None
    atoms = getattr(dist, "atoms", None)
    if atoms is None:
        return None
    atoms = np.asarray(atoms, dtype=float)
    w = getattr(dist, "weights", None)
    w = np.full(atoms.size, 1.0 / atoms.size) if w is None else np.asarray(w, float)
    return atoms, w / w.sum()


def _continuous(dist) -> bool:
    return not getattr(dist, "is_discrete", False) and all(
        callable(getattr(dist, m, None)) for m in ("cdf", "sf", "pdf", "ppf", "isf")
    )


def _scale(dist) -> float:
    """A robust length scale: the IQR / 1.349 (the std of a normal)."""
    q1, q3 = (float(v) for v in dist.ppf(np.array([0.25, 0.75])))
    s = (q3 - q1) / 1.349
    if not s > 0:
        s = float(dist.std())
    return s


class Mixture:
    """The law of ``Y + C``: ``Y`` discrete (atoms `y`, weights `w`), ``C``
    continuous (`dist`, with ``cdf``, ``sf``, ``pdf``, ``ppf``, ``isf``)."""

    def __init__(self, y, w, dist):
        y = np.asarray(y, dtype=float)
        w = np.asarray(w, dtype=float)
        keep = w > 0
        y, inv = np.unique(y[keep], return_inverse=True)
        self.y = y
        self.w = np.bincount(inv, weights=w[keep], minlength=y.size)
        self.dist = dist

    def evaluate(self, x, which=(0, 1, 2)):
        """``(F, S, f)`` at the points `x` (only the rows `which` are filled):
        positive sums of the continuous part's own ``cdf``, ``sf`` and ``pdf``."""
        x = np.asarray(x, dtype=float).ravel()
        out = np.full((3, x.size), np.nan)
        step = max(1, _BLOCK // self.y.size)
        d = self.dist
        funcs = [(k, (d.cdf, d.sf, d.pdf)[k]) for k in which]
        with np.errstate(all="ignore"):
            for i in range(0, x.size, step):
                t = x[i : i + step, None] - self.y[None, :]
                for k, func in funcs:
                    out[k, i : i + step] = np.asarray(func(t), float) @ self.w
        return out

    def cdf(self, x):
        return self.evaluate(x)[0]

    def sf(self, x):
        return self.evaluate(x)[1]

    def bounds(self) -> tuple[float, float]:
        """Points below (above) which less than ``2^-50`` of probability lies."""
        lo = self.y[0] + float(self.dist.ppf(_EDGE))
        hi = self.y[-1] + float(self.dist.isf(_EDGE))
        return lo, hi


def quadrature_atoms(dist):
    """Gauss–Legendre nodes (quantiles of `dist`) and weights of the probability
    integral ``int_0^1 g(Q(u)) du``: :data:`QUAD_BODY` sub-intervals on
    [1/4, 3/4], :data:`QUAD_PER_BAND` per dyadic band into both tails, down to
    ``2^-(QUAD_BANDS + 2)``; the upper half through ``isf``."""
    g, gw = np.polynomial.legendre.leggauss(QUAD_ORDER)
    g, gw = 0.5 * (g + 1.0), 0.5 * gw
    edges = [np.linspace(0.25, 0.5, QUAD_BODY // 2 + 1)]
    for k in range(1, QUAD_BANDS + 1):
        lo, hi = 2.0 ** -(k + 2), 2.0 ** -(k + 1)
        edges.append(np.linspace(lo, hi, QUAD_PER_BAND + 1))
    u, w = [], []
    for e in edges:
        a, b = e[:-1, None], e[1:, None]
        u.append((a + (b - a) * g).ravel())
        w.append(((b - a) * gw).ravel())
    u, w = np.concatenate(u), np.concatenate(w)  # probabilities in (0, 1/2]
    y = np.concatenate([dist.ppf(u), dist.isf(u)])
    return np.asarray(y, float), np.concatenate([w, w])


def _hermite_solve(x0, h, v0, v1, d0, d1, target):
    """The root in [0, 1] of the cubic Hermite interpolant of values `v0`, `v1`
    and slopes `d0`, `d1` (per unit x, interval width `h`) equal to `target`
    (``v0 <= target < v1``), by Newton iterations safeguarded by bisection."""
    m0, m1 = d0 * h, d1 * h
    lo = np.zeros_like(target)
    hi = np.ones_like(target)
    span = v1 - v0
    with np.errstate(all="ignore"):  # a failed grid (inf, nan): checked later
        t = np.where(span > 0, (target - v0) / np.where(span > 0, span, 1.0), 0.5)
    for _ in range(60):
        t2, t3 = t * t, t * t * t
        val = (
            (2 * t3 - 3 * t2 + 1) * v0
            + (t3 - 2 * t2 + t) * m0
            + (-2 * t3 + 3 * t2) * v1
            + (t3 - t2) * m1
        )
        der = (6 * t2 - 6 * t) * v0 + (3 * t2 - 4 * t + 1) * m0
        der += (-6 * t2 + 6 * t) * v1 + (3 * t2 - 2 * t) * m1
        below = val < target
        lo = np.where(below, t, lo)
        hi = np.where(below, hi, t)
        with np.errstate(all="ignore"):
            nt = t - (val - target) / der
        ok = np.isfinite(nt) & (nt > lo) & (nt < hi)
        new = np.where(ok, nt, 0.5 * (lo + hi))
        if np.all(np.abs(new - t) <= 1e-15):
            t = new
            break
        t = new
    return x0 + t * h


class _Inverse:
    """Quantile function of a :class:`Mixture` on a uniform grid of spacing `h`."""

    def __init__(self, mix: Mixture, h: float):
        lo, hi = mix.bounds()
        m = min(MAX_GRID, max(64, math.ceil((hi - lo) / h) + 1))
        self.x = np.linspace(lo, hi, m)
        F, S, f = mix.evaluate(self.x)
        self.F = F
        with np.errstate(divide="ignore", invalid="ignore"):
            self.lf, self.dlf = np.log(F), f / F  # lower half: log F, increasing
            self.ls, self.dls = -np.log(S), f / S  # upper half: -log S, increasing
        self.lf = np.maximum.accumulate(self.lf)
        self.ls = np.maximum.accumulate(self.ls)

    def _solve(self, v, dv, target):
        k = np.searchsorted(v, target, side="right") - 1
        k = np.clip(k, 0, self.x.size - 2)
        x0, h = self.x[k], self.x[k + 1] - self.x[k]
        return _hermite_solve(x0, h, v[k], v[k + 1], dv[k], dv[k + 1], target)

    def ppf(self, p):
        p = np.asarray(p, dtype=float)
        return self._solve(self.lf, self.dlf, np.log(p))

    def isf(self, s):
        s = np.asarray(s, dtype=float)
        return self._solve(self.ls, self.dls, -np.log(s))


def _tolerance(p):
    """:data:`CHECK_FRACTION` of 0.1 SE at :data:`CHECK_N` impacts."""
    return CHECK_FRACTION * 0.1 * np.sqrt(p * (1.0 - p) / CHECK_N)


def check_nodes(mix: Mixture, inverse, stride: int = CHECK_STRIDE):
    """Worst ratio of the exact CDF error to the tolerance at every `stride`-th
    node of the refined grid (lower half through ``F``, upper through ``S``)."""

    p, s = refined_probabilities()
    p, s = p[1:-1:stride], s[1:-1:stride]
    lower = p <= 0.5
    x = np.where(lower, inverse.ppf(np.where(lower, p, 0.5)), 0.0)
    x[~lower] = inverse.isf(s[~lower])
    err = np.empty(p.size)
    err[lower] = np.abs(mix.evaluate(x[lower], (0,))[0] - p[lower])
    err[~lower] = np.abs(mix.evaluate(x[~lower], (1,))[1] - s[~lower])
    return float(np.max(err / _tolerance(np.minimum(p, s))))


def _invert(mix: Mixture, scale: float):
    """The inverse of `mix` on a grid of spacing ``scale / GRID_PER_SCALE``, halved
    until :func:`check_nodes` passes (at most :data:`MAX_REFINE` times), and the
    check's worst ratio."""
    h = scale / GRID_PER_SCALE
    for attempt in range(MAX_REFINE + 1):
        inverse = _Inverse(mix, h)
        worst = check_nodes(mix, inverse)
        if worst <= 1.0 or attempt == MAX_REFINE or inverse.x.size >= MAX_GRID:
            break
        h *= 0.5
    return inverse, worst


def mixture_table(inverse, worst, *, x_nodes=False) -> CellTable:
    """The refined-grid table of an inverted mixture (see :func:`_invert`).

    `x_nodes`: the inversion grid's points are nodes of the table as well (its
    probabilities as ``breaks``), so that no cell is wider than the grid spacing
    (a discrete + narrow continuous law has gaps between the atoms in which the
    density nearly vanishes; a cell across one would spread its mass evenly)."""
    if worst > 1.0:
        warnings.warn(
            "the table of the surface + particle roughness angle misses its "
            f"accuracy target by a factor {worst:.3g} (a distribution with a "
            "kink or a jump in its density, or a heavy tail cut at 90 deg?)",
            RuntimeWarning,
            stacklevel=4,
        )
    breaks = ()
    if x_nodes:
        b = np.unique(inverse.F)
        breaks = b[(b >= _BREAK_MIN) & (b <= 1.0 - _BREAK_MIN)]
    return CellTable.from_quantile(inverse.ppf, inverse.isf, breaks=breaks)


def jump_points(mix: Mixture) -> np.ndarray:
    """Where the density of `mix` may jump: each atom plus each finite end of the
    continuous part's support (a uniform law, a truncation, an exponential's
    origin), inside the mixture's bounds."""
    support = getattr(mix.dist, "support", None)
    if not callable(support):
        return np.empty(0)
    lo, hi = mix.bounds()
    ends = [float(e) for e in support() if math.isfinite(float(e))]
    x = np.concatenate([mix.y + e for e in ends]) if ends else np.empty(0)
    return x[(x >= lo) & (x <= hi)]


def exact_node_table(mix: Mixture, inverse, jumps) -> tuple[CellTable, float]:
    """A table whose node probabilities are the exact mixture CDF (SF in the upper
    half) at its nodes, and the worst in-cell error against the tolerance.

    The nodes are the approximate quantiles of the refined grid (where the
    inversion gave finite values), the inversion grid's points and the `jumps`:
    wherever the density jumps there is a node, so inside every cell it is smooth
    (constant for a uniform law, which the table's linear cells then reproduce
    exactly). The check evaluates the exact CDF at the middle of every
    :data:`CHECK_STRIDE`-th cell and of every cell next to a jump."""
    lo, hi = mix.bounds()
    p, sv = refined_probabilities()
    lower = p[1:-1] <= 0.5
    with np.errstate(all="ignore"):
        xq = np.where(lower, inverse.ppf(np.where(lower, p[1:-1], 0.5)), 0.0)
        xq[~lower] = inverse.isf(sv[1:-1][~lower])
    # geometric nodes into the two outermost jumps, where F (S) starts from 0
    h = float(inverse.x[1] - inverse.x[0])
    geo = h * 2.0 ** -(np.arange(GEO_LEVELS * GEO_PER_LEVEL) / GEO_PER_LEVEL)
    ends = [jumps.min() + geo, jumps.max() - geo] if jumps.size else []
    x = np.concatenate([xq[np.isfinite(xq)], inverse.x, jumps, *ends, [lo, hi]])
    x = np.unique(np.clip(x, lo, hi))
    F, S, _ = mix.evaluate(x, (0, 1))
    cum = _integer_probabilities(F, S)  # equal ones: empty cells, dropped
    left = np.r_[x[0], x]
    right = np.r_[x, x[-1]]
    table = CellTable.from_cells(np.r_[np.uint64(0), cum], left, right)
    # the check: table CDF at cell middles against the exact one
    n = table.size
    near = np.searchsorted(table.left, jumps)
    cells = np.unique(np.r_[np.arange(1, n - 1, CHECK_STRIDE), near - 1, near])
    cells = cells[(cells >= 1) & (cells < n - 1)]
    cells = cells[table.right[cells] > table.left[cells]]
    if cells.size == 0:
        return table, 0.0
    xm = 0.5 * (table.left[cells] + table.right[cells])
    start = table.cum[cells].astype(float) / 2.0**64
    w = table.widths()[cells]
    t_cdf = start + 0.5 * w
    t_sf = (np.uint64(0) - table.cum[cells + 1]).astype(float) / 2.0**64 + 0.5 * w
    Fm, Sm, _ = mix.evaluate(xm, (0, 1))
    use_f = Fm <= Sm
    err = np.where(use_f, np.abs(t_cdf - Fm), np.abs(t_sf - Sm))
    tol = _tolerance(np.where(use_f, Fm, Sm)) / CHECK_FRACTION * CELL_CHECK_FRACTION
    return table, float(np.max(err / tol))


def sum_mixtures(a, b):
    """The sum of two independent angle distributions as :class:`Mixture` objects
    to try in turn, each with the length scale of its continuous part, and whether
    the table needs the inversion grid as nodes (a discrete part); empty when both
    are discrete or one lacks the continuous protocol. Two continuous laws: first
    the quadrature over the narrower one (the integrand is smooth on the wider
    one's scale), then over the wider one (when the narrower has a kink, e.g. a
    uniform law)."""
    da, db = discrete_atoms(a), discrete_atoms(b)
    if da is not None and _continuous(b):
        return [(Mixture(*da, b), _scale(b), True)]
    if db is not None and _continuous(a):
        return [(Mixture(*db, a), _scale(a), True)]
    if _continuous(a) and _continuous(b):
        sa, sb = _scale(a), _scale(b)
        (wide, s_w), (narrow, s_n) = sorted(((a, sa), (b, sb)), key=lambda t: -t[1])
        return [
            (Mixture(*quadrature_atoms(narrow), wide), s_w, False),
            (Mixture(*quadrature_atoms(wide), narrow), s_n, False),
        ]
    return []


def reduced_convolution(a, b) -> CellTable:
    """The approximate convolution (the fallback): each distribution reduced to
    :data:`REDUCED_ATOMS` equiprobable atoms (its table's quantiles at the
    mid-probabilities), all sums formed and their empirical quantile function
    tabulated on the refined grid; Kolmogorov distance up to ~``1/REDUCED_ATOMS``."""
    m = REDUCED_ATOMS
    q = mid_probabilities(m)
    xa, xb = cell_table(a).quantile(q), cell_table(b).quantile(q)
    sums = np.sort((xa[:, None] + xb[None, :]).ravel())
    n = sums.size

    def ppf(p):  # the empirical quantile, linear between order statistics
        k = np.clip(np.asarray(p) * n - 0.5, 0.0, n - 1.0)
        i = np.minimum(k.astype(np.intp), n - 2)
        return sums[i] + (k - i) * (sums[i + 1] - sums[i])

    return CellTable.from_quantile(ppf)


def sum_table(a, b) -> CellTable:
    """The :class:`~microimpact._core.tables.CellTable` of the sum of two independent
    angle distributions `a`, `b` (see the module docstring)."""
    best = None
    for mix, scale, x_nodes in sum_mixtures(a, b):
        inverse, worst = _invert(mix, scale)
        if best is None or worst < best[1]:
            best = (inverse, worst, x_nodes)
        if worst <= 1.0:
            break
        jumps = jump_points(mix) if x_nodes else np.empty(0)
        if jumps.size:  # a density with jumps: nodes there, exact probabilities
            table, cell_worst = exact_node_table(mix, inverse, jumps)
            if cell_worst <= 1.0:
                return table
    if best is not None:
        return mixture_table(best[0], best[1], x_nodes=best[2])
    da, db = discrete_atoms(a), discrete_atoms(b)
    if da is not None and db is not None and da[0].size * db[0].size <= MAX_SUM_ATOMS:
        sums = (da[0][:, None] + db[0][None, :]).ravel()
        return CellTable.from_atoms(sums, (da[1][:, None] * db[1][None, :]).ravel())
    return reduced_convolution(a, b)
