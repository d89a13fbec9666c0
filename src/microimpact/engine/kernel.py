r"""The Monte Carlo kernel: one block of impacts at one sweep point.

This is the paper's model (Eqs. 1-9) fused for speed on tabulated atoms (see
:mod:`microimpact.engine.plan`); :func:`microimpact.apparent_rebound` is the reference
it is tested against. Per impact, with ``s`` the incident speed, ``j`` the angle atom
and ``i`` the diameter atom:

.. math::

    u &= s\,\sin(\theta-\phi_j) = |v_{n'}|, \qquad
    c = \cot(\theta-\phi_j) = v_{t'}/v_{n'} \\
    R &= 1/(1 + (u/k_1)^p)                                  && \text{Eq. 4} \\
    \rho &= 1/(1 + ((u - v_c)/k_2)^q), \quad
        \text{captured if } u \le v_c                       && \text{Eq. 5} \\
    e &= R(1-\rho)                                          && \text{Eq. 6} \\
    \mu_0 &= 2c / [7(1+e)], \quad \mu = \mathrm{clip}(\mu_0, \pm f)  && \text{Eq. 3} \\
    e_m &= \frac{e - \tan\phi\,[c - \mu(1+e)]}{1 + \tan\phi\, c}     && \text{Eq. 8} \\
    \mu_m &= \frac{\mu - \tan\phi}{\mu\tan\phi + 1}                 && \text{Eq. 9}

where Eq. 8 uses :math:`V_{t'}/v_{n'} = c - \mu(1+e)` from Eq. 2, and the rebound
re-impacts the nominal surface when :math:`e_m < 0` (nominal :math:`V_n < 0`).
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import InputError
from .accumulators import (
    E_EDGES,
    MU_EDGES,
    Moments,
    PointAccumulator,
    histogram_counts,
)
from .plan import (
    A_COT,
    A_GAIN,
    A_PHI,
    A_SIN,
    A_TAN,
    A_TANCOT,
    VAR_ANGLE,
    VAR_DIAMETER,
    VAR_SPEED,
    Plan,
)

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
    from scipy.stats import qmc  # lazily: scipy.stats costs 0.6 s and ~80 MB

    ss = np.random.SeedSequence(entropy, spawn_key=(point, QMC_TAG, rep))
    engine = qmc.Sobol(dim, scramble=True, rng=np.random.default_rng(ss))
    if block:
        engine.fast_forward(block * block_size)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # balance warning for n != 2^k
        return engine.random(n)


def _draw(plan: Plan, point, rep, block, n, variables):
    """``(arrays, shift)``: per listed variable a uint64 array whose values shifted
    right by `shift` are the table indices, MC (raw draws) or QMC."""
    bits = plan.table_bits
    if plan.sampling == "qmc":
        u = qmc_uniforms(
            plan.entropy, point, rep, block, n, len(variables), plan.block_size
        )
        scale = float(1 << bits)
        return [
            np.minimum((u[:, k] * scale).astype(np.uint64), (1 << bits) - 1)
            for k in range(len(variables))
        ], 0
    raws = [stream_raw(plan.entropy, point, block, v, n) for v in variables]
    return raws, 64 - bits


def simulate_block(
    plan: Plan, point: int, rep: int, block: int, n: int, *, store=False
):
    """Simulate `n` impacts of block `block` at sweep point `point`.

    Returns a :class:`PointAccumulator`, or with ``store=True`` a dict of per-impact
    arrays (``diameter``, ``roughness_angle``, ``speed``, ``e_m``, ``mu_m``,
    ``captured``, ``shadowed``, ``reimpact``) for inspection and small studies.
    """
    sp = plan.points[point]
    tables = plan.angle_tables(sp.surface, sp.angle_deg)
    variables = [VAR_DIAMETER]
    if tables.random:
        variables.append(VAR_ANGLE)
    if plan.speed_factor is not None:
        variables.append(VAR_SPEED)
    draws, shift = _draw(plan, point, rep, block, n, variables)
    raw = dict(zip(variables, draws, strict=True))
    if not store and _COMPILED is not None:  # the kernel shifts as it reads
        return _simulate_compiled(plan, sp, tables, raw, shift, n)
    for a in draws:
        a >>= np.uint64(shift)
    idx = {v: a.view(np.int64) for v, a in zip(variables, draws, strict=True)}

    i_d = idx[VAR_DIAMETER]
    coef = plan.coefficients[i_d]
    inv_k1, inv_k2, v_c = coef[:, 0], coef[:, 1], coef[:, 2]
    # one row per impact (or the single row of a smooth surface: scalars)
    row = (
        tables.rows[tables.row_of_atom[idx[VAR_ANGLE]]]
        if tables.random
        else (tables.rows[0])
    )
    sin_true, cot = row[..., A_SIN], row[..., A_COT]
    tan_phi, tan_cot, gain = row[..., A_TAN], row[..., A_TANCOT], row[..., A_GAIN]

    speed = sp.speed
    if plan.speed_factor is not None:
        speed = speed * plan.speed_factor[idx[VAR_SPEED]]
    u = speed * sin_true  # true normal speed |v_n'|
    if not isinstance(u, np.ndarray):
        u = np.full(n, u)

    shadowed = None
    n_shadowed = 0
    if tables.random and plan.shadowing == "none":
        reach = u > 0.0
        n_shadowed = n - int(np.count_nonzero(reach))
        if n_shadowed:
            shadowed = ~reach
            u = u[reach]
            inv_k1, inv_k2, v_c = inv_k1[reach], inv_k2[reach], v_c[reach]
            cot, tan_phi = cot[reach], tan_phi[reach]
            tan_cot, gain = tan_cot[reach], gain[reach]

    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
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
    if store:
        out = {
            "e_m": np.where(captured, 0.0, e_m),
            "mu_m": np.where(captured, np.nan, mu_m),
            "captured": captured,
            "reimpact": rebound & (e_m < 0),
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
        out["diameter"] = plan.diameter[i_d]
        out["roughness_angle"] = row[:, A_PHI].copy() if tables.random else np.zeros(n)
        out["speed"] = np.broadcast_to(speed, (n,)).copy()
        return out

    n_captured = int(np.count_nonzero(captured))
    if n_captured:
        e_r = e_m[rebound]
        mu_r = mu_m[rebound]
        n_rolling = int(np.count_nonzero(rolling[rebound]))
    else:
        e_r, mu_r = e_m, mu_m
        n_rolling = int(np.count_nonzero(rolling))
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
    )


# ------------------------------------------------------------------ compiled path
#: Environment variable choosing the kernel: ``numpy`` forces the NumPy kernel,
#: ``compiled`` requires the compiled one, unset or ``auto`` takes the compiled
#: kernel when it was built at install time.
KERNEL_ENV = "MICROIMPACT_KERNEL"
_KERNEL_CHOICES = ("auto", "compiled", "numpy")


def _load_compiled():
    """The compiled kernel module ``_ckernel``, or None for the NumPy kernel."""
    choice = os.environ.get(KERNEL_ENV, "").strip().lower() or "auto"
    if choice not in _KERNEL_CHOICES:
        raise InputError(
            f"environment variable {KERNEL_ENV}={os.environ[KERNEL_ENV]!r}: "
            f"expected one of {', '.join(_KERNEL_CHOICES)}"
        )
    if choice == "numpy":
        return None
    try:
        from . import _ckernel
    except ImportError as exc:
        if choice == "compiled":
            raise InputError(
                f"{KERNEL_ENV}=compiled, but the compiled kernel is not installed "
                f"({exc}); reinstall microimpact on a machine with a C compiler"
            ) from exc
        return None
    return _ckernel


_COMPILED = _load_compiled()
#: Which kernel this process runs: ``"compiled"`` or ``"numpy"`` (recorded in the
#: provenance of every result).
KERNEL = "numpy" if _COMPILED is None else "compiled"
_NO_DRAW = np.zeros(1, dtype=np.uint64)  # index array for a variable not drawn
_NO_SPREAD = np.ones(1)  # speed factor table without a speed spread
#: The histogram layout for the compiled kernel: e_m then mu_m lower edge, inverse
#: bin width, bin count.
_HIST = np.array(
    [
        E_EDGES[0],
        (E_EDGES.size - 1) / (E_EDGES[-1] - E_EDGES[0]),
        E_EDGES.size - 1,
        MU_EDGES[0],
        (MU_EDGES.size - 1) / (MU_EDGES[-1] - MU_EDGES[0]),
        MU_EDGES.size - 1,
    ]
)
_SPILL = 8  # spill slots appended to each histogram array (the C kernel's SPILL)


def _simulate_compiled(plan, sp, tables, raw, shift, n):
    """The same block through the compiled kernel (``_ckernel.c``)."""
    spread = plan.speed_factor is not None
    e_hist = np.zeros(E_EDGES.size + 1 + _SPILL, dtype=np.int64)
    mu_hist = np.zeros(MU_EDGES.size + 1 + _SPILL, dtype=np.int64)
    counts, sums = _COMPILED.block(
        raw[VAR_DIAMETER],
        raw.get(VAR_ANGLE, _NO_DRAW),
        raw.get(VAR_SPEED, _NO_DRAW),
        shift,
        n,
        tables.random,
        spread,
        plan.coefficients,
        plan.coefficients.shape[1],
        tables.row_of_atom,
        tables.rows,
        tables.rows.shape[1],
        plan.speed_factor if spread else _NO_SPREAD,
        float(sp.speed),
        plan.p,
        plan.q,
        plan.friction,
        bool(tables.random and plan.shadowing == "none"),
        _HIST,
        e_hist,
        mu_hist,
    )
    m = counts[4]
    return PointAccumulator(
        n=n,
        shadowed=counts[0],
        captured=counts[1],
        reimpact=counts[2],
        rolling=counts[3],
        e=Moments.from_shifted_sums(m, *sums[:4]),
        mu=Moments.from_shifted_sums(m, *sums[4:]),
        e_hist=e_hist[:-_SPILL],
        mu_hist=mu_hist[:-_SPILL],
    )
