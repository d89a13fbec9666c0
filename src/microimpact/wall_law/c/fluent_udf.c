/*
 * fluent_udf.c -- Ansys Fluent DPM wall boundary condition from a microimpact wall law.
 *
 * A thin DEFINE_DPM_BC wrapper around swl.c: at every wall hit it turns the
 * particle's velocity into the wall frame with the face normal, samples the wall
 * law (capture, or a rebound drawn from the node's reservoir; docs/wall-law.md)
 * with five numbers from Fluent's uniform generator, and writes the rebound
 * velocity back, or ends the particle if it is captured.
 *
 * Use (compiled UDF): Source Files fluent_udf.c and swl.c, Header Files swl.h;
 * hook `microimpact_wall` as the wall's Discrete Phase BC (type user-defined).
 * The table is read once per process, on the first wall hit (or when the
 * on-demand function `microimpact_wall_report` runs), from the file named by the
 * environment variable MICROIMPACT_SWL_TABLE, else SWL_TABLE_PATH below (relative
 * to Fluent's working folder). The surface is the one named by
 * MICROIMPACT_SWL_SURFACE, else SWL_SURFACE_NAME, else the table's first surface.
 * For several surfaces, copy `microimpact_wall` below under another name with
 * another surface name. Either speed axis of the table (absolute, or reduced
 * v / v_c(d); binary format version 1, 2 or 3) is handled inside swl.c: the
 * wrapper always passes the particle's diameter in um and its velocity in m/s.
 *
 * What it does the Fluent way (sources [1]-[4] below):
 * - The DEFINE_DPM_BC(name, tp, t, f, f_normal, dim) signature [3], the unit face
 *   normal f_normal, the 2-D axisymmetric-swirl normal built from the particle
 *   position, the new velocity written into both TP_VEL and TP_VEL0, PATH_ACTIVE
 *   returned to keep tracking [1].
 * - A captured (trapped) particle: velocity set to zero and PATH_ABORT returned,
 *   as the particle-trap example does [4]. CAVEAT: Fluent's DPM summary lists a
 *   particle stopped with PATH_ABORT under *aborted*; its *trapped* count belongs
 *   to the built-in trap condition (check the report of your release). Count
 *   captures with `microimpact_wall_report` (per process) or your own UDM.
 *   SWL_CAPTURE_STATUS changes the returned status.
 * - Resuspension: a table built with a [resuspension] table (format version 3)
 *   says, from the same five numbers, whether a captured particle stays after
 *   the stated exposure at the stated friction velocity (swl.h,
 *   SWL_FLAG_RESUSPENDED; quasi-steady flow, independent particles). Such a
 *   particle is counted as resuspended (`microimpact_wall_report`) and ends
 *   with SWL_RESUSPENDED_STATUS (default PATH_ABORT, as a capture: it leaves
 *   the wall's deposit, and this wrapper does not re-inject it).
 * - A particle whose diameter is below 0.01 um or whose speed is above 1 km/s
 *   beyond the table (SWL_E_UNIT: a unit slip) is aborted (PATH_ABORT) and the
 *   reason is printed once with Message().
 * - Uniform numbers: `float uniform_random(void)` of Fluent's random.h [2] (which
 *   also declares cheap_uniform_random, the one the wall-jet example [1] uses);
 *   define SWL_UNIFORM() to use another generator.
 * - f_normal points out of the fluid in Fluent's examples (the wall-jet example
 *   [1] takes dot(v, f_normal) > 0 for a particle hitting the wall); this wrapper
 *   does not rely on it: the wall's outward normal is whichever of +-f_normal
 *   faces the incoming particle.
 * Sources:
 * [1] Ansys Fluent UDF Manual, DEFINE_DPM_BC, Example 1 "reflect boundary
 *     condition for inert particles" and Example 2 (Naber & Reitz wall jet),
 *     e.g. FLUENT 6.3 UDF Manual (2006) section 2.5.1.
 * [2] Fluent's random.h (ANSYS 1987-2022): float uniform_random(void);
 *     real cheap_uniform_random(void).
 * [3] Fluent's udf.h: DEFINE_DPM_BC(name, tp, t, f, normal, dim) is
 *     int name(Tracked_Particle *tp, Thread *t, face_t f, real normal[], int dim);
 *     dpm.h: Path_Status { PATH_END, PATH_ACTIVE, PATH_BREAK, PATH_ABORT, ... }.
 * [4] The "UDF particle trap criteria" example circulated with the manual's
 *     DEFINE_DPM_BC examples ("captured by the wall (trapped, using a return of
 *     PATH_ABORT)"); user deposition UDFs end a stuck particle the same way.
 * Limits: stationary walls only (the wall's velocity is not subtracted); in 2-D
 * planar cases the lateral (out-of-plane) rebound component is dropped (it is 0
 * for profile roughness); TP_* macros are those of recent Fluent releases (older
 * ones name them P_*). The lazy load is not thread-safe: with hybrid (threaded)
 * DPM parallel, run `microimpact_wall_report` once before tracking.
 */
#include "udf.h"
#include "random.h"

#include <math.h>
#include <stdlib.h>

#include "swl.h"

#ifndef SWL_TABLE_PATH
#define SWL_TABLE_PATH "wall_law.swl"
#endif
#ifndef SWL_SURFACE_NAME
#define SWL_SURFACE_NAME NULL /* NULL: the table's first surface */
#endif
#ifndef SWL_UNIFORM
#define SWL_UNIFORM() ((double)uniform_random())
#endif
#ifndef SWL_CAPTURE_STATUS
#define SWL_CAPTURE_STATUS PATH_ABORT
#endif
#ifndef SWL_RESUSPENDED_STATUS
#define SWL_RESUSPENDED_STATUS PATH_ABORT
#endif

static swl_law *swl_fluent_law = NULL;
static int swl_fluent_state = 1; /* 1 not tried, 0 loaded, < 0 the load error */
/* outcomes in this process: rebound, captured, reflected specularly (no data at
 * the node, or a particle sliding along the face), aborted (no table), and of
 * the captured those resuspended (SWL_FLAG_RESUSPENDED) */
static long swl_fluent_count[5] = {0, 0, 0, 0, 0};
static int swl_fluent_unit_said = 0; /* the wrong-unit message was printed */

static int swl_fluent_load(void)
{
    const char *path;
    if (swl_fluent_state == 1) {
        path = getenv("MICROIMPACT_SWL_TABLE");
        if (!path || !*path)
            path = SWL_TABLE_PATH;
        swl_fluent_state = swl_load(path, &swl_fluent_law);
        if (swl_fluent_state != 0)
            Message("microimpact wall law: cannot load %s: %s; particles hitting "
                    "these walls are aborted\n",
                    path, swl_strerror(swl_fluent_state));
    }
    return swl_fluent_state;
}

/* The surface index of `name` (NULL: MICROIMPACT_SWL_SURFACE, else the first);
 * an unknown name is reported once. */
static int swl_fluent_surface(const char *name)
{
    static int warned = 0;
    int s;
    if (!name)
        name = getenv("MICROIMPACT_SWL_SURFACE");
    if (!name || !*name)
        return 0;
    s = swl_surface_index(swl_fluent_law, name);
    if (s < 0 && !warned) {
        warned = 1;
        Message("microimpact wall law: no surface named '%s' in the table; particles "
                "hitting these walls are aborted\n",
                name);
    }
    return s;
}

/* A uniform number in [0, 1) from Fluent's generator (a float may round to 1). */
static double swl_fluent_uniform(void)
{
    double u = SWL_UNIFORM();
    if (!(u >= 0.0))
        u = 0.0;
    if (u >= 1.0)
        u = nextafter(1.0, 0.0);
    return u;
}

/* The wall hit of particle tp on a face with unit normal f_normal, for the
 * surface named `surface` (see swl_fluent_surface). */
static int swl_fluent_hit(Tracked_Particle *tp, real f_normal[], int dim,
                          const char *surface)
{
    double v[3] = {0.0, 0.0, 0.0}, n[3] = {0.0, 0.0, 0.0}, out[3], u[5], vn = 0.0;
    int i, rc, flags, s, idim = dim;

    for (i = 0; i < 5; i++) /* always five per hit, whatever the outcome */
        u[i] = swl_fluent_uniform();
    if (swl_fluent_load() != 0) {
        swl_fluent_count[3]++;
        return PATH_ABORT;
    }
    s = swl_fluent_surface(surface);
    if (s < 0) {
        swl_fluent_count[3]++;
        return PATH_ABORT;
    }

#if RP_2D
    /* 2-D axisymmetric swirl: a 3-D normal from the particle's position, as in
     * the manual's reflect example */
    if (rp_axi_swirl) {
        double r = sqrt(TP_POS(tp)[1] * TP_POS(tp)[1] + TP_POS(tp)[2] * TP_POS(tp)[2]);
        if (r > 1.e-20) {
            idim = 3;
            n[0] = f_normal[0];
            n[1] = f_normal[1] * TP_POS(tp)[1] / r;
            n[2] = f_normal[1] * TP_POS(tp)[2] / r;
        } else {
            for (i = 0; i < idim; i++)
                n[i] = f_normal[i];
        }
    } else
#endif
        for (i = 0; i < idim; i++)
            n[i] = f_normal[i];

    for (i = 0; i < idim; i++) {
        v[i] = TP_VEL(tp)[i];
        vn += v[i] * n[i];
    }
    if (vn > 0.0) /* the outward normal of the wall faces the incoming particle */
        for (i = 0; i < idim; i++)
            n[i] = -n[i];

    /* the particle diameter in um; the table's diameters are in um */
    rc = swl_rebound_velocity(swl_fluent_law, s, 1.0e6 * (double)TP_DIAM(tp), v, n, u,
                              out, &flags);
    if (rc == SWL_CAPTURED) {
        swl_fluent_count[1]++;
        for (i = 0; i < idim; i++)
            TP_VEL(tp)[i] = TP_VEL0(tp)[i] = 0.0;
        if (flags & SWL_FLAG_RESUSPENDED) {
            swl_fluent_count[4]++;
            return SWL_RESUSPENDED_STATUS;
        }
        return SWL_CAPTURE_STATUS;
    }
    if (rc == SWL_NO_DATA || rc == SWL_E_ARG) {
        /* no impact tabulated at the node (every draw shadowed), or a particle
         * sliding along the face (v.n = 0) or with a zero diameter: reflect it
         * specularly */
        swl_fluent_count[2]++;
        vn = 0.0;
        for (i = 0; i < idim; i++)
            vn += v[i] * n[i];
        for (i = 0; i < idim; i++)
            out[i] = v[i] - 2.0 * vn * n[i];
    } else if (rc == SWL_E_UNIT) {
        /* a diameter below 0.01 um or a speed above 1 km/s beyond the table: a
         * unit slip (TP_DIAM is in metres; the table's diameters in um). Said
         * once, the particle aborted every time. */
        swl_fluent_count[3]++;
        if (!swl_fluent_unit_said) {
            swl_fluent_unit_said = 1;
            Message("\nmicroimpact wall law: %s (diameter %g um, speed %g m/s); "
                    "such particles are aborted, this is said once\n",
                    swl_strerror(rc), 1.0e6 * (double)TP_DIAM(tp),
                    sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]));
        }
        return PATH_ABORT;
    } else if (rc != SWL_REBOUND) {
        swl_fluent_count[3]++;
        return PATH_ABORT;
    } else {
        swl_fluent_count[0]++;
    }
    /* a re-impact (flags & SWL_FLAG_REIMPACT: U_z < 0) is passed on as it is:
     * Fluent meets the wall again on the particle's next step */
    for (i = 0; i < idim; i++)
        TP_VEL(tp)[i] = TP_VEL0(tp)[i] = (real)out[i];
    return PATH_ACTIVE;
}

DEFINE_DPM_BC(microimpact_wall, tp, t, f, f_normal, dim)
{
    (void)t;
    (void)f;
    return swl_fluent_hit(tp, f_normal, dim, SWL_SURFACE_NAME);
}

/* Loads the table now (before tracking) and prints this process's counts. */
DEFINE_ON_DEMAND(microimpact_wall_report)
{
    if (swl_fluent_load() == 0)
        Message("microimpact wall law: %ld rebounds, %ld captured (%ld of them "
                "resuspended after the table's exposure), %ld reflected "
                "specularly, %ld aborted\n",
                swl_fluent_count[0], swl_fluent_count[1], swl_fluent_count[4],
                swl_fluent_count[2], swl_fluent_count[3]);
}
