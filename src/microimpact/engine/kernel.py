r"""The Monte Carlo kernel: one block of impacts at one sweep point.

This is the paper's model (Eqs. 1-9) fused for speed on tabulated cells (see
:mod:`microimpact.engine.plan`); :func:`microimpact.apparent_rebound` is the reference
it is tested against. Per impact, with ``s`` the incident speed, the angle read from
its cell as ``sin(phi)``, ``cos(phi)``, ``tan(phi)`` and the diameter cell giving
``1/k1``, ``1/k2``, ``v_c``:

.. math::

    u &= s\,\sin(\theta-\phi) = |v_{n'}|, \qquad
    c = \cot(\theta-\phi) = v_{t'}/v_{n'} \\
    R &= 1/(1 + (u/k_1)^p)                                  && \text{Eq. 4} \\
    \rho &= 1/(1 + ((u - v_c)/k_2)^q), \quad
        \text{captured if } u \le v_c                       && \text{Eq. 5} \\
    e &= R(1-\rho)                                          && \text{Eq. 6} \\
    \mu_0 &= 2c / [7(1+e)], \quad \mu = \mathrm{clip}(\mu_0, \pm f)  && \text{Eq. 3} \\
    e_m &= \frac{e - \tan\phi\,[c - \mu(1+e)]}{1 + \tan\phi\, c}     && \text{Eq. 8} \\
    \mu_m &= \frac{\mu - \tan\phi}{\mu\tan\phi + 1}                 && \text{Eq. 9}

where Eq. 8 uses :math:`V_{t'}/v_{n'} = c - \mu(1+e)` from Eq. 2, and the rebound
re-impacts the nominal surface when :math:`e_m < 0` (nominal :math:`V_n < 0`).
``sin(theta - phi)`` and ``cos(theta - phi)`` come from the angle-difference
formulas, so one angle table serves every apparent angle.
"""

from __future__ import annotations

import threading
import warnings
import weakref
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._core.tables import (
    CellTable,
    _integer_probabilities,
    fraction_to_integer,
    mulhi64,
    refined_probabilities,
)
from . import _compiled
from .accumulators import (
    E_BINS,
    E_EDGES,
    LATERAL_BINS,
    LATERAL_EDGES,
    MU_BINS,
    MU_EDGES,
    Moments,
    PointAccumulator,
    histogram_counts,
    in_plane_lateral,
    lateral_histogram_counts,
)
from .plan import (
    A_COS,
    A_COSX,
    A_PERP,
    A_SIN,
    A_SINX,
    A_TAN,
    D_IK1,
    D_IK2,
    D_VC,
    KERNEL_CHOICES,  # noqa: F401 (re-exported)
    KERNEL_ENV,  # noqa: F401 (re-exported)
    S_FACTOR,
    VAR_ANGLE,
    VAR_DIAMETER,
    VAR_PAIR,
    VAR_SPEED,
    Plan,
    Sampler,
    pair_sin,
    resolve_kernel,
)
from .summary import Spans, Stacked

#: spawn-key slot that separates QMC scrambles from MC block streams
QMC_TAG = 0xFFFF_FFFF


def stream_raw(entropy, point, block, var, n):
    """`n` raw 64-bit draws of variable `var` in block `block` of `point`.

    The stream is addressed by key, ``SeedSequence(entropy, spawn_key=(point, block,
    var))``, so any worker can build it directly and the draws do not depend on the
    worker count, the task grouping or the order blocks are run in.
    """
    ss = np.random.SeedSequence(entropy, spawn_key=(point, block, var))
    return np.random.PCG64(ss).random_raw(n)


def qmc_uniforms(entropy, point, rep, block, n, dim, block_size):
    """Scrambled Sobol points ``[block*B, block*B + n)`` of replicate `rep`."""
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.stats import qmc  # lazily: scipy.stats costs 0.6 s and ~80 MB

    ss = np.random.SeedSequence(entropy, spawn_key=(point, QMC_TAG, rep))
    engine = qmc.Sobol(dim, scramble=True, rng=np.random.default_rng(ss))
    if block:
        engine.fast_forward(block * block_size)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # balance warning for n != 2^k
        return engine.random(n)


def _draw(plan: Plan, point, rep, block, n, variables):
    """Per listed variable a uint64 array of draws, MC (raw 64-bit outputs) or QMC
    (the uniforms scaled to 64-bit integers, ``u * 2^64``: a double has 53 bits,
    so this keeps every bit of a QMC point)."""
    if plan.sampling == "qmc":
        u = qmc_uniforms(
            plan.entropy, point, rep, block, n, len(variables), plan.block_size
        )
        return [fraction_to_integer(u[:, k]) for k in range(len(variables))]
    return [stream_raw(plan.entropy, point, block, v, n) for v in variables]


def _locate(sampler, r):
    """``(cell, fraction)`` of draws `r`; the fraction is None for a table of atoms
    (equal cells: nothing to interpolate, and neither kernel does)."""
    t = sampler.table
    if t.kind == t.EQUAL:
        return t.cells(r), None
    return t.locate(r)


def _col(rows, j, f, k):
    """Column pair `k` of `rows` at cells `j`, fractions `f` (``lo + f * span``)."""
    if f is None:
        return rows[j, k]
    return rows[j, k] + f * rows[j, k + 1]


def _variables(plan: Plan, tables) -> list[int]:
    variables = [VAR_DIAMETER]
    if tables.random:
        variables.append(VAR_ANGLE)
    if plan.speeds is not None:
        variables.append(VAR_SPEED)
    if tables.random and tables.pair_search:  # the particle atom's proposal
        variables.append(VAR_PAIR)
    return variables


def simulate_block(
    plan: Plan, point: int, rep: int, block: int, n: int, *, store=False
):
    """Simulate `n` impacts of block `block` at sweep point `point`.

    Returns a :class:`PointAccumulator`, or with ``store=True`` a dict of per-impact
    arrays (``diameter``, ``roughness_angle`` [rad], ``out_of_plane_angle`` [rad;
    0 but on an areal surface], ``speed``, ``e_m``, ``mu_m``,
    ``lateral_angle_deg`` (the lateral rebound angle psi of
    :func:`microimpact.apparent_rebound`: 0 forward, 180 backward in the plane of
    incidence; NaN where captured or shadowed), ``captured``, ``shadowed``,
    ``reimpact``, and the coefficients ``k1``, ``k2``, ``v_c`` the kernel used) for
    inspection and small studies. In a continuous
    distribution's cell the coefficients and the angle's sine, cosine and tangent
    are interpolated like the diameter and the angle themselves, so they equal the
    laws and the trigonometric functions of the reported values to second order in
    the cell width (exactly for discrete distributions).
    The kernel is ``plan.kernel`` (``store=True`` always runs the NumPy kernel).
    """
    return _simulate_block(plan, point, rep, block, n, store)


def _simulate_block(plan: Plan, point, rep, block, n, store=False):
    if not store and plan.kernel == "compiled":
        return _simulate_keyed(plan, [(point, rep, block, n)])[0]
    sp = plan.points[point]
    tables = plan.angle_tables(sp.surface, sp.angle_deg)
    # set on the paths that have them (pairs, a random facet, an areal facet)
    j_a = f_a = j_b = s_phi = c_phi = s_chi = c_chi = q_t = q_b = None
    variables = _variables(plan, tables)
    draws = _draw(plan, point, rep, block, n, variables)
    raw = dict(zip(variables, draws, strict=True))

    j_d, f_d = _locate(plan.diameters, raw[VAR_DIAMETER])
    dr = plan.diameters.rows
    inv_k1 = _col(dr, j_d, f_d, D_IK1)
    inv_k2 = _col(dr, j_d, f_d, D_IK2)
    v_c = _col(dr, j_d, f_d, D_VC)
    st, ct = tables.sin_theta, tables.cos_theta
    if tables.pairs:  # rough particle on a discrete surface: an exact pair
        _, j_a, j_b = tables.pair_draws(raw[VAR_ANGLE], raw.get(VAR_PAIR))
        ar, br = tables.sampler.rows, tables.pair.rows
        s_a, c_a, t_a = ar[j_a, A_SIN], ar[j_a, A_COS], ar[j_a, A_TAN]
        s_b, c_b, t_b = br[j_b, A_SIN], br[j_b, A_COS], br[j_b, A_TAN]
        sin_true, cos_true = pair_sin(st, ct, s_a, c_a, s_b, c_b)  # theta - a - b
        with np.errstate(divide="ignore", invalid="ignore"):
            tan_phi = (t_a + t_b) / (1.0 - t_a * t_b)  # tan(a + b)
        if store:  # sin and cos of a + b, for the lateral angle
            s_phi = s_a * c_b + c_a * s_b
            c_phi = c_a * c_b - s_a * s_b
    elif tables.random:
        r_a = raw[VAR_ANGLE]
        if tables.cut:
            r_a = mulhi64(r_a, tables.cut)  # 'reject': reachable facets only
        j_a, f_a = _locate(tables.sampler, r_a)
        ar = tables.sampler.rows
        s_phi = _col(ar, j_a, f_a, A_SIN)
        c_phi = _col(ar, j_a, f_a, A_COS)
        tan_phi = _col(ar, j_a, f_a, A_TAN)
        sin_true = st * c_phi - ct * s_phi  # sin(theta - phi)
        cos_true = ct * c_phi + st * s_phi  # cos(theta - phi)
        if tables.areal:  # the facet's tilt chi about its own line t'
            s_chi = _col(ar, j_a, f_a, A_SINX)
            c_chi = _col(ar, j_a, f_a, A_COSX)
    else:  # smooth: phi = 0 exactly
        sin_true, cos_true, tan_phi = st, ct, np.zeros(n)
        s_phi, c_phi = 0.0, 1.0

    speed = sp.speed
    if plan.speeds is not None:
        j_s, f_s = _locate(plan.speeds, raw[VAR_SPEED])
        speed = speed * _col(plan.speeds.rows, j_s, f_s, S_FACTOR)
    areal = tables.areal
    with np.errstate(divide="ignore", invalid="ignore"):
        u = speed * sin_true  # true normal speed |v_n'|
        cot = cos_true / sin_true
    if not isinstance(u, np.ndarray):
        u = np.full(n, u)
    if areal:
        u = u * c_chi  # |u . n'| = cos(chi) |v_n_phi| (times 1.0 where chi = 0)
    cot = np.broadcast_to(cot, (n,))
    if store or areal:  # the lateral angle needs phi's sine and cosine
        s_phi = np.broadcast_to(s_phi, (n,))
        c_phi = np.broadcast_to(c_phi, (n,))

    shadowed = None
    n_shadowed = 0
    if tables.random and tables.count_shadowed:
        reach = u > 0.0
        n_shadowed = n - int(np.count_nonzero(reach))
        if n_shadowed:
            shadowed = ~reach
            u = u[reach]
            inv_k1, inv_k2, v_c = inv_k1[reach], inv_k2[reach], v_c[reach]
            cot, tan_phi = cot[reach], tan_phi[reach]
            if areal:
                s_chi, c_chi = s_chi[reach], c_chi[reach]
            if store or areal:
                s_phi, c_phi = s_phi[reach], c_phi[reach]

    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        tan_cot = tan_phi * cot
        gain = tan_cot + 1.0
        gain = np.reciprocal(gain, out=gain)  # the Eq. 8 denominator
        captured = u <= v_c  # capture rule (see physics.impact)
        x = u * inv_k1
        if plan.p != 1.0:
            x **= plan.p
        x += 1.0
        R = np.reciprocal(x, out=x)  # Eq. 4
        y = u - v_c
        y *= inv_k2
        if plan.q != 1.0:
            np.power(y, plan.q, out=y)
        y += 1.0
        rho = np.reciprocal(y, out=y)  # Eq. 5
        e = np.subtract(1.0, rho, out=rho)
        e *= R  # Eq. 6
        e[captured] = 0.0
        one_e = e + 1.0
        if areal:  # the 3-D impact (docs/physics.md, "Areal roughness")
            e_m, mu_m, mu, rolling, q_t, q_b = _areal_impact(
                plan.friction, cot, tan_cot, gain, e, one_e, tan_phi, s_chi, c_chi
            )
        else:
            mu = cot * (2.0 / 7.0)
            mu /= one_e  # mu0, Eq. 3 (no initial spin)
            rolling = np.abs(mu) <= plan.friction
            if np.isfinite(plan.friction):
                np.clip(mu, -plan.friction, plan.friction, out=mu)
            # Eq. 8 with V_t'/v_n' = cot - mu (1 + e) from Eq. 2
            e_m = mu * one_e
            e_m *= tan_phi
            e_m -= tan_cot
            e_m += e
            e_m *= gain
            # Eq. 9
            denom = mu * tan_phi
            denom += 1.0
            mu_m = np.subtract(mu, tan_phi)
            mu_m /= denom

    rebound = ~captured
    facet = (s_phi, c_phi, s_chi, c_chi, q_t, q_b)
    if store:
        return _block_outputs(
            plan, tables, n, speed, (j_d, f_d), (j_a, f_a, j_b), shadowed, facet,
            (captured, rebound, e, one_e, mu, cot, e_m, mu_m),
        )  # fmt: skip
    return _block_accumulator(
        n, n_shadowed, captured, rebound, rolling, e, e_m, mu_m, tables.areal, facet
    )


def _block_outputs(plan, tables, n, speed, diameter_cell, angle_cells, shadowed,
                   facet, outcome):  # fmt: skip
    """The per-impact outputs of one block (``store=True``): e_m, mu_m, the
    fates, the lateral angle and every random input, NaN (or False) where a
    facet was shadowed."""
    j_d, f_d = diameter_cell
    j_a, f_a, j_b = angle_cells
    s_phi, c_phi, s_chi, c_chi, q_t, q_b = facet
    captured, rebound, e, one_e, mu, cot, e_m, mu_m = outcome
    areal = tables.areal
    if areal:
        psi = _lateral_angle(s_phi, c_phi, s_chi, c_chi, e, q_t, q_b)
    else:  # in the plane of incidence: chi = 0
        psi = lateral_angle_deg(s_phi, c_phi, 0.0, 1.0, cot, e, one_e, mu, 0.0)
    out = {
        "e_m": np.where(captured, 0.0, e_m),
        "mu_m": np.where(captured, np.nan, mu_m),
        "captured": captured,
        "reimpact": rebound & (e_m < 0),
        "lateral_angle_deg": np.where(captured, np.nan, psi),
    }
    if shadowed is not None:
        full = {}
        for k, v in out.items():
            fill = False if v.dtype == bool else np.nan
            a = np.full(n, fill, dtype=v.dtype)
            a[~shadowed] = v
            full[k] = a
        out = full
    out["shadowed"] = shadowed if shadowed is not None else np.zeros(n, bool)
    dr = plan.diameters.rows
    out["diameter"] = _col(plan.diameters.values, j_d, f_d, 0)
    # the coefficients the kernel used: interpolated in the diameter's cell like
    # the diameter itself (equal to the laws at the diameter to second order)
    with np.errstate(divide="ignore"):
        out["k1"] = 1.0 / _col(dr, j_d, f_d, D_IK1)
        out["k2"] = 1.0 / _col(dr, j_d, f_d, D_IK2)
    out["v_c"] = _col(dr, j_d, f_d, D_VC)
    if tables.pairs:
        out["roughness_angle"] = (
            tables.sampler.values[j_a, 0] + tables.pair.values[j_b, 0]
        )
    elif tables.random:
        out["roughness_angle"] = _col(tables.sampler.values, j_a, f_a, 0)
    else:
        out["roughness_angle"] = np.zeros(n)
    if areal:
        out["out_of_plane_angle"] = _col(tables.sampler.rows, j_a, f_a, A_PERP)
    else:
        out["out_of_plane_angle"] = np.zeros(n)
    out["speed"] = np.broadcast_to(speed, (n,)).copy()
    return out


def _block_accumulator(n, n_shadowed, captured, rebound, rolling, e, e_m, mu_m,
                       areal, facet):  # fmt: skip
    """The block's accumulator: fates, moments and histograms of the rebounds'
    e_m, mu_m and (on an areal surface) folded lateral angle."""
    s_phi, c_phi, s_chi, c_chi, q_t, q_b = facet
    n_captured = int(np.count_nonzero(captured))
    if n_captured:
        e_r = e_m[rebound]
        mu_r = mu_m[rebound]
        n_rolling = int(np.count_nonzero(rolling[rebound]))
    else:
        e_r, mu_r = e_m, mu_m
        n_rolling = int(np.count_nonzero(rolling))
    if areal:  # the folded lateral angle psi_f of each rebound
        lat = _lateral_angle(s_phi, c_phi, s_chi, c_chi, e, q_t, q_b, folded=True)
        if n_captured:
            lat = lat[rebound]
        lateral, lateral_span = Moments.of(lat), None
        lateral_hist = lateral_histogram_counts(lat)
    else:  # in the plane of incidence: psi_f = 0 exactly
        lateral, lateral_span = in_plane_lateral(e_r.size)
        lateral_hist = None
    return PointAccumulator(
        n=n,
        shadowed=n_shadowed,
        captured=n_captured,
        reimpact=int(np.count_nonzero(e_r < 0.0)),
        rolling=n_rolling,
        e=Moments.of(e_r),
        mu=Moments.of(mu_r),
        e_hist=histogram_counts(e_r, E_EDGES),
        mu_hist=histogram_counts(mu_r, MU_EDGES),
        lateral=lateral,
        lateral_hist=lateral_hist,
        lateral_span=lateral_span,
    )


def _areal_impact(friction, cot, tan_cot, gain, e, one_e, tan_phi, s_chi, c_chi):
    """``(e_m, mu_m, mu, rolling, q_t, q_b)`` of impacts on facets tilted by
    ``chi`` about their line ``t'``, in units of the paper's facet normal speed
    ``v_n_phi`` (what :func:`microimpact.apparent_rebound` computes with
    ``out_of_plane_angle_deg``; docs/physics.md): ``u_n' = cos(chi) v_n_phi``,
    ``u_b' = sin(chi) v_n_phi``, the slip ``(cot, sin(chi)) v_n_phi`` with
    ``eta = g / cos(chi)``, ``g`` = :func:`slip_ratio` (``cot`` where
    ``chi = 0``), the impulse along the slip, and Eqs. 8-9 with
    ``e_phi = e cos^2(chi) - sin(chi) V_b'/v_n_phi`` and
    ``mu_phi = mu_t / (cos(chi) + mu_b sin(chi))``. Where
    ``chi = 0`` every step is the 2-D kernel's, operation for operation (``g =
    cot``, multiplications by 1.0, additions of 0.0): the same bits. ``q_t``,
    ``q_b``: the rebound's ``V_t'``, ``V_b'`` over ``v_n_phi`` (the lateral angle's
    ``Q_t'``, ``Q_b'``; :func:`_lateral_angle`)."""
    g = slip_ratio(cot, s_chi)  # slip / v_n_phi, signed like cot
    mu = g / c_chi  # eta
    mu *= 2.0 / 7.0
    mu /= one_e  # mu0, Eq. 3 (no initial spin)
    rolling = np.abs(mu) <= friction
    if np.isfinite(friction):
        np.clip(mu, -friction, friction, out=mu)
    moving = g != 0.0
    mu_t = mu * np.where(moving, cot / g, 1.0)  # impulse ratio along t'
    mu_b = mu * np.where(moving, s_chi / g, 0.0)  # and along b'
    # V_b'/v_n_phi = sin(chi) - mu_b (1 + e) cos(chi)
    q_b = mu_b * one_e
    q_b *= c_chi
    q_b = np.subtract(s_chi, q_b, out=q_b)
    e_phi = e * (c_chi * c_chi)
    e_phi -= s_chi * q_b
    # Eq. 8 with e -> e_phi and V_t'/v_n_phi = cot - mu_t (1 + e) cos(chi)
    e_m = mu_t * one_e
    e_m *= c_chi
    q_t = cot - e_m
    e_m *= tan_phi
    e_m -= tan_cot
    e_m += e_phi
    e_m *= gain
    # Eq. 9 with mu -> mu_phi
    mu_phi = mu_b * s_chi
    mu_phi += c_chi
    mu_phi = np.divide(mu_t, mu_phi, out=mu_phi)
    denom = mu_phi * tan_phi
    denom += 1.0
    mu_m = np.subtract(mu_phi, tan_phi)
    mu_m /= denom
    return e_m, mu_m, mu, rolling, q_t, q_b


def lateral_angle_deg(
    s_phi, c_phi, s_chi, c_chi, cot, e, one_e, mu_t, mu_b, *, folded=False
):
    """The lateral rebound angle ``psi = atan2(V_b, -V_t)`` [deg] of
    :func:`microimpact.apparent_rebound`, from the rebound ``U = Q v_n_phi`` in
    units of the (negative) facet normal speed ``v_n_phi``: ``Q_n' = -e cos chi``,
    ``Q_t' = cot - mu_t (1 + e) cos chi``, ``Q_b' = sin chi - mu_b (1 + e) cos
    chi``, rotated by ``chi`` about ``t'`` and by ``phi`` about ``b`` (Eq. 7), so
    ``psi = atan2(-Q_b, Q_t)``. In the plane of incidence (``chi = 0``) it is 0
    for a forward and 180 for a backward rebound. With ``folded=True`` the
    summary's folded angle ``psi_f = atan2(V_b, |V_t|)`` in [-90, 90] (0 for every
    rebound in the plane of incidence; docs/outputs.md)."""
    with np.errstate(invalid="ignore"):
        q_t = cot - mu_t * one_e * c_chi
        q_b = s_chi - mu_b * one_e * c_chi
    return _lateral_angle(s_phi, c_phi, s_chi, c_chi, e, q_t, q_b, folded)


def _lateral_angle(s_phi, c_phi, s_chi, c_chi, e, q_t, q_b, folded=False):
    """:func:`lateral_angle_deg` from the rebound's ``Q_t'`` and ``Q_b'`` (which
    :func:`_areal_impact` has already formed)."""
    with np.errstate(invalid="ignore"):
        q_n = -e * c_chi
        q_a = q_n * c_chi + q_b * s_chi  # along the paper's facet normal n_phi
        x = c_phi * q_t - s_phi * q_a  # -V_t / |v_n_phi|
        y = s_chi * q_n - c_chi * q_b  # V_b / |v_n_phi|
        if folded:
            x = np.abs(x)
        return atan2_deg(y + 0.0, x)  # + 0.0: no -0 (psi = 180)


def slip_ratio(cot, s_chi):
    """``copysign(sqrt(cot^2 + sin^2 chi), cot)``: the slip over ``v_n_phi``, signed
    like ``cot`` and exactly ``cot`` where ``sin chi = 0``. A square root, not
    ``np.hypot``, so that the compiled kernel computes the same bits (NumPy's
    ``hypot`` and the C library's differ in the last bit for ~0.3 % of arguments;
    ``cot^2`` cannot overflow here: ``|cot| < 1e17`` for any reachable facet)."""
    with np.errstate(invalid="ignore", over="ignore"):
        h = np.sqrt(cot * cot + s_chi * s_chi)
    return np.where(s_chi == 0.0, cot, np.copysign(h, cot))


# Cephes' atan (Moshier): range reduction to |t| <= tan(pi/8) (0.66 as Cephes
# takes it) and a degree 4/5 rational approximation, relative error ~2e-16.
_ATAN_P = (
    -8.750608600031904122785e-1,
    -1.615753718733365076637e1,
    -7.500855792314704667340e1,
    -1.228866684490136173410e2,
    -6.485021904942025371773e1,
)
_ATAN_Q = (
    2.485846490142306297962e1,
    1.650270098316988542046e2,
    4.328810604912902668951e2,
    4.853903996359136964868e2,
    1.945506571482613964425e2,
)
_T3P8 = 2.41421356237309504880  # tan(3 pi / 8)
_MOREBITS = 6.123233995736765886130e-17  # pi/2 - fl(pi/2)
_RAD2DEG = 180.0 / np.pi


def atan2_deg(y, x):
    """``atan2(y, x)`` in degrees from IEEE operations only (``+ - * /``,
    comparisons, selections), which the compiled kernel performs in the same order,
    so both kernels give the same bits (``np.arctan2`` is the SIMD library's on
    some CPUs and differs from the C library's in the last bit). Cephes' ``atan``
    of ``|y| / |x|`` (within 2 ulp of the exact angle), ``pi - a`` where ``x`` has
    its sign bit set, the sign of ``y``; ``atan2(0, 0) = 0``, ``atan2(0, -0) =
    180``, exactly 0, 90 and 180 where ``np.arctan2`` gives them."""
    y = np.asarray(y, dtype=float)
    x = np.asarray(x, dtype=float)
    ay, ax = np.abs(y), np.abs(x)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t = ay / ax
        big = t > _T3P8
        mid = (t > 0.66) & ~big
        num = np.where(big, -1.0, np.where(mid, t - 1.0, t))
        den = np.where(big, t, np.where(mid, t + 1.0, 1.0))
        r = num / den
        z = r * r
        p, q = _ATAN_P, _ATAN_Q
        pz = (((p[0] * z + p[1]) * z + p[2]) * z + p[3]) * z + p[4]
        qz = ((((z + q[0]) * z + q[1]) * z + q[2]) * z + q[3]) * z + q[4]
        z = z * pz
        z = z / qz
        z = r * z + r
        z = z + np.where(big, _MOREBITS, np.where(mid, 0.5 * _MOREBITS, 0.0))
        a = np.where(big, np.pi / 2, np.where(mid, np.pi / 4, 0.0)) + z
        a = np.where(ay == 0.0, 0.0, a)
        a = np.where(np.signbit(x), np.pi - a, a)
        return np.copysign(a, y) * _RAD2DEG


def simulate_specs(plan: Plan, specs) -> list[PointAccumulator]:
    """One accumulator per block spec ``(point, rep, block, n)``, each exactly what
    ``simulate_block(plan, *spec)`` returns (same draws, same bits), in order.

    With the compiled kernel this is one C call for all the specs, which derives
    every block's keyed streams itself (``_ckernel.specs``: NumPy's
    ``SeedSequence`` and ``PCG64``, bit for bit; see :func:`stream_raw`), or for
    QMC its scrambled Sobol' points (:func:`sobol_state`: SciPy's, bit for bit)."""
    if plan.kernel == "compiled":
        return _simulate_keyed(plan, specs)
    return [_simulate_block(plan, *spec) for spec in specs]


# ------------------------------------------------------------------ compiled path
#: What ``auto`` resolves to in this process: ``"compiled"`` when the compiled kernel
#: is installed, else ``"numpy"`` (``MICROIMPACT_KERNEL`` aside). A run's kernel is
#: ``plan.kernel``, fixed when the plan is built (recorded in the provenance).
KERNEL = resolve_kernel("auto")
_NO_DRAW = np.zeros(1, dtype=np.uint64)  # draw array for a variable not drawn
#: The histogram layout for the compiled kernel: e_m then mu_m then psi_f lower
#: edge, inverse bin width, bin count (as :func:`histogram_counts` computes them),
#: then psi_f's upper edge (inclusive: :func:`lateral_histogram_counts`).
_HIST = np.array(
    [
        E_EDGES[0],
        (E_EDGES.size - 1) / (E_EDGES[-1] - E_EDGES[0]),
        E_EDGES.size - 1,
        MU_EDGES[0],
        (MU_EDGES.size - 1) / (MU_EDGES[-1] - MU_EDGES[0]),
        MU_EDGES.size - 1,
        LATERAL_EDGES[0],
        (LATERAL_EDGES.size - 1) / (LATERAL_EDGES[-1] - LATERAL_EDGES[0]),
        LATERAL_EDGES.size - 1,
        LATERAL_EDGES[-1],
    ]
)
_SPILL = 8  # spill slots appended to each histogram array (the C kernel's SPILL)
#: A one-cell sampler for a variable that is not drawn (never read).
_NO_SAMPLER = None


def _ckernel():
    if _compiled.ckernel is None:
        raise ImportError(f"the compiled kernel is not installed ({_compiled.ERROR})")
    return _compiled.ckernel


_SAMPLER_ARGS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def constant_columns(sampler) -> int:
    """Bit ``q`` set where interpolated column ``q`` (``rows[:, 2 + 2q]``, span
    ``rows[:, 3 + 2q]``) is the same in every cell: the same ``lo`` bits and a
    ``+0.0`` span, so that ``lo + f * span`` is ``lo + 0.0`` for any fraction (k1 of
    every preset). The compiled kernel reads such a column once, not per impact
    (the same bits)."""
    rows = sampler.rows[:-1].view(np.uint64)
    k = min(3, (rows.shape[1] - 2) // 2)
    lo, span = rows[:, 2 : 2 + 2 * k : 2], rows[:, 3 : 3 + 2 * k : 2]
    # (the columns at once: a wall law's 16 one-atom samplers each pay this)
    same = np.all(lo == lo[:1], axis=0) & ~np.any(span, axis=0)
    return sum(1 << q for q in np.flatnonzero(same).tolist())


@lru_cache(maxsize=4)
def _refined_starts(levels: int, cells_log2: int) -> np.ndarray:
    """The cell starts of the canonical refined grid (``CellTable.DYADIC``)."""

    p, s = refined_probabilities(levels, 1 << cells_log2)
    return _integer_probabilities(p[:-1], s[:-1])


def _compact_rows(sampler, constant: int):
    """``(rows, stride)`` of the compiled kernel's SIMD lookups, or None: per cell
    only the columns that vary, ``(lo, span)`` each for the refined grid and ``lo``
    for atoms (whose span is never read), the stride padded to a power of two.
    The refined grid's rows need no start or ``1/width``: its cells are aligned
    to their power-of-two widths, which is checked here against the canonical grid
    (a table that is not exactly it gets no compact rows: the scalar lookups)."""
    t, rows = sampler.table, sampler.rows[:-1]
    if t.kind == t.EQUAL and rows.shape[1] >= 12 and not constant & 0b111:
        # an areal surface's pairs (plan.ArealSampler): sin, cos, tan phi_par and
        # sin, cos chi, one 64-byte row per pair (the fetch of the compiled
        # kernel's areal path reads this layout where the stride is 8)
        out = np.zeros((t.size, 8))
        out[:, :5] = rows[:, [2, 4, 6, 8, 10]]
        out.setflags(write=False)
        return out, 8
    if t.kind == t.DYADIC:
        if not np.array_equal(t.starts, _refined_starts(t.levels, t.cells_log2)):
            return None
        per = 2
    elif t.kind == t.EQUAL:
        per = 1
    else:
        return None
    cols = []
    for q in range(min(3, (rows.shape[1] - 2) // 2)):
        if not (constant >> q) & 1:
            cols.extend(range(2 + 2 * q, 2 + 2 * q + per))
    stride = 1
    while stride < len(cols):
        stride *= 2
    out = np.zeros((t.size, stride))
    out[:, : len(cols)] = rows[:, cols]
    out.setflags(write=False)
    return out, stride


def _sampler_args(sampler):
    """The ``(rows, stride, guide, guide_shift, kind, levels, cells_log2,
    constant_columns[, compact_rows, compact_stride])`` tuple of the C kernel
    (built once per sampler)."""
    global _NO_SAMPLER
    if sampler is None:
        if _NO_SAMPLER is None:
            one = ([1.0], [1.0])
            _NO_SAMPLER = Sampler.of(CellTable.from_atoms([1.0]), one, one, one, one)
        sampler = _NO_SAMPLER
    args = _SAMPLER_ARGS.get(sampler)
    if args is None:
        t = sampler.table
        constant = constant_columns(sampler)
        args = (
            sampler.rows,
            sampler.rows.shape[1],
            t.guide,
            t.guide_shift,
            t.kind,
            t.levels,
            t.cells_log2,
            constant,
        )
        compact = _compact_rows(sampler, constant)
        if compact is not None:
            args += compact
        _SAMPLER_ARGS[sampler] = args
    return args


def _simulate_compiled(plan, sp, tables, raw, n):
    """The same block through the compiled kernel (``_ckernel.c``)."""
    spread = plan.speeds is not None
    areal = bool(tables.areal)
    e_hist = np.zeros(E_EDGES.size + 1 + _SPILL, dtype=np.int64)
    mu_hist = np.zeros(MU_EDGES.size + 1 + _SPILL, dtype=np.int64)
    lat_hist = np.zeros(LATERAL_BINS + _SPILL if areal else 1, dtype=np.int64)
    counts, sums = _ckernel().block(
        raw[VAR_DIAMETER],
        raw.get(VAR_ANGLE, _NO_DRAW),
        raw.get(VAR_SPEED, _NO_DRAW),
        raw.get(VAR_PAIR, _NO_DRAW),
        n,
        tables.random,
        spread,
        _sampler_args(plan.diameters),
        _sampler_args(tables.sampler),
        int(tables.cut),
        _sampler_args(tables.pair),
        int(tables.pair_total),
        tables.pair_mode,
        _sampler_args(plan.speeds),
        tables.sin_theta,
        tables.cos_theta,
        float(sp.speed),
        plan.p,
        plan.q,
        plan.friction,
        bool(tables.random and tables.count_shadowed),
        _HIST,
        e_hist,
        mu_hist,
        areal,
        lat_hist,
    )
    m = counts[4]
    if areal:
        lateral = Moments.from_shifted_sums(m, *sums[8:])
        lateral_hist, lateral_span = lat_hist[:-_SPILL], None
    else:  # profile or smooth surfaces: psi_f = 0
        lateral, lateral_span = in_plane_lateral(m)
        lateral_hist = None
    return PointAccumulator(
        n=n,
        shadowed=counts[0],
        captured=counts[1],
        reimpact=counts[2],
        rolling=counts[3],
        e=Moments.from_shifted_sums(m, *sums[:4]),
        mu=Moments.from_shifted_sums(m, *sums[4:8]),
        e_hist=e_hist[:-_SPILL],
        mu_hist=mu_hist[:-_SPILL],
        lateral=lateral,
        lateral_hist=lateral_hist,
        lateral_span=lateral_span,
    )


# ------------------------------------------------- compiled path, keyed streams
@lru_cache(maxsize=16)
def entropy_words(entropy: int) -> bytes:
    """The uint32 words of `entropy`, little-endian, as ``SeedSequence`` splits an
    integer (0 is one word 0), as the bytes ``_ckernel.stream``/``specs`` read."""
    entropy = int(entropy)
    if entropy < 0:
        raise ValueError("entropy must be a non-negative integer")
    n = max(1, (entropy.bit_length() + 31) // 32)
    return entropy.to_bytes(4 * n, "little")


def compiled_stream_raw(entropy, key, n) -> np.ndarray:
    """``PCG64(SeedSequence(entropy, spawn_key=key)).random_raw(n)`` computed by the
    compiled kernel (the same bits; tests/engine/test_rng_streams.py)."""
    out = np.empty(n, dtype=np.uint64)
    _ckernel().stream(entropy_words(entropy), tuple(int(k) for k in key), out)
    return out


_COMMON_ARGS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_POINT_ARGS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _common_args(plan: Plan):
    """What every block of `plan` shares, as ``_ckernel.specs`` reads it."""
    args = _COMMON_ARGS.get(plan)
    if args is None:
        args = _COMMON_ARGS[plan] = (
            _sampler_args(plan.diameters),
            _sampler_args(plan.speeds),
            plan.speeds is not None,
            float(plan.p),
            float(plan.q),
            float(plan.friction),
            _HIST,
        )
    return args


def _point_args(tables, speed: float):
    """The point tuple of ``_ckernel.specs`` (cached per angle tables and speed:
    the same object for every block of a point, which the C side parses once)."""
    cached = _POINT_ARGS.get(tables)
    if cached is None:
        # what does not depend on the speed, once per tables (a sweep grid has a
        # new speed at nearly every point), and the tuples built by speed
        cached = _POINT_ARGS[tables] = (
            (
                bool(tables.random),
                _sampler_args(tables.sampler),
                int(tables.cut),
                _sampler_args(tables.pair),
                int(tables.pair_total),
                tables.pair_mode,
                float(tables.sin_theta),
                float(tables.cos_theta),
            ),
            (bool(tables.random and tables.count_shadowed), bool(tables.areal)),
            {},
        )
    head, tail, by_speed = cached
    args = by_speed.get(speed)
    if args is None:
        args = by_speed[speed] = (*head, float(speed), *tail)
    return args


_PLAN_POINTS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_PLAN_POINTS_LOCK = threading.Lock()


def _plan_points(plan: Plan):
    """Every (surface, angle) point tuple of `plan` parsed once by the compiled
    kernel (``_ckernel.points``), in the order of ``plan.point_columns()``'s
    keys; None where a surface has tables of its own per angle (weighted
    shadowing, pair tables: the plan keeps only some of them, and so does a
    task)."""
    got = _PLAN_POINTS.get(plan)
    if got is None:
        with _PLAN_POINTS_LOCK:  # built once, not by every worker thread at once
            got = _PLAN_POINTS.get(plan)
            if got is None:
                got = _PLAN_POINTS[plan] = _shared_plan_points(plan)
    return got if got is not False else None


def plan_points_parsed(plan: Plan) -> bool:
    """Whether the compiled kernel holds every point of `plan` parsed once
    (:func:`_plan_points`; not where a surface has tables per angle)."""
    return plan.kernel == "compiled" and _plan_points(plan) is not None


def prepare_plan(plan: Plan, *, points: bool = True) -> None:
    """Parse what the compiled kernel reads of `plan` now (its common arguments
    and, with `points`, its points, each once per plan), so that the first
    kernel calls of the workers do not (they would hold the GIL between kernel
    calls to do it)."""
    if plan.kernel == "compiled":
        _common_args(plan)
        if points:
            _plan_points(plan)


def _shared_plan_points(plan: Plan):
    """:func:`_parse_plan_points`, shared by the plans derived from one another
    that keep its points, surfaces and angle tables (:meth:`Plan.shared`: a wall
    law's plan per diameter; the capsule holds no diameter), for the shadowing
    and speed flag it was parsed for."""
    key = ("_ckernel.points", plan.shadowing, plan.speeds is not None)
    return plan.shared(key, _parse_plan_points)


def _parse_plan_points(plan: Plan):
    if any(plan.own_tables(i) for i in range(len(plan.surfaces))):
        return False
    _, speed, _, table, keys = plan.point_columns()
    heads = [_point_args(plan.angle_tables(*key), 0.0) for key in keys]
    # with every point's table and speed: task() runs a task from its indices
    return _ckernel().points(
        heads,
        plan.speeds is not None,
        np.ascontiguousarray(table, dtype=np.int64),
        np.ascontiguousarray(speed, dtype=np.float64),
    )


@dataclass(frozen=True, eq=False)
class SpecArrays:
    """Monte Carlo block specs as arrays (int64, one entry per block): what a
    list of ``(point, 0, block, n)`` tuples describes, without an object per
    block (issue 31: the driver's Python per point). It still iterates as those
    tuples, for a caller that reads specs one by one."""

    point: np.ndarray
    block: np.ndarray
    n: np.ndarray

    def __len__(self) -> int:
        return int(self.n.size)

    def __iter__(self):
        rows = zip(
            self.point.tolist(), self.block.tolist(), self.n.tolist(), strict=True
        )
        return ((p, 0, b, n) for p, b, n in rows)

    def __getitem__(self, i):
        """Spec `i` as its tuple; a slice as specs."""
        if isinstance(i, slice):
            return SpecArrays(self.point[i], self.block[i], self.n[i])
        return (int(self.point[i]), 0, int(self.block[i]), int(self.n[i]))


def _array_items(plan: Plan, specs: SpecArrays) -> tuple:
    """The tuple form of ``_ckernel.specs``'s specs: ``(points, which, speed,
    point, block, n)``, the point tuples of the (surface, angle) tables the
    specs use, each once (speed 0.0: the kernel takes each spec's own)."""
    if plan.sampling == "qmc":
        raise ValueError("array specs are Monte Carlo only")
    _, speed, _, table, keys = plan.point_columns()
    point = np.ascontiguousarray(specs.point, dtype=np.int64)
    heads = _plan_points(plan)
    if heads is not None:  # every point's tables, parsed once per plan
        which = table[point]
    else:  # tables of their own per angle: only those of these specs
        used, which = np.unique(table[point], return_inverse=True)
        heads = [_point_args(plan.angle_tables(*keys[t]), 0.0) for t in used.tolist()]
    return (
        heads,
        which.reshape(-1).astype(np.int64),
        np.ascontiguousarray(speed[point]),
        point,
        np.ascontiguousarray(specs.block, dtype=np.int64),
        np.ascontiguousarray(specs.n, dtype=np.int64),
    )


#: The count dtype of each item size ``_ckernel.task`` narrows to.
_NARROWED = {1: np.uint8, 2: np.uint16, 4: np.int32, 8: np.int64}


def task_rows(plan: Plan, task, store=None) -> Stacked | None:
    """The rows of a :class:`~.tasks.BlockTask` (a row per group, its blocks
    merged in block order) from one ``_ckernel.task`` call: the kernel expands
    the groups into blocks, looks each point's tables and speed up in the plan's
    parsed points, and writes the rows in the driver's own layout with the
    histogram counts narrowed, so the GIL is held for a few array allocations
    per task (issue 31). Exactly ``simulate_specs_stacked(plan, task.specs(),
    task.lengths).narrow()``; None where the plan's points are not parsed once
    (tables of their own per angle) or the kernel is not the compiled one.
    `store`: ``(e_m, mu_m, lateral_angle_deg, outcome)`` arrays of the task's
    impacts (float64, int8), written as :func:`simulate_specs_impacts` writes
    them."""
    if plan.kernel != "compiled" or plan.sampling == "qmc":
        return None
    points = _plan_points(plan)
    if points is None:
        return None
    G = len(task.point)
    table = np.empty((G, 5), dtype=np.int64)
    moments = np.empty((3, G, 4))
    spans = np.empty((3, 2, G), dtype=np.int64)
    e, e_w, mu, mu_w, lat, lat_w = _ckernel().task(
        entropy_words(plan.entropy),
        _common_args(plan),
        points,
        np.ascontiguousarray(task.point, dtype=np.int64),
        np.ascontiguousarray(task.first, dtype=np.int64),
        np.ascontiguousarray(task.last, dtype=np.int64),
        task.stop,
        task.block_size,
        task.last_n,
        table,
        moments,
        spans,
        *(() if store is None else (store,)),
    )
    return Stacked(
        table,
        moments[0],
        moments[1],
        Spans(spans[0, 0], spans[0, 1], np.frombuffer(e, _NARROWED[e_w]), E_BINS),
        Spans(spans[1, 0], spans[1, 1], np.frombuffer(mu, _NARROWED[mu_w]), MU_BINS),
        moments[2],
        Spans(
            spans[2, 0], spans[2, 1], np.frombuffer(lat, _NARROWED[lat_w]), LATERAL_BINS
        ),
    )


def kernel_tasks_available() -> bool:
    """Whether the compiled kernel can run a whole run's tasks itself
    (:class:`KernelTasks`: built with GCC's atomics)."""
    ck = _compiled.ckernel
    return ck is not None and hasattr(ck, "tasks_run")


class KernelTasks:
    """The tasks of a fresh fixed-size run whose groups are whole streams, run
    inside the compiled kernel (``_ckernel.tasks``): each worker thread makes
    one :meth:`run` call, the threads take the tasks from a shared counter, and
    each task's rows are written straight into the driver's `table` (13
    arrays: see ``_ckernel.tasks``) at its points' rows. No Python runs between
    two tasks and the GIL is not taken from the first to the last (issue 31:
    ~60-100 us of held GIL per task before, each after ~7 ms of kernel, when
    the caches are cold). Each task is the kernel call :func:`task_rows` makes
    for it, so the rows and counts are the same bits."""

    def __init__(self, plan: Plan, tasks, table: tuple):
        parts, sizes = [], []
        for t in tasks:  # (each task's arrays are views: not kept past here)
            parts.append((t.point, t.first, t.last))
            sizes.append(len(t))
            self.stop, block_size, last_n = t.stop, t.block_size, t.last_n
        if not parts:
            raise ValueError("KernelTasks: no task")
        #: the groups' points (each a row of the table), and task i's groups
        #: ``starts[i] .. starts[i + 1] - 1``
        self.point, first, last = (
            np.concatenate([p[j] for p in parts]).astype(np.int64, copy=False)
            for j in range(3)
        )
        del parts
        self.starts = np.zeros(len(sizes) + 1, dtype=np.int64)
        np.cumsum(sizes, out=self.starts[1:])
        self._capsule = _ckernel().tasks(
            entropy_words(plan.entropy),
            _common_args(plan),
            _plan_points(plan),
            self.point,
            first,
            last,
            self.starts,
            self.stop,
            block_size,
            last_n,
            table,
        )

    def __len__(self) -> int:
        return self.starts.size - 1

    def run(self) -> int:
        """Run tasks until none is left or :meth:`halt`; the tasks run."""
        return _ckernel().tasks_run(self._capsule)

    def halt(self, halt: bool = True) -> None:
        """Make the :meth:`run` calls return after their current task (or,
        `halt` false, let later calls go on)."""
        _ckernel().tasks_halt(self._capsule, halt)

    def harvest(self) -> tuple[int, list]:
        """The impacts of the tasks done so far, and ``(i, e, mu, lateral)``
        for each task done since the last harvest: its index and its
        histograms' flat counts (read-only arrays of the narrowest dtype)."""
        impacts, items = _ckernel().tasks_harvest(self._capsule)
        return impacts, [
            (
                i,
                np.frombuffer(e, _NARROWED[we]),
                np.frombuffer(mu, _NARROWED[wm]),
                np.frombuffer(lat, _NARROWED[wl]),
            )
            for i, e, we, mu, wm, lat, wl in items
        ]


_SOBOL: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: Scrambled Sobol' sequences kept per plan (a few hundred bytes each; a run goes
#: through its points in order, so this only saves rebuilding a (point, replicate)
#: sequence for each of its blocks, ~0.2 ms each).
SOBOL_CACHE = 4096


def sobol_state(plan: Plan, point: int, rep: int, dim: int) -> bytes:
    """The scrambled Sobol' sequence of replicate `rep` at `point` (the one
    :func:`qmc_uniforms` draws from) as ``_ckernel.specs`` reads it: uint32 words
    ``[dim, bits, shift[dim], sv[dim][bits]]``, SciPy's own scrambled direction
    numbers and digital shift (``scipy.stats.qmc.Sobol._sv``, ``._shift``; the
    compiled kernel generates the points from them in SciPy's Gray-code order,
    and tests/test_kernel_compiled.py checks the bits against
    :func:`qmc_uniforms`)."""
    cache = _SOBOL.get(plan)
    if cache is None:
        cache = _SOBOL[plan] = {}
    key = (point, rep, dim)
    state = cache.get(key)
    if state is None:
        # deferred: this SciPy submodule loads only when it is used (import time)
        from scipy.stats import qmc

        ss = np.random.SeedSequence(plan.entropy, spawn_key=(point, QMC_TAG, rep))
        engine = qmc.Sobol(dim, scramble=True, rng=np.random.default_rng(ss))
        sv = np.asarray(engine._sv, dtype=np.uint32)
        shift = np.asarray(engine._shift, dtype=np.uint32)
        if sv.shape != (dim, engine.bits) or shift.shape != (dim,):
            raise RuntimeError("scipy.stats.qmc.Sobol: unexpected internal layout")
        head = np.array([dim, engine.bits], dtype=np.uint32)
        state = np.concatenate([head, shift, sv.ravel()]).tobytes()
        if len(cache) >= SOBOL_CACHE:
            cache.clear()
        cache[key] = state
    return state


def _keyed_outputs(plan: Plan, specs, store=None, groups=None):
    """One ``_ckernel.specs`` call for block specs: ``(items, counts, sums, spans,
    flat)`` (the per-block counts, the shifted sums, the occupied histogram spans
    and their counts, flat). Monte Carlo blocks draw from their keyed streams, QMC
    blocks from their replicate's Sobol' points ``[block B, block B + n)``.

    With `groups` (an int64 array of group lengths summing to ``len(specs)``) the
    kernel merges each group's consecutive blocks itself, as
    :meth:`~.accumulators.PointAccumulator.merge` folds them left to right (the
    same bits): a row per group, and ``sums`` then holds each group's moments
    ``(n, mean, M2, M3)`` of e_m, mu_m and psi_f."""
    if isinstance(specs, SpecArrays):
        items = _array_items(plan, specs)
        specs = ()
        k = len(items[1]) if groups is None else len(groups)
    else:
        items = _tuple_items(plan, specs)
        k = len(items) if groups is None else len(groups)
    counts = np.empty((k, 5), dtype=np.int64)
    sums = np.empty((k, 12))
    spans = np.empty((k, 6), dtype=np.int64)
    args = [entropy_words(plan.entropy), _common_args(plan), items, counts, sums]
    args.append(spans)
    if store is not None or groups is not None:
        args.append(store)
    if groups is not None:
        args.append(np.ascontiguousarray(groups, dtype=np.int64))
    buf = _ckernel().specs(*args)
    return items, counts, sums, spans, np.frombuffer(buf, dtype=np.int64)


def _tuple_items(plan: Plan, specs) -> list:
    """The list form of ``_ckernel.specs``'s specs (:func:`_keyed_outputs`)."""
    items = []
    points = plan.points
    qmc = plan.sampling == "qmc"
    last = None  # consecutive specs of one point (a group's blocks) share its args
    for point, rep, block, n in specs:
        if point != last:
            sp = points[point]
            tables = plan.angle_tables(sp.surface, sp.angle_deg)
            args = _point_args(tables, float(sp.speed))
            last = point
        if qmc:
            start = block * plan.block_size
            if start + n > 2**30:  # what scipy's Sobol(bits=30) refuses too
                raise ValueError(
                    f"At most 2**30 QMC points per replicate; block {block} "
                    f"of {n} reaches {start + n}"
                )
            dim = len(_variables(plan, tables))
            items.append((point, start, n, args, sobol_state(plan, point, rep, dim)))
        else:
            items.append((point, block, n, args))
    return items


def simulate_specs_impacts(plan: Plan, specs, out=None) -> dict:
    """The impacts of block specs ``(point, rep, block, n)`` through the compiled
    kernel, one after the other (one ``_ckernel.specs`` call): ``e_m``, ``mu_m``
    (valid where ``outcome == 0``), ``lateral_angle_deg`` (valid for rebounds on an
    areal surface; 0 elsewhere) and ``outcome`` (int8: 0 a rebound, 1 captured, 2
    shadowed). The same impacts, bit for bit, as ``simulate_block(plan, *spec,
    store=True)`` gives for those outcomes (tests/test_kernel_compiled.py); what
    the wall law is built from without a Python array per node. `out`: arrays of
    at least the specs' total length to write into (their leading parts are
    returned), reused from call to call. `specs` may be a
    :class:`~.tasks.BlockTask` (its blocks in order; known by its ``impacts()``,
    which specs have not): then one ``_ckernel.task`` call on the plan's parsed
    points (:func:`task_rows`) where it has them."""
    if plan.kernel != "compiled":
        raise ValueError("simulate_specs_impacts needs the compiled kernel")
    task = specs if hasattr(specs, "impacts") else None
    if task is not None:
        total = int(task.impacts().sum())
    elif isinstance(specs, SpecArrays):
        total = int(specs.n.sum())
    else:
        total = sum(int(spec[3]) for spec in specs)
    if out is None:
        out = {
            "e_m": np.empty(total),
            "mu_m": np.empty(total),
            "lateral_angle_deg": np.empty(total),
            "outcome": np.empty(total, dtype=np.int8),
        }
    out = {k: out[k][:total] for k in ("e_m", "mu_m", "lateral_angle_deg", "outcome")}
    store = tuple(out.values())
    if task is None:
        _keyed_outputs(plan, specs, store=store)
    elif task_rows(plan, task, store=store) is None:  # points not parsed once
        _keyed_outputs(plan, task.specs(), store=store)
    return out


def _simulate_keyed(plan: Plan, specs) -> list[PointAccumulator]:
    """Monte Carlo block specs through one ``_ckernel.specs`` call: the kernel draws
    each block's variables from its keyed streams itself and returns the counts,
    the shifted sums and the occupied histogram spans (the same bits as
    :func:`_simulate_compiled` on :func:`stream_raw`'s draws)."""
    _, counts, sums, spans, flat = _keyed_outputs(plan, specs)
    ns = specs.n.tolist() if isinstance(specs, SpecArrays) else [s[3] for s in specs]
    out = []
    # each histogram's spans follow one another, e_m's, then mu_m's, then psi_f's
    at_e = 0
    at_mu = int(spans[:, 1].sum())
    at_l = at_mu + int(spans[:, 3].sum())
    of = Moments.from_shifted_sums
    for n, c, s, (e_lo, e_len, mu_lo, mu_len, l_lo, l_len) in zip(
        ns, counts.tolist(), sums.tolist(), spans.tolist(), strict=True
    ):
        e_counts = flat[at_e : at_e + e_len]
        at_e += e_len
        mu_counts = flat[at_mu : at_mu + mu_len]
        at_mu += mu_len
        m = c[4]
        # off an areal surface the sums are zeros and the span one bin at
        # psi_f = 0: exactly in_plane_lateral(m)
        lateral = of(m, *s[8:])
        lateral_span = (l_lo, flat[at_l : at_l + l_len])
        at_l += l_len
        out.append(
            PointAccumulator(
                n=n,
                shadowed=c[0],
                captured=c[1],
                reimpact=c[2],
                rolling=c[3],
                e=of(m, *s[:4]),
                mu=of(m, *s[4:8]),
                e_span=(e_lo, e_counts),
                mu_span=(mu_lo, mu_counts),
                lateral=lateral,
                lateral_span=lateral_span,
            )
        )
    return out


def simulate_specs_stacked(plan: Plan, specs, groups=None):
    """:func:`simulate_specs` as one :class:`~.summary.Stacked` (a row per spec),
    built from the compiled kernel's arrays without an object per block: exactly
    ``Stacked.of(simulate_specs(plan, specs))``. With `groups` (lengths of runs of
    consecutive specs, summing to ``len(specs)``) a row per group: its blocks'
    accumulators merged left to right in the kernel, exactly as
    :meth:`~.accumulators.PointAccumulator.merge` folds them (the driver's bits,
    with no Python object or GIL per block). The compiled kernel only (None
    otherwise)."""

    if plan.kernel != "compiled":
        return None
    arrays = isinstance(specs, SpecArrays)
    size = len(specs.n) if arrays else len(specs)
    if groups is None:
        groups = np.ones(size, dtype=np.int64)
    else:
        groups = np.asarray(groups, dtype=np.int64)
    _, counts, moments, spans, flat = _keyed_outputs(plan, specs, groups=groups)
    table = np.empty((len(groups), 5), dtype=np.int64)
    if size:  # each group's impacts
        n = (
            specs.n
            if arrays
            else np.fromiter((spec[3] for spec in specs), np.int64, size)
        )
        table[:, 0] = np.add.reduceat(n, np.cumsum(groups) - groups)
    table[:, 1:] = counts[:, :4]
    # (3, G): offsets and lengths of e_m's, mu_m's and psi_f's spans; the
    # kernel writes every group's e_m counts, then their mu_m's, then psi_f's
    ln = spans[:, 1::2].T.copy()
    offset = np.where(ln > 0, spans[:, 0::2].T, 0)
    ends = np.cumsum(ln.sum(axis=1)).tolist()
    hists = []
    for h, size in enumerate((E_BINS, MU_BINS, LATERAL_BINS)):
        parts = flat[(ends[h - 1] if h else 0) : ends[h]]
        hists.append(Spans(offset[h], ln[h], parts, size))
    # (3, G, 4): the moments of e_m, mu_m and psi_f, each block contiguous
    m = moments.reshape(-1, 3, 4).transpose(1, 0, 2).copy()
    return Stacked(table, m[0], m[1], hists[0], hists[1], m[2], hists[2])
