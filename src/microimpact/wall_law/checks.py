"""The value ranges of a wall-law table, checked alike by every reader and writer.

The C reader (``c/swl.c``, ``check_values``), the Python reader
(:class:`~microimpact.wall_law.WallLaw`) and the binary writer
(:mod:`~microimpact.wall_law.export_c`) refuse the same tables, so a writer can
never write what a reader refuses (docs/wall-law.md, "Value ranges"):

* diameter and speed nodes (and critical speeds) finite and > 0, angle nodes in
  (0, 90]; every axis strictly increasing, the log axes in log too;
* ``capture_probability`` in [0, 1] or NaN; ``reservoir_count`` in [0, K], 0 only
  where the capture probability is 1 or NaN;
* each held sample: ``|e_n| <= 1e6``, ``|mu| <= 1e12``, the lateral angle in
  (-90, 90) degrees, ``speed_ratio`` in [0, 1], and at its node's angle theta
  ``|e_n sin theta| <= 1`` and ``|cos theta - mu (1 + e_n) sin theta| <= 1`` to
  1e-9: neither the normal nor the tangential rebound is faster than the impact.

* ``stay_probability``, where the table carries it, finite and in [0, 1] at
  every node (NaN too is refused: it is a function of the diameter only).

``e_n`` is the apparent restitution: negative for a re-impact and above 1 at
grazing angles (up to 1 / sin theta), so it is bounded through ``|e_n sin theta|``
rather than to [0, 1].
"""

from __future__ import annotations

import numpy as np

#: Bounds on a held reservoir sample (swl.c: SWL_MAX_E_N, SWL_MAX_MU,
#: SWL_MAX_LATERAL, SWL_VALUE_TOLERANCE).
MAX_E_N = 1e6
MAX_MU = 1e12
MAX_LATERAL_DEG = float(np.nextafter(90.0, 0.0))
VALUE_TOLERANCE = 1e-9

#: Reservoir variables in the binary table's order.
RESERVOIRS = ("e_n", "mu", "lateral_angle_deg", "speed_ratio")


def _first(bad: np.ndarray) -> tuple[int, ...]:
    return tuple(int(i) for i in np.argwhere(bad)[0])


def _at(index: tuple[int, ...], dims) -> str:
    return ", ".join(f"{d} {i}" for d, i in zip(dims, index, strict=False))


def axis_problem(name: str, x, *, log: bool, angle: bool = False) -> str | None:
    """Why axis `name` (its node values `x`) is not a valid wall-law axis, or None."""
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size == 0:
        return f"{name} must be a non-empty 1-D axis"
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(x) & (x > 0) & ((x <= 90.0) if angle else True)
    if not ok.all():
        allowed = "in (0, 90]" if angle else "finite and > 0"
        return f"{name} must be {allowed}; node {_first(~ok)[0]} is {x[~ok][0]:g}"
    scaled = np.log(x) if log else x
    if np.any(np.diff(scaled) <= 0):
        i = int(np.argmax(np.diff(scaled) <= 0))
        return (
            f"{name} must be strictly increasing{' (in log too)' if log else ''}; "
            f"node {i} is {float(x[i])!r} and node {i + 1} is {float(x[i + 1])!r}"
        )
    return None


def node_problem(angle_deg, p, count, reservoirs: dict, k: int, dims) -> str | None:
    """Why the node values break the documented ranges, or None.

    `p` and `count` have shape (surface, diameter, speed, angle); each reservoir
    array that shape plus (K,); `angle_deg` the angle nodes; `dims` the names of
    the four node dimensions (for the message).
    """
    p = np.asarray(p, dtype=float)
    count = np.asarray(count)
    with np.errstate(invalid="ignore"):
        bad = ~np.isnan(p) & ~((p >= 0) & (p <= 1))
    if bad.any():
        i = _first(bad)
        return (
            f"capture_probability must be in [0, 1] or NaN; at {_at(i, dims)} it "
            f"is {p[i]:g}"
        )
    bad = (count < 0) | (count > k)
    if bad.any():
        i = _first(bad)
        return (
            f"reservoir_count must be in [0, {k}]; at {_at(i, dims)} it is {count[i]}"
        )
    bad = (count == 0) & ~(np.isnan(p) | (p == 1))
    if bad.any():
        return (
            "a node with reservoir_count 0 must have capture_probability 1 or NaN; "
            f"at {_at(_first(bad), dims)} it is {p[_first(bad)]:g}"
        )
    held = np.arange(k) < count[..., None]
    e_n, mu, lateral, ratio = (
        np.where(held, np.asarray(reservoirs[n], dtype=float), 0.0) for n in RESERVOIRS
    )
    theta = np.deg2rad(np.asarray(angle_deg, dtype=float))[:, None]
    tol = 1.0 + VALUE_TOLERANCE
    with np.errstate(invalid="ignore", over="ignore"):
        checks = (
            (
                "reservoir_e_n",
                e_n,
                np.abs(e_n) <= MAX_E_N,
                f"in [-{MAX_E_N:g}, {MAX_E_N:g}]",
            ),
            ("reservoir_mu", mu, np.abs(mu) <= MAX_MU, f"in [-{MAX_MU:g}, {MAX_MU:g}]"),
            (
                "reservoir_lateral_angle_deg",
                lateral,
                np.abs(lateral) <= MAX_LATERAL_DEG,
                "in (-90, 90)",
            ),
            ("reservoir_speed_ratio", ratio, (ratio >= 0) & (ratio <= 1), "in [0, 1]"),
            (
                "reservoir_e_n",
                e_n,
                np.abs(e_n * np.sin(theta)) <= tol,
                "such that |e_n sin(angle)| <= 1 (no normal rebound faster than the "
                "impact)",
            ),
            (
                "reservoir_mu",
                mu,
                np.abs(np.cos(theta) - mu * (1.0 + e_n) * np.sin(theta)) <= tol,
                "such that |cos(angle) - mu (1 + e_n) sin(angle)| <= 1 (no "
                "tangential rebound faster than the impact)",
            ),
        )
        for name, value, ok, allowed in checks:
            bad = held & ~ok
            if bad.any():
                i = _first(bad)
                return (
                    f"{name} must be {allowed} where it is held; at "
                    f"{_at(i, (*dims, 'sample'))} it is {value[i]:g}"
                )
    return None


def stay_problem(q, dims) -> str | None:
    """Why the ``stay_probability`` array `q` (shape (surface, diameter, speed,
    angle)) breaks its range (finite, in [0, 1], NaN-safe), or None."""
    q = np.asarray(q, dtype=float)
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(q) & (q >= 0.0) & (q <= 1.0))
    if bad.any():
        i = _first(bad)
        return (
            f"stay_probability must be finite and in [0, 1]; at {_at(i, dims)} it "
            f"is {q[i]:g}"
        )
    return None


def dataset_problem(ds, dims) -> str | None:
    """Why the wall-law Dataset `ds` (node dimensions `dims`: surface, diameter,
    speed axis, angle) breaks the documented ranges, or None. (The critical
    speeds of a reduced axis are checked where they are read: ``WallLaw`` and the
    binary writer.)"""
    order = (*dims, "sample")
    for name in dims[1:]:
        problem = axis_problem(
            name,
            node_values(ds, name, order),
            log=name != "angle_deg",
            angle=name == "angle_deg",
        )
        if problem:
            return problem
    problem = node_problem(
        node_values(ds, "angle_deg", order),
        node_values(ds, "capture_probability", order),
        node_values(ds, "reservoir_count", order),
        {n: node_values(ds, f"reservoir_{n}", order) for n in RESERVOIRS},
        int(ds.sizes["sample"]),
        dims,
    )
    if problem is None and "stay_probability" in ds:
        problem = stay_problem(node_values(ds, "stay_probability", order), dims)
    return problem


def node_values(ds, name: str, order) -> np.ndarray:
    """The values of variable or coordinate `name` of Dataset `ds`, its
    dimensions in `order` where it has them (then the rest): what
    ``ds.transpose(*order, ...)[name].values`` gives, from the variable itself
    (no Dataset or DataArray built: ~1.5 ms of Python per wall law, issue 31)."""
    var = ds.variables[name]
    return var.transpose(*(d for d in order if d in var.dims), ...).values


#: Queries that look like a wrong unit (swl.c: SWL_MIN_DIAMETER_UM,
#: SWL_MAX_SPEED_M_S; SWL_E_UNIT): a diameter below 10 nm (metres given as µm:
#: 3e-6 for 3 µm) and a speed above 1 km/s beyond the table's fastest node (mm/s
#: given as m/s; cold spray reaches ~1 km/s, and a table built that fast takes it).
WRONG_UNIT_DIAMETER_UM = 0.01
WRONG_UNIT_SPEED_M_S = 1000.0


def wrong_unit(diameter_um, speed_m_s, top_speed_m_s: float) -> str | None:
    """Why a query looks like a wrong unit (naming the first such value and the
    likely slip), or None."""
    d = np.asarray(diameter_um, dtype=float)
    v = np.asarray(speed_m_s, dtype=float)
    small = d < WRONG_UNIT_DIAMETER_UM
    if small.any():
        x = float(d[small][0])
        return (
            f"`diameter_um` = {x:g} is below 0.01 um, not a particle: was it given "
            f"in metres? {x:g} m is {x * 1e6:g} um; diameters are in um here"
        )
    fast = (v > WRONG_UNIT_SPEED_M_S) & (v > top_speed_m_s)
    if fast.any():
        x = float(v[fast][0])
        return (
            f"`speed_m_s` = {x:g} is above 1 km/s and above the table's fastest "
            f"node ({top_speed_m_s:g} m/s): was it given in mm/s? {x:g} mm/s is "
            f"{x * 1e-3:g} m/s; speeds are in m/s here"
        )
    return None
