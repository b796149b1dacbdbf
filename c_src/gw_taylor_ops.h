/*
 * gw_taylor_ops.h -- the Taylor-coefficient recurrences of the generated kernels
 * (gw_taylor_model.h, taylor/kernel_c.py) and the W-lane vectors they are computed with (a
 * template: included once per lane count, before the model's kernel).
 *
 * Coefficients are the normalised derivatives a_k = a^(k)(t0) / k!.  Coefficient k >= 1 of a
 * node comes from coefficients < k of its result and <= k of its operands (order 0 is the plain
 * operation).  Each recurrence is split into an interior sum I over j = 1 .. k-1, whose
 * coefficients are all known before order k starts (the kernel computes the interior sums of all
 * nodes of an order together, in loops of independent multiply-adds), and the boundary terms
 * j = 0 and j = k with the finishing operation (in program order).  With d_j = j a_j (weighted
 * series, kept by the kernel for the operands that need them) and v the result (Jorba & Zou 2005,
 * Exp. Math. 14, sect. 3.2; Griewank & Walther 2008, table 13.2):
 *   mul   v = a b        I = sum a_j b_{k-j}          v_k = I + a_0 b_k + a_k b_0
 *   sq    v = a^2        I = sum a_j a_{k-j}          v_k = I + 2 a_0 a_k
 *   div   v = a / b      I = sum b_j v_{k-j}          v_k = (a_k - I - b_k v_0) / b_0
 *   sqrt  v^2 = a        I = sum v_j v_{k-j}          v_k = (a_k - I) / (2 v_0)
 *   sincos s' = a' c, c' = -a' s:  I_s = sum da_j c_{k-j}, I_c = sum da_j s_{k-j},
 *                        s_k = I_s / k + a_k c_0,     c_k = -(I_c / k + a_k s_0)
 *   sinhcosh s' = a' c, c' = a' s: the same with c_k = +(...)
 *   exp   v' = a' v      I = sum da_j v_{k-j}         v_k = I / k + a_k v_0
 *   tan   v' = a' q, q = 1 + v^2 (tanh: q = 1 - v^2): I_v = sum da_j q_{k-j},
 *                        v_k = I_v / k + a_k q_0,     I_q = sum v_j v_{k-j},
 *                        q_k = +-(I_q + 2 v_0 v_k)
 *   log   a v' = a'      I = sum dv_j a_{k-j}         v_k = (a_k - I / k) / a_0
 *   pow   a v' = e a' v  I = sum (e da_j v_{k-j} - dv_j a_{k-j}),
 *                        v_k = (I / k + e a_k v_0) / a_0
 *   dq    r v' = n'      I = sum dv_j r_{k-j}         v_k = (n_k - I / k) / r_0
 *         (atan: r = 1 + a^2, n = a; asin: r = sqrt(1 - a^2), n = a; acos n = -a)
 *   atan2 r v' = b a' - a b', r = a^2 + b^2:
 *         I = sum (da_j b_{k-j} - db_j a_{k-j} - dv_j r_{k-j}),
 *         v_k = (I / k + a_k b_0 - b_k a_0) / r_0
 *   linear ops, fabs, fmin, fmax, if_else: boundary terms only; piecewise constants: 0.
 * The kernel divides by none of the order-0 denominators (b_0, 2 v_0, a_0, r_0) at k >= 1: it
 * multiplies by their reciprocals, computed once at order 0.
 *
 * The lanes: GW_TL(v) holds one slice of GW_TL_VW lanes (W = GW_TL_BLK slices); the interior
 * loops use only
 *   GW_TLZ(s)              s = 0
 *   GW_TLFMA(s, pa, pb)    s += pa[l] pb[l] for the slice's lanes (GW_TLFMS: s -= ...)
 *   GW_TLFMA3(s, pc, pa, pb)  s += pc[l] pa[l] pb[l] (GW_TLFMS3: s -= ...)
 *   GW_TLST(p, s)          p[l] = s
 * and the boundary phase writes slice statements on GW_TLX(p) (the slice at p, an lvalue;
 * read-only: GW_TLR).  Under GCC and clang a slice is 4 lanes (W a multiple of 4: one AVX2
 * register, a term one vector multiply-add) or 2, with their vector extension, and 8 where the
 * includer defines GW_TL_VW_MAX 8 and W is a multiple of 8 (gw_ensemble.c on an AVX-512F CPU:
 * one zmm register in its x86-64-v4 clone); otherwise (and for W = 1) one lane, a double.
 * Wider vectors than the hardware's were measured 10x slower (GCC lowers an 8-double vector on
 * AVX2 through memory), hence 8 only on request.  The generated kernel undefines these macros
 * at its end.
 *
 * Before including: GW_TL_W (lanes) and GW_TL(name) (the name prefix of this instance).
 * Checked against CasADi's own derivatives and mpmath: tests/test_taylor_kernel.py.
 */
#include <stdint.h>

/* GW_TL_STATIC: how the model's cst and jet (gw_taylor_model.h) are declared */
#ifndef GW_TL_STATIC
#define GW_TL_STATIC static GW_MAYBE_UNUSED
#endif

/* GW_TL_VW_MAX: the widest slice, 4 unless the including file says 8 (gw_ensemble.c with
 * GW_ENSEMBLE_AVX512: a multiple of 8 lanes on a CPU with AVX-512F, whose x86-64-v4 clone of the
 * kernel then runs each slice as one 8-double register) */
#if defined(__GNUC__) && defined(GW_TL_VW_MAX) && GW_TL_VW_MAX >= 8 && GW_TL_W % 8 == 0
#define GW_TL_VW 8
#elif defined(__GNUC__) && GW_TL_W % 4 == 0
#define GW_TL_VW 4
#elif defined(__GNUC__) && GW_TL_W % 2 == 0
#define GW_TL_VW 2
#else
#define GW_TL_VW 1
#endif
#define GW_TL_BLK (GW_TL_W / GW_TL_VW)
/* GW_TL_UNROLL: before each loop over the slices, so that W > VW lanes (8, 16) run their
 * slices' statements straight-line rather than as a loop over them (measured on the paper
 * kernel at order 10, AVX-512 machine: 8 lanes 1.15x the per-lane time of 4 as a loop, 1.04x
 * unrolled) */
#if defined(__GNUC__) && !defined(__clang__) && GW_TL_BLK > 1
#define GW_TL_UNROLL _Pragma("GCC unroll 4")
#else
#define GW_TL_UNROLL
#endif
/* p rounded up to a slice's alignment (VW doubles) */
#define GW_TL_ALIGN(p)                                                                             \
    ((p) + (GW_TL_VW - (size_t)((uintptr_t)(p) / sizeof(double) % GW_TL_VW)) % GW_TL_VW)

#if GW_TL_VW == 1
typedef double GW_TL(v);
#define GW_TLZ(s) ((s) = 0.0)
#define GW_TLFMA(s, pa, pb) ((s) += *(pa) * *(pb))
#define GW_TLFMS(s, pa, pb) ((s) -= *(pa) * *(pb))
#define GW_TLFMA3(s, pc, pa, pb) ((s) += *(pc) * *(pa) * *(pb))
#define GW_TLFMS3(s, pc, pa, pb) ((s) -= *(pc) * *(pa) * *(pb))
#define GW_TLST(p, s) (*(p) = (s))
#define GW_TLX(p) (*(p))
#define GW_TLR(p) (*(p))
#else
typedef double GW_TL(v) __attribute__((vector_size(GW_TL_VW * sizeof(double))));
/* the same for loads and stores at any double's address (slices are VW doubles apart) */
typedef double GW_TL(vu)
    __attribute__((vector_size(GW_TL_VW * sizeof(double)), aligned(sizeof(double)), may_alias));
#define GW_TLR(p) (*(const GW_TL(vu) *)(const void *)(p))
#define GW_TLX(p) (*(GW_TL(vu) *)(void *)(p))
#define GW_TLZ(s) ((s) = (GW_TL(v)){0.0})
#define GW_TLFMA(s, pa, pb) ((s) += GW_TLR(pa) * GW_TLR(pb))
#define GW_TLFMS(s, pa, pb) ((s) -= GW_TLR(pa) * GW_TLR(pb))
#define GW_TLFMA3(s, pc, pa, pb) ((s) += GW_TLR(pc) * GW_TLR(pa) * GW_TLR(pb))
#define GW_TLFMS3(s, pc, pa, pb) ((s) -= GW_TLR(pc) * GW_TLR(pa) * GW_TLR(pb))
#define GW_TLST(p, s) (GW_TLX(p) = (s))
#endif

/* GW_TL_PACK: the one-lane kernel under GCC and clang sums 4 terms' products per vector
 * operation from packed copies of their operands (taylor/kernel_packs.py, Packs):
 *   GW_TL(p)               4 doubles, two 2-double vectors (SSE2 and NEON registers; a 4-double
 *                          vector lives in memory where no register holds it: the portable
 *                          default clone beside x86-64-v3 ran 0.79-0.85x the former scalar
 *                          loops with it, and the v3 clone was no faster with it: 0.97-1.10x)
 *   GW_TLPZ(s)             s = 0
 *   GW_TLPFMA(s, pa, pb)   s += pa[0..3] pb[0..3] (loads at any double's address)
 *   GW_TLPST(p, s)         p[0..3] = s */
#if defined(__GNUC__) /* GW_TL_PACK1: the one-lane kernel packs (its row: GW_TL_NODES) */
#define GW_TL_PACK1 1
#else
#define GW_TL_PACK1 0
#endif
#if GW_TL_PACK1 && GW_TL_W == 1
#define GW_TL_PACK 1
typedef double GW_TL(p2) __attribute__((vector_size(2 * sizeof(double))));
typedef double GW_TL(pu)
    __attribute__((vector_size(2 * sizeof(double)), aligned(sizeof(double)), may_alias));
#define GW_TLPR(p) (*(const GW_TL(pu) *)(const void *)(p))
typedef struct {
    GW_TL(p2) lo, hi;
} GW_TL(p);
#define GW_TLPZ(s) ((s).lo = (s).hi = (GW_TL(p2)){0.0})
#define GW_TLPFMA(s, pa, pb)                                                                       \
    ((s).lo += GW_TLPR(pa) * GW_TLPR(pb), (s).hi += GW_TLPR((pa) + 2) * GW_TLPR((pb) + 2))
#define GW_TLPST(p, s)                                                                             \
    (*(GW_TL(pu) *)(void *)(p) = (s).lo, *(GW_TL(pu) *)(void *)((p) + 2) = (s).hi)
#else
#define GW_TL_PACK 0
#endif

/* GW_TL_V0: order 0 (the right-hand side) in slices too, with GW_TL(sincos), where GW_TL(v) is
 * a vector (GCC and clang, W a multiple of 2); without it order 0 runs lane by lane, each sine
 * and cosine a scalar gw_sincos (measured: 32% of a 4-lane jet of order 10 on the paper
 * scenario, the same per lane at 4, 8 and 16 lanes).  Not under -ffast-math (the reduction's
 * 1.5 2^52 trick needs its roundings; the lanes' gw_sincos keeps them with GW_FM_KEEP). */
#include "gw_sincos.h"
#if GW_TL_VW > 1 && !defined(__FAST_MATH__)
#define GW_TL_V0 1
typedef long long GW_TL(vi) __attribute__((vector_size(GW_TL_VW * sizeof(double))));
/* sin and cos of the slice at px into the slices at ps and pc: gw_sincos's operations (its
 * reduction's common case, gw_kernel_sin and gw_kernel_cos, gw_trig_select) on all lanes of
 * the slice at once, so each lane's values are gw_sincos's to a rounding (the contraction of a
 * multiply-add may differ); a slice with a lane outside that common case (|x| > 2^20, NaN, an
 * argument close to a multiple of pi/2) is done lane by lane with gw_sincos itself. */
static inline __attribute__((always_inline)) void GW_TL(sincos)(const double *px, double *ps,
                                                              double *pc) {
    typedef GW_TL(v) V;
    typedef GW_TL(vi) VI;
    const V x = GW_TLR(px);
    const VI absm = (VI){0} + 0x7fffffffffffffffLL, one = (VI){0} + 1, two = (VI){0} + 2;
    const V ax = (V)((VI)x & absm);
    const V t = x * GW_INVPIO2 + 0x1.8p52; /* 1.5 2^52 + k (|x| <= 2^20) */
    const VI k = ((VI)t << 32) >> 32;       /* k, sign-extended from the low 32 bits */
    const V kd = t - 0x1.8p52;              /* (double)k, exactly */
    const V a = x - kd * GW_PIO2_1, w = kd * GW_PIO2_1T, rh = a - w;
    const VI fast = (ax <= GW_TRIG_FAST_MAX) & ((V)((VI)rh & absm) >= ax * 0x1p-16);
    int i, all = 1;
    for (i = 0; i < GW_TL_VW; i++) all &= fast[i] != 0;
    if (!all) {
        for (i = 0; i < GW_TL_VW; i++) gw_sincos(px[i], &ps[i], &pc[i]);
        return;
    }
    {
        const V rl = (a - rh) - w, z = rh * rh, zz = z * z, v = z * rh;
        const V sr = 8.33333333332248946124e-03 + z * (-1.98412698298579493134e-04 + z * 2.75573137070700676789e-06)
                     + z * zz * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10);
        const V ks = rh - ((z * (0.5 * rl - v * sr) - rl) - v * -1.66666666666666324348e-01);
        const V cr = z * (4.16666666666666019037e-02 + z * (-1.38888888888741095749e-03 + z * 2.48015872894767294178e-05))
                     + zz * zz * (-2.75573143513906633035e-07 + z * (2.08757232129817482790e-09
                                                                     + z * -1.13596475577881948265e-11));
        const V hz = 0.5 * z, w1 = 1.0 - hz;
        const V kc = w1 + (((1.0 - w1) - hz) + (z * cr - rh * rl));
        const VI odd = (k & one) == one, zero = x == 0.0;
        const VI vs = (odd & (VI)kc) | (~odd & (VI)ks), vc = (odd & (VI)ks) | (~odd & (VI)kc);
        const VI s = vs ^ ((k & two) << 62), c = vc ^ (((k + one) & two) << 62);
        GW_TLX(ps) = (V)((zero & (VI)x) | (~zero & s));
        GW_TLX(pc) = (V)c;
    }
}
#else
#define GW_TL_V0 0
#endif
