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

from .._tables import TABLE_SIZE, QuantileTable

#: Samples per block: the engine's unit of randomness (an algorithm constant, never
#: derived from the worker count or the memory).
BLOCK_SIZE = 1 << 15
#: Atoms per one-dimensional table used when convolving two angle distributions.
CONVOLUTION_ATOMS = 1024

SHADOWING_OPTIONS = ("reject", "weighted", "none")
SAMPLING_OPTIONS = ("mc", "qmc")

# Variable ids in the stream keys (fixed: adding a variable never shifts the others).
VAR_DIAMETER, VAR_ANGLE, VAR_SPEED = 0, 1, 2


@dataclass(frozen=True)
class SweepPoint:
    """One sweep point: surface variant x incident speed x apparent angle."""

    index: int
    surface: int
    surface_name: str
    speed: float  # [m s-1]
    angle_deg: float  # apparent incidence angle from the nominal plane [deg]


@dataclass(frozen=True)
class AngleTables:
    """Per-atom quantities for one (surface, apparent angle) pair.

    Scalars for a molecularly smooth surface (phi = 0 exactly).
    """

    sin_true: np.ndarray | float  # sin(theta - phi): |v_n'| = speed * sin_true
    cot_true: np.ndarray | float  # cot(theta - phi) = v_t'/v_n'
    tan_phi: np.ndarray | float
    tan_cot: np.ndarray | float  # tan(phi) * cot(theta - phi)
    gain: np.ndarray | float  # 1 / (1 + tan(phi) cot(theta - phi))  (Eq. 8 denominator)
    phi: np.ndarray | float  # the atoms themselves [rad]
    shadowed_mass: float  # P(phi >= theta) under the surface's own distribution
    random: bool  # False for a smooth surface (no angle draw needed)
    rows: np.ndarray | None = None  # interleaved copy for the compiled kernel


@dataclass(frozen=True, eq=False)
class Plan:
    """Picklable description of a run for the kernel (built by :func:`build_plan`)."""

    entropy: int
    points: tuple[SweepPoint, ...]
    diameter: np.ndarray  # atoms [m]
    inv_k1: np.ndarray  # 1/k1 per diameter atom [s m-1]
    inv_k2: np.ndarray  # 1/k2 per diameter atom [s m-1]
    v_c: np.ndarray  # capture velocity per diameter atom [m s-1]
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

    def angle_tables(self, surface: int, angle_deg: float) -> AngleTables:
        key = (surface, float(angle_deg))
        tables = self._cache.get(key)
        if tables is None:
            if len(self._cache) > 16:
                rows = self._cache.get("diameter_rows")
                self._cache.clear()
                if rows is not None:
                    self._cache["diameter_rows"] = rows
            tables = _angle_tables(
                self.surface_atoms[surface], float(angle_deg), self.shadowing
            )
            self._cache[key] = tables
        return tables

    def diameter_rows(self) -> np.ndarray:
        """Interleaved (1/k1, 1/k2, v_c, 0) rows for the compiled kernel."""
        rows = self._cache.get("diameter_rows")
        if rows is None:
            rows = np.zeros((self.diameter.size, 4))
            rows[:, 0], rows[:, 1], rows[:, 2] = self.inv_k1, self.inv_k2, self.v_c
            self._cache["diameter_rows"] = rows
        return rows

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
        return AngleTables(s, c / s, 0.0, 0.0, 1.0, 0.0, 0.0, False)
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
    true = theta - phi
    with np.errstate(divide="ignore", invalid="ignore"):
        sin_true = np.sin(true)
        cot_true = np.where(true > 0, np.cos(true) / sin_true, 0.0)
        tan_phi = np.tan(phi)
        tan_cot = tan_phi * cot_true
        gain = 1.0 / (1.0 + tan_cot)
    return AngleTables(
        sin_true, cot_true, tan_phi, tan_cot, gain, phi, shadowed_mass, True
    )


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
    q = (np.arange(size) + 0.5) / size
    atoms = 1.0 + relative_std * ndtri(lo + q * (hi - lo))
    atoms.setflags(write=False)
    return atoms
