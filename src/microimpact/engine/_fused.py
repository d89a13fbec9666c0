"""The fused, compiled form of the kernel (numba), one pass over a block.

It computes exactly what :func:`microimpact.engine.kernel.simulate_block` computes
with NumPy, in the same IEEE operation order (no fast-math, no contraction into
fused multiply-adds), and sums sequentially as the NumPy fallback does; the two are
tested to agree bit for bit (``tests/test_kernel_fused.py``). It exists only for
speed: one loop, no temporaries, the tables read once per impact.

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


def _physics(
    i_d,
    i_a,
    i_s,
    n,
    angle_random,
    speed_random,
    dtab,
    amap,
    atab,
    speed_factor,
    speed,
    p,
    q,
    friction,
    em_out,
    mum_out,
    flag_out,
):
    """Elementwise part (no branches, no loop-carried state: vectorisable).

    flag_out[k] = 0 rebound, 1 captured, 2 shadowed (u <= 0: facet not reached),
    +4 if the rebound leaves rolling.
    """
    two_sevenths = 2.0 / 7.0
    for k in range(n):
        ja = amap[i_a[k]] if angle_random else 0
        u = speed * speed_factor[i_s[k]] if speed_random else speed
        u = u * atab[ja, 0]
        jd = i_d[k]
        vc = dtab[jd, 2]
        x = u * dtab[jd, 0]
        if p != 1.0:
            x = x**p
        x = x + 1.0
        R = 1.0 / x  # Eq. 4
        y = u - vc
        y = y * dtab[jd, 1]
        if q != 1.0:
            y = y**q
        y = y + 1.0
        rho = 1.0 / y  # Eq. 5
        e = 1.0 - rho
        e = e * R  # Eq. 6
        one_e = e + 1.0
        mu = atab[ja, 1] * two_sevenths
        mu = mu / one_e  # Eq. 3
        rolling = abs(mu) <= friction
        mu = min(max(mu, -friction), friction)
        tp = atab[ja, 2]
        em = mu * one_e  # Eq. 8
        em = em * tp
        em = em - atab[ja, 3]
        em = em + e
        em = em * atab[ja, 4]
        den = mu * tp  # Eq. 9
        den = den + 1.0
        mum = mu - tp
        mum = mum / den
        # capture rule: u <= v_c; not reached: u <= 0
        flag = 2 if not (u > 0.0) else (1 if u <= vc else 0)
        em_out[k] = em
        mum_out[k] = mum
        flag_out[k] = flag + 4 * rolling


def _reduce(
    n,
    shadow_none,
    em_in,
    mum_in,
    flag_in,
    e_lo,
    e_inv_w,
    e_nb,
    mu_lo,
    mu_inv_w,
    mu_nb,
    e_hist,
    mu_hist,
    buf_e,
    buf_mu,
    counts,
):
    """Counts, compaction of the rebounds and the fixed-edge histograms.

    `buf_e`, `buf_mu` may be `em_in`, `mum_in` themselves: the rebound written to
    slot ``m <= k`` never overwrites a value still to be read.
    """
    n_shadow = 0
    n_capt = 0
    n_reimp = 0
    n_roll = 0
    m = 0
    e_top = int(e_nb) + 1
    mu_top = int(mu_nb) + 1
    for k in range(n):
        f = flag_in[k]
        kind = f & 3
        shadowed = shadow_none and kind == 2
        reb = kind != 1 and not shadowed
        n_shadow += shadowed
        n_capt += kind == 1 and not shadowed
        em = em_in[k] if reb else 0.0
        mum = mum_in[k] if reb else 0.0
        n_roll += reb and f >= 4
        n_reimp += em < 0.0
        buf_e[m] = em
        buf_mu[m] = mum
        m += reb
        t = (em - e_lo) * e_inv_w
        j = 0 if t < 0.0 else (e_top if t >= e_nb else int(t) + 1)
        e_hist[j] += reb
        t = (mum - mu_lo) * mu_inv_w
        j = 0 if t < 0.0 else (mu_top if t >= mu_nb else int(t) + 1)
        mu_hist[j] += reb
    counts[0] = n_shadow
    counts[1] = n_capt
    counts[2] = n_reimp
    counts[3] = n_roll
    counts[4] = m


def _moments(x, m, out):
    """Sequential two-pass sum, M2, M3 of x[:m] into out[0:3]."""
    s = 0.0
    for k in range(m):
        s += x[k]
    mean = s / m if m else 0.0
    s2 = 0.0
    s3 = 0.0
    for k in range(m):
        d = x[k] - mean
        d2 = d * d
        s2 += d2
        s3 += d2 * d
    out[0] = mean
    out[1] = s2
    out[2] = s3


if AVAILABLE:  # pragma: no branch
    physics = numba.njit(cache=True, nogil=True, error_model="numpy")(_physics)
    reduce = numba.njit(cache=True, nogil=True, error_model="numpy")(_reduce)
    moments = numba.njit(cache=True, nogil=True, error_model="numpy")(_moments)
else:  # pragma: no cover
    physics = reduce = moments = None
