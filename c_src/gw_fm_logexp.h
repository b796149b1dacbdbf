/*
 * gw_fm_logexp.h -- ln and exp that are deterministic and the same bit for bit whether called on
 * a double (gw_fm_log, gw_fm_exp) or on the 4 lanes of a GNU vector (gw_fm_log4, gw_fm_exp4):
 * one body for both (gw_fm_base.h).  The ensemble library's ln and exp of a rejected Taylor
 * step's shorter retry (GW_TAYLOR_STEP_FM, gw_solver_taylor.c); the 4-lane forms serve the tests
 * (tests/c/test_fastexp.c), which hold every lane to the scalar form.
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
 * (GW_TAYLOR_STEP_FM, gw_solver_taylor.c).
 *
 * What is borrowed, gw_fm_log's reduction and its coefficients Lg1..Lg7 and the split of ln 2 into
 * ln2_hi + ln2_lo, is fdlibm's (e_log.c, e_exp.c), under:
 *
 *   Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
 *   Developed at SunPro, a Sun Microsystems, Inc. business.
 *   Permission to use, copy, modify, and distribute this software is freely granted,
 *   provided that this notice is preserved.
 */
#ifndef GW_FM_LOGEXP_H
#define GW_FM_LOGEXP_H

#include <math.h>
#include <stdint.h>

#include "gw_fm_base.h"

#define GW_FM_LN2_HI 6.93147180369123816490e-01 /* 0x3fe62e42fee00000: k ln2_hi exact */
#define GW_FM_LN2_LO 1.90821492927058770002e-10

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

/* ln x, e^x of a double */
GW_FASTMATH_INLINE double gw_fm_log(double x)
    GW_FM_LOG_BODY(double, uint64_t, gw_fm_bits, gw_fm_dbl, GW_FM_SEL1, GW_FM_RET1, GW_FM_KEEP1)
GW_FASTMATH_INLINE double gw_fm_exp(double x)
    GW_FM_EXP_BODY(double, uint64_t, gw_fm_bits, gw_fm_dbl, GW_FM_SEL1, GW_FM_RET1, GW_FM_KEEP1)

#if GW_FASTMATH_V4
/* *gw_fm_out = ln *xp and e^*xp in 4 lanes, each bit-equal to gw_fm_log / gw_fm_exp of that
 * lane (through pointers: a 32-byte vector passed by value changes the ABI without AVX) */
GW_FASTMATH_INLINE void gw_fm_log4(gw_fm_v4 *gw_fm_out, const gw_fm_v4 *xp) {
    const gw_fm_v4 x = *xp;
    GW_FM_LOG_BODY(gw_fm_v4, gw_fm_u4, GW_FM_BITS4, GW_FM_DBL4, GW_FM_SEL4, GW_FM_RET4, GW_FM_KEEP4)
}
GW_FASTMATH_INLINE void gw_fm_exp4(gw_fm_v4 *gw_fm_out, const gw_fm_v4 *xp) {
    const gw_fm_v4 x = *xp;
    GW_FM_EXP_BODY(gw_fm_v4, gw_fm_u4, GW_FM_BITS4, GW_FM_DBL4, GW_FM_SEL4, GW_FM_RET4, GW_FM_KEEP4)
}
#endif

#endif /* GW_FM_LOGEXP_H */
