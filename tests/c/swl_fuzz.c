/*
 * swl_fuzz.c -- a fuzz harness for the wall-law sampler (src/microimpact/wall_law/c).
 *
 * Built by tests/wall_law/test_wall_law_fuzz.py with -fsanitize=address,undefined
 * and run with floating-point traps on (FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW,
 * as OpenFOAM's FOAM_SIGFPE): a trap is a SIGFPE, a memory error an ASan report,
 * both a non-zero exit.
 *
 *     swl_fuzz fuzz SEED SECONDS MAX_ITERATIONS WORKDIR TABLE...
 *         Mutate real tables (a few values or bits at a time, the layout known
 *         from the header: special doubles such as NaN, signalling NaN, inf,
 *         1e300, subnormals, 90 + 1 ulp into axes, capture probabilities and
 *         reservoirs; bad counts; flipped bits; header bytes; truncation),
 *         rewrite the CRC-32 so the values reach the checks, load each with
 *         swl_load and, where it loads, sample it with swl_sample and
 *         swl_rebound_velocity at random and extreme queries.
 *     swl_fuzz check FILE...
 *         Load each file and, where it loads, sample it the same way.
 *
 * Every sample must hold the contract of swl.h: a known result code; a rebound
 * finite and never faster than the impact (|U| <= s (1 + 1e-12)); a capture
 * (0, 0, 0); an error NaN; a diameter below 0.01 um SWL_E_UNIT. The last line of
 * the output counts iterations, load results by code and sample results by code;
 * a broken contract prints the case, keeps the file as WORKDIR/violation.swl and
 * exits 1.
 */
#define _GNU_SOURCE
#include <fenv.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "swl.h"

#define N_CODES 16 /* result codes -10 .. 5 as index code + 10 */
#define QUERIES 64

static uint64_t rng_state;

static uint64_t next_u64(void) /* splitmix64 */
{
    uint64_t z = (rng_state += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

static double uniform(void) { return (double)(next_u64() >> 11) * 0x1.0p-53; }

static size_t below(size_t n) { return n ? (size_t)(next_u64() % n) : 0; }

/* x finite, by its bits (a signalling NaN traps even in isfinite) */
static int finite_bits(double x)
{
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return (b & UINT64_C(0x7FF0000000000000)) != UINT64_C(0x7FF0000000000000);
}

static double from_bits(uint64_t b)
{
    double x;
    memcpy(&x, &b, sizeof x);
    return x;
}

static uint32_t get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) |
           ((uint32_t)p[3] << 24);
}

static void put_u32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}

static uint32_t crc32(const unsigned char *p, size_t len)
{
    uint32_t c = 0xFFFFFFFFu;
    size_t i;
    int j;
    for (i = 0; i < len; i++) {
        c ^= p[i];
        for (j = 0; j < 8; j++)
            c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    }
    return ~c;
}

/* ---- special values ---------------------------------------------------------- */

static double special_double(void)
{
    switch (below(26)) {
    case 0: return from_bits(UINT64_C(0x7FF8000000000000)); /* quiet NaN */
    case 1: return from_bits(UINT64_C(0xFFF8000000000000)); /* -NaN */
    case 2: return from_bits(UINT64_C(0x7FF0000000000001)); /* signalling NaN */
    case 3: return from_bits(UINT64_C(0x7FF0000000000000)); /* inf */
    case 4: return from_bits(UINT64_C(0xFFF0000000000000)); /* -inf */
    case 5: return 0.0;
    case 6: return -0.0;
    case 7: return DBL_MIN;
    case 8: return DBL_MIN / 1024.0; /* subnormal */
    case 9: return DBL_MAX;
    case 10: return -DBL_MAX;
    case 11: return 1e300;
    case 12: return -1e300;
    case 13: return 1.0;
    case 14: return 1.0 + DBL_EPSILON;
    case 15: return -1.0;
    case 16: return 90.0;
    case 17: return nextafter(90.0, 0.0);
    case 18: return nextafter(90.0, 100.0);
    case 19: return 1e6;
    case 20: return 1e12 * 1.5;
    case 21: return 1e-320;
    case 22: return -1e-300;
    case 23: return 2.0;
    case 24: return -90.0;
    default: return from_bits(next_u64()); /* any bits */
    }
}

/* ---- the layout of a table (swl.h) ------------------------------------------ */

typedef struct {
    size_t start, count, width; /* a region of `count` values of `width` bytes */
} region;

/* The value regions of the table in `buf` (a valid table's header), in file
 * order; returns how many (0 if the header is not readable). */
static int layout(const unsigned char *buf, size_t size, region out[12])
{
    uint32_t s, d, v, a, k, kind;
    size_t off, nodes, values;
    int n = 0;
    if (size < 64)
        return 0;
    s = get_u32(buf + 12);
    d = get_u32(buf + 16);
    v = get_u32(buf + 20);
    a = get_u32(buf + 24);
    k = get_u32(buf + 28);
    kind = get_u32(buf + 36);
    nodes = (size_t)s * d * v * a;
    values = nodes * k;
    off = 64 + (size_t)s * 64;
    out[n].start = off, out[n].count = d, out[n++].width = 8, off += 8u * d;
    out[n].start = off, out[n].count = v, out[n++].width = 8, off += 8u * v;
    out[n].start = off, out[n].count = a, out[n++].width = 8, off += 8u * a;
    if (kind == 1)
        out[n].start = off, out[n].count = d, out[n++].width = 8, off += 8u * d;
    out[n].start = off, out[n].count = nodes, out[n++].width = 8, off += 8u * nodes;
    for (int r = 0; r < 4; r++) {
        out[n].start = off, out[n].count = values, out[n++].width = 8;
        off += 8u * values;
    }
    out[n].start = off, out[n].count = nodes, out[n++].width = 4, off += 4u * nodes;
    if (get_u32(buf + 8) >= 3 && (get_u32(buf + 52) & 1u)) /* stay_probability */
        out[n].start = off, out[n].count = nodes, out[n++].width = 8, off += 8u * nodes;
    return off == size ? n : 0;
}

static void put_double(unsigned char *p, double x)
{
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    for (int i = 0; i < 8; i++)
        p[i] = (unsigned char)(b >> (8 * i));
}

static double get_double(const unsigned char *p)
{
    uint64_t b = 0;
    for (int i = 0; i < 8; i++)
        b |= (uint64_t)p[i] << (8 * i);
    return from_bits(b);
}

static size_t cap_of_buffer; /* bytes allocated for the mutated table */

/* One mutation of buf[0..*size) (a copy of a valid table with `nr` regions). */
static void mutate(unsigned char *buf, size_t *size, const region *reg, int nr)
{
    const region *r = &reg[below((size_t)nr)];
    size_t at, i;
    int kind = (int)below(10);
    if (r->count == 0)
        kind = 6;
    at = r->start + r->width * below(r->count);
    switch (kind) {
    case 0: case 1: case 2: /* a special value where a double belongs */
        if (r->width == 8) {
            put_double(buf + at, special_double());
            break;
        }
        kind = 3; /* a count */
        /* FALLTHROUGH */
    case 3: { /* a count: -1, 0, K, K + 1, extremes, any */
        const region *c = &reg[0];
        for (int j = 0; j < nr; j++) /* the counts: the one int32 region */
            if (reg[j].width == 4)
                c = &reg[j];
        uint32_t k = get_u32(buf + 28), pick[6] = {0xFFFFFFFFu, 0u, 0, 0, 0x7FFFFFFFu, 0};
        pick[2] = k;
        pick[3] = k + 1u;
        pick[5] = (uint32_t)next_u64();
        put_u32(buf + c->start + 4 * below(c->count), pick[below(6)]);
        break;
    }
    case 4: /* a double scaled: sign, doubled, far out, a last place up */
        if (r->width == 8) {
            static const double f[6] = {-1.0, 2.0, 1e300, 1e-300, 1.0 + DBL_EPSILON, 0.5};
            double x = get_double(buf + at);
            /* the mutator's own arithmetic must not trap: scale only finite
             * values and only where the product stays finite */
            double g = f[below(6)];
            if (finite_bits(x) && (fabs(x) <= 1.0 || fabs(g) <= 1.0))
                put_double(buf + at, x * g);
        }
        break;
    case 5: /* a value copied from another region (an angle into a ratio, ...) */
        if (r->width == 8) {
            const region *o = &reg[below((size_t)nr)];
            if (o->width == 8 && o->count)
                memmove(buf + at, buf + o->start + 8 * below(o->count), 8);
        }
        break;
    case 6: case 7: /* a few bits flipped anywhere after the header */
        for (i = 0, kind = 1 + (int)below(8); i < (size_t)kind; i++) {
            size_t byte = 64 + below(*size - 64);
            buf[byte] ^= (unsigned char)(1u << below(8));
        }
        break;
    case 8: /* a header byte */
        buf[8 + below(56)] = (unsigned char)next_u64();
        break;
    default: /* truncated, or a byte too many */
        if (below(2))
            *size -= 1 + below(*size < 200 ? *size : 200);
        else if (*size < cap_of_buffer)
            buf[(*size)++] = 0;
        break;
    }
}

/* ---- sampling under the contract ------------------------------------------- */

static long n_samples, n_by_code[N_CODES], n_loads[N_CODES];
static char work_file[4096];

static int code_index(int rc) { return rc >= -10 && rc <= 5 ? rc + 10 : -1; }

static int fail(const char *what, double d, double s, double a, const double *vel, int rc)
{
    fprintf(stderr, "violation: %s (code %d, d %.17g um, s %.17g m/s, angle %.17g; "
                    "velocity %.17g %.17g %.17g); the table is %s\n",
            what, rc, d, s, a, vel[0], vel[1], vel[2], work_file);
    return 1;
}

static double query_diameter(void)
{
    switch (below(12)) {
    case 0: return 3e-6; /* metres given as um */
    case 1: return 0.01;
    case 2: return nextafter(0.01, 0.0);
    case 3: return 1e-300;
    case 4: return 1e300;
    case 5: return special_double();
    default: return exp(log(0.1) + uniform() * (log(1e4) - log(0.1)));
    }
}

static double query_speed(void)
{
    switch (below(12)) {
    case 0: return 1e-300;
    case 1: return 1e300;
    case 2: return 1500.0;
    case 3: return special_double();
    default: return exp(log(1e-4) + uniform() * (log(1e3) - log(1e-4)));
    }
}

static double query_angle(void)
{
    switch (below(12)) {
    case 0: return 90.0;
    case 1: return 1e-300;
    case 2: return nextafter(90.0, 100.0);
    case 3: return special_double();
    default: return 90.0 * (1.0 - uniform()); /* (0, 90] */
    }
}

static double query_uniform(void)
{
    switch (below(40)) {
    case 0: return 0.0;
    case 1: return nextafter(1.0, 0.0);
    case 2: return special_double(); /* mostly not in [0, 1): SWL_E_ARG */
    default: return uniform();
    }
}

/* Is the query valid per swl.h (else SWL_E_ARG is due)? */
static int valid_query(double d, double s, double a, const double u[5])
{
    for (int i = 0; i < 5; i++)
        if (!finite_bits(u[i]) || !(u[i] >= 0.0 && u[i] < 1.0))
            return 0;
    return finite_bits(d) && finite_bits(s) && finite_bits(a) && d > 0.0 && s >= DBL_MIN &&
           a > 0.0 && a <= 90.0;
}

static int sample_table(const swl_law *law)
{
    int n_surface = swl_size(law, SWL_DIM_SURFACE);
    for (int q = 0; q < QUERIES; q++) {
        double d = query_diameter(), s = query_speed(), a = query_angle(), u[5], vel[3];
        int flags, rc, surface = (int)below((size_t)n_surface + 1) - (below(50) == 0);
        for (int i = 0; i < 5; i++)
            u[i] = query_uniform();
        rc = swl_sample(law, surface, d, s, a, u, vel, &flags);
        n_samples++;
        if (code_index(rc) < 0)
            return fail("an unknown result code", d, s, a, vel, rc);
        n_by_code[code_index(rc)]++;
        if (surface < 0 || surface >= n_surface || !valid_query(d, s, a, u)) {
            if (rc != SWL_E_ARG)
                return fail("a bad query not refused with SWL_E_ARG", d, s, a, vel, rc);
            continue;
        }
        if (d < 0.01 && rc != SWL_E_UNIT)
            return fail("a diameter below 0.01 um not refused", d, s, a, vel, rc);
        if (rc == SWL_REBOUND) {
            if (!isfinite(vel[0]) || !isfinite(vel[1]) || !isfinite(vel[2]))
                return fail("a non-finite rebound", d, s, a, vel, rc);
            /* |U| / s, each component divided first: s may be near DBL_MAX */
            if (!(hypot(hypot(vel[0] / s, vel[1] / s), vel[2] / s) <= 1.0 + 1e-12))
                return fail("a rebound faster than the impact", d, s, a, vel, rc);
        } else if (rc == SWL_CAPTURED) {
            if (vel[0] != 0.0 || vel[1] != 0.0 || vel[2] != 0.0)
                return fail("a capture with a velocity", d, s, a, vel, rc);
        } else if (flags & SWL_FLAG_RESUSPENDED) {
            return fail("resuspended but not captured", d, s, a, vel, rc);
        } else if (!isnan(vel[0]) || !isnan(vel[1]) || !isnan(vel[2])) {
            return fail("no data or an error without NaN velocity", d, s, a, vel, rc);
        }
        if (rc >= 0) { /* a checked query: its stay probability, in [0, 1] */
            double prob;
            int src = swl_stay_probability(law, surface, d, s, a, &prob, &flags);
            if (!(src == 0 || src == SWL_NO_DATA || src == SWL_E_NO_STAY) ||
                (src == 0 && !(prob >= 0.0 && prob <= 1.0)) ||
                (src != 0 && !isnan(prob)) || (src == SWL_E_NO_STAY) == swl_has_stay(law))
                return fail("a bad stay probability", d, s, a, vel, src);
        }
        if (q % 4 == 0) { /* the same through swl_rebound_velocity */
            double v_in[3], normal[3], out[3], speed;
            for (int i = 0; i < 3; i++) {
                v_in[i] = (uniform() - 0.5) * exp(log(1e-3) + uniform() * log(1e6));
                normal[i] = (uniform() - 0.5) * (below(20) ? 1.0 : 1e300);
            }
            rc = swl_rebound_velocity(law, 0, d, v_in, normal, u, out, &flags);
            if (code_index(rc) < 0)
                return fail("an unknown result code (rebound_velocity)", d, 0, 0, out, rc);
            speed = hypot(hypot(v_in[0], v_in[1]), v_in[2]);
            if (rc == SWL_REBOUND &&
                (!isfinite(out[0]) || !isfinite(out[1]) || !isfinite(out[2]) ||
                 !(hypot(hypot(out[0] / speed, out[1] / speed), out[2] / speed) <=
                   1.0 + 1e-12)))
                return fail("a bad rebound_velocity", d, speed, 0, out, rc);
        }
    }
    return 0;
}

static int load_and_sample(const char *path)
{
    swl_law *law = NULL;
    int rc = swl_load(path, &law);
    if (code_index(rc) < 0 || rc > 0) {
        double none[3] = {0, 0, 0};
        return fail("swl_load returned an unknown code", 0, 0, 0, none, rc);
    }
    n_loads[code_index(rc)]++;
    if (rc == 0) {
        int bad = sample_table(law);
        swl_free(law);
        return bad;
    }
    if (law != NULL) {
        double none[3] = {0, 0, 0};
        return fail("a refused table left *out set", 0, 0, 0, none, rc);
    }
    return 0;
}

static unsigned char *read_all(const char *path, size_t *size)
{
    FILE *fp = fopen(path, "rb");
    unsigned char *buf;
    long end;
    if (!fp)
        return NULL;
    fseek(fp, 0, SEEK_END);
    end = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    buf = (unsigned char *)malloc((size_t)end + 1);
    if (buf && fread(buf, 1, (size_t)end, fp) != (size_t)end) {
        free(buf);
        buf = NULL;
    }
    fclose(fp);
    *size = (size_t)end;
    return buf;
}

static void report(long iterations)
{
    printf("iterations %ld loads", iterations);
    for (int c = 0; c < N_CODES; c++)
        if (n_loads[c])
            printf(" %d:%ld", c - 10, n_loads[c]);
    printf(" samples %ld", n_samples);
    for (int c = 0; c < N_CODES; c++)
        if (n_by_code[c])
            printf(" %d:%ld", c - 10, n_by_code[c]);
    printf("\n");
}

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
    if (feenableexcept(FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW) < 0) {
        fprintf(stderr, "cannot enable floating-point traps\n");
        return 3;
    }
    if (argc >= 3 && strcmp(argv[1], "check") == 0) {
        int bad = 0;
        for (int i = 2; i < argc; i++) {
            snprintf(work_file, sizeof work_file, "%s", argv[i]);
            rng_state = 1;
            bad |= load_and_sample(argv[i]);
        }
        report(0);
        return bad;
    }
    if (argc < 7 || strcmp(argv[1], "fuzz") != 0) {
        fprintf(stderr, "usage: swl_fuzz fuzz SEED SECONDS MAX_ITERATIONS WORKDIR TABLE...\n"
                        "       swl_fuzz check FILE...\n");
        return 2;
    }
    {
        int n_tables = argc - 6;
        unsigned char **tables = calloc((size_t)n_tables, sizeof *tables);
        size_t *sizes = calloc((size_t)n_tables, sizeof *sizes), cap = 0, size;
        region regions[64][12];
        int n_regions[64];
        double stop = now() + atof(argv[3]);
        long max_iter = atol(argv[4]), it;
        unsigned char *buf;
        rng_state = strtoull(argv[2], NULL, 10);
        snprintf(work_file, sizeof work_file, "%s/fuzz.swl", argv[5]);
        if (n_tables > 64)
            n_tables = 64;
        for (int t = 0; t < n_tables; t++) {
            tables[t] = read_all(argv[6 + t], &sizes[t]);
            n_regions[t] = tables[t] ? layout(tables[t], sizes[t], regions[t]) : 0;
            if (!n_regions[t]) {
                fprintf(stderr, "%s is not a readable wall-law table\n", argv[6 + t]);
                return 2;
            }
            if (sizes[t] > cap)
                cap = sizes[t];
        }
        cap_of_buffer = cap + 8; /* a few bytes may be appended */
        buf = (unsigned char *)malloc(cap_of_buffer);
        for (it = 0; it < max_iter && now() < stop; it++) {
            int t = (int)below((size_t)n_tables), m = 1 + (int)below(4);
            FILE *fp;
            size = sizes[t];
            memcpy(buf, tables[t], size);
            for (int i = 0; i < m; i++)
                mutate(buf, &size, regions[t], n_regions[t]);
            if (size >= 64 && below(16)) /* mostly: the CRC made right again */
                put_u32(buf + 48, crc32(buf + 64, size - 64));
            fp = fopen(work_file, "wb");
            if (!fp || fwrite(buf, 1, size, fp) != size || fclose(fp) != 0) {
                fprintf(stderr, "cannot write %s\n", work_file);
                return 2;
            }
            if (load_and_sample(work_file)) {
                char keep[4200];
                snprintf(keep, sizeof keep, "%s/violation.swl", argv[5]);
                rename(work_file, keep);
                report(it + 1);
                return 1;
            }
        }
        report(it);
        for (int t = 0; t < n_tables; t++)
            free(tables[t]);
        free(tables);
        free(sizes);
        free(buf);
    }
    return 0;
}
