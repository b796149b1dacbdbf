/*
 * gw_ensemble_passes.h -- the ensemble's step arithmetic over all lanes at once (gw_ensemble.c):
 * the step size norms, the defects and the increments' Horner sums of GW_ENSEMBLE_LANES lanes
 * on the batch's series (structure of arrays: state i's coefficient k of a lane at
 * w[i si + k so + lane], lanes contiguous; the batch passes the kernel's own order-major layout,
 * si = lanes, so = a row of the kernel's nodes times lanes), loops
 * with the lanes innermost, the same operations in the same order as solver taylor's one-lane
 * code (gw_taylor_step, gw_taylor_defect, gw_taylor_increment), so each lane's numbers are those
 * of its single run bit for bit.  Included by gw_ensemble.c only.
 */
#ifndef GW_ENSEMBLE_PASSES_H
#define GW_ENSEMBLE_PASSES_H

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "gw_solver_taylor_step.h" /* gw_fm_step4: the lanes' step sizes */

/* The passes work on vectors of GW_ENS_V lanes (GCC / clang vector extension: GCC vectorised
 * none of the plain loops): 4 lanes (one AVX2 register) where the lanes are a multiple of 4,
 * else 2 or 1.  They are also compiled for AVX2 (target clones, chosen at load time) without
 * FMA: the same IEEE multiplies, adds and divisions as the one-lane code, bit for bit. */
#if defined(__GNUC__) || defined(__clang__)
#if GW_ENSEMBLE_LANES % 4 == 0
#define GW_ENS_V 4
#elif GW_ENSEMBLE_LANES % 2 == 0
#define GW_ENS_V 2
#else
#define GW_ENS_V 1
#endif
typedef double gw_ens_v __attribute__((vector_size(8 * GW_ENS_V)));
typedef long long gw_ens_m __attribute__((vector_size(8 * GW_ENS_V))); /* lane masks: 0, -1 */
#define GW_ENS_SEL(m, a, b) ((gw_ens_v)(((m) & (gw_ens_m)(a)) | (~(m) & (gw_ens_m)(b))))
#define GW_ENS_NOT(m) (~(m))
#define GW_ENS_ABS(a) ((gw_ens_v)((gw_ens_m)(a) & ((gw_ens_m){0} + 0x7fffffffffffffffLL)))
#define GW_ENS_LANE(m, l) ((m)[l])
/* unaligned loads and stores (the lanes of a coefficient are 8-byte aligned) */
typedef double gw_ens_vu __attribute__((vector_size(8 * GW_ENS_V), aligned(8), may_alias));
#define gw_ens_ld(p) (*(const gw_ens_vu *)(const void *)(p))
#define gw_ens_st(p, v) (*(gw_ens_vu *)(void *)(p) = (v))
#else
#define GW_ENS_V 1
typedef double gw_ens_v;
typedef int gw_ens_m;
#define GW_ENS_SEL(m, a, b) ((m) ? (a) : (b))
#define GW_ENS_NOT(m) (!(m))
#define GW_ENS_ABS(a) fabs(a)
#define GW_ENS_LANE(m, l) ((void)(l), (m))
#define gw_ens_ld(p) (*(p))
#define gw_ens_st(p, v) (*(p) = (v))
#endif
#if defined(__GNUC__) && defined(__x86_64__) && defined(__ELF__) && !defined(GW_NO_CLONES) &&   \
    ((defined(__clang__) && __clang_major__ >= 14) || (!defined(__clang__) && __GNUC__ >= 8))
#define GW_ENS_PASS static __attribute__((target_clones("avx2", "default")))
#else
#define GW_ENS_PASS static
#endif
/* the increments' Horner sums: fused multiply-adds where the machine has them, in the same
 * clones (GW_TL_CLONED: x86-64-v3 and default, fp-contract=fast) as the one-lane code they equal
 * lane by lane (gw_taylor_increment8 in gw_solver_taylor.c) */
#ifdef GW_TL_CLONED
#define GW_ENS_PASS_FMA static GW_TL_CLONED
#else
#define GW_ENS_PASS_FMA static
#endif

/* N_{p-1}, N_p of every lane (gw_taylor_step), n1, n2; its step size from them and log2 c =
 * lc[l] (gw_taylor_step_size: gw_fm_step4 on 4 lanes at once, bit-equal lane by lane to
 * gw_fm_step; non-finite norms give any h, refused by gw_taylor_attempt_size), hs; and d1[l] = 0
 * where every state and derivative (orders 0 and 1) of lane l is finite, NaN otherwise (the sum
 * of x_i^[0] * 0 + x_i^[1] * 0: NaN from an infinity or a NaN), the checks gw_accept_step and
 * gw_taylor_attempt_size would otherwise make on copies of them.  The step sizes in the same
 * pass, the norms still in registers: a pass of their own was 6% of the C of a run (N = 16,
 * rel_tol 1e-4), their chain's latency not overlapped. */
GW_ENS_PASS void gw_ens_norms(const double *w, size_t si, size_t so, const double *fsn, int nx,
                              int order, const double *lc, double *n1, double *n2, double *d1,
                              double *hs) {
    enum { W = GW_ENSEMBLE_LANES, V = GW_ENS_V };
    const double q1 = 1.0 / (order - 1), q2 = 1.0 / order;
    int i, j;
    for (j = 0; j < W; j += V) {
        gw_ens_v m1 = {0.0}, m2 = {0.0}, z = {0.0};
        for (i = 0; i < nx; i++) {
            const double *x0 = w + (size_t)i * si + j;
            const gw_ens_v rsc = 1.0 / (GW_ENS_ABS(gw_ens_ld(x0)) + gw_ens_ld(fsn + (size_t)i * W + j));
            const gw_ens_v r1 = GW_ENS_ABS(gw_ens_ld(x0 + (size_t)(order - 1) * so)) * rsc;
            const gw_ens_v r2 = GW_ENS_ABS(gw_ens_ld(x0 + (size_t)order * so)) * rsc;
            m1 = GW_ENS_SEL((r1 > m1) | (r1 != r1), r1, m1); /* a NaN sticks (gw_taylor_step) */
            m2 = GW_ENS_SEL((r2 > m2) | (r2 != r2), r2, m2);
            z = z + gw_ens_ld(x0) * 0.0 + gw_ens_ld(x0 + so) * 0.0;
        }
        gw_ens_st(n1 + j, m1);
        gw_ens_st(n2 + j, m2);
        gw_ens_st(d1 + j, z);
#if GW_ENS_V == 4 && GW_FASTMATH_V4
        {
            const gw_fm_v4 c = gw_ens_ld(lc + j);
            gw_fm_v4 hv;
            gw_fm_step4(&hv, &m1, &m2, q1, q2, &c);
            gw_ens_st(hs + j, hv);
        }
#else
        for (i = j; i < j + V; i++) hs[i] = gw_fm_step(n1[i], n2[i], q1, q2, lc[i]);
#endif
    }
}

/* the defect of every lane's pending attempt with f(t1, P(h)) = order 1 of the batch's series
 * (gw_taylor_defect); scale[l] = h / (p + 1) of lane l's attempt, its xnew in x, P'(h) in dp.
 * As gw_taylor_defect, the usual case first without divisions: where every component of the
 * GW_ENS_V lanes has num <= den (and 0 < den < inf) their defects are 0 (accepted: only
 * err <= 1 is read then); else the quotients of those lanes (the divisions were nearly all of
 * the pass: 2% of a run at N = 16, rel_tol 1e-4). */
GW_ENS_PASS void gw_ens_defects(const double *w, size_t si, size_t so, const double *dp,
                                const double *x, const double *anom, int nx, double rtol,
                                const double *scale, double *err) {
    enum { W = GW_ENSEMBLE_LANES, V = GW_ENS_V };
    int i, j, l;
    for (j = 0; j < W; j += V) {
        const gw_ens_v sc = gw_ens_ld(scale + j), zero = {0.0};
        gw_ens_v e = {0.0};
        gw_ens_m ok = zero == zero;
        int all = 1;
        for (i = 0; i < nx; i++) {
            const size_t at = (size_t)i * W + j;
            const gw_ens_v num = GW_ENS_ABS(gw_ens_ld(w + (size_t)i * si + so + j) - gw_ens_ld(dp + at)) * sc,
                           den = rtol * GW_ENS_ABS(gw_ens_ld(x + at)) + gw_ens_ld(anom + at);
            ok &= (num <= den) & (den > zero) & (den < zero + HUGE_VAL); /* inf <= inf: NaN below */
        }
        for (l = 0; l < V; l++) all &= GW_ENS_LANE(ok, l) != 0;
        if (!all)
            for (i = 0; i < nx; i++) {
                const size_t at = (size_t)i * W + j;
                const gw_ens_v r = GW_ENS_ABS(gw_ens_ld(w + (size_t)i * si + so + j) - gw_ens_ld(dp + at)) *
                                   sc / (rtol * GW_ENS_ABS(gw_ens_ld(x + at)) + gw_ens_ld(anom + at));
                /* a NaN r stays (a rejection, as gw_taylor_defect's break at a NaN): r <= NaN is
                 * false, so without the e == e test a later finite r replaced it */
                e = GW_ENS_SEL(GW_ENS_NOT(r <= e) & (e == e), r, e);
            }
        gw_ens_st(err + j, GW_ENS_SEL(ok, zero, e));
    }
    for (l = 0; l < W; l++) err[l] = isfinite(err[l]) ? err[l] : HUGE_VAL;
}

/* The Horner chains of components i0 .. i0 + nc - 1 (nc <= C) of all lanes (gw_ens_increments);
 * inlined with a constant nc, so that the chains stay in registers (with a variable count GCC
 * kept them on the stack and recomputed each coefficient's address: about half of the pass) */
#if defined(__GNUC__) || defined(__clang__)
#define GW_ENS_INLINE static inline __attribute__((always_inline))
#else
#define GW_ENS_INLINE static
#endif
enum { GW_ENS_NV = GW_ENSEMBLE_LANES / GW_ENS_V, GW_ENS_C = GW_ENS_NV >= 4 ? 1 : 4 / GW_ENS_NV };
GW_ENS_INLINE void gw_ens_horner(const double *w, size_t si, size_t so, int order,
                                 const gw_ens_v *hh, int i0, int nc, double *qx, double *qd) {
    enum { W = GW_ENSEMBLE_LANES, V = GW_ENS_V, NV = GW_ENS_NV, C = GW_ENS_C };
    gw_ens_v q[C][NV], dq[C][NV];
    const double *wk = w + (size_t)i0 * si + (size_t)order * so;
    int k, j, c;
    /* dq from 0, as gw_taylor_increment: started at q (its first sum, 0 h + q), GCC shares the
     * product q h of the first two sums and fuses neither the first sum of q nor the last of
     * P'(h) into a multiply-add, where the one-lane code fuses both: dx would differ from
     * gw_taylor_increment's in 1.2% of the components, P'(h) in 20% (random series, orders 7-12:
     * tests/c/test_ens_increments.c; the inline lane-steps against GW_ENSEMBLE_LANE_STEPS=1) */
    for (c = 0; c < nc; c++)
        for (j = 0; j < NV; j++) {
            q[c][j] = gw_ens_ld(wk + (size_t)c * si + j * V);
            dq[c][j] = (gw_ens_v){0.0};
        }
    for (k = order - 1; k >= 1; k--) {
        wk -= so;
        for (c = 0; c < nc; c++)
            for (j = 0; j < NV; j++) {
                dq[c][j] = dq[c][j] * hh[j] + q[c][j];
                q[c][j] = q[c][j] * hh[j] + gw_ens_ld(wk + (size_t)c * si + j * V);
            }
    }
    for (c = 0; c < nc; c++)
        for (j = 0; j < NV; j++) {
            const size_t at = (size_t)(i0 + c) * W + (size_t)(j * V);
            gw_ens_st(qx + at, q[c][j] * hh[j]);
            gw_ens_st(qd + at, q[c][j] + hh[j] * dq[c][j]);
        }
}

/* dx (qx) and P'(h) (qd) of every lane for its step size h[l] (gw_taylor_increment):
 * the Horner chains of C components and all lanes side by side (independent chains overlap
 * where one component after the other waited on each multiply and add) */
GW_ENS_PASS_FMA void gw_ens_increments(const double *w, size_t si, size_t so, int nx, int order,
                                   const double *h, double *qx, double *qd) {
    enum { V = GW_ENS_V, NV = GW_ENS_NV, C = GW_ENS_C }; /* at most 8 chains of q and dq */
    gw_ens_v hh[NV];
    int i0, j;
    for (j = 0; j < NV; j++) hh[j] = gw_ens_ld(h + j * V);
    for (i0 = 0; i0 + C <= nx; i0 += C) gw_ens_horner(w, si, so, order, hh, i0, C, qx, qd);
    for (; i0 < nx; i0++) gw_ens_horner(w, si, so, order, hh, i0, 1, qx, qd); /* the last ones */
}

/* Every lane's compensated update (gw_sum_update's TwoSum, element by element, so the same
 * values): xnew = x + (dx + xc), its rounding in xcnew, dx from the increments pass (qx); lane l's
 * x, xc are the columns bx, xcn where acc[l] != 0 (a step accepted in the batch: its end point
 * and rounding), else xa, xca; either is left in xa, xca (the lane's current state), xnew in bx
 * (its point in the next batch), xcnew in xcn.  The lanes innermost: one lane at a time, the
 * strided stores of its new point into bx were 3.5% of a run (N = 16 at rel_tol 1e-4). */
GW_ENS_PASS void gw_ens_sum_updates(const double *qx, const double *acc, int nx, double *xa,
                                    double *xca, double *bx, double *xcn) {
    enum { W = GW_ENSEMBLE_LANES, V = GW_ENS_V };
    int i, j;
    for (j = 0; j < W; j += V) {
        const gw_ens_v zero = {0.0};
        const gw_ens_m m = gw_ens_ld(acc + j) != zero;
        for (i = 0; i < nx; i++) {
            const size_t at = (size_t)i * W + (size_t)j;
            const gw_ens_v x = GW_ENS_SEL(m, gw_ens_ld(bx + at), gw_ens_ld(xa + at)),
                           xc = GW_ENS_SEL(m, gw_ens_ld(xcn + at), gw_ens_ld(xca + at));
            const gw_ens_v y = gw_ens_ld(qx + at) + xc, sum = x + y, bp = sum - x;
            gw_ens_st(xa + at, x);
            gw_ens_st(xca + at, xc);
            gw_ens_st(bx + at, sum);
            gw_ens_st(xcn + at, (x - (sum - bp)) + (y - bp));
        }
    }
}

#endif /* GW_ENSEMBLE_PASSES_H */
