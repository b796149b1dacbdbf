/* fastmath_unit.c -- gw_sincos and gw_sincos2 as out-of-line functions, a translation unit of
 * its own so that tests/test_fastmath.py can compile it with a parent project's flags
 * (-ffast-math -fno-finite-math-only) and measure it from a harness compiled with IEEE
 * semantics (tests/c/test_fastmath_flags.c). */
#include "gw_sincos.h"

void unit_sincos(double x, double *s, double *c);
void unit_sincos2(double x0, double x1, double *s0, double *c0, double *s1, double *c1);

void unit_sincos(double x, double *s, double *c) { gw_sincos(x, s, c); }

void unit_sincos2(double x0, double x1, double *s0, double *c0, double *s1, double *c1) {
    gw_sincos2(x0, x1, s0, c0, s1, c1);
}
