/*
 * test_tl_sincos.c -- GW_TL(sincos) (c_src/gw_taylor_ops.h), the sine and cosine of a slice of
 * lanes at the W-lane Taylor kernel's order 0, against gw_sincos (c_src/gw_sincos.h) lane by
 * lane.  Slices of GW_TL_W lanes (compiled for W = 4 and 8, VW 4 doubles, and W = 2) made of:
 *   uniform  random arguments in [-1e5, 1e5] and [-pi, pi] (the common case, all lanes fast)
 *   mixed    one lane per slice from a hard set and the others uniform: the doubles nearest to
 *            k pi/2 and their neighbours (the precise reduction), +-2^20 and beyond (libm), NaN,
 *            +-inf, +-0, tiny magnitudes
 * Fails if a value differs from gw_sincos's by more than BOUND ulp (0 where the compiler does
 * not contract, STRICT_EQUAL: the same IEEE operations in the same order; 1 with FMA
 * contraction), if a NaN or sin(-0) = -0 is lost.  Run by tests/test_taylor_sincos.py.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fm_check.h"

#define GW_MAYBE_UNUSED __attribute__((unused))
#define GW_TL(name) tl_##name
#include "gw_taylor_ops.h"

#ifndef STRICT_EQUAL
#define STRICT_EQUAL 0
#endif

static double max_ulp;
static long n_values;

static double ulps(double v, double ref) {
    double u;
    if (v == ref) return 0.0;
    if (ref == 0.0 || !isfinite(ref)) return INFINITY;
    u = ldexp(1.0, ilogb(ref) - 52);
    return fabs(v - ref) / u;
}

static void check_slice(const double *x) {
    double s[GW_TL_W] __attribute__((aligned(64))), c[GW_TL_W] __attribute__((aligned(64)));
    double xs[GW_TL_W] __attribute__((aligned(64)));
    int l;
    memcpy(xs, x, sizeof xs);
    for (l = 0; l < GW_TL_W; l += GW_TL_VW) tl_sincos(xs + l, s + l, c + l);
    for (l = 0; l < GW_TL_W; l++) {
        double rs, rc, es, ec;
        gw_sincos(x[l], &rs, &rc);
        n_values++;
        if (isnan(rs) || isnan(rc)) {
            check(isnan(s[l]) && isnan(c[l]), "NaN lost", x[l]);
            continue;
        }
        check(signbit(s[l]) == signbit(rs) || s[l] != 0.0, "sign of a zero sine", x[l]);
        es = ulps(s[l], rs);
        ec = ulps(c[l], rc);
        if (es > max_ulp) max_ulp = es;
        if (ec > max_ulp) max_ulp = ec;
        check(STRICT_EQUAL ? (es == 0.0 && ec == 0.0) : (es <= 1.0 && ec <= 1.0),
              "lane differs from gw_sincos", x[l]);
    }
}

int main(void) {
    const double hard[] = {0.0, -0.0, 1e-300, -4.9e-324, 1048576.0, -1048576.0, 1048576.0000000002,
                           3e6, -1e300, INFINITY, -INFINITY, NAN};
    double x[GW_TL_W];
    long i, k;
    int l, h;
    for (i = 0; i < 400000; i++) { /* uniform slices */
        const double span = i % 2 ? 1e5 : 3.141592653589793;
        for (l = 0; l < GW_TL_W; l++) x[l] = span * (2.0 * uniform01() - 1.0);
        check_slice(x);
    }
    for (k = 1; k < 200000; k += 7) { /* k pi/2 and neighbours, each in its own lane */
        double xk = (double)k * 1.5707963267948966;
        for (h = -2; h <= 2; h++) {
            double y = xk;
            int m;
            for (m = 0; m < (h < 0 ? -h : h); m++) y = nextafter(y, h < 0 ? 0.0 : INFINITY);
            for (l = 0; l < GW_TL_W; l++) x[l] = 10.0 * (2.0 * uniform01() - 1.0);
            x[(k + h + 2) % GW_TL_W] = y;
            check_slice(x);
        }
    }
    for (h = 0; h < (int)(sizeof hard / sizeof hard[0]); h++)
        for (l = 0; l < GW_TL_W; l++) { /* each hard value in each lane of a slice */
            int m;
            for (m = 0; m < GW_TL_W; m++) x[m] = 2.0 * uniform01() - 1.0;
            x[l] = hard[h];
            check_slice(x);
        }
    printf("W = %d (slices of %d): %ld values, max %.3g ulp from gw_sincos\n", GW_TL_W, GW_TL_VW,
           n_values, max_ulp);
    fprintf(stderr, "test_tl_sincos: %d checks, %d failures\n", n_checks, n_failures);
    return n_failures != 0;
}
