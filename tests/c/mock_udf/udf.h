/*
 * A SMALL mock of Ansys Fluent's udf.h: only what
 * src/microimpact/wall_law/c/fluent_udf.c uses, so that the wrapper compiles
 * (cc -std=c99 -Wall -Werror -c) and runs in the tests without Fluent.
 * It is not Fluent's header: the names and signatures follow the Fluent UDF
 * Manual (DEFINE_DPM_BC(name, tp, t, f, f_normal, dim) returning an int Path_Status,
 * TP_VEL/TP_VEL0/TP_DIAM/TP_POS, Message), the layout behind them is made up.
 */
#ifndef MOCK_FLUENT_UDF_H
#define MOCK_FLUENT_UDF_H

#ifndef RP_2D
#define RP_2D 0
#endif
#define RP_3D (!RP_2D)

#ifdef MOCK_UDF_SINGLE
typedef float real; /* Fluent's single-precision solver */
#else
typedef double real; /* Fluent's double-precision solver */
#endif
typedef int face_t;
typedef struct mock_thread Thread; /* opaque here */

typedef struct {
    real pos[3];
    real V[3];
    real diam;
} mock_particle_state;

typedef struct {
    mock_particle_state state;  /* current state */
    mock_particle_state state0; /* state at the start of the step */
} Tracked_Particle;

#define TP_POS(tp) ((tp)->state.pos)
#define TP_VEL(tp) ((tp)->state.V)
#define TP_VEL0(tp) ((tp)->state0.V)
#define TP_DIAM(tp) ((tp)->state.diam)

/* Path_Status, in the order of Fluent's dpm.h */
typedef enum { PATH_END, PATH_ACTIVE, PATH_BREAK, PATH_ABORT, PATH_STOP } Path_Status;

extern int rp_axi_swirl; /* 2-D axisymmetric swirl case */

void Message(const char *format, ...);

#define DEFINE_DPM_BC(name, tp, t, f, f_normal, dim) \
    int name(Tracked_Particle *tp, Thread *t, face_t f, real f_normal[], int dim)
#define DEFINE_ON_DEMAND(name) void name(void)

#endif /* MOCK_FLUENT_UDF_H */
