/*
 * swl.h -- read and sample a microimpact stochastic wall law (portable C99).
 *
 * The wall law is the table that `microimpact wall-law` builds (docs/wall-law.md):
 * at every node (surface, diameter, speed, angle) a capture probability and a
 * reservoir of K joint rebound samples (e_n, mu, lateral angle, speed ratio) of
 * the Monte Carlo
 * model of Li, Dunn & Brach (2000). This reader loads the binary export of that
 * table (`wall_law.swl`, written by microimpact.wall_law.export_c.write_binary)
 * and samples it exactly as docs/wall-law.md, "The sampling rule", says -- the same
 * rule as the Python sampler microimpact's WallLaw.sample_uniform, given the same
 * five uniform numbers. It needs only libc and libm; the caller supplies the
 * uniform numbers, so any CFD code's random generator can be used.
 *
 * Wall frame (docs/wall-law.md): z is the outward normal of the wall (into the
 * fluid), x the incoming particle's tangential direction of travel, y = z x x.
 * The particle arrives with speed s at the angle theta from the wall plane
 * (90 deg = normal incidence): u = (s cos theta, 0, -s sin theta).
 *
 * ---------------------------------------------------------------------------
 * Binary format, version 3 (all numbers little-endian; offsets in bytes).
 * This reader also reads version 2, which is version 3 with the sections word
 * 0, and version 1, which is version 2 with speed axis code 0. microimpact
 * writes version 3 only for a table with a section (else version 2), so a
 * reader older than version 3 still reads every table without one.
 * ---------------------------------------------------------------------------
 * Header, 64 bytes:
 *     0  char[8]   magic "SWLTABL\0"
 *     8  uint32    format version (3, 2 or 1)
 *    12  uint32    S  number of surfaces           (>= 1)
 *    16  uint32    D  number of diameters          (>= 1)
 *    20  uint32    V  number of speeds             (>= 1)
 *    24  uint32    A  number of angles             (>= 1)
 *    28  uint32    K  reservoir size (samples/node) (>= 1)
 *    32  uint32    W  width of a surface name field (64)
 *    36  uint32    the speed axis: 0 absolute (the speed nodes are speeds in
 *                  m/s), 1 reduced (they are ratios r = v / v_c(d), and the
 *                  critical speeds v_c follow the axes); always 0 in version 1
 *    40  uint64    total file size in bytes
 *    48  uint32    CRC-32 (zlib's) of every byte after the header
 *    52  uint32    sections (version 3; 0 in versions 1 and 2): bit 0 set
 *                  where the stay_probability section follows the counts;
 *                  no other bit may be set
 *    56  char[8]   0  (reserved)
 * Payload, in this order (N = S*D*V*A nodes, arrays in C order over
 * (surface, diameter, speed, angle[, sample])):
 *     S * W bytes      surface names, UTF-8, NUL-padded (at least one NUL)
 *     D float64        diameter_um, strictly increasing, > 0
 *     V float64        speed_m_s (axis 0) or reduced_speed r (axis 1), strictly
 *                      increasing, > 0
 *     A float64        angle_deg, strictly increasing
 *     D float64        critical_speed_m_s v_c(d) at each diameter node, finite
 *                      and > 0: present only on a reduced speed axis (code 1)
 *     N float64        capture_probability, in [0, 1], or NaN (no impact)
 *     N*K float64      reservoir_e_n
 *     N*K float64      reservoir_mu
 *     N*K float64      reservoir_lateral_angle_deg, in (-90, 90)
 *     N*K float64      reservoir_speed_ratio, |U| / s >= 0
 *     N int32          reservoir_count, in [0, K]; 0 only where the capture
 *                      probability is 1 or NaN; the first count samples of a
 *                      node are finite, the rest are ignored (NaN by convention)
 *     N float64        stay_probability, finite and in [0, 1]: present only
 *                      where sections bit 0 is set. The probability that a
 *                      particle captured at the node stays on the wall after
 *                      the exposure of the scenario's [resuspension] table
 *                      (Rock'n'Roll, at the node's diameter; microimpact's
 *                      docs/resuspension.md: quasi-steady flow, independent
 *                      particles, the stated friction velocity and exposure)
 * The file ends there: its size is 64 + S*W + 8*(D+V+A) + 8*N*(1+4K) + 4*N,
 * plus 8*D on a reduced speed axis and 8*N with the stay_probability section.
 * The CRC-32 covers every section.
 *
 * On a reduced speed axis the speed variable of a query (d, v) is
 * log(v) - log v_c(d), where log v_c(d) is interpolated linearly in log d between
 * the diameter nodes of the query's diameter cell, at the query's own fraction of
 * it (the end node's v_c outside the diameter range); nodes at the same r then
 * follow the capture edge, v = v_c(d) at normal incidence.
 * swl_load checks all of this and returns an error code for any file that breaks
 * it (truncated, trailing bytes, wrong magic or version, bad CRC, bad values).
 *
 * Value ranges (checked on load, SWL_E_VALUE; every check is NaN-safe, so a host
 * that traps floating-point exceptions never traps inside swl_load or
 * swl_sample):
 *     diameter and speed nodes, critical speeds: finite, > 0, and the axes
 *         strictly increasing, in log too (two nodes one last place apart are not);
 *     angle nodes in (0, 90], strictly increasing;
 *     capture_probability in [0, 1] or NaN;
 *     each held sample: |e_n| <= 1e6, |mu| <= 1e12 (far beyond the model's
 *         values; they keep the sampler's arithmetic far from overflow),
 *         lateral angle in (-90, 90), speed_ratio in [0, 1], and at its node's
 *         angle theta |e_n sin theta| <= 1 and |cos theta - mu (1 + e_n) sin
 *         theta| <= 1, to 1e-9 (|U_z| and |U_x| at most the incoming speed).
 *         e_n is the apparent restitution: negative for a re-impact, above 1 at
 *         grazing angles (up to 1 / sin theta), so [0, 1] would refuse real
 *         tables.
 * A sample is therefore always finite and never faster than the impact:
 * |U| = speed_ratio * s <= s, up to rounding (a few units in the last place).
 *
 * ---------------------------------------------------------------------------
 * Uniform numbers
 * ---------------------------------------------------------------------------
 * Each sample takes u[0..4] in [0, 1): u[0] picks the diameter corner, u[1] the
 * speed corner, u[2] the angle corner, u[3] decides capture and u[4] picks the
 * reservoir sample. All five are consumed on every call, whatever the outcome,
 * so a caller may draw them in blocks of five. On a table with a
 * stay_probability q the same u[3] also decides whether a captured particle
 * stays: captured where u[3] < p, stays where u[3] < p * q (given capture,
 * u[3] / p is uniform, so it stays with probability q), else the sample is
 * still SWL_CAPTURED with SWL_FLAG_RESUSPENDED set. No sixth number is drawn.
 */
#ifndef SWL_H
#define SWL_H

#ifdef __cplusplus
extern "C" {
#endif

#define SWL_FORMAT_VERSION 3 /* the newest format read; versions 1, 2 too */
#define SWL_NAME_WIDTH 64 /* bytes per surface name in the file, NULs included */

/* Results of a sample (>= 0) and errors (< 0). */
enum {
    SWL_REBOUND = 0,     /* velocity holds the rebound */
    SWL_CAPTURED = 1,    /* the particle sticks; velocity is (0, 0, 0) */
    SWL_NO_DATA = 2,     /* the chosen node had no impact (NaN); velocity is NaN */
    SWL_E_ARG = -1,      /* bad argument: NULL, unknown surface, a diameter not > 0,
                            a speed below DBL_MIN (2.2e-308, or not a number), an
                            angle outside (0, 90], u outside [0, 1), NaN */
    SWL_E_IO = -2,       /* the file cannot be opened or read */
    SWL_E_MAGIC = -3,    /* not a wall-law table (wrong magic) */
    SWL_E_VERSION = -4,  /* a format version this reader does not know */
    SWL_E_TRUNCATED = -5,/* the file ends before its data does */
    SWL_E_SIZE = -6,     /* sizes in the header are invalid or disagree with the file */
    SWL_E_CHECKSUM = -7, /* the CRC-32 of the payload does not match */
    SWL_E_VALUE = -8,    /* a value breaks the format (unsorted axis, count > K, ...) */
    SWL_E_NOMEM = -9,    /* out of memory */
    SWL_E_UNIT = -10,    /* a query that looks like a wrong unit: a diameter below
                            0.01 um (metres given as um: 3e-6 for 3 um), or a speed
                            above 1 km/s and above the table's fastest node (mm/s
                            given as m/s), or a velocity component above 1e150 */
    SWL_E_NO_STAY = -11  /* the table carries no stay_probability (built without
                            a [resuspension] table) */
};

/* The speed axis of a table (swl_speed_axis). */
enum { SWL_SPEED_ABSOLUTE = 0, SWL_SPEED_REDUCED = 1 };

/* Bits of *flags. A query is clamped on an axis where it lies outside the
 * axis' end nodes by more than 1e-9 relative (round-off is not clamping). */
#define SWL_FLAG_CLAMPED_DIAMETER 1 /* the diameter was outside the table's range */
#define SWL_FLAG_CLAMPED_SPEED 2    /* the speed was outside the table's range */
#define SWL_FLAG_CLAMPED_ANGLE 4    /* the angle was outside the table's range */
#define SWL_FLAG_CLAMPED 7          /* any of the three */
#define SWL_FLAG_REIMPACT 8         /* rebound with U_z < 0: strike the wall again */
#define SWL_FLAG_RESUSPENDED 16     /* captured, then removed by the flow of the
                                       [resuspension] table (u[3] >= p * q) */

typedef struct swl_law swl_law; /* opaque; read only after swl_load */

/* Load the table at `path`. On success returns 0 and sets *out (free it with
 * swl_free); on failure returns a negative SWL_E_* code and sets *out to NULL. */
int swl_load(const char *path, swl_law **out);

/* Release a table from swl_load (NULL is allowed). */
void swl_free(swl_law *law);

/* A short English message for a result or error code (a static string). */
const char *swl_strerror(int code);

/* The index of the surface named `name`, or SWL_E_ARG if there is none. */
int swl_surface_index(const swl_law *law, const char *name);

/* Table sizes: number of surfaces, diameters, speeds, angles, reservoir size K.
 * Returns SWL_E_ARG for a NULL law or an unknown `what`. */
enum { SWL_DIM_SURFACE, SWL_DIM_DIAMETER, SWL_DIM_SPEED, SWL_DIM_ANGLE, SWL_DIM_RESERVOIR };
int swl_size(const swl_law *law, int what);

/* SWL_SPEED_ABSOLUTE or SWL_SPEED_REDUCED (the table's speed axis, which the
 * sampler handles itself: queries are always in m/s), SWL_E_ARG for NULL. */
int swl_speed_axis(const swl_law *law);

/* 1 where the table carries stay_probability (format version 3, section bit
 * 0), 0 where not, SWL_E_ARG for NULL. */
int swl_has_stay(const swl_law *law);

/*
 * The probability that a particle captured at the query (surface, diameter
 * [um], speed [m/s], angle [deg]; checked as in swl_sample) stays on the wall
 * after the table's [resuspension] exposure, under the sampling rule: with w_c
 * the probability of picking corner c of the query's cell, p_c its capture
 * probability and q_c its stay_probability,
 *     *probability = sum_c w_c p_c q_c / sum_c w_c p_c
 * over the corners with w_c > 0 and p_c not NaN (in the corner order diameter,
 * speed, angle, lower node first); where that denominator is 0 (nothing can be
 * captured there) sum_c w_c q_c / sum_c w_c. Returns 0, SWL_NO_DATA (no
 * corner has data; *probability NaN), SWL_E_NO_STAY, or an error of
 * swl_sample. *flags (may be NULL) gets the SWL_FLAG_CLAMPED_* bits.
 */
int swl_stay_probability(const swl_law *law, int surface, double diameter_um,
                         double speed_m_s, double angle_deg, double *probability,
                         int *flags);

/* The name of surface `surface` (NUL-terminated), or NULL if out of range. */
const char *swl_surface_name(const swl_law *law, int surface);

/*
 * Sample the law at (surface, diameter [um] > 0, speed [m/s] > 0, angle [deg from
 * the wall plane] in (0, 90]) with the uniform numbers u[0..4] (see above).
 * Writes the rebound velocity in the wall frame into velocity[3] and the
 * SWL_FLAG_* bits into *flags (flags may be NULL; SWL_FLAG_RESUSPENDED on a
 * capture that does not stay, on a table with stay_probability). Returns SWL_REBOUND,
 * SWL_CAPTURED, SWL_NO_DATA or a negative error (then velocity is NaN).
 * Queries outside an axis' range use its end node and are flagged clamped; the
 * velocity is always built at the query's own speed and angle.
 */
int swl_sample(const swl_law *law, int surface, double diameter_um, double speed_m_s,
               double angle_deg, const double u[5], double velocity[3], int *flags);

/*
 * swl_sample for n queries: arrays diameter_um[n], speed_m_s[n], angle_deg[n],
 * u[5n], velocity[3n], status[n] and flags[n] (flags may be NULL). Returns 0, or
 * SWL_E_ARG for a NULL law or array (per-query errors are in status).
 */
int swl_sample_n(const swl_law *law, int surface, long n, const double *diameter_um,
                 const double *speed_m_s, const double *angle_deg, const double *u,
                 double *velocity, int *status, int *flags);

/*
 * The rebound of a particle with velocity v_in[3] on a wall with outward normal
 * normal[3] (pointing from the wall into the fluid; it need not be of unit
 * length), both in the caller's frame. The particle must move into the wall,
 * dot(v_in, normal) < 0; otherwise SWL_E_ARG (the caller decides what a particle
 * sliding along the wall does).
 * It computes the speed s = |v_in|, the angle theta = atan2(-v_n, |v_t|) from the
 * wall plane, and the wall axes z = normal/|normal|, x = v_t/|v_t| (v_t the
 * tangential part of v_in) and y = z x x. At exactly normal incidence (v_t = 0)
 * x is the unit vector along e_k - n_k n, with e_k the axis of the smallest |n_k|
 * (the first such k): any x orthogonal to n would do, this one is deterministic.
 * Then it samples like swl_sample and writes the rebound velocity, turned back
 * into the caller's frame, into v_out[3] ((0, 0, 0) if captured, NaN if no data).
 */
int swl_rebound_velocity(const swl_law *law, int surface, double diameter_um,
                         const double v_in[3], const double normal[3], const double u[5],
                         double v_out[3], int *flags);

#ifdef __cplusplus
}
#endif

#endif /* SWL_H */
