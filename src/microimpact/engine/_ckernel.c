/*
 * The compiled form of the Monte Carlo kernel: blocks of impacts.
 *
 * It computes exactly what microimpact.engine.kernel.simulate_block computes with
 * NumPy, in the same IEEE operation order: built with -ffp-contract=off (no fused
 * multiply-adds) and without fast-math, it sums sequentially as the NumPy kernel
 * does, and tests/test_kernel_compiled.py checks that the two agree bit for bit.
 * It exists only for speed; the physics (Eqs. 3-9 of Li, Dunn & Brach 2000) is
 * documented in kernel.py and docs/engine.md.
 *
 * Every random variable is a cell table (plan.Sampler, _tables.CellTable): a
 * 64-bit draw r selects the cell j with cum[j] <= r < cum[j+1] (a guide table
 * indexed by the top bits of r, then a short search) and the fraction
 * f = (r - cum[j]) * inv_width[j]; a quantity is read as lo + f * span from the
 * cell's row.
 *
 * A block is processed in chunks of CHUNK impacts, each in three loops over
 * L1-resident scratch:
 *   1. gather (scalar): the cells of the drawn diameter, angle and speed are
 *      located and their quantities interpolated into one contiguous array per
 *      quantity, with sin(theta - phi) and cos(theta - phi) from the
 *      angle-difference formulas;
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
 * The random draws: block() reads them from arrays (QMC, and the tests);
 * specs() runs a list of Monte Carlo blocks in one call and draws each block's
 * variables itself from their keyed streams, NumPy's
 * PCG64(SeedSequence(entropy, spawn_key=(point, block, variable))) reimplemented
 * bit for bit (see "keyed streams" below; tests/test_rng_streams.py), a chunk
 * at a time into L1-resident scratch.
 *
 * The module needs only the buffer protocol (no NumPy headers) and releases the
 * GIL while it runs.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include <time.h>

/* The nanoseconds the kernel has run with the GIL released, summed over every
 * call and thread (released_ns()): benchmarks/gil_share.py's second reading of
 * a path's GIL share. Two clock reads per call (~40 ns). */
static int64_t released_total_ns = 0;

static int64_t
clock_ns(void)
{
    struct timespec t;
#if defined(CLOCK_MONOTONIC) && !defined(_WIN32)
    clock_gettime(CLOCK_MONOTONIC, &t);
#else
    timespec_get(&t, TIME_UTC);
#endif
    return (int64_t)t.tv_sec * 1000000000 + t.tv_nsec;
}

#if defined(__GNUC__)
#define ADD_RELEASED(x) __atomic_fetch_add(&released_total_ns, (x), __ATOMIC_RELAXED)
#define LOAD_RELEASED() __atomic_load_n(&released_total_ns, __ATOMIC_RELAXED)
#else /* an instrument: two threads adding at once may lose one count */
#define ADD_RELEASED(x) (released_total_ns += (x))
#define LOAD_RELEASED() (released_total_ns)
#endif

/* Py_BEGIN/END_ALLOW_THREADS that also count the time between them. */
#define RELEASE_GIL                                                            \
    Py_BEGIN_ALLOW_THREADS {                                                   \
        const int64_t released_from_ = clock_ns();
#define ACQUIRE_GIL                                                            \
    ADD_RELEASED(clock_ns() - released_from_);                                 \
    }                                                                          \
    Py_END_ALLOW_THREADS

#define CHUNK 256 /* impacts per inner chunk: the scratch stays in L1 */
#define SPILL 8   /* rotating spill slots appended to each histogram array */

/* rows of the float scratch: gathered inputs, outputs, shifted powers */
enum { W_U, W_SIN, W_COT, W_TAN, W_IK1, W_IK2, W_VC, W_EM, W_MUM,
       W_D1, W_D2, W_D3, W_G1, W_G2, W_G3,
       /* areal surfaces: sin, cos of phi_par and of the tilt chi; the folded
        * lateral angle psi_f and its shifted powers */
       W_SP, W_CP, W_SX, W_CX, W_LAT, W_L1, W_L2, W_L3,
       /* the lateral angle's atan2 arguments (for stored impacts) */
       W_LX, W_LY, W_ROWS };
/* rows of the integer scratch: rebound (0/1), e_m slot, mu_m slot, psi_f slot,
 * outcome (0 rebound, 1 captured, 2 shadowed) */
enum { I_CODE, I_BE, I_BM, I_BL, I_OUT, I_ROWS };

typedef struct {
    double ws[W_ROWS * CHUNK];
    int64_t iws[I_ROWS * CHUNK];
    uint64_t ra[CHUNK];          /* angle draws (scaled for "reject") */
    uint32_t g[3][CHUNK];        /* guide entry per variable */
    uint64_t draw[4][CHUNK];     /* a chunk of each variable's keyed stream */
    /* pair search: per impact the particle atom; per rejected proposal (packed)
     * its impact, f gmax - g, gmax - g, the target, alpha, beta, the end of the
     * atoms searched and the search's position */
    int64_t pj[CHUNK];
    uint32_t pg[CHUNK];
    double pf[CHUNK], pgw[CHUNK];
    int32_t pat[CHUNK];
    double pnum[CHUNK], pden[CHUNK], pu[CHUNK], pal[CHUNK], pbe[CHUNK];
    int64_t pn[CHUNK], pb[CHUNK];
} scratch_t;

typedef struct {
    double e_lo, e_inv_w, e_nb, mu_lo, mu_inv_w, mu_nb;
    double lat_lo, lat_inv_w, lat_nb, lat_hi; /* psi_f; lat_hi: the last edge */
    int64_t e_top, mu_top, e_spill, mu_spill, lat_top, lat_spill, lat_zero;
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

ALWAYS_INLINE void
shifted_lateral(double *restrict ws, int64_t k, double lat, int64_t reb, double kl)
{
    double d = reb ? lat - kl : 0.0;
    double d2 = d * d;
    ws[W_L1 * CHUNK + k] = d;
    ws[W_L2 * CHUNK + k] = d2;
    ws[W_L3 * CHUNK + k] = d2 * d;
}

/* Cephes' atan (kernel.atan2_deg, the same IEEE operations in the same order):
 * |y| / |x| reduced to [0, 0.66] (the branches as selections), a degree 4/5
 * rational approximation, the sign of y; x >= 0 (the folded angle), in degrees. */
#define ATAN_T3P8 2.41421356237309504880
#define ATAN_MOREBITS 6.123233995736765886130e-17
#define RAD2DEG (180.0 / 3.141592653589793)
/* atan(ay / ax) for ay, ax >= 0 (0 where ay = 0). */
ALWAYS_INLINE double
atan_abs(double ay, double ax)
{
    double t = ay / ax;
    int64_t big = t > ATAN_T3P8;
    int64_t mid = (t > 0.66) & (big ^ 1);
    /* (every operand formed unconditionally, then selected: GCC if-converts
     * and vectorises only selections of values) */
    double tm = t - 1.0, tp = t + 1.0;
    double num = big ? -1.0 : (mid ? tm : t);
    double den = big ? t : (mid ? tp : 1.0);
    double r = num / den;
    double z = r * r;
    double pz = (((-8.750608600031904122785e-1 * z + -1.615753718733365076637e1) * z +
                  -7.500855792314704667340e1) * z + -1.228866684490136173410e2) * z +
                -6.485021904942025371773e1;
    double qz = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z +
                  4.328810604912902668951e2) * z + 4.853903996359136964868e2) * z +
                1.945506571482613964425e2;
    z = z * pz;
    z = z / qz;
    z = r * z + r;
    z = z + (big ? ATAN_MOREBITS : (mid ? 0.5 * ATAN_MOREBITS : 0.0));
    double a = (big ? 3.141592653589793 / 2 : (mid ? 3.141592653589793 / 4 : 0.0)) + z;
    return ay == 0.0 ? 0.0 : a;
}

/* The folded angle: x >= 0. */
ALWAYS_INLINE double
atan2_deg_folded(double y, double x)
{
    return copysign(atan_abs(fabs(y), x), y) * RAD2DEG;
}

/* Any x: pi - a where x has its sign bit set. */
ALWAYS_INLINE double
atan2_deg(double y, double x)
{
    double a = atan_abs(fabs(y), fabs(x));
    double b = 3.141592653589793 - a;
    a = signbit(x) ? b : a;
    return copysign(a, y) * RAD2DEG;
}

/* Eqs. 3-9 for the gathered impacts of a chunk; `general` and `powers` are
 * literal constants at every call, so each call site is its own specialised,
 * branch-free loop. The loop always runs over a whole chunk (past `c` it
 * recomputes stale values and counts nothing). */
ALWAYS_INLINE void
physics(double *restrict ws, int64_t *restrict iws, int64_t c, double p,
        double q, double friction, int64_t shadow_none, const hist_t *h, int general,
        double ke, double km, int powers, counts_t *cnt, int areal, double kl)
{
    const double two_sevenths = 2.0 / 7.0;
    const double e_lo = h->e_lo, e_inv_w = h->e_inv_w, e_nb = h->e_nb;
    const double mu_lo = h->mu_lo, mu_inv_w = h->mu_inv_w, mu_nb = h->mu_nb;
    const int64_t e_spill = h->e_spill, mu_spill = h->mu_spill;
    const double lat_lo = h->lat_lo, lat_inv_w = h->lat_inv_w, lat_nb = h->lat_nb;
    const double lat_hi = h->lat_hi;
    const int64_t lat_spill = h->lat_spill, lat_last = h->lat_top - 1;
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
        /* W_COT holds cos(theta - phi) until here */
        double cot = ws[W_COT * CHUNK + k] / ws[W_SIN * CHUNK + k];
        double tp = ws[W_TAN * CHUNK + k];
        /* tan(phi) cot(theta - phi) and the Eq. 8 gain, computed exactly as the
         * NumPy kernel computes them (same bits) */
        double tancot = tp * cot;
        double gain = tancot + 1.0;
        gain = 1.0 / gain;
        double em, mum, lat = 0.0;
        int64_t rolling;
        if (!areal) {
            double mu = cot * two_sevenths;
            mu = mu / one_e; /* Eq. 3 */
            rolling = fabs(mu) <= friction;
            mu = mu < -friction ? -friction : mu;
            mu = mu > friction ? friction : mu;
            em = mu * one_e; /* Eq. 8 */
            em = em * tp;
            em = em - tancot;
            em = em + e;
            em = em * gain;
            double den = mu * tp; /* Eq. 9 */
            den = den + 1.0;
            mum = mu - tp;
            mum = mum / den;
        } else {
            /* the facet tilted by chi about its line t' (kernel._areal_impact,
             * operation for operation; chi = 0 gives the branch above's bits) */
            double sx = ws[W_SX * CHUNK + k], cx = ws[W_CX * CHUNK + k];
            double h2 = cot * cot + sx * sx;
            double h = copysign(sqrt(h2), cot);
            double g = sx == 0.0 ? cot : h; /* slip_ratio */
            double mu = g / cx; /* eta */
            mu = mu * two_sevenths;
            mu = mu / one_e; /* Eq. 3 */
            rolling = fabs(mu) <= friction;
            mu = mu < -friction ? -friction : mu;
            mu = mu > friction ? friction : mu;
            int64_t moving = g != 0.0;
            double cg = cot / g, sg = sx / g;
            double mt = mu * (moving ? cg : 1.0);
            double mb = mu * (moving ? sg : 0.0);
            double qb = mb * one_e;
            qb = qb * cx;
            qb = sx - qb;
            double ephi = e * (cx * cx);
            ephi = ephi - sx * qb;
            em = mt * one_e;
            em = em * cx;
            double qt = cot - em;
            em = em * tp;
            em = em - tancot;
            em = em + ephi;
            em = em * gain;
            double muphi = mb * sx;
            muphi = muphi + cx;
            muphi = mt / muphi;
            double den = muphi * tp;
            den = den + 1.0;
            mum = muphi - tp;
            mum = mum / den;
            /* the folded lateral angle (kernel._lateral_angle) */
            double qn = -e * cx;
            double qa = qn * cx + qb * sx;
            double lx = ws[W_CP * CHUNK + k] * qt - ws[W_SP * CHUNK + k] * qa;
            double ly = sx * qn - cx * qb;
            lat = atan2_deg_folded(ly + 0.0, fabs(lx));
            ws[W_LX * CHUNK + k] = lx;
            ws[W_LY * CHUNK + k] = ly;
        }
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
        iws[I_OUT * CHUNK + k] = 2 * shad + capt;
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
        if (areal) {
            ws[W_LAT * CHUNK + k] = reb ? lat : 0.0;
            t = (lat - lat_lo) * lat_inv_w;
            t = t < 0.0 ? -1.0 : t;
            t = t >= lat_nb ? lat_nb : t;
            s = (int32_t)t + 1;
            s = lat == lat_hi ? lat_last : s; /* the last edge is inclusive */
            iws[I_BL * CHUNK + k] = reb ? s : lat_spill + spill;
            if (powers)
                shifted_lateral(ws, k, lat, reb, kl);
        }
    }
    cnt->shadow += n_shadow;
    cnt->capt += n_capt;
    cnt->reimp += n_reimp;
    cnt->roll += n_roll;
    cnt->reb += m;
}

/* One cell table (see plan.Sampler): row j holds the cell's start (uint64 bits),
 * 1/width and (lo, span) pairs; row n is a sentinel whose start is 2^64 - 1. The
 * guide (entries <= n - 1 and non-decreasing by construction: the plan builds it)
 * gives the first cell of every top-bits slot of a draw. */
typedef struct {
    const double *rows;
    Py_ssize_t stride, n;
    const uint32_t *guide;
    int gshift;
    int kind;        /* 0 general (guide), 1 equal cells, 2 dyadic grid */
    int levels, cbits; /* dyadic: levels per half, log2 cells per level */
    int constant;      /* bit q: interpolated column q is the same in every cell */
    double cval[3];    /* its value (what the interpolation gives in any cell) */
    const double *crows; /* compact rows (kinds 1, 2): the varying columns only */
    Py_ssize_t cstride;
    int cpos[3];       /* column q's place in a compact row; -1: constant */
} sampler_t;

#define GUIDE_SEARCH 0x80000000u /* _tables.GUIDE_SEARCH */
#define GUIDE_CELL 0x7FFFFFFFu

/* floor(a * b / 2^64), exactly (the NumPy kernel: _tables.mulhi64) */
ALWAYS_INLINE uint64_t
mulhi64(uint64_t a, uint64_t b)
{
#if defined(__SIZEOF_INT128__)
    return (uint64_t)(((unsigned __int128)a * b) >> 64);
#else
    const uint64_t m = 0xFFFFFFFFu;
    uint64_t a_lo = a & m, a_hi = a >> 32, b_lo = b & m, b_hi = b >> 32;
    uint64_t cross = ((a_lo * b_lo) >> 32) + ((a_hi * b_lo) & m) + a_lo * b_hi;
    return ((a_hi * b_lo) >> 32) + (cross >> 32) + a_hi * b_hi;
#endif
}

ALWAYS_INLINE uint64_t
cell_start(const sampler_t *s, Py_ssize_t i)
{
    uint64_t c;
    memcpy(&c, s->rows + i * s->stride, sizeof c);
    return c;
}

/* First pass of a lookup: the cell of draw r where arithmetic gives it (kinds 1
 * and 2, see _tables.CellTable), else its guide entry; and a prefetch of the row
 * it names (the second pass, locate, then finds the row in cache). */
ALWAYS_INLINE uint32_t
guide_entry(const sampler_t *s, uint64_t r)
{
    uint32_t g;
    if (s->kind == 1) { /* n equal cells: floor(r n / 2^64) */
        g = (uint32_t)mulhi64(r, (uint64_t)s->n);
    } else if (s->kind == 2) { /* the refined grid, mirrored in the upper half */
        /* branch-free: the upper half mirrored (R = ~r), the level from the
         * leading bit, the outermost cell where R has no bit at or above level
         * `levels` */
        uint64_t up = r >> 63;
        uint64_t R = r ^ (0 - up); /* < 2^63 */
        int k = __builtin_clzll(R | 1) - 1; /* R in [2^(62-k), 2^(63-k)) */
        int deep = (R >> (63 - s->levels)) == 0;
        k = k < s->levels - 1 ? k : s->levels - 1;
        Py_ssize_t j = (Py_ssize_t)(R >> (62 - k - s->cbits)) &
                       (((Py_ssize_t)1 << s->cbits) - 1);
        Py_ssize_t L = 1 + ((Py_ssize_t)(s->levels - 1 - k) << s->cbits) + j;
        L = deep ? 0 : L;
        g = (uint32_t)(up ? s->n - 1 - L : L);
    } else {
        g = s->guide[r >> s->gshift];
    }
    return g;
}

/* The cell of draw r (the last cell starting at or below r) and its fraction;
 * returns the cell's row. `g` is the guide entry of r: most draws fall in a slot
 * of one cell and need no search (the flag is clear); the others search the
 * guide range [g, next entry], one step branch-free, then by bisection (slots
 * deep in a tail hold many cells). */
ALWAYS_INLINE Py_ssize_t
locate(const sampler_t *s, uint64_t r, uint32_t g, double *f)
{
    Py_ssize_t i = g & GUIDE_CELL;
    if (g & GUIDE_SEARCH) {
        Py_ssize_t hi = s->guide[(r >> s->gshift) + 1] & GUIDE_CELL;
        i += (Py_ssize_t)((i < hi) & (cell_start(s, i + 1) <= r));
        if (i < hi && cell_start(s, i + 1) <= r) {
            Py_ssize_t lo = i + 1; /* cell_start(lo) <= r: the answer is in [lo, hi] */
            while (lo < hi) {
                Py_ssize_t mid = lo + (hi - lo + 1) / 2;
                if (cell_start(s, mid) <= r)
                    lo = mid;
                else
                    hi = mid - 1;
            }
            i = lo;
        }
    }
    *f = (double)(r - cell_start(s, i)) * s->rows[i * s->stride + 1];
    return i;
}

/* ------------------------------------- keyed streams: SeedSequence and PCG64 */
/* Block b of sweep point p draws variable v from
 * numpy.random.PCG64(numpy.random.SeedSequence(entropy, spawn_key=(p, b, v))),
 * and this is that generator, bit for bit (tests/test_rng_streams.py checks it
 * against NumPy): SeedSequence's hash pool (numpy/random/bit_generator.pyx:
 * mix_entropy and generate_state, pool of 4 uint32 words), PCG64's seeding
 * (pcg64_set_seed: state and increment from generate_state(4, uint64), with the
 * two initial steps of pcg_setseq_128_srandom_r) and its output, XSL-RR 128/64
 * (random_raw; numpy/random/src/pcg64/pcg64.h).
 *
 * The assembled entropy is the entropy's uint32 words (little-endian; 0 is one
 * word 0), padded with zeros to the pool size when shorter (NumPy does so when a
 * spawn key is given), then every key element's words. Only the first pool-size
 * words enter the pool before its words are mixed together; the rest are mixed
 * in one at a time. So the pool after the entropy does not depend on the key
 * (ss_prefix, once per run), and each stream adds its few key words (ss_key). */
#define SS_POOL 4
#define SS_INIT_A 0x43b0d7e5u
#define SS_MULT_A 0x931e8875u
#define SS_INIT_B 0x8b51f9ddu
#define SS_MULT_B 0x58f38dedu
#define SS_MIX_MULT_L 0xca01f9ddu
#define SS_MIX_MULT_R 0x4973f715u
#define SS_XSHIFT 16

typedef struct {
    uint32_t pool[SS_POOL];
    uint32_t hash_const; /* the running hashmix constant */
} ss_state;

static inline uint32_t
ss_hashmix(uint32_t value, uint32_t *hash_const)
{
    value ^= *hash_const;
    *hash_const *= SS_MULT_A;
    value *= *hash_const;
    value ^= value >> SS_XSHIFT;
    return value;
}

static inline uint32_t
ss_mix(uint32_t x, uint32_t y)
{
    uint32_t result = SS_MIX_MULT_L * x - SS_MIX_MULT_R * y;
    result ^= result >> SS_XSHIFT;
    return result;
}

/* The pool after the entropy words w[0:nw] (nw >= 1; padded with zeros to the
 * pool size, as NumPy pads when a spawn key follows). */
static void
ss_prefix(const uint32_t *w, Py_ssize_t nw, ss_state *st)
{
    uint32_t hc = SS_INIT_A;
    for (int i = 0; i < SS_POOL; i++)
        st->pool[i] = ss_hashmix(i < nw ? w[i] : 0u, &hc);
    for (int i_src = 0; i_src < SS_POOL; i_src++)
        for (int i_dst = 0; i_dst < SS_POOL; i_dst++)
            if (i_src != i_dst)
                st->pool[i_dst] = ss_mix(st->pool[i_dst], ss_hashmix(st->pool[i_src], &hc));
    for (Py_ssize_t i_src = SS_POOL; i_src < nw; i_src++)
        for (int i_dst = 0; i_dst < SS_POOL; i_dst++)
            st->pool[i_dst] = ss_mix(st->pool[i_dst], ss_hashmix(w[i_src], &hc));
    st->hash_const = hc;
}

/* One more entropy word mixed into every pool word. */
static inline void
ss_word(ss_state *st, uint32_t word)
{
    for (int i_dst = 0; i_dst < SS_POOL; i_dst++)
        st->pool[i_dst] = ss_mix(st->pool[i_dst], ss_hashmix(word, &st->hash_const));
}

/* A spawn-key element: its uint32 words, little-endian (0 is one word 0). */
static inline void
ss_key(ss_state *st, uint64_t k)
{
    do {
        ss_word(st, (uint32_t)k);
        k >>= 32;
    } while (k);
}

/* generate_state(n64, uint64): 2 * n64 uint32 words, cycling over the pool, read
 * as little-endian pairs. */
static void
ss_generate64(const ss_state *st, int n64, uint64_t *out)
{
    uint32_t hc = SS_INIT_B;
    for (int i = 0; i < n64; i++) {
        uint64_t v = 0;
        for (int h = 0; h < 2; h++) {
            uint32_t d = st->pool[(2 * i + h) % SS_POOL];
            d ^= hc;
            hc *= SS_MULT_B;
            d *= hc;
            d ^= d >> SS_XSHIFT;
            v |= (uint64_t)d << (32 * h);
        }
        out[i] = v;
    }
}

/* PCG64 (pcg_setseq_128 with the XSL-RR 128/64 output). With unsigned __int128
 * (GCC, Clang) the state is one; otherwise two 64-bit halves with the 64 x 64
 * -> 128 product from 32-bit halves (MICROIMPACT_NO_INT128 forces this path;
 * both give the same bits). */
#define PCG_MULT_HI 2549297995355413924ULL
#define PCG_MULT_LO 4865540595714422341ULL
#if defined(__SIZEOF_INT128__) && !defined(MICROIMPACT_NO_INT128)
#define PCG_INT128 1
typedef unsigned __int128 u128;
typedef struct {
    u128 state, inc;
} pcg64_t;

static inline void
pcg_step(pcg64_t *g)
{
    g->state = g->state * (((u128)PCG_MULT_HI << 64) | PCG_MULT_LO) + g->inc;
}

static inline uint64_t
pcg_hi(const pcg64_t *g)
{
    return (uint64_t)(g->state >> 64);
}

static inline uint64_t
pcg_lo(const pcg64_t *g)
{
    return (uint64_t)g->state;
}

static void
pcg_seed(pcg64_t *g, const uint64_t v[4])
{
    u128 initstate = ((u128)v[0] << 64) | v[1];
    u128 initseq = ((u128)v[2] << 64) | v[3];
    g->state = 0;
    g->inc = (initseq << 1) | 1u;
    pcg_step(g);
    g->state += initstate;
    pcg_step(g);
}
#else
#define PCG_INT128 0
typedef struct {
    uint64_t s_hi, s_lo, i_hi, i_lo;
} pcg64_t;

/* the full 128-bit product of two 64-bit words */
static inline void
mul_64x64(uint64_t a, uint64_t b, uint64_t *hi, uint64_t *lo)
{
    const uint64_t m = 0xFFFFFFFFu;
    uint64_t a_lo = a & m, a_hi = a >> 32, b_lo = b & m, b_hi = b >> 32;
    uint64_t ll = a_lo * b_lo, hl = a_hi * b_lo, lh = a_lo * b_hi, hh = a_hi * b_hi;
    uint64_t cross = (ll >> 32) + (hl & m) + lh;
    *hi = (hl >> 32) + (cross >> 32) + hh;
    *lo = (cross << 32) | (ll & m);
}

static inline void
pcg_step(pcg64_t *g)
{
    uint64_t hi, lo;
    mul_64x64(g->s_lo, PCG_MULT_LO, &hi, &lo);
    hi += g->s_hi * PCG_MULT_LO + g->s_lo * PCG_MULT_HI;
    uint64_t nlo = lo + g->i_lo;
    hi += g->i_hi + (nlo < lo);
    g->s_hi = hi;
    g->s_lo = nlo;
}

static inline uint64_t
pcg_hi(const pcg64_t *g)
{
    return g->s_hi;
}

static inline uint64_t
pcg_lo(const pcg64_t *g)
{
    return g->s_lo;
}

static void
pcg_seed(pcg64_t *g, const uint64_t v[4])
{
    g->s_hi = 0;
    g->s_lo = 0;
    g->i_hi = (v[2] << 1) | (v[3] >> 63);
    g->i_lo = (v[3] << 1) | 1u;
    pcg_step(g);
    uint64_t lo = g->s_lo + v[1];
    g->s_hi += v[0] + (lo < g->s_lo);
    g->s_lo = lo;
    pcg_step(g);
}
#endif

/* random_raw: step, then the output of the new state */
static inline uint64_t
pcg_next(pcg64_t *g)
{
    pcg_step(g);
    uint64_t hi = pcg_hi(g);
    uint64_t x = hi ^ pcg_lo(g);
    unsigned rot = (unsigned)(hi >> 58);
    return (x >> rot) | (x << ((-rot) & 63));
}

static inline void
pcg_fill(pcg64_t *g, uint64_t *out, Py_ssize_t n)
{
    for (Py_ssize_t i = 0; i < n; i++)
        out[i] = pcg_next(g);
}

/* The generator of SeedSequence(entropy, spawn_key=key[0:nk]), `prefix` being
 * the pool after the entropy (ss_prefix). */
static void
stream_seed(const ss_state *prefix, const uint64_t *key, int nk, pcg64_t *g)
{
    ss_state st = *prefix;
    uint64_t v[4];
    for (int i = 0; i < nk; i++)
        ss_key(&st, key[i]);
    ss_generate64(&st, 4, v);
    pcg_seed(g, v);
}

typedef struct {
    const uint64_t *i_d, *i_a, *i_s, *i_p;
    Py_ssize_t n;
    int angle_random, speed_random;
    sampler_t d, a, s, b; /* diameter: 1/k1, 1/k2, v_c; angle: sin, cos, tan
                             phi; speed factor; particle angle atoms (pairs) */
    uint64_t cut;      /* angle draws scaled to [0, cut) ("reject"); 0: not */
    uint64_t pair_total; /* pairs (surface atom, particle atom) drawn from */
    int pair_shift;      /* > 0: pair tables (plan.PairSampler); -1: a pair
                            search (plan.PairSearch) */
    double sin_theta, cos_theta;
    double speed, p, q, friction;
    int shadow_none;
    hist_t hist;
    int64_t *e_hist, *mu_hist, *lat_hist;
    int areal;         /* an areal surface (plan.ArealSampler rows) */
    counts_t counts;
    double sums[12];   /* e_m, mu_m, then psi_f (areal surfaces; else zeros) */
    /* per-impact outputs (NULL: none): e_m and mu_m (0.0 where not a rebound),
     * the lateral angle psi (areal surfaces; else 0.0), the outcome code */
    double *st_em, *st_mum, *st_psi;
    int8_t *st_code;
    int keyed;         /* draw from gen[] (the keyed streams), not i_d, ... i_p */
    pcg64_t gen[4];    /* diameter, angle, speed, pair proposal streams */
    /* quasi-Monte Carlo (keyed): the scrambled Sobol' sequence of the block's
     * (point, replicate) instead of gen[]; see sobol_fill */
    int qmc, qbits, qd, qdim[4]; /* qdim: the Sobol' dimension of each variable
                                    (-1: not drawn); qd dimensions */
    const uint32_t *qsv;     /* scrambled direction numbers, [dim][bit] */
    uint32_t qx[4];          /* the current point's integer coordinates */
    uint64_t qk;             /* its index in the sequence */
} block_args;

/* The next c points of the Sobol' sequence, scipy.stats.qmc.Sobol's (Gray-code
 * order: point k + 1 is point k XOR the direction numbers of the lowest zero bit
 * of k), each coordinate x as the uint64 draw x 2^(64 - bits), which is what
 * _tables.fraction_to_integer makes of SciPy's x 2^-bits (exactly). */
static void
sobol_fill(block_args *a, uint64_t (*draw)[CHUNK], int c, int nv)
{
    const int sh = 64 - a->qbits;
    for (int k = 0; k < c; k++) {
        for (int v = 0; v < nv; v++)
            if (a->qdim[v] >= 0)
                draw[v][k] = (uint64_t)a->qx[a->qdim[v]] << sh;
        int l = __builtin_ctzll(~a->qk);
        if (l < a->qbits) /* (the point after the last one is never used) */
            for (int q = 0; q < a->qd; q++)
                a->qx[q] ^= a->qsv[q * a->qbits + l];
        a->qk++;
    }
}

/* Locate the cells of draws r[0:c] (kinds: see guide_entry) and write the first
 * `one ? 1 : 3` interpolated columns of their rows to out0..out2; `g` receives
 * the cells. Past c the outputs are left as they were (finite: the physics loop
 * recomputes stale values there and counts nothing). */
ALWAYS_INLINE void
fetch(const sampler_t *s, const uint64_t *restrict r, int one, int c,
      uint32_t *restrict g, double *restrict out0, double *restrict out1,
      double *restrict out2)
{
    if (s->kind == 1) {
        for (int k = 0; k < c; k++)
            g[k] = (uint32_t)mulhi64(r[k], (uint64_t)s->n);
    } else if (s->kind == 2) {
        for (int k = 0; k < c; k++)
            g[k] = guide_entry(s, r[k]);
    } else {
        for (int k = 0; k < c; k++)
            g[k] = s->guide[r[k] >> s->gshift];
    }
    if (s->kind == 1) { /* atoms: nothing to interpolate (nor does NumPy) */
        for (int k = 0; k < c; k++) {
            const double *row = s->rows + (Py_ssize_t)g[k] * s->stride;
            out0[k] = row[2];
            if (!one) {
                out1[k] = row[4];
                out2[k] = row[6];
            }
        }
        return;
    }
    if (s->kind == 2) { /* the cell is known: no search (a gather loop) */
        const double *restrict rows = s->rows;
        const Py_ssize_t stride = s->stride;
        for (int k = 0; k < c; k++) {
            const double *row = rows + (Py_ssize_t)g[k] * stride;
            uint64_t start;
            memcpy(&start, row, sizeof start);
            double f = (double)(r[k] - start) * row[1];
            out0[k] = row[2] + f * row[3];
            if (!one) {
                out1[k] = row[4] + f * row[5];
                out2[k] = row[6] + f * row[7];
            }
        }
        return;
    }
    for (int k = 0; k < c; k++) {
        double f;
        Py_ssize_t i = locate(s, r[k], g[k], &f);
        const double *row = s->rows + i * s->stride;
        g[k] = (uint32_t)i; /* the cell, for pairs */
        out0[k] = row[2] + f * row[3];
        if (!one) {
            out1[k] = row[4] + f * row[5];
            out2[k] = row[6] + f * row[7];
        }
    }
}


/* The cells of an areal surface's draws r[0:c] (atoms, or a guide table for
 * "weighted": plan.ArealSampler) and their rows' sin, cos, tan phi_par, sin chi,
 * cos chi, read as the NumPy kernel reads them (lo for atoms, else lo + f span). */
ALWAYS_INLINE void
fetch_areal(const sampler_t *s, const uint64_t *restrict r, int c,
            uint32_t *restrict g, double *restrict ws)
{
    static const int col[5] = {2, 4, 6, 8, 10};
    static const int dst[5] = {W_SP, W_CP, W_TAN, W_SX, W_CX};
    if (s->kind == 1 && s->crows != NULL && s->cstride >= 8 && s->cpos[0] == 0 &&
        s->cpos[1] == 1 && s->cpos[2] == 2) {
        /* compact rows of an areal table (kernel._compact_rows): the five
         * columns' lo, one 64-byte row per pair (the table fits in L2) */
        const double *restrict cr = s->crows;
        const Py_ssize_t cs = s->cstride;
        for (int k = 0; k < c; k++)
            g[k] = (uint32_t)mulhi64(r[k], (uint64_t)s->n);
        for (int k = 0; k < c; k++) {
            const double *row = cr + (Py_ssize_t)g[k] * cs;
            for (int q = 0; q < 5; q++)
                ws[dst[q] * CHUNK + k] = row[q];
        }
        return;
    }
    for (int k = 0; k < c; k++) {
        Py_ssize_t i;
        double f = 0.0;
        if (s->kind == 1)
            i = (Py_ssize_t)mulhi64(r[k], (uint64_t)s->n);
        else
            i = locate(s, r[k], guide_entry(s, r[k]), &f);
        const double *row = s->rows + i * s->stride;
        g[k] = (uint32_t)i;
        if (s->kind == 1) {
            for (int q = 0; q < 5; q++)
                ws[dst[q] * CHUNK + k] = row[col[q]];
        } else {
            for (int q = 0; q < 5; q++)
                ws[dst[q] * CHUNK + k] = row[col[q]] + f * row[col[q] + 1];
        }
    }
}

/* ------------------------------------------------ AVX-512 lookups (same bits) */
/* The arithmetic kinds (refined grid, equal atoms) 8 draws at a time: the cell
 * from vplzcntq and shifts (or an exact 64-bit multiply-high from 32-bit
 * products), the row's quantities by gathers, the interpolation by the same IEEE
 * operations as fetch() (u64 -> double conversion rounded to nearest, then
 * multiply, then add: no fused multiply-add), so the bits are those of the
 * scalar loops. Only compiled where GCC can target AVX-512 and only called where
 * the CPU has AVX-512F/DQ/CD (have_avx512). */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(MICROIMPACT_NO_AVX512)
#define HAVE_AVX512_PATH 1
#include <immintrin.h>
#define AVX512_FN \
    static __attribute__((target("avx512f,avx512dq,avx512cd,avx512vl"), noinline))

static int have_avx512 = 0;

/* floor(a * b / 2^64) per lane, exactly (the 32-bit halves of _tables.mulhi64) */
static inline __attribute__((target("avx512f,avx512dq,avx512cd,avx512vl"), always_inline))
__m512i
mulhi64_x8(__m512i a, uint64_t b)
{
    const __m512i m = _mm512_set1_epi64(0xFFFFFFFF);
    const __m512i b_lo = _mm512_set1_epi64((long long)(b & 0xFFFFFFFFu));
    const __m512i b_hi = _mm512_set1_epi64((long long)(b >> 32));
    __m512i a_hi = _mm512_srli_epi64(a, 32);
    __m512i ll = _mm512_mul_epu32(a, b_lo);
    __m512i hl = _mm512_mul_epu32(a_hi, b_lo);
    __m512i lh = _mm512_mul_epu32(a, b_hi);
    __m512i hh = _mm512_mul_epu32(a_hi, b_hi);
    __m512i cross = _mm512_add_epi64(
        _mm512_add_epi64(_mm512_srli_epi64(ll, 32), _mm512_and_si512(hl, m)), lh);
    return _mm512_add_epi64(
        _mm512_add_epi64(_mm512_srli_epi64(hl, 32), _mm512_srli_epi64(cross, 32)), hh);
}

/* fetch() for kinds 1 and 2 (and the "reject" scaling r -> mulhi64(r, cut) when
 * cut > 0), reading the compact rows (s->crows): per cell only the columns that
 * vary, (lo, span) for the refined grid and lo for atoms. The refined grid's
 * cells are aligned to their widths, which are powers of two 2^w (w from the
 * level, see guide_entry), so r - start is the low w bits of r and 1/width is
 * 2^-w: the fraction has the bits of fetch()'s (r - start) * inv_width without
 * reading either from the row. Constant columns are written as their value. */
AVX512_FN void
fetch_avx512(const sampler_t *s, const uint64_t *restrict r, int one, int c,
             uint64_t cut, double *restrict out0, double *restrict out1,
             double *restrict out2)
{
    const int ncol = one ? 1 : 3;
    double *outs[3] = {out0, out1, out2};
    const double *crows = s->crows;
    const __m512i cstride = _mm512_set1_epi64(s->cstride);
    const int kind = s->kind;
    const __m512i one_i = _mm512_set1_epi64(1);
    const __m512i lv1 = _mm512_set1_epi64(s->levels - 1);
    const __m512i last = _mm512_set1_epi64(s->n - 1);
    const __m512i c62 = _mm512_set1_epi64(62 - s->cbits);
    const __m512i w_deep = _mm512_set1_epi64(63 - s->levels);
    const __m512i bias = _mm512_set1_epi64(1023);
    const __m512i cmask = _mm512_set1_epi64(((int64_t)1 << s->cbits) - 1);
    const __m128i cb = _mm_cvtsi32_si128(s->cbits);
    const __m128i deep_sh = _mm_cvtsi32_si128(63 - s->levels);
    const __m512i zero = _mm512_setzero_si512();
    const __m512d zero_d = _mm512_setzero_pd();
    /* two passes over the chunk: the cells (and fractions) of every draw, with a
     * prefetch of each row, then the gathers, which then find their rows in
     * cache (gathers issued right after their index wait on the memory one
     * group at a time) */
    int64_t offs[CHUNK] __attribute__((aligned(64)));
    double fr[CHUNK] __attribute__((aligned(64)));
    for (int k = 0; k < c; k += 8) {
        __mmask8 lane = c - k >= 8 ? 0xFF : (__mmask8)((1u << (c - k)) - 1);
        __m512i rv = _mm512_maskz_loadu_epi64(lane, r + k);
        if (cut)
            rv = mulhi64_x8(rv, cut);
        __m512i idx;
        if (kind == 1) {
            idx = mulhi64_x8(rv, (uint64_t)s->n);
        } else {
            /* the cell: as guide_entry() computes it */
            __m512i upm = _mm512_srai_epi64(rv, 63);
            __mmask8 up = _mm512_movepi64_mask(rv);
            __m512i R = _mm512_xor_si512(rv, upm);
            __m512i kk = _mm512_sub_epi64(
                _mm512_lzcnt_epi64(_mm512_or_si512(R, one_i)), one_i);
            kk = _mm512_min_epi64(kk, lv1);
            __mmask8 deep =
                _mm512_cmpeq_epi64_mask(_mm512_srl_epi64(R, deep_sh), zero);
            __m512i w = _mm512_sub_epi64(c62, kk); /* log2 of the cell's width */
            __m512i j = _mm512_and_si512(_mm512_srlv_epi64(R, w), cmask);
            __m512i L = _mm512_add_epi64(
                _mm512_add_epi64(one_i, _mm512_sll_epi64(_mm512_sub_epi64(lv1, kk), cb)),
                j);
            L = _mm512_maskz_mov_epi64((__mmask8)~deep, L);
            idx = _mm512_mask_sub_epi64(L, up, last, L);
            w = _mm512_mask_mov_epi64(w, deep, w_deep); /* the outermost cells */
            /* f = (r mod 2^w) * 2^-w, both factors exact */
            __m512i low = _mm512_and_si512(
                rv, _mm512_sub_epi64(_mm512_sllv_epi64(one_i, w), one_i));
            __m512d scale =
                _mm512_castsi512_pd(_mm512_slli_epi64(_mm512_sub_epi64(bias, w), 52));
            _mm512_store_pd(fr + k, _mm512_mul_pd(_mm512_cvtepu64_pd(low), scale));
        }
        /* masked-off lanes hold row 0 (in range) */
        idx = _mm512_maskz_mov_epi64(lane, idx);
        _mm512_store_si512((void *)(offs + k), _mm512_mullo_epi64(idx, cstride));
        for (int q = 0; q < 8; q++)
            _mm_prefetch((const char *)(crows + offs[k + q]), _MM_HINT_T0);
    }
    for (int k = 0; k < c; k += 8) {
        __mmask8 lane = c - k >= 8 ? 0xFF : (__mmask8)((1u << (c - k)) - 1);
        __m512i off = _mm512_load_si512((const void *)(offs + k));
        if (kind == 1) {
            for (int q = 0; q < ncol; q++) {
                __m512d v = s->cpos[q] < 0
                    ? _mm512_set1_pd(s->cval[q])
                    : _mm512_mask_i64gather_pd(zero_d, lane, off, crows + s->cpos[q], 8);
                _mm512_mask_storeu_pd(outs[q] + k, lane, v);
            }
            continue;
        }
        __m512d f = _mm512_load_pd(fr + k);
        for (int q = 0; q < ncol; q++) {
            __m512d v;
            if (s->cpos[q] < 0) {
                v = _mm512_set1_pd(s->cval[q]);
            } else {
                const double *col = crows + s->cpos[q];
                __m512d lo = _mm512_mask_i64gather_pd(zero_d, lane, off, col, 8);
                __m512d sp = _mm512_mask_i64gather_pd(zero_d, lane, off, col + 1, 8);
                v = _mm512_add_pd(lo, _mm512_mul_pd(f, sp));
            }
            _mm512_mask_storeu_pd(outs[q] + k, lane, v);
        }
    }
}
#endif

/* One variable's lookups for a chunk: the AVX-512 loop where the CPU has it and
 * the kind is arithmetic, else the scalar fetch() (after the "reject" scaling
 * r -> mulhi64(r, cut) into `tmp` when cut > 0). */
ALWAYS_INLINE void
lookup(const sampler_t *s, const uint64_t *r, int one, int c, uint64_t cut,
       uint64_t *restrict tmp, uint32_t *restrict g, double *restrict out0,
       double *restrict out1, double *restrict out2)
{
#ifdef HAVE_AVX512_PATH
    if (have_avx512 && s->kind != 0 && s->crows != NULL) {
        fetch_avx512(s, r, one, c, cut, out0, out1, out2);
        return;
    }
#endif
    if (cut) {
        for (int k = 0; k < c; k++)
            tmp[k] = mulhi64(r[k], cut);
        r = tmp;
    }
    fetch(s, r, one, c, g, out0, out1, out2);
}

/* Column layout of a pair search (plan.PairSearch): surface rows hold alpha,
 * beta, the rejection's bound lam_i, the end n_i of the particle atoms drawn
 * from, their weight C_i(n_i) - C_i(m_i) and their first atom m_i after the
 * angle columns, then the K + 1 ends of the proposal's bands (uint64 bits;
 * K = stride - Q_BANDS - 1, a power of two); particle rows hold the prefix sums
 * P1, P2 of the atoms before them. */
enum { Q_ALPHA = 8, Q_BETA, Q_BOUND, Q_COUNT, Q_TOTAL, Q_FIRST, Q_BANDS };
enum { P_ONE = 8, P_TWO };
/* Column of a pair-rank surface row (plan.PairSampler): the first particle atom
 * m_i of the surface atom's pairs. */
enum { PAIR_FIRST = 8 };

/* sin, cos (theta - a - b) and tan(a + b) of impact k from sin, cos, tan of its
 * surface atom a and the row of its particle atom b (pair ranks and searches). */
ALWAYS_INLINE void
pair_angles(double *restrict ws, int k, double st, double ct, double sa, double ca,
            double ta, const double *rb)
{
    double s1 = st * ca - ct * sa; /* sin(theta - a) */
    double c1 = ct * ca + st * sa;
    ws[W_SIN * CHUNK + k] = s1 * rb[4] - c1 * rb[2];
    ws[W_COT * CHUNK + k] = c1 * rb[4] + s1 * rb[2];
    ws[W_TAN * CHUNK + k] = (ta + rb[6]) / (1.0 - ta * rb[6]);
}

/* The cell of draw r (no fraction). */
ALWAYS_INLINE Py_ssize_t
cell_of(const sampler_t *s, uint64_t r)
{
    double f;
    return locate(s, r, guide_entry(s, r), &f);
}

/* A pair drawn by rejection with a search as the fallback (plan.search_pairs,
 * step for step; the argument is plan.PairSearch's): the surface cell i and
 * the fraction f of each draw r; the band k of the particle's proposal (the top
 * bits of r2) and the proposed atom j, the particle cell of
 * y_k + floor(z w_k / 2^64) (z: the other bits of r2), accepted when
 * f lam_i < g_ij w_k, g_ij = alpha_i cos b_j + beta_i sin b_j (g at or below 0
 * counts as 0; lam_i = 0 for the masses: every proposal is accepted). The
 * rejected proposals are packed, and for each the largest J in [m_i, n_i) with
 * C_i(J) = alpha_i P1[J] + beta_i P2[J] <= C_i(m_i) + u' (C_i(n_i) - C_i(m_i)),
 * u' = (f lam_i - g w) / (lam_i - g w), is found by steps of decreasing powers
 * of two from m_i, one step for all of them at a time (their searches
 * overlap); sin, cos (theta - a - b) and tan(a + b) as for pair ranks. */
ALWAYS_INLINE void
pair_search(const block_args *a, scratch_t *s, const uint64_t *restrict r,
            const uint64_t *restrict r2, int c)
{
    const sampler_t *A = &a->a, *B = &a->b;
    double *restrict ws = s->ws;
    int64_t *restrict jj = s->pj;
    int32_t *restrict at = s->pat;
    double *restrict num = s->pnum, *restrict den = s->pden;
    double *restrict u = s->pu, *restrict al = s->pal, *restrict be = s->pbe;
    int64_t *restrict nn = s->pn, *restrict base = s->pb;
    uint32_t *restrict cell = s->g[1];
    const double st = a->sin_theta, ct = a->cos_theta;
    const int64_t nb = B->n;
    const double *restrict prow = B->rows;
    const Py_ssize_t pstride = B->stride;
    int bits = 1; /* log2 of the bands (a power of two >= 2: check_pairs) */
    while (((Py_ssize_t)1 << bits) < A->stride - Q_BANDS - 1)
        bits++;
    uint32_t *restrict gs = s->pg;
    double *restrict ff = s->pf, *restrict gw = s->pgw;
    /* three passes, so that each one's loads are issued for the whole chunk
     * before they are waited on: the surface cells' guide entries, the cells,
     * fractions and proposals, then the acceptance */
    for (int k = 0; k < c; k++)
        gs[k] = A->guide[r[k] >> A->gshift];
    for (int k = 0; k < c; k++) {
        double f;
        Py_ssize_t i = locate(A, r[k], gs[k], &f);
        const double *row = A->rows + i * A->stride;
        const double *band = row + Q_BANDS + (Py_ssize_t)(r2[k] >> (64 - bits));
        uint64_t y0, y1;
        memcpy(&y0, band, sizeof y0);
        memcpy(&y1, band + 1, sizeof y1);
        uint64_t w = y1 - y0; /* modulo 2^64 */
        uint64_t x = y0 + mulhi64(r2[k] << bits, w);
        Py_ssize_t j = cell_of(B, x);
        /* below n_i for any plan's tables; the clamp keeps a malformed call
         * inside the buffer */
        j = j < nb ? j : nb - 1;
        cell[k] = (uint32_t)i;
        ff[k] = f;
        gw[k] = (double)w;
        jj[k] = j;
    }
    int m = 0; /* rejected proposals so far */
    for (int k = 0; k < c; k++) {
        const double *row = A->rows + (Py_ssize_t)cell[k] * A->stride;
        const double *pr = prow + jj[k] * pstride;
        double f = ff[k];
        double alpha = row[Q_ALPHA], beta = row[Q_BETA], lam = row[Q_BOUND];
        double g = alpha * pr[4] + beta * pr[2];
        g = g > 0.0 ? g : 0.0;
        double gwk = g * gw[k];
        double t = f * lam;
        /* the proposal's angles (kept if accepted) */
        pair_angles(ws, k, st, ct, row[2], row[4], row[6], pr);
        /* written for every impact, kept (m advanced) for the rejected */
        at[m] = k;
        num[m] = t - gwk;
        den[m] = lam - gwk;
        al[m] = alpha;
        be[m] = beta;
        m += !(t < gwk);
    }
    for (int q = 0; q < m; q++) {
        const double *row = A->rows + (Py_ssize_t)cell[at[q]] * A->stride;
        double cnt = row[Q_COUNT], first = row[Q_FIRST];
        /* in [1, nb] and [0, n_i) for any plan's tables; the clamps keep a
         * malformed call inside the buffer */
        nn[q] = cnt >= 1.0 ? (cnt <= (double)nb ? (int64_t)cnt : nb) : 1;
        base[q] = first >= 0.0 ? (first < (double)nn[q] ? (int64_t)first : 0) : 0;
        const double *pm = prow + base[q] * pstride;
        double c0 = al[q] * pm[P_ONE] + be[q] * pm[P_TWO]; /* C_i(m_i) */
        double fresh = num[q] / den[q]; /* u', uniform on [0, 1) */
        u[q] = c0 + fresh * row[Q_TOTAL];
    }
    int64_t step = 0;
    if (nb > 1 && m > 0) {
        step = 1;
        while (step <= (nb - 1) / 2)
            step *= 2;
    }
    for (; step > 0; step >>= 1) {
        for (int q = 0; q < m; q++) {
            /* branch-free (whether a candidate is in range is not predictable):
             * row 0 stands in for a candidate out of range */
            int64_t cand = base[q] + step;
            int64_t ok = cand < nn[q];
            const double *pr = prow + (cand * ok) * pstride;
            double cm = al[q] * pr[P_ONE] + be[q] * pr[P_TWO];
            base[q] += step * (ok & (int64_t)(cm <= u[q]));
        }
    }
    for (int q = 0; q < m; q++) {
        int k = at[q];
        const double *ra = A->rows + (Py_ssize_t)cell[k] * A->stride;
        pair_angles(ws, k, st, ct, ra[2], ra[4], ra[6], prow + base[q] * pstride);
    }
}

/* The caller has checked every index (see draws_in_range). */
static CLONES __attribute__((noinline)) void
run_block(block_args *a, scratch_t *s)
{
    double *restrict ws = s->ws;
    int64_t *restrict iws = s->iws;
    const int pq_one = a->p == 1.0 && a->q == 1.0;
    const double st = a->sin_theta, ct = a->cos_theta;
    counts_t cnt = {0, 0, 0, 0, 0};
    double ke = 0.0, km = 0.0, kl = 0.0;
    double se1 = 0.0, se2 = 0.0, se3 = 0.0, sm1 = 0.0, sm2 = 0.0, sm3 = 0.0;
    double sl1 = 0.0, sl2 = 0.0, sl3 = 0.0;
    const int areal = a->angle_random && a->areal && a->pair_shift == 0;
    if (!a->angle_random) { /* smooth: phi = 0 exactly, the same in every chunk */
        for (int k = 0; k < CHUNK; k++) {
            ws[W_SIN * CHUNK + k] = st * 1.0 - ct * 0.0;
            ws[W_COT * CHUNK + k] = ct * 1.0 + st * 0.0;
            ws[W_TAN * CHUNK + k] = 0.0;
        }
    }
    for (Py_ssize_t start = 0; start < a->n; start += CHUNK) {
        int c = (int)(a->n - start < CHUNK ? a->n - start : CHUNK);
        const uint64_t *i_d, *i_a, *i_s, *i_p;
        if (a->keyed && a->qmc) { /* this chunk of the Sobol' points */
            sobol_fill(a, s->draw, c, 4);
            i_d = s->draw[0];
            i_a = s->draw[1];
            i_s = s->draw[2];
            i_p = s->draw[3];
        } else if (a->keyed) { /* this chunk of each stream, in impact order */
            pcg_fill(&a->gen[0], s->draw[0], c);
            if (a->angle_random)
                pcg_fill(&a->gen[1], s->draw[1], c);
            if (a->speed_random)
                pcg_fill(&a->gen[2], s->draw[2], c);
            if (a->angle_random && a->pair_shift < 0)
                pcg_fill(&a->gen[3], s->draw[3], c);
            i_d = s->draw[0];
            i_a = s->draw[1];
            i_s = s->draw[2];
            i_p = s->draw[3];
        } else {
            i_d = a->i_d + start;
            i_a = a->i_a + start;
            i_s = a->i_s + start;
            i_p = a->i_p + start;
        }
        /* 1. locate the drawn cells and interpolate their quantities, one
         * variable at a time (a loop specialised for each kind of table) */
        lookup(&a->d, i_d, 0, c, 0, s->ra, s->g[0], ws + W_IK1 * CHUNK,
               ws + W_IK2 * CHUNK, ws + W_VC * CHUNK);
        if (a->angle_random && a->pair_shift < 0) {
            pair_search(a, s, i_a, i_p, c);
        } else if (a->angle_random && a->pair_shift) {
            /* a pair: its rank k among the pairs, placed in the top bits, gives
             * the surface cell i (a table with a start per surface atom) and the
             * particle atom j = m_i + rank - start(i) (its pairs are the range
             * [m_i, n_i) of the particle atoms) */
            const uint64_t *ra = i_a;
            for (int k = 0; k < c; k++)
                s->ra[k] = mulhi64(ra[k], a->pair_total) << a->pair_shift;
            fetch(&a->a, s->ra, 0, c, s->g[1], ws + W_SIN * CHUNK, ws + W_COT * CHUNK,
                  ws + W_TAN * CHUNK);
            for (int k = 0; k < c; k++) {
                uint64_t j = (s->ra[k] - cell_start(&a->a, s->g[1][k])) >>
                             a->pair_shift;
                double first =
                    a->a.rows[(Py_ssize_t)s->g[1][k] * a->a.stride + PAIR_FIRST];
                /* m_i and j below b.n for any plan's tables; the clamps keep a
                 * malformed call inside the buffer */
                j += first >= 0.0 && first < (double)a->b.n ? (uint64_t)first : 0;
                j = j < (uint64_t)a->b.n ? j : (uint64_t)a->b.n - 1;
                pair_angles(ws, k, st, ct, ws[W_SIN * CHUNK + k],
                            ws[W_COT * CHUNK + k], ws[W_TAN * CHUNK + k],
                            a->b.rows + (Py_ssize_t)j * a->b.stride);
            }
        } else if (areal) {
            const uint64_t *ra = i_a;
            if (a->cut) { /* "reject": the reachable pairs are a prefix */
                for (int k = 0; k < c; k++)
                    s->ra[k] = mulhi64(ra[k], a->cut);
                ra = s->ra;
            }
            fetch_areal(&a->a, ra, c, s->g[1], ws);
            for (int k = 0; k < CHUNK; k++) {
                double sp = ws[W_SP * CHUNK + k], cp = ws[W_CP * CHUNK + k];
                ws[W_SIN * CHUNK + k] = st * cp - ct * sp; /* sin(theta - phi) */
                ws[W_COT * CHUNK + k] = ct * cp + st * sp; /* cos(theta - phi) */
            }
        } else if (a->angle_random) {
            lookup(&a->a, i_a, 0, c, a->cut, s->ra, s->g[1],
                   ws + W_SIN * CHUNK, ws + W_COT * CHUNK, ws + W_TAN * CHUNK);
            for (int k = 0; k < CHUNK; k++) {
                double sp = ws[W_SIN * CHUNK + k], cp = ws[W_COT * CHUNK + k];
                ws[W_SIN * CHUNK + k] = st * cp - ct * sp; /* sin(theta - phi) */
                ws[W_COT * CHUNK + k] = ct * cp + st * sp; /* cos(theta - phi) */
            }
        }
        if (a->speed_random) {
            lookup(&a->s, i_s, 1, c, 0, s->ra, s->g[2], ws + W_U * CHUNK,
                   NULL, NULL);
            for (int k = 0; k < CHUNK; k++) {
                double spd = a->speed * ws[W_U * CHUNK + k];
                ws[W_U * CHUNK + k] = spd * ws[W_SIN * CHUNK + k];
            }
        } else {
            for (int k = 0; k < CHUNK; k++)
                ws[W_U * CHUNK + k] = a->speed * ws[W_SIN * CHUNK + k];
        }
        if (areal) /* |u . n'| = cos(chi) |v_n_phi| */
            for (int k = 0; k < CHUNK; k++)
                ws[W_U * CHUNK + k] = ws[W_U * CHUNK + k] * ws[W_CX * CHUNK + k];
        /* 2. the physics, branch-free (the shifted powers too once the shift is
         * known, i.e. after the block's first rebound) */
        int known = cnt.reb > 0;
#define PHYSICS(P, Q, GENERAL, POWERS, AREAL)                                     \
    physics(ws, iws, c, P, Q, a->friction, a->shadow_none, &a->hist, GENERAL, ke, \
            km, POWERS, &cnt, AREAL, kl)
        if (areal) {
            if (pq_one) {
                if (known)
                    PHYSICS(1.0, 1.0, 0, 1, 1);
                else
                    PHYSICS(1.0, 1.0, 0, 0, 1);
            } else {
                if (known)
                    PHYSICS(a->p, a->q, 1, 1, 1);
                else
                    PHYSICS(a->p, a->q, 1, 0, 1);
            }
        } else if (pq_one) {
            if (known)
                PHYSICS(1.0, 1.0, 0, 1, 0);
            else
                PHYSICS(1.0, 1.0, 0, 0, 0);
        } else {
            if (known)
                PHYSICS(a->p, a->q, 1, 1, 0);
            else
                PHYSICS(a->p, a->q, 1, 0, 0);
        }
#undef PHYSICS
        if (!known && cnt.reb > 0) { /* 3. this chunk holds the first rebound */
            for (int k = 0; k < c; k++) {
                if (iws[I_CODE * CHUNK + k]) {
                    ke = ws[W_EM * CHUNK + k];
                    km = ws[W_MUM * CHUNK + k];
                    kl = areal ? ws[W_LAT * CHUNK + k] : 0.0;
                    break;
                }
            }
            for (int k = 0; k < CHUNK; k++)
                shifted_powers(ws, k, ws[W_EM * CHUNK + k], ws[W_MUM * CHUNK + k],
                               iws[I_CODE * CHUNK + k] != 0, ke, km);
            if (areal)
                for (int k = 0; k < CHUNK; k++)
                    shifted_lateral(ws, k, ws[W_LAT * CHUNK + k],
                                    iws[I_CODE * CHUNK + k] != 0, kl);
        }
        if (a->st_em != NULL) { /* the per-impact outputs of this chunk */
            Py_ssize_t at = start;
            for (int k = 0; k < c; k++) {
                a->st_em[at + k] = ws[W_EM * CHUNK + k];
                a->st_mum[at + k] = ws[W_MUM * CHUNK + k];
                a->st_code[at + k] = (int8_t)iws[I_OUT * CHUNK + k];
                a->st_psi[at + k] = areal && iws[I_CODE * CHUNK + k]
                    ? atan2_deg(ws[W_LY * CHUNK + k] + 0.0, ws[W_LX * CHUNK + k])
                    : 0.0;
            }
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
        if (areal)
            for (int k = 0; k < c; k++) {
                a->lat_hist[iws[I_BL * CHUNK + k]] += 1;
                sl1 += ws[W_L1 * CHUNK + k];
                sl2 += ws[W_L2 * CHUNK + k];
                sl3 += ws[W_L3 * CHUNK + k];
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
    a->sums[8] = kl;
    a->sums[9] = sl1;
    a->sums[10] = sl2;
    a->sums[11] = sl3;
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

/* The histogram layout (10 float64: e_m then mu_m lower edge, inverse bin width,
 * bin count; then psi_f's and its upper edge, which is inclusive); slots 0 below
 * the range, 1..nb the bins, nb + 1 above, then SPILL. */
static int
parse_hist(Py_buffer *bh, hist_t *hs)
{
    if (check_len(bh, "hist", 8, 10))
        return -1;
    const double *h = (const double *)bh->buf;
    if (!(h[2] >= 1 && h[5] >= 1 && h[8] >= 1 && h[2] < 1e7 && h[5] < 1e7 &&
          h[8] < 1e7)) {
        PyErr_SetString(PyExc_ValueError, "_ckernel: bad hist layout");
        return -1;
    }
    hs->e_lo = h[0];
    hs->e_inv_w = h[1];
    hs->e_nb = h[2];
    hs->mu_lo = h[3];
    hs->mu_inv_w = h[4];
    hs->mu_nb = h[5];
    hs->e_top = (int64_t)h[2] + 1;
    hs->mu_top = (int64_t)h[5] + 1;
    hs->e_spill = hs->e_top + 1;
    hs->mu_spill = hs->mu_top + 1;
    hs->lat_lo = h[6];
    hs->lat_inv_w = h[7];
    hs->lat_nb = h[8];
    hs->lat_hi = h[9];
    hs->lat_top = (int64_t)h[8] + 1;
    hs->lat_spill = hs->lat_top + 1;
    /* the slot of psi_f = 0 (every rebound off an areal surface) */
    double t = (0.0 - h[6]) * h[7];
    hs->lat_zero = t >= 0.0 && t < h[8] ? (int64_t)t + 1 : 0;
    return 0;
}

/* Release the buffers of a parsed sampler (the compact rows are optional). */
static void
release_sampler(Py_buffer *bufs)
{
    for (int j = 0; j < 3; j++)
        if (j < 2 || bufs[j].obj != NULL)
            PyBuffer_Release(&bufs[j]);
}

/* Pairs: every rank < pair_total, shifted, must stay below 2^64, and every
 * particle atom index (m_i + rank - start, clamped) must have a row; the surface
 * table is searched through its guide (kind 0) and its rows hold m_i
 * (PAIR_FIRST). A pair search
 * (shift -1) needs the columns of its layout (P_TWO; Q_BANDS and a power of two
 * >= 2 of bands, at most 64) and a surface
 * table searched through its guide. */
static int
check_pairs(int shift, unsigned long long total, const sampler_t *surface,
            const sampler_t *particle)
{
    if (shift == -1) {
        Py_ssize_t bands = surface->stride - Q_BANDS - 1;
        if (surface->kind == 0 && bands >= 2 && bands <= 64 &&
            (bands & (bands - 1)) == 0 && particle->stride > P_TWO)
            return 0;
        PyErr_SetString(PyExc_ValueError, "_ckernel: bad pair search layout");
        return -1;
    }
    if (shift < 0 || shift > 63 ||
        (shift && (total < 1 || (((uint64_t)total - 1) >> (64 - shift)) ||
                   surface->kind != 0 || surface->stride <= PAIR_FIRST))) {
        PyErr_SetString(PyExc_ValueError, "_ckernel: bad pair layout");
        return -1;
    }
    return 0;
}

/* An areal surface: one angle (no pairs) and rows holding sin chi, cos chi
 * (plan.A_SINX, A_COSX), drawn as atoms or through a guide (kinds 1, 0). */
static int
check_areal(int shift, const sampler_t *surface)
{
    if (shift != 0 || surface->stride < 12 || surface->kind == 2) {
        PyErr_SetString(PyExc_ValueError, "_ckernel: bad areal layout");
        return -1;
    }
    return 0;
}

/* Parse one sampler tuple (rows, stride, guide, guide_shift, kind, levels,
 * log2 cells per level[, constant columns[, compact rows, compact stride]]);
 * `bufs` receives the 2 or 3 buffers to release. */
static int
parse_sampler(PyObject *tup, const char *name, sampler_t *s, Py_ssize_t min_stride,
              Py_buffer *bufs, int *held)
{
    s->constant = 0;
    s->crows = NULL;
    s->cstride = 0;
    bufs[2].buf = NULL;
    bufs[2].obj = NULL;
    if (!PyArg_ParseTuple(tup, "y*ny*iiii|iy*n", &bufs[0], &s->stride, &bufs[1],
                          &s->gshift, &s->kind, &s->levels, &s->cbits, &s->constant,
                          &bufs[2], &s->cstride))
        return -1;
    *held = 1;
    s->rows = bufs[0].buf;
    s->guide = bufs[1].buf;
    if (s->gshift < 1 || s->gshift > 63 || s->stride < min_stride) {
        PyErr_Format(PyExc_ValueError, "_ckernel.block: bad %s sampler", name);
        return -1;
    }
    s->n = bufs[0].len / 8 / s->stride - 1;
    Py_ssize_t guide_len = ((Py_ssize_t)1 << (64 - s->gshift)) + 1;
    if (s->n < 1) {
        PyErr_Format(PyExc_ValueError, "_ckernel.block: %s sampler has no cell",
                     name);
        return -1;
    }
    if (check_len(&bufs[0], name, 8, (s->n + 1) * s->stride) ||
        check_len(&bufs[1], name, 4, guide_len))
        return -1;
    /* constant columns (the caller's promise: the same lo bits and a +0.0 span in
     * every cell): their value is what fetch() computes, lo + f * 0.0 = lo + 0.0
     * for interpolated kinds, lo for atoms */
    s->constant &= 7;
    for (int q = 0; q < 3; q++) {
        s->cval[q] = 0.0;
        if (((s->constant >> q) & 1) && 3 + 2 * q < s->stride)
            s->cval[q] = s->kind == 1 ? s->rows[2 + 2 * q] : s->rows[2 + 2 * q] + 0.0;
        else
            s->constant &= ~(1 << q);
    }
    /* compact rows: per cell the non-constant columns in order, (lo, span) each
     * for the refined grid, lo for atoms (kernel._compact_rows) */
    if (bufs[2].buf != NULL) {
        Py_ssize_t pos = 0, avail = (s->stride - 2) / 2;
        for (int q = 0; q < 3; q++) {
            s->cpos[q] = -1;
            if (q < avail && !((s->constant >> q) & 1)) {
                s->cpos[q] = (int)pos;
                pos += s->kind == 1 ? 1 : 2;
            }
        }
        if (s->kind == 0 || s->cstride < pos || s->cstride < 1 ||
            check_len(&bufs[2], name, 8, s->n * s->cstride)) {
            PyErr_Clear();
            PyErr_Format(PyExc_ValueError, "_ckernel.block: bad %s compact rows",
                         name);
            return -1;
        }
        s->crows = bufs[2].buf;
    }
    /* the arithmetic kinds must describe exactly these n cells */
    if (s->n >= 0x7FFFFFFF || s->kind < 0 || s->kind > 2 ||
        (s->kind == 2 &&
         (s->levels < 1 || s->cbits < 0 || s->levels - 1 + s->cbits > 62 ||
          s->n != 2 * (((Py_ssize_t)s->levels << s->cbits) + 1)))) {
        PyErr_Format(PyExc_ValueError, "_ckernel.block: bad %s sampler kind", name);
        return -1;
    }
    return 0;
}

PyDoc_STRVAR(block_doc,
"block(i_d, i_a, i_s, i_p, n, angle_random, speed_random, dsamp, asamp, cut,\n"
"      psamp, pair_total, pair_shift, ssamp,\n"
"      sin_theta, cos_theta, speed, p, q, friction, shadow_none, hist,\n"
"      e_hist, mu_hist, areal, lat_hist) -> (counts, sums)\n\n"
"One block of `n` impacts from the uint64 draws i_d, i_a, i_s (and i_p, the\n"
"particle's proposals of a pair search). Each sampler is a\n"
"tuple (rows float64[(n+1)*stride], stride, guide uint32[2^g+1], 64-g, kind,\n"
"levels, log2 cells per level) of a\n"
"cell table (see plan.Sampler): each row starts with the cell start (uint64\n"
"bits) and 1/width; then diameter rows hold (lo, span) of 1/k1, 1/k2, v_c,\n"
"angle rows of sin, cos, tan phi, speed rows of the factor. Angle draws are scaled to [0, cut) when\n"
"cut > 0. pair_shift > 0: the angle is a (surface, particle) pair of rank\n"
"floor(r pair_total / 2^64) placed in the top bits (plan.PairSampler); -1: a\n"
"pair drawn by a search (plan.PairSearch); 0: one angle. `areal`: the angle\n"
"table is an areal surface's (plan.ArealSampler: sin, cos of chi after the angle\n"
"columns), and the folded lateral angle psi_f is histogrammed into lat_hist and\n"
"summed. `hist` holds 10 float64 values (e_m then mu_m then psi_f lower edge,\n"
"inverse bin width, bin count; then psi_f's inclusive upper edge); the int64\n"
"histogram arrays are added to (their last 8 slots are spill). Returns counts\n"
"(shadowed, captured, reimpact, rolling, rebounds) and sums (K, S1, S2, S3 of\n"
"e_m, then of mu_m, then of psi_f (zeros unless areal); S_r = sum over rebounds\n"
"of (x - K)^r).");

static PyObject *
ck_block(PyObject *self, PyObject *args)
{
    Py_buffer bd, ba, bs, bq, bh, beh, bmh, blh;
    Py_buffer sb[4][3];
    int held[4] = {0, 0, 0, 0};
    PyObject *samp[4];
    int angle_random, speed_random, shadow_none;
    unsigned long long cut;
    Py_ssize_t n;
    block_args a;
    unsigned long long pair_total;
    if (!PyArg_ParseTuple(args, "y*y*y*y*nppOOKOKiOddddddpy*w*w*pw*:block", &bd,
                          &ba, &bs, &bq, &n, &angle_random, &speed_random, &samp[0],
                          &samp[1], &cut, &samp[3], &pair_total, &a.pair_shift,
                          &samp[2], &a.sin_theta, &a.cos_theta, &a.speed, &a.p,
                          &a.q, &a.friction, &shadow_none, &bh, &beh, &bmh,
                          &a.areal, &blh))
        return NULL;
    PyObject *result = NULL;
    memset(&a.counts, 0, sizeof a.counts);
    if (parse_sampler(samp[0], "diameter", &a.d, 8, sb[0], &held[0]) ||
        parse_sampler(samp[1], "angle", &a.a, 8, sb[1], &held[1]) ||
        parse_sampler(samp[2], "speed", &a.s, 4, sb[2], &held[2]) ||
        parse_sampler(samp[3], "particle", &a.b, 8, sb[3], &held[3]))
        goto done;
    if (check_pairs(a.pair_shift, pair_total, &a.a, &a.b))
        goto done;
    a.pair_total = (uint64_t)pair_total;
    if (n < 0) {
        PyErr_SetString(PyExc_ValueError, "_ckernel.block: bad n or stride");
        goto done;
    }
    if (check_len(&bd, "i_d", 8, n) ||
        (angle_random && check_len(&ba, "i_a", 8, n)) ||
        (speed_random && check_len(&bs, "i_s", 8, n)) ||
        (angle_random && a.pair_shift < 0 && check_len(&bq, "i_p", 8, n)) ||
        parse_hist(&bh, &a.hist) ||
        check_len(&beh, "e_hist", 8, a.hist.e_spill + SPILL) ||
        check_len(&bmh, "mu_hist", 8, a.hist.mu_spill + SPILL) ||
        (a.areal && check_areal(a.pair_shift, &a.a)) ||
        check_len(&blh, "lat_hist", 8, a.areal ? a.hist.lat_spill + SPILL : 0))
        goto done;
    a.i_d = bd.buf;
    a.i_a = ba.buf;
    a.i_s = bs.buf;
    a.i_p = bq.buf;
    a.n = n;
    a.angle_random = angle_random;
    a.speed_random = speed_random;
    a.cut = (uint64_t)cut;
    a.shadow_none = shadow_none;
    a.e_hist = beh.buf;
    a.mu_hist = bmh.buf;
    a.lat_hist = blh.buf;
    a.st_em = a.st_mum = a.st_psi = NULL;
    a.st_code = NULL;
    a.keyed = 0;
    scratch_t *s = PyMem_RawMalloc(sizeof(scratch_t));
    if (s == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    RELEASE_GIL
    run_block(&a, s);
    ACQUIRE_GIL
    PyMem_RawFree(s);
    result = Py_BuildValue(
        "(LLLLL)(dddddddddddd)", (long long)a.counts.shadow,
        (long long)a.counts.capt, (long long)a.counts.reimp,
        (long long)a.counts.roll, (long long)a.counts.reb, a.sums[0], a.sums[1],
        a.sums[2], a.sums[3], a.sums[4], a.sums[5], a.sums[6], a.sums[7],
        a.sums[8], a.sums[9], a.sums[10], a.sums[11]);
done:
    PyBuffer_Release(&bd);
    PyBuffer_Release(&ba);
    PyBuffer_Release(&bs);
    PyBuffer_Release(&bq);
    PyBuffer_Release(&bh);
    PyBuffer_Release(&beh);
    PyBuffer_Release(&bmh);
    PyBuffer_Release(&blh);
    for (int i = 0; i < 4; i++)
        if (held[i])
            release_sampler(sb[i]);
    return result;
}

/* --------------------------------------------------- keyed streams: bindings */

/* The entropy's uint32 words (kernel.entropy_words) as the pool after them. */
static int
parse_entropy(Py_buffer *b, ss_state *st)
{
    if (b->len < 4 || b->len % 4 != 0) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel: entropy needs at least one uint32 word");
        return -1;
    }
    ss_prefix((const uint32_t *)b->buf, b->len / 4, st);
    return 0;
}

PyDoc_STRVAR(stream_doc,
"stream(entropy_words, key, out) -> None\n\n"
"Fill the uint64 buffer `out` with the first outputs of\n"
"PCG64(SeedSequence(entropy, spawn_key=key)).random_raw(len(out)): `entropy_words`\n"
"holds the entropy's uint32 words, little-endian (kernel.entropy_words), `key` is\n"
"a tuple of integers in [0, 2^64).");

static PyObject *
ck_stream(PyObject *self, PyObject *args)
{
    Py_buffer be, bo;
    PyObject *key;
    if (!PyArg_ParseTuple(args, "y*O!w*:stream", &be, &PyTuple_Type, &key, &bo))
        return NULL;
    PyObject *result = NULL;
    ss_state st;
    uint64_t k[16];
    Py_ssize_t nk = PyTuple_GET_SIZE(key);
    if (parse_entropy(&be, &st))
        goto done;
    if (nk > 16 || bo.len % 8 != 0) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.stream: at most 16 key words, out of uint64");
        goto done;
    }
    for (Py_ssize_t i = 0; i < nk; i++) {
        k[i] = PyLong_AsUnsignedLongLong(PyTuple_GET_ITEM(key, i));
        if (PyErr_Occurred())
            goto done;
    }
    pcg64_t g;
    stream_seed(&st, k, (int)nk, &g);
    RELEASE_GIL
    pcg_fill(&g, (uint64_t *)bo.buf, bo.len / 8);
    ACQUIRE_GIL
    result = Py_None;
    Py_INCREF(result);
done:
    PyBuffer_Release(&be);
    PyBuffer_Release(&bo);
    return result;
}

/* A sampler tuple parsed once per call, found again by identity. */
typedef struct {
    PyObject *tup;
    sampler_t s;
    Py_buffer bufs[3];
    int held;
} parsed_sampler;

typedef struct {
    parsed_sampler **items; /* each allocated alone: its address is kept */
    Py_ssize_t n, cap;
} sampler_set;

static const sampler_t *
sampler_of(sampler_set *set, PyObject *tup, const char *name, Py_ssize_t min_stride)
{
    for (Py_ssize_t i = set->n - 1; i >= 0; i--)
        if (set->items[i]->tup == tup)
            return &set->items[i]->s;
    if (set->n == set->cap) {
        Py_ssize_t cap = set->cap ? 2 * set->cap : 8;
        parsed_sampler **p = PyMem_Realloc(set->items, cap * sizeof *p);
        if (p == NULL) {
            PyErr_NoMemory();
            return NULL;
        }
        set->items = p;
        set->cap = cap;
    }
    parsed_sampler *ps = PyMem_Malloc(sizeof *ps);
    if (ps == NULL) {
        PyErr_NoMemory();
        return NULL;
    }
    ps->tup = tup;
    ps->held = 0;
    if (parse_sampler(tup, name, &ps->s, min_stride, ps->bufs, &ps->held)) {
        if (ps->held)
            release_sampler(ps->bufs);
        PyMem_Free(ps);
        return NULL;
    }
    set->items[set->n++] = ps;
    return &ps->s;
}

static void
sampler_set_free(sampler_set *set)
{
    for (Py_ssize_t i = 0; i < set->n; i++) {
        release_sampler(set->items[i]->bufs);
        PyMem_Free(set->items[i]);
    }
    PyMem_Free(set->items);
}

/* One block spec with its point's parameters. */
typedef struct {
    uint64_t point, block;
    Py_ssize_t n;
    /* QMC: the (point, replicate)'s scrambled Sobol' sequence, uint32 words
     * [d, bits, shift[d], sv[d][bits]] (NULL: keyed PCG64 streams); `block` is
     * then the index of the block's first point in it */
    const uint32_t *sobol;
    int angle_random, shadow_none, pair_shift, areal;
    const sampler_t *a, *b;
    uint64_t cut, pair_total;
    double sin_theta, cos_theta, speed;
} spec_t;

/* The Sobol' dimension of each variable, as kernel._variables lists them:
 * diameter, then the angle, the speed factor and the pair proposal where drawn
 * (-1 where not). Returns their count. */
static int
sobol_variables(int angle_random, int speed_random, int search, int *dim)
{
    int d = 0;
    dim[0] = d++;
    dim[1] = angle_random ? d++ : -1;
    dim[2] = speed_random ? d++ : -1;
    dim[3] = angle_random && search ? d++ : -1;
    return d;
}

/* A QMC spec's Sobol' sequence must have one dimension per variable drawn. */
static int
sobol_dims(const spec_t *x, int speed_random)
{
    int dim[4];
    if (x->sobol != NULL &&
        (int)x->sobol[0] != sobol_variables(x->angle_random, speed_random,
                                             x->pair_shift < 0, dim)) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.specs: sobol dimensions != variables drawn");
        return -1;
    }
    return 0;
}

/* Point `k0` of the sequence: the shift XOR the direction numbers of the bits of
 * the Gray code of k0 (what scipy's fast_forward reaches). */
static void
sobol_start(block_args *a, const uint32_t *sobol, uint64_t k0, int speed_random)
{
    int d = (int)sobol[0], bits = (int)sobol[1];
    sobol_variables(a->angle_random, speed_random, a->pair_shift < 0, a->qdim);
    a->qd = d;
    a->qbits = bits;
    a->qsv = sobol + 2 + d;
    a->qk = k0;
    uint64_t gray = k0 ^ (k0 >> 1);
    for (int q = 0; q < d; q++) {
        uint32_t x = sobol[2 + q];
        for (int j = 0; j < bits; j++)
            if ((gray >> j) & 1)
                x ^= a->qsv[q * bits + j];
        a->qx[q] = x;
    }
}

/* The occupied span [lo, hi) of h[0:size] (lo = hi = 0 when empty). */
static void
occupied(const int64_t *h, int64_t size, int64_t *lo, int64_t *hi)
{
    int64_t i = 0, j = size;
    while (i < size && h[i] == 0)
        i++;
    if (i == size) {
        *lo = *hi = 0;
        return;
    }
    while (h[j - 1] == 0)
        j--;
    *lo = i;
    *hi = j;
}

/* The moments (n, mean, M2, M3) of n values from their shifted sums s = (shift,
 * S1, S2, S3): accumulators.Moments.from_shifted_sums, the same operations in the
 * same order (this file is built with -ffp-contract=off), the cube as Python's
 * float power takes it (pow of the magnitude, the sign put back). */
static double
py_cube(double d)
{
    if (d == 0.0 || d != d)
        return d * d * d; /* 0 keeps its sign; NaN stays NaN */
    return d < 0.0 ? -pow(-d, 3.0) : pow(d, 3.0);
}

static void
moments_of_sums(int64_t n, const double *s, double *out)
{
    if (n == 0) {
        out[0] = out[1] = out[2] = out[3] = 0.0;
        return;
    }
    double dn = (double)n;
    double delta = s[1] / dn;
    double m2 = s[2] - s[1] * delta;
    double m3 = (s[3] - 3.0 * delta * s[2]) + 2.0 * dn * py_cube(delta);
    out[0] = dn;
    out[1] = s[0] + delta;
    out[2] = m2 < 0.0 ? 0.0 : m2; /* Python's max(m2, 0.0) */
    out[3] = m3;
}

/* a = a merged with b (accumulators.Moments.merge, Pebay 2008 Eqs. 1.1-1.3): the
 * same operations in the same order; counts below 2^53 are exact doubles. */
static void
moments_merge(double *a, const double *b)
{
    if (b[0] == 0.0)
        return;
    if (a[0] == 0.0) {
        memcpy(a, b, 4 * sizeof *a);
        return;
    }
    double na = a[0], nb = b[0], n = na + nb;
    double delta = b[1] - a[1];
    double mean = a[1] + delta * nb / n;
    double m2 = a[2] + b[2] + delta * delta * na * nb / n;
    double m3 = a[3] + b[3] + py_cube(delta) * na * nb * (na - nb) / (n * n) +
                3.0 * delta * (na * b[2] - nb * a[2]) / n;
    a[0] = n;
    a[1] = mean;
    a[2] = m2;
    a[3] = m3;
}

PyDoc_STRVAR(specs_doc,
"specs(entropy_words, common, specs, counts, sums, spans) -> bytes\n\n"
"Run block specs in order, each drawing its variables from its keyed streams\n"
"PCG64(SeedSequence(entropy, spawn_key=(point, block, v))) (v: 0 diameter,\n"
"1 angle, 2 speed, 3 the particle's proposal of a pair search), and reduce each\n"
"as block() does. `common` is (dsamp, ssamp,\n"
"speed_random, p, q, friction, hist); each spec is (point, block, n, pt) with pt\n"
"= (angle_random, asamp, cut, psamp, pair_total, pair_shift, sin_theta,\n"
"cos_theta, speed, shadow_none, areal) (see block(); equal objects are parsed\n"
"once). Writes per spec: counts int64[5] (shadowed, captured, reimpact, rolling,\n"
"rebounds), sums float64[12] (as block()), spans int64[6] (offset and length of\n"
"the occupied e_m histogram span, then of mu_m's, then of psi_f's: off an areal\n"
"surface every rebound's psi_f is 0, one bin). Returns the spans' counts as\n"
"int64 bytes: every row's e_m span, then every row's mu_m span, then every\n"
"row's psi_f span (each histogram's counts contiguous, in row order).\n"
"With `store` = (e_m, mu_m, psi, outcome), C-contiguous writable buffers of\n"
"float64, float64, float64, int8 of the specs' total n, each impact's e_m and mu_m (0.0 where not a rebound), its lateral angle\n"
"psi [deg] (kernel.atan2_deg; areal surfaces only, else 0.0) and outcome (0 a\n"
"rebound, 1 captured, 2 shadowed) are written there, in spec order.\n\n"
"`specs` may instead be a tuple of arrays (points, which, speed, point, block,\n"
"n): spec i is the point tuple points[which[i]] at speed[i] (the tuple's own\n"
"speed is not used) with point[i], block[i] and n[i] (int64; speed float64):\n"
"the same specs without a Python object each, Monte Carlo only. `points` is a\n"
"list of point tuples or their capsule from points() (parsed once).");

/* One point tuple `pt` of _ckernel.specs (everything of a spec but its point,
 * block and n) into `x`, its samplers parsed once per call through `set`; x->sobol
 * is set by the caller. */
static int
parse_point(PyObject *pt, spec_t *x, sampler_set *set, int speed_random)
{
    PyObject *as, *ps;
    unsigned long long cut, pair_total;
    if (!PyTuple_Check(pt)) {
        PyErr_SetString(PyExc_TypeError, "_ckernel.specs: a point is a tuple");
        return -1;
    }
    if (!PyArg_ParseTuple(pt, "pOKOKidddpp:specs", &x->angle_random, &as, &cut, &ps,
                          &pair_total, &x->pair_shift, &x->sin_theta, &x->cos_theta,
                          &x->speed, &x->shadow_none, &x->areal))
        return -1;
    if ((x->a = sampler_of(set, as, "angle", 8)) == NULL ||
        (x->b = sampler_of(set, ps, "particle", 8)) == NULL)
        return -1;
    x->cut = cut;
    x->pair_total = pair_total;
    if (check_pairs(x->pair_shift, pair_total, x->a, x->b) ||
        (x->areal && check_areal(x->pair_shift, x->a)) || sobol_dims(x, speed_random))
        return -1;
    return 0;
}

/* A plan's point tuples parsed once (_ckernel.points): the templates of its
 * specs and the samplers they read, held for the capsule's life (the tuples'
 * arrays stay alive through the buffers held, the list through `heads`). */
typedef struct {
    PyObject *heads;
    sampler_set set;
    spec_t *tmpl;
    Py_ssize_t n;
    /* optional (task()): every plan point's template (int64) and speed */
    Py_buffer which, speed;
    Py_ssize_t points;
} point_table;

static const char *POINTS_CAPSULE = "microimpact.engine._ckernel.points";

static void
point_table_free(PyObject *capsule)
{
    point_table *t = PyCapsule_GetPointer(capsule, POINTS_CAPSULE);
    if (t == NULL)
        return;
    sampler_set_free(&t->set);
    PyMem_Free(t->tmpl);
    Py_XDECREF(t->heads);
    if (t->which.obj != NULL)
        PyBuffer_Release(&t->which);
    if (t->speed.obj != NULL)
        PyBuffer_Release(&t->speed);
    PyMem_Free(t);
}

PyDoc_STRVAR(points_doc,
"points(heads, speed_random[, which, speed]) -> capsule\n\n"
"The point tuples `heads` (a list, as specs() reads them) parsed once, for the\n"
"tuple-of-arrays form of specs() (in place of its list of points): a plan's\n"
"points are then parsed once, not in every call. With `which` (int64, an index\n"
"of `heads` per plan point) and `speed` (float64, its speed), task() can run\n"
"groups of the plan's points from their indices alone.");

static PyObject *
ck_points(PyObject *self, PyObject *args)
{
    PyObject *heads, *which = Py_None, *speed = Py_None;
    int speed_random;
    if (!PyArg_ParseTuple(args, "O!p|OO:points", &PyList_Type, &heads, &speed_random,
                          &which, &speed))
        return NULL;
    point_table *t = PyMem_Calloc(1, sizeof *t);
    if (t == NULL)
        return PyErr_NoMemory();
    t->n = PyList_GET_SIZE(heads);
    t->tmpl = PyMem_Malloc((t->n ? t->n : 1) * sizeof *t->tmpl);
    if (t->tmpl == NULL) {
        PyMem_Free(t);
        return PyErr_NoMemory();
    }
    Py_INCREF(heads);
    t->heads = heads;
    PyObject *capsule = PyCapsule_New(t, POINTS_CAPSULE, point_table_free);
    if (capsule == NULL) {
        sampler_set_free(&t->set);
        PyMem_Free(t->tmpl);
        Py_DECREF(heads);
        PyMem_Free(t);
        return NULL;
    }
    for (Py_ssize_t h = 0; h < t->n; h++) {
        t->tmpl[h].sobol = NULL;
        if (parse_point(PyList_GET_ITEM(heads, h), &t->tmpl[h], &t->set,
                        speed_random)) {
            Py_DECREF(capsule);
            return NULL;
        }
    }
    if ((which == Py_None) != (speed == Py_None)) {
        PyErr_SetString(PyExc_TypeError, "_ckernel.points: which and speed together");
        Py_DECREF(capsule);
        return NULL;
    }
    if (which != Py_None) {
        if (PyObject_GetBuffer(which, &t->which, PyBUF_C_CONTIGUOUS) < 0 ||
            PyObject_GetBuffer(speed, &t->speed, PyBUF_C_CONTIGUOUS) < 0) {
            Py_DECREF(capsule);
            return NULL;
        }
        if (t->which.len % 8 || t->speed.len != t->which.len) {
            PyErr_SetString(PyExc_ValueError,
                            "_ckernel.points: which (int64) and speed (float64) "
                            "are of one length");
            Py_DECREF(capsule);
            return NULL;
        }
        t->points = t->which.len / 8;
        const int64_t *w = t->which.buf;
        for (Py_ssize_t i = 0; i < t->points; i++)
            if (w[i] < 0 || w[i] >= t->n) {
                PyErr_SetString(PyExc_ValueError,
                                "_ckernel.points: which must index heads");
                Py_DECREF(capsule);
                return NULL;
            }
    }
    return capsule;
}

/* The specs given as arrays, `arr` = (points, which, speed, point, block, n):
 * spec i is points[which[i]] (point tuples as in the list form) at speed[i], with
 * its own point, block and n (int64 arrays; speed float64), all of one length.
 * Monte Carlo only (no Sobol' states). Fills `*sp` (PyMem_Malloc'd) and `*K`. */
static int
specs_from_arrays(PyObject *arr, spec_t **sp, Py_ssize_t *K, sampler_set *set,
                  int speed_random)
{
    static const char *names[5] = {"which", "speed", "point", "block", "n"};
    Py_buffer b[5] = {{0}};
    int nb = 0, rc = -1;
    spec_t *tmpl = NULL;
    const spec_t *use;
    PyObject *heads = NULL;
    point_table *parsed = NULL;
    if (PyTuple_GET_SIZE(arr) == 6 && PyCapsule_CheckExact(PyTuple_GET_ITEM(arr, 0))) {
        parsed = PyCapsule_GetPointer(PyTuple_GET_ITEM(arr, 0), POINTS_CAPSULE);
        if (parsed == NULL)
            return -1;
    } else if (PyTuple_GET_SIZE(arr) != 6 ||
               !PyList_Check(heads = PyTuple_GET_ITEM(arr, 0))) {
        PyErr_SetString(PyExc_TypeError,
                        "_ckernel.specs: array specs are (points, which, speed, "
                        "point, block, n)");
        return -1;
    }
    for (; nb < 5; nb++) {
        if (PyObject_GetBuffer(PyTuple_GET_ITEM(arr, nb + 1), &b[nb],
                               PyBUF_C_CONTIGUOUS) < 0)
            goto out;
        if (b[nb].len % 8 != 0 || b[nb].len != b[0].len) {
            PyErr_Format(PyExc_ValueError,
                         "_ckernel.specs: %s is 8-byte items, as long as which",
                         names[nb]);
            nb++;
            goto out;
        }
    }
    Py_ssize_t n = b[0].len / 8, H = parsed ? parsed->n : PyList_GET_SIZE(heads);
    *sp = PyMem_Malloc((n ? n : 1) * sizeof **sp);
    if (*sp == NULL) {
        PyErr_NoMemory();
        goto out;
    }
    if (parsed != NULL) {
        use = parsed->tmpl;
    } else {
        tmpl = PyMem_Malloc((H ? H : 1) * sizeof *tmpl);
        if (tmpl == NULL) {
            PyErr_NoMemory();
            goto out;
        }
        for (Py_ssize_t h = 0; h < H; h++) {
            tmpl[h].sobol = NULL;
            if (parse_point(PyList_GET_ITEM(heads, h), &tmpl[h], set, speed_random))
                goto out;
        }
        use = tmpl;
    }
    const int64_t *wh = b[0].buf, *pa = b[2].buf, *bl = b[3].buf, *nn = b[4].buf;
    const double *spd = b[1].buf;
    for (Py_ssize_t i = 0; i < n; i++) {
        if (wh[i] < 0 || wh[i] >= H || pa[i] < 0 || bl[i] < 0 || nn[i] < 0) {
            PyErr_SetString(PyExc_ValueError,
                            "_ckernel.specs: which must index the points; point, "
                            "block and n must be >= 0");
            goto out;
        }
        spec_t *x = &(*sp)[i];
        *x = use[wh[i]];
        x->point = (uint64_t)pa[i];
        x->block = (uint64_t)bl[i];
        x->n = (Py_ssize_t)nn[i];
        x->speed = spd[i];
    }
    *K = n;
    rc = 0;
out:
    PyMem_Free(tmpl);
    for (int j = 0; j < nb; j++)
        PyBuffer_Release(&b[j]);
    return rc;
}

/* The blocks `sp[0 .. K)` through the kernel, the GIL released (the core of
 * specs() and task()): per block (glen NULL) or per group of glen[g] consecutive
 * blocks merged in block order, its counts (shadowed, captured, reimpact,
 * rolling, rebounds) in counts[5 row], its shifted sums (per block) or moments
 * (n, mean, M2, M3 per group) of e_m, mu_m, psi_f in sums[12 row], and its
 * occupied histogram spans (lo, length per histogram) in spans[6 row], their
 * counts appended to out[h] (PyMem_RawMalloc'd here, freed by the caller;
 * used[h] values). st_d/st_code: the per-impact outputs, or NULL. Needs no
 * GIL (the callers release it); returns -1 where memory ran out. */
static int
run_specs(const ss_state *st, const hist_t *hs, const sampler_t *sd,
          const sampler_t *ss, int speed_random, double p, double q,
          double friction, const spec_t *sp, Py_ssize_t K, const int64_t *glen,
          int64_t *counts, double *sums, int64_t *spans, double *const st_d[3],
          int8_t *st_code, int64_t *out[3], Py_ssize_t used[3])
{
    scratch_t *scr = NULL;
    int64_t *eh = NULL, *mh = NULL, *lh = NULL;
    Py_ssize_t cap[3] = {4096, 4096, 4096};
    int oom = 0;
    int64_t e_size = hs->e_spill + SPILL, mu_size = hs->mu_spill + SPILL;
    int64_t lat_size = hs->lat_spill + SPILL;
    scr = PyMem_RawMalloc(sizeof(scratch_t));
    eh = PyMem_RawCalloc(e_size, sizeof *eh);
    mh = PyMem_RawCalloc(mu_size, sizeof *mh);
    lh = PyMem_RawCalloc(lat_size, sizeof *lh);
    for (int h = 0; h < 3; h++)
        out[h] = PyMem_RawMalloc(cap[h] * sizeof *out[h]);
    if (scr == NULL || eh == NULL || mh == NULL || lh == NULL || out[0] == NULL ||
        out[1] == NULL || out[2] == NULL) {
        oom = 1;
        goto end;
    }
    Py_ssize_t offset = 0, g = 0, at = 0; /* group, and block within it */
    for (Py_ssize_t i = 0; i < K && !oom; i++) {
        const spec_t *x = &sp[i];
        block_args a;
        a.st_em = a.st_mum = a.st_psi = NULL;
        a.st_code = NULL;
        if (st_code != NULL) { /* this block's impacts in the per-impact outputs */
            a.st_em = st_d[0] + offset;
            a.st_mum = st_d[1] + offset;
            a.st_psi = st_d[2] + offset;
            a.st_code = st_code + offset;
        }
        offset += x->n;
        a.i_d = a.i_a = a.i_s = a.i_p = NULL;
        a.n = x->n;
        a.angle_random = x->angle_random;
        a.speed_random = speed_random;
        a.d = *sd;
        a.a = *x->a;
        a.s = *ss;
        a.b = *x->b;
        a.cut = x->cut;
        a.pair_total = x->pair_total;
        a.pair_shift = x->pair_shift;
        a.sin_theta = x->sin_theta;
        a.cos_theta = x->cos_theta;
        a.speed = x->speed;
        a.p = p;
        a.q = q;
        a.friction = friction;
        a.shadow_none = x->shadow_none;
        a.hist = *hs;
        a.e_hist = eh;
        a.mu_hist = mh;
        a.lat_hist = lh;
        a.areal = x->areal;
        memset(&a.counts, 0, sizeof a.counts);
        a.keyed = 1;
        int search = x->angle_random && x->pair_shift < 0;
        a.qmc = x->sobol != NULL;
        if (a.qmc)
            sobol_start(&a, x->sobol, x->block, speed_random);
        for (int v = 0; v < 4 && !a.qmc; v++) {
            uint64_t key[3] = {x->point, x->block, (uint64_t)v};
            if (v == 0 || (v == 1 && x->angle_random) || (v == 2 && speed_random) ||
                (v == 3 && search))
                stream_seed(st, key, 3, &a.gen[v]);
        }
        run_block(&a, scr);
        int lat_areal = a.areal && a.angle_random && a.pair_shift == 0;
        /* this block's row, or its group's (merged in block order) */
        Py_ssize_t row = glen == NULL ? i : g;
        int64_t *c = counts + 5 * row;
        if (glen == NULL || at == 0)
            memset(c, 0, 5 * sizeof *c);
        c[0] += a.counts.shadow;
        c[1] += a.counts.capt;
        c[2] += a.counts.reimp;
        c[3] += a.counts.roll;
        c[4] += a.counts.reb;
        if (glen == NULL) {
            memcpy(sums + 12 * i, a.sums, sizeof a.sums);
        } else {
            double *gm = sums + 12 * g;
            for (int h = 0; h < 3; h++) {
                double bm[4];
                moments_of_sums(a.counts.reb, a.sums + 4 * h, bm);
                if (at == 0)
                    memcpy(gm + 4 * h, bm, sizeof bm);
                else
                    moments_merge(gm + 4 * h, bm);
            }
        }
        /* off an areal surface psi_f = 0 for every rebound: one bin */
        if (!lat_areal)
            lh[hs->lat_zero] += a.counts.reb;
        memset(eh + hs->e_spill, 0, SPILL * sizeof *eh);
        memset(mh + hs->mu_spill, 0, SPILL * sizeof *mh);
        memset(lh + hs->lat_spill, 0, SPILL * sizeof *lh);
        if (glen != NULL && ++at < glen[g])
            continue; /* the group's histograms go on adding up */
        at = 0;
        if (glen != NULL)
            g++;
        /* the occupied spans, each appended to its histogram's `out`; then the
         * scratch histograms are zeroed where they were written */
        int64_t lo[3], hi[3];
        occupied(eh, hs->e_top + 1, &lo[0], &hi[0]);
        occupied(mh, hs->mu_top + 1, &lo[1], &hi[1]);
        if (!lat_areal) {
            lo[2] = c[4] ? hs->lat_zero : 0;
            hi[2] = c[4] ? hs->lat_zero + 1 : 0;
        } else {
            occupied(lh, hs->lat_top + 1, &lo[2], &hi[2]);
        }
        for (int h = 0; h < 3 && !oom; h++) {
            Py_ssize_t need = used[h] + (hi[h] - lo[h]);
            if (need > cap[h]) {
                while (cap[h] < need)
                    cap[h] *= 2;
                int64_t *o = PyMem_RawRealloc(out[h], cap[h] * sizeof *o);
                if (o == NULL) {
                    oom = 1;
                    break;
                }
                out[h] = o;
            }
        }
        if (oom)
            break;
        for (int h = 0; h < 3; h++) {
            int64_t *hist = h == 0 ? eh : (h == 1 ? mh : lh);
            memcpy(out[h] + used[h], hist + lo[h], (hi[h] - lo[h]) * sizeof *hist);
            used[h] += hi[h] - lo[h];
            memset(hist + lo[h], 0, (hi[h] - lo[h]) * sizeof *hist);
            spans[6 * row + 2 * h] = lo[h];
            spans[6 * row + 2 * h + 1] = hi[h] - lo[h];
        }
        lh[hs->lat_zero] = 0;
    }
end:
    PyMem_RawFree(scr);
    PyMem_RawFree(eh);
    PyMem_RawFree(mh);
    PyMem_RawFree(lh);
    return oom ? -1 : 0;
}

/* The per-impact outputs `store` of specs() and task() (None, or a tuple of
 * e_m, mu_m, psi float64 and outcome int8 buffers of at least `total_n` items)
 * into bst[0 .. *nst); -1 with the error set (the caller releases bst[0 ..
 * *nst) either way). */
static int
store_of(PyObject *store, Py_ssize_t total_n, const char *fn, Py_buffer bst[4],
         int *nst)
{
    static const char *names[4] = {"e_m", "mu_m", "psi", "outcome"};
    static const Py_ssize_t sizes[4] = {8, 8, 8, 1};
    if (store == Py_None)
        return 0;
    if (!PyTuple_Check(store) || PyTuple_GET_SIZE(store) != 4) {
        PyErr_Format(PyExc_TypeError, "_ckernel.%s: store is a 4-tuple", fn);
        return -1;
    }
    for (; *nst < 4; (*nst)++) {
        if (PyObject_GetBuffer(PyTuple_GET_ITEM(store, *nst), &bst[*nst],
                               PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) < 0)
            return -1;
        if (check_len(&bst[*nst], names[*nst], sizes[*nst], total_n)) {
            (*nst)++;
            return -1;
        }
    }
    return 0;
}

/* The outputs' pointers of a parsed `store` (NULL where there is none). */
static void
store_pointers(Py_buffer bst[4], int nst, double *st_d[3], int8_t **st_code)
{
    if (nst != 4)
        return;
    for (int j = 0; j < 3; j++)
        st_d[j] = bst[j].buf;
    *st_code = bst[3].buf;
}

static PyObject *
ck_specs(PyObject *self, PyObject *args)
{
    Py_buffer be, bh, bc, bs, bp;
    Py_buffer bst[4] = {{0}};
    int nst = 0;
    Py_buffer bg = {0};
    PyObject *dsamp, *ssamp, *list, *store = Py_None, *groups = Py_None;
    int speed_random;
    double p, q, friction;
    if (!PyArg_ParseTuple(args, "y*(OOpdddy*)Ow*w*w*|OO:specs", &be, &dsamp, &ssamp,
                          &speed_random, &p, &q, &friction, &bh, &list, &bc, &bs,
                          &bp, &store, &groups))
        return NULL; /* (the parser releases what it acquired) */
    PyObject *result = NULL;
    Py_ssize_t total_n = 0;
    sampler_set set = {NULL, 0, 0};
    spec_t *sp = NULL;
    /* the occupied spans' counts, one buffer per histogram (e_m, mu_m, psi_f) */
    int64_t *out[3] = {NULL, NULL, NULL};
    Py_ssize_t used[3] = {0, 0, 0};
    Py_ssize_t K = 0, G = 0;
    const int64_t *glen = NULL;
    int arrays = PyTuple_Check(list);
    if (!arrays && !PyList_Check(list)) {
        PyErr_SetString(PyExc_TypeError,
                        "_ckernel.specs: specs is a list of tuples or a tuple of "
                        "arrays");
        goto done;
    }
    if (arrays) {
        if (specs_from_arrays(list, &sp, &K, &set, speed_random))
            goto done;
    } else {
        K = PyList_GET_SIZE(list);
    }
    G = K;
    ss_state st;
    hist_t hs;
    const sampler_t *sd, *ss;
    if (groups != Py_None) {
        if (PyObject_GetBuffer(groups, &bg, PyBUF_C_CONTIGUOUS) < 0)
            goto done;
        if (bg.len % 8 != 0) {
            PyErr_SetString(PyExc_ValueError, "_ckernel.specs: groups is int64");
            goto done;
        }
        G = bg.len / 8;
        glen = bg.buf;
        Py_ssize_t covered = 0;
        for (Py_ssize_t g = 0; g < G; g++) {
            if (glen[g] < 1 || glen[g] > K - covered) {
                PyErr_SetString(PyExc_ValueError,
                                "_ckernel.specs: group lengths must be >= 1 and "
                                "sum to the number of specs");
                goto done;
            }
            covered += glen[g];
        }
        if (covered != K) {
            PyErr_SetString(PyExc_ValueError,
                            "_ckernel.specs: group lengths must sum to the number "
                            "of specs");
            goto done;
        }
    }
    if (parse_entropy(&be, &st) || parse_hist(&bh, &hs) ||
        check_len(&bc, "counts", 8, 5 * G) || check_len(&bs, "sums", 8, 12 * G) ||
        check_len(&bp, "spans", 8, 6 * G))
        goto done;
    if ((sd = sampler_of(&set, dsamp, "diameter", 8)) == NULL ||
        (ss = sampler_of(&set, ssamp, "speed", 4)) == NULL)
        goto done;
    if (!arrays)
        sp = PyMem_Malloc((K ? K : 1) * sizeof *sp);
    if (sp == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    PyObject *prev_pt = NULL;
    for (Py_ssize_t i = 0; i < K && !arrays; i++) {
        PyObject *item = PyList_GET_ITEM(list, i), *pt, *po, *bo;
        PyObject *qo = Py_None;
        spec_t *x = &sp[i];
        if (!PyTuple_Check(item)) {
            PyErr_SetString(PyExc_TypeError, "_ckernel.specs: a spec is a tuple");
            goto done;
        }
        if (!PyArg_ParseTuple(item, "OOnO!|O:specs", &po, &bo, &x->n, &PyTuple_Type,
                              &pt, &qo))
            goto done;
        const uint32_t *sobol = NULL;
        if (qo != Py_None) {
            if (!PyBytes_Check(qo)) {
                PyErr_SetString(PyExc_TypeError, "_ckernel.specs: sobol is bytes");
                goto done;
            }
            sobol = (const uint32_t *)PyBytes_AS_STRING(qo);
            Py_ssize_t words = PyBytes_GET_SIZE(qo) / 4;
            if (PyBytes_GET_SIZE(qo) % 4 || words < 2 || sobol[0] < 1 ||
                sobol[0] > 4 || sobol[1] < 1 || sobol[1] > 32 ||
                words != 2 + (Py_ssize_t)sobol[0] * (1 + sobol[1])) {
                PyErr_SetString(PyExc_ValueError, "_ckernel.specs: bad sobol layout");
                goto done;
            }
        }
        /* key elements in [0, 2^64), as SeedSequence takes them */
        x->point = PyLong_AsUnsignedLongLong(po);
        if (PyErr_Occurred())
            goto done;
        x->block = PyLong_AsUnsignedLongLong(bo);
        if (PyErr_Occurred())
            goto done;
        if (x->n < 0) {
            PyErr_SetString(PyExc_ValueError, "_ckernel.specs: negative n");
            goto done;
        }
        if (sobol != NULL && (x->block > ((uint64_t)1 << sobol[1]) ||
                              (uint64_t)x->n > ((uint64_t)1 << sobol[1]) - x->block)) {
            PyErr_SetString(PyExc_ValueError,
                            "_ckernel.specs: past the end of the Sobol' sequence");
            goto done;
        }
        if (pt == prev_pt) { /* the same point as the spec before */
            spec_t keep = *x;
            *x = sp[i - 1];
            x->point = keep.point;
            x->block = keep.block;
            x->n = keep.n;
            x->sobol = sobol;
            if (sobol_dims(x, speed_random))
                goto done;
            continue;
        }
        x->sobol = sobol;
        if (parse_point(pt, x, &set, speed_random))
            goto done;
        prev_pt = pt;
    }
    for (Py_ssize_t i = 0; i < K; i++)
        total_n += sp[i].n;
    if (store_of(store, total_n, "specs", bst, &nst))
        goto done;
    int64_t *counts = bc.buf, *spans = bp.buf;
    double *sums = bs.buf;
    double *st_d[3] = {NULL, NULL, NULL};
    int8_t *st_code = NULL;
    store_pointers(bst, nst, st_d, &st_code);
    int oom;
    RELEASE_GIL
    oom = run_specs(&st, &hs, sd, ss, speed_random, p, q, friction, sp, K, glen,
                    counts, sums, spans, st_d, st_code, out, used);
    ACQUIRE_GIL
    if (oom) {
        PyErr_NoMemory();
        goto done;
    }
    result = PyBytes_FromStringAndSize(
        NULL, (used[0] + used[1] + used[2]) * (Py_ssize_t)sizeof(int64_t));
    if (result != NULL) {
        char *to = PyBytes_AS_STRING(result);
        for (int h = 0; h < 3; h++) {
            memcpy(to, out[h], used[h] * sizeof(int64_t));
            to += used[h] * sizeof(int64_t);
        }
    }
done:
    for (int h = 0; h < 3; h++)
        PyMem_RawFree(out[h]);
    PyMem_Free(sp);
    sampler_set_free(&set);
    PyBuffer_Release(&be);
    PyBuffer_Release(&bh);
    PyBuffer_Release(&bc);
    PyBuffer_Release(&bs);
    PyBuffer_Release(&bp);
    if (bg.obj != NULL)
        PyBuffer_Release(&bg);
    for (int j = 0; j < nst; j++)
        PyBuffer_Release(&bst[j]);
    return result;
}

/* The counts `c` rewritten in place, from the front, in the narrowest of uint8,
 * uint16, int32 and int64 that holds every one of them (summary.compact_counts;
 * item i is written at byte w i <= 8 i, after it is read); returns w. */
static int
narrow_in_place(int64_t *c, Py_ssize_t n)
{
    int64_t top = 0;
    for (Py_ssize_t i = 0; i < n; i++)
        top = c[i] > top ? c[i] : top;
    int w = top <= UINT8_MAX ? 1 : (top <= UINT16_MAX ? 2 : (top <= INT32_MAX ? 4 : 8));
    char *to = (char *)c; /* byte stores: ordered against the int64 loads */
    if (w == 1)
        for (Py_ssize_t i = 0; i < n; i++) {
            uint8_t v = (uint8_t)c[i];
            memcpy(to + i, &v, 1);
        }
    else if (w == 2)
        for (Py_ssize_t i = 0; i < n; i++) {
            uint16_t v = (uint16_t)c[i];
            memcpy(to + 2 * i, &v, 2);
        }
    else if (w == 4)
        for (Py_ssize_t i = 0; i < n; i++) {
            int32_t v = (int32_t)c[i];
            memcpy(to + 4 * i, &v, 4);
        }
    return w;
}

/* Adds a group's blocks fi .. la to *K and their impacts to *n (blocks of
 * bsize impacts, block stop - 1 of last_n); -1 with a ValueError where the
 * totals would not fit what the kernel allocates for them (specs, and per
 * impact outputs), which a wrapped size would have overrun. */
static int
add_group(Py_ssize_t *K, Py_ssize_t *n, int64_t fi, int64_t la, Py_ssize_t stop,
          Py_ssize_t bsize, Py_ssize_t last_n, const char *name)
{
    const Py_ssize_t kmax = PY_SSIZE_T_MAX / (Py_ssize_t)(sizeof(spec_t) + 64);
    const Py_ssize_t nmax = PY_SSIZE_T_MAX / 64;
    int64_t b = la - fi + 1;
    if (b > kmax - *K || b > (nmax - *n) / bsize) {
        PyErr_Format(PyExc_ValueError, "_ckernel.%s: too many blocks or impacts",
                     name);
        return -1;
    }
    *K += b;
    *n += b * bsize - (la == stop - 1 ? bsize - last_n : 0);
    return 0;
}

/* One task's scratch for task_core: K specs, and per group (G) its blocks,
 * impacts, counts (5), sums (12) and spans (6). */
typedef struct {
    spec_t *sp;
    int64_t *glen, *nimp, *counts, *spans;
    double *sums;
} task_scratch;

static void
task_scratch_free(task_scratch *s)
{
    PyMem_RawFree(s->sp);
    PyMem_RawFree(s->glen);
    PyMem_RawFree(s->nimp);
    PyMem_RawFree(s->counts);
    PyMem_RawFree(s->sums);
    PyMem_RawFree(s->spans);
    memset(s, 0, sizeof *s);
}

/* 0, or -1 where memory ran out (nothing then held); needs no GIL. */
static int
task_scratch_new(task_scratch *s, Py_ssize_t K, Py_ssize_t G)
{
    Py_ssize_t G1 = G ? G : 1;
    s->sp = PyMem_RawMalloc((K ? K : 1) * sizeof *s->sp);
    s->glen = PyMem_RawMalloc(G1 * sizeof *s->glen);
    s->nimp = PyMem_RawMalloc(G1 * sizeof *s->nimp);
    s->counts = PyMem_RawMalloc(G1 * 5 * sizeof *s->counts);
    s->sums = PyMem_RawMalloc(G1 * 12 * sizeof *s->sums);
    s->spans = PyMem_RawMalloc(G1 * 6 * sizeof *s->spans);
    if (s->sp == NULL || s->glen == NULL || s->nimp == NULL || s->counts == NULL ||
        s->sums == NULL || s->spans == NULL) {
        task_scratch_free(s);
        return -1;
    }
    return 0;
}

/* The GIL-free middle of task() and tasks_run(): groups g < G of point pt[g]
 * (its template and speed from the plan's points `t`), blocks fi[g] .. la[g],
 * each merged in block order, in the scratch `s` (task_scratch_new(K, G), K
 * the groups' blocks). Written: s->nimp[g] (the group's impacts) and what
 * run_specs writes (s->counts[5 g], s->sums[12 g], s->spans[6 g], out[h],
 * used[h]), each histogram's counts narrowed in place to width[h] bytes.
 * Returns -1 where memory ran out (the caller frees out[h]). */
static int
task_core(const ss_state *st, const hist_t *hs, const sampler_t *sd,
          const sampler_t *ss, int speed_random, double p, double q,
          double friction, const point_table *t, const int64_t *pt,
          const int64_t *fi, const int64_t *la, Py_ssize_t G, Py_ssize_t stop,
          Py_ssize_t bsize, Py_ssize_t last_n, task_scratch *s,
          double *const st_d[3], int8_t *st_code, int64_t *out[3],
          Py_ssize_t used[3], int width[3])
{
    const int64_t *which = t->which.buf;
    const double *speed = t->speed.buf;
    Py_ssize_t k = 0;
    for (Py_ssize_t g = 0; g < G; g++) {
        s->glen[g] = la[g] - fi[g] + 1;
        int64_t n = 0;
        for (int64_t b = fi[g]; b <= la[g]; b++, k++) {
            spec_t *x = &s->sp[k];
            *x = t->tmpl[which[pt[g]]];
            x->point = (uint64_t)pt[g];
            x->block = (uint64_t)b;
            x->n = b == stop - 1 ? last_n : bsize;
            x->speed = speed[pt[g]];
            n += x->n;
        }
        s->nimp[g] = n;
    }
    if (run_specs(st, hs, sd, ss, speed_random, p, q, friction, s->sp, k, s->glen,
                  s->counts, s->sums, s->spans, st_d, st_code, out, used))
        return -1;
    for (int h = 0; h < 3; h++)
        width[h] = narrow_in_place(out[h], used[h]);
    return 0;
}

PyDoc_STRVAR(task_doc,
"task(entropy, common, points, point, first, last, stop, block_size, last_n,\n"
"     table, moments, spans) -> (e, e_size, mu, mu_size, lat, lat_size)\n\n"
"A task of G groups run as the driver keeps them (tasks.BlockTask): group g is\n"
"blocks first[g] .. last[g] of point point[g]'s keyed stream (replicate 0),\n"
"merged in block order; every stream has `stop` blocks of `block_size` impacts,\n"
"its last one `last_n`. `points` is a capsule of points() with `which` and\n"
"`speed`. Written: table int64[G][5] (impacts, shadowed, captured, reimpact,\n"
"rolling), moments float64[3][G][4] ((n, mean, M2, M3) of e_m, mu_m, psi_f) and\n"
"spans int64[3][2][G] (each histogram's offset, 0 where empty, and length).\n"
"Returned: each histogram's span counts, one group after the other, as bytes\n"
"of the narrowest of uint8, uint16, int32 and int64 that holds them, with\n"
"that item size. The bits of specs() with groups, followed by the driver's\n"
"own layout (kernel.simulate_specs_stacked) and Stacked.narrow(). `store`: as\n"
"specs()'s, the per-impact outputs of every block, in order.");

static PyObject *
ck_task(PyObject *self, PyObject *args)
{
    Py_buffer be, bh, bpt, bf, bl, bt, bm, bsp;
    Py_buffer bst[4] = {{0}};
    int nst = 0;
    PyObject *dsamp, *ssamp, *capsule, *store = Py_None;
    int speed_random;
    double p, q, friction;
    Py_ssize_t stop, bsize, last_n;
    if (!PyArg_ParseTuple(args, "y*(OOpdddy*)O!y*y*y*nnnw*w*w*|O:task", &be, &dsamp,
                          &ssamp, &speed_random, &p, &q, &friction, &bh,
                          &PyCapsule_Type, &capsule, &bpt, &bf, &bl, &stop, &bsize,
                          &last_n, &bt, &bm, &bsp, &store))
        return NULL;
    PyObject *result = NULL, *bytes[3] = {NULL, NULL, NULL};
    int width[3] = {0, 0, 0};
    sampler_set set = {NULL, 0, 0};
    task_scratch scr = {0};
    int64_t *out[3] = {NULL, NULL, NULL};
    Py_ssize_t used[3] = {0, 0, 0};
    ss_state st;
    hist_t hs;
    const sampler_t *sd, *ss;
    point_table *t = PyCapsule_GetPointer(capsule, POINTS_CAPSULE);
    if (t == NULL)
        goto done;
    if (t->which.obj == NULL) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.task: points has no which and speed");
        goto done;
    }
    if (bpt.len % 8 || bf.len != bpt.len || bl.len != bpt.len) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.task: point, first and last are int64 of one length");
        goto done;
    }
    Py_ssize_t G = bpt.len / 8;
    if (stop < 1 || bsize < 1 || last_n < 1 || last_n > bsize) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.task: stop, block_size >= 1 and 1 <= last_n <= "
                        "block_size");
        goto done;
    }
    const int64_t *pt = bpt.buf, *fi = bf.buf, *la = bl.buf;
    Py_ssize_t K = 0, total_n = 0;
    for (Py_ssize_t g = 0; g < G; g++) {
        if (pt[g] < 0 || pt[g] >= t->points || fi[g] < 0 || la[g] < fi[g] ||
            la[g] >= stop) {
            PyErr_SetString(PyExc_ValueError,
                            "_ckernel.task: a point outside the plan, or not 0 <= "
                            "first <= last < stop");
            goto done;
        }
        if (add_group(&K, &total_n, fi[g], la[g], stop, bsize, last_n, "task"))
            goto done;
    }
    if (store_of(store, total_n, "task", bst, &nst))
        goto done;
    double *st_d[3] = {NULL, NULL, NULL};
    int8_t *st_code = NULL;
    store_pointers(bst, nst, st_d, &st_code);
    if (parse_entropy(&be, &st) || parse_hist(&bh, &hs) ||
        check_len(&bt, "table", 8, 5 * G) || check_len(&bm, "moments", 8, 12 * G) ||
        check_len(&bsp, "spans", 8, 6 * G))
        goto done;
    if ((sd = sampler_of(&set, dsamp, "diameter", 8)) == NULL ||
        (ss = sampler_of(&set, ssamp, "speed", 4)) == NULL)
        goto done;
    if (task_scratch_new(&scr, K, G)) {
        PyErr_NoMemory();
        goto done;
    }
    int64_t *table = bt.buf;
    double *moments = bm.buf;
    int64_t *sp3 = bsp.buf;
    int oom;
    RELEASE_GIL
    oom = task_core(&st, &hs, sd, ss, speed_random, p, q, friction, t, pt, fi, la,
                    G, stop, bsize, last_n, &scr, st_d, st_code, out, used, width);
    for (Py_ssize_t g = 0; g < G && !oom; g++) {
        table[5 * g] = scr.nimp[g];
        memcpy(table + 5 * g + 1, scr.counts + 5 * g, 4 * sizeof *table);
        for (int h = 0; h < 3; h++) {
            memcpy(moments + 4 * (h * G + g), scr.sums + 12 * g + 4 * h,
                   4 * sizeof *scr.sums);
            /* (an empty span's lo is 0: occupied()) */
            sp3[(2 * h) * G + g] = scr.spans[6 * g + 2 * h];
            sp3[(2 * h + 1) * G + g] = scr.spans[6 * g + 2 * h + 1];
        }
    }
    ACQUIRE_GIL
    if (oom) {
        PyErr_NoMemory();
        goto done;
    }
    for (int h = 0; h < 3; h++) {
        bytes[h] = PyBytes_FromStringAndSize((const char *)out[h], used[h] * width[h]);
        if (bytes[h] == NULL)
            goto done;
    }
    result = Py_BuildValue("(NiNiNi)", bytes[0], width[0], bytes[1], width[1],
                           bytes[2], width[2]);
    bytes[0] = bytes[1] = bytes[2] = NULL; /* stolen, also on failure */
done:
    for (int h = 0; h < 3; h++) {
        Py_XDECREF(bytes[h]);
        PyMem_RawFree(out[h]);
    }
    task_scratch_free(&scr);
    sampler_set_free(&set);
    PyBuffer_Release(&be);
    PyBuffer_Release(&bh);
    PyBuffer_Release(&bpt);
    PyBuffer_Release(&bf);
    PyBuffer_Release(&bl);
    PyBuffer_Release(&bt);
    PyBuffer_Release(&bm);
    PyBuffer_Release(&bsp);
    for (int j = 0; j < nst; j++)
        PyBuffer_Release(&bst[j]);
    return result;
}

/* ------------------------------------------- a run's tasks inside the kernel */
/* tasks_new/tasks_run/tasks_harvest (kernel.KernelTasks): a fixed-size run's
 * tasks taken by the worker threads from a shared counter, each written
 * straight into the driver's table, so that no Python runs between them and
 * the GIL is not taken from the first task to the last (issue 31). */
#if defined(__GNUC__)
#define HAVE_TASK_LOOP 1
#define A_LOAD(p) __atomic_load_n((p), __ATOMIC_ACQUIRE)
#define A_STORE(p, v) __atomic_store_n((p), (v), __ATOMIC_RELEASE)
#define A_ADD(p, v) __atomic_fetch_add((p), (v), __ATOMIC_ACQ_REL)
#endif

/* A buffer of counts that the kernel allocated, handed to Python without a
 * copy (np.frombuffer reads it; freed with the last reference). */
typedef struct {
    PyObject_HEAD
    void *data;
    Py_ssize_t len;
} FlatObject;

static int
flat_getbuffer(PyObject *o, Py_buffer *view, int flags)
{
    FlatObject *f = (FlatObject *)o;
    return PyBuffer_FillInfo(view, o, f->data, f->len, 1, flags);
}

static void
flat_dealloc(PyObject *o)
{
    PyMem_RawFree(((FlatObject *)o)->data);
    Py_TYPE(o)->tp_free(o);
}

static PyBufferProcs flat_as_buffer = {flat_getbuffer, NULL};

static PyTypeObject FlatType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "microimpact.engine._ckernel.Flat",
    .tp_basicsize = sizeof(FlatObject),
    .tp_dealloc = flat_dealloc,
    .tp_as_buffer = &flat_as_buffer,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Counts written by the kernel (read-only bytes, no copy).",
};

static PyObject *
flat_new(void *data, Py_ssize_t len)
{
    FlatObject *f = PyObject_New(FlatObject, &FlatType);
    if (f == NULL)
        return NULL;
    f->data = data;
    f->len = len;
    return (PyObject *)f;
}

#ifdef HAVE_TASK_LOOP
enum { TD_COUNTS, TD_MOM = 1, TD_OFF = 4, TD_LEN = 7, TD_START = 10, TD_N = 13 };

typedef struct {
    ss_state st;
    hist_t hs;
    sampler_set set;
    const sampler_t *sd, *ss;
    int speed_random;
    double p, q, friction;
    PyObject *capsule; /* the plan's points, held */
    point_table *t;
    /* copies of the point, first, last (per group) and task starts given */
    int64_t *idx;
    const int64_t *pt, *fi, *la, *ts;
    Py_ssize_t G, ntasks, stop, bsize, last_n, rows;
    Py_buffer bd[TD_N]; /* the driver's table: see tasks_doc */
    int held_d;
    /* shared by the worker threads (atomics) */
    Py_ssize_t next;
    int halt, failed;
    int64_t impacts;
    int *done; /* per task: 1 once its rows and flats are written */
    /* per task: its flats (3, narrowed), their counts and item sizes; taken[i]
     * once harvested (under the GIL) */
    int64_t **flat;
    Py_ssize_t *used;
    int *width;
    char *taken;
} tasks_ctx;

static const char *TASKS_CAPSULE = "microimpact.engine._ckernel.tasks";

/* Frees `c` and what it holds (the flats not harvested too). */
static void
tasks_ctx_free(tasks_ctx *c)
{
    if (c->flat != NULL)
        for (Py_ssize_t i = 0; i < 3 * c->ntasks; i++)
            PyMem_RawFree(c->flat[i]);
    PyMem_Free(c->flat);
    PyMem_Free(c->used);
    PyMem_Free(c->width);
    PyMem_Free(c->done);
    PyMem_Free(c->taken);
    PyMem_Free(c->idx);
    sampler_set_free(&c->set);
    for (int j = 0; j < c->held_d; j++)
        PyBuffer_Release(&c->bd[j]);
    Py_XDECREF(c->capsule);
    PyMem_Free(c);
}

static void
tasks_free(PyObject *capsule)
{
    tasks_ctx *c = PyCapsule_GetPointer(capsule, TASKS_CAPSULE);
    if (c != NULL)
        tasks_ctx_free(c);
}

PyDoc_STRVAR(tasks_doc,
"tasks(entropy, common, points, point, first, last, starts, stop, block_size,\n"
"      last_n, table) -> capsule\n\n"
"A fixed-size run's tasks for tasks_run(): task i is groups starts[i] ..\n"
"starts[i+1]-1 (int64, from 0 to the groups' count), group g blocks first[g] ..\n"
"last[g] of point point[g] (as task()'s), every group of a distinct point.\n"
"`table` is the driver's table, 13 arrays of R rows, written at row point[g]\n"
"for group g: counts int64[R][5] (impacts, shadowed, captured, reimpact,\n"
"rolling); the moments float64[R][4] of e_m, mu_m, psi_f; their spans'\n"
"offsets (int32[R], 0 where empty), lengths (int32[R]) and starts in their\n"
"task's flat counts (int64[R]). The same rows and counts as task() of each\n"
"task, bit for bit.");

static int
tasks_buffer(PyObject *o, Py_buffer *b, const char *name, Py_ssize_t item,
             Py_ssize_t need, int writable)
{
    if (PyObject_GetBuffer(o, b, writable ? PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS
                                          : PyBUF_C_CONTIGUOUS))
        return -1;
    if (b->len % item != 0 || b->len / item != need) {
        PyErr_Format(PyExc_ValueError,
                     "_ckernel.tasks: %s holds %zd bytes, needs %zd items of %zd",
                     name, b->len, need, item);
        PyBuffer_Release(b);
        return -1;
    }
    return 0;
}

static PyObject *
ck_tasks(PyObject *self, PyObject *args)
{
    Py_buffer be, bh;
    PyObject *dsamp, *ssamp, *capsule, *garr[4], *table;
    int speed_random;
    double p, q, friction;
    Py_ssize_t stop, bsize, last_n;
    if (!PyArg_ParseTuple(args, "y*(OOpdddy*)O!OOOOnnnO!:tasks", &be, &dsamp, &ssamp,
                          &speed_random, &p, &q, &friction, &bh, &PyCapsule_Type,
                          &capsule, &garr[0], &garr[1], &garr[2], &garr[3], &stop,
                          &bsize, &last_n, &PyTuple_Type, &table))
        return NULL;
    PyObject *result = NULL;
    Py_buffer bg[4]; /* point, first, last, starts: copied, then released */
    int held_g = 0;
    tasks_ctx *c = PyMem_Calloc(1, sizeof *c);
    if (c == NULL) {
        PyErr_NoMemory();
        goto fail;
    }
    c->t = PyCapsule_GetPointer(capsule, POINTS_CAPSULE);
    if (c->t == NULL)
        goto fail;
    if (c->t->which.obj == NULL) {
        PyErr_SetString(PyExc_ValueError, "_ckernel.tasks: points has no which and speed");
        goto fail;
    }
    Py_INCREF(capsule);
    c->capsule = capsule;
    if (parse_entropy(&be, &c->st) || parse_hist(&bh, &c->hs))
        goto fail;
    if ((c->sd = sampler_of(&c->set, dsamp, "diameter", 8)) == NULL ||
        (c->ss = sampler_of(&c->set, ssamp, "speed", 4)) == NULL)
        goto fail;
    c->speed_random = speed_random;
    c->p = p;
    c->q = q;
    c->friction = friction;
    if (stop < 1 || bsize < 1 || last_n < 1 || last_n > bsize) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.tasks: stop, block_size >= 1 and 1 <= last_n <= "
                        "block_size");
        goto fail;
    }
    c->stop = stop;
    c->bsize = bsize;
    c->last_n = last_n;
    if (PyObject_GetBuffer(garr[0], &bg[0], PyBUF_C_CONTIGUOUS))
        goto fail;
    held_g = 1;
    c->G = bg[0].len / 8;
    const char *gname[3] = {"point", "first", "last"};
    for (int j = 1; j < 3; j++) {
        if (tasks_buffer(garr[j], &bg[j], gname[j], 8, c->G, 0))
            goto fail;
        held_g = j + 1;
    }
    if (PyObject_GetBuffer(garr[3], &bg[3], PyBUF_C_CONTIGUOUS))
        goto fail;
    held_g = 4;
    if (bg[0].len % 8 || bg[3].len % 8 || bg[3].len < 16) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.tasks: point, first, last and starts are int64");
        goto fail;
    }
    c->ntasks = bg[3].len / 8 - 1;
    /* copies of the index arrays, checked below: the callers' arrays could
     * change while the threads read them, or overlap the table */
    c->idx = PyMem_Malloc((3 * c->G + c->ntasks + 1 + 1) * sizeof *c->idx);
    if (c->idx == NULL) {
        PyErr_NoMemory();
        goto fail;
    }
    for (int j = 0; j < 3; j++)
        memcpy(c->idx + j * c->G, bg[j].buf, c->G * sizeof *c->idx);
    memcpy(c->idx + 3 * c->G, bg[3].buf, (c->ntasks + 1) * sizeof *c->idx);
    c->pt = c->idx;
    c->fi = c->idx + c->G;
    c->la = c->idx + 2 * c->G;
    c->ts = c->idx + 3 * c->G;
    if (PyTuple_GET_SIZE(table) != TD_N) {
        PyErr_SetString(PyExc_ValueError, "_ckernel.tasks: table is 13 arrays");
        goto fail;
    }
    if (PyObject_GetBuffer(PyTuple_GET_ITEM(table, 0), &c->bd[0],
                           PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS))
        goto fail;
    c->held_d = 1;
    c->rows = c->bd[0].len / 40;
    if (c->bd[0].len % 40) {
        PyErr_SetString(PyExc_ValueError, "_ckernel.tasks: counts is int64[R][5]");
        goto fail;
    }
    for (int j = 1; j < TD_N; j++) {
        Py_ssize_t item = j < TD_OFF ? 32 : (j < TD_START ? 4 : 8);
        if (tasks_buffer(PyTuple_GET_ITEM(table, j), &c->bd[j], "a table array",
                         item, c->rows, 1))
            goto fail;
        c->held_d = j + 1;
    }
    /* the tasks and groups (every group's row in the table, once) */
    if (c->ts[0] != 0 || c->ts[c->ntasks] != c->G) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.tasks: starts run from 0 to the groups' count");
        goto fail;
    }
    for (Py_ssize_t i = 0; i < c->ntasks; i++)
        if (c->ts[i + 1] < c->ts[i]) {
            PyErr_SetString(PyExc_ValueError, "_ckernel.tasks: starts decrease");
            goto fail;
        }
    for (Py_ssize_t g = 0; g < c->G; g++)
        if (c->pt[g] < 0 || c->pt[g] >= c->t->points || c->pt[g] >= c->rows ||
            c->fi[g] < 0 || c->la[g] < c->fi[g] || c->la[g] >= stop ||
            (g && c->pt[g] <= c->pt[g - 1])) {
            PyErr_SetString(PyExc_ValueError,
                            "_ckernel.tasks: a point outside the plan or the table, "
                            "points not increasing, or not 0 <= first <= last < stop");
            goto fail;
        }
    for (Py_ssize_t i = 0; i < c->ntasks; i++) { /* each task's sizes fit */
        Py_ssize_t K = 0, n = 0;
        for (Py_ssize_t g = c->ts[i]; g < c->ts[i + 1]; g++)
            if (add_group(&K, &n, c->fi[g], c->la[g], stop, bsize, last_n, "tasks"))
                goto fail;
    }
    Py_ssize_t nt = c->ntasks ? c->ntasks : 1;
    c->flat = PyMem_Calloc(3 * nt, sizeof *c->flat);
    c->used = PyMem_Calloc(3 * nt, sizeof *c->used);
    c->width = PyMem_Calloc(3 * nt, sizeof *c->width);
    c->done = PyMem_Calloc(nt, sizeof *c->done);
    c->taken = PyMem_Calloc(nt, 1);
    if (c->flat == NULL || c->used == NULL || c->width == NULL || c->done == NULL ||
        c->taken == NULL) {
        PyErr_NoMemory();
        goto fail;
    }
    result = PyCapsule_New(c, TASKS_CAPSULE, tasks_free);
    if (result == NULL)
        goto fail;
    c = NULL;
fail:
    if (c != NULL)
        tasks_ctx_free(c);
    for (int j = 0; j < held_g; j++)
        PyBuffer_Release(&bg[j]);
    PyBuffer_Release(&be);
    PyBuffer_Release(&bh);
    return result;
}

/* Task i of `c` (no GIL): its rows into the table, its flats kept; -1 where
 * memory ran out. */
static int
tasks_one(tasks_ctx *c, Py_ssize_t i)
{
    Py_ssize_t g0 = c->ts[i], G = c->ts[i + 1] - g0, K = 0;
    const int64_t *pt = c->pt + g0, *fi = c->fi + g0, *la = c->la + g0;
    for (Py_ssize_t g = 0; g < G; g++)
        K += la[g] - fi[g] + 1;
    task_scratch scr = {0};
    int64_t *out[3] = {NULL, NULL, NULL};
    Py_ssize_t used[3] = {0, 0, 0};
    int width[3] = {0, 0, 0};
    double *const st_d[3] = {NULL, NULL, NULL};
    int oom = task_scratch_new(&scr, K, G) ||
              task_core(&c->st, &c->hs, c->sd, c->ss, c->speed_random, c->p, c->q,
                        c->friction, c->t, pt, fi, la, G, c->stop, c->bsize,
                        c->last_n, &scr, st_d, NULL, out, used, width);
    if (!oom) {
        int64_t *tc = c->bd[TD_COUNTS].buf, total = 0;
        int64_t at[3] = {0, 0, 0};
        for (Py_ssize_t g = 0; g < G; g++) {
            Py_ssize_t k = pt[g];
            tc[5 * k] = scr.nimp[g];
            memcpy(tc + 5 * k + 1, scr.counts + 5 * g, 4 * sizeof *tc);
            total += scr.nimp[g];
            for (int h = 0; h < 3; h++) {
                const int64_t *span = scr.spans + 6 * g + 2 * h; /* lo, length */
                double *m = c->bd[TD_MOM + h].buf;
                int32_t *off = c->bd[TD_OFF + h].buf, *len = c->bd[TD_LEN + h].buf;
                int64_t *start = c->bd[TD_START + h].buf;
                memcpy(m + 4 * k, scr.sums + 12 * g + 4 * h, 4 * sizeof *m);
                off[k] = (int32_t)span[0];
                len[k] = (int32_t)span[1];
                start[k] = at[h];
                at[h] += span[1];
            }
        }
        for (int h = 0; h < 3; h++) {
            /* the narrowed counts copied out, the int64 buffer freed: shrunk
             * in place, each task's buffer left 7/8 of it as holes that the
             * next task's could not use (a 10^6-point sweep's peak +45 %) */
            Py_ssize_t bytes = used[h] * width[h];
            int64_t *small = PyMem_RawMalloc(bytes ? bytes : 1);
            if (small == NULL) {
                oom = 1;
                break;
            }
            memcpy(small, out[h], bytes);
            c->flat[3 * i + h] = small;
            c->used[3 * i + h] = used[h];
            c->width[3 * i + h] = width[h];
        }
        if (oom) /* (the task's flats made so far) */
            for (int h = 0; h < 3; h++) {
                PyMem_RawFree(c->flat[3 * i + h]);
                c->flat[3 * i + h] = NULL;
            }
        else {
            A_ADD(&c->impacts, total);
            A_STORE(&c->done[i], 1);
        }
    }
    for (int h = 0; h < 3; h++)
        PyMem_RawFree(out[h]);
    task_scratch_free(&scr);
    return oom ? -1 : 0;
}

static tasks_ctx *
tasks_of(PyObject *args, const char *fmt)
{
    PyObject *capsule;
    if (!PyArg_ParseTuple(args, fmt, &PyCapsule_Type, &capsule))
        return NULL;
    return PyCapsule_GetPointer(capsule, TASKS_CAPSULE);
}

PyDoc_STRVAR(tasks_run_doc,
"tasks_run(tasks) -> int\n\n"
"Run tasks of tasks() (a capsule) until none is left or tasks_halt() is\n"
"called, the GIL released throughout: each worker thread calls it once, and\n"
"the threads take the tasks in order from a shared counter. Returns the tasks\n"
"this call ran; MemoryError where memory ran out (the other calls then stop\n"
"after their current task).");

static PyObject *
ck_tasks_run(PyObject *self, PyObject *args)
{
    tasks_ctx *c = tasks_of(args, "O!:tasks_run");
    if (c == NULL)
        return NULL;
    Py_ssize_t ran = 0;
    int oom = 0;
    RELEASE_GIL
    while (!A_LOAD(&c->halt)) {
        Py_ssize_t i = A_ADD(&c->next, 1);
        if (i >= c->ntasks)
            break;
        if (tasks_one(c, i)) {
            oom = 1;
            A_STORE(&c->failed, 1);
            A_STORE(&c->halt, 1);
            break;
        }
        ran++;
    }
    ACQUIRE_GIL
    if (oom)
        return PyErr_NoMemory();
    return PyLong_FromSsize_t(ran);
}

PyDoc_STRVAR(tasks_halt_doc,
"tasks_halt(tasks, halt) -> None\n\n"
"With `halt` true, tasks_run() calls return after their current task (tasks\n"
"not taken stay to run); false lets later calls take tasks again (not after\n"
"a MemoryError).");

static PyObject *
ck_tasks_halt(PyObject *self, PyObject *args)
{
    PyObject *capsule;
    int halt;
    if (!PyArg_ParseTuple(args, "O!p:tasks_halt", &PyCapsule_Type, &capsule, &halt))
        return NULL;
    tasks_ctx *c = PyCapsule_GetPointer(capsule, TASKS_CAPSULE);
    if (c == NULL)
        return NULL;
    A_STORE(&c->halt, halt || A_LOAD(&c->failed));
    Py_RETURN_NONE;
}

PyDoc_STRVAR(tasks_harvest_doc,
"tasks_harvest(tasks) -> (impacts, [(i, e, e_size, mu, mu_size, lat, lat_size)])\n\n"
"The impacts of the tasks done so far (read after the list: it may count a\n"
"task that finished since), and each task done since the last\n"
"harvest, in task order: its index and each histogram's flat counts (a\n"
"read-only buffer, no copy) with their item size (1, 2, 4 or 8).");

static PyObject *
ck_tasks_harvest(PyObject *self, PyObject *args)
{
    tasks_ctx *c = tasks_of(args, "O!:tasks_harvest");
    if (c == NULL)
        return NULL;
    PyObject *list = PyList_New(0);
    if (list == NULL)
        return NULL;
    for (Py_ssize_t i = 0; i < c->ntasks; i++) {
        if (c->taken[i] || !A_LOAD(&c->done[i]))
            continue;
        PyObject *f[3] = {NULL, NULL, NULL}, *item = NULL;
        for (int h = 0; h < 3; h++) {
            f[h] = flat_new(NULL, 0); /* (its data once all three are made) */
            if (f[h] == NULL)
                goto fail;
        }
        for (int h = 0; h < 3; h++) { /* the objects' now */
            ((FlatObject *)f[h])->data = c->flat[3 * i + h];
            ((FlatObject *)f[h])->len = c->used[3 * i + h] * c->width[3 * i + h];
            c->flat[3 * i + h] = NULL;
        }
        c->taken[i] = 1;
        item = Py_BuildValue("(nNiNiNi)", i, f[0], c->width[3 * i], f[1],
                             c->width[3 * i + 1], f[2], c->width[3 * i + 2]);
        f[0] = f[1] = f[2] = NULL; /* stolen */
        if (item == NULL || PyList_Append(list, item)) {
            Py_XDECREF(item);
            goto fail;
        }
        Py_DECREF(item);
        continue;
    fail:
        for (int h = 0; h < 3; h++)
            Py_XDECREF(f[h]);
        Py_DECREF(list);
        return NULL;
    }
    return Py_BuildValue("(LN)", (long long)A_LOAD(&c->impacts), list);
}
#endif /* HAVE_TASK_LOOP */

/* ------------------------------------------------- wall-law node statistics */
enum { WV_EN, WV_ET, WV_MU, WV_ANGLE, WV_LATERAL, WV_SPEED, WV_COUNT };
enum { WS_IMPACTS, WS_CAPTURED, WS_REBOUNDS, WS_REIMPACTS, WS_MEAN,
       WS_STD = WS_MEAN + 5, WS_COUNT = WS_STD + 5 };

/* The wall-law variables of m rebounds (ck_wall_rows), written branch-free
 * (every operand formed, then selected). GCC 12 does not vectorise these loops
 * yet ("control flow in loop" on the AVX2 and AVX-512 clones), so they run
 * scalar: ~14 ns per rebound with the compaction and the sums. */
static CLONES __attribute__((noinline)) void
wall_outcomes(const double *restrict en, const double *restrict mu_,
              double *restrict et, double *restrict ang, double *restrict lat,
              double *restrict spd, Py_ssize_t m, double s, double c, int areal,
              int64_t *reimp)
{
    int64_t n_reimp = 0;
    /* branch-free over the rebounds (vectorised; e_t is NaN where the
     * incidence is normal, c = 0) */
    const double cd = c > 0 ? c : 1.0;
    if (areal) {
        for (Py_ssize_t j = 0; j < m; j++) {
            double e = en[j], mu = mu_[j];
            double u_z = e * s;
            double u_x = c - mu * (1.0 + e) * s;
            double uy = -u_x * lat[j];
            double u_y = lat[j] == 0.0 ? 0.0 : uy;
            et[j] = u_x / cd;
            ang[j] = atan2_deg(u_z, u_x);
            lat[j] = atan2_deg(u_y, sqrt(u_x * u_x + u_z * u_z));
            spd[j] = sqrt(u_x * u_x + u_y * u_y + u_z * u_z);
            n_reimp += e < 0.0;
        }
    } else { /* u_y = 0: the lateral angle is 0 */
        for (Py_ssize_t j = 0; j < m; j++) {
            double e = en[j], mu = mu_[j];
            double u_z = e * s;
            double u_x = c - mu * (1.0 + e) * s;
            et[j] = u_x / cd;
            ang[j] = atan2_deg(u_z, u_x);
            lat[j] = 0.0;
            spd[j] = sqrt(u_x * u_x + 0.0 * 0.0 + u_z * u_z);
            n_reimp += e < 0.0;
        }
    }
    *reimp += n_reimp;
}

PyDoc_STRVAR(wall_rows_doc,
"wall_rows(P, S, e_m, mu_m, psi, outcome, geom, out, stats) -> None\n\n"
"The wall-law outcomes of P nodes of S impacts each (the arrays of specs()'s\n"
"`store`, rows of S): per node, its rebounds' e_n, e_t, mu, rebound angle,\n"
"lateral angle [deg] and speed ratio (wall_law.build.node_outcomes; the angles by\n"
"kernel.atan2_deg, the hypotenuse by a square root) written in draw order to\n"
"out float64[6][P][S], the rest of each row +inf; and stats float64[P][14]:\n"
"impacts, captured, rebounds, reimpacts (e_n < 0), the means of the first five\n"
"(a sequential sum / count), their standard deviations (ddof 1, sequential\n"
"sums). geom float64[P][3]: sin theta, cos theta (0 at 90 deg) and 1.0 for an\n"
"areal surface's node (then u_y = -u_x tan(psi), 0 where sin(psi) = 0).\n\n"
"With `reservoir` float64[V'][P][R], `slots` int64[V'][2] and `lat_max`, also\n"
"each node's reservoirs: row v' holds the first min(R, rebounds) values of\n"
"variable slots[v'][0] in draw order, NaN after them; kind slots[v'][1] 1\n"
"clips them to [-lat_max, lat_max], 2 to at most 1.0 (wall_law.build).");

static PyObject *
ck_wall_rows(PyObject *self, PyObject *args)
{
    Py_ssize_t P, S;
    Py_buffer be, bm, bp, bc, bg, bo, bs;
    Py_buffer br = {0}, bk = {0};
    double lat_max = 90.0;
    if (!PyArg_ParseTuple(args, "nny*y*y*y*y*w*w*|w*y*d:wall_rows", &P, &S, &be, &bm,
                          &bp, &bc, &bg, &bo, &bs, &br, &bk, &lat_max))
        return NULL;
    PyObject *result = NULL;
    Py_ssize_t VR = 0, R = 0;
    const int64_t *slots = NULL;
    double *res = NULL;
    if ((br.obj == NULL) != (bk.obj == NULL)) {
        PyErr_SetString(PyExc_TypeError, "_ckernel.wall_rows: reservoir and slots "
                                         "together");
        goto done;
    }
    if (br.obj != NULL) {
        VR = bk.len / 16;
        slots = bk.buf;
        res = br.buf;
        if (bk.len % 16 || VR < 1 || P < 1 || br.len % (8 * VR * P)) {
            PyErr_SetString(PyExc_ValueError,
                            "_ckernel.wall_rows: slots is int64[V'][2], reservoir "
                            "float64[V'][P][R]");
            goto done;
        }
        R = br.len / (8 * VR * P);
        for (Py_ssize_t i = 0; i < VR; i++)
            if (slots[2 * i] < 0 || slots[2 * i] >= WV_COUNT || slots[2 * i + 1] < 0 ||
                slots[2 * i + 1] > 2) {
                PyErr_SetString(PyExc_ValueError,
                                "_ckernel.wall_rows: a slot is (variable 0..5, kind "
                                "0..2)");
                goto done;
            }
    }
    if (P < 0 || S < 0 || check_len(&be, "e_m", 8, P * S) ||
        check_len(&bm, "mu_m", 8, P * S) || check_len(&bp, "psi", 8, P * S) ||
        check_len(&bc, "outcome", 1, P * S) || check_len(&bg, "geom", 8, 3 * P) ||
        check_len(&bo, "out", 8, WV_COUNT * P * S) ||
        check_len(&bs, "stats", 8, WS_COUNT * P))
        goto done;
    const double *em = be.buf, *mum = bm.buf, *psi = bp.buf, *geom = bg.buf;
    const int8_t *code = bc.buf;
    double *out = bo.buf, *stats = bs.buf;
    RELEASE_GIL
    for (Py_ssize_t r = 0; r < P; r++) {
        const double s = geom[3 * r], c = geom[3 * r + 1];
        const int areal = geom[3 * r + 2] != 0.0;
        double *o[WV_COUNT];
        for (int v = 0; v < WV_COUNT; v++)
            o[v] = out + ((Py_ssize_t)v * P + r) * S;
        int64_t n_imp = 0, n_capt = 0, n_reimp = 0;
        Py_ssize_t m = 0;
        /* the rebounds, in draw order: e_n, mu and psi into their rows */
        double *pw = o[WV_SPEED]; /* psi, until the speed ratio overwrites it */
        for (Py_ssize_t j = 0; j < S; j++) {
            Py_ssize_t i = r * S + j;
            int8_t k = code[i];
            n_imp += k != 2;
            n_capt += k == 1;
            o[WV_EN][m] = em[i];
            o[WV_MU][m] = mum[i];
            pw[m] = psi[i];
            m += k == 0;
        }
        double *restrict en = o[WV_EN], *restrict mu_ = o[WV_MU];
        double *restrict et = o[WV_ET], *restrict ang = o[WV_ANGLE];
        double *restrict lat = o[WV_LATERAL], *restrict spd = o[WV_SPEED];
        if (areal) { /* tan(psi), 0 where sin(psi) = 0 (in the plane) */
            for (Py_ssize_t j = 0; j < m; j++) {
                double pr = spd[j] * (3.141592653589793 / 180.0);
                lat[j] = sin(pr) == 0.0 ? 0.0 : tan(pr);
            }
        }
        wall_outcomes(en, mu_, et, ang, lat, spd, m, s, c, areal, &n_reimp);
        if (!(c > 0))
            for (Py_ssize_t j = 0; j < m; j++)
                et[j] = NAN;
        for (int v = 0; v < WV_COUNT; v++)
            for (Py_ssize_t j = m; j < S; j++)
                o[v][j] = INFINITY;
        double *st = stats + (Py_ssize_t)WS_COUNT * r;
        st[WS_IMPACTS] = (double)n_imp;
        st[WS_CAPTURED] = (double)n_capt;
        st[WS_REBOUNDS] = (double)m;
        st[WS_REIMPACTS] = (double)n_reimp;
        double div = m > 0 ? (double)m : 1.0, dof = m > 1 ? (double)(m - 1) : 1.0;
        /* sequential sums of each variable (five independent chains at once) */
        double sum[5] = {0.0, 0.0, 0.0, 0.0, 0.0}, ss[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
        for (Py_ssize_t j = 0; j < m; j++)
            for (int v = 0; v < 5; v++)
                sum[v] += o[v][j];
        double mean[5];
        for (int v = 0; v < 5; v++)
            mean[v] = sum[v] / div;
        for (Py_ssize_t j = 0; j < m; j++)
            for (int v = 0; v < 5; v++) {
                double d = o[v][j] - mean[v];
                ss[v] += d * d;
            }
        for (int v = 0; v < 5; v++) {
            st[WS_MEAN + v] = mean[v];
            st[WS_STD + v] = sqrt(ss[v] / dof);
        }
        /* the reservoirs: the first rebounds in draw order (before any sort) */
        for (Py_ssize_t i = 0; i < VR; i++) {
            const double *x = o[slots[2 * i]];
            const int64_t kind = slots[2 * i + 1];
            double *to = res + (i * P + r) * R;
            Py_ssize_t k = m < R ? m : R;
            for (Py_ssize_t j = 0; j < k; j++) {
                double y = x[j];
                if (kind == 1) /* np.clip: NaN stays NaN */
                    y = y < -lat_max ? -lat_max : (y > lat_max ? lat_max : y);
                else if (kind == 2) /* np.minimum(y, 1.0) */
                    y = y > 1.0 ? 1.0 : y;
                to[j] = y;
            }
            for (Py_ssize_t j = k; j < R; j++)
                to[j] = NAN;
        }
    }
    ACQUIRE_GIL
    result = Py_None;
    Py_INCREF(result);
done:
    if (br.obj != NULL)
        PyBuffer_Release(&br);
    if (bk.obj != NULL)
        PyBuffer_Release(&bk);
    PyBuffer_Release(&be);
    PyBuffer_Release(&bm);
    PyBuffer_Release(&bp);
    PyBuffer_Release(&bc);
    PyBuffer_Release(&bg);
    PyBuffer_Release(&bo);
    PyBuffer_Release(&bs);
    return result;
}

PyDoc_STRVAR(wall_quantiles_doc,
"wall_quantiles(P, S, V, out, stats, q, means, stds, quant) -> None\n\n"
"After wall_rows() and a sort of each of the first V rows of `out`\n"
"(float64[>= V][P][S]): per variable v and node r, with n its rebounds (stats\n"
"float64[P][14], column 2), the quantiles q (float64[Q]) of out[v][r][:n] as\n"
"np.quantile's linear rule computes them (its operations: the virtual index\n"
"(n - 1) q, its floor, the two-sided lerp), and the mean and standard\n"
"deviation of stats, into quant float64[V][P][Q], means and stds float64[V][P]:\n"
"NaN where the node has no rebound or the mean is NaN, the deviation also where\n"
"n < 2 (wall_law.build._node_rows).");

static PyObject *
ck_wall_quantiles(PyObject *self, PyObject *args)
{
    Py_ssize_t P, S, V;
    Py_buffer bo, bs, bq, bm, bd, bu;
    if (!PyArg_ParseTuple(args, "nnny*y*y*w*w*w*:wall_quantiles", &P, &S, &V, &bo,
                          &bs, &bq, &bm, &bd, &bu))
        return NULL;
    PyObject *result = NULL;
    Py_ssize_t Q = bq.len / 8;
    if (P < 0 || S < 1 || V < 1 || V > 5 || bq.len % 8 ||
        check_len(&bo, "out", 8, V * P * S) || check_len(&bs, "stats", 8, WS_COUNT * P) ||
        check_len(&bm, "means", 8, V * P) || check_len(&bd, "stds", 8, V * P) ||
        check_len(&bu, "quant", 8, V * P * Q)) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError,
                            "_ckernel.wall_quantiles: P >= 0, S >= 1, 1 <= V <= 5");
        goto done;
    }
    const double *out = bo.buf, *stats = bs.buf, *q = bq.buf;
    double *means = bm.buf, *stds = bd.buf, *quant = bu.buf;
    RELEASE_GIL
    const double top = (double)(S - 1);
    for (Py_ssize_t r = 0; r < P; r++) {
        const double *st = stats + (Py_ssize_t)WS_COUNT * r;
        const double nf = st[WS_REBOUNDS];
        for (Py_ssize_t v = 0; v < V; v++) {
            const double mean = st[WS_MEAN + v];
            const int empty = nf == 0.0 || mean != mean;
            means[v * P + r] = empty ? NAN : mean;
            stds[v * P + r] = empty || nf < 2.0 ? NAN : st[WS_STD + v];
            const double *row = out + (v * P + r) * S;
            double *to = quant + (v * P + r) * Q;
            for (Py_ssize_t j = 0; j < Q && empty; j++)
                to[j] = NAN;
            for (Py_ssize_t j = 0; j < Q && !empty; j++) {
                double x = (nf - 1.0) * q[j];
                double prev = floor(x);
                int last = x >= nf - 1.0;
                double x0 = last ? nf - 1.0 : prev, x1 = last ? nf - 1.0 : prev + 1.0;
                /* np.clip(., 0, top), then the cast to an index */
                x0 = x0 < 0.0 ? 0.0 : (x0 > top ? top : x0);
                x1 = x1 < 0.0 ? 0.0 : (x1 > top ? top : x1);
                double a = row[(Py_ssize_t)x0], b = row[(Py_ssize_t)x1];
                double g = x - (last ? -1.0 : prev);
                double diff = b - a;
                to[j] = g >= 0.5 ? b - diff * (1.0 - g) : a + diff * g;
            }
        }
    }
    ACQUIRE_GIL
    result = Py_None;
    Py_INCREF(result);
done:
    PyBuffer_Release(&bo);
    PyBuffer_Release(&bs);
    PyBuffer_Release(&bq);
    PyBuffer_Release(&bm);
    PyBuffer_Release(&bd);
    PyBuffer_Release(&bu);
    return result;
}

PyDoc_STRVAR(simd_doc,
"simd(flag=None) -> bool\n\n"
"Whether the AVX-512 lookups run (the CPU has AVX-512F/DQ/CD/VL); with `flag`\n"
"False they are switched off (True switches them back on where the CPU has\n"
"them). Both give the same bits; this exists for the tests.");

static PyObject *
ck_simd(PyObject *self, PyObject *args)
{
    int flag = -1;
    if (!PyArg_ParseTuple(args, "|p:simd", &flag))
        return NULL;
#ifdef HAVE_AVX512_PATH
    if (flag == 0)
        have_avx512 = 0;
    else if (flag == 1)
        have_avx512 = __builtin_cpu_supports("avx512f") &&
                      __builtin_cpu_supports("avx512dq") &&
                      __builtin_cpu_supports("avx512cd") &&
                      __builtin_cpu_supports("avx512vl");
    return PyBool_FromLong(have_avx512);
#else
    return PyBool_FromLong(0);
#endif
}

PyDoc_STRVAR(reach_cut_doc,
"reach_cut(rows, width, sin_col, cos_col, st, ct) -> (j, a_j, b_j)\n\n"
"The first cell j of an angle table (float64 rows of `width` columns, the last\n"
"row the end sentinel) whose end is not reachable at the apparent angle theta\n"
"(st, ct = sin, cos theta), with sin(theta - phi) at its start (a_j) and end\n"
"(b_j); j = -1 where every cell is reachable. The operations of plan._reach\n"
"and plan._first_blocked_of, in the same order (no contraction: the same bits).");

static PyObject *
ck_reach_cut(PyObject *self, PyObject *args)
{
    Py_buffer br;
    Py_ssize_t W, cs, cc;
    double st, ct;
    if (!PyArg_ParseTuple(args, "y*nnndd:reach_cut", &br, &W, &cs, &cc, &st, &ct))
        return NULL;
    PyObject *result = NULL;
    if (W < 2 || cs < 0 || cc < 0 || cs + 1 >= W || cc + 1 >= W ||
        br.len % (8 * W) || br.len < 8 * W) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.reach_cut: rows of `width` float64 columns "
                        "(at least the sentinel), 0 <= sin_col, cos_col < width - 1");
        goto done;
    }
    const double *rows = br.buf;
    const Py_ssize_t n = br.len / (8 * W) - 1; /* the last row is the sentinel */
    Py_ssize_t j = -1;
    double a = 0.0, b = 0.0;
    RELEASE_GIL
    for (Py_ssize_t i = 0; i < n; i++) {
        const double *r = rows + i * W;
        /* _reach at f = 0 and f = 1: s = lo + f * span, st * c - ct * s */
        const double s0 = r[cs] + 0.0 * r[cs + 1], c0 = r[cc] + 0.0 * r[cc + 1];
        const double s1 = r[cs] + 1.0 * r[cs + 1], c1 = r[cc] + 1.0 * r[cc + 1];
        const double ai = st * c0 - ct * s0, bi = st * c1 - ct * s1;
        const double end = r[cs + 1] == 0.0 ? ai : bi;
        if (!(end > 0.0)) {
            j = i;
            a = ai;
            b = bi;
            break;
        }
    }
    ACQUIRE_GIL
    result = Py_BuildValue("ndd", j, a, b);
done:
    PyBuffer_Release(&br);
    return result;
}

PyDoc_STRVAR(span_quantiles_doc,
"span_quantiles(counts, kind, start, length, offset, size, edges, q, out)\n\n"
"Quantiles q (float64, each in [0, 1]) of histograms stored as spans (summary.Spans:\n"
"row i is dense bins offset[i] .. offset[i] + length[i] - 1 of `size` bins, its\n"
"counts counts[start[i] : start[i] + length[i]]; start, length, offset int64),\n"
"linear within a bin on `edges` (float64, size - 1 of them), into `out` (float64,\n"
"rows x len(q), row-major): -inf/+inf in the under/overflow bin; rows of length 0\n"
"or with no counts are left as they are. `kind` is the counts' dtype character ('B', 'H', 'i', 'I',\n"
"'q'). Each row's totals must be below 2**52. The definitions and operations of\n"
"summary.histogram_quantiles, row by row (the same bits), with the GIL released.");

/* Histogram counts of any compact dtype (summary.compact_counts), by its NumPy
   character `kind`: 'B' uint8, 'H' uint16, 'i' int32, 'I' uint32, 'q' int64. */
static Py_ssize_t
count_itemsize(int kind)
{
    return kind == 'B' ? 1 : kind == 'H' ? 2 : (kind == 'i' || kind == 'I') ? 4
         : kind == 'q' ? 8 : 0;
}

#define COUNT_AT(k)                                                            \
    (kind == 'B'   ? (int64_t)((const uint8_t *)cv)[k]                         \
     : kind == 'H' ? (int64_t)((const uint16_t *)cv)[k]                        \
     : kind == 'i' ? (int64_t)((const int32_t *)cv)[k]                         \
     : kind == 'I' ? (int64_t)((const uint32_t *)cv)[k]                        \
                   : ((const int64_t *)cv)[k])

static PyObject *
ck_span_quantiles(PyObject *self, PyObject *args)
{
    Py_buffer bc, bs, bl, bo, be, bq, bout;
    int kind;
    Py_ssize_t size;
    if (!PyArg_ParseTuple(args, "y*Cy*y*y*ny*y*w*:span_quantiles", &bc, &kind, &bs,
                          &bl, &bo, &size, &be, &bq, &bout))
        return NULL;
    PyObject *result = NULL;
    const Py_ssize_t item = count_itemsize(kind);
    const Py_ssize_t rows = bs.len / 8, nq = bq.len / 8, nc = item ? bc.len / item : 0;
    int bad = item == 0 || bc.len % (item ? item : 1) || bs.len % 8 ||
              bl.len != bs.len || bo.len != bs.len || bq.len % 8 || be.len % 8 ||
              size < 2 || be.len / 8 != size - 1 || bout.len != 8 * rows * nq;
    const int64_t *st = bs.buf, *ln = bl.buf, *off = bo.buf;
    const double *edges = be.buf, *q = bq.buf;
    for (Py_ssize_t k = 0; !bad && k < nq; k++)
        bad = !(q[k] >= 0.0 && q[k] <= 1.0);
    for (Py_ssize_t r = 0; !bad && r < rows; r++)
        bad = ln[r] < 0 || (ln[r] > 0 && (st[r] < 0 || st[r] + ln[r] > nc ||
                                          off[r] < 0 || off[r] + ln[r] > size));
    if (bad) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.span_quantiles: counts of dtype `kind`, int64 "
                        "start/length/offset of one length whose spans lie in counts "
                        "and in `size` >= 2 bins, size - 1 float64 edges, q in [0, 1], "
                        "out of rows x len(q) float64");
        goto done;
    }
    const void *cv = bc.buf;
    double *out = bout.buf;
    int too_big = 0;
    RELEASE_GIL
    for (Py_ssize_t r = 0; r < rows && !too_big; r++) {
        const int64_t n = ln[r];
        if (n <= 0)
            continue;
        const int64_t s0 = st[r], o = off[r];
        int64_t total = 0;
        for (int64_t j = 0; j < n; j++)
            total += COUNT_AT(s0 + j);
        if (total >= ((int64_t)1 << 52)) {
            too_big = 1;
            break;
        }
        if (total == 0)
            continue; /* no values: left as they are, as an empty row */
        const double tf = (double)total;
        for (Py_ssize_t k = 0; k < nq; k++) {
            const double qk = q[k];
            /* least c in [0, total + 1] with float(c) / float(total) >= qk */
            double c0 = floor(qk * tf);
            int64_t c = c0 < 0.0 ? 0 : c0 > tf + 1.0 ? total + 1 : (int64_t)c0;
            while (c > 0 && (double)(c - 1) / tf >= qk)
                c--;
            while (c <= total && !((double)c / tf >= qk))
                c++;
            /* below: the first stored bin whose cumulative count is >= c */
            int64_t below = 0, cum = COUNT_AT(s0);
            while (cum < c && below < n - 1) {
                below++;
                cum += COUNT_AT(s0 + below);
            }
            if (cum < c)
                below = n; /* none (only for q > 1, refused above) */
            const int64_t i = o + below;
            double val;
            if (i > 0 && i < size - 1 && below < n) {
                /* the row's cumulative fraction after and before this bin */
                const double after = (double)cum / tf;
                const double before =
                    below > 0 ? (double)(cum - COUNT_AT(s0 + below)) / tf : 0.0;
                const double frac =
                    after > before ? (qk - before) / (after - before) : 0.5;
                const double lo = edges[i - 1], hi = edges[i];
                val = lo + frac * (hi - lo);
            } else {
                val = i == 0 ? -INFINITY : INFINITY;
            }
            out[r * nq + k] = val;
        }
    }
    ACQUIRE_GIL
    if (too_big)
        PyErr_SetString(PyExc_OverflowError,
                        "_ckernel.span_quantiles: a row's total is 2**52 or more");
    else
        result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&bc);
    PyBuffer_Release(&bs);
    PyBuffer_Release(&bl);
    PyBuffer_Release(&bo);
    PyBuffer_Release(&be);
    PyBuffer_Release(&bq);
    PyBuffer_Release(&bout);
    return result;
}

PyDoc_STRVAR(tail_steps_doc,
"tail_steps(counts, kind, ia, first_x, mean, w, width2, need, left, right, tail1,\n"
"           tail2)\n\n"
"The in-range steps of summary.tail_pull, row by row with the GIL released: each\n"
"row r takes its bins from the two ends of its run (stored counts from ia[r] +\n"
"left[r] to ia[r] + right[r]; `kind` as for span_quantiles), the one whose centre\n"
"first_x[r] + w * index is farther from mean[r] first (a tie: the left one),\n"
"min(need, count) values at a time, adding take * dev to tail1[r] and\n"
"take * (dev * dev + width2) to tail2[r], until need[r] (updated in place) is\n"
"spent or the run is. ia, left, right int64; first_x, mean, need, tail1, tail2\n"
"float64, all of one length. The NumPy loop's operations, in its order.");

static PyObject *
ck_tail_steps(PyObject *self, PyObject *args)
{
    Py_buffer bc, bia, bfx, bmu, bneed, bl, br, bt1, bt2;
    int kind;
    double w, width2;
    if (!PyArg_ParseTuple(args, "y*Cy*y*y*ddw*y*y*w*w*:tail_steps", &bc, &kind,
                          &bia, &bfx, &bmu, &w, &width2, &bneed, &bl, &br, &bt1,
                          &bt2))
        return NULL;
    PyObject *result = NULL;
    const Py_ssize_t item = count_itemsize(kind);
    const Py_ssize_t rows = bia.len / 8, nc = item ? bc.len / item : 0;
    int bad = item == 0 || bc.len % (item ? item : 1) || bia.len % 8 ||
              bfx.len != bia.len || bmu.len != bia.len || bneed.len != bia.len ||
              bl.len != bia.len || br.len != bia.len || bt1.len != bia.len ||
              bt2.len != bia.len;
    const int64_t *ia = bia.buf, *left0 = bl.buf, *right0 = br.buf;
    for (Py_ssize_t r = 0; !bad && r < rows; r++)
        bad = left0[r] <= right0[r] &&
              (ia[r] + left0[r] < 0 || ia[r] + right0[r] >= nc);
    if (bad) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.tail_steps: counts of dtype `kind`; int64 ia, left, "
                        "right and float64 first_x, mean, need, tail1, tail2 of one "
                        "length, each run inside counts");
        goto done;
    }
    const void *cv = bc.buf;
    const double *fx = bfx.buf, *mu = bmu.buf;
    double *need = bneed.buf, *t1 = bt1.buf, *t2 = bt2.buf;
    RELEASE_GIL
    for (Py_ssize_t r = 0; r < rows; r++) {
        int64_t left = left0[r], right = right0[r];
        while (need[r] > 0 && left <= right) {
            const double dl = fx[r] + w * (double)left - mu[r];
            const double dr = fx[r] + w * (double)right - mu[r];
            const int use_r = fabs(dr) > fabs(dl);
            const double dev = use_r ? dr : dl;
            const double c = (double)COUNT_AT(ia[r] + (use_r ? right : left));
            const double take = need[r] <= c ? need[r] : c;
            t1[r] += take * dev;
            t2[r] += take * (dev * dev + width2);
            need[r] -= take;
            right -= use_r;
            left += !use_r;
        }
    }
    ACQUIRE_GIL
    result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&bc);
    PyBuffer_Release(&bia);
    PyBuffer_Release(&bfx);
    PyBuffer_Release(&bmu);
    PyBuffer_Release(&bneed);
    PyBuffer_Release(&bl);
    PyBuffer_Release(&br);
    PyBuffer_Release(&bt1);
    PyBuffer_Release(&bt2);
    return result;
}
#undef COUNT_AT

PyDoc_STRVAR(pow_into_doc,
"pow_into(x, y, out) -> None\n\n"
"out[i] = pow(x[i], y) for float64 arrays x and out of one length, with the C\n"
"library's pow (what math.pow returns, bit for bit, where it returns; NaN or\n"
"inf where math.pow raises), the GIL released (summary._skewness).");

static PyObject *
ck_pow_into(PyObject *self, PyObject *args)
{
    Py_buffer bx, bo;
    double y;
    if (!PyArg_ParseTuple(args, "y*dw*:pow_into", &bx, &y, &bo))
        return NULL;
    PyObject *result = NULL;
    if (bx.len % 8 || bo.len != bx.len) {
        PyErr_SetString(PyExc_ValueError,
                        "_ckernel.pow_into: x and out are float64 of one length");
        goto done;
    }
    const double *x = bx.buf;
    double *out = bo.buf;
    const Py_ssize_t n = bx.len / 8;
    RELEASE_GIL
    for (Py_ssize_t i = 0; i < n; i++)
        out[i] = pow(x[i], y);
    ACQUIRE_GIL
    result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&bx);
    PyBuffer_Release(&bo);
    return result;
}

PyDoc_STRVAR(released_ns_doc,
"released_ns() -> int\n\n"
"Nanoseconds the kernel's calls have run with the GIL released since the module\n"
"was loaded, summed over threads (a monotonic count: take differences).");

static PyObject *
ck_released_ns(PyObject *self, PyObject *args)
{
    return PyLong_FromLongLong((long long)LOAD_RELEASED());
}

static PyMethodDef ck_methods[] = {
    {"released_ns", ck_released_ns, METH_NOARGS, released_ns_doc},
    {"block", ck_block, METH_VARARGS, block_doc},
    {"simd", ck_simd, METH_VARARGS, simd_doc},
    {"stream", ck_stream, METH_VARARGS, stream_doc},
    {"specs", ck_specs, METH_VARARGS, specs_doc},
    {"points", ck_points, METH_VARARGS, points_doc},
    {"task", ck_task, METH_VARARGS, task_doc},
#ifdef HAVE_TASK_LOOP
    {"tasks", ck_tasks, METH_VARARGS, tasks_doc},
    {"tasks_run", ck_tasks_run, METH_VARARGS, tasks_run_doc},
    {"tasks_halt", ck_tasks_halt, METH_VARARGS, tasks_halt_doc},
    {"tasks_harvest", ck_tasks_harvest, METH_VARARGS, tasks_harvest_doc},
#endif
    {"wall_rows", ck_wall_rows, METH_VARARGS, wall_rows_doc},
    {"wall_quantiles", ck_wall_quantiles, METH_VARARGS, wall_quantiles_doc},
    {"reach_cut", ck_reach_cut, METH_VARARGS, reach_cut_doc},
    {"span_quantiles", ck_span_quantiles, METH_VARARGS, span_quantiles_doc},
    {"pow_into", ck_pow_into, METH_VARARGS, pow_into_doc},
    {"tail_steps", ck_tail_steps, METH_VARARGS, tail_steps_doc},
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
#ifdef HAVE_AVX512_PATH
    __builtin_cpu_init();
    have_avx512 = __builtin_cpu_supports("avx512f") &&
                  __builtin_cpu_supports("avx512dq") &&
                  __builtin_cpu_supports("avx512cd") &&
                  __builtin_cpu_supports("avx512vl");
#endif
    if (PyType_Ready(&FlatType) < 0)
        return NULL;
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
