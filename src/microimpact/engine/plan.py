"""The engine's plan: everything a worker needs, precomputed once.

Every random input is a :class:`~microimpact._core.tables.CellTable`: cells whose
probabilities are 64-bit integers (exact to ``2^-64``) and whose values are linear
inside the cell. A draw is one 64-bit integer ``r``: it selects the cell ``j`` with
``cum[j] <= r < cum[j+1]`` and the fraction ``f = (r - cum[j]) / width_j`` in [0, 1),
and every tabulated quantity is read as ``lo_j + f * span_j``:

* a continuous distribution (normal, truncated normal, lognormal, uniform, a SciPy
  distribution, the speed-spread factor) is its quantile function on a grid that is
  uniform in the body and refined geometrically into both tails
  (:func:`~microimpact._core.tables.refined_probabilities`), interpolated linearly; a
  histogram has a node at every bin edge as well, so it is sampled exactly;
* a discrete distribution (an empirical sample, a monodisperse population, measured
  angles) has one zero-length cell per distinct atom: its atoms are drawn with their
  exact probabilities, and nothing is interpolated.

Derived quantities are tabulated at the cell ends and interpolated with the same
fraction: ``1/k1(d)``, ``1/k2(d)``, ``v_c(d)`` per diameter cell (the coefficient laws
are evaluated once per node, never per impact), and ``sin(phi)``, ``cos(phi)``,
``tan(phi)`` per angle cell. The angle tables do not depend on the apparent angle
``theta``: the kernel forms ``sin(theta - phi)`` and ``cos(theta - phi)`` per impact
from them, so one table per surface serves the whole sweep.

Shadowing acts on the draw, exactly and without rejection loops (which keeps
quasi-Monte Carlo structure intact); ``reachable`` means ``sin(theta - phi) > 0`` as
the table computes it:

* ``"reject"``: the angle distribution conditioned on the facet being reachable. The
  reachable facets are a prefix of the table (``phi`` increases with the draw), so
  the draw ``r`` is mapped to ``floor(r * cut / 2^64)``, ``cut`` the integer
  probability where the table's ``sin(theta - phi)`` reaches 0 (solved in its cell).
  This is the paper's situation (every simulated impact strikes a reachable facet).
* ``"weighted"``: each cell is weighted by the integral of ``sin(theta - phi)_+``
  over it, the Sommerfeld & Huber (1999) effective PDF of the facets a particle
  actually hits: a table of integer probabilities per apparent angle (the values
  are shared).
* ``"none"``: the table is used as it is and unreachable facets are counted as
  ``shadowed``.

In the first two cases the removed probability ``P(phi >= theta)`` of the table is
reported as the shadowed fraction (for a pair of angles, :class:`PairSampler` and
:class:`PairSearch`, that of the pairs with ``sin(theta - a - b) <= 0``: the pairs
leaning back past -90 deg, ``a + b < theta - pi``, included).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from .._core.tables import (
    CellTable,
    fraction_to_integer,
    linear_columns,
    mid_probabilities,
    mulhi64,
    nonempty_cells,
)
from ..errors import InputError, ScenarioError
from ..scenario.grid import GridPoint, GridPoints, SweepGrid
from . import _compiled
from ._cells import cell_table, one_atom_table
from ._convolution import MAX_SUM_ATOMS, discrete_atoms, sum_table

#: Samples per block: the engine's unit of randomness (an algorithm constant, never
#: derived from the worker count or the memory).
BLOCK_SIZE = 1 << 15
#: Bits of each draw the sampler reads (all of a 64-bit integer).
DRAW_BITS = 64
#: Bytes of weighted-shadowing angle tables kept per plan (each has its own cell
#: probabilities, so its own rows).
WEIGHTED_CACHE_BYTES = 64 << 20

# Variable ids in the stream keys (fixed: adding a variable never shifts the others).
#: ``VAR_PAIR``: the particle atom's proposal of a pair drawn by
#: :class:`PairSearch` (drawn for such points only).
VAR_DIAMETER, VAR_ANGLE, VAR_SPEED, VAR_PAIR = 0, 1, 2, 3


#: One sweep point (the grid owns the numbering; see :mod:`microimpact.scenario.grid`).
SweepPoint = GridPoint

#: Every kernel row starts with the cell's start (its uint64 bits) and 1/width.
R_CUM, R_INVW = 0, 1
#: Columns of a diameter row: (lo, span) pairs of 1/k1, 1/k2, v_c.
D_IK1, D_IK2, D_VC = 2, 4, 6
#: Columns of an angle row: (lo, span) pairs of sin(phi), cos(phi), tan(phi).
A_SIN, A_COS, A_TAN = 2, 4, 6
#: Column of a speed row: (lo, span) of the relative speed factor.
S_FACTOR = 2
#: Further columns of an areal angle row (:class:`ArealSampler`): (lo, span) pairs
#: of sin(chi), cos(chi) and phi_perp, ``chi = arctan(tan(phi_perp) cos(phi_par))``
#: the facet's tilt about its own line t' (docs/physics.md).
A_SINX, A_COSX, A_PERP = 8, 10, 12

#: Environment variable choosing the kernel: ``numpy`` forces the NumPy kernel,
#: ``compiled`` requires the compiled one, unset or ``auto`` takes the compiled
#: kernel when it was built at install time.
KERNEL_ENV = "MICROIMPACT_KERNEL"
KERNEL_CHOICES = ("auto", "compiled", "numpy")


@dataclass(frozen=True, eq=False)
class Sampler:
    """A :class:`~microimpact._core.tables.CellTable` laid out for the kernels.

    ``rows`` has one row per cell plus a sentinel row: the cell's start (the bits of
    its uint64 ``cum``), ``1/width``, then ``(lo, span)`` pairs of the quantities the
    kernel reads, so that one draw touches one guide entry and one row (and the
    next row's start). ``values`` holds ``(lo, span)`` of the sampled variable itself
    (diameter, angle, speed factor), which only inspection reads.
    """

    table: CellTable
    rows: np.ndarray  # (n + 1, stride) float64, C-contiguous
    values: np.ndarray  # (n, 2)

    def __post_init__(self):
        r, n = self.rows, self.table.size
        if not (
            r.dtype == np.float64
            and r.ndim == 2
            and r.flags.c_contiguous
            and r.shape[0] == n + 1
            and r.shape[1] >= 2
            and np.array_equal(r[:, R_CUM].view(np.uint64), self.table.cum)
            and self.values.shape == (n, 2)
        ):
            raise ValueError("Sampler: one row per cell and a sentinel (internal)")
        r.setflags(write=False)
        self.values.setflags(write=False)

    @classmethod
    def of(cls, table: CellTable, value, *columns) -> Sampler:
        """`value` and each of `columns` given as ``(left, right)`` at the cell
        ends."""
        n = table.size
        rows = np.zeros((n + 1, 2 + 2 * len(columns)))
        rows[:, R_CUM] = table.cum.view(np.float64)
        rows[:n, R_INVW] = table.inv_width
        for k, (left, right) in enumerate(columns):
            rows[:n, 2 + 2 * k], rows[:n, 3 + 2 * k] = linear_columns(left, right)
        values = np.column_stack(linear_columns(*value))
        return cls(table, rows, values)

    @property
    def nbytes(self) -> int:
        t = self.table
        return self.rows.nbytes + self.values.nbytes + t.cum.nbytes * 4

    def value(self, r) -> np.ndarray:
        """The sampled variable at the draws `r`."""
        j, f = self.table.locate(r)
        return self.values[j, 0] + f * self.values[j, 1]

    def subset(self, table: CellTable, cells) -> Sampler:
        """The same cell values with other probabilities (`table`, whose cells are
        ``cells`` of this one)."""
        n = table.size
        rows = np.zeros((n + 1, self.rows.shape[1]))
        rows[:n, 2:] = self.rows[cells, 2:]
        rows[:, R_CUM] = table.cum.view(np.float64)
        rows[:n, R_INVW] = table.inv_width
        return Sampler(table, rows, np.ascontiguousarray(self.values[cells]))


@dataclass(frozen=True, eq=False)
class AngleTables:
    """What the kernel needs for one (surface, apparent angle) pair.

    ``sampler`` draws the angle cell (for ``"weighted"`` shadowing, a table of its own
    probabilities over the surface's cells); ``cut`` is 0, or the integer
    probability the draws are scaled to (``"reject"``: only reachable facets).
    A molecularly smooth surface has no angle draw (``random`` False).
    """

    sampler: Sampler | None
    cut: int  # 0: no scaling; else draws r -> floor(r * cut / 2^64)
    sin_theta: float
    cos_theta: float
    shadowed_mass: float  # P(phi >= theta) under the surface's own table
    random: bool  # False for a smooth surface
    #: Rough particle on a discrete surface (see :class:`PairSampler`): the
    #: particle's atoms, the number of (surface, particle) pairs drawn from and the
    #: shift that places a pair rank in the top bits (0: not a pair table).
    pair: Sampler | None = None
    pair_total: int = 0
    pair_shift: int = 0
    #: Draw from the whole table and count the unreachable facets as shadowed
    #: (``"none"``, and any point at which no facet can be reached at all).
    count_shadowed: bool = False
    #: A pair drawn by a search (see :class:`PairSearch`): ``sampler`` draws the
    #: surface atom, ``pair`` holds the particle atoms and their prefix sums.
    pair_search: bool = False
    #: An areal surface (:class:`ArealSampler`): each cell of ``sampler`` is one
    #: ``(phi_par, phi_perp)`` pair, its rows carry :data:`A_SINX`,
    #: :data:`A_COSX`, :data:`A_PERP`.
    areal: bool = False

    @property
    def pairs(self) -> bool:
        """The angle is a (surface, particle) pair (:class:`PairSampler` or
        :class:`PairSearch`)."""
        return bool(self.pair_shift) or self.pair_search

    @property
    def pair_mode(self) -> int:
        """The compiled kernel's ``pair_shift``: the shift of a rank pair, -1 for a
        pair search, 0 for no pair."""
        return -1 if self.pair_search else int(self.pair_shift)

    def pair_draws(self, r, r2=None):
        """``(key, surface cell, particle atom)`` of angle draws `r` (pair tables;
        the key is the rank placed in the top bits, or the draw itself for a
        search, which needs the particle's draws `r2` too: :data:`VAR_PAIR`)."""
        if self.pair_search:
            if r2 is None:
                raise ValueError("a pair search draws twice: give r2 (internal)")
            return (r, *search_pairs(self.sampler, self.pair, r, r2))
        k = mulhi64(r, self.pair_total) << np.uint64(self.pair_shift)
        i, _ = self.sampler.table.locate(k)
        j = (k - self.sampler.table.cum[i]) >> np.uint64(self.pair_shift)
        j += self.sampler.rows[i, PAIR_FIRST].astype(np.uint64)  # from m_i
        return k, i, j.astype(np.intp)

    def areal_cells(self, r) -> np.ndarray:
        """The row of ``sampler`` (one ``(phi_par, phi_perp)`` pair) that each angle
        draw `r` selects, as the NumPy kernel maps it (areal tables only)."""
        if not self.areal:
            raise ValueError("areal_cells: not an areal surface's tables")
        r = np.asarray(r, dtype=np.uint64)
        if self.cut:
            r = mulhi64(r, self.cut)
        return self.sampler.table.cells(r)

    @property
    def pair_acceptance(self) -> float | None:
        """The fraction of the particle's proposals a :class:`PairSearch` accepts
        (the rest go to the search), from the tables: ``sum_i p_i W_i / (K
        lam_i / 2^64)`` (see the class); None for other tables."""
        if not self.pair_search:
            return None
        q = self.sampler.rows[:-1]
        lam = q[:, Q_BOUND]
        if not lam.any():  # the masses: every proposal is accepted
            return 1.0
        accept = q[:, Q_TOTAL] * 2.0**64 / (PAIR_BANDS * lam)
        return float(np.sum(self.sampler.table.widths() * accept))

    @property
    def phi(self) -> np.ndarray:
        """2^16 equiprobable angles [rad] of the sampled (conditional or re-weighted)
        distribution: the table's quantile function at mid-probabilities (for a
        pair search, whose particle atom needs a second draw, the points of a
        Hammersley set: the second coordinates are the indices bit-reversed)."""
        if not self.random:
            return np.zeros(1 << 16)
        r = fraction_to_integer(mid_probabilities(1 << 16))
        if self.pairs:
            k = np.arange(1 << 16, dtype=np.uint64)
            rev = np.zeros_like(k)
            for bit in range(16):
                rev |= ((k >> np.uint64(bit)) & np.uint64(1)) << np.uint64(63 - bit)
            _, i, j = self.pair_draws(r, rev | np.uint64(1 << 47))
            return self.sampler.values[i, 0] + self.pair.values[j, 0]
        if self.cut:
            r = mulhi64(r, self.cut)
        return self.sampler.value(r)


#: Column of a :class:`PairSampler` surface row (per apparent angle): the first
#: particle atom ``m_i`` of the surface atom's pairs (its rank ``r`` in the cell
#: is the particle atom ``m_i + r``).
PAIR_FIRST = 8


@dataclass(frozen=True, eq=False)
class _Pairs:
    """Two discrete angle sets, the surface's and the particle's, whose pairs
    ``(a_i, b_j)`` are drawn exactly (:class:`PairSampler`, :class:`PairSearch`)."""

    surface: Sampler
    particle: Sampler

    def leans_back(self, angle_deg: float) -> bool:
        """Whether some pairs lean back past -90 deg at `angle_deg` (below
        ``theta``, ``a_i + b_j < theta``, but not reachable by the sine)."""
        return _leans_back(self.surface, self.particle, angle_deg)

    @property
    def values(self) -> np.ndarray:
        return np.concatenate([self.surface.values, self.particle.values])


@dataclass(frozen=True, eq=False)
class PairSampler(_Pairs):
    """A rough particle on a surface whose angle distributions are both discrete
    with equal masses (the paper's *Lycopodium* on Formica): the roughness angle is
    ``a_i + b_j`` for a pair drawn exactly, from one 64-bit draw, among the
    ``n_a n_b`` equiprobable pairs (``"reject"``: among the reachable ones,
    ``sin(theta - a_i - b_j) > 0`` as the kernels compute it). For each ``i``
    the reachable pairs are a range ``m_i <= j < n_i`` of the sorted ``b``: below
    ``theta`` (``a_i + b_j < theta``) but not leaning back past -90 deg (``a_i +
    b_j < theta - pi``, steep facets on both sides, where the sine is negative
    too). The per-angle table has one cell per surface atom holding its
    ``n_i - m_i`` ranks (``n_b`` for ``"none"``, from ``m_i = 0``) and the rows
    carry ``m_i`` (:data:`PAIR_FIRST`); a rank ``r`` within the cell is the
    particle atom ``m_i + r``. The kernels combine the two angles with the
    angle-addition formulas, so nothing is convolved or re-tabulated.
    :data:`ALGORITHM` is in the checkpoint fingerprint of the plans whose
    tables this range changed ("reject" where some pairs lean back: see
    :meth:`Plan.pair_algorithm`)."""

    #: How the pairs are drawn where that changed (see the class).
    ALGORITHM = "pair ranks: range [m, n), leaning back left out"

    @property
    def nbytes(self) -> int:
        return self.surface.nbytes + self.particle.nbytes


@dataclass(frozen=True, eq=False)
class ArealSampler(Sampler):
    """The facet-angle pairs ``(phi_par, phi_perp)`` of an areal surface
    (:class:`~microimpact.surface.areal_angles.ArealAngles`): one equal-mass
    zero-length cell per pair, sorted by ``phi_par`` (the table of ``phi_par``
    alone is exactly the one-angle table of the same angles, so the draw mapping
    is that of an empirical angle set), each row carrying ``sin``, ``cos``,
    ``tan`` of ``phi_par`` and ``sin(chi)``, ``cos(chi)``, ``phi_perp``
    (:data:`A_SINX`, :data:`A_COSX`, :data:`A_PERP`). Reachability depends on
    ``phi_par`` alone (the particle has no component along ``b``), so the
    reachable pairs are a prefix of the table. :data:`ALGORITHM` is in the
    checkpoint fingerprint of plans with an areal surface (see
    :meth:`Plan.pair_algorithm`)."""

    #: How an areal impact is computed where that changed (issue 24: the slip by a
    #: square root and the lateral angle by the portable atan2, on both kernels;
    #: a checkpoint of an areal run written before is not resumed).
    ALGORITHM = "areal: slip sqrt, portable atan2"

    @property
    def perp(self) -> np.ndarray:
        """``phi_perp`` [rad] of each cell."""
        return self.rows[:-1, A_PERP]


def areal_sampler(angles) -> ArealSampler:
    """The :class:`ArealSampler` of an
    :class:`~microimpact.surface.areal_angles.ArealAngles` (pairs sorted by
    ``phi_par``, then ``phi_perp``)."""
    par = np.asarray(angles.phi_par, dtype=float)
    perp = np.asarray(angles.phi_perp, dtype=float)
    order = np.lexsort((perp, par))
    par, perp = par[order], perp[order]
    base = _angle_sampler(CellTable.from_atoms(par))
    n = base.table.size
    if n != par.size or not np.array_equal(base.table.left, par):
        raise ValueError("areal_sampler: one cell per pair (internal)")
    lo = base.values[:, 0]  # phi_par, clipped inside (-pi/2, pi/2)
    perp = np.clip(perp, -_LIMIT, _LIMIT)
    chi = np.arctan(np.tan(perp) * np.cos(lo))
    rows = np.zeros((n + 1, 14))
    rows[:, :8] = base.rows
    rows[:n, A_SINX] = np.sin(chi)
    rows[:n, A_COSX] = np.cos(chi)
    rows[:n, A_PERP] = perp
    return ArealSampler(base.table, rows, np.array(base.values))


#: Columns of a :class:`PairSearch` particle row: the prefix sums (over the atoms
#: before it) that the search reads.
P_ONE, P_TWO = 8, 9
#: Columns of a :class:`PairSearch` surface row (per apparent angle): the
#: coefficients ``alpha``, ``beta`` of the weight and of the conditional CDF, the
#: rejection's bound ``lam`` (0 for the masses: every proposal is accepted), the
#: end ``n`` of the particle atoms drawn from, their weight ``C(n) - C(m)``
#: (``C(J) = alpha P1[J] + beta P2[J]``) and their first atom ``m``; then, from
#: :data:`Q_BANDS`, the ``PAIR_BANDS + 1`` ends of the proposal's bands (uint64
#: bits: integer positions in the particle table, from its start of atom ``m``
#: to its end of atom ``n - 1``, ``2^64`` written 0).
Q_ALPHA, Q_BETA, Q_BOUND, Q_COUNT, Q_TOTAL, Q_FIRST, Q_BANDS = range(8, 15)
#: Equal-probability bands of the particle's proposal per surface atom (a power
#: of two: a band is the top bits of the draw).
PAIR_BANDS = 8
#: The relative and absolute margins of a band's bound on ``g`` over its closed
#: form (the computed ``g`` exceeds the exact one by a few 1e-16 at most).
BOUND_RELATIVE, BOUND_ABSOLUTE = 1e-12, 1e-14


@dataclass(frozen=True, eq=False)
class PairSearch(_Pairs):
    """A rough particle on a surface whose angle distributions are both discrete,
    where :class:`PairSampler` does not apply (``"weighted"`` shadowing, or unequal
    masses) and the pairs are too many to tabulate their sums exactly (more than
    ``MAX_SUM_ATOMS``): the pair ``(a_i, b_j)`` is drawn exactly from one 64-bit
    draw, without forming the pairs.

    The pair weight is ``w_i v_j g_ij``, with ``g = 1`` for the reachable pairs
    (``"reject"``: ``sin(theta - a_i - b_j) > 0``; every pair for ``"none"``)
    and ``g = sin(theta - a_i - b_j)_+`` for ``"weighted"``. For each surface
    atom ``i`` the particle atoms of positive weight are a range ``m_i <= j <
    n_i`` of the sorted ``b``: below ``theta`` (``a_i + b_j < theta``) but not
    leaning back past -90 deg (``a_i + b_j < theta - pi``, steep facets on both
    sides, where the sine is negative too; ``m_i = 0`` for ``"none"``). The
    cumulative weight of the atoms before ``J`` is ``C_i(J) - C_i(m_i)``,
    ``C_i(J) = alpha_i P1[J] + beta_i P2[J]`` with angle-independent prefix sums:
    ``P1 = cumsum(v)``, ``P2 = 0``, ``alpha = 1``, ``beta = 0`` for the masses;
    ``P1 = cumsum(v cos b)``, ``P2 = cumsum(v sin b)``, ``alpha_i = sin(theta -
    a_i)``, ``beta_i = -cos(theta - a_i)`` for the sine weight. A per-angle table
    of integer probabilities ``w_i (C_i(n_i) - C_i(m_i))`` draws ``i`` and the
    fraction ``f`` inside its cell.

    The particle atom is drawn by rejection, with an exact search as the fallback
    (:func:`search_pairs`, the same steps in both kernels). A second 64-bit draw
    ``r2`` (:data:`VAR_PAIR`, one per impact) proposes ``j`` in ``[m_i, n_i)``
    from the masses ``v`` (the particle table's integer cells) under a
    piecewise-constant envelope: the integer range ``[L_i, L_i + M_i)`` of those
    atoms in the particle table is cut into ``K =`` :data:`PAIR_BANDS` bands
    ``[y_k, y_k+1)`` of widths ``w_k``, each drawn with probability ``1/K`` (the
    top bits of ``r2``), and ``x = y_k + floor(z w_k / 2^64)`` with ``z`` the
    other bits of ``r2``; ``j`` is the particle cell holding ``x`` (a band may cut
    an atom: each part is proposed within its own band). The proposal is
    accepted when ``f lam_i < g_ij w_k``, ``g_ij = alpha_i cos b_j + beta_i sin
    b_j`` (the particle rows' :data:`A_COS`, :data:`A_SIN`), where ``lam_i >=
    g_ij w_k`` for every atom of every band. The fraction ``f`` of the surface
    draw is uniform on [0, 1) and independent of ``(k, j)``, so with ``c_jk`` the
    part of atom ``j``'s integer mass in band ``k``

        P(accept, j | i) = sum_k (1/K) (c_jk / w_k) (g_ij w_k / lam_i)
                         = c_j g_ij / (K lam_i)  ~  v_j g_ij.

    Given a rejected proposal, ``f`` is uniform on ``[g w / lam, 1)``, so ``u' =
    (f lam - g w) / (lam - g w)`` is uniform on [0, 1) whatever ``(k, j)`` was:
    the search then takes the largest ``J`` in ``[m_i, n_i)`` with ``C_i(J) <=
    C_i(m_i) + u' W_i`` (``W_i = C_i(n_i) - C_i(m_i) = sum_j v_j g_ij``), which
    is ``J`` with the target law ``v_J g_iJ / W_i``. Altogether, with ``A_i =
    sum_j P(accept, j | i)``,

        P(J | i) = v_J g_iJ / (K' lam_i) + (1 - A_i) v_J g_iJ / W_i
                 = v_J g_iJ / W_i                (A_i = W_i / (K' lam_i)),

    the target law exactly (``K' = K / 2^64``), for any bands and any ``lam``
    that bounds every band's ``g w`` (a larger one only sends more draws to the
    search). ``g = sin(psi_i - b)`` with ``psi_i = theta - a_i`` is unimodal in
    ``b`` over the range (``0 < psi_i - b < pi``), so its largest value over a
    band's atoms is ``hypot(alpha_i, beta_i)`` (1 to round-off) where the peak
    ``b = psi_i - pi/2`` lies between them, else the larger end value; each is
    raised by :data:`BOUND_RELATIVE` and :data:`BOUND_ABSOLUTE` so that
    round-off never makes a computed ``g`` exceed it. The bands are chosen so
    that the bound times the width is about the same in each (a ziggurat: the
    widths in proportion to the inverse bounds, a few times over), which
    accepts about 86 to 95 % of the proposals for the Formica angles (the rest
    go to the search). A ``g`` computed at or below 0 (at the ends of the range,
    by round-off) counts as 0 (never accepted). For the masses the proposal is
    the target: ``lam = 0``, and every proposal is accepted (``g = cos b > 0``
    as computed with ``alpha = 1``, ``beta = 0``)."""

    # surface: Sampler; particle: Sampler, rows + (P1, P2) of the masses
    sine: Sampler | None  # rows + (P1, P2) of the sine weight ("weighted")

    #: How the pairs are drawn (in checkpoint fingerprints: a checkpoint of an
    #: earlier way, whose draws gave other pairs, is not resumed).
    ALGORITHM = f"pair search: banded rejection ({PAIR_BANDS}), range [m, n)"
    #: Added to :data:`ALGORITHM` for ``"reject"`` where some pairs lean back
    #: past -90 deg (their range used to start at 0: :meth:`Plan.pair_algorithm`).
    REJECT_RANGE = "'reject': range [m, n) too"

    @property
    def nbytes(self) -> int:
        return self.surface.nbytes * 2 + self.particle.nbytes


def _prefix_sampler(b: Sampler, one, two) -> Sampler:
    """`b` with the prefix sums of `one` and `two` as columns :data:`P_ONE`,
    :data:`P_TWO` (row ``j``: the sum over the atoms before ``j``; the sentinel
    row holds the totals)."""
    n = b.table.size
    rows = np.zeros((n + 1, 10))
    rows[:, : b.rows.shape[1]] = b.rows
    rows[1:, P_ONE] = np.cumsum(one)
    rows[1:, P_TWO] = np.cumsum(two)
    return Sampler(b.table, rows, b.values)


def _pair_search(ta: CellTable, tb: CellTable, shadowing: str) -> PairSearch:
    a, b = _angle_sampler(ta), _angle_sampler(tb)
    v = tb.widths()  # the table's integer cells: the masses the proposal draws
    particle = _prefix_sampler(b, v, np.zeros_like(v))
    sine = None
    if shadowing == "weighted":
        rb = b.rows[:-1]
        sine = _prefix_sampler(b, v * rb[:, A_COS], v * rb[:, A_SIN])
    return PairSearch(a, particle, sine)


def _search_top(n: int) -> int:
    """The first step of the pair search over `n` atoms: the largest power of two
    below `n` (0 for one atom)."""
    return 1 << ((n - 1).bit_length() - 1) if n > 1 else 0


def _band_bits() -> int:
    bits = PAIR_BANDS.bit_length() - 1
    if PAIR_BANDS < 2 or PAIR_BANDS != 1 << bits:
        raise ValueError("PAIR_BANDS must be a power of two >= 2 (internal)")
    return bits


def search_pairs(surface: Sampler, particle: Sampler, r, r2, *, detail=False):
    """``(surface cell, particle atom)`` of draws `r` (the surface) and `r2` (the
    particle's proposal) from :class:`PairSearch` tables: the cell ``i`` and
    fraction ``f`` of `r`; the band ``k`` (the top bits of `r2`) and the proposal
    ``j``, the particle cell of ``y_k + floor(z w_k / 2^64)`` (``z``: the other
    bits of `r2`), accepted where ``f lam_i < g_ij w_k``; for the others the
    largest ``J`` in ``[m_i, n_i)`` with ``alpha_i P1[J] + beta_i P2[J] <=
    C_i(m_i) + u' total_i``, ``u' = (f lam_i - g_ij w_k) / (lam_i - g_ij w_k)``,
    by steps of decreasing powers of two from ``m_i`` over the rejected draws only
    (what the compiled kernel does, operation for operation). With
    ``detail=True`` the proposals and the mask of the accepted ones follow (for
    inspection)."""
    bits = _band_bits()
    i, f = surface.table.locate(r)
    q = surface.rows[i]
    alpha, beta, bound = q[:, Q_ALPHA], q[:, Q_BETA], q[:, Q_BOUND]
    r2 = np.asarray(r2, dtype=np.uint64)
    band = (r2 >> np.uint64(64 - bits)).astype(np.intp) + Q_BANDS
    z = r2 << np.uint64(bits)
    at = np.arange(i.size)
    y0 = q[at, band].view(np.uint64)
    w = q[at, band + 1].view(np.uint64) - y0  # modulo 2^64
    x = y0 + mulhi64(z, w)
    j = particle.table.cells(x)
    prow = particle.rows
    g = alpha * prow[j, A_COS] + beta * prow[j, A_SIN]
    g = np.where(g > 0.0, g, 0.0)
    gw = g * w.astype(float)
    t = f * bound
    accepted = t < gw
    proposal = j.astype(np.intp)
    rejected = np.flatnonzero(~accepted)
    if rejected.size == 0:
        return (i, proposal, proposal, accepted) if detail else (i, proposal)
    t, gw, bound = t[rejected], gw[rejected], bound[rejected]
    alpha, beta, q = alpha[rejected], beta[rejected], q[rejected]
    fresh = (t - gw) / (bound - gw)  # u', uniform on [0, 1) whatever j was
    count = q[:, Q_COUNT].astype(np.int64)
    base = q[:, Q_FIRST].astype(np.int64)
    p1, p2 = prow[:, P_ONE], prow[:, P_TWO]
    u = alpha * p1[base] + beta * p2[base]  # C_i(m_i)
    u += fresh * q[:, Q_TOTAL]
    step = _search_top(particle.table.size)
    while step:
        cand = base + step
        ok = cand < count
        cm = alpha * p1[cand * ok] + beta * p2[cand * ok]
        base += step * (ok & (cm <= u))
        step >>= 1
    j[rejected] = base
    j = j.astype(np.intp)
    return (i, j, proposal, accepted) if detail else (i, j)


#: The bands' fractions are iterated on every ``BAND_ROWS``-th surface row and
#: taken by its neighbours (whose ``psi`` is nearly the same), then bounded
#: exactly in every row.
BAND_ROWS = 8


def _search_bands(part: Sampler, alpha, beta, first, counts, weighted: bool):
    """``(ends, lam)`` of :class:`PairSearch`'s proposal per surface row: the
    ``PAIR_BANDS + 1`` integer ends of its bands in the particle table (uint64,
    ``2^64`` written 0) and the bound ``lam >= g_ij w_k`` over every atom ``j`` of
    every band ``k`` as the kernels compute ``g`` (rows with ``counts >
    first``). The bands start equal (and stay so for the masses, whose proposal
    is the target: ``lam = 0``); for the sine they are then resized a few times
    towards widths in proportion to the inverse of their bound on ``g`` (damped:
    the plain fixed point oscillates), from float positions, on every
    :data:`BAND_ROWS`-th row; each row takes the fractions with the smallest
    ``lam`` of its nearest such row, as integers, and its bounds are then found
    exactly."""
    nb_ = PAIR_BANDS
    table = part.table
    n_rows = alpha.size
    cum = table.cum.copy()
    cum[-1] = 0  # the end of the table, 2^64, wrapped
    low = cum[first]
    mass = cum[counts] - low  # modulo 2^64: 0 is 2^64
    span = np.where(mass == 0, 2.0**64, mass.astype(float)) / 2.0**64
    most = np.where(mass == 0, np.uint64(2**64 - 1), mass)[:, None]
    bv = part.values[:, 0]
    cos_b = np.ascontiguousarray(part.rows[:-1, A_COS])
    sin_b = np.ascontiguousarray(part.rows[:-1, A_SIN])

    def bound(rows, j_a, j_b):
        """The bound on g over the atoms ``j_a..j_b`` of `rows` (unimodal: the
        ends, or the peak between them), with its margins."""
        al, be = alpha[rows, None], beta[rows, None]
        g_a = al * cos_b[j_a] + be * sin_b[j_a]
        g_b = al * cos_b[j_b] + be * sin_b[j_b]
        # alpha cos b + beta sin b = R cos(b - b*): its peak R at b*
        b_star = np.arctan2(be, al)
        inside = (bv[j_a] <= b_star) & (b_star <= bv[j_b])
        top = np.where(inside, np.hypot(al, be), np.maximum(g_a, g_b))
        return np.maximum(top, 0.0) * (1.0 + BOUND_RELATIVE) + BOUND_ABSOLUTE

    frac = np.broadcast_to(np.arange(nb_ + 1) / nb_, (n_rows, nb_ + 1))
    if weighted:  # the bands' fractions of the range, from float positions
        sub = np.unique(np.r_[np.arange(0, n_rows, BAND_ROWS), n_rows - 1])
        lo_atom, hi_atom = first[sub, None], counts[sub, None] - 1
        start = np.cumsum(np.r_[0.0, table.widths()])  # of each atom
        f = frac[sub]
        best_lam = np.full(sub.size, np.inf)
        best = f
        for _ in range(4):
            at = start[first[sub], None] + f * span[sub, None]
            if table.kind == table.EQUAL:
                j = (at * table.size).astype(np.int64)  # the atom, near enough
            else:
                j = np.searchsorted(start, at, side="right") - 1
            j = np.clip(j, lo_atom, hi_atom)
            top = bound(sub, j[:, :-1], j[:, 1:])
            lam = np.max(top * np.diff(f, axis=1), axis=1)
            better = lam < best_lam
            best_lam = np.where(better, lam, best_lam)
            best = np.where(better[:, None], f, best)
            share = 1.0 / np.maximum(top, 1e-300)
            share /= share.sum(axis=1, keepdims=True)
            share = 0.3 * np.diff(f, axis=1) + 0.7 * share
            f = np.concatenate([np.zeros((sub.size, 1)), np.cumsum(share, axis=1)], 1)
        near = np.minimum(np.rint(np.arange(n_rows) / BAND_ROWS), sub.size - 1)
        frac = best[near.astype(np.intp)]
    off = np.minimum(fraction_to_integer(frac * span[:, None]), most)  # rounded
    off[:, 0] = 0
    ends = low[:, None] + np.maximum.accumulate(off, axis=1)
    ends[:, -1] = low + mass  # exactly the end of atom n - 1
    if not weighted:
        return ends, np.zeros(n_rows)
    width = ends[:, 1:] - ends[:, :-1]  # modulo 2^64
    j_a = np.clip(table.cells(ends[:, :-1]), first[:, None], counts[:, None] - 1)
    j_b = np.clip(table.cells(ends[:, 1:] - np.uint64(1)), j_a, counts[:, None] - 1)
    top = np.where(width > 0, bound(np.arange(n_rows), j_a, j_b), 0.0)
    lam = np.max(top * width.astype(float), axis=1) * (1.0 + BOUND_RELATIVE)
    return ends, lam


@dataclass(frozen=True, eq=False)
class Plan:
    """Picklable description of a run for the kernel (built by
    :func:`build_plan`)."""

    entropy: int
    points: Sequence[SweepPoint]  # a GridPoints from build_plan, or a tuple
    diameters: Sampler  # rows: 1/k1, 1/k2, v_c, d
    p: float
    q: float
    friction: float
    speeds: Sampler | None  # the relative speed factor, or None
    # per variant (an ArealSampler is a Sampler)
    surfaces: tuple[Sampler | PairSampler | PairSearch | None, ...]
    shadowing: str
    sampling: str = "mc"
    replicates: int = 1
    block_size: int = BLOCK_SIZE
    kernel: str = "numpy"  # "compiled" or "numpy" (see resolve_kernel)
    _cache: dict = field(default_factory=dict, repr=False, compare=False)
    # (not copied by dataclasses.replace: a plan with other points has its own)
    _columns: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    #: Bits of a draw the tables read (recorded in checkpoint fingerprints).
    table_bits = DRAW_BITS

    @property
    def diameter(self) -> np.ndarray:
        """Diameter at the start of each cell [m]."""
        return self.diameters.values[:, 0]

    @property
    def coefficients(self) -> np.ndarray:
        """Per diameter cell: start, 1/width, (lo, span) of 1/k1, 1/k2, v_c (the
        kernel rows, sentinel row included)."""
        return self.diameters.rows

    @property
    def speed_factor(self) -> np.ndarray | None:
        """Relative speed factor at the start of each cell, or None."""
        return None if self.speeds is None else self.speeds.values[:, 0]

    @property
    def surface_atoms(self) -> tuple[np.ndarray | None, ...]:
        """Roughness angle at the start of each cell [rad], per surface (None for a
        smooth one); for an areal surface the ``(phi_par, phi_perp)`` pairs,
        shape ``(n, 2)``."""
        return tuple(
            None
            if s is None
            else np.column_stack([s.values[:, 0], s.perp])
            if isinstance(s, ArealSampler)
            else s.values[:, 0]
            for s in self.surfaces
        )

    def shared(self, key, make):
        """``make(self)``, kept in the tables' cache that the plans derived from
        this one with ``dataclasses.replace`` share, for each of them that keeps
        its points and surfaces (a wall law's plan per diameter: only the
        diameters differ): made once for all of them, and once for each points
        of theirs (a reduced speed axis gives each diameter its own). `key`
        names the value (with whatever else it depends on)."""
        at = (key, id(self.points), id(self.surfaces))
        held = self._cache.get(at)
        if held is None:  # (kept with the objects: their ids are not reused)
            held = self._cache[at] = (self.points, self.surfaces, make(self))
        return held[2]

    def own_tables(self, surface: int) -> bool:
        """Whether surface `surface` has tables with rows of their own per
        apparent angle (weighted shadowing, pair tables): the plan keeps only
        :data:`WEIGHTED_CACHE_BYTES` of them."""
        s = self.surfaces[surface]
        return s is not None and (
            self.shadowing == "weighted" or isinstance(s, PairSampler | PairSearch)
        )

    def angle_tables(self, surface: int, angle_deg: float) -> AngleTables:
        """Tables of one (surface, angle), cached for the life of the plan: for
        ``"reject"`` and ``"none"`` they are a few scalars, for ``"weighted"`` one
        table of rows per apparent angle (at most :data:`WEIGHTED_CACHE_BYTES`
        kept)."""
        key = (surface, float(angle_deg))
        tables = self._cache.get(key)
        if tables is None:
            if self.own_tables(surface):
                size = self.surfaces[surface].nbytes
                if size * (len(self._cache) + 1) > WEIGHTED_CACHE_BYTES:
                    self._cache.clear()
            tables = self._cache[key] = _angle_tables(
                self.surfaces[surface], float(angle_deg), self.shadowing
            )
        return tables

    def pair_algorithm(self, surface: int) -> str | None:
        """How the pairs of surface `surface` are drawn, for the checkpoint
        fingerprint where that changed (a checkpoint written before, whose tables
        gave other pairs, is not resumed): :attr:`PairSearch.ALGORITHM`, with
        :attr:`PairSearch.REJECT_RANGE` under ``"reject"`` where some pairs lean
        back past -90 deg at one of the surface's apparent angles (they used to
        be drawn); :attr:`PairSampler.ALGORITHM` there too; else None (the
        fingerprint is what it was); :attr:`ArealSampler.ALGORITHM` for an areal
        surface."""
        s = self.surfaces[surface]
        if isinstance(s, ArealSampler):
            return s.ALGORITHM
        if not isinstance(s, PairSampler | PairSearch):
            return None
        algorithm = getattr(s, "ALGORITHM", None)
        leaning = self.shadowing == "reject" and self._leans_back(surface)
        if isinstance(s, PairSampler):
            return algorithm if leaning else None
        if algorithm and leaning:
            algorithm = f"{algorithm}; {s.REJECT_RANGE}"
        return algorithm

    def _leans_back(self, surface: int) -> bool:
        """Whether some pairs of surface `surface` (a pair sampler or search)
        lean back past -90 deg at one of its apparent angles."""
        s = self.surfaces[surface]
        low = float(s.surface.values[:, 0].min() + s.particle.values[:, 0].min())
        angles = {sp.angle_deg for sp in self.points if sp.surface == surface}
        # none can lean back where the steepest pair is well above theta - pi
        near = [t for t in angles if low < np.deg2rad(t) - np.pi + 1e-6]
        return any(s.leans_back(t) for t in sorted(near, reverse=True))

    def point_columns(self):
        """Every point as arrays, for tasks described by arrays (issue 31):
        ``(surface, speed, angle_deg, table, keys)``: each point's surface index,
        nominal speed [m s-1] and apparent angle [deg], the index of its (surface,
        angle) in `keys` (the arguments of :meth:`angle_tables`, sorted). From the
        grid's own arrays when the points are a
        :class:`~microimpact.scenario.grid.GridPoints`, else read point by point
        once; kept for the life of the plan."""
        cols = self._columns.get("columns")
        if cols is None:
            pts = self.points
            if hasattr(pts, "columns"):
                surface, speed, angle = pts.columns()
            else:
                n = len(pts)
                surface = np.fromiter((p.surface for p in pts), np.int64, n)
                speed = np.fromiter((p.speed for p in pts), float, n)
                angle = np.fromiter((p.angle_deg for p in pts), float, n)
            if hasattr(pts, "tables"):
                table, keys = pts.tables()
            else:
                pairs = np.column_stack([surface.astype(float), angle]).reshape(-1, 2)
                found, table = np.unique(pairs, axis=0, return_inverse=True)
                keys = [(int(s), float(a)) for s, a in found.tolist()]
                table = table.reshape(-1).astype(np.int64)
            cols = (surface, speed, angle, table, keys)
            self._columns["columns"] = cols
        return cols

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_cache"] = {}
        state["_columns"] = {}
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)


def _reach(s_theta, c_theta, rows, f):
    """``sin(theta - phi)`` as the kernels compute it, at fraction `f` of each cell."""
    s = rows[:-1, A_SIN] + f * rows[:-1, A_SIN + 1]
    c = rows[:-1, A_COS] + f * rows[:-1, A_COS + 1]
    return s_theta * c - c_theta * s


def _first_blocked_of(rows, a, b) -> tuple[int, float, float]:
    """The first cell whose end is not reachable (the reachable facets are a
    prefix of the table), from every cell's reach at its start `a` and end `b`
    (:func:`_reach`): ``(j, a[j], b[j])``, or ``(-1, 0.0, 0.0)`` where every
    cell is reachable. A cell of zero span ends where it starts."""
    ends = np.where(rows[:-1, A_SIN + 1] == 0.0, a, b)
    blocked = np.flatnonzero(~(ends > 0.0))
    if blocked.size == 0:
        return -1, 0.0, 0.0
    j = int(blocked[0])
    return j, float(a[j]), float(b[j])


def first_blocked(st: float, ct: float, rows: np.ndarray) -> tuple[int, float, float]:
    """:func:`_first_blocked_of` at the apparent angle with sine `st` and cosine
    `ct`: by the compiled kernel where there is one (``_ckernel.reach_cut``:
    the same operations, so the same bits, stopping at the first blocked cell
    and without holding the GIL; issue 31: a sweep's angles are set up before its
    workers start), else with NumPy."""
    ck = _compiled.ckernel
    if ck is None:
        return _first_blocked_of(
            rows, _reach(st, ct, rows, 0.0), _reach(st, ct, rows, 1.0)
        )
    rows = np.ascontiguousarray(rows, dtype=np.float64)
    j, a_j, b_j = ck.reach_cut(rows, rows.shape[1], A_SIN, A_COS, st, ct)
    return j, a_j, b_j


def pair_sin(st, ct, sa, ca, sb, cb):
    """``sin`` and ``cos`` of ``theta - a - b`` as the kernels compute them."""
    s1 = st * ca - ct * sa
    c1 = ct * ca + st * sa
    return s1 * cb - c1 * sb, c1 * cb + s1 * sb


def _reachable_counts(a: Sampler, b: Sampler, st, ct, angle_deg):
    """Per surface atom ``a_i``: the number of particle atoms (a prefix of the
    sorted ``b``) whose pair is reachable, ``sin(theta - a_i - b_j) > 0`` as the
    kernels compute it."""
    n_b = b.table.size
    ra, rb = a.rows[:-1], b.rows[:-1]
    theta = np.deg2rad(angle_deg)
    bv = b.values[:, 0]
    counts = np.searchsorted(bv, theta - a.values[:, 0], side="left")
    for _ in range(3):  # agree with the kernels' own sign at the boundary
        jm = np.clip(counts - 1, 0, n_b - 1)
        s_lo = pair_sin(
            st, ct, ra[:, A_SIN], ra[:, A_COS], rb[jm, A_SIN], rb[jm, A_COS]
        )[0]
        counts = np.where((counts > 0) & ~(s_lo > 0), counts - 1, counts)
        jp = np.clip(counts, 0, n_b - 1)
        s_hi = pair_sin(
            st, ct, ra[:, A_SIN], ra[:, A_COS], rb[jp, A_SIN], rb[jp, A_COS]
        )[0]
        counts = np.where((counts < n_b) & (s_hi > 0), counts + 1, counts)
    return counts


def _leaning_back(a: Sampler, b: Sampler, st, ct, angle_deg):
    """Per surface atom ``a_i``: the number of particle atoms (a prefix of the
    sorted ``b``) whose pair leans back past -90 deg, ``a_i + b_j < theta - pi``,
    where ``sin(theta - a_i - b_j) <= 0`` as the kernels compute it although the
    pair is below ``theta`` (steep facets on both sides)."""
    n_b = b.table.size
    ra, rb = a.rows[:-1], b.rows[:-1]
    theta = np.deg2rad(angle_deg)
    bv = b.values[:, 0]
    first = np.searchsorted(bv, theta - np.pi - a.values[:, 0], side="right")

    def sine(j):
        jc = np.clip(j, 0, n_b - 1)
        return pair_sin(
            st, ct, ra[:, A_SIN], ra[:, A_COS], rb[jc, A_SIN], rb[jc, A_COS]
        )[0]

    for _ in range(3):  # agree with the kernels' own sign at the boundary
        first = np.where((first > 0) & (sine(first - 1) > 0), first - 1, first)
        first = np.where((first < n_b) & ~(sine(first) > 0), first + 1, first)
    return first


def _leans_back(a: Sampler, b: Sampler, angle_deg) -> bool:
    """Whether some pairs of the atoms of `a` and `b` lean back past -90 deg at
    `angle_deg` (the range ``[m_i, n_i)`` of some surface atom starts above 0)."""
    theta = np.deg2rad(angle_deg)
    st, ct = float(np.sin(theta)), float(np.cos(theta))
    counts = _reachable_counts(a, b, st, ct, angle_deg)
    return bool(np.minimum(_leaning_back(a, b, st, ct, angle_deg), counts).any())


def _pair_tables(pair: PairSampler, st, ct, angle_deg, shadowing) -> AngleTables:
    """The per-angle table of a :class:`PairSampler`: one cell per surface atom
    with its ``n_i - m_i`` reachable pairs (every pair for ``"none"``, or where
    none is reachable), the ranks placed in the top bits, and ``m_i`` in the
    rows (:data:`PAIR_FIRST`). The shadowed mass is that of the unreachable
    pairs, the ones leaning back past -90 deg included."""
    a, b = pair.surface, pair.particle
    n_a, n_b = a.table.size, b.table.size
    counts = _reachable_counts(a, b, st, ct, angle_deg)
    first = np.minimum(_leaning_back(a, b, st, ct, angle_deg), counts)
    reach = counts - first
    shadowed = 1.0 - int(reach.sum()) / (n_a * n_b)
    count = shadowing == "none" or not reach.any()  # nothing reachable: count
    if count:  # every pair; the unreachable ones are counted as shadowed
        first = np.zeros(n_a, dtype=np.int64)
        reach = np.full(n_a, n_b, dtype=np.int64)
    total = int(reach.sum())
    shift = 64 - (total - 1).bit_length() if total > 1 else 63
    starts = np.concatenate([[0], np.cumsum(reach)[:-1]]).astype(np.uint64)
    cum = starts << np.uint64(shift)
    sub = CellTable.from_cells(cum, a.table.left, a.table.right)
    cells = np.flatnonzero(nonempty_cells(cum))
    plain = a.subset(sub, cells)
    rows = np.zeros((sub.size + 1, PAIR_FIRST + 1))
    rows[:, :PAIR_FIRST] = plain.rows
    rows[:-1, PAIR_FIRST] = first[cells]
    sampler = Sampler(sub, rows, plain.values)
    return AngleTables(sampler, 0, st, ct, shadowed, True, b, total, shift, count)


def _search_tables(pair: PairSearch, st, ct, angle_deg, shadowing) -> AngleTables:
    """The per-angle table of a :class:`PairSearch`: surface atom ``i`` with
    probability ``w_i (C_i(n_i) - C_i(m_i))`` (normalised), its rows extended by
    ``alpha_i``, ``beta_i``, the rejection's bound, ``n_i``, ``C_i(n_i) -
    C_i(m_i)``, ``m_i`` and the ends of the proposal's bands (:data:`Q_ALPHA`
    ...)."""
    a = pair.surface
    n_b = pair.particle.table.size
    counts = _reachable_counts(a, pair.particle, st, ct, angle_deg)
    lean = np.minimum(_leaning_back(a, pair.particle, st, ct, angle_deg), counts)
    w = a.table.widths()
    masses = pair.particle.rows[:, P_ONE]  # cumsum of v, from 0
    # the unreachable pairs: at or above theta, and leaning back past -90 deg
    shadowed = max(0.0, 1.0 - float(np.sum(w * (masses[counts] - masses[lean]))))
    count = shadowing == "none" or not (counts > lean).any()  # nothing reachable
    ra = a.rows[:-1]
    while True:
        first = lean
        if count:  # every pair, by mass; the unreachable ones are counted
            counts = np.full(a.table.size, n_b, dtype=np.int64)
            first = np.zeros(a.table.size, dtype=np.int64)
        if shadowing == "weighted" and not count:
            part = pair.sine
            alpha = st * ra[:, A_COS] - ct * ra[:, A_SIN]  # sin(theta - a_i)
            beta = -(ct * ra[:, A_COS] + st * ra[:, A_SIN])  # -cos(theta - a_i)
        else:
            part = pair.particle
            alpha = np.ones(a.table.size)
            beta = np.zeros(a.table.size)
        rp = part.rows
        total = alpha * rp[counts, P_ONE] + beta * rp[counts, P_TWO]
        total = total - (alpha * rp[first, P_ONE] + beta * rp[first, P_TWO])
        mass = w * np.where(counts > first, np.maximum(total, 0.0), 0.0)
        keep = np.flatnonzero(mass > 0)
        if keep.size or count:
            break
        count = True  # round-off: reachable by a hair, with zero weight
    c = np.cumsum(mass[keep])
    cum = fraction_to_integer(np.r_[0.0, c[:-1]] / c[-1])
    sub = CellTable.from_cells(cum, a.table.left[keep], a.table.right[keep])
    cells = keep[nonempty_cells(cum)]
    n = sub.size
    rows = np.zeros((n + 1, Q_BANDS + PAIR_BANDS + 1))
    rows[:, R_CUM] = sub.cum.view(np.float64)
    rows[:n, R_INVW] = sub.inv_width
    rows[:n, 2:8] = a.rows[cells, 2:8]
    rows[:n, Q_ALPHA] = alpha[cells]
    rows[:n, Q_BETA] = beta[cells]
    rows[:n, Q_COUNT] = counts[cells]
    rows[:n, Q_TOTAL] = total[cells]
    rows[:n, Q_FIRST] = first[cells]
    first, counts = first[cells], counts[cells]
    weighted = part is not pair.particle  # else the masses: the proposal is the
    ends, lam = _search_bands(  # target (lam = 0: every proposal accepted)
        part, alpha[cells], beta[cells], first, counts, weighted
    )
    rows[:n, Q_BOUND] = lam
    rows[:n, Q_BANDS:] = ends.view(np.float64)
    sampler = Sampler(sub, rows, np.ascontiguousarray(a.values[cells]))
    return AngleTables(
        sampler,
        0,
        st,
        ct,
        shadowed,
        True,
        part,
        count_shadowed=count,
        pair_search=True,
    )


def _angle_tables(sampler, angle_deg: float, shadowing: str) -> AngleTables:
    theta = np.deg2rad(angle_deg)
    st, ct = float(np.sin(theta)), float(np.cos(theta))
    if sampler is None:  # molecularly smooth: phi = 0 exactly
        return AngleTables(None, 0, st, ct, 0.0, False)
    if isinstance(sampler, PairSampler):
        return _pair_tables(sampler, st, ct, angle_deg, shadowing)
    if isinstance(sampler, PairSearch):
        return _search_tables(sampler, st, ct, angle_deg, shadowing)
    # an areal surface: one cell per (phi_par, phi_perp) pair, reachable by
    # phi_par alone; "weighted" multiplies by the exposure's cos(chi) as well
    areal = isinstance(sampler, ArealSampler)
    table, rows = sampler.table, sampler.rows
    if shadowing == "weighted":  # every cell's reach, for the weights below
        a = _reach(st, ct, rows, 0.0)  # at the start of each cell
        b = _reach(st, ct, rows, 1.0)  # at its end
        j, a_j, b_j = _first_blocked_of(rows, a, b)
    else:  # only the first cell that cannot be reached
        j, a_j, b_j = first_blocked(st, ct, rows)
    if j < 0:
        cut, shadowed = 0, 0.0
    else:
        start = int(table.cum[j])
        if a_j > 0.0:  # the crossing inside cell j: sin(theta - phi) linear in f
            width = (int(table.cum[j + 1]) if j + 1 < table.size else 2**64) - start
            f_star = a_j / (a_j - b_j)
            start += min(width, int(f_star * width))
        cut = start
        shadowed = 1.0 - cut / 2.0**64
    if shadowing == "none" or (cut == 0 and j >= 0):
        # "none"; or no facet at all can be reached at this angle, which every
        # option reports the same way: each sample is shadowed, none impacts
        return AngleTables(
            sampler, 0, st, ct, shadowed, True, count_shadowed=True, areal=areal
        )
    if shadowing == "reject":
        return AngleTables(sampler, cut, st, ct, shadowed, True, areal=areal)
    # "weighted": each cell's mass times the mean of sin(theta - phi)_+ over it
    # (linear in the fraction, so the integral is exact for the table)
    with np.errstate(divide="ignore", invalid="ignore"):
        # the mean over the cell of (a + (b - a) f)_+: a trapezium, or a triangle
        # where the cell straddles theta
        tri_a = np.where(b > 0, 0.5 * b * b / (b - a), 0.0)
        pos = np.where(
            (a > 0) & (b >= 0),
            0.5 * (a + b),
            np.where(a > 0, 0.5 * a * a / (a - b), tri_a),
        )
        f_end = np.where((a > 0) & (b < 0), a / (a - b), 1.0)
    mass = table.widths() * pos
    if areal:
        # the facet's exposure max(0, -n'.u) = cos(chi) sin(theta - phi_par)_+
        # (docs/engine.md); cos(chi) = 1 exactly where phi_perp = 0
        mass = mass * rows[:-1, A_COSX]
    if not mass.sum() > 0:  # round-off: reachable by a hair, with zero weight
        return AngleTables(
            sampler, 0, st, ct, 1.0, True, count_shadowed=True, areal=areal
        )
    keep = np.flatnonzero(mass > 0)
    last = int(keep[-1]) + 1
    first = int(keep[0])
    m = mass[first:last]
    c = np.cumsum(m)
    cum = fraction_to_integer(np.r_[0.0, c[:-1]] / c[-1])
    sub = CellTable.from_cells(
        cum, table.left[first:last], table.right[first:last], scale=f_end[first:last]
    )
    # from_cells drops cells that round to zero probability: keep their rows out too
    cells = np.arange(first, last)[nonempty_cells(cum)]
    return AngleTables(
        sampler.subset(sub, cells), 0, st, ct, shadowed, True, areal=areal
    )


#: Largest angle strictly inside (-pi/2, pi/2) [rad].
_LIMIT = float(np.nextafter(np.pi / 2, 0.0))


def _angle_sampler(table: CellTable) -> Sampler:
    # angles outside (-90, 90) deg are not facets (an untruncated distribution):
    # clipped, so that the reachable facets are a prefix of the table
    lo = np.clip(table.left, -_LIMIT, _LIMIT)
    hi = np.clip(table.right, -_LIMIT, _LIMIT)
    return Sampler.of(
        table,
        (lo, hi),
        (np.sin(lo), np.sin(hi)),
        (np.cos(lo), np.cos(hi)),
        (np.tan(lo), np.tan(hi)),
    )


def convolve_angles(a, b) -> CellTable:
    """Table of the sum of two independent angles (surface + particle roughness).

    Exact at the refined grid's nodes when at least one of the two is continuous
    (the CDF of the sum is a mixture, or a Gauss–Legendre integral in probability,
    inverted on a fine grid and checked against the exact CDF), exact for two
    discrete ones with at most ``MAX_SUM_ATOMS`` pairs, and otherwise the reduced
    convolution of 1,024 atoms each (see :mod:`._convolution`).
    """
    return sum_table(a, b)


@lru_cache(maxsize=8)
def _speed_factor_table(relative_std: float) -> CellTable:
    """Normal speed factor N(1, relative_std) truncated to (0, 2) (symmetric, so the
    upper half is ``2 - ppf(s)``)."""
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.special import ndtr, ndtri

    lo, hi = ndtr(-1.0 / relative_std), ndtr(1.0 / relative_std)

    def ppf(q):
        return 1.0 + relative_std * ndtri(lo + q * (hi - lo))

    def isf(s):
        return 1.0 - relative_std * ndtri(lo + s * (hi - lo))

    return CellTable.from_quantile(ppf, isf)


def resolve_entropy(seed) -> int:
    """Root entropy: the seed itself, or fresh OS entropy when `seed` is None."""
    if seed is None:
        return int(np.random.SeedSequence().entropy)
    if isinstance(seed, np.random.SeedSequence):
        return int(seed.entropy)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"`seed` must be an integer >= 0 or None; got {seed!r}.")
    return int(seed)


def resolve_kernel(kernel=None) -> str:
    """``"compiled"`` or ``"numpy"``: `kernel` (one of :data:`KERNEL_CHOICES` or
    None), where None reads the environment variable :data:`KERNEL_ENV`; ``auto``
    takes the compiled kernel when it is installed."""
    source = "argument `kernel`"
    if kernel is None:
        raw = os.environ.get(KERNEL_ENV, "")
        kernel = raw.strip().lower() or "auto"
        source = f"environment variable {KERNEL_ENV}={raw!r}"
    if kernel not in KERNEL_CHOICES:
        raise InputError(f"{source}: expected one of {', '.join(KERNEL_CHOICES)}")
    if kernel == "numpy":
        return "numpy"
    if _compiled.ckernel is None:
        if kernel == "compiled":
            raise InputError(
                f"{source} asks for the compiled kernel, but it is not installed "
                f"({_compiled.ERROR}); reinstall microimpact on a machine with a C "
                "compiler"
            ) from _compiled.ERROR
        return "numpy"
    return "compiled"


#: Largest number of (surface, particle) angle pairs drawn exactly.
MAX_PAIRS = 1 << 40


def _is_areal(angles) -> bool:
    return bool(getattr(angles, "is_areal", False))


def _surface_sampler(variant, particle_roughness, shadowing, source=None):
    if _is_areal(particle_roughness):
        raise ScenarioError(
            "a particle's roughness is one angle; an areal (two-angle) "
            "distribution is a surface's",
            source=source,
            field="particle_roughness",
        )
    if _is_areal(variant.angles):
        if particle_roughness is not None:
            raise ScenarioError(
                f"surface {variant.name!r} is areal: a rough particle on an areal "
                "surface is not supported yet (how the particle's one angle "
                "combines with the facet's two is not defined); remove "
                "particle_roughness or use a profile surface",
                source=source,
                field="particle_roughness",
            )
        return areal_sampler(variant.angles)
    if variant.angles is None and particle_roughness is None:
        return None
    if variant.angles is None:
        table = cell_table(particle_roughness)
    elif particle_roughness is None:
        table = cell_table(variant.angles)
    else:
        ta, tb = cell_table(variant.angles), cell_table(particle_roughness)
        if (
            shadowing != "weighted"
            and ta.kind == tb.kind == CellTable.EQUAL
            and ta.size * tb.size <= MAX_PAIRS
        ):
            return PairSampler(_angle_sampler(ta), _angle_sampler(tb))
        if (
            discrete_atoms(variant.angles) is not None
            and discrete_atoms(particle_roughness) is not None
            and ta.size * tb.size > MAX_SUM_ATOMS
        ):  # too many pairs to tabulate their sums: drawn by a search
            return _pair_search(ta, tb, shadowing)
        table = convolve_angles(variant.angles, particle_roughness)
        _warn_beyond_vertical(table, variant.name)
    return _angle_sampler(table)


#: Probability of summed facet angles beyond +-90 deg above which the build warns
#: that they are simulated at +-90 deg (far below 0.1 SE at 10^9 impacts under it).
BEYOND_VERTICAL_WARN = 1e-9


def _warn_beyond_vertical(table: CellTable, surface: str) -> None:
    """Warn when the summed angle (surface + particle roughness) puts more than
    :data:`BEYOND_VERTICAL_WARN` of its probability in cells reaching beyond
    +-90 deg: the angle sampler clips them to +-90 deg (a near-vertical facet,
    reachable for ``theta < 90``), where a pair of two measured sets is simulated
    at its own angle (and left out when it leans back past ``theta - 180``)."""
    w = table.widths()
    out = (table.left < -_LIMIT) | (table.right > _LIMIT)
    p = float(np.sum(w[out]))
    if p > BEYOND_VERTICAL_WARN:
        warnings.warn(
            f"surface {surface!r}: the surface and particle roughness angles sum "
            f"beyond +-90 deg with probability {p:.2g} (steep facets on both); "
            "those facets are simulated at +-90 deg (the summed-angle table clips "
            "them), not at their own angle; narrow either distribution, or give "
            "both as measured angle sets (pairs are then simulated exactly)",
            RuntimeWarning,
            stacklevel=4,
        )


def diameter_sampler(scenario, particles=None, *, table=None) -> Sampler:
    """The kernel's diameter table for `scenario` (rows 1/k1, 1/k2, v_c, d): the
    cells of `particles` (default ``scenario.particles``; or `table`, the cells
    already made) with the scenario's coefficient laws evaluated at both ends of
    each cell. A wall law's plan per fixed diameter comes from
    :func:`atom_sampler` instead (the same sampler)."""
    if table is None:
        table = cell_table(scenario.particles if particles is None else particles)
    columns = [_coefficient_columns(scenario, table.left)]
    if not np.array_equal(table.left, table.right):
        columns.append(_coefficient_columns(scenario, table.right))
    else:  # (atoms: both ends the same, so the columns)
        columns.append(columns[0])
    return Sampler.of(
        table, (table.left, table.right), *zip(columns[0], columns[1], strict=True)
    )


def _coefficient_columns(scenario, d) -> tuple:
    """``(1/k1, 1/k2, v_c)`` of the scenario's coefficient laws at diameters `d`
    [m] (an array), checked: a value the laws may not give raises the
    :class:`ScenarioError` of :func:`_bad_coefficient`."""
    k1, k2, v_c = (
        np.broadcast_to(np.asarray(a, dtype=float), d.shape)
        for a in scenario.coefficients.evaluate(d)
    )
    every = np.stack([k1, k2, v_c])
    if not (np.all(every >= 0) and np.all(np.isfinite(v_c))):
        _bad_coefficient(scenario, d, k1, k2, v_c)
    with np.errstate(divide="ignore"):
        return 1.0 / k1, 1.0 / k2, v_c


def atom_columns(scenario, diameters) -> np.ndarray:
    """``(n, 3)``: the columns ``1/k1, 1/k2, v_c`` of each of the `n` fixed
    `diameters` [m], the coefficient laws evaluated once over all of them (for
    :func:`atom_sampler`; a wall law's diameter nodes). The laws are elementwise,
    so each row has the bits of an evaluation at its diameter alone (tested
    for every kind of law)."""
    d = np.array(diameters, dtype=float).reshape(-1)
    return np.column_stack(_coefficient_columns(scenario, d))


def atom_sampler(diameter: float, columns) -> Sampler:
    """The kernel's diameter table of the one diameter `diameter` [m], with its
    coefficient columns `columns` (its row of :func:`atom_columns`): every field
    of ``diameter_sampler(scenario, table=one_atom_table(diameter))``, bit for
    bit (tests/engine/test_sampling_tables.py), its two rows written directly
    (an atom's spans are +0.0). The generic path held the GIL ~0.1-0.5 ms per
    diameter of a wall law (issue 31)."""
    table = one_atom_table(diameter)
    rows = np.zeros((2, 8))
    rows[:, R_CUM] = table.cum.view(np.float64)
    rows[0, R_INVW] = table.inv_width[0]
    rows[0, 2::2] = columns  # each column's lo; its span +0.0
    values = np.zeros((1, 2))
    values[0, 0] = table.left[0]
    return Sampler(table, rows, values)


def _bad_coefficient(scenario, end, k1, k2, v_c):
    """Raise the error of the first coefficient the law gives outside its range
    (:func:`diameter_sampler`): NaN or negative, or an infinite v_c."""
    for name, arr in (("k1", k1), ("k2", k2), ("v_c", v_c)):
        bad = np.isnan(arr) | (arr < 0) | ((name == "v_c") & np.isinf(arr))
        if np.any(bad):
            i = int(np.argmax(bad))
            raise ScenarioError(
                f"the law gives {arr[i]!r} at diameter {end[i] * 1e6:.4g} µm; "
                "coefficients must be >= 0 (k1, k2 may be inf) over the whole "
                "particle distribution",
                source=scenario.source,
                field=f"coefficients.{name}",
            )


def build_plan(scenario, *, seed=None, kernel=None) -> Plan:
    """Tabulate everything the kernel needs for `scenario` (see :mod:`.plan`).

    `kernel` is ``"compiled"``, ``"numpy"``, ``"auto"`` or None (the environment
    variable ``MICROIMPACT_KERNEL``, else auto); the choice is ``plan.kernel``.
    Every scenario runs on either kernel, areal surfaces and QMC included.
    """
    kernel = resolve_kernel(kernel)
    entropy = resolve_entropy(scenario.seed if seed is None else seed)
    diameters = diameter_sampler(scenario)
    coeffs = scenario.coefficients
    points = GridPoints(SweepGrid.from_scenario(scenario))
    surfaces = tuple(
        _surface_sampler(
            v, scenario.particle_roughness, scenario.shadowing, scenario.source
        )
        for v in scenario.surfaces
    )
    speeds = None
    if scenario.speed_spread > 0:
        st = _speed_factor_table(float(scenario.speed_spread))
        speeds = Sampler.of(st, (st.left, st.right), (st.left, st.right))
    return Plan(
        entropy=entropy,
        points=points,
        diameters=diameters,
        p=float(coeffs.p),
        q=float(coeffs.q),
        friction=float(coeffs.friction),
        speeds=speeds,
        surfaces=surfaces,
        shadowing=scenario.shadowing,
        sampling=scenario.sampling,
        replicates=scenario.qmc_replicates if scenario.sampling == "qmc" else 1,
        block_size=BLOCK_SIZE,
        kernel=kernel,
    )
