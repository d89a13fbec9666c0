/*
 * The compiled form of the Monte Carlo kernel: one call per block of impacts.
 *
 * It computes exactly what microimpact.engine.kernel.simulate_block computes with
 * NumPy, in the same IEEE operation order: built with -ffp-contract=off (no fused
 * multiply-adds) and without fast-math, it sums sequentially as the NumPy kernel
 * does, and tests/test_kernel_compiled.py checks that the two agree bit for bit.
 * It exists only for speed; the physics (Eqs. 3-9 of Li, Dunn & Brach 2000) is
 * documented in kernel.py and docs/engine.md.
 *
 * A block is processed in chunks of CHUNK impacts, each in three loops over
 * L1-resident scratch:
 *   1. gather (scalar): the table rows of the drawn diameter and angle atoms are
 *      copied into one contiguous array per quantity;
 *   2. physics (branch-free, vectorised by the compiler): Eqs. 3-9 for every
 *      impact, the counts, both histogram slots and the shifted powers (x - K)^r
 *      of the rebound moments (the shift K is the block's first rebound).
 *      Captured and shadowed impacts are computed and masked, never branched on.
 *      p = q = 1 has its own copy without pow();
 *   3. sum (scalar): the histogram increments and the floating-point sums, kept
 *      sequential so that the bits do not depend on the SIMD width.
 *
 * On x86-64 Linux the block function is cloned for AVX-512, AVX2 and the baseline
 * ISA and the loader picks the best the CPU has; all clones give the same bits.
 *
 * The module needs only the buffer protocol (no NumPy headers) and releases the
 * GIL while it runs.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define CHUNK 256 /* impacts per inner chunk: the scratch stays in L1 */
#define SPILL 8   /* rotating spill slots appended to each histogram array */

/* rows of the float scratch: gathered inputs, outputs, shifted powers */
enum { W_U, W_COT, W_TAN, W_IK1, W_IK2, W_VC, W_EM, W_MUM,
       W_D1, W_D2, W_D3, W_G1, W_G2, W_G3, W_ROWS };
/* rows of the integer scratch: rebound (0/1), e_m slot, mu_m slot */
enum { I_CODE, I_BE, I_BM, I_ROWS };

typedef struct {
    double ws[W_ROWS * CHUNK];
    int64_t iws[I_ROWS * CHUNK];
} scratch_t;

typedef struct {
    double e_lo, e_inv_w, e_nb, mu_lo, mu_inv_w, mu_nb;
    int64_t e_top, mu_top, e_spill, mu_spill;
} hist_t;

typedef struct {
    int64_t shadow, capt, reimp, roll, reb;
} counts_t;

#if defined(__GNUC__)
#define ALWAYS_INLINE static inline __attribute__((always_inline))
#else
#define ALWAYS_INLINE static inline
#endif

#if defined(__GNUC__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(MICROIMPACT_NO_CLONES)
#define CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define CLONES
#endif

ALWAYS_INLINE void
shifted_powers(double *restrict ws, int64_t k, double em, double mum, int64_t reb,
               double ke, double km)
{
    double d = reb ? em - ke : 0.0;
    double d2 = d * d;
    ws[W_D1 * CHUNK + k] = d;
    ws[W_D2 * CHUNK + k] = d2;
    ws[W_D3 * CHUNK + k] = d2 * d;
    d = reb ? mum - km : 0.0;
    d2 = d * d;
    ws[W_G1 * CHUNK + k] = d;
    ws[W_G2 * CHUNK + k] = d2;
    ws[W_G3 * CHUNK + k] = d2 * d;
}

/* Eqs. 3-9 for the gathered impacts of a chunk; `general` and `powers` are
 * literal constants at every call, so each call site is its own specialised,
 * branch-free loop. The loop always runs over a whole chunk (past `c` it
 * recomputes stale values and counts nothing). */
ALWAYS_INLINE void
physics(double *restrict ws, int64_t *restrict iws, int64_t c, double p,
        double q, double friction, int64_t shadow_none, const hist_t *h, int general,
        double ke, double km, int powers, counts_t *cnt)
{
    const double two_sevenths = 2.0 / 7.0;
    const double e_lo = h->e_lo, e_inv_w = h->e_inv_w, e_nb = h->e_nb;
    const double mu_lo = h->mu_lo, mu_inv_w = h->mu_inv_w, mu_nb = h->mu_nb;
    const int64_t e_top = h->e_top, mu_top = h->mu_top;
    const int64_t e_spill = h->e_spill, mu_spill = h->mu_spill;
    int64_t n_shadow = 0, n_capt = 0, n_reimp = 0, n_roll = 0, m = 0;
    for (int64_t k = 0; k < CHUNK; k++) {
        double u = ws[W_U * CHUNK + k];
        double vc = ws[W_VC * CHUNK + k];
        double x = u * ws[W_IK1 * CHUNK + k];
        if (general)
            x = pow(x, p);
        x = x + 1.0;
        double R = 1.0 / x; /* Eq. 4 */
        double y = u - vc;
        y = y * ws[W_IK2 * CHUNK + k];
        if (general)
            y = pow(y, q);
        y = y + 1.0;
        double rho = 1.0 / y; /* Eq. 5 */
        double e = 1.0 - rho;
        e = e * R; /* Eq. 6 */
        double one_e = e + 1.0;
        double cot = ws[W_COT * CHUNK + k];
        double mu = cot * two_sevenths;
        mu = mu / one_e; /* Eq. 3 */
        int64_t rolling = fabs(mu) <= friction;
        mu = mu < -friction ? -friction : mu;
        mu = mu > friction ? friction : mu;
        double tp = ws[W_TAN * CHUNK + k];
        /* tan(phi) cot(theta - phi) and the Eq. 8 gain, computed exactly as the
         * plan tabulates them (same bits) rather than gathered */
        double tancot = tp * cot;
        double gain = tancot + 1.0;
        gain = 1.0 / gain;
        double em = mu * one_e; /* Eq. 8 */
        em = em * tp;
        em = em - tancot;
        em = em + e;
        em = em * gain;
        double den = mu * tp; /* Eq. 9 */
        den = den + 1.0;
        double mum = mu - tp;
        mum = mum / den;
        /* not reached (u <= 0) counts as shadowed only with shadowing "none";
         * capture rule: u <= v_c */
        /* (flags are 0/1 integers combined arithmetically: GCC vectorises
         * this where it does not vectorise logical operators) */
        int64_t live = k < c;
        int64_t reached = u > 0.0;
        int64_t shad = shadow_none & (reached ^ 1);
        int64_t below = u <= vc;
        int64_t capt = below & (shad ^ 1);
        int64_t reb = live & (capt ^ 1) & (shad ^ 1);
        /* everything below reads the unmasked em, mum and masks its own result
         * (GCC does not vectorise the loop when they read the masked values) */
        ws[W_EM * CHUNK + k] = reb ? em : 0.0;
        ws[W_MUM * CHUNK + k] = reb ? mum : 0.0;
        iws[I_CODE * CHUNK + k] = reb;
        n_shadow += live & shad;
        n_capt += live & capt;
        n_roll += reb & rolling;
        n_reimp += reb & (int64_t)(em < 0.0);
        m += reb;
        /* histogram slots; impacts that are not rebounds go to SPILL rotating
         * slots past the histogram, so the increments need no branch and no two
         * consecutive ones wait on each other */
        int64_t spill = k & (SPILL - 1);
        /* slot 0 below the range, nb + 1 above it, else 1 + floor(t): clamped
         * in floating point first, so that the conversion is always defined */
        double t = (em - e_lo) * e_inv_w;
        t = t < 0.0 ? -1.0 : t;
        t = t >= e_nb ? e_nb : t;
        int64_t s = (int32_t)t + 1; /* t in [-1, nb]: int32 is exact */
        iws[I_BE * CHUNK + k] = reb ? s : e_spill + spill;
        t = (mum - mu_lo) * mu_inv_w;
        t = t < 0.0 ? -1.0 : t;
        t = t >= mu_nb ? mu_nb : t;
        s = (int32_t)t + 1;
        iws[I_BM * CHUNK + k] = reb ? s : mu_spill + spill;
        if (powers)
            shifted_powers(ws, k, em, mum, reb, ke, km);
    }
    cnt->shadow += n_shadow;
    cnt->capt += n_capt;
    cnt->reimp += n_reimp;
    cnt->roll += n_roll;
    cnt->reb += m;
}

typedef struct {
    const uint64_t *i_d, *i_a, *i_s;
    int shift;
    Py_ssize_t n;
    int angle_random, speed_random;
    const double *dtab;  /* rows of (1/k1, 1/k2, v_c, ...) per diameter atom */
    Py_ssize_t dstride, drows;
    const uint16_t *amap; /* angle atom -> row of atab (< arows: the caller
                             checks this once per table, see plan.AngleTables) */
    Py_ssize_t amap_len;
    const double *atab;  /* rows of (sin, cot, tan, ...) per angle row */
    Py_ssize_t astride, arows;
    const double *sfac;  /* speed factor atoms */
    Py_ssize_t sfac_len;
    double speed, p, q, friction;
    int shadow_none;
    hist_t hist;
    int64_t *e_hist, *mu_hist;
    counts_t counts;
    double sums[8];
} block_args;

/* The caller has checked every index (see draws_in_range). */
static CLONES __attribute__((noinline)) void
run_block(block_args *a, scratch_t *s)
{
    double *restrict ws = s->ws;
    int64_t *restrict iws = s->iws;
    const int pq_one = a->p == 1.0 && a->q == 1.0;
    const int shift = a->shift;
    counts_t cnt = {0, 0, 0, 0, 0};
    double ke = 0.0, km = 0.0;
    double se1 = 0.0, se2 = 0.0, se3 = 0.0, sm1 = 0.0, sm2 = 0.0, sm3 = 0.0;
    for (Py_ssize_t start = 0; start < a->n; start += CHUNK) {
        int c = (int)(a->n - start < CHUNK ? a->n - start : CHUNK);
        /* 1. gather the table rows of the drawn atoms */
        for (int k = 0; k < c; k++) {
            Py_ssize_t ja = 0;
            double u = a->speed;
            if (a->angle_random)
                ja = a->amap[a->i_a[start + k] >> shift];
            if (a->speed_random)
                u = a->speed * a->sfac[a->i_s[start + k] >> shift];
            uint64_t jd = a->i_d[start + k] >> shift;
            const double *ar = a->atab + ja * a->astride;
            const double *dr = a->dtab + jd * a->dstride;
            ws[W_U * CHUNK + k] = u * ar[0]; /* true normal speed |v_n'| */
            ws[W_COT * CHUNK + k] = ar[1];
            ws[W_TAN * CHUNK + k] = ar[2];
            ws[W_IK1 * CHUNK + k] = dr[0];
            ws[W_IK2 * CHUNK + k] = dr[1];
            ws[W_VC * CHUNK + k] = dr[2];
        }
        /* 2. the physics, branch-free (the shifted powers too once the shift is
         * known, i.e. after the block's first rebound) */
        int known = cnt.reb > 0;
        if (pq_one) {
            if (known)
                physics(ws, iws, c, 1.0, 1.0, a->friction, a->shadow_none,
                        &a->hist, 0, ke, km, 1, &cnt);
            else
                physics(ws, iws, c, 1.0, 1.0, a->friction, a->shadow_none,
                        &a->hist, 0, ke, km, 0, &cnt);
        } else {
            if (known)
                physics(ws, iws, c, a->p, a->q, a->friction, a->shadow_none,
                        &a->hist, 1, ke, km, 1, &cnt);
            else
                physics(ws, iws, c, a->p, a->q, a->friction, a->shadow_none,
                        &a->hist, 1, ke, km, 0, &cnt);
        }
        if (!known && cnt.reb > 0) { /* 3. this chunk holds the first rebound */
            for (int k = 0; k < c; k++) {
                if (iws[I_CODE * CHUNK + k]) {
                    ke = ws[W_EM * CHUNK + k];
                    km = ws[W_MUM * CHUNK + k];
                    break;
                }
            }
            for (int k = 0; k < CHUNK; k++)
                shifted_powers(ws, k, ws[W_EM * CHUNK + k], ws[W_MUM * CHUNK + k],
                               iws[I_CODE * CHUNK + k] != 0, ke, km);
        }
        if (cnt.reb == 0)
            continue; /* no rebound yet: nothing to histogram or sum */
        /* 4. histograms and the moment sums, sequential in impact order (a
         * non-rebound adds exactly 0.0 to the sums and 1 to a spill slot) */
        for (int k = 0; k < c; k++) {
            a->e_hist[iws[I_BE * CHUNK + k]] += 1;
            a->mu_hist[iws[I_BM * CHUNK + k]] += 1;
            se1 += ws[W_D1 * CHUNK + k];
            se2 += ws[W_D2 * CHUNK + k];
            se3 += ws[W_D3 * CHUNK + k];
            sm1 += ws[W_G1 * CHUNK + k];
            sm2 += ws[W_G2 * CHUNK + k];
            sm3 += ws[W_G3 * CHUNK + k];
        }
    }
    a->counts = cnt;
    a->sums[0] = ke;
    a->sums[1] = se1;
    a->sums[2] = se2;
    a->sums[3] = se3;
    a->sums[4] = km;
    a->sums[5] = sm1;
    a->sums[6] = sm2;
    a->sums[7] = sm3;
}

/* Whether every draw of `x[0:n]`, shifted right by `shift`, is below `len`
 * (free when the shift alone guarantees it, as for Monte Carlo draws). */
static int
draws_in_range(const uint64_t *x, Py_ssize_t n, int shift, Py_ssize_t len)
{
    if ((UINT64_MAX >> shift) < (uint64_t)len)
        return 1;
    uint64_t top = 0;
    for (Py_ssize_t i = 0; i < n; i++)
        top = x[i] > top ? x[i] : top;
    return n == 0 || (top >> shift) < (uint64_t)len;
}

/* ------------------------------------------------------------ Python binding */

static int
check_len(Py_buffer *b, const char *name, Py_ssize_t itemsize, Py_ssize_t need)
{
    if (b->len % itemsize != 0 || b->len / itemsize < need) {
        PyErr_Format(PyExc_ValueError,
                     "_ckernel.block: %s holds %zd bytes, needs %zd items of %zd",
                     name, b->len, need, itemsize);
        return -1;
    }
    return 0;
}

PyDoc_STRVAR(block_doc,
"block(i_d, i_a, i_s, shift, n, angle_random, speed_random, dtab, dstride,\n"
"      amap, atab, astride, sfac, speed, p, q, friction, shadow_none, hist,\n"
"      e_hist, mu_hist) -> (counts, sums)\n\n"
"One block of `n` impacts (table indices: the uint64 draws shifted right by\n"
"`shift`). All arrays are C-contiguous: uint64 draws, float64 tables with\n"
"`dstride`/`astride` columns, uint16 `amap`, float64 `hist` (6 values: e_m then\n"
"mu_m lower edge, inverse bin width, bin count)\n"
"and int64 histogram arrays, which are added to (their last 8 slots are spill).\n"
"Returns counts (shadowed, captured, reimpact, rolling, rebounds) and sums\n"
"(K, S1, S2, S3 of e_m, then of mu_m; S_r = sum over rebounds of (x - K)^r).");

static PyObject *
ck_block(PyObject *self, PyObject *args)
{
    Py_buffer bd, ba, bs, bdt, bam, bat, bsf, bh, beh, bmh;
    int shift, angle_random, speed_random, shadow_none;
    Py_ssize_t n, dstride, astride;
    block_args a;
    if (!PyArg_ParseTuple(args, "y*y*y*inppy*ny*y*ny*ddddpy*w*w*:block", &bd,
                          &ba, &bs, &shift, &n, &angle_random, &speed_random,
                          &bdt, &dstride, &bam, &bat, &astride, &bsf, &a.speed,
                          &a.p, &a.q, &a.friction, &shadow_none, &bh, &beh, &bmh))
        return NULL;
    PyObject *result = NULL;
    memset(&a.counts, 0, sizeof a.counts);
    if (shift < 0 || shift > 63 || n < 0 || dstride < 3 || astride < 3) {
        PyErr_SetString(PyExc_ValueError, "_ckernel.block: bad shift, n or stride");
        goto done;
    }
    if (check_len(&bd, "i_d", 8, n) || check_len(&bdt, "dtab", 8, dstride) ||
        check_len(&bat, "atab", 8, astride) || check_len(&bh, "hist", 8, 6) ||
        check_len(&bam, "amap", 2, 1) || check_len(&bsf, "sfac", 8, 1) ||
        (angle_random && check_len(&ba, "i_a", 8, n)) ||
        (speed_random && check_len(&bs, "i_s", 8, n)))
        goto done;
    const double *h = (const double *)bh.buf;
    a.hist.e_lo = h[0];
    a.hist.e_inv_w = h[1];
    a.hist.e_nb = h[2];
    a.hist.mu_lo = h[3];
    a.hist.mu_inv_w = h[4];
    a.hist.mu_nb = h[5];
    /* slots: 0 below the range, 1..nb the bins, nb + 1 above, then SPILL */
    a.hist.e_top = (int64_t)h[2] + 1;
    a.hist.mu_top = (int64_t)h[5] + 1;
    a.hist.e_spill = a.hist.e_top + 1;
    a.hist.mu_spill = a.hist.mu_top + 1;
    if (h[2] < 1 || h[5] < 1 ||
        check_len(&beh, "e_hist", 8, a.hist.e_spill + SPILL) ||
        check_len(&bmh, "mu_hist", 8, a.hist.mu_spill + SPILL)) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "_ckernel.block: bad hist layout");
        goto done;
    }
    a.i_d = bd.buf;
    a.i_a = ba.buf;
    a.i_s = bs.buf;
    a.shift = shift;
    a.n = n;
    a.angle_random = angle_random;
    a.speed_random = speed_random;
    a.dtab = bdt.buf;
    a.dstride = dstride;
    a.drows = bdt.len / 8 / dstride;
    a.amap = bam.buf;
    a.amap_len = bam.len / 2;
    a.atab = bat.buf;
    a.astride = astride;
    a.arows = bat.len / 8 / astride;
    a.sfac = bsf.buf;
    a.sfac_len = bsf.len / 8;
    a.shadow_none = shadow_none;
    a.e_hist = beh.buf;
    a.mu_hist = bmh.buf;

    if (a.drows < 1 || a.arows < 1 ||
        !draws_in_range(a.i_d, n, shift, a.drows) ||
        (angle_random && !draws_in_range(a.i_a, n, shift, a.amap_len)) ||
        (speed_random && !draws_in_range(a.i_s, n, shift, a.sfac_len))) {
        PyErr_SetString(PyExc_IndexError,
                        "_ckernel.block: a drawn index falls outside its table");
        goto done;
    }
    scratch_t *s = PyMem_RawMalloc(sizeof(scratch_t));
    if (s == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    run_block(&a, s);
    Py_END_ALLOW_THREADS
    PyMem_RawFree(s);
    result = Py_BuildValue(
        "(LLLLL)(dddddddd)", (long long)a.counts.shadow, (long long)a.counts.capt,
        (long long)a.counts.reimp, (long long)a.counts.roll,
        (long long)a.counts.reb, a.sums[0], a.sums[1], a.sums[2], a.sums[3],
        a.sums[4], a.sums[5], a.sums[6], a.sums[7]);
done:
    PyBuffer_Release(&bd);
    PyBuffer_Release(&ba);
    PyBuffer_Release(&bs);
    PyBuffer_Release(&bdt);
    PyBuffer_Release(&bam);
    PyBuffer_Release(&bat);
    PyBuffer_Release(&bsf);
    PyBuffer_Release(&bh);
    PyBuffer_Release(&beh);
    PyBuffer_Release(&bmh);
    return result;
}

static PyMethodDef ck_methods[] = {
    {"block", ck_block, METH_VARARGS, block_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef ck_module = {
    PyModuleDef_HEAD_INIT, "_ckernel",
    "The compiled Monte Carlo kernel of microimpact (see _ckernel.c).", -1,
    ck_methods,
};

PyMODINIT_FUNC
PyInit__ckernel(void)
{
    PyObject *m = PyModule_Create(&ck_module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddIntConstant(m, "CHUNK", CHUNK) ||
        PyModule_AddIntConstant(m, "SPILL", SPILL)) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
