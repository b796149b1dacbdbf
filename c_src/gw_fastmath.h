/*
 * gw_fastmath.h -- sin and cos for the generated right-hand sides: static inline, pure, C99,
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
 * x = 0.7956032296848280; 97% correctly rounded; glibc: 0.52); docs/performance.md.  Deterministic: +, -, *, a bit read and one int-to-double
 * conversion, no tables, no state.  Under a parent project's -ffast-math (-fno-finite-math-only:
 * NaN checks kept) the exact differences and TwoSums are held by GW_FM_KEEP: at most 4 ulp
 * (gw_sincos2 then not bit-equal to gw_sincos; tests/test_fastmath.py, gcc and clang).
 */
#ifndef GW_FASTMATH_H
#define GW_FASTMATH_H

#include <math.h>
#include <stdint.h>
#include <string.h>

/* inlined whatever the compiler's size heuristics say (gcc -O2 kept out-of-line calls: 62 ns
 * per gw_ode instead of 22; a call even on the rare path made it spill around it) */
#if defined(__GNUC__) || defined(__clang__)
#define GW_FASTMATH_INLINE static inline __attribute__((always_inline))
#else
#define GW_FASTMATH_INLINE static inline
#endif

/* GW_FM_KEEP(v): v as computed, opaque to the optimiser.  Under a parent project's -ffast-math
 * (the C export allows it with -fno-finite-math-only, which leaves __FAST_MATH__ undefined;
 * clang has no macro for reassociation) the compiler folds the reduction's exact differences and
 * TwoSums away, (a - (a - w)) - w = 0 and (x - k P1) - k P1T = x - k pi/2 rounded: measured
 * 1e6 ulp on [-pi, pi] near pi and 1e12 ulp near multiples of pi around 5e4 (an absolute error
 * of ulp(x)).  An empty asm with the value in its register stops that whatever the flags; under
 * IEEE semantics (the FMU's own flags) it changes no result (tests/test_fastmath.py). */
#if (defined(__GNUC__) || defined(__clang__)) && defined(__SSE2_MATH__)
#define GW_FM_KEEP(v) __asm__("" : "+x"(v))
#elif (defined(__GNUC__) || defined(__clang__)) && defined(__aarch64__)
#define GW_FM_KEEP(v) __asm__("" : "+w"(v))
#elif (defined(__GNUC__) || defined(__clang__)) && (defined(__FAST_MATH__) || defined(__ASSOCIATIVE_MATH__))
#define GW_FM_KEEP(v) __asm__("" : "+m"(v))
#else
#define GW_FM_KEEP(v) ((void)0)
#endif

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
 * 0.778 ulp, review of issue 11); elsewhere (or with -DGW_FASTMATH_NO_SIMD) two gw_sincos calls. */
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

/* ---- ln and exp: one definition for a double and for a vector of 4 -------------------------
 * Written for the ensemble's Taylor step size when it took two logarithms and one exponential per
 * lane and step (now gw_fm_step below; gw_fm_log and gw_fm_exp remain the ensemble library's ln
 * and exp of a rejected step's shorter retry, GW_TAYLOR_STEP_FM): ln and exp that are
 * deterministic and the same bit for bit whether called on a double (gw_fm_log, gw_fm_exp) or on
 * the 4 lanes of a GNU vector (gw_fm_log4, gw_fm_exp4, used by no runtime code since: tested by
 * tests/c/test_fastexp.c): the bodies below are macros over the
 * value type D, its 64-bit unsigned integer twin U, the bit casts, a lane select and GW_FM_KEEP,
 * instantiated for both, so that the two perform the same IEEE operations in the same order (no
 * libm, no tables, no int-to-double conversion: the exponent is read and written as bits).
 *
 * gw_fm_log: fdlibm's e_log.c in musl's branch-free form (x = 2^k (1 + f), 1 + f in
 * [sqrt(2)/2, sqrt(2)), s = f / (2 + f), ln(1 + f) = f - f^2/2 + s (f^2/2 + R(s^2)), R the
 * minimax Lg1..Lg7, error below 2^-58.45); subnormals scaled by 2^54 first; 0 gives -inf, inf
 * inf, x < 0 and NaN NaN.
 * gw_fm_exp: k = nearest integer to x / ln 2, r = x - k ln2 as hi - lo (fdlibm's ln2 split: k
 * ln2_hi and hi exact), e^r - 1 - r by its Taylor polynomial of degree 13 (truncation below
 * 6e-18 relative on |r| <= ln2 / 2; Estrin's scheme), 1 + r + the polynomial with the roundings
 * of r = hi - lo and of both sums added back before the last (error-free transformations), then
 * 2^k as 2^floor(k/2) added to the exponent and a product by 2^ceil(k/2) (x clamped to [-746,
 * 710]: overflow to inf and gradual underflow as that product rounds them); NaN gives NaN.
 * Measured against long double (tests/c/test_fastexp.c, tests/test_fastmath.py, 1e7 points):
 * ln 0.84 ulp at most, exp 0.68 over ln h in [-60, 10] and 0.76 over every finite result
 * (glibc: 0.52); every lane of the 4-lane forms bit-equal to the scalar ones (gcc, clang; SSE2,
 * AVX2, x86-64-v3).  Under a parent project's -ffast-math -fno-finite-math-only at most 2.2 ulp
 * (GW_FM_KEEP holds the reduction; the exponent tricks are integer operations the optimiser
 * cannot reassociate), the scalar and vector forms then not bit-equal.
 * Cost: without FMA a scalar gw_fm_exp takes about 22 ns of latency where glibc's table-driven
 * exp (FMA where the CPU has it) takes 11, so the FMU's solver taylor keeps libm's
 * (GW_TAYLOR_STEP_FM, gw_solver_taylor.c). */
#define GW_FM_LN2_HI 6.93147180369123816490e-01 /* 0x3fe62e42fee00000: k ln2_hi exact */
#define GW_FM_LN2_LO 1.90821492927058770002e-10
#define GW_FM_TWO52 4503599627370496.0 /* 2^52: bits 0x4330000000000000 */

/* ln x (see above); x of type D, bit casts BITS: D -> U, DBL: U -> D, SEL(mask, a, b), the
 * result given to RET */
#define GW_FM_LOG_BODY(D, U, BITS, DBL, SEL, RET, KEEP)                                                     \
    {                                                                                            \
        const D zero = (D){0};                                                                   \
        const D sub = zero + 0x1p54, one = zero + 1.0;                                          \
        const D xs = SEL(x < 0x1p-1022, x * sub, x); /* subnormal (and x <= 0: fixed below) */  \
        U ix = BITS(xs), hx, kb;                                                                 \
        D f, kd, hfsq, s, z, w, t1, t2, r, y;                                                    \
        hx = (ix >> 32) + 0x95f62u; /* 0x3ff00000 - 0x3fe6a09e */                                           \
        kb = hx >> 20; /* k + 1023 */                                                            \
        ix = ((((hx & 0xfffffu) + 0x3fe6a09eu)) << 32) | (ix & 0xffffffffu);                     \
        f = DBL(ix) - one;                                                                       \
        kd = (DBL(kb | 0x4330000000000000u) - (GW_FM_TWO52 + 1023.0)) -                          \
             SEL(x < 0x1p-1022, zero + 54.0, zero);                                              \
        hfsq = 0.5 * f * f;                                                                      \
        s = f / (2.0 + f);                                                                       \
        z = s * s;                                                                               \
        w = z * z;                                                                               \
        t1 = w * (3.999999999940941908e-01 +                                                     \
                  w * (2.222219843214978396e-01 + w * 1.531383769920937332e-01));                \
        t2 = z * (6.666666666666735130e-01 +                                                     \
                  w * (2.857142874366239149e-01 +                                                \
                       w * (1.818357216161805012e-01 + w * 1.479819860511658591e-01)));          \
        r = t2 + t1;                                                                             \
        y = s * (hfsq + r) + kd * GW_FM_LN2_LO - hfsq + f + kd * GW_FM_LN2_HI;                  \
        RET(SEL((x > 0.0) & (x < HUGE_VAL), y,                                                   \
                SEL(x == 0.0, zero - HUGE_VAL, SEL(x < 0.0, zero + NAN, x + x))));               \
    }

/* e^x (see above) */
#define GW_FM_EXP_BODY(D, U, BITS, DBL, SEL, RET, KEEP)                                                     \
    {                                                                                            \
        const D zero = (D){0};                                                                   \
        const D xc = SEL(x > 710.0, zero + 710.0, SEL(x < -746.0, zero - 746.0, x));           \
        D t = xc * 1.44269504088896338700e+00 + 0x1.8p52; /* 1.5 2^52 + k */                   \
        KEEP(t);                                                                                 \
        {                                                                                        \
            const U kk = (BITS(t) + (1u << 20)) & ((1u << 21) - 1u); /* k + 2^20 */             \
            const D kd = DBL(kk | 0x4330000000000000u) - (GW_FM_TWO52 + 1048576.0);              \
            D hi = xc - kd * GW_FM_LN2_HI; /* exact */                                           \
            KEEP(hi);                                                                            \
            {                                                                                    \
                const D lo = kd * GW_FM_LN2_LO, r = hi - lo, rc = (hi - r) - lo; /* r + rc */    \
                /* sum_{n=2..13} r^n / n! = z P(r), P of degree 11 by Estrin's scheme (a     \
                 * shorter chain than Horner's: the latency is what a step waits for) */       \
                const D z = r * r, z2 = z * z, z4 = z2 * z2;                                     \
                const D q0 = (1.0 / 2 + r * (1.0 / 6)) + z * (1.0 / 24 + r * (1.0 / 120));      \
                const D q1 = (1.0 / 720 + r * (1.0 / 5040)) + z * (1.0 / 40320 + r * (1.0 / 362880)); \
                const D q2 = (1.0 / 3628800 + r * (1.0 / 39916800)) +                            \
                             z * (1.0 / 479001600 + r * (1.0 / 6227020800.0));                   \
                /* e^r = 1 + s, |r| <= ln2/2; the roundings of s and 1 + s (Fast2Sum: |r| >     \
                 * |tl|, 1 > |s|) added back before the last addition */                         \
                const D tl = z * ((q0 + z2 * q1) + z4 * q2), s = r + tl, m = 1.0 + s;                           \
                const D mm = m + ((s - (m - 1.0)) + ((tl - (s - r)) + rc));                      \
                /* 2^floor(k/2) into mm's exponent (an integer addition: mm in [0.7, 1.42],     \
                 * the result normal), then times 2^ceil(k/2), whose rounding is the result's   \
                 * (overflow, gradual underflow); (kk >> 1) - 2^19 + 1023 > 0 */                 \
                const U e1 = (kk >> 1) - (1u << 19), e2 = kk - (kk >> 1) - 523265u;             \
                RET(DBL(BITS(mm) + (e1 << 52)) * DBL(e2 << 52));                                 \
            }                                                                                    \
        }                                                                                        \
    }

/* ---- the Taylor step size: h = 2^(min(-log2(n1) r1, -log2(n2) r2) + lc) ------------------------
 * Solver taylor's step size rule (gw_taylor_step_size; the ensemble's norms pass gw_ens_norms, 4
 * lanes at once by gw_fm_step4) needs no full precision: a relative error d of h moves the first neglected
 * term by (p + 1) d.  So log2 by the exponent's bits and a polynomial of degree 5 on the
 * mantissa, 1 + f in [sqrt(2)/2, sqrt(2)) (no division; absolute error below 1.5e-5, measured
 * on 4e5 points), and 2^y by k = nearest integer to y into the exponent's bits and 2^r, |r| <=
 * 1/2, by a polynomial of degree 4 (relative error below 3.8e-6): h within 6e-6 of the exact
 * rule for the orders >= 7 used (tests/c/test_ens_passes.c; a degree lower each than the
 * 4e-7 forms before: about 1.5% less time of an ensemble run at N = 16, rel_tol 1e-4, the
 * same step count; the first neglected term moves by 6e-5 at most), about 16 IEEE operations
 * against two fdlibm logarithms and an exponential (9% of an ensemble run at rel_tol 1e-4).  The same body
 * for a double and a vector of 4 (GW_FM_LOG_BODY's scheme): bit for bit equal lane by lane.
 * n = 0 bounds nothing (its term +inf); y clamped to [-1000, 1000] (2^-1000: an underflow the
 * caller refuses), +inf above 1000 (no bound at all); non-finite norms give an unspecified h
 * (the caller names the order first).  Polynomials: least squares on Chebyshev nodes, reweighted
 * toward minimax (Lawson). */
#define GW_FM_LOG2A(D, U, BITS, DBL, SEL, x, out)                                               \
    {                                                                                            \
        const D xs = SEL(x < 0x1p-1022, x * 0x1p54, x); /* subnormal: scaled */                   \
        const U ix = BITS(xs), hx = (ix >> 32) + 0x95f62u; /* 0x3ff00000 - 0x3fe6a09e */          \
        const D kd = (DBL((hx >> 20) | 0x4330000000000000u) - (GW_FM_TWO52 + 1023.0)) -           \
                     SEL(x < 0x1p-1022, (D){0} + 54.0, (D){0});                                  \
        const D f = DBL(((((hx & 0xfffffu) + 0x3fe6a09eu)) << 32) | (ix & 0xffffffffu)) - 1.0;  \
        const D f2 = f * f;                                                                      \
        out = kd + f * ((1.4425780070863066 + f * -0.720241803743346) +                          \
                        f2 * ((0.48668617629839483 + f * -0.3945753472072584) +                  \
                              f2 * 0.2526600960867279));                                         \
    }
#define GW_FM_STEP_BODY(D, U, BITS, DBL, SEL, RET, KEEP)                                        \
    {                                                                                            \
        const D zero = (D){0};                                                                   \
        D a, b, y, yc, t;                                                                        \
        GW_FM_LOG2A(D, U, BITS, DBL, SEL, n1, a)                                                 \
        GW_FM_LOG2A(D, U, BITS, DBL, SEL, n2, b)                                                 \
        a = SEL(n1 > 0.0, -a * r1, zero + HUGE_VAL);                                            \
        b = SEL(n2 > 0.0, -b * r2, zero + HUGE_VAL);                                            \
        y = SEL(b < a, b, a) + lc;                                                               \
        yc = SEL(y > 1000.0, zero + 1000.0, SEL(y < -1000.0, zero - 1000.0, y));               \
        t = yc + 0x1.8p52; /* 1.5 2^52 + k, k = nearest integer to yc */                        \
        KEEP(t);                                                                                 \
        {                                                                                        \
            const U kk = (BITS(t) + (1u << 20)) & ((1u << 21) - 1u); /* k + 2^20 */             \
            const D r = yc - (DBL(kk | 0x4330000000000000u) - (GW_FM_TWO52 + 1048576.0)), z = r * r; \
            const D q = 1.0 + r * ((0.6931215289235051 + r * 0.24022020974121439) +             \
                                   z * (0.05591968876485047 + r * 0.009681909414623472));        \
            RET(SEL(y > 1000.0, zero + HUGE_VAL, DBL(BITS(q) + ((kk - (1u << 20)) << 52))));     \
        }                                                                                        \
    }

GW_FASTMATH_INLINE uint64_t gw_fm_bits(double x) {
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

GW_FASTMATH_INLINE double gw_fm_dbl(uint64_t u) {
    double x;
    memcpy(&x, &u, sizeof x);
    return x;
}

#define GW_FM_SEL1(m, a, b) ((m) ? (a) : (b))
#define GW_FM_RET1(v) return (v);
#define GW_FM_KEEP1(v) GW_FM_KEEP(v)

/* ln x, e^x of a double */
GW_FASTMATH_INLINE double gw_fm_log(double x)
    GW_FM_LOG_BODY(double, uint64_t, gw_fm_bits, gw_fm_dbl, GW_FM_SEL1, GW_FM_RET1, GW_FM_KEEP1)
GW_FASTMATH_INLINE double gw_fm_exp(double x)
    GW_FM_EXP_BODY(double, uint64_t, gw_fm_bits, gw_fm_dbl, GW_FM_SEL1, GW_FM_RET1, GW_FM_KEEP1)

/* the step size 2^(min(-log2(n1) r1, -log2(n2) r2) + lc) of a double (see above) */
GW_FASTMATH_INLINE double gw_fm_step(double n1, double n2, double r1, double r2, double lc)
    GW_FM_STEP_BODY(double, uint64_t, gw_fm_bits, gw_fm_dbl, GW_FM_SEL1, GW_FM_RET1, GW_FM_KEEP1)

#if defined(__GNUC__) || defined(__clang__)
#define GW_FASTMATH_V4 1
typedef double gw_fm_v4 __attribute__((vector_size(32)));             /* 4 lanes */
typedef unsigned long long gw_fm_u4 __attribute__((vector_size(32))); /* their bits */
typedef long long gw_fm_m4 __attribute__((vector_size(32)));          /* lane masks: 0, -1 */
#define GW_FM_BITS4(v) ((gw_fm_u4)(v))
#define GW_FM_DBL4(u) ((gw_fm_v4)(u))
#define GW_FM_SEL4(m, a, b) \
    ((gw_fm_v4)(((gw_fm_u4)(m) & (gw_fm_u4)(a)) | (~(gw_fm_u4)(m) & (gw_fm_u4)(b))))
#define GW_FM_RET4(v) *gw_fm_out = (v);
/* GW_FM_KEEP of a 4-lane vector: in a register with AVX, else through memory (a 32-byte vector
 * is two SSE registers; functions compiled for AVX2 by target attributes take this path too) */
#if defined(__AVX__) && defined(__SSE2_MATH__)
#define GW_FM_KEEP4(v) __asm__("" : "+x"(v))
#else
#define GW_FM_KEEP4(v) __asm__("" : "+m"(v))
#endif
/* *gw_fm_out = ln *xp and e^*xp in 4 lanes, each bit-equal to gw_fm_log / gw_fm_exp of that lane (through
 * pointers: a 32-byte vector passed by value changes the ABI without AVX) */
GW_FASTMATH_INLINE void gw_fm_log4(gw_fm_v4 *gw_fm_out, const gw_fm_v4 *xp) {
    const gw_fm_v4 x = *xp;
    GW_FM_LOG_BODY(gw_fm_v4, gw_fm_u4, GW_FM_BITS4, GW_FM_DBL4, GW_FM_SEL4, GW_FM_RET4, GW_FM_KEEP4)
}
GW_FASTMATH_INLINE void gw_fm_exp4(gw_fm_v4 *gw_fm_out, const gw_fm_v4 *xp) {
    const gw_fm_v4 x = *xp;
    GW_FM_EXP_BODY(gw_fm_v4, gw_fm_u4, GW_FM_BITS4, GW_FM_DBL4, GW_FM_SEL4, GW_FM_RET4, GW_FM_KEEP4)
}
/* the same for 4 lanes, each bit-equal to gw_fm_step of that lane */
GW_FASTMATH_INLINE void gw_fm_step4(gw_fm_v4 *gw_fm_out, const gw_fm_v4 *n1p, const gw_fm_v4 *n2p,
                                    double r1, double r2, const gw_fm_v4 *lcp) {
    const gw_fm_v4 n1 = *n1p, n2 = *n2p, lc = *lcp;
    GW_FM_STEP_BODY(gw_fm_v4, gw_fm_u4, GW_FM_BITS4, GW_FM_DBL4, GW_FM_SEL4, GW_FM_RET4, GW_FM_KEEP4)
}
#else
#define GW_FASTMATH_V4 0
#endif

#endif /* GW_FASTMATH_H */
