"""The fused, compiled form of the kernel (numba): one call per block.

It computes exactly what :func:`microimpact.engine.kernel.simulate_block` computes
with NumPy, in the same IEEE operation order (no fast-math, no contraction into
fused multiply-adds), and sums sequentially as the NumPy fallback does; the two are
tested to agree bit for bit (``tests/test_kernel_fused.py``). It exists only for
speed. A block is processed in chunks of :data:`CHUNK` impacts, each in three
loops over L1-resident scratch:

1. *gather* (scalar): the table rows of the drawn diameter and angle atoms are
   copied into one contiguous array per quantity (LLVM does not emit vector gathers
   on every x86 CPU, so the lookups are kept out of the arithmetic loop);
2. *physics* (branch-free, vectorised by LLVM): Eqs. 3-9 for every impact, the
   outcome code and both histogram bins; captured and shadowed impacts are computed
   and masked, never branched on. ``p = q = 1`` has its own copy of this loop
   without ``pow`` (a ``pow`` anywhere in the loop stops the vectorisation);
3. *reduce*: counts, histograms and the shifted sums of the
   rebound moments (see
   :meth:`~microimpact.engine.accumulators.Moments.from_shifted_sums`), the
   shift being the block's first rebound. Only the histogram increments and the
   floating-point sums (sequential, for reproducible bits) remain scalar.

Set ``MICROIMPACT_KERNEL=numpy`` to force the NumPy kernel.
"""

from __future__ import annotations

import os

try:  # pragma: no cover - import guard
    if os.environ.get("MICROIMPACT_KERNEL", "").lower() == "numpy":
        raise ImportError("disabled by MICROIMPACT_KERNEL=numpy")
    import numba

    AVAILABLE = True
except ImportError:  # pragma: no cover
    numba = None
    AVAILABLE = False

#: Impacts per inner chunk: the scratch (11 float64 + 3 int64 rows) stays in L1.
CHUNK = 256
#: Rows of the float scratch ``ws``: gathered inputs, then the outputs.
W_U, W_COT, W_TAN, W_TANCOT, W_GAIN, W_IK1, W_IK2, W_VC, W_EM, W_MUM = range(10)
#: ... and the shifted powers (x - K)^r, r = 1, 2, 3, of e_m (D) and mu_m (G).
W_D1, W_D2, W_D3, W_G1, W_G2, W_G3 = range(10, 16)
W_ROWS = 16
#: Rows of the integer scratch ``iws``: outcome code, e_m bin, mu_m bin.
I_CODE, I_BE, I_BM = range(3)
I_ROWS = 3
#: Spill slots appended to each histogram array (a power of two).
SPILL = 8
#: Bits of the outcome code.
CODE_CAPTURED, CODE_SHADOWED, CODE_REBOUND, CODE_ROLLING = 1, 2, 4, 8


def _physics(ws, iws, p, q, friction, shadow_none, hist, general):
    """Eqs. 3-9 for the gathered impacts of a chunk (no loop-carried state)."""
    two_sevenths = 2.0 / 7.0
    e_lo, e_inv_w, e_nb, mu_lo, mu_inv_w, mu_nb = (
        hist[0],
        hist[1],
        hist[2],
        hist[3],
        hist[4],
        hist[5],
    )
    e_top = int(e_nb) + 1
    mu_top = int(mu_nb) + 1
    # The scratch is one flat array, row r at offset r * CHUNK, and the loop always
    # runs over a whole chunk (past `c` it recomputes stale values nobody reads):
    # with constant offsets and trip count LLVM proves that the rows do not overlap
    # and vectorises without runtime alias checks.
    for k in range(CHUNK):
        u = ws[W_U * CHUNK + k]
        vc = ws[W_VC * CHUNK + k]
        x = u * ws[W_IK1 * CHUNK + k]
        if general:
            x = x**p
        x = x + 1.0
        R = 1.0 / x  # Eq. 4
        y = u - vc
        y = y * ws[W_IK2 * CHUNK + k]
        if general:
            y = y**q
        y = y + 1.0
        rho = 1.0 / y  # Eq. 5
        e = 1.0 - rho
        e = e * R  # Eq. 6
        one_e = e + 1.0
        mu = ws[W_COT * CHUNK + k] * two_sevenths
        mu = mu / one_e  # Eq. 3
        rolling = abs(mu) <= friction
        mu = min(max(mu, -friction), friction)
        tp = ws[W_TAN * CHUNK + k]
        em = mu * one_e  # Eq. 8
        em = em * tp
        em = em - ws[W_TANCOT * CHUNK + k]
        em = em + e
        em = em * ws[W_GAIN * CHUNK + k]
        den = mu * tp  # Eq. 9
        den = den + 1.0
        mum = mu - tp
        mum = mum / den
        # not reached (u <= 0) counts as shadowed only with shadowing "none";
        # capture rule: u <= v_c
        shad = shadow_none and not (u > 0.0)
        capt = (u <= vc) and not shad
        reb = not capt and not shad
        em = em if reb else 0.0
        mum = mum if reb else 0.0
        ws[W_EM * CHUNK + k] = em
        ws[W_MUM * CHUNK + k] = mum
        iws[I_CODE * CHUNK + k] = (
            CODE_CAPTURED * capt
            + CODE_SHADOWED * shad
            + CODE_REBOUND * reb
            + CODE_ROLLING * (rolling and reb)
        )
        t = (em - e_lo) * e_inv_w
        iws[I_BE * CHUNK + k] = 0 if t < 0.0 else (e_top if t >= e_nb else int(t) + 1)
        t = (mum - mu_lo) * mu_inv_w
        iws[I_BM * CHUNK + k] = 0 if t < 0.0 else (mu_top if t >= mu_nb else int(t) + 1)


def _block(
    i_d,
    i_a,
    i_s,
    n,
    angle_random,
    speed_random,
    dtab,
    amap,
    atab,
    sfac,
    speed,
    p,
    q,
    friction,
    shadow_none,
    hist,
    e_hist,
    mu_hist,
    counts,
    sums,
    ws,
    iws,
):
    """One block of `n` impacts: counts, histograms (added into `e_hist`,
    `mu_hist`, each with :data:`SPILL` extra slots at the end that the caller
    discards) and the shifted moment sums of the rebounds.

    ``counts`` <- (shadowed, captured, reimpact, rolling, rebounds);
    ``sums`` <- (K, S1, S2, S3) of e_m then of mu_m, with the shift K the first
    rebound's value and S_r = sum of (x - K)^r over rebounds in impact order.
    """
    pq_one = p == 1.0 and q == 1.0
    e_spill = e_hist.size - SPILL
    mu_spill = mu_hist.size - SPILL
    n_shadow = 0
    n_capt = 0
    n_reimp = 0
    n_roll = 0
    m = 0
    ke = 0.0
    km = 0.0
    se1 = 0.0
    se2 = 0.0
    se3 = 0.0
    sm1 = 0.0
    sm2 = 0.0
    sm3 = 0.0
    for start in range(0, n, CHUNK):
        c = min(CHUNK, n - start)
        # 1. gather the table rows of the drawn atoms
        for k in range(c):
            ja = amap[i_a[start + k]] if angle_random else 0
            u = speed * sfac[i_s[start + k]] if speed_random else speed
            jd = i_d[start + k]
            ws[W_U * CHUNK + k] = u * atab[ja, 0]  # true normal speed |v_n'|
            ws[W_COT * CHUNK + k] = atab[ja, 1]
            ws[W_TAN * CHUNK + k] = atab[ja, 2]
            ws[W_TANCOT * CHUNK + k] = atab[ja, 3]
            ws[W_GAIN * CHUNK + k] = atab[ja, 4]
            ws[W_IK1 * CHUNK + k] = dtab[jd, 0]
            ws[W_IK2 * CHUNK + k] = dtab[jd, 1]
            ws[W_VC * CHUNK + k] = dtab[jd, 2]
        # 2. the physics, branch-free
        if pq_one:
            physics(ws, iws, 1.0, 1.0, friction, shadow_none, hist, False)
        else:
            physics(ws, iws, p, q, friction, shadow_none, hist, True)
        # 3. the shift of the moment sums: the block's first rebound
        if m == 0:
            for k in range(c):
                if iws[I_CODE * CHUNK + k] & CODE_REBOUND:
                    ke = ws[W_EM * CHUNK + k]
                    km = ws[W_MUM * CHUNK + k]
                    break
        # 4. counts (integer reductions), shifted powers, histogram slots (branch-
        # free: impacts that are not rebounds go to 8 rotating spill slots past
        # the histogram, so no two consecutive increments wait on each other)
        for k in range(CHUNK):
            f = iws[I_CODE * CHUNK + k]
            live = k < c
            reb = live and (f & CODE_REBOUND) != 0
            em = ws[W_EM * CHUNK + k]
            d = em - ke if reb else 0.0
            d2 = d * d
            ws[W_D1 * CHUNK + k] = d
            ws[W_D2 * CHUNK + k] = d2
            ws[W_D3 * CHUNK + k] = d2 * d
            d = ws[W_MUM * CHUNK + k] - km if reb else 0.0
            d2 = d * d
            ws[W_G1 * CHUNK + k] = d
            ws[W_G2 * CHUNK + k] = d2
            ws[W_G3 * CHUNK + k] = d2 * d
            n_capt += live and (f & CODE_CAPTURED) != 0
            n_shadow += live and (f & CODE_SHADOWED) != 0
            n_roll += reb and (f & CODE_ROLLING) != 0
            n_reimp += reb and em < 0.0
            m += reb
            spill = k & (SPILL - 1)
            be = iws[I_BE * CHUNK + k]
            bm = iws[I_BM * CHUNK + k]
            iws[I_BE * CHUNK + k] = be if reb else e_spill + spill
            iws[I_BM * CHUNK + k] = bm if reb else mu_spill + spill
        # 5. histograms and the moment sums, sequential in impact order (a
        # non-rebound adds exactly 0.0)
        for k in range(c):
            e_hist[iws[I_BE * CHUNK + k]] += 1
            mu_hist[iws[I_BM * CHUNK + k]] += 1
            se1 += ws[W_D1 * CHUNK + k]
            se2 += ws[W_D2 * CHUNK + k]
            se3 += ws[W_D3 * CHUNK + k]
            sm1 += ws[W_G1 * CHUNK + k]
            sm2 += ws[W_G2 * CHUNK + k]
            sm3 += ws[W_G3 * CHUNK + k]
    counts[0] = n_shadow
    counts[1] = n_capt
    counts[2] = n_reimp
    counts[3] = n_roll
    counts[4] = m
    sums[0] = ke
    sums[1] = se1
    sums[2] = se2
    sums[3] = se3
    sums[4] = km
    sums[5] = sm1
    sums[6] = sm2
    sums[7] = sm3


if AVAILABLE:  # pragma: no branch
    _opts = dict(cache=True, nogil=True, error_model="numpy")
    physics = numba.njit(inline="always", **_opts)(_physics)
    block = numba.njit(**_opts)(_block)
else:  # pragma: no cover
    physics = block = None
