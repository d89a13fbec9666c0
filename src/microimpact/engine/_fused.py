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
   counts, both histogram slots and the shifted powers ``(x - K)^r`` of the
   rebound moments (see
   :meth:`~microimpact.engine.accumulators.Moments.from_shifted_sums`; the shift K
   is the block's first rebound). Captured and shadowed impacts are computed and
   masked, never branched on. ``p = q = 1`` has its own copy of this loop without
   ``pow`` (a ``pow`` anywhere in the loop stops the vectorisation);
3. *sum* (scalar): the histogram increments and the floating-point sums, kept
   sequential so that the bits do not depend on the SIMD width of the machine.

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

#: Impacts per inner chunk: the scratch (14 float64 + 3 int64 rows) stays in L1.
CHUNK = 256
#: Rows of the float scratch ``ws``: gathered inputs, then the outputs.
W_U, W_COT, W_TAN, W_IK1, W_IK2, W_VC, W_EM, W_MUM = range(8)
#: ... and the shifted powers (x - K)^r, r = 1, 2, 3, of e_m (D) and mu_m (G).
W_D1, W_D2, W_D3, W_G1, W_G2, W_G3 = range(8, 14)
W_ROWS = 14
#: Rows of the integer scratch ``iws``: rebound (0/1), e_m slot, mu_m slot.
I_CODE, I_BE, I_BM = range(3)
I_ROWS = 3
#: Spill slots appended to each histogram array (a power of two).
SPILL = 8


def _physics(ws, iws, c, p, q, friction, shadow_none, hist, general, ke, km, powers):
    """Eqs. 3-9 for the gathered impacts of a chunk (no loop-carried state except
    integer counts, which LLVM vectorises as reductions).

    Writes the masked e_m, mu_m (0 unless a rebound), the outcome code and the
    histogram slots; with `powers`, also the shifted powers about (`ke`, `km`).
    Returns the counts (shadowed, captured, reimpact, rolling, rebounds) of the
    first `c` impacts.
    """
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
    e_spill = int(hist[6])
    mu_spill = int(hist[7])
    n_shadow = 0
    n_capt = 0
    n_reimp = 0
    n_roll = 0
    m = 0
    # The scratch is one flat array, row r at offset r * CHUNK, and the loop always
    # runs over a whole chunk (past `c` it recomputes stale values and counts
    # nothing): with constant offsets and trip count LLVM proves that the rows do
    # not overlap and vectorises without runtime alias checks.
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
        cot = ws[W_COT * CHUNK + k]
        mu = cot * two_sevenths
        mu = mu / one_e  # Eq. 3
        rolling = abs(mu) <= friction
        mu = min(max(mu, -friction), friction)
        tp = ws[W_TAN * CHUNK + k]
        # tan(phi) cot(theta - phi) and the Eq. 8 gain, computed exactly as the
        # plan tabulates them (same bits) rather than gathered
        tancot = tp * cot
        gain = tancot + 1.0
        gain = 1.0 / gain
        em = mu * one_e  # Eq. 8
        em = em * tp
        em = em - tancot
        em = em + e
        em = em * gain
        den = mu * tp  # Eq. 9
        den = den + 1.0
        mum = mu - tp
        mum = mum / den
        # not reached (u <= 0) counts as shadowed only with shadowing "none";
        # capture rule: u <= v_c
        live = k < c
        shad = shadow_none and not (u > 0.0)
        capt = (u <= vc) and not shad
        reb = live and not capt and not shad
        em = em if reb else 0.0
        mum = mum if reb else 0.0
        ws[W_EM * CHUNK + k] = em
        ws[W_MUM * CHUNK + k] = mum
        iws[I_CODE * CHUNK + k] = reb
        n_shadow += live and shad
        n_capt += live and capt
        n_roll += reb and rolling
        n_reimp += em < 0.0
        m += reb
        # histogram slots; impacts that are not rebounds go to SPILL rotating
        # slots past the histogram, so the increments need no branch and no two
        # consecutive ones wait on each other
        spill = k & (SPILL - 1)
        t = (em - e_lo) * e_inv_w
        t = 0 if t < 0.0 else (e_top if t >= e_nb else int(t) + 1)
        iws[I_BE * CHUNK + k] = t if reb else e_spill + spill
        t = (mum - mu_lo) * mu_inv_w
        t = 0 if t < 0.0 else (mu_top if t >= mu_nb else int(t) + 1)
        iws[I_BM * CHUNK + k] = t if reb else mu_spill + spill
        if powers:
            shifted_powers(ws, k, em, mum, reb, ke, km)
    return n_shadow, n_capt, n_reimp, n_roll, m


def _shifted_powers(ws, k, em, mum, reb, ke, km):
    """(x - K)^r, r = 1, 2, 3, of impact `k`'s e_m and mu_m (0 unless a rebound)."""
    d = em - ke if reb else 0.0
    d2 = d * d
    ws[W_D1 * CHUNK + k] = d
    ws[W_D2 * CHUNK + k] = d2
    ws[W_D3 * CHUNK + k] = d2 * d
    d = mum - km if reb else 0.0
    d2 = d * d
    ws[W_G1 * CHUNK + k] = d
    ws[W_G2 * CHUNK + k] = d2
    ws[W_G3 * CHUNK + k] = d2 * d


def _powers(ws, iws, ke, km):
    """The shifted powers of a chunk whose shift was not known before its physics
    (the chunk holding the block's first rebound)."""
    for k in range(CHUNK):
        em, mum = ws[W_EM * CHUNK + k], ws[W_MUM * CHUNK + k]
        shifted_powers(ws, k, em, mum, iws[I_CODE * CHUNK + k] != 0, ke, km)


def _block(
    i_d,
    i_a,
    i_s,
    shift,
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
    """One block of `n` impacts (table indices: the draws shifted right by
    `shift`): counts, histograms (added into `e_hist`, `mu_hist`, whose last
    :data:`SPILL` slots the caller discards; ``hist[6:8]`` are their offsets) and
    the shifted moment sums of the rebounds.

    ``counts`` <- (shadowed, captured, reimpact, rolling, rebounds);
    ``sums`` <- (K, S1, S2, S3) of e_m then of mu_m, with the shift K the first
    rebound's value and S_r = sum of (x - K)^r over rebounds in impact order.
    """
    pq_one = p == 1.0 and q == 1.0
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
            ja = amap[i_a[start + k] >> shift] if angle_random else 0
            u = speed * sfac[i_s[start + k] >> shift] if speed_random else speed
            jd = i_d[start + k] >> shift
            ws[W_U * CHUNK + k] = u * atab[ja, 0]  # true normal speed |v_n'|
            ws[W_COT * CHUNK + k] = atab[ja, 1]
            ws[W_TAN * CHUNK + k] = atab[ja, 2]
            ws[W_IK1 * CHUNK + k] = dtab[jd, 0]
            ws[W_IK2 * CHUNK + k] = dtab[jd, 1]
            ws[W_VC * CHUNK + k] = dtab[jd, 2]
        # 2. the physics, branch-free (the shifted powers too once the shift is
        # known, i.e. after the block's first rebound)
        known = m > 0
        if pq_one:
            cs = physics(
                ws, iws, c, 1.0, 1.0, friction, shadow_none, hist, False, ke, km, known
            )
        else:
            cs = physics(
                ws, iws, c, p, q, friction, shadow_none, hist, True, ke, km, known
            )
        n_shadow += cs[0]
        n_capt += cs[1]
        n_reimp += cs[2]
        n_roll += cs[3]
        m += cs[4]
        if not known and m > 0:  # 3. this chunk holds the first rebound
            for k in range(c):
                if iws[I_CODE * CHUNK + k]:
                    ke = ws[W_EM * CHUNK + k]
                    km = ws[W_MUM * CHUNK + k]
                    break
            powers(ws, iws, ke, km)
        if m == 0:
            continue  # no rebound yet: nothing to histogram or sum
        # 4. histograms and the moment sums, sequential in impact order (a
        # non-rebound adds exactly 0.0 to the sums and 1 to a spill slot)
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
    shifted_powers = numba.njit(inline="always", **_opts)(_shifted_powers)
    physics = numba.njit(inline="always", **_opts)(_physics)
    powers = numba.njit(inline="always", **_opts)(_powers)
    block = numba.njit(**_opts)(_block)
else:  # pragma: no cover
    shifted_powers = physics = powers = block = None
