/*
 * swl.c -- read and sample a microimpact stochastic wall law (portable C99).
 * See swl.h for the API and the binary format, and docs/wall-law.md for the frame
 * and the sampling rule, which this file follows step by step.
 */
#include "swl.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SWL_HEADER_SIZE 64
#define SWL_PI 3.14159265358979323846
/* Largest size of one axis and of the whole table this reader accepts: far above
 * any real table, small enough that no size computation below can overflow. */
#define SWL_MAX_AXIS 1000000u
#define SWL_MAX_VALUES 0x40000000u /* 2^30 values per reservoir array (8 GiB) */

/* A query is flagged clamped only where it lies outside an axis' end nodes by
 * more than this, relative, in the axis' variable: in log d, log v and
 * log(v / v_c) the tolerance itself, on the angle axis this times the end node's
 * angle. A query at an end node up to round-off (a diameter converted from
 * metres, a speed r v_c(d)) is not clamped. Python: law.CLAMP_TOLERANCE. */
#define SWL_CLAMP_TOLERANCE 1e-9

/* Value ranges of a reservoir sample (swl.h, "Value ranges"; Python:
 * wall_law/checks.py). The caps on e_n and mu keep every product in the sampler
 * far from overflow; the model's own values are far inside them (|e_n| <= 1 /
 * sin theta, 57 at a 1-degree node). SWL_MAX_LATERAL is the largest double below
 * 90. SWL_VALUE_TOLERANCE is the round-off allowed on |U| / s <= 1 at a node. */
#define SWL_MAX_E_N 1e6
#define SWL_MAX_MU 1e12
#define SWL_MAX_LATERAL 89.99999999999999
#define SWL_VALUE_TOLERANCE 1e-9
/* Queries that look like a wrong unit (swl.h, SWL_E_UNIT): below 0.01 um is a
 * molecule (a diameter in metres, 3e-6 for 3 um, lands here); above 1 km/s and
 * above the table's fastest node is mm/s given as m/s (cold spray reaches
 * ~1 km/s: a table built that fast accepts it). Python: law.WRONG_UNIT_*. */
#define SWL_MIN_DIAMETER_UM 0.01
#define SWL_MAX_SPEED_M_S 1000.0

static const char SWL_MAGIC[8] = {'S', 'W', 'L', 'T', 'A', 'B', 'L', '\0'};

struct swl_law {
    int n[5]; /* surfaces, diameters, speeds, angles, reservoir K */
    char *names;                 /* S * SWL_NAME_WIDTH, each NUL-terminated */
    double *axis[3];             /* diameter_um, speed_m_s, angle_deg */
    double *scaled[3];           /* log(diameter), log(speed), angle: the axes' variables */
    double tol[3][2];            /* clamping tolerance below / above each axis */
    int speed_axis;              /* SWL_SPEED_ABSOLUTE or SWL_SPEED_REDUCED */
    double *critical;            /* v_c at each diameter node [m/s] (reduced axis) */
    double *log_critical;        /* log(critical) */
    double top_speed;            /* the table's fastest node [m/s] */
    double *capture;             /* capture_probability [S*D*V*A] */
    double *e_n, *mu, *lateral, *ratio; /* reservoirs [S*D*V*A*K] */
    int32_t *count;              /* reservoir_count [S*D*V*A] */
    double *stay;                /* stay_probability [S*D*V*A], or NULL */
};

/* ---- little-endian decoding and CRC-32 ------------------------------------ */

static uint32_t get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) |
           ((uint32_t)p[3] << 24);
}

static uint64_t get_u64(const unsigned char *p)
{
    return (uint64_t)get_u32(p) | ((uint64_t)get_u32(p + 4) << 32);
}

/* CRC-32 of zlib (reflected polynomial 0xEDB88320), updated over `len` bytes. */
static uint32_t crc32_update(uint32_t crc, const unsigned char *p, size_t len)
{
    static uint32_t table[256];
    static int ready = 0;
    size_t i;
    if (!ready) {
        uint32_t k, c;
        int j;
        for (k = 0; k < 256; k++) {
            c = k;
            for (j = 0; j < 8; j++)
                c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            table[k] = c;
        }
        ready = 1;
    }
    crc = ~crc;
    for (i = 0; i < len; i++)
        crc = table[(crc ^ p[i]) & 0xFFu] ^ (crc >> 8);
    return ~crc;
}

/* Read `len` bytes into `dst`, updating the CRC. */
static int read_block(FILE *fp, void *dst, size_t len, uint32_t *crc)
{
    if (len && fread(dst, 1, len, fp) != len)
        return ferror(fp) ? SWL_E_IO : SWL_E_TRUNCATED;
    *crc = crc32_update(*crc, (const unsigned char *)dst, len);
    return 0;
}

/* Turn `n` little-endian float64 values read into `v` into host doubles. Every
 * NaN becomes the quiet NaN, by its bits: a signalling NaN raises FE_INVALID even
 * in isnan() and the quiet comparison macros, so it must never reach one. */
static void fix_doubles(double *v, size_t n)
{
    size_t i;
    uint64_t bits;
    const uint64_t exponent = UINT64_C(0x7FF0000000000000);
    const uint64_t mantissa = UINT64_C(0x000FFFFFFFFFFFFF);
    for (i = 0; i < n; i++) {
        bits = get_u64((const unsigned char *)&v[i]);
        if ((bits & exponent) == exponent && (bits & mantissa) != 0)
            bits = UINT64_C(0x7FF8000000000000); /* the quiet NaN */
        memcpy(&v[i], &bits, sizeof bits);
    }
}

static void fix_int32(int32_t *v, size_t n)
{
    size_t i;
    uint32_t bits;
    for (i = 0; i < n; i++) {
        bits = get_u32((const unsigned char *)&v[i]);
        memcpy(&v[i], &bits, sizeof bits);
    }
}

/* x finite, by its bits: no floating-point operation touches x, so even a
 * signalling NaN argument raises nothing (isfinite may compare, and a comparison
 * of a signalling NaN raises FE_INVALID, a SIGFPE where the host traps). */
static int finite_bits(double x)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    return (bits & UINT64_C(0x7FF0000000000000)) != UINT64_C(0x7FF0000000000000);
}

/* ---- loading --------------------------------------------------------------- */

void swl_free(swl_law *law)
{
    int i;
    if (!law)
        return;
    free(law->names);
    for (i = 0; i < 3; i++) {
        free(law->axis[i]);
        free(law->scaled[i]);
    }
    free(law->critical);
    free(law->log_critical);
    free(law->capture);
    free(law->e_n);
    free(law->mu);
    free(law->lateral);
    free(law->ratio);
    free(law->count);
    free(law->stay);
    free(law);
}

/* x finite and lo <= x <= hi, without an ordered comparison of a NaN (which
 * raises FE_INVALID, a SIGFPE where the host traps floating-point exceptions, as
 * OpenFOAM does): isfinite first, then C99's quiet comparison macros. */
static int within(double x, double lo, double hi)
{
    return isfinite(x) && isgreaterequal(x, lo) && islessequal(x, hi);
}

/* One held reservoir sample at a node of incidence angle theta (sin st, cos ct)
 * against the documented ranges (swl.h, "Value ranges"). */
static int good_sample(double e_n, double mu, double lateral, double ratio, double st,
                       double ct)
{
    if (!within(e_n, -SWL_MAX_E_N, SWL_MAX_E_N) || !within(mu, -SWL_MAX_MU, SWL_MAX_MU) ||
        !within(lateral, -SWL_MAX_LATERAL, SWL_MAX_LATERAL) || !within(ratio, 0.0, 1.0))
        return 0;
    /* |U_z| / s = |e_n| sin theta and |U_x| / s = |cos theta - mu (1 + e_n) sin
     * theta| are at most 1 at the node: a rebound is never faster than the
     * impact (the operands are bounded above, so nothing overflows) */
    return islessequal(fabs(e_n * st), 1.0 + SWL_VALUE_TOLERANCE) &&
           islessequal(fabs(ct - mu * (1.0 + e_n) * st), 1.0 + SWL_VALUE_TOLERANCE);
}

static int check_values(swl_law *law, size_t nodes)
{
    const size_t k = (size_t)law->n[4], n_angle = (size_t)law->n[3];
    size_t a, i, j, base;
    int32_t c;
    double p, th, st, ct;
    for (a = 0; a < (size_t)law->n[0]; a++) {
        const char *name = law->names + a * SWL_NAME_WIDTH;
        if (memchr(name, '\0', SWL_NAME_WIDTH) == NULL)
            return SWL_E_VALUE; /* a name must end within its field */
    }
    for (a = 0; a < 3; a++) {
        const double *x = law->axis[a];
        for (i = 0; i < (size_t)law->n[a + 1]; i++) {
            /* diameters and speeds in (0, inf), angles in (0, 90] */
            if (!within(x[i], 0.0, a < 2 ? DBL_MAX : 90.0) || !isgreater(x[i], 0.0))
                return SWL_E_VALUE;
            if (i > 0 && !isgreater(x[i], x[i - 1]))
                return SWL_E_VALUE;
        }
    }
    if (law->critical)
        for (i = 0; i < (size_t)law->n[1]; i++)
            if (!within(law->critical[i], 0.0, DBL_MAX) || !isgreater(law->critical[i], 0.0))
                return SWL_E_VALUE;
    for (i = 0; i < nodes; i++) {
        p = law->capture[i];
        c = law->count[i];
        if (!isnan(p) && !within(p, 0.0, 1.0))
            return SWL_E_VALUE;
        if (c < 0 || (size_t)c > k)
            return SWL_E_VALUE;
        if (c == 0 && !(isnan(p) || p == 1.0))
            return SWL_E_VALUE; /* a node that can rebound needs a sample */
        base = i * k;
        th = law->axis[2][i % n_angle] * (SWL_PI / 180.0);
        st = sin(th);
        ct = cos(th);
        for (j = 0; j < (size_t)c; j++)
            if (!good_sample(law->e_n[base + j], law->mu[base + j], law->lateral[base + j],
                             law->ratio[base + j], st, ct))
                return SWL_E_VALUE;
        /* a probability, finite (NaN-safe: within tests isfinite first) */
        if (law->stay && !within(law->stay[i], 0.0, 1.0))
            return SWL_E_VALUE;
    }
    return 0;
}

static int load_file(FILE *fp, swl_law **out)
{
    unsigned char h[SWL_HEADER_SIZE];
    uint32_t dims[5], crc = 0, width, version, kind, sections;
    uint64_t size, expected, nodes, values;
    swl_law *law;
    int rc, i, extra;
    size_t got;

    got = fread(h, 1, sizeof h, fp);
    if (ferror(fp))
        return SWL_E_IO;
    /* a short file that starts like the magic is truncated; anything else is not
     * a table at all */
    if (memcmp(h, SWL_MAGIC, got < sizeof SWL_MAGIC ? got : sizeof SWL_MAGIC) != 0)
        return SWL_E_MAGIC;
    if (got < 12)
        return SWL_E_TRUNCATED;
    version = get_u32(h + 8);
    if (version < 1 || version > SWL_FORMAT_VERSION)
        return SWL_E_VERSION; /* this reader knows versions 1, 2 and 3 */
    if (got < sizeof h)
        return SWL_E_TRUNCATED;
    for (i = 0; i < 5; i++) {
        dims[i] = get_u32(h + 12 + 4 * i);
        if (dims[i] < 1 || dims[i] > SWL_MAX_AXIS)
            return SWL_E_SIZE;
    }
    width = get_u32(h + 32);
    kind = get_u32(h + 36); /* version 2: the speed axis; version 1: 0 */
    if (width != SWL_NAME_WIDTH || kind > (version >= 2 ? 1u : 0u))
        return SWL_E_SIZE;
    /* version 3: the sections word (bit 0: stay_probability); before, 0 */
    sections = version >= 3 ? get_u32(h + 52) : 0u;
    if (sections & ~1u)
        return SWL_E_SIZE;
    for (i = version >= 3 ? 56 : 52; i < SWL_HEADER_SIZE; i++)
        if (h[i] != 0)
            return SWL_E_SIZE;
    /* each factor is <= 1e6, so nodes fits a uint64 when checked step by step */
    nodes = (uint64_t)dims[0] * dims[1];
    if (nodes > SWL_MAX_VALUES)
        return SWL_E_SIZE;
    nodes *= dims[2];
    if (nodes > SWL_MAX_VALUES)
        return SWL_E_SIZE;
    nodes *= dims[3];
    if (nodes > SWL_MAX_VALUES)
        return SWL_E_SIZE;
    values = nodes * dims[4];
    if (values > SWL_MAX_VALUES)
        return SWL_E_SIZE;
    expected = SWL_HEADER_SIZE + (uint64_t)dims[0] * SWL_NAME_WIDTH +
               8u * ((uint64_t)dims[1] + dims[2] + dims[3]) + 8u * nodes +
               32u * values + 4u * nodes + (kind == 1 ? 8u * (uint64_t)dims[1] : 0u) +
               ((sections & 1u) ? 8u * nodes : 0u);
    size = get_u64(h + 40);
    if (size != expected)
        return SWL_E_SIZE;
    if ((size_t)values != values) /* a 32-bit host cannot hold this table */
        return SWL_E_NOMEM;
    /* the file's length, where the C library can tell it, before allocating: a
     * corrupt header must not make us allocate gigabytes for a short file */
    if (fseek(fp, 0, SEEK_END) == 0) {
        long end = ftell(fp);
        if (end >= 0 && (uint64_t)end != size)
            return (uint64_t)end < size ? SWL_E_TRUNCATED : SWL_E_SIZE;
        if (fseek(fp, SWL_HEADER_SIZE, SEEK_SET) != 0)
            return SWL_E_IO;
    }

    law = (swl_law *)calloc(1, sizeof *law);
    if (!law)
        return SWL_E_NOMEM;
    for (i = 0; i < 5; i++)
        law->n[i] = (int)dims[i];
    law->speed_axis = kind == 1 ? SWL_SPEED_REDUCED : SWL_SPEED_ABSOLUTE;
    if (kind == 1) {
        law->critical = (double *)malloc(dims[1] * sizeof(double));
        law->log_critical = (double *)malloc(dims[1] * sizeof(double));
        if (!law->critical || !law->log_critical) {
            swl_free(law);
            return SWL_E_NOMEM;
        }
    }
    if (sections & 1u) {
        law->stay = (double *)malloc((size_t)nodes * sizeof(double));
        if (!law->stay) {
            swl_free(law);
            return SWL_E_NOMEM;
        }
    }
    law->names = (char *)malloc((size_t)dims[0] * SWL_NAME_WIDTH);
    for (i = 0; i < 3; i++) {
        law->axis[i] = (double *)malloc(dims[i + 1] * sizeof(double));
        law->scaled[i] = (double *)malloc(dims[i + 1] * sizeof(double));
    }
    law->capture = (double *)malloc((size_t)nodes * sizeof(double));
    law->e_n = (double *)malloc((size_t)values * sizeof(double));
    law->mu = (double *)malloc((size_t)values * sizeof(double));
    law->lateral = (double *)malloc((size_t)values * sizeof(double));
    law->ratio = (double *)malloc((size_t)values * sizeof(double));
    law->count = (int32_t *)malloc((size_t)nodes * sizeof(int32_t));
    if (!law->names || !law->axis[0] || !law->axis[1] || !law->axis[2] ||
        !law->scaled[0] || !law->scaled[1] || !law->scaled[2] || !law->capture ||
        !law->e_n || !law->mu || !law->lateral || !law->ratio || !law->count) {
        swl_free(law);
        return SWL_E_NOMEM;
    }

    rc = read_block(fp, law->names, (size_t)dims[0] * SWL_NAME_WIDTH, &crc);
    for (i = 0; i < 3 && rc == 0; i++)
        rc = read_block(fp, law->axis[i], dims[i + 1] * sizeof(double), &crc);
    if (rc == 0 && law->critical)
        rc = read_block(fp, law->critical, dims[1] * sizeof(double), &crc);
    if (rc == 0)
        rc = read_block(fp, law->capture, (size_t)nodes * sizeof(double), &crc);
    if (rc == 0)
        rc = read_block(fp, law->e_n, (size_t)values * sizeof(double), &crc);
    if (rc == 0)
        rc = read_block(fp, law->mu, (size_t)values * sizeof(double), &crc);
    if (rc == 0)
        rc = read_block(fp, law->lateral, (size_t)values * sizeof(double), &crc);
    if (rc == 0)
        rc = read_block(fp, law->ratio, (size_t)values * sizeof(double), &crc);
    if (rc == 0)
        rc = read_block(fp, law->count, (size_t)nodes * sizeof(int32_t), &crc);
    if (rc == 0 && law->stay)
        rc = read_block(fp, law->stay, (size_t)nodes * sizeof(double), &crc);
    if (rc == 0) {
        extra = fgetc(fp);
        if (extra != EOF)
            rc = SWL_E_SIZE; /* trailing bytes */
        else if (ferror(fp))
            rc = SWL_E_IO;
    }
    if (rc == 0 && crc != get_u32(h + 48))
        rc = SWL_E_CHECKSUM;
    if (rc == 0) {
        for (i = 0; i < 3; i++)
            fix_doubles(law->axis[i], dims[i + 1]);
        if (law->critical)
            fix_doubles(law->critical, dims[1]);
        fix_doubles(law->capture, (size_t)nodes);
        fix_doubles(law->e_n, (size_t)values);
        fix_doubles(law->mu, (size_t)values);
        fix_doubles(law->lateral, (size_t)values);
        fix_doubles(law->ratio, (size_t)values);
        fix_int32(law->count, (size_t)nodes);
        if (law->stay)
            fix_doubles(law->stay, (size_t)nodes);
        rc = check_values(law, (size_t)nodes);
    }
    if (rc != 0) {
        swl_free(law);
        return rc;
    }
    /* the axes' interpolation variables: natural log for d and v (or v / v_c),
     * degrees for theta, and their clamping tolerances */
    for (i = 0; i < 3; i++) {
        uint32_t j;
        for (j = 0; j < dims[i + 1]; j++)
            law->scaled[i][j] = i < 2 ? log(law->axis[i][j]) : law->axis[i][j];
        law->tol[i][0] = i < 2 ? SWL_CLAMP_TOLERANCE
                               : SWL_CLAMP_TOLERANCE * fabs(law->axis[i][0]);
        law->tol[i][1] = i < 2 ? SWL_CLAMP_TOLERANCE
                               : SWL_CLAMP_TOLERANCE * fabs(law->axis[i][dims[i + 1] - 1]);
        /* two nodes a last place apart can have the same log: a cell of width 0
         * would divide by zero */
        for (j = 1; j < dims[i + 1]; j++)
            if (!(law->scaled[i][j] > law->scaled[i][j - 1])) {
                swl_free(law);
                return SWL_E_VALUE;
            }
    }
    law->top_speed = law->axis[1][dims[2] - 1];
    if (law->critical) {
        uint32_t j;
        double top = 0.0;
        for (j = 0; j < dims[1]; j++) {
            law->log_critical[j] = log(law->critical[j]);
            top = fmax(top, law->critical[j]);
        }
        /* r v_c, without overflow (DBL_MAX for a crafted table: that only
         * disables the wrong-unit check on speed) */
        law->top_speed = (top <= 1.0 || law->top_speed <= DBL_MAX / top)
                             ? top * law->top_speed
                             : DBL_MAX;
    }
    *out = law;
    return 0;
}

int swl_load(const char *path, swl_law **out)
{
    FILE *fp;
    int rc;
    if (!out)
        return SWL_E_ARG;
    *out = NULL;
    if (!path)
        return SWL_E_ARG;
    fp = fopen(path, "rb");
    if (!fp)
        return SWL_E_IO;
    rc = load_file(fp, out);
    fclose(fp);
    return rc;
}

const char *swl_strerror(int code)
{
    switch (code) {
    case SWL_REBOUND: return "rebound";
    case SWL_CAPTURED: return "captured";
    case SWL_NO_DATA: return "no data at the chosen node (every draw was shadowed)";
    case SWL_E_ARG: return "bad argument";
    case SWL_E_IO: return "cannot open or read the file";
    case SWL_E_MAGIC: return "not a microimpact wall-law table (wrong magic)";
    case SWL_E_VERSION: return "unknown wall-law table format version";
    case SWL_E_TRUNCATED: return "the file is truncated";
    case SWL_E_SIZE: return "the sizes in the header are invalid or disagree with the file";
    case SWL_E_CHECKSUM: return "the table is corrupt (CRC-32 mismatch)";
    case SWL_E_VALUE:
        return "the table holds an invalid value (NaN, out of its documented range, "
               "or an axis not strictly increasing)";
    case SWL_E_NOMEM: return "out of memory";
    case SWL_E_UNIT:
        return "a diameter below 0.01 um or a speed above 1 km/s (and above the "
               "table): a wrong unit? diameters are in um, speeds in m/s";
    case SWL_E_NO_STAY:
        return "the table carries no stay probability (build it from a scenario "
               "with a [resuspension] table)";
    default: return "unknown code";
    }
}

int swl_surface_index(const swl_law *law, const char *name)
{
    int s;
    if (!law || !name)
        return SWL_E_ARG;
    for (s = 0; s < law->n[0]; s++)
        if (strcmp(law->names + (size_t)s * SWL_NAME_WIDTH, name) == 0)
            return s;
    return SWL_E_ARG;
}

int swl_speed_axis(const swl_law *law)
{
    return law ? law->speed_axis : SWL_E_ARG;
}

int swl_has_stay(const swl_law *law)
{
    return law ? law->stay != NULL : SWL_E_ARG;
}

int swl_size(const swl_law *law, int what)
{
    if (!law || what < SWL_DIM_SURFACE || what > SWL_DIM_RESERVOIR)
        return SWL_E_ARG;
    return law->n[what];
}

const char *swl_surface_name(const swl_law *law, int surface)
{
    if (!law || surface < 0 || surface >= law->n[0])
        return NULL;
    return law->names + (size_t)surface * SWL_NAME_WIDTH;
}

/* ---- sampling (docs/wall-law.md, "The sampling rule") ----------------------- */

/* Step 1 on one axis: the cell of `x`, the query in the axis' variable (log d,
 * log v or log(v / v_c), or theta): its lower node *lo, its fraction *t in
 * [0, 1] (0 below the axis, 1 above it, 0 on an axis of one node), and *clamped
 * where x lies outside the end nodes by more than the axis' tolerance. */
static void bracket(const double *node, int n, const double tol[2], double x, int *lo,
                    double *t, int *clamped)
{
    int hi, mid;
    *clamped = x < node[0] - tol[0] || x > node[n - 1] + tol[1];
    *lo = 0;
    *t = 0.0;
    if (n == 1)
        return;
    if (x < node[0])
        return; /* i = 0, t = 0: the lower node */
    if (x > node[n - 1]) {
        *lo = n - 2;
        *t = 1.0; /* i = n - 2, t = 1: the upper node */
        return;
    }
    /* binary search: node[lo] <= x <= node[hi], hi = lo + 1 */
    hi = n - 1;
    while (hi - *lo > 1) {
        mid = *lo + (hi - *lo) / 2;
        if (node[mid] <= x)
            *lo = mid;
        else
            hi = mid;
    }
    *t = (x - node[*lo]) / (node[hi] - node[*lo]);
    if (*t > 1.0) /* as the Python sampler's clip */
        *t = 1.0;
}

/* Step 2 on one axis: the upper node where u < t. */
static int pick(int lo, double t, double u)
{
    return u < t ? lo + 1 : lo;
}

/* Step 1 on the three axes: the lower node lo[a] and fraction t[a] of the
 * query's cell on each axis, and the clamped flags. */
static int cell(const swl_law *law, double diameter_um, double speed_m_s,
                double angle_deg, int lo[3], double t[3])
{
    int c1, c2, c3;
    double xv, lvc;
    bracket(law->scaled[0], law->n[1], law->tol[0], log(diameter_um), &lo[0], &t[0],
            &c1);
    xv = log(speed_m_s);
    if (law->speed_axis == SWL_SPEED_REDUCED) {
        /* x = log v - log v_c(d), log v_c linear in log d between the diameter
         * nodes at the query's own (clipped) fraction */
        lvc = law->log_critical[lo[0]];
        if (law->n[1] > 1)
            lvc = law->log_critical[lo[0]] + t[0] * (law->log_critical[lo[0] + 1] -
                                                     law->log_critical[lo[0]]);
        xv = xv - lvc;
    }
    bracket(law->scaled[1], law->n[2], law->tol[1], xv, &lo[1], &t[1], &c2);
    bracket(law->scaled[2], law->n[3], law->tol[2], angle_deg, &lo[2], &t[2], &c3);
    return (c1 ? SWL_FLAG_CLAMPED_DIAMETER : 0) | (c2 ? SWL_FLAG_CLAMPED_SPEED : 0) |
           (c3 ? SWL_FLAG_CLAMPED_ANGLE : 0);
}

static size_t node_index(const swl_law *law, int surface, int id, int iv, int ia)
{
    return (((size_t)surface * law->n[1] + id) * law->n[2] + iv) * law->n[3] + ia;
}

/* Steps 1-4 for a query already checked; the velocity in the wall frame. */
static int sample_checked(const swl_law *law, int surface, double diameter_um,
                          double speed_m_s, double angle_deg, const double u[5],
                          double velocity[3], int *flags)
{
    int id, iv, ia, k, count, lo[3];
    size_t node, at;
    double p, th, st, ct, s, en, mu, ux, uy, uz, norm, scale, t[3];

    *flags = cell(law, diameter_um, speed_m_s, angle_deg, lo, t);
    id = pick(lo[0], t[0], u[0]);
    iv = pick(lo[1], t[1], u[1]);
    ia = pick(lo[2], t[2], u[2]);
    node = node_index(law, surface, id, iv, ia);

    p = law->capture[node];
    count = law->count[node];
    if (isnan(p) || (count == 0 && !(u[3] < p))) {
        velocity[0] = velocity[1] = velocity[2] = NAN;
        return SWL_NO_DATA;
    }
    /* step 3; on a table with stay_probability q the same u[3] decides whether
     * the captured particle stays: u[3] < p q (given capture u[3] / p is
     * uniform) */
    if (u[3] < p) {
        velocity[0] = velocity[1] = velocity[2] = 0.0;
        if (law->stay && !(u[3] < p * law->stay[node]))
            *flags |= SWL_FLAG_RESUSPENDED;
        return SWL_CAPTURED;
    }
    /* step 4: sample k = floor(u[4] * count), at most count - 1 */
    k = (int)floor(u[4] * (double)count);
    if (k > count - 1)
        k = count - 1;
    at = node * (size_t)law->n[4] + (size_t)k;
    en = law->e_n[at];
    mu = law->mu[at];
    s = speed_m_s;
    th = angle_deg * (SWL_PI / 180.0);
    st = sin(th);
    ct = cos(th);
    /* the direction per unit speed (swl_load bounds e_n, mu and the lateral
     * angle, so each factor is finite and far from overflow), then scaled to
     * |U| = speed_ratio * s: hypot never overflows, each component's share
     * |u_i| / norm is at most 1 and speed_ratio at most 1, so |U| <= s up to
     * rounding (a zero vector stays zero) */
    uz = en * st;
    ux = ct - mu * (1.0 + en) * st;
    uy = tan(law->lateral[at] * (SWL_PI / 180.0)) * hypot(ux, uz);
    norm = hypot(hypot(ux, uz), uy);
    scale = law->ratio[at] * s;
    if (norm > 0.0) { /* |u_i| / norm <= 1: no overflow even for a tiny norm */
        ux = ux / norm * scale;
        uy = uy / norm * scale;
        uz = uz / norm * scale;
    } else {
        ux = uy = uz = 0.0;
    }
    velocity[0] = ux;
    velocity[1] = uy;
    velocity[2] = uz;
    if (uz < 0.0)
        *flags |= SWL_FLAG_REIMPACT;
    return SWL_REBOUND;
}

static int good_uniforms(const double u[5])
{
    int i;
    for (i = 0; i < 5; i++)
        if (!finite_bits(u[i]) || !(u[i] >= 0.0 && u[i] < 1.0))
            return 0;
    return 1;
}

/* 0 for a query the sampler takes, else SWL_E_ARG or SWL_E_UNIT. */
static int check_query(const swl_law *law, int surface, double diameter_um,
                       double speed_m_s, double angle_deg)
{
    /* finite by the bits before any comparison: a NaN argument must not trap; a
     * subnormal speed is refused: its rebound could not be rounded to |U| <= s */
    if (!law || surface < 0 || surface >= law->n[0] || !finite_bits(diameter_um) ||
        !finite_bits(speed_m_s) || !finite_bits(angle_deg) || !(diameter_um > 0.0) ||
        !(speed_m_s >= DBL_MIN) || !(angle_deg > 0.0) || !(angle_deg <= 90.0))
        return SWL_E_ARG;
    /* a diameter in metres, or a speed in mm/s, given where um and m/s belong */
    if (diameter_um < SWL_MIN_DIAMETER_UM ||
        (speed_m_s > SWL_MAX_SPEED_M_S && speed_m_s > law->top_speed))
        return SWL_E_UNIT;
    return 0;
}

int swl_sample(const swl_law *law, int surface, double diameter_um, double speed_m_s,
               double angle_deg, const double u[5], double velocity[3], int *flags)
{
    int dummy, rc;
    if (!flags)
        flags = &dummy;
    *flags = 0;
    if (!velocity)
        return SWL_E_ARG;
    velocity[0] = velocity[1] = velocity[2] = NAN;
    if (!u || !good_uniforms(u))
        return SWL_E_ARG;
    rc = check_query(law, surface, diameter_um, speed_m_s, angle_deg);
    if (rc != 0)
        return rc;
    return sample_checked(law, surface, diameter_um, speed_m_s, angle_deg, u, velocity,
                          flags);
}

int swl_stay_probability(const swl_law *law, int surface, double diameter_um,
                         double speed_m_s, double angle_deg, double *probability,
                         int *flags)
{
    int dummy, rc, c, a, lo[3], ix[3], up;
    size_t node;
    double t[3], w, p, q, num = 0.0, den = 0.0, wq = 0.0, wsum = 0.0;
    if (!flags)
        flags = &dummy;
    *flags = 0;
    if (!probability)
        return SWL_E_ARG;
    *probability = NAN;
    rc = check_query(law, surface, diameter_um, speed_m_s, angle_deg);
    if (rc != 0)
        return rc;
    if (!law->stay)
        return SWL_E_NO_STAY;
    *flags = cell(law, diameter_um, speed_m_s, angle_deg, lo, t);
    /* the corners in the order of the Python reader (WallLaw.stay_probability):
     * bit 4 the diameter, 2 the speed, 1 the angle; lower node first */
    for (c = 0; c < 8; c++) {
        w = 1.0;
        for (a = 0; a < 3; a++) {
            up = (c >> (2 - a)) & 1;
            w = w * (up ? t[a] : 1.0 - t[a]);
            ix[a] = lo[a] + up;
            if (ix[a] > law->n[a + 1] - 1)
                ix[a] = law->n[a + 1] - 1; /* an axis of one node (weight 0) */
        }
        node = node_index(law, surface, ix[0], ix[1], ix[2]);
        p = law->capture[node];
        q = law->stay[node];
        if (!(w > 0.0) || isnan(p))
            continue; /* never picked, or no impact there */
        num = num + w * p * q;
        den = den + w * p;
        wq = wq + w * q;
        wsum = wsum + w;
    }
    if (den > 0.0)
        *probability = num / den;
    else if (wsum > 0.0)
        *probability = wq / wsum;
    else
        return SWL_NO_DATA;
    return 0;
}

int swl_sample_n(const swl_law *law, int surface, long n, const double *diameter_um,
                 const double *speed_m_s, const double *angle_deg, const double *u,
                 double *velocity, int *status, int *flags)
{
    long i;
    int f;
    if (!law || n < 0 || (n > 0 && (!diameter_um || !speed_m_s || !angle_deg || !u ||
                                    !velocity || !status)))
        return SWL_E_ARG;
    for (i = 0; i < n; i++) {
        status[i] = swl_sample(law, surface, diameter_um[i], speed_m_s[i], angle_deg[i],
                               u + 5 * i, velocity + 3 * i, &f);
        if (flags)
            flags[i] = f;
    }
    return 0;
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

int swl_rebound_velocity(const swl_law *law, int surface, double diameter_um,
                         const double v_in[3], const double normal[3], const double u[5],
                         double v_out[3], int *flags)
{
    double z[3], x[3], y[3], vt[3], w[3], nn, vn, tmag, s, theta;
    int i, k, rc, dummy;
    if (!flags)
        flags = &dummy;
    *flags = 0;
    if (!v_out)
        return SWL_E_ARG;
    v_out[0] = v_out[1] = v_out[2] = NAN;
    if (!v_in || !normal)
        return SWL_E_ARG;
    for (i = 0; i < 3; i++)
        if (!finite_bits(v_in[i]) || !finite_bits(normal[i]))
            return SWL_E_ARG;
    /* |v_in| above 1e150 m/s is no speed (and would overflow below) */
    for (i = 0; i < 3; i++)
        if (!isless(fabs(v_in[i]), 1e150))
            return SWL_E_UNIT;
    /* the normal divided by its largest component first: no overflow */
    nn = fmax(fabs(normal[0]), fmax(fabs(normal[1]), fabs(normal[2])));
    if (!(nn > 0.0))
        return SWL_E_ARG;
    for (i = 0; i < 3; i++)
        z[i] = normal[i] / nn;
    nn = sqrt(dot3(z, z));
    for (i = 0; i < 3; i++)
        z[i] = z[i] / nn;
    vn = dot3(v_in, z);
    if (!(vn < 0.0))
        return SWL_E_ARG; /* moving along or away from the wall, not into it */
    for (i = 0; i < 3; i++)
        vt[i] = v_in[i] - vn * z[i];
    tmag = sqrt(dot3(vt, vt));
    s = sqrt(dot3(v_in, v_in));
    if (!(s > 0.0) || !isfinite(s))
        return SWL_E_ARG;
    theta = fmin(atan2(-vn, tmag) * (180.0 / SWL_PI), 90.0);
    if (tmag > 0.0) {
        for (i = 0; i < 3; i++)
            x[i] = vt[i] / tmag;
    } else { /* normal incidence: x along e_k - n_k z, |z_k| smallest */
        k = 0;
        for (i = 1; i < 3; i++)
            if (fabs(z[i]) < fabs(z[k]))
                k = i;
        for (i = 0; i < 3; i++)
            x[i] = (i == k ? 1.0 : 0.0) - z[k] * z[i];
        tmag = sqrt(dot3(x, x));
        for (i = 0; i < 3; i++)
            x[i] /= tmag;
    }
    y[0] = z[1] * x[2] - z[2] * x[1];
    y[1] = z[2] * x[0] - z[0] * x[2];
    y[2] = z[0] * x[1] - z[1] * x[0];
    rc = swl_sample(law, surface, diameter_um, s, theta, u, w, flags);
    if (rc == SWL_REBOUND)
        for (i = 0; i < 3; i++)
            v_out[i] = w[0] * x[i] + w[1] * y[i] + w[2] * z[i];
    else if (rc == SWL_CAPTURED)
        v_out[0] = v_out[1] = v_out[2] = 0.0;
    return rc;
}
