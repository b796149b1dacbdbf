/*
 * gw_sincos.h -- sin and cos for the generated right-hand sides: static inline, pure, C99,
 * at most 1 ulp from the exact value for |x| <= GW_TRIG_FAST_MAX (libm beyond, and for NaN
 * and infinities); gw_sincos2 computes two arguments' in the two lanes of an SSE2 register.
 * Measured (docs/performance.md): a DOP853 run 17-20% faster than with glibc's sincos (the
 * trig is on the stage-to-stage critical path), one RHS evaluation as fast.
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
 * Reduction (Cody-Waite; gw_trig_reduce): k = nearest integer to x 2/pi (|k| < 2^20), r =
 * x - k pi/2 as a double-double (rh, rl).  Common case: fdlibm's first round, pi/2 = P1 + P1T
 * with P1 of 33 bits (k P1 exact, x - k P1 exact), good to 85 bits; within |x| 2^-16 of a
 * multiple of pi/2 the precise reduction, pi/2 in four pieces and two TwoSums (about 150
 * bits), so no cancellation reaches the result.  sin and cos of one x share the reduction and
 * both kernels (gw_sincos); compilers do not merge two inlined gw_sin / gw_cos by themselves,
 * so fmu_build/casadi_c.py writes gw_sincos / gw_sincos2 calls into the generated code.
 *
 * Error measured against glibc's long double sinl/cosl (tests/c/test_fastmath.c, run by
 * tests/test_fastmath.py): at most 1 ulp over 10^7 points in [-1e5, 1e5], near every multiple
 * of pi/2 below 2^20, and on [-pi, pi] (0.78 ulp at most in that sample, 0.785 found at
 * x = 0.7956032296848280; 97% correctly rounded; glibc: 0.52); docs/performance.md.
 * Deterministic: +, -, *, a bit read and one int-to-double conversion, no tables, no state.
 * Under a parent project's -ffast-math (-fno-finite-math-only: NaN checks kept) the exact
 * differences and TwoSums are held by GW_FM_KEEP: at most 4 ulp (gw_sincos2 then not
 * bit-equal to gw_sincos; tests/test_fastmath.py, gcc and clang).
 */
#ifndef GW_SINCOS_H
#define GW_SINCOS_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "gw_fm_base.h" /* GW_FASTMATH_INLINE, GW_FM_KEEP */

/* beyond this |x| the reduction is libm's (k would need more than 20 bits) */
#define GW_TRIG_FAST_MAX 1048576.0

#define GW_INVPIO2 6.36619772367581382433e-01 /* 2/pi */
#define GW_PIO2_1 1.57079632673412561417e+00  /* first 33 bits of pi/2 */
#define GW_PIO2_1T 6.07710050650619224932e-11 /* pi/2 - P1 */
#define GW_PIO2_2 6.07710050630396597660e-11  /* second 33 bits */
#define GW_PIO2_3 2.02226624871116645580e-21  /* third 33 bits */
#define GW_PIO2_3T 8.47842766036889956997e-32 /* pi/2 - (P1 + P2 + P3) */

/* TwoSum of a and -b: s + e = a - b exactly (|a| >= |b| not needed); every intermediate kept
 * (GW_FM_KEEP) so that no reassociation merges it with its neighbours */
GW_FASTMATH_INLINE double gw_two_diff(double a, double b, double *e) {
    double s = a - b, bb, sb, ea, eb;
    GW_FM_KEEP(s);
    bb = s - a;
    GW_FM_KEEP(bb);
    sb = s - bb;
    GW_FM_KEEP(sb);
    ea = a - sb;
    GW_FM_KEEP(ea);
    eb = -b - bb;
    GW_FM_KEEP(eb);
    *e = ea + eb;
    GW_FM_KEEP(*e);
    return s;
}

/* the precise reduction (the rare case of gw_trig_reduce): r = x - kd pi/2 with pi/2 = P1 + P2 +
 * P3 + P3T, P1..P3 of 33 bits each so that kd Pi is exact; x - kd P1 is exact (both are multiples
 * of ulp(x), the difference is below 1 in magnitude), the two further subtractions are TwoSums:
 * r carries about 150 bits of pi/2 whatever the cancellation. */
GW_FASTMATH_INLINE void gw_trig_reduce_precise(double x, double kd, double *rh, double *rl) {
    double a = x - kd * GW_PIO2_1, e1, e2, lo, hi, d3;
    GW_FM_KEEP(a);
    const double s1 = gw_two_diff(a, kd * GW_PIO2_2, &e1); /* TwoSum(a, -t2) = s1 + e1 */
    const double s2 = gw_two_diff(s1, kd * GW_PIO2_3, &e2); /* TwoSum(s1, -t3) = s2 + e2 */
    lo = (e1 + e2) - kd * GW_PIO2_3T;
    GW_FM_KEEP(lo);
    hi = s2 + lo;
    GW_FM_KEEP(hi);
    d3 = hi - s2;
    GW_FM_KEEP(d3);
    *rh = hi;
    *rl = lo - d3;
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
    double a = xs - kd * GW_PIO2_1, r;
    const double w = kd * GW_PIO2_1T;
    GW_FM_KEEP(a);
    r = a - w;
    GW_FM_KEEP(r);
    if (fabs(r) >= fabs(xs) * 0x1p-16) {
        double ar = a - r; /* exact */
        GW_FM_KEEP(ar);
        *rh = r;
        *rl = ar - w;
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
    const double hz = 0.5 * z;
    double w1 = 1.0 - hz;
    GW_FM_KEEP(w1);
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

/* sin and cos of two arguments at once: the generated code pairs the sincos of alpha and of
 * beta.  With SSE2 (every x86-64) the two reductions and kernels run in the two lanes of one
 * register, the same IEEE operations in the same order as gw_sincos, so the same bits (checked
 * by tests/c/test_fastmath.c) when the compiler does not contract a * b + c into an FMA (the
 * FMU's -std=c99 with GCC; with -mfma or -march=x86-64-v3 under GCC's GNU modes or clang the
 * two paths contract differently and may differ by a rounding, at the same accuracy: measured
 * 0.778 ulp); elsewhere (or with -DGW_FASTMATH_NO_SIMD) two gw_sincos calls. */
#if (defined(__SSE2__) || defined(_M_X64) || (defined(_M_IX86_FP) && _M_IX86_FP >= 2)) && \
    !defined(GW_FASTMATH_NO_SIMD)
#include <emmintrin.h>
#define GW_FASTMATH_SSE2 1
GW_FASTMATH_INLINE void gw_sincos2(double x0, double x1, double *s0, double *c0, double *s1,
                                   double *c1) {
    const __m128d absmask = _mm_castsi128_pd(_mm_set_epi32(0x7fffffff, -1, 0x7fffffff, -1));
    const __m128d x = _mm_set_pd(x1, x0), half = _mm_set1_pd(0.5), one = _mm_set1_pd(1.0);
    const __m128d xs = _mm_and_pd(x, _mm_cmple_pd(_mm_and_pd(x, absmask), _mm_set1_pd(GW_TRIG_FAST_MAX)));
    const __m128d t = _mm_add_pd(_mm_mul_pd(xs, _mm_set1_pd(GW_INVPIO2)), _mm_set1_pd(0x1.8p52));
    const __m128i kb = _mm_castpd_si128(t);
    const __m128d kd = _mm_cvtepi32_pd(_mm_shuffle_epi32(kb, 0x08)); /* dwords 0 and 2 */
    __m128d a = _mm_sub_pd(xs, _mm_mul_pd(kd, _mm_set1_pd(GW_PIO2_1)));
    const __m128d w0 = _mm_mul_pd(kd, _mm_set1_pd(GW_PIO2_1T));
    __m128d rh, rl;
    GW_FM_KEEP(a);
    rh = _mm_sub_pd(a, w0);
    GW_FM_KEEP(rh);
    rl = _mm_sub_pd(a, rh);
    GW_FM_KEEP(rl);
    rl = _mm_sub_pd(rl, w0);
    __m128d z, w, v, sr, cr, ks, kc;
    int l;
    if (_mm_movemask_pd(_mm_cmpge_pd(_mm_and_pd(rh, absmask),
                                     _mm_mul_pd(_mm_and_pd(xs, absmask), _mm_set1_pd(0x1p-16)))) != 3) {
        double xsv[2], kdv[2], rhv[2], rlv[2];
        _mm_storeu_pd(xsv, xs);
        _mm_storeu_pd(kdv, kd);
        _mm_storeu_pd(rhv, rh);
        _mm_storeu_pd(rlv, rl);
        for (l = 0; l < 2; l++)
            if (!(fabs(rhv[l]) >= fabs(xsv[l]) * 0x1p-16))
                gw_trig_reduce_precise(xsv[l], kdv[l], &rhv[l], &rlv[l]);
        rh = _mm_loadu_pd(rhv);
        rl = _mm_loadu_pd(rlv);
    }
    z = _mm_mul_pd(rh, rh);
    w = _mm_mul_pd(z, z);
    v = _mm_mul_pd(z, rh);
    /* gw_kernel_sin, operation by operation */
    sr = _mm_add_pd(
        _mm_add_pd(_mm_set1_pd(8.33333333332248946124e-03),
                   _mm_mul_pd(z, _mm_add_pd(_mm_set1_pd(-1.98412698298579493134e-04),
                                            _mm_mul_pd(z, _mm_set1_pd(2.75573137070700676789e-06))))),
        _mm_mul_pd(_mm_mul_pd(z, w),
                   _mm_add_pd(_mm_set1_pd(-2.50507602534068634195e-08),
                              _mm_mul_pd(z, _mm_set1_pd(1.58969099521155010221e-10)))));
    ks = _mm_sub_pd(rh, _mm_sub_pd(_mm_sub_pd(_mm_mul_pd(z, _mm_sub_pd(_mm_mul_pd(half, rl), _mm_mul_pd(v, sr))),
                                              rl),
                                   _mm_mul_pd(v, _mm_set1_pd(-1.66666666666666324348e-01))));
    /* gw_kernel_cos, operation by operation */
    cr = _mm_add_pd(
        _mm_mul_pd(z, _mm_add_pd(_mm_set1_pd(4.16666666666666019037e-02),
                                 _mm_mul_pd(z, _mm_add_pd(_mm_set1_pd(-1.38888888888741095749e-03),
                                                          _mm_mul_pd(z, _mm_set1_pd(2.48015872894767294178e-05)))))),
        _mm_mul_pd(_mm_mul_pd(w, w),
                   _mm_add_pd(_mm_set1_pd(-2.75573143513906633035e-07),
                              _mm_mul_pd(z, _mm_add_pd(_mm_set1_pd(2.08757232129817482790e-09),
                                                       _mm_mul_pd(z, _mm_set1_pd(-1.13596475577881948265e-11)))))));
    {
        const __m128d hz = _mm_mul_pd(half, z);
        __m128d w1 = _mm_sub_pd(one, hz);
        GW_FM_KEEP(w1);
        kc = _mm_add_pd(w1, _mm_add_pd(_mm_sub_pd(_mm_sub_pd(one, w1), hz),
                                       _mm_sub_pd(_mm_mul_pd(z, cr), _mm_mul_pd(rh, rl))));
    }
    { /* quadrant select in the register: lane swap where k is odd (k + 1 for cos), sign flip
       * where bit 1 is set, as gw_trig_select; sin(+-0) = +-0; libm beyond the bound */
        const __m128i one32 = _mm_set_epi32(0, 1, 0, 1), two32 = _mm_set_epi32(0, 2, 0, 2);
        const __m128i kc1 = _mm_add_epi32(kb, one32);
        const __m128d odd_s = _mm_castsi128_pd(
            _mm_shuffle_epi32(_mm_cmpeq_epi32(_mm_and_si128(kb, one32), one32), 0xA0));
        const __m128d sgn_s = _mm_castsi128_pd(_mm_slli_epi64(_mm_and_si128(kb, two32), 62));
        const __m128d sgn_c = _mm_castsi128_pd(_mm_slli_epi64(_mm_and_si128(kc1, two32), 62));
        const __m128d vs = _mm_or_pd(_mm_and_pd(odd_s, kc), _mm_andnot_pd(odd_s, ks));
        const __m128d vc = _mm_or_pd(_mm_and_pd(odd_s, ks), _mm_andnot_pd(odd_s, kc));
        const __m128d zero = _mm_cmpeq_pd(x, _mm_setzero_pd());
        const __m128d sv = _mm_or_pd(_mm_and_pd(zero, x), _mm_andnot_pd(zero, _mm_xor_pd(vs, sgn_s)));
        const __m128d cv = _mm_xor_pd(vc, sgn_c);
        _mm_storel_pd(s0, sv);
        _mm_storeh_pd(s1, sv);
        _mm_storel_pd(c0, cv);
        _mm_storeh_pd(c1, cv);
        if (!(fabs(x0) <= GW_TRIG_FAST_MAX)) {
            *s0 = sin(x0);
            *c0 = cos(x0);
        }
        if (!(fabs(x1) <= GW_TRIG_FAST_MAX)) {
            *s1 = sin(x1);
            *c1 = cos(x1);
        }
    }
}
#else
GW_FASTMATH_INLINE void gw_sincos2(double x0, double x1, double *s0, double *c0, double *s1,
                                   double *c1) {
    gw_sincos(x0, s0, c0);
    gw_sincos(x1, s1, c1);
}
#endif

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

#endif /* GW_SINCOS_H */
