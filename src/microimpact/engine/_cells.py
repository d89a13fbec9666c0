"""The cell table of one size or angle distribution (a leaf of the engine).

:func:`cell_table` is what the plan (:mod:`.plan`) and the particle-roughness
convolution (:mod:`._convolution`) sample from: exact atoms for a discrete
distribution, the quantile function on the refined grid for a continuous one.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from .._core.tables import CellTable, QuantileTable

__all__ = ["cell_table", "one_atom_table"]


def _histogram_breaks(dist):
    """Probabilities of the bin edges of a histogram distribution (kinks of its
    quantile function), or ()."""
    inner = getattr(dist, "dist", None)
    bins = getattr(inner, "_hbins", None)
    if bins is None or not hasattr(dist, "cdf"):
        return ()
    return np.asarray(dist.cdf(np.asarray(bins, dtype=float)), dtype=float)


def cell_table(dist) -> CellTable:
    """The :class:`~microimpact._core.tables.CellTable` of a size or angle distribution.

    Discrete distributions (``is_discrete`` with their atoms) give one cell per
    atom, continuous ones (``ppf``, and ``isf`` when it has one) the refined grid;
    an object with only ``table()`` gives its equiprobable atoms (a step table).
    """
    discrete = bool(getattr(dist, "is_discrete", False))
    if discrete:
        atoms = getattr(dist, "atoms", None)
        if atoms is not None:
            atoms = np.asarray(atoms, dtype=float)
            w = getattr(dist, "weights", None)
            if w is not None and atoms.size > 1 and np.any(w != w[0]):
                return CellTable.from_atoms(atoms, w)
            return CellTable.from_atoms(atoms)
    if not discrete and hasattr(dist, "ppf"):
        # the upper half from the inverse survival function where the object has
        # one; else ppf(1 - s), exact to ~1e-16 in probability
        isf = getattr(dist, "isf", None)
        return CellTable.from_quantile(dist.ppf, isf, breaks=_histogram_breaks(dist))
    table: QuantileTable = dist.table()
    return CellTable.from_atoms(table.values)


@functools.lru_cache(maxsize=1)
def _one_atom_template() -> CellTable:
    return CellTable.from_atoms(np.array([1.0]))


def one_atom_table(value: float) -> CellTable:
    """The table of the degenerate distribution at `value` [SI]: what
    :func:`cell_table` gives for ``monodisperse`` (every field the same, bit for
    bit; tests/engine/test_sampling_tables.py), without building the
    distribution and its cells. A one-atom table's cells, guide and kind do not
    depend on the atom, so they come from one template; a wall law makes one
    per diameter node, and the generic path held the GIL ~0.2-0.6 ms each
    (issue 31)."""
    x = np.array([float(value)])
    if not np.isfinite(x[0]):
        raise ValueError("atoms must be a non-empty array of finite values.")
    y = x.copy()
    x.setflags(write=False)
    y.setflags(write=False)
    return dataclasses.replace(_one_atom_template(), left=x, right=y)
