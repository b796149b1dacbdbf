/*
 * gw_solver_dop853.c -- Dormand-Prince 8(5,3) (Hairer's DOP853): the step with its combined
 * 5th/3rd-order error estimate and the 7th-order continuous extension.  The adaptive loop
 * (shared with RODAS4) is in gw_solver.c.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>

#include "gw_solver.h"

#include "gw_dop853_tableau.h"

/* DOP853 stage vectors: 0..5 in I->k[0..5], 6..11 in I->kx[0..5], 12 (f at the end
 * point, FSAL) in I->k[6] so that gw_accept_step hands it on as the next k[0], 13..15
 * (dense output) in I->kx[6..8]. */
static void gw_dop853_stages(const gw_instance *I, double *K[16]) {
    int s;
    for (s = 0; s < 6; s++) K[s] = I->k[s];
    for (s = 6; s < 12; s++) K[s] = I->kx[s - 6];
    K[12] = I->k[6];
    for (s = 13; s < 16; s++) K[s] = I->kx[s - 7];
}

/* xt = x + h * sum_{j<s} dop_a[s][j] K[j], the nonzero terms only, summed in the order of j.
 * One pass over the state, four components at a time with the sums in registers (the
 * stage-by-stage form kept the partial sums in memory: a load and a store per term, 20% of a
 * DOP853 run in perf); same arithmetic in the same order, so the same bits. */
static void gw_dop853_arg(const gw_instance *I, double *const K[16], int s, double h, double *xt) {
    int i, j, m, nz = 0, nx = I->m->nx;
    const double *a = dop_a[s], *restrict x = I->x;
    const double *Kz[16];
    double az[16];
    for (j = 0; j < s; j++)
        if (j == 0 || a[j] != 0.0) {
            az[nz] = a[j];
            Kz[nz++] = K[j];
        }
    for (i = 0; i + 4 <= nx; i += 4) { /* four components at a time: independent sums */
        double c0 = az[0] * Kz[0][i], c1 = az[0] * Kz[0][i + 1], c2 = az[0] * Kz[0][i + 2],
               c3 = az[0] * Kz[0][i + 3];
        for (m = 1; m < nz; m++) {
            const double am = az[m], *Km = Kz[m] + i;
            c0 += am * Km[0];
            c1 += am * Km[1];
            c2 += am * Km[2];
            c3 += am * Km[3];
        }
        xt[i] = x[i] + h * c0;
        xt[i + 1] = x[i + 1] + h * c1;
        xt[i + 2] = x[i + 2] + h * c2;
        xt[i + 3] = x[i + 3] + h * c3;
    }
    for (; i < nx; i++) {
        double acc = az[0] * Kz[0][i];
        for (m = 1; m < nz; m++) acc += az[m] * Kz[m][i];
        xt[i] = x[i] + h * acc;
    }
}

/* DOP853 step (12 stages); *err = Hairer's combined 5th/3rd-order error norm with the
 * DOPRI5 weights.  f(t1, xnew) is not evaluated here (only for accepted steps). */
GW_INTERNAL int gw_dop853_step(gw_instance *I, double h, double t1, double *err) {
    int i, j, s, nx = I->m->nx;
    const double t = I->t, *x = I->x, *nom = I->nominal;
    const double rtol = I->rel_tol, atol = I->atol_eff;
    double *K[16], *xt = I->xtmp;
    double err5 = 0.0, err3 = 0.0, deno;
    gw_dop853_stages(I, K);
    I->k7_valid = 0;
    for (s = 1; s < 12; s++) {
        gw_dop853_arg(I, K, s, h, xt);
        if (gw_rhs_checked(I, s == 11 ? t1 : t + dop_c[s] * h, xt, K[s])) return -1;
    }
    for (i = 0; i < nx; i++) { /* the 8th-order increment (in sacc), the 5th-order error (in xt) */
        double incr = dop_b[0] * K[0][i], e5 = dop_e5[0] * K[0][i];
        for (j = 5; j < 12; j++) {
            incr += dop_b[j] * K[j][i];
            e5 += dop_e5[j] * K[j][i];
        }
        I->sacc[i] = incr;
        xt[i] = e5;
    }
    for (i = 0; i < nx; i++) {
        const double incr = I->sacc[i], e5 = xt[i];
        double e3, sk, ax, an;
        I->dx[i] = h * incr;
        e3 = incr - dop_bhh0 * K[0][i] - dop_bhh8 * K[8][i] - dop_bhh11 * K[11][i];
        ax = fabs(x[i]);
        an = fabs(x[i] + I->dx[i]);
        sk = atol * nom[i] + rtol * (ax > an ? ax : an);
        err5 += (e5 / sk) * (e5 / sk);
        err3 += (e3 / sk) * (e3 / sk);
    }
    gw_sum_update(I); /* xn = x + dx, compensated */
    deno = err5 + 0.01 * err3;
    if (deno <= 0.0) deno = 1.0;
    *err = nx > 0 ? fabs(h) * err5 * sqrt(1.0 / ((double)nx * deno)) : 0.0;
    return 0;
}


/* ---- dense output ------------------------------------------------------------ */

/* DOP853's 7th-order continuous extension (dop853.f, CONTD8): three more stages,
 * then rcont[4] and rcx[0..2] = h * D K.  If a stage evaluation fails the higher terms
 * are dropped (cubic Hermite, still matching values and slopes at both ends). */
GW_INTERNAL void gw_dop853_dense(gw_instance *I) {
    int i, j, r, s, nx = I->m->nx;
    const double h = I->dense_h, t0 = I->dense_t0;
    double *K[16], *out[4];
    gw_dop853_stages(I, K);
    out[0] = I->rcont + 4 * nx;
    out[1] = I->rcx;
    out[2] = I->rcx + nx;
    out[3] = I->rcx + 2 * nx;
    for (s = 13; s < 16; s++) {
        gw_dop853_arg(I, K, s, h, I->xtmp);
        if (gw_rhs(I, t0 + dop_c[s] * h, I->xtmp, K[s]) != 0 ||
            gw_first_nonfinite(K[s], nx) >= 0) {
            for (r = 0; r < 4; r++)
                for (i = 0; i < nx; i++) out[r][i] = 0.0;
            return;
        }
    }
    for (r = 0; r < 4; r++)
        for (i = 0; i < nx; i++) {
            double acc = 0.0;
            for (j = 0; j < 16; j++)
                if (dop_d[r][j] != 0.0) acc += dop_d[r][j] * K[j][i];
            out[r][i] = h * acc;
        }
}

/* x(t0 + th h) of the 7th-order extension, in the nested form of gw_dense_eval */
GW_INTERNAL void gw_dop853_dense_eval(const gw_instance *I, double th, double th1, double *x_out) {
    int i, nx = I->m->nx;
    const double *r0 = I->rcont, *r1 = r0 + nx, *r2 = r1 + nx, *r3 = r2 + nx, *r4 = r3 + nx;
    const double *r5 = I->rcx, *r6 = r5 + nx, *r7 = r6 + nx;
    for (i = 0; i < nx; i++) {
        const double conv = r4[i] + th * (r5[i] + th1 * (r6[i] + th * r7[i]));
        x_out[i] = r0[i] + th * (r1[i] + th1 * (r2[i] + th * (r3[i] + th1 * conv)));
    }
}

#endif /* GW_UNITY_BUILD */
