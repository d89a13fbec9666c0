/*
 * fpe_traps.c -- switch floating-point traps on and off around calls into swl.c
 * from the ctypes tests (tests/wall_law/test_wall_law_c.py), as OpenFOAM runs with
 * FOAM_SIGFPE: an invalid operation (an ordered comparison of a NaN, 0/0), a
 * division by zero or an overflow inside the sampler raises SIGFPE and kills the
 * test process, instead of passing unseen. glibc only (feenableexcept); elsewhere
 * both functions return -1 and the tests skip what needs them.
 */
#define _GNU_SOURCE
#include <fenv.h>

#define SWL_TRAPS (FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW)

int swl_test_traps_on(void)
{
#if defined(__GLIBC__)
    feclearexcept(FE_ALL_EXCEPT); /* no stale flag may fire on enabling */
    return feenableexcept(SWL_TRAPS) < 0 ? -1 : 0;
#else
    return -1;
#endif
}

int swl_test_traps_off(void)
{
#if defined(__GLIBC__)
    int rc = fedisableexcept(SWL_TRAPS) < 0 ? -1 : 0;
    feclearexcept(FE_ALL_EXCEPT);
    return rc;
#else
    return -1;
#endif
}
