/*
 * gw_fm_base.h -- what the runtime's own floating-point kernels share (gw_sincos.h,
 * gw_fm_logexp.h, gw_solver_taylor_step.h): forced inlining, GW_FM_KEEP (a value whose roundings
 * the optimiser may not fold away), and the scaffolding that instantiates one body for a double
 * and for the 4 lanes of a GNU vector.
 *
 * One body, two types: a kernel written as a macro over the value type D, its 64-bit unsigned
 * integer twin U, the bit casts BITS: D -> U and DBL: U -> D, a lane select SEL(mask, a, b), RET
 * (how the result is handed back) and KEEP (GW_FM_KEEP's form) is instantiated with the _1 forms
 * below for a double and with the _4 forms for a vector of 4 lanes, so that both perform the same
 * IEEE operations in the same order: every lane of the vector form bit-equal to the double form
 * of that lane (no libm, no tables, no int-to-double conversion: exponents are read and written
 * as bits).
 */
#ifndef GW_FM_BASE_H
#define GW_FM_BASE_H

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

#define GW_FM_TWO52 4503599627370496.0 /* 2^52: bits 0x4330000000000000 */

/* the double form */
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

/* the 4-lane form: GCC's and clang's vector extensions (GW_FASTMATH_V4 0 elsewhere) */
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
#else
#define GW_FASTMATH_V4 0
#endif

#endif /* GW_FM_BASE_H */
