/*
 * gw_solver_dopri5.c -- Dormand-Prince 5(4) (Hairer, Norsett, Wanner, Solving ODE I,
 * Sect. II.5): 7 stages with FSAL, error control by the RMS norm of
 * err_i / (abs_tol nominal_i + rel_tol max(|x_i|, |xnew_i|)), step size h * clamp(0.9
 * err^(-1/5), 0.2, 10) bounded by max_step and carried between communication steps, and its
 * 4th-order continuous extension for event location.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>

#include "gw_solver.h"

/* ---- Dormand-Prince 5(4) coefficients (Hairer, Norsett, Wanner) ---------- */
static const double dp5_c2 = 1.0 / 5.0, dp5_c3 = 3.0 / 10.0, dp5_c4 = 4.0 / 5.0,
                    dp5_c5 = 8.0 / 9.0;
static const double dp5_a21 = 1.0 / 5.0;
static const double dp5_a31 = 3.0 / 40.0, dp5_a32 = 9.0 / 40.0;
static const double dp5_a41 = 44.0 / 45.0, dp5_a42 = -56.0 / 15.0, dp5_a43 = 32.0 / 9.0;
static const double dp5_a51 = 19372.0 / 6561.0, dp5_a52 = -25360.0 / 2187.0,
                    dp5_a53 = 64448.0 / 6561.0, dp5_a54 = -212.0 / 729.0;
static const double dp5_a61 = 9017.0 / 3168.0, dp5_a62 = -355.0 / 33.0, dp5_a63 = 46732.0 / 5247.0,
                    dp5_a64 = 49.0 / 176.0, dp5_a65 = -5103.0 / 18656.0;
static const double dp5_a71 = 35.0 / 384.0, dp5_a73 = 500.0 / 1113.0, dp5_a74 = 125.0 / 192.0,
                    dp5_a75 = -2187.0 / 6784.0, dp5_a76 = 11.0 / 84.0;
static const double dp5_e1 = 71.0 / 57600.0, dp5_e3 = -71.0 / 16695.0, dp5_e4 = 71.0 / 1920.0,
                    dp5_e5 = -17253.0 / 339200.0, dp5_e6 = 22.0 / 525.0, dp5_e7 = -1.0 / 40.0;
static const double dp5_d1 = -12715105075.0 / 11282082432.0,
                    dp5_d3 = 87487479700.0 / 32700410799.0,
                    dp5_d4 = -10690763975.0 / 1880347072.0,
                    dp5_d5 = 701980252875.0 / 199316789632.0,
                    dp5_d6 = -1453857185.0 / 822651844.0, dp5_d7 = 69997945.0 / 29380423.0;

/* DOPRI5 step; *err = weighted RMS error norm (NaN/inf when something overflowed). */
static int gw_dopri5_step(gw_instance *I, double h, double t1, double *err) {
    int i, nx = I->m->nx;
    const double t = I->t, *x = I->x, *nom = I->nominal;
    const double rtol = I->rel_tol, atol = I->atol_eff;
    double *k1 = I->k[0], *k2 = I->k[1], *k3 = I->k[2], *k4 = I->k[3], *k5 = I->k[4],
           *k6 = I->k[5], *k7 = I->k[6], *xt = I->xtmp, *xn = I->xnew;
    double sum = 0.0;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * dp5_a21 * k1[i];
    if (gw_rhs_checked(I, t + dp5_c2 * h, xt, k2)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * (dp5_a31 * k1[i] + dp5_a32 * k2[i]);
    if (gw_rhs_checked(I, t + dp5_c3 * h, xt, k3)) return -1;
    for (i = 0; i < nx; i++)
        xt[i] = x[i] + h * (dp5_a41 * k1[i] + dp5_a42 * k2[i] + dp5_a43 * k3[i]);
    if (gw_rhs_checked(I, t + dp5_c4 * h, xt, k4)) return -1;
    for (i = 0; i < nx; i++)
        xt[i] = x[i] + h * (dp5_a51 * k1[i] + dp5_a52 * k2[i] + dp5_a53 * k3[i] + dp5_a54 * k4[i]);
    if (gw_rhs_checked(I, t + dp5_c5 * h, xt, k5)) return -1;
    for (i = 0; i < nx; i++)
        xt[i] = x[i] + h * (dp5_a61 * k1[i] + dp5_a62 * k2[i] + dp5_a63 * k3[i] + dp5_a64 * k4[i] +
                            dp5_a65 * k5[i]);
    if (gw_rhs_checked(I, t1, xt, k6)) return -1;
    for (i = 0; i < nx; i++)
        I->dx[i] = h * (dp5_a71 * k1[i] + dp5_a73 * k3[i] + dp5_a74 * k4[i] + dp5_a75 * k5[i] +
                        dp5_a76 * k6[i]);
    gw_sum_update(I); /* xn = x + dx, compensated */
    if (gw_rhs_checked(I, t1, xn, k7)) return -1;
    I->k7_valid = 1;
    for (i = 0; i < nx; i++) {
        double ax = fabs(x[i]), an = fabs(xn[i]);
        double sk = atol * nom[i] + rtol * (ax > an ? ax : an);
        double ei = h * (dp5_e1 * k1[i] + dp5_e3 * k3[i] + dp5_e4 * k4[i] + dp5_e5 * k5[i] +
                         dp5_e6 * k6[i] + dp5_e7 * k7[i]);
        double r = ei / sk;
        sum += r * r;
    }
    *err = nx > 0 ? sqrt(sum / nx) : 0.0;
    return 0;
}

/* DOPRI5's 4th-order continuous extension (Hairer's dense output of DOPRI5):
 * rcont[4] = h (d1 k1 + d3 k3 + ... + d7 k7), the rest is the cubic Hermite base. */
GW_INTERNAL void gw_dopri5_dense(gw_instance *I) {
    int i, nx = I->m->nx;
    const double h = I->dense_h;
    const double *k1 = I->k[0], *k3 = I->k[2], *k4 = I->k[3], *k5 = I->k[4], *k6 = I->k[5],
                 *k7 = I->k[6];
    double *r4 = I->rcont + 4 * nx;
    for (i = 0; i < nx; i++)
        r4[i] = h * (dp5_d1 * k1[i] + dp5_d3 * k3[i] + dp5_d4 * k4[i] + dp5_d5 * k5[i] +
                     dp5_d6 * k6[i] + dp5_d7 * k7[i]);
}

/* ---- the adaptive loop -------------------------------------------------------- */

GW_INTERNAL gw_int_result gw_integrate_dopri5(gw_instance *I, double t_end) {
    int events = 0, rejected_last = 0;
    unsigned long n_fast = 0; /* attempts in a row projecting too many steps (guard) */
    double h_ref = 0.0; /* step size at the start of the budget projection window */
    const double hmax = I->max_step;
    if (gw_ensure_f0(I)) return GW_INT_ERROR;
    if (!(I->h_adapt > 0.0)) I->h_adapt = gw_initial_step(I, hmax, 5.0);
    if (I->h_adapt > hmax) I->h_adapt = hmax;
    while (I->t < t_end) {
        double h, err = 0.0, t1, fac;
        int last;
        if (gw_ensure_f0(I)) return GW_INT_ERROR;
        if (gw_next_attempt(I, t_end, rejected_last, &h_ref, &n_fast, &h, &t1, &last)) return GW_INT_ERROR;
        if (gw_dopri5_step(I, h, t1, &err)) return GW_INT_ERROR;
        if (err <= 1.0) {
            gw_int_result r;
            fac = gw_step_factor(I, err, 5.0, GW_DOPRI5_BETA, 0.75, GW_DOPRI5_FAC_MIN,
                                 GW_DOPRI5_FAC_MAX, 1, rejected_last);
            {
                double hnew = h * fac;
                /* a step shortened to land on t_end says little about the step size */
                if (last && h < I->h_adapt && hnew >= h) {
                    if (hnew < I->h_adapt) hnew = I->h_adapt;
                }
                I->h_adapt = hnew < hmax ? hnew : hmax;
            }
            rejected_last = 0;
            r = gw_accept_step(I, t1, &events);
            if (r != GW_INT_OK) return r;
        } else {
            I->n_rejected++;
            fac = gw_step_factor(I, err, 5.0, 0.0, 0.0, GW_DOPRI5_FAC_MIN, GW_DOPRI5_FAC_MAX, 0,
                                 rejected_last);
            I->h_adapt = h * fac;
            rejected_last = 1;
            if (I->h_adapt < gw_h_min(I->t)) {
                GW_LOG_ERR(I, "step size underflow at t=%.17g (h=%g, error norm %g, solver dopri5)",
                           I->t, I->h_adapt, err);
                return GW_INT_ERROR;
            }
        }
    }
    I->t = t_end;
    return GW_INT_OK;
}

#endif /* GW_UNITY_BUILD */
