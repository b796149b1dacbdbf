/* test_fastmath_flags.c -- the error of gw_sincos / gw_sincos2 compiled in another translation
 * unit (fastmath_unit.c) with whatever flags the test gives it, measured here under IEEE
 * semantics against glibc's long double sinl / cosl.  Prints one line per set of arguments,
 * "max ulp S C", and the NaN / infinity / signed-zero results; tests/test_fastmath.py sets the
 * bounds. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>

void unit_sincos(double x, double *s, double *c);
void unit_sincos2(double x0, double x1, double *s0, double *c0, double *s1, double *c1);

static double ulp_err(long double ref, double got) {
    const double r = fabs((double)ref), u = nextafter(r, INFINITY) - r;
    return (double)(fabsl((long double)got - ref) / u);
}

static void measure(const char *name, double x, double *ws, double *wc) {
    double s, c, s2, c2, t, tc;
    double es, ec;
    unit_sincos(x, &s, &c);
    unit_sincos2(x, 0.5, &s2, &c2, &t, &tc);
    es = fmax(ulp_err(sinl(x), s), ulp_err(sinl(x), s2));
    ec = fmax(ulp_err(cosl(x), c), ulp_err(cosl(x), c2));
    if (es > *ws) *ws = es;
    if (ec > *wc) *wc = ec;
    (void)name;
}

int main(void) {
    uint64_t st = 88172645463325252ull;
    double ws[3] = {0, 0, 0}, wc[3] = {0, 0, 0}, s, c;
    long i;
    int k, d;
    for (i = 0; i < 1000000; i++) {
        double u;
        st ^= st << 13;
        st ^= st >> 7;
        st ^= st << 17;
        u = (double)(st >> 11) / 9007199254740992.0;
        measure("uniform", (2 * u - 1) * 1e5, &ws[0], &wc[0]);
        measure("small", (2 * u - 1) * 3.5, &ws[1], &wc[1]);
    }
    for (k = -200000; k <= 200000; k += 7) { /* the doubles nearest k pi/2 and neighbours */
        double x = (double)((long double)k * 1.57079632679489661923132169163975144L);
        for (d = -2; d <= 2; d++) {
            double y = x;
            int m;
            for (m = 0; m < (d < 0 ? -d : d); m++) y = nextafter(y, d < 0 ? -INFINITY : INFINITY);
            if (y != 0.0) measure("halfpi", y, &ws[2], &wc[2]);
        }
    }
    printf("uniform max ulp %.3f %.3f\n", ws[0], wc[0]);
    printf("small max ulp %.3f %.3f\n", ws[1], wc[1]);
    printf("halfpi max ulp %.3f %.3f\n", ws[2], wc[2]);
    unit_sincos(NAN, &s, &c);
    printf("nan %d %d\n", isnan(s) != 0, isnan(c) != 0);
    unit_sincos(INFINITY, &s, &c);
    printf("inf %d %d\n", isnan(s) != 0, isnan(c) != 0);
    unit_sincos(-0.0, &s, &c);
    printf("negzero %d %g\n", signbit(s) != 0, c);
    return 0;
}
