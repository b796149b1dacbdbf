/* fastexp_unit.c -- gw_fm_log, gw_fm_exp and their 4-lane forms as out-of-line functions, a
 * translation unit of its own so that tests/test_fastmath.py can compile it with a parent
 * project's flags (-ffast-math -fno-finite-math-only) and measure it from tests/c/test_fastexp.c
 * compiled with IEEE semantics (-DGW_FASTEXP_UNIT). */
#include "gw_fm_logexp.h"

double unit_log(double x);
double unit_exp(double x);
void unit_log4(double *y, const double *x);
void unit_exp4(double *y, const double *x);

double unit_log(double x) { return gw_fm_log(x); }
double unit_exp(double x) { return gw_fm_exp(x); }

/* y[l] = ln x[l], e^x[l], l < 4 (the scalar form where the compiler has no vector extension) */
#if GW_FASTMATH_V4
#define UNIT4(name, f4, f1)                                                                       \
    void name(double *y, const double *x) {                                                       \
        gw_fm_v4 v, r;                                                                            \
        memcpy(&v, x, sizeof v);                                                                  \
        f4(&r, &v);                                                                               \
        memcpy(y, &r, sizeof r);                                                                  \
    }
#else
#define UNIT4(name, f4, f1)                                                                       \
    void name(double *y, const double *x) {                                                       \
        int l;                                                                                    \
        for (l = 0; l < 4; l++) y[l] = f1(x[l]);                                                  \
    }
#endif
UNIT4(unit_log4, gw_fm_log4, gw_fm_log)
UNIT4(unit_exp4, gw_fm_exp4, gw_fm_exp)
