/*
 * gw_solver.c -- the step driver: gw_integrate dispatches to the solver families
 * (gw_solver.h), hands every accepted step to the event module (the budget of internal steps
 * that bounds every call is gw_budget.c), runs the adaptive loop shared by DOP853 and RODAS4,
 * and evaluates the dense output of the last accepted step.  No memory is allocated while integrating: all
 * work vectors live in the instance (gw_solver_alloc at instantiation).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <float.h>
#include <math.h>
#include <string.h>

#include "gw_solver.h"

GW_INTERNAL double gw_h_min(double t) {
    double at = fabs(t);
    return 16.0 * DBL_EPSILON * (at > 1.0 ? at : 1.0);
}

GW_INTERNAL const char *gw_x_name(const gw_instance *I, int i) {
    return (I->m->x_names && I->m->x_names[i]) ? I->m->x_names[i] : "?";
}

GW_INTERNAL int gw_first_nonfinite(const double *v, int n) {
    int i, bad = 0;
    for (i = 0; i < n; i++) bad |= !(fabs(v[i]) <= DBL_MAX); /* branch-free: every step's check */
    if (!bad) return -1;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) return i;
    return -1;
}

GW_INTERNAL int gw_ensure_f0(gw_instance *I) {
    int bad;
    if (I->fcur_valid) return 0;
    if (gw_rhs(I, I->t, I->x, I->k[0]) != 0) {
        GW_LOG_ERR(I, "evaluation of the right-hand side failed at t=%.17g", I->t);
        return -1;
    }
    bad = gw_first_nonfinite(I->k[0], I->m->nx);
    if (bad >= 0) {
        GW_LOG_ERR(I, "derivative of state %s is not finite (%g) at t=%.17g", gw_x_name(I, bad),
                   I->k[0][bad], I->t);
        return -1;
    }
    I->fcur_valid = 1;
    return 0;
}

GW_INTERNAL int gw_rhs_checked(gw_instance *I, double t, const double *x, double *xdot) {
    if (gw_rhs(I, t, x, xdot) != 0) {
        GW_LOG_ERR(I, "evaluation of the right-hand side failed at t=%.17g", t);
        return -1;
    }
    return 0;
}

/* ---- accepted steps ------------------------------------------------------------ */

static void gw_swap_ptr(double **a, double **b) {
    double *tmp = *a;
    *a = *b;
    *b = tmp;
}

GW_INTERNAL gw_int_result gw_accept_step(gw_instance *I, double t1, int *events) {
    double te;
    gw_ev_result ev;
    int bad = gw_first_nonfinite(I->xnew, I->m->nx);
    I->n_accepted++;
    if (bad >= 0) {
        GW_LOG_ERR(I, "state %s is not finite (%g) at t=%.17g (solver %s)", gw_x_name(I, bad),
                   I->xnew[bad], t1, gw_solver_name(I->solver_in_use));
        return GW_INT_ERROR;
    }
    I->dense_t0 = I->t;
    I->dense_h = t1 - I->t;
    I->dense_ready = 0;
    ev = (I->m->ne > 0) ? gw_events_check(I, I->t, t1, &te) : GW_EV_NONE;
    if (ev == GW_EV_ERROR) return GW_INT_ERROR;
    if (ev == GW_EV_NONE) {
        gw_swap_ptr(&I->x, &I->xnew);
        gw_swap_ptr(&I->xc, &I->xcnew);
        if (I->m->ne > 0) {
            gw_swap_ptr(&I->e, &I->enew);
            gw_swap_ptr(&I->edot, &I->edot_new); /* the indicators' slopes at t1 */
            I->edot_t = t1;
            I->edot_valid = 1;
        }
        I->t = t1;
        if (I->k7_valid) {
            gw_swap_ptr(&I->k[0], &I->k[6]);
            I->fcur_valid = 1;
        } else {
            I->fcur_valid = 0;
        }
        return GW_INT_OK;
    }
    /* an event at te: the state there (dense output) becomes the current state */
    gw_swap_ptr(&I->x, &I->xev);
    memset(I->xc, 0, (size_t)I->m->nx * sizeof(double));
    gw_swap_ptr(&I->e, &I->eev);
    I->t = te;
    I->fcur_valid = 0; /* restart the integration at the event */
    I->edot_valid = 0;
    if (ev == GW_EV_TERMINATE) return GW_INT_TERMINATED;
    if (ev == GW_EV_UPDATE && I->stop_at_update != GW_STOP_NEVER) return GW_INT_EVENT;
    if (++(*events) > GW_MAX_EVENTS_PER_STEP) {
        gw_events_log_too_many(I, te, GW_MAX_EVENTS_PER_STEP);
        return GW_INT_ERROR;
    }
    return GW_INT_OK;
}


/* ---- error norm, initial step, next attempt ---------------------------------------------- */

GW_INTERNAL double gw_rms_weighted(const gw_instance *I, const double *v, const double *x) {
    int i, nx = I->m->nx;
    double sum = 0.0;
    for (i = 0; i < nx; i++) {
        double sk = I->atol_eff * I->nominal[i] + I->rel_tol * fabs(x[i]);
        double r = v[i] / sk;
        sum += r * r;
    }
    return nx > 0 ? sqrt(sum / nx) : 0.0;
}

GW_INTERNAL double gw_initial_step(gw_instance *I, double hmax, double order) {
    int i, nx = I->m->nx;
    double dnf = gw_rms_weighted(I, I->k[0], I->x), dny = gw_rms_weighted(I, I->x, I->x);
    double h, der2, der12, h1;
    if (nx == 0) return hmax;
    h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : 0.01 * dny / dnf;
    if (h > hmax) h = hmax;
    for (i = 0; i < nx; i++) I->xtmp[i] = I->x[i] + h * I->k[0][i];
    if (gw_rhs(I, I->t + h, I->xtmp, I->k[1]) != 0) return h * 1e-3;
    for (i = 0; i < nx; i++) I->k[2][i] = I->k[1][i] - I->k[0][i];
    der2 = gw_rms_weighted(I, I->k[2], I->x) / h;
    der12 = fabs(der2) > sqrt(dnf) ? fabs(der2) : sqrt(dnf);
    h1 = (der12 <= 1e-15 || !isfinite(der12)) ? (h * 1e-3 > 1e-6 ? h * 1e-3 : 1e-6)
                                              : pow(0.01 / der12, 1.0 / order);
    if (!isfinite(h1)) h1 = h * 1e-3;
    h = 100.0 * h < h1 ? 100.0 * h : h1;
    /* Hairer's estimate scales with abs_tol where a state starts at 0 with a nonzero rate (a
     * free fall's height rate): a tiny abs_tol gives a first step below the step-size floor,
     * which gw_next_attempt would refuse before the error control ever judged a step.  Start at
     * GW_H0_FLOORS floors at least: the error control shrinks it if it must. */
    if (h < GW_H0_FLOORS * gw_h_min(I->t)) h = GW_H0_FLOORS * gw_h_min(I->t);
    return h < hmax ? h : hmax;
}

/* Hairer's step size controller with step size stabilisation (PI, Gustafsson; dopri5.f and
 * dop853.f with BETA): fac = err^-expo / err_old^-beta with expo = 1/q - w beta (Hairer's
 * weights w: 0.75 for DOPRI5, 0.2 for DOP853), h_new = h * safety * fac within [fac_min,
 * fac_max]; no increase right after a rejection; a rejected step uses err^(-1/q) alone.
 * err_old (I->err_old, part of a saved state) is the error norm of the last accepted step,
 * floored at 1e-4 (0: none yet, integral control alone). */
GW_INTERNAL double gw_step_factor(gw_instance *I, double err, double q, double beta, double w,
                                  double fac_min, double fac_max, int accepted, int rejected_last) {
    const double safety = 0.9;
    double fac;
    if (!isfinite(err)) return fac_min;
    if (!(err > 0.0)) return accepted && !rejected_last ? fac_max : 1.0;
    if (!accepted) {
        fac = safety * pow(err, -1.0 / q);
        return fac < fac_min ? fac_min : (fac > 1.0 ? 1.0 : fac);
    }
    fac = (beta > 0.0 && I->err_old > 0.0)
              ? safety * pow(err, -(1.0 / q - w * beta)) * pow(I->err_old, beta)
              : safety * pow(err, -1.0 / q);
    I->err_old = err > 1e-4 ? err : 1e-4;
    if (fac > fac_max) fac = fac_max;
    if (fac < fac_min) fac = fac_min;
    if (rejected_last && fac > 1.0) fac = 1.0;
    return fac;
}

/* x_new = x + dx with the state's compensation (TwoSum, Knuth / Moller): x + xc carries the
 * increments below half an ulp of x that plain addition rounds away (a lean rate of 1e-17
 * rad/s near pi/2, the phase of a long run), so the state loses nothing to rounding step
 * after step.  Writes I->xnew and I->xcnew from I->x, I->xc and I->dx. */
GW_INTERNAL void gw_sum_update(gw_instance *I) {
    int i, nx = I->m->nx;
    const double *x = I->x, *xc = I->xc, *dx = I->dx;
    double *xn = I->xnew, *xcn = I->xcnew;
    for (i = 0; i < nx; i++) {
        const double y = dx[i] + xc[i], s = x[i] + y, bp = s - x[i];
        xn[i] = s;
        xcn[i] = (x[i] - (s - bp)) + (y - bp);
    }
}

/* ---- DOP853 and Rosenbrock: adaptive loop ---------------------------------------------
 * Same landing on t_end, max_step bound, step size carry-over (I->h_adapt) and
 * underflow rule as DOPRI5.  Controllers (Hairer's codes, without memory of earlier
 * steps, so nothing beyond h_adapt has to be part of a saved state):
 *   DOP853      h_new = h * clamp(0.9 err^(-1/8), 1/3, 6)
 *   Rosenbrock  h_new = h * clamp(0.9 err^(-1/4), 1/5, 6)
 * no increase right after a rejection.  Rosenbrock evaluates the Jacobian once per
 * accepted step (at its start point); a rejected step only refactors W with the new h.
 * A singular W is treated like a rejected step with h halved. */
static gw_int_result gw_integrate_adaptive(gw_instance *I, double t_end) {
    const int ros = (I->solver_in_use == GW_SOLVER_ROSENBROCK);
    const double fac_min = ros ? 0.2 : 1.0 / 3.0, fac_max = 6.0, hmax = I->max_step;
    int events = 0, rejected_last = 0, jac_valid = 0;
    double lu_h = 0.0; /* step size of the factors in I->lu (0: none) */
    unsigned long n_jac = 0, n_lu = 0, rhs_jac = 0, n_fast = 0;
    double h_ref = 0.0; /* step size at the start of the budget projection window */
    const double t_begin = I->t;
    gw_int_result result = GW_INT_OK;
    if (gw_ensure_f0(I)) return GW_INT_ERROR;
    if (!(I->h_adapt > 0.0)) I->h_adapt = gw_initial_step(I, hmax, ros ? 4.0 : 8.0);
    if (I->h_adapt > hmax) I->h_adapt = hmax;
    while (I->t < t_end) {
        double h, err = 0.0, t1, fac;
        int last;
        if (gw_ensure_f0(I)) return GW_INT_ERROR;
        if (gw_next_attempt(I, t_end, rejected_last, &h_ref, &n_fast, &h, &t1, &last)) return GW_INT_ERROR;
        if (ros) {
            if (!jac_valid) {
                unsigned long long r0 = I->n_rhs;
                if (gw_rodas4_linearise(I)) return GW_INT_ERROR;
                rhs_jac += (unsigned long)(I->n_rhs - r0);
                jac_valid = 1;
                n_jac++;
                lu_h = 0.0;
            }
            if (lu_h != h) {
                n_lu++;
                lu_h = h;
                if (gw_rodas4_factor(I, h)) {
                    lu_h = 0.0;
                    I->n_rejected++;
                    I->h_adapt = 0.5 * h;
                    rejected_last = 1;
                    if (I->h_adapt < gw_h_min(I->t)) {
                        GW_LOG_ERR(I, "step size underflow at t=%.17g (h=%g, solver rosenbrock): "
                                   "the matrix I/(gamma h) - J stays singular", I->t, I->h_adapt);
                        return GW_INT_ERROR;
                    }
                    continue;
                }
            }
            if (gw_rodas4_step(I, h, t1, &err)) return GW_INT_ERROR;
        } else {
            if (gw_dop853_step(I, h, t1, &err)) return GW_INT_ERROR;
        }
        if (err <= 1.0) {
            gw_int_result r;
            double hnew;
            if (!ros) {
                /* FSAL: f at the new point, for the next step and the dense output */
                if (gw_rhs_checked(I, t1, I->xnew, I->k[6])) return GW_INT_ERROR;
                I->k7_valid = 1;
            }
            fac = ros ? gw_step_factor(I, err, 4.0, 0.0, 0.0, fac_min, fac_max, 1, rejected_last)
                      : gw_step_factor(I, err, 8.0, GW_DOP853_BETA, 0.2, fac_min, fac_max, 1,
                                       rejected_last);
            hnew = h * fac;
            /* a step shortened to land on t_end says little about the step size */
            if (last && h < I->h_adapt && hnew >= h && hnew < I->h_adapt) hnew = I->h_adapt;
            I->h_adapt = hnew < hmax ? hnew : hmax;
            rejected_last = 0;
            jac_valid = 0; /* a new point: new Jacobian */
            r = gw_accept_step(I, t1, &events);
            if (r != GW_INT_OK) {
                result = r;
                break;
            }
        } else {
            I->n_rejected++;
            fac = gw_step_factor(I, err, ros ? 4.0 : 8.0, 0.0, 0.0, fac_min, fac_max, 0, rejected_last);
            I->h_adapt = h * fac;
            rejected_last = 1;
            if (I->h_adapt < gw_h_min(I->t)) {
                GW_LOG_ERR(I, "step size underflow at t=%.17g (h=%g, error norm %g, solver %s)",
                           I->t, I->h_adapt, err, gw_solver_name(I->solver_in_use));
                return GW_INT_ERROR;
            }
        }
    }
    if (result == GW_INT_OK) I->t = t_end;
    if (ros && gw_log_enabled(I, GW_LOG_SOLVER))
        gw_log(I, GW_OK, GW_LOG_SOLVER,
               "rosenbrock t=%.17g -> t=%.17g jacobians=%lu (%s, rhs=%lu) lu=%lu", t_begin,
               I->t, n_jac, I->f_jac.eval ? "analytic" : "finite differences", rhs_jac, n_lu);
    return result;
}

GW_API int gw_solver_auto(const gw_model *m) {
    return m->taylor.jet && !m->upd.eval ? GW_SOLVER_TAYLOR : GW_SOLVER_DOP853;
}

GW_INTERNAL void gw_solver_select(gw_instance *I) {
    I->solver_in_use = I->solver == GW_SOLVER_AUTO ? gw_solver_auto(I->m) : I->solver;
}

GW_INTERNAL gw_int_result gw_integrate(gw_instance *I, double t_end) {
    gw_solver_select(I);
    if (gw_budget_upfront(I, t_end)) return GW_INT_ERROR;
    switch (I->solver_in_use) {
    case GW_SOLVER_EULER:
    case GW_SOLVER_RK4: return gw_integrate_fixed(I, t_end);
    case GW_SOLVER_DOPRI5: return gw_integrate_dopri5(I, t_end);
    case GW_SOLVER_DOP853:
    case GW_SOLVER_ROSENBROCK: return gw_integrate_adaptive(I, t_end);
    case GW_SOLVER_TAYLOR: return gw_integrate_taylor(I, t_end);
    default:
        GW_LOG_ERR(I, "solver %s (%d) not available", gw_solver_name(I->solver_in_use), I->solver);
        return GW_INT_ERROR;
    }
}


/* ---- dense output ------------------------------------------------------------ */

/* Fill rcont for the last accepted step (lazy: only when an event needs it): the cubic
 * Hermite base of every explicit solver, refined by DOPRI5 and DOP853; RODAS4's own. */
GW_INTERNAL void gw_dense_prepare(gw_instance *I) {
    int i, nx = I->m->nx;
    const double h = I->dense_h;
    const double *x = I->x, *xn = I->xnew, *k1 = I->k[0], *k7 = I->k[6];
    double *r0 = I->rcont, *r1 = r0 + nx, *r2 = r1 + nx, *r3 = r2 + nx, *r4 = r3 + nx;
    if (I->dense_ready) return;
    if (I->solver_in_use == GW_SOLVER_TAYLOR) { /* the step's own polynomial */
        I->dense_ready = 1;
        return;
    }
    if (I->solver_in_use == GW_SOLVER_ROSENBROCK) {
        gw_rodas4_dense(I);
        I->dense_ready = 1;
        return;
    }
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
    if (I->solver_in_use == GW_SOLVER_DOPRI5) gw_dopri5_dense(I);
    if (I->solver_in_use == GW_SOLVER_DOP853) gw_dop853_dense(I);
    I->dense_ready = 1;
}

GW_INTERNAL void gw_dense_eval(const gw_instance *I, double t, double *x_out) {
    int i, nx = I->m->nx;
    const double *r0 = I->rcont, *r1 = r0 + nx, *r2 = r1 + nx, *r3 = r2 + nx, *r4 = r3 + nx;
    double th, th1;
    if (t >= I->dense_t0 + I->dense_h) {
        memcpy(x_out, I->xnew, (size_t)nx * sizeof(double));
        return;
    }
    if (I->solver_in_use == GW_SOLVER_TAYLOR) {
        gw_taylor_dense_eval(I, t < I->dense_t0 ? I->dense_t0 : t, x_out);
        return;
    }
    th = (t - I->dense_t0) / I->dense_h;
    if (th < 0.0) th = 0.0;
    th1 = 1.0 - th;
    if (I->solver_in_use == GW_SOLVER_DOP853) {
        gw_dop853_dense_eval(I, th, th1, x_out);
        return;
    }
    for (i = 0; i < nx; i++)
        x_out[i] = r0[i] + th * (r1[i] + th1 * (r2[i] + th * (r3[i] + th1 * r4[i])));
}

/* ---- solver work memory ------------------------------------------------------------- */

GW_API int gw_solver_available(int solver) {
    return solver == GW_SOLVER_EULER || solver == GW_SOLVER_RK4 || solver == GW_SOLVER_DOPRI5 ||
           solver == GW_SOLVER_ROSENBROCK || solver == GW_SOLVER_DOP853 ||
           solver == GW_SOLVER_TAYLOR || solver == GW_SOLVER_AUTO;
}

GW_INTERNAL int gw_solver_alloc(gw_instance *I) {
    const size_t nx = (size_t)I->m->nx;
    int i;
    for (i = 0; i < 9; i++) {
        I->kx[i] = (double *)gw_alloc(I, nx, sizeof(double));
        if (!I->kx[i]) return -1;
    }
    I->rcx = (double *)gw_alloc(I, 3 * nx, sizeof(double));
    I->sacc = (double *)gw_alloc(I, nx, sizeof(double));
    if (!I->sacc) return -1;
    I->jac = (double *)gw_alloc(I, nx * nx, sizeof(double));
    I->lu = (double *)gw_alloc(I, nx * nx, sizeof(double));
    I->piv = (int *)gw_alloc(I, nx, sizeof(int));
    if (gw_taylor_alloc(I)) return -1;
    return (I->rcx && I->jac && I->lu && I->piv) ? 0 : -1;
}

GW_INTERNAL void gw_solver_free(gw_instance *I) {
    int i;
    for (i = 0; i < 9; i++) {
        gw_free(I, I->kx[i]);
        I->kx[i] = NULL;
    }
    gw_free(I, I->rcx);
    gw_free(I, I->sacc);
    I->sacc = NULL;
    gw_free(I, I->jac);
    gw_free(I, I->lu);
    gw_free(I, I->piv);
    I->rcx = I->jac = I->lu = NULL;
    I->piv = NULL;
    gw_taylor_free(I);
}

GW_API const char *gw_solver_name(int solver) {
    switch (solver) {
    case GW_SOLVER_EULER: return "euler";
    case GW_SOLVER_RK4: return "rk4";
    case GW_SOLVER_DOPRI5: return "dopri5";
    case GW_SOLVER_ROSENBROCK: return "rosenbrock";
    case GW_SOLVER_DOP853: return "dop853";
    case GW_SOLVER_TAYLOR: return "taylor";
    case GW_SOLVER_AUTO: return "auto";
    default: return "unknown";
    }
}

#endif /* GW_UNITY_BUILD */
