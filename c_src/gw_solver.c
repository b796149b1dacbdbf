/*
 * gw_solver.c -- internal integrators (explicit Euler, RK4, Dormand-Prince 5(4)),
 * their dense output, and the loop that integrates one communication step
 * exactly to its end, handing every accepted step to the event module.
 * No memory is allocated here: all work vectors live in the instance.
 */
#include <float.h>
#include <math.h>
#include <string.h>

#include "gw_solver.h"

/* ---- Dormand-Prince 5(4) coefficients (Hairer, Norsett, Wanner) ---------- */
static const double c2 = 1.0 / 5.0, c3 = 3.0 / 10.0, c4 = 4.0 / 5.0, c5 = 8.0 / 9.0;
static const double a21 = 1.0 / 5.0;
static const double a31 = 3.0 / 40.0, a32 = 9.0 / 40.0;
static const double a41 = 44.0 / 45.0, a42 = -56.0 / 15.0, a43 = 32.0 / 9.0;
static const double a51 = 19372.0 / 6561.0, a52 = -25360.0 / 2187.0, a53 = 64448.0 / 6561.0,
                    a54 = -212.0 / 729.0;
static const double a61 = 9017.0 / 3168.0, a62 = -355.0 / 33.0, a63 = 46732.0 / 5247.0,
                    a64 = 49.0 / 176.0, a65 = -5103.0 / 18656.0;
static const double a71 = 35.0 / 384.0, a73 = 500.0 / 1113.0, a74 = 125.0 / 192.0,
                    a75 = -2187.0 / 6784.0, a76 = 11.0 / 84.0;
static const double e1 = 71.0 / 57600.0, e3 = -71.0 / 16695.0, e4 = 71.0 / 1920.0,
                    e5 = -17253.0 / 339200.0, e6 = 22.0 / 525.0, e7 = -1.0 / 40.0;
static const double d1 = -12715105075.0 / 11282082432.0, d3 = 87487479700.0 / 32700410799.0,
                    d4 = -10690763975.0 / 1880347072.0, d5 = 701980252875.0 / 199316789632.0,
                    d6 = -1453857185.0 / 822651844.0, d7 = 69997945.0 / 29380423.0;

double gw_h_min(double t) {
    double at = fabs(t);
    return 16.0 * DBL_EPSILON * (at > 1.0 ? at : 1.0);
}

static const char *x_name(const gw_instance *I, int i) {
    return (I->m->x_names && I->m->x_names[i]) ? I->m->x_names[i] : "?";
}

static int first_nonfinite(const double *v, int n) {
    int i;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) return i;
    return -1;
}

/* Make k[0] = f(t, x) (reused across steps: FSAL / end-point derivative). */
static int ensure_f0(gw_instance *I) {
    int bad;
    if (I->fcur_valid) return 0;
    if (gw_rhs(I, I->t, I->x, I->k[0]) != 0) {
        GW_ERROR(I, "evaluation of the right-hand side failed at t=%.17g", I->t);
        return -1;
    }
    bad = first_nonfinite(I->k[0], I->m->nx);
    if (bad >= 0) {
        GW_ERROR(I, "derivative of state %s is not finite (%g) at t=%.17g", x_name(I, bad),
                 I->k[0][bad], I->t);
        return -1;
    }
    I->fcur_valid = 1;
    return 0;
}

static int rhs(gw_instance *I, double t, const double *x, double *xdot) {
    if (gw_rhs(I, t, x, xdot) != 0) {
        GW_ERROR(I, "evaluation of the right-hand side failed at t=%.17g", t);
        return -1;
    }
    return 0;
}

/* ---- single steps from (I->t, I->x) to t1 = I->t + h: result in I->xnew ---- */

static int step_euler(gw_instance *I, double h) {
    int i, nx = I->m->nx;
    const double *x = I->x, *k1 = I->k[0];
    for (i = 0; i < nx; i++) I->xnew[i] = x[i] + h * k1[i];
    I->k7_valid = 0;
    return 0;
}

static int step_rk4(gw_instance *I, double h, double t1) {
    int i, nx = I->m->nx;
    const double t = I->t, hh = 0.5 * h;
    const double *x = I->x;
    double *k1 = I->k[0], *k2 = I->k[1], *k3 = I->k[2], *k4 = I->k[3], *xt = I->xtmp;
    for (i = 0; i < nx; i++) xt[i] = x[i] + hh * k1[i];
    if (rhs(I, t + hh, xt, k2)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + hh * k2[i];
    if (rhs(I, t + hh, xt, k3)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * k3[i];
    if (rhs(I, t1, xt, k4)) return -1;
    for (i = 0; i < nx; i++)
        I->xnew[i] = x[i] + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    I->k7_valid = 0;
    return 0;
}

/* DOPRI5 step; *err = weighted RMS error norm (NaN/inf when something overflowed). */
static int step_dopri5(gw_instance *I, double h, double t1, double *err) {
    int i, nx = I->m->nx;
    const double t = I->t, *x = I->x, *nom = I->nominal;
    const double rtol = I->rel_tol, atol = I->abs_tol;
    double *k1 = I->k[0], *k2 = I->k[1], *k3 = I->k[2], *k4 = I->k[3], *k5 = I->k[4],
           *k6 = I->k[5], *k7 = I->k[6], *xt = I->xtmp, *xn = I->xnew;
    double sum = 0.0;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * a21 * k1[i];
    if (rhs(I, t + c2 * h, xt, k2)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * (a31 * k1[i] + a32 * k2[i]);
    if (rhs(I, t + c3 * h, xt, k3)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * (a41 * k1[i] + a42 * k2[i] + a43 * k3[i]);
    if (rhs(I, t + c4 * h, xt, k4)) return -1;
    for (i = 0; i < nx; i++)
        xt[i] = x[i] + h * (a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i]);
    if (rhs(I, t + c5 * h, xt, k5)) return -1;
    for (i = 0; i < nx; i++)
        xt[i] = x[i] + h * (a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i] + a65 * k5[i]);
    if (rhs(I, t1, xt, k6)) return -1;
    for (i = 0; i < nx; i++)
        xn[i] = x[i] + h * (a71 * k1[i] + a73 * k3[i] + a74 * k4[i] + a75 * k5[i] + a76 * k6[i]);
    if (rhs(I, t1, xn, k7)) return -1;
    I->k7_valid = 1;
    for (i = 0; i < nx; i++) {
        double ax = fabs(x[i]), an = fabs(xn[i]);
        double sk = atol * nom[i] + rtol * (ax > an ? ax : an);
        double ei = h * (e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] +
                         e7 * k7[i]);
        double r = ei / sk;
        sum += r * r;
    }
    *err = nx > 0 ? sqrt(sum / nx) : 0.0;
    return 0;
}

/* ---- dense output ------------------------------------------------------------ */

/* Fill rcont for the last accepted step (lazy: only when an event needs it). */
void gw_dense_prepare(gw_instance *I) {
    int i, nx = I->m->nx;
    const double h = I->dense_h;
    const double *x = I->x, *xn = I->xnew, *k1 = I->k[0], *k7 = I->k[6];
    double *r0 = I->rcont, *r1 = r0 + nx, *r2 = r1 + nx, *r3 = r2 + nx, *r4 = r3 + nx;
    if (I->dense_ready) return;
    if (!I->k7_valid) {
        /* fixed-step solvers: end-point derivative for the cubic Hermite; it is
         * reused as k1 of the next step, so this costs nothing in the long run */
        if (gw_rhs(I, I->dense_t0 + h, xn, I->k[6]) != 0) {
            /* fall back to linear interpolation */
            for (i = 0; i < nx; i++) I->k[6][i] = (xn[i] - x[i]) / h;
        } else {
            I->k7_valid = 1;
        }
    }
    for (i = 0; i < nx; i++) {
        double ydiff = xn[i] - x[i];
        double bspl = h * k1[i] - ydiff;
        r0[i] = x[i];
        r1[i] = ydiff;
        r2[i] = bspl;
        r3[i] = ydiff - h * k7[i] - bspl;
        r4[i] = 0.0;
    }
    if (I->solver == GW_SOLVER_DOPRI5) {
        const double *k3 = I->k[2], *k4 = I->k[3], *k5 = I->k[4], *k6 = I->k[5];
        for (i = 0; i < nx; i++)
            r4[i] = h * (d1 * k1[i] + d3 * k3[i] + d4 * k4[i] + d5 * k5[i] + d6 * k6[i] +
                         d7 * k7[i]);
    }
    I->dense_ready = 1;
}

void gw_dense_eval(const gw_instance *I, double t, double *x_out) {
    int i, nx = I->m->nx;
    const double *r0 = I->rcont, *r1 = r0 + nx, *r2 = r1 + nx, *r3 = r2 + nx, *r4 = r3 + nx;
    double th, th1;
    if (t >= I->dense_t0 + I->dense_h) {
        memcpy(x_out, I->xnew, (size_t)nx * sizeof(double));
        return;
    }
    th = (t - I->dense_t0) / I->dense_h;
    if (th < 0.0) th = 0.0;
    th1 = 1.0 - th;
    for (i = 0; i < nx; i++)
        x_out[i] = r0[i] + th * (r1[i] + th1 * (r2[i] + th * (r3[i] + th1 * r4[i])));
}

/* ---- accepted steps ------------------------------------------------------------ */

static void swap_ptr(double **a, double **b) {
    double *tmp = *a;
    *a = *b;
    *b = tmp;
}

/* Accepted step (I->t, I->x) -> (t1, I->xnew): finiteness, events, commit.
 * *events counts events in this communication step (loop guard). */
static gw_int_result accept_step(gw_instance *I, double t1, int *events) {
    double te;
    gw_ev_result ev;
    int bad = first_nonfinite(I->xnew, I->m->nx);
    I->n_accepted++;
    if (bad >= 0) {
        GW_ERROR(I, "state %s is not finite (%g) at t=%.17g (solver %s)", x_name(I, bad),
                 I->xnew[bad], t1, gw_solver_name(I->solver));
        return GW_INT_ERROR;
    }
    I->dense_t0 = I->t;
    I->dense_h = t1 - I->t;
    I->dense_ready = 0;
    ev = (I->m->ne > 0) ? gw_events_check(I, I->t, t1, &te) : GW_EV_NONE;
    if (ev == GW_EV_ERROR) return GW_INT_ERROR;
    if (ev == GW_EV_NONE) {
        swap_ptr(&I->x, &I->xnew);
        if (I->m->ne > 0) swap_ptr(&I->e, &I->enew);
        I->t = t1;
        if (I->k7_valid) {
            swap_ptr(&I->k[0], &I->k[6]);
            I->fcur_valid = 1;
        } else {
            I->fcur_valid = 0;
        }
        return GW_INT_OK;
    }
    /* an event at te: the state there becomes the current state */
    swap_ptr(&I->x, &I->xev);
    swap_ptr(&I->e, &I->eev);
    I->t = te;
    I->fcur_valid = 0; /* restart the integration at the event */
    if (ev == GW_EV_TERMINATE) return GW_INT_TERMINATED;
    if (++(*events) > GW_MAX_EVENTS_PER_STEP) {
        GW_ERROR(I, "more than %d events in one communication step at t=%.17g",
                 GW_MAX_EVENTS_PER_STEP, te);
        return GW_INT_ERROR;
    }
    return GW_INT_OK;
}

/* ---- fixed-step solvers ------------------------------------------------------ */

static gw_int_result integrate_fixed(gw_instance *I, double t_end) {
    const double t0 = I->t, H = t_end - t0;
    double nd = ceil(H / I->max_step - 1e-12);
    unsigned long long n, i;
    int events = 0;
    if (nd < 1.0) nd = 1.0;
    if (nd > 1e15) {
        GW_ERROR(I, "communication step %g needs too many steps of max_step=%g", H, I->max_step);
        return GW_INT_ERROR;
    }
    n = (unsigned long long)nd;
    for (i = 1; i <= n; i++) {
        /* deterministic grid: t_i = t0 + i*H/n, the last one exactly t_end */
        const double ti = (i == n) ? t_end : t0 + (double)i * H / (double)n;
        while (I->t < ti) {
            const double h = ti - I->t;
            gw_int_result r;
            if (ensure_f0(I)) return GW_INT_ERROR;
            if (I->solver == GW_SOLVER_EULER) {
                step_euler(I, h);
            } else if (step_rk4(I, h, ti)) {
                return GW_INT_ERROR;
            }
            r = accept_step(I, ti, &events);
            if (r != GW_INT_OK) return r;
        }
    }
    I->t = t_end;
    return GW_INT_OK;
}

/* ---- Dormand-Prince 5(4) ------------------------------------------------------- */

static double rms_weighted(const gw_instance *I, const double *v, const double *x) {
    int i, nx = I->m->nx;
    double sum = 0.0;
    for (i = 0; i < nx; i++) {
        double sk = I->abs_tol * I->nominal[i] + I->rel_tol * fabs(x[i]);
        double r = v[i] / sk;
        sum += r * r;
    }
    return nx > 0 ? sqrt(sum / nx) : 0.0;
}

/* Hairer's initial step size estimate (one extra RHS evaluation). */
static double initial_step(gw_instance *I, double hmax) {
    int i, nx = I->m->nx;
    double dnf = rms_weighted(I, I->k[0], I->x), dny = rms_weighted(I, I->x, I->x);
    double h, der2, der12, h1;
    if (nx == 0) return hmax;
    h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : 0.01 * dny / dnf;
    if (h > hmax) h = hmax;
    for (i = 0; i < nx; i++) I->xtmp[i] = I->x[i] + h * I->k[0][i];
    if (gw_rhs(I, I->t + h, I->xtmp, I->k[1]) != 0) return h * 1e-3;
    for (i = 0; i < nx; i++) I->k[2][i] = I->k[1][i] - I->k[0][i];
    der2 = rms_weighted(I, I->k[2], I->x) / h;
    der12 = fabs(der2) > sqrt(dnf) ? fabs(der2) : sqrt(dnf);
    h1 = (der12 <= 1e-15 || !isfinite(der12)) ? (h * 1e-3 > 1e-6 ? h * 1e-3 : 1e-6)
                                              : pow(0.01 / der12, 0.2);
    if (!isfinite(h1)) h1 = h * 1e-3;
    h = 100.0 * h < h1 ? 100.0 * h : h1;
    return h < hmax ? h : hmax;
}

static gw_int_result integrate_dopri5(gw_instance *I, double t_end) {
    int events = 0, rejected_last = 0;
    const double hmax = I->max_step;
    if (ensure_f0(I)) return GW_INT_ERROR;
    if (!(I->h_adapt > 0.0)) I->h_adapt = initial_step(I, hmax);
    if (I->h_adapt > hmax) I->h_adapt = hmax;
    while (I->t < t_end) {
        const double remaining = t_end - I->t;
        double h = I->h_adapt, err = 0.0, t1, fac;
        int last = 0;
        if (ensure_f0(I)) return GW_INT_ERROR;
        if (h > hmax) h = hmax;
        if (1.01 * h >= remaining) {
            h = remaining;
            last = 1;
        }
        t1 = last ? t_end : I->t + h;
        if (!last && (h < gw_h_min(I->t) || !(t1 > I->t))) {
            /* the controller asks for steps that no longer advance time */
            GW_ERROR(I, "step size underflow at t=%.17g (h=%g)", I->t, h);
            return GW_INT_ERROR;
        }
        if (step_dopri5(I, h, t1, &err)) return GW_INT_ERROR;
        if (err <= 1.0) {
            gw_int_result r;
            fac = err > 0.0 ? GW_DOPRI5_SAFETY * pow(err, -0.2) : GW_DOPRI5_FAC_MAX;
            if (fac > GW_DOPRI5_FAC_MAX) fac = GW_DOPRI5_FAC_MAX;
            if (fac < GW_DOPRI5_FAC_MIN) fac = GW_DOPRI5_FAC_MIN;
            if (rejected_last && fac > 1.0) fac = 1.0;
            {
                double hnew = h * fac;
                /* a step shortened to land on t_end says little about the step size */
                if (last && h < I->h_adapt && hnew >= h) {
                    if (hnew < I->h_adapt) hnew = I->h_adapt;
                }
                I->h_adapt = hnew < hmax ? hnew : hmax;
            }
            rejected_last = 0;
            r = accept_step(I, t1, &events);
            if (r != GW_INT_OK) return r;
        } else {
            I->n_rejected++;
            fac = isfinite(err) ? GW_DOPRI5_SAFETY * pow(err, -0.2) : GW_DOPRI5_FAC_MIN;
            if (fac < GW_DOPRI5_FAC_MIN) fac = GW_DOPRI5_FAC_MIN;
            I->h_adapt = h * fac;
            rejected_last = 1;
            if (I->h_adapt < gw_h_min(I->t)) {
                GW_ERROR(I, "step size underflow at t=%.17g (h=%g, error norm %g)", I->t,
                         I->h_adapt, err);
                return GW_INT_ERROR;
            }
        }
    }
    I->t = t_end;
    return GW_INT_OK;
}

gw_int_result gw_integrate(gw_instance *I, double t_end) {
    switch (I->solver) {
    case GW_SOLVER_EULER:
    case GW_SOLVER_RK4: return integrate_fixed(I, t_end);
    case GW_SOLVER_DOPRI5: return integrate_dopri5(I, t_end);
    default:
        GW_ERROR(I, "solver %s (%d) not available", gw_solver_name(I->solver), I->solver);
        return GW_INT_ERROR;
    }
}
