/*
 * test_fastexp.c -- the error of gw_fm_log / gw_fm_exp (c_src/gw_fm_logexp.h) in ulps against glibc's
 * long double logl / expl (64-bit significand), and the bit-equality of the 4-lane forms
 * gw_fm_log4 / gw_fm_exp4 with them, lane by lane:
 *   log  norms   3e6 log-uniform points in [1e-300, 1e300] (the step size's norms N_j)
 *        unit    2e6 uniform points in [0.5, 2] (the reduction's seams at sqrt(2)/2, sqrt(2))
 *        subnorm 2e5 log-uniform subnormals and DBL_MIN's neighbours
 *   exp  step    3e6 uniform points in [-60, 10] (ln h of the step size: h from 1e-26 to 2e4)
 *        wide    2e6 uniform points in [-745, 709.7] (every normal and subnormal result)
 * Fails if any error is not below GW_FASTEXP_ULP_BOUND (default 1 ulp), if a lane of the 4-lane
 * forms is not bit-equal to the scalar form (lanes filled with the current and 3 earlier
 * points, each in every lane position), or on the special values: log(0) = -inf, log(inf) =
 * inf, log(-1), log(NaN), exp(NaN) NaN, exp(+-inf) = inf / 0, exp(710) = inf, exp(-746) = 0,
 * log(1) = 0, exp(0) = 1.  Run by tests/test_fastmath.py (gcc and clang, strict flags, also
 * with AVX2).
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fm_check.h"
#include "gw_fm_logexp.h"

/* the functions measured: tests/c/fastexp_unit.c's, in this translation unit (inlined), or
 * (-DGW_FASTEXP_UNIT) compiled on its own with other flags; the lanes' bit-equality is then
 * reported, and required only with -DGW_FASTEXP_LANES_EXACT=1 */
#ifdef GW_FASTEXP_UNIT
double unit_log(double x);
double unit_exp(double x);
void unit_log4(double *y, const double *x);
void unit_exp4(double *y, const double *x);
#ifndef GW_FASTEXP_LANES_EXACT
#define GW_FASTEXP_LANES_EXACT 0
#endif
#else
#include "fastexp_unit.c"
#ifndef GW_FASTEXP_LANES_EXACT
#define GW_FASTEXP_LANES_EXACT 1
#endif
#endif
#define FX_LOG unit_log
#define FX_EXP unit_exp
#define FX_LOG4 unit_log4
#define FX_EXP4 unit_exp4

#ifndef GW_FASTEXP_ULP_BOUND
#define GW_FASTEXP_ULP_BOUND 0.9
#endif

static long n_lane_differ;

typedef struct {
    const char *name;
    double max, at, max_libm;
    long n, rounded;
} tally;

static double ulp_error(double v, long double ref) {
    long double ulp;
    if (isinf(v) && isinf((double)ref) && (v > 0) == (ref > 0)) return 0.0;
    if (ref == 0.0L) return v == 0.0 ? 0.0 : INFINITY;
    ulp = fabsl(ref) < (long double)DBL_MIN ? ldexpl(1.0L, -1074) : ldexpl(1.0L, ilogbl(ref) - 52);
    return (double)(fabsl((long double)v - ref) / ulp);
}

/* the last 4 arguments in every lane rotation of gw_fm_log4 / gw_fm_exp4 against the scalar form */
static double ring[4] = {1.0, 2.0, 0.5, 3.0};
static long ring_at;
static void lanes(int is_log) {
    int rot, l;
    for (rot = 0; rot < 4; rot++) {
        double x[4], y[4];
        for (l = 0; l < 4; l++) x[l] = ring[(l + rot) & 3];
        if (is_log)
            FX_LOG4(y, x);
        else
            FX_EXP4(y, x);
        for (l = 0; l < 4; l++) {
            const double s = is_log ? FX_LOG(x[l]) : FX_EXP(x[l]), v = y[l];
            n_lane_differ += memcmp(&s, &v, sizeof s) != 0;
        }
    }
}

static void measure(tally *t, int is_log, double x) {
    const long double ref = is_log ? logl((long double)x) : expl((long double)x);
    const double v = is_log ? FX_LOG(x) : FX_EXP(x);
    const double e = ulp_error(v, ref), el = ulp_error(is_log ? log(x) : exp(x), ref);
    ring[ring_at++ & 3] = x;
    if ((ring_at & 3) == 0) lanes(is_log);
    if (e > t->max || e != e) {
        t->max = e != e ? INFINITY : e;
        t->at = x;
    }
    if (el > t->max_libm) t->max_libm = el;
    t->rounded += v == (double)ref;
    t->n++;
}

static void report(const tally *t) {
    n_checks++;
    printf("%-8s %8ld points: max ulp %.3f (x=%.17g); glibc %.3f; correctly rounded %.4f%%\n",
           t->name, t->n, t->max, t->at, t->max_libm, 100.0 * (double)t->rounded / (double)t->n);
    if (!(t->max < GW_FASTEXP_ULP_BOUND)) {
        n_failures++;
        fprintf(stderr, "%s: error %.3f ulp, not below %g\n", t->name, t->max, (double)GW_FASTEXP_ULP_BOUND);
    }
}

int main(void) {
    tally norms = {"norms", 0, 0, 0, 0, 0}, unit = {"unit", 0, 0, 0, 0, 0};
    tally sub = {"subnorm", 0, 0, 0, 0, 0}, step = {"step", 0, 0, 0, 0, 0};
    tally wide = {"wide", 0, 0, 0, 0, 0};
    const double sp[] = {0.0, -0.0, 1.0, INFINITY, -INFINITY, NAN, -1.0, 710.0, -746.0,
                         DBL_MAX, DBL_MIN, 4.9406564584124654e-324};
    long i;
    int j;
    double x;
    for (i = 0; i < 3000000L; i++) measure(&norms, 1, pow(10.0, -300.0 + 600.0 * uniform01()));
    for (i = 0; i < 2000000L; i++) measure(&unit, 1, 0.5 + 1.5 * uniform01());
    for (i = 0; i < 200000L; i++) measure(&sub, 1, ldexp(1.0 + uniform01(), -1074 + (int)(52 * uniform01())));
    for (x = DBL_MIN, j = 0; j < 8; j++, x = nextafter(x, 0.0)) measure(&sub, 1, x);
    for (i = 0; i < 3000000L; i++) measure(&step, 0, -60.0 + 70.0 * uniform01());
    for (i = 0; i < 2000000L; i++) measure(&wide, 0, -745.0 + 1454.7 * uniform01());
    report(&norms);
    report(&unit);
    report(&sub);
    report(&step);
    report(&wide);
    check(FX_LOG(0.0) == -INFINITY && FX_LOG(-0.0) == -INFINITY, "log(0) is not -inf", 0.0);
    check(FX_LOG(INFINITY) == INFINITY, "log(inf) is not inf", INFINITY);
    check(isnan(FX_LOG(-1.0)) && isnan(FX_LOG(-INFINITY)) && isnan(FX_LOG(NAN)), "log: not NaN", -1.0);
    check(FX_LOG(1.0) == 0.0 && FX_EXP(0.0) == 1.0, "log(1), exp(0)", 1.0);
    check(isnan(FX_EXP(NAN)), "exp(NaN) is not NaN", NAN);
    check(FX_EXP(INFINITY) == INFINITY && FX_EXP(710.0) == INFINITY, "exp: no overflow", 710.0);
    check(FX_EXP(-INFINITY) == 0.0 && FX_EXP(-746.0) == 0.0, "exp: no underflow", -746.0);
    for (j = 0; j < (int)(sizeof sp / sizeof sp[0]); j++) { /* lanes of the special values too */
        ring[ring_at++ & 3] = sp[j];
        lanes(1);
        lanes(0);
    }
    printf("gw_fm_log4 / gw_fm_exp4 against gw_fm_log / gw_fm_exp: %ld lanes not bit-equal\n", n_lane_differ);
    check(!GW_FASTEXP_LANES_EXACT || n_lane_differ == 0, "a lane of gw_fm_log4 / gw_fm_exp4 differs from gw_fm_log / gw_fm_exp", 0.0);
    fprintf(stderr, "test_fastexp: %d checks, %d failures\n", n_checks, n_failures);
    return n_failures != 0;
}
