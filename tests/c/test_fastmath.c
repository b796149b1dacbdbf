/*
 * test_fastmath.c -- the error of gw_sin / gw_cos (c_src/gw_sincos.h) in ulps against glibc's
 * long double sinl / cosl (64-bit significand: its own error is about 2^-11 ulp of a double),
 * over more than 10^7 arguments:
 *   uniform  6e6 points in [-1e5, 1e5] (the angles of long runs)
 *   halfpi   the doubles nearest to k pi/2 and their 2 neighbours each side, every k up to
 *            2^20 (the whole fast range; the worst cancellation of the reduction is there)
 *   small    2e6 points in [-pi, pi] and 2e5 log-spaced magnitudes in [1e-300, 1]
 *   bound    +-2^20 and the doubles either side, where the fast path hands over to libm
 * Prints, per set, the largest error of gw_sin, gw_cos and (for comparison) glibc's sin, cos,
 * and the share of correctly rounded results; fails if any gw_ error exceeds 1 ulp, if
 * gw_sincos2 (two arguments, SSE2 lanes) is not bit-equal to gw_sincos at every point, if a
 * non-finite argument does not give NaN, if sin(-0) is not -0, or beyond the bound the result
 * is not libm's.  Run by tests/test_fastmath.py (gcc and clang, strict flags).
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fm_check.h"
#include "gw_sincos.h"

static long n_pair_differ; /* gw_sincos2 results not bit-equal to gw_sincos's */
static double prev_x = 0.5;

typedef struct {
    const char *name;
    double max_sin, max_cos, max_libm, at_sin, at_cos;
    long n, rounded;
} tally;

/* |v - ref| in ulps of the double nearest ref */
static double ulp_error(double v, long double ref) {
    long double ulp;
    if (ref == 0.0L) return v == 0.0 ? 0.0 : INFINITY;
    ulp = fabsl(ref) < (long double)DBL_MIN ? ldexpl(1.0L, -1074) : ldexpl(1.0L, ilogbl(ref) - 52);
    return (double)(fabsl((long double)v - ref) / ulp);
}

static void measure(tally *t, double x) {
    const long double rs = sinl((long double)x), rc = cosl((long double)x);
    const double s = gw_sin(x), c = gw_cos(x);
    const double es = ulp_error(s, rs), ec = ulp_error(c, rc);
    const double el = fmax(ulp_error(sin(x), rs), ulp_error(cos(x), rc));
    double s2[2], c2[2], sp, cp;
    gw_sincos2(x, prev_x, &s2[0], &c2[0], &s2[1], &c2[1]);
    gw_sincos(prev_x, &sp, &cp);
    n_pair_differ += memcmp(&s2[0], &s, sizeof s) != 0 || memcmp(&c2[0], &c, sizeof c) != 0 ||
                     memcmp(&s2[1], &sp, sizeof sp) != 0 || memcmp(&c2[1], &cp, sizeof cp) != 0;
    prev_x = x;
    if (es > t->max_sin) {
        t->max_sin = es;
        t->at_sin = x;
    }
    if (ec > t->max_cos) {
        t->max_cos = ec;
        t->at_cos = x;
    }
    if (el > t->max_libm) t->max_libm = el;
    t->rounded += (s == (double)rs) + (c == (double)rc);
    t->n++;
}

static void report(const tally *t) {
    n_checks++;
    printf("%-8s %9ld points: max ulp gw_sin %.3f (x=%.17g) gw_cos %.3f (x=%.17g); glibc sin/cos "
           "%.3f; correctly rounded %.4f%%\n", t->name, t->n, t->max_sin, t->at_sin, t->max_cos,
           t->at_cos, t->max_libm, 50.0 * (double)t->rounded / (double)t->n);
    if (!(t->max_sin <= 1.0 && t->max_cos <= 1.0)) {
        n_failures++;
        fprintf(stderr, "%s: error above 1 ulp\n", t->name);
    }
}

int main(void) {
    const long double pio2 = 1.5707963267948966192313216916397514L;
    tally uni = {"uniform", 0, 0, 0, 0, 0, 0, 0}, hp = {"halfpi", 0, 0, 0, 0, 0, 0, 0};
    tally sm = {"small", 0, 0, 0, 0, 0, 0, 0}, bd = {"bound", 0, 0, 0, 0, 0, 0, 0};
    const double specials[] = {NAN, INFINITY, -INFINITY};
    long i, k;
    int j;
    double x;
    for (i = 0; i < 6000000L; i++) measure(&uni, -1e5 + 2e5 * uniform01());
    for (k = 1; (double)((long double)k * pio2) <= GW_TRIG_FAST_MAX; k++) {
        const double x0 = (double)((long double)k * pio2);
        double up = x0, down = x0;
        measure(&hp, x0);
        measure(&hp, -x0);
        for (j = 0; j < 2; j++) {
            up = nextafter(up, INFINITY);
            down = nextafter(down, 0.0);
            measure(&hp, up);
            measure(&hp, down);
        }
    }
    for (i = 0; i < 2000000L; i++) measure(&sm, (double)(pio2 * 2.0L) * (2.0 * uniform01() - 1.0));
    for (i = 0; i < 200000L; i++) {
        x = pow(10.0, -300.0 + 300.0 * (double)i / 200000.0);
        measure(&sm, i % 2 ? x : -x);
    }
    x = GW_TRIG_FAST_MAX;
    for (j = 0; j < 4; j++) x = nextafter(x, 0.0);
    for (j = 0; j < 4; j++, x = nextafter(x, INFINITY)) {
        measure(&bd, x);
        measure(&bd, -x);
    }
    for (j = 0; j < 4; j++, x = nextafter(x, INFINITY)) { /* beyond the bound: libm's value */
        check(gw_sin(x) == sin(x) && gw_cos(x) == cos(x), "beyond the bound: not libm's", x);
        check(gw_sin(-x) == sin(-x) && gw_cos(-x) == cos(-x), "beyond the bound: not libm's", -x);
    }
    report(&uni);
    report(&hp);
    report(&sm);
    report(&bd);
    for (j = 0; j < 3; j++)
        check(isnan(gw_sin(specials[j])) && isnan(gw_cos(specials[j])), "not NaN", specials[j]);
    check(gw_sin(-0.0) == 0.0 && signbit(gw_sin(-0.0)), "sin(-0) is not -0", -0.0);
    check(gw_sin(0.0) == 0.0 && !signbit(gw_sin(0.0)) && gw_cos(0.0) == 1.0, "sin(0), cos(0)", 0.0);
    check(gw_cos(-0.0) == 1.0, "cos(-0) is not 1", -0.0);
    printf("gw_sincos2 against gw_sincos: %ld pairs not bit-equal\n", n_pair_differ);
    check(n_pair_differ == 0, "gw_sincos2 differs from gw_sincos", 0.0);
    fprintf(stderr, "test_fastmath: %d checks, %d failures\n", n_checks, n_failures);
    return n_failures != 0;
}
