/*
 * gw_fastmath.h -- sin and cos for the generated right-hand sides: static inline, pure, C99,
 * at most 1 ulp from the exact value for |x| <= GW_TRIG_FAST_MAX (libm beyond, and for NaN
 * and infinities), about 3x cheaper than glibc's sin/cos here (docs/performance.md).
 *
 * Why not libm: glibc's sin and cos are out-of-line calls through the PLT (gcc merges a pair
 * into one sincos call at best), 10-15 ns each inside gw_ode, about 45% of a DOP853 run.  Why
 * not SLEEF or another vectorised library: the FMU ships C sources that must compile anywhere
 * with a C99 compiler alone, so any library would be vendored source; its scalar double sin/cos
 * is this same construction (Cody-Waite reduction, a minimax kernel) around dispatch and
 * macros we do not need.  What is borrowed is the well-tested part: the kernels below are
 * FreeBSD msun's __kernel_sin / __kernel_cos (k_sin.c, k_cos.c; polynomial error below 2^-58
 * on [-pi/4, pi/4]) and the pieces of pi/2 are fdlibm's (e_rem_pio2.c), under:
 *
 *   Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
 *   Developed at SunPro, a Sun Microsystems, Inc. business.
 *   Permission to use, copy, modify, and distribute this software is freely granted,
 *   provided that this notice is preserved.
 *
 * Reduction (Cody-Waite in four pieces, branch-free): k = nearest integer to x 2/pi (|k| <
 * 2^20), r = x - k pi/2 as a double-double (rh, rl) with pi/2 = P1 + P2 + P3 + P3T, P1..P3 of
 * 33 bits each so that k Pi is exact; x - k P1 is exact (both are multiples of ulp(x) and the
 * difference is below 1 in magnitude), the two further subtractions are TwoSums, so r carries
 * about 150 bits of pi/2: no cancellation near a multiple of pi/2 (the closest double there is
 * some 2^-60 away relative) reaches the result.  sin and cos of the same x share one reduction
 * and both kernels: gw_sin and gw_cos compute the same pure expressions before a quadrant
 * select, so after inlining the compiler keeps one copy (gcc and clang at -O2; the generated
 * code calls both for alpha and beta).
 *
 * Error measured against glibc's long double sinl/cosl (tests/c/test_fastmath.c, run by
 * tests/test_fastmath.py): at most 1 ulp over 10^7 points in [-1e5, 1e5], near every multiple
 * of pi/2 below 2^20, and on [-pi, pi]; the tally is in docs/performance.md.  Deterministic:
 * only +, -, * and two conversions between double and int, no lookup tables, no state.
 */
#ifndef GW_FASTMATH_H
#define GW_FASTMATH_H

#include <math.h>
#include <stdint.h>
#include <string.h>

/* inlined whatever the compiler's size heuristics say: the sharing of one reduction between
 * sin(x) and cos(x) depends on it (gcc -O2 keeps 4 out-of-line calls otherwise: 62 ns per
 * gw_ode instead of 22) */
#if defined(__GNUC__) || defined(__clang__)
#define GW_FASTMATH_INLINE static inline __attribute__((always_inline))
#else
#define GW_FASTMATH_INLINE static inline
#endif

/* beyond this |x| the reduction is libm's (k would need more than 20 bits) */
#define GW_TRIG_FAST_MAX 1048576.0

#define GW_INVPIO2 6.36619772367581382433e-01 /* 2/pi */
#define GW_PIO2_1 1.57079632673412561417e+00  /* first 33 bits of pi/2 */
#define GW_PIO2_1T 6.07710050650619224932e-11 /* pi/2 - P1 */
#define GW_PIO2_2 6.07710050630396597660e-11  /* second 33 bits */
#define GW_PIO2_3 2.02226624871116645580e-21  /* third 33 bits */
#define GW_PIO2_3T 8.47842766036889956997e-32 /* pi/2 - (P1 + P2 + P3) */

/* the precise reduction (the rare case of gw_trig_reduce): r = x - kd pi/2 with pi/2 = P1 + P2 +
 * P3 + P3T, P1..P3 of 33 bits each so that kd Pi is exact; x - kd P1 is exact (both are multiples
 * of ulp(x), the difference is below 1 in magnitude), the two further subtractions are TwoSums:
 * r carries about 150 bits of pi/2 whatever the cancellation. */
GW_FASTMATH_INLINE void gw_trig_reduce_precise(double x, double kd, double *rh, double *rl) {
    const double a = x - kd * GW_PIO2_1;
    const double t2 = kd * GW_PIO2_2, t3 = kd * GW_PIO2_3;
    const double s1 = a - t2, b1 = s1 - a; /* TwoSum(a, -t2) = s1 + e1 */
    const double e1 = (a - (s1 - b1)) + (-t2 - b1);
    const double s2 = s1 - t3, b2 = s2 - s1; /* TwoSum(s1, -t3) = s2 + e2 */
    const double e2 = (s1 - (s2 - b2)) + (-t3 - b2);
    const double lo = (e1 + e2) - kd * GW_PIO2_3T, hi = s2 + lo;
    *rh = hi;
    *rl = lo - (hi - s2);
}

/* r = x - k pi/2 = rh + rl (|rh| <= pi/4 + a rounding); returns k mod 4.  x outside the fast
 * range (or NaN) is reduced as 0 and its result replaced by libm's in gw_sincos.
 * Common case (fdlibm's first round): r = (x - k P1) - k P1T, good to about 85 bits of pi/2,
 * an absolute error below |x| 2^-86, kept when |r| >= |x| 2^-16 (relative error below 2^-70);
 * closer to a multiple of pi/2 (a share of about 2^-16 |x| / (pi/4) of the arguments) the
 * precise reduction. */
GW_FASTMATH_INLINE int gw_trig_reduce(double x, double *rh, double *rl) {
    const double xs = fabs(x) <= GW_TRIG_FAST_MAX ? x : 0.0;
    /* k: xs 2/pi + 1.5 2^52 rounds to 1.5 2^52 + k, whose low 32 bits are k (two's complement).
     * Read as bits rather than by subtracting 1.5 2^52 again: reassociation (-ffast-math in a
     * parent project of the C export) would fold (y + C) - C into y. */
    const double t = xs * GW_INVPIO2 + 0x1.8p52;
    uint64_t bits;
    int32_t k;
    double kd;
    memcpy(&bits, &t, sizeof bits);
    k = (int32_t)(uint32_t)bits;
    kd = (double)k;
    const double a = xs - kd * GW_PIO2_1, w = kd * GW_PIO2_1T, r = a - w;
    if (fabs(r) >= fabs(xs) * 0x1p-16) {
        *rh = r;
        *rl = (a - r) - w;
    } else {
        gw_trig_reduce_precise(xs, kd, rh, rl);
    }
    return (int)(k & 3);
}

/* sin(x + y), |x| <= pi/4, |y| tiny against x (FreeBSD k_sin.c) */
GW_FASTMATH_INLINE double gw_kernel_sin(double x, double y) {
    const double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
                 S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
                 S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
    const double z = x * x, w = z * z, v = z * x;
    const double r = S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6);
    return x - ((z * (0.5 * y - v * r) - y) - v * S1);
}

/* cos(x + y), |x| <= pi/4 (FreeBSD k_cos.c) */
GW_FASTMATH_INLINE double gw_kernel_cos(double x, double y) {
    const double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
                 C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
                 C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;
    const double z = x * x, w = z * z;
    const double r = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
    const double hz = 0.5 * z, w1 = 1.0 - hz;
    return w1 + (((1.0 - w1) - hz) + (z * r - x * y));
}

/* quadrant q = n + shift (0 sin, 1 cos): sin, cos, -sin, -cos of the reduced argument */
GW_FASTMATH_INLINE double gw_trig_select(double s, double c, int q) {
    const double v = (q & 1) ? c : s;
    return (q & 2) ? -v : v;
}

/* sin(x) and cos(x) from one reduction and one pair of kernels, each at most 1 ulp from the
 * exact value (libm's sin and cos for |x| > GW_TRIG_FAST_MAX, NaN and infinities) */
GW_FASTMATH_INLINE void gw_sincos(double x, double *s, double *c) {
    double rh, rl, ks, kc;
    const int n = gw_trig_reduce(x, &rh, &rl);
    if (!(fabs(x) <= GW_TRIG_FAST_MAX)) {
        *s = sin(x);
        *c = cos(x);
        return;
    }
    ks = gw_kernel_sin(rh, rl);
    kc = gw_kernel_cos(rh, rl);
    *s = x == 0.0 ? x : gw_trig_select(ks, kc, n); /* sin(-0) = -0 */
    *c = gw_trig_select(ks, kc, n + 1);
}

/* sin(x) alone (the generated code calls gw_sincos where it needs both) */
GW_FASTMATH_INLINE double gw_sin(double x) {
    double s, c;
    gw_sincos(x, &s, &c);
    return s;
}

/* cos(x) alone */
GW_FASTMATH_INLINE double gw_cos(double x) {
    double s, c;
    gw_sincos(x, &s, &c);
    return c;
}

#endif /* GW_FASTMATH_H */
