"""The engine's plan: everything a worker needs, precomputed once.

Every random input is an equiprobable :class:`~microimpact._tables.QuantileTable`
(``M = 2**16`` atoms), so a draw is one table index taken from the high bits of a
64-bit random integer, and everything that depends only on the drawn value is
tabulated on the same atoms:

* the diameter atoms ``d_j`` give ``1/k1(d_j)``, ``1/k2(d_j)``, ``v_c(d_j)``
  (the coefficient laws are evaluated 65,536 times per run, not once per impact);
* the roughness-angle atoms ``phi_j`` give, for each apparent angle ``theta`` of the
  sweep, ``sin(theta - phi_j)``, ``cot(theta - phi_j)`` and ``tan(phi_j)``, so the
  kernel computes no trigonometric function at all.

Shadowing is applied to the angle table of each sweep angle, exactly and without
rejection loops (which keeps quasi-Monte Carlo structure intact):

* ``"reject"``: the atoms with ``phi >= theta`` are removed and the rest re-weighted
  equally: the angle distribution conditioned on the facet being reachable. This is the
  paper's situation (every simulated impact strikes a reachable facet).
* ``"weighted"``: each atom is weighted by ``sin(theta - phi)_+ / sin(theta)``, the
  Sommerfeld & Huber (1999) effective PDF of the facets a particle actually hits.
* ``"none"``: the table is used as it is and unreachable facets are counted as
  ``shadowed``.

In the first two cases the removed probability ``P(phi >= theta)`` is reported as the
shadowed fraction (exact, from the table).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from .._tables import TABLE_SIZE, QuantileTable, mid_probabilities
from ..errors import ScenarioError
from ..grid import GridPoint, SweepGrid

#: Samples per block: the engine's unit of randomness (an algorithm constant, never
#: derived from the worker count or the memory).
BLOCK_SIZE = 1 << 15
#: Atoms per one-dimensional table used when convolving two angle distributions.
CONVOLUTION_ATOMS = 1024

# Variable ids in the stream keys (fixed: adding a variable never shifts the others).
VAR_DIAMETER, VAR_ANGLE, VAR_SPEED = 0, 1, 2


#: One sweep point (the grid owns the numbering; see :mod:`microimpact.grid`).
SweepPoint = GridPoint


#: Columns of an angle-table row (one 64-byte row per distinct angle atom).
A_SIN, A_COT, A_TAN, A_TANCOT, A_GAIN, A_PHI = range(6)


@dataclass(frozen=True, eq=False)
class AngleTables:
    """Per-atom quantities for one (surface, apparent angle) pair.

    ``rows[row_of_atom[j]]`` holds, for angle atom ``j``: ``sin(theta - phi)`` (so
    ``|v_n'| = speed * sin``), ``cot(theta - phi) = v_t'/v_n'``, ``tan(phi)``,
    ``tan(phi) cot(theta - phi)``, ``1 / (1 + tan(phi) cot(theta - phi))`` (the Eq. 8
    denominator) and ``phi`` itself, padded to 8 columns. Measured angle sets have far
    fewer distinct atoms than the 65,536 equiprobable ones, so the distinct rows and
    the 16-bit map stay in the L2 cache. A molecularly smooth surface has one row
    (phi = 0 exactly) and needs no angle draw.
    """

    rows: np.ndarray
    row_of_atom: np.ndarray
    shadowed_mass: float  # P(phi >= theta) under the surface's own distribution
    random: bool  # False for a smooth surface

    def __post_init__(self):
        # the layout the compiled kernel reads without checking each row number
        if not (
            self.rows.dtype == np.float64
            and self.rows.ndim == 2
            and self.rows.flags.c_contiguous
            and self.row_of_atom.dtype == np.uint16
            and self.row_of_atom.size
            and int(self.row_of_atom.max()) < self.rows.shape[0]
        ):
            raise ValueError("AngleTables: row_of_atom must index rows (internal)")

    @property
    def phi(self) -> np.ndarray:
        """The equiprobable angle atoms [rad]."""
        return self.rows[self.row_of_atom, A_PHI]


@dataclass(frozen=True, eq=False)
class Plan:
    """Picklable description of a run for the kernel (built by
    :func:`build_plan`)."""

    entropy: int
    points: tuple[SweepPoint, ...]
    diameter: np.ndarray  # atoms [m]
    coefficients: np.ndarray  # (M, 4) rows (1/k1, 1/k2, v_c, 0) per diameter atom
    p: float
    q: float
    friction: float
    speed_factor: np.ndarray | None  # atoms of the relative speed factor, or None
    surface_atoms: tuple[np.ndarray | None, ...]  # per surface variant [rad]
    shadowing: str
    sampling: str = "mc"
    replicates: int = 1
    block_size: int = BLOCK_SIZE
    table_bits: int = 16
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def inv_k1(self) -> np.ndarray:
        """1/k1 per diameter atom [s m-1]."""
        return self.coefficients[:, 0]

    @property
    def inv_k2(self) -> np.ndarray:
        """1/k2 per diameter atom [s m-1]."""
        return self.coefficients[:, 1]

    @property
    def v_c(self) -> np.ndarray:
        """Capture velocity per diameter atom [m s-1]."""
        return self.coefficients[:, 2]

    def angle_tables(self, surface: int, angle_deg: float) -> AngleTables:
        """Tables of one (surface, angle), cached (a sweep revisits each angle once
        per speed)."""
        key = (surface, float(angle_deg))
        tables = self._cache.get(key)
        if tables is None:
            if len(self._cache) >= 16:
                self._cache.clear()
            tables = self._cache[key] = _angle_tables(
                self.surface_atoms[surface], float(angle_deg), self.shadowing
            )
        return tables

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_cache"] = {}
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)


def _angle_tables(atoms, angle_deg: float, shadowing: str) -> AngleTables:
    theta = np.deg2rad(angle_deg)
    if atoms is None:  # molecularly smooth: phi = 0 exactly
        s, c = np.sin(theta), np.cos(theta)
        rows = np.zeros((1, 8))
        rows[0, [A_SIN, A_COT, A_GAIN]] = s, c / s, 1.0
        return AngleTables(rows, np.zeros(1, dtype=np.uint16), 0.0, False)
    phi = atoms
    reachable = phi < theta
    shadowed_mass = 1.0 - float(np.count_nonzero(reachable)) / phi.size
    if shadowing != "none" and shadowed_mass > 0.0:
        if shadowed_mass >= 1.0:
            raise ValueError(
                f"every roughness angle shadows the facet at the apparent angle "
                f"{angle_deg} deg: no facet can be reached."
            )
        if shadowing == "reject":
            weights = reachable.astype(float)
        else:
            weights = np.where(reachable, np.sin(theta - phi), 0.0)
        phi = QuantileTable.from_weights(phi, weights, size=phi.size).values
    elif shadowing == "weighted":
        weights = np.sin(theta - phi)
        phi = QuantileTable.from_weights(phi, weights, size=phi.size).values
    # the atoms are sorted, so equal atoms are adjacent: an O(M) run-length map
    starts = np.empty(phi.size, dtype=bool)
    starts[0] = True
    np.not_equal(phi[1:], phi[:-1], out=starts[1:])
    row_of_atom = (np.cumsum(starts) - 1).astype(np.uint16)
    distinct = phi[starts]
    true = theta - distinct
    rows = np.zeros((distinct.size, 8))
    with np.errstate(divide="ignore", invalid="ignore"):
        rows[:, A_SIN] = np.sin(true)
        rows[:, A_COT] = np.where(true > 0, np.cos(true) / rows[:, A_SIN], 0.0)
        rows[:, A_TAN] = np.tan(distinct)
        rows[:, A_TANCOT] = rows[:, A_TAN] * rows[:, A_COT]
        rows[:, A_GAIN] = 1.0 / (1.0 + rows[:, A_TANCOT])
    rows[:, A_PHI] = distinct
    return AngleTables(rows, row_of_atom, shadowed_mass, True)


def convolve_angles(a: QuantileTable, b: QuantileTable, *, size: int = TABLE_SIZE):
    """Table of the sum of two independent angles (surface + particle roughness).

    Each table is reduced to :data:`CONVOLUTION_ATOMS` equiprobable atoms, all pairs are
    summed (an exact discrete convolution of the reduced tables), and the result is
    re-tabulated; the Kolmogorov distance to the exact convolution is at most
    ``1/CONVOLUTION_ATOMS``.
    """
    m = CONVOLUTION_ATOMS
    ia = ((np.arange(m) + 0.5) * a.size / m).astype(np.intp)
    ib = ((np.arange(m) + 0.5) * b.size / m).astype(np.intp)
    sums = (a.values[ia][:, None] + b.values[ib][None, :]).ravel()
    return QuantileTable.from_sample(sums, size=size)


@lru_cache(maxsize=8)
def _speed_factor_atoms(relative_std: float, size: int) -> np.ndarray:
    """Atoms of a normal speed factor N(1, relative_std) truncated to (0, 2)."""
    from scipy.special import ndtr, ndtri

    lo, hi = ndtr(-1.0 / relative_std), ndtr(1.0 / relative_std)
    q = mid_probabilities(size)
    atoms = 1.0 + relative_std * ndtri(lo + q * (hi - lo))
    atoms.setflags(write=False)
    return atoms


def resolve_entropy(seed) -> int:
    """Root entropy: the seed itself, or fresh OS entropy when `seed` is None."""
    if seed is None:
        return int(np.random.SeedSequence().entropy)
    if isinstance(seed, np.random.SeedSequence):
        return int(seed.entropy)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"`seed` must be an integer >= 0 or None; got {seed!r}.")
    return int(seed)


def _surface_atoms(variant, particle_roughness):
    if variant.angles is None and particle_roughness is None:
        return None
    if variant.angles is None:
        table = particle_roughness.table()
    else:
        table = variant.angles.table()
        if particle_roughness is not None:
            table = convolve_angles(table, particle_roughness.table())
    return table.values


def build_plan(scenario, *, seed=None) -> Plan:
    """Tabulate everything the kernel needs for `scenario` (see :mod:`.plan`)."""
    entropy = resolve_entropy(scenario.seed if seed is None else seed)
    table: QuantileTable = scenario.particles.table()
    diameter = table.values
    coeffs = scenario.coefficients
    k1, k2, v_c = (
        np.broadcast_to(np.asarray(a, dtype=float), diameter.shape)
        for a in coeffs.evaluate(diameter)
    )
    for name, arr in (("k1", k1), ("k2", k2), ("v_c", v_c)):
        bad = np.isnan(arr) | (arr < 0) | ((name == "v_c") & np.isinf(arr))
        if np.any(bad):
            i = int(np.argmax(bad))
            raise ScenarioError(
                f"the law gives {arr[i]!r} at diameter {diameter[i] * 1e6:.4g} µm; "
                "coefficients must be >= 0 (k1, k2 may be inf) over the whole "
                "particle distribution",
                source=scenario.source,
                field=f"coefficients.{name}",
            )
    coefficients = np.zeros((diameter.size, 4))  # interleaved: one row per atom
    with np.errstate(divide="ignore"):
        np.divide(1.0, k1, out=coefficients[:, 0])
        np.divide(1.0, k2, out=coefficients[:, 1])
    coefficients[:, 2] = v_c
    points = tuple(SweepGrid.from_scenario(scenario).points())
    surface_atoms = tuple(
        _surface_atoms(v, scenario.particle_roughness) for v in scenario.surfaces
    )
    speed_factor = None
    if scenario.speed_spread > 0:
        speed_factor = _speed_factor_atoms(float(scenario.speed_spread), table.size)
    return Plan(
        entropy=entropy,
        points=points,
        diameter=diameter,
        coefficients=coefficients,
        p=float(coeffs.p),
        q=float(coeffs.q),
        friction=float(coeffs.friction),
        speed_factor=speed_factor,
        surface_atoms=surface_atoms,
        shadowing=scenario.shadowing,
        sampling=scenario.sampling,
        replicates=scenario.qmc_replicates if scenario.sampling == "qmc" else 1,
        block_size=BLOCK_SIZE,
        table_bits=table.bits,
    )
