/*
 * gw_solver_taylor_step.h -- solver taylor's step size rule, h = 2^(min(-log2(n1) r1, -log2(n2) r2)
 * + lc) (gw_solver_taylor.c: r1 = 1 / (p - 1), r2 = 1 / p, lc = log2 of the rule's constant).
 *
 * The rule (gw_taylor_step_size; the ensemble's norms pass gw_ens_norms, 4 lanes at once by
 * gw_fm_step4) needs no full precision: a relative error d of h moves the first neglected term by
 * (p + 1) d.  So log2 by the exponent's bits and a polynomial of degree 5 on the
 * mantissa, 1 + f in [sqrt(2)/2, sqrt(2)) (no division; absolute error below 1.5e-5, measured
 * on 4e5 points), and 2^y by k = nearest integer to y into the exponent's bits and 2^r, |r| <=
 * 1/2, by a polynomial of degree 4 (relative error below 3.8e-6): h within 6e-6 of the exact
 * rule for the orders >= 7 used (tests/c/test_ens_passes.c; the first neglected term moves by
 * 6e-5 at most; polynomials a degree higher each, good to 4e-7, took about 1.5% more time of an
 * ensemble run at N = 16, rel_tol 1e-4, for the same step count), about 16 IEEE operations
 * against two fdlibm logarithms and an exponential (9% of an ensemble run at rel_tol 1e-4).  The
 * same body for a double and a vector of 4 (gw_fm_base.h): bit for bit equal lane by lane.
 * n = 0 bounds nothing (its term +inf); y clamped to [-1000, 1000] (2^-1000: an underflow the
 * caller refuses), +inf above 1000 (no bound at all); non-finite norms give an unspecified h
 * (the caller names the order first).  Polynomials: least squares on Chebyshev nodes, reweighted
 * toward minimax (Lawson).
 */
#ifndef GW_SOLVER_TAYLOR_STEP_H
#define GW_SOLVER_TAYLOR_STEP_H

#include <math.h>
#include <stdint.h>

#include "gw_fm_base.h"

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

/* the step size 2^(min(-log2(n1) r1, -log2(n2) r2) + lc) of a double (see above) */
GW_FASTMATH_INLINE double gw_fm_step(double n1, double n2, double r1, double r2, double lc)
    GW_FM_STEP_BODY(double, uint64_t, gw_fm_bits, gw_fm_dbl, GW_FM_SEL1, GW_FM_RET1, GW_FM_KEEP1)

#if GW_FASTMATH_V4
/* the same for 4 lanes, each bit-equal to gw_fm_step of that lane */
GW_FASTMATH_INLINE void gw_fm_step4(gw_fm_v4 *gw_fm_out, const gw_fm_v4 *n1p, const gw_fm_v4 *n2p,
                                    double r1, double r2, const gw_fm_v4 *lcp) {
    const gw_fm_v4 n1 = *n1p, n2 = *n2p, lc = *lcp;
    GW_FM_STEP_BODY(gw_fm_v4, gw_fm_u4, GW_FM_BITS4, GW_FM_DBL4, GW_FM_SEL4, GW_FM_RET4, GW_FM_KEEP4)
}
#endif

#endif /* GW_SOLVER_TAYLOR_STEP_H */
