/*
 * gw_solver_fixed.c -- explicit Euler and classical Runge-Kutta 4 with a fixed step: a
 * communication step h is cut into n = ceil(h / max_step) equal substeps on a deterministic
 * grid (t_i = t0 + i h / n, the last one exactly t_end).  Both refuse a step beyond their
 * stability limit on the real axis (an estimate of h |lambda| from the step's own derivatives:
 * Euler's secant along the step, RK4's stages and its secant at the step's end), since such
 * garbage can cross event indicators: a "fall" located
 * at beta = -31 rad after one step of a wheel spinning at 1e5 rad/s.  Dense output: the cubic
 * Hermite of gw_solver.c.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <float.h>
#include <math.h>

#include "gw_solver.h"

/* ---- single steps from (I->t, I->x) to t1 = I->t + h: result in I->xnew ---- */

/* max_i |a_i - b_i| / nominal_i */
static double gw_scaled_diff(const gw_instance *I, const double *a, const double *b) {
    int i;
    double m = 0.0;
    for (i = 0; i < I->m->nx; i++) {
        double d = fabs(a[i] - b[i]) / I->nominal[i];
        if (d > m || d != d) m = d;
    }
    return m;
}

/* max_i |k1_i| / nominal_i: the scale below which a difference of derivatives is rounding */
static double gw_scaled_rate(const gw_instance *I) {
    double k1 = 0.0;
    int i;
    for (i = 0; i < I->m->nx; i++) {
        double a = fabs(I->k[0][i]) / I->nominal[i];
        if (a > k1) k1 = a;
    }
    return k1;
}

/* The largest h |lambda| each method takes: Euler is stable for h |lambda| <= 2 on the negative
 * real axis, RK4 for h |lambda| <= 2.79; a resolved motion has h |lambda| << 1.  An estimate
 * above the limit means a step whose result grows without meaning (a factor 1.5 per Euler step
 * at h lambda = -2.5).  The estimates are exact for a linear f = lambda y; the bounds sit 10 %
 * and 8 % above the limits, so that a step at the limit itself, stable but inaccurate, passes
 * (tests/c/test_stiff.c: 1.9 and 2.7 pass, 2.5 and 3.2 are refused). */
#define GW_EULER_UNSTABLE 2.2
#define GW_RK4_UNSTABLE 3.0

static int gw_fixed_unstable(gw_instance *I, double h, double h_lambda, const char *limit) {
    /* h: the grid's step, max_step or a little less (the communication step cut into equal ones) */
    GW_LOG_ERR(I, "%s is unstable at t=%.17g with steps of h=%g (max_step=%g): h |lambda| ~ %.3g (stable "
               "up to %s); the dynamics are faster than the step: reduce max_step or use an adaptive solver",
               gw_solver_name(I->solver_in_use), I->t, h, I->max_step, h_lambda, limit);
    return 1;
}

/* h |lambda| from the secant between the step's end and a point a of the step: h |f(t1, x1) -
 * f_a| / |x1 - x_a|; Euler: a = the start (x, k1), RK4: a = its last stage's point (x + h k3, k4),
 * where a step that turns to garbage near its end (a wheel dipping towards flat, its rates
 * growing as 1 / sin(beta)) shows it although its first stages did not.  f(t1, x1) is the next
 * step's k1: kept in k[6] as the step's end derivative (k7_valid, as dopri5's FSAL stage), so
 * the check costs no evaluation.  An end derivative that cannot be evaluated or is not finite is
 * left to the next step, which names it; a difference of derivatives below 1e-6 of the
 * derivatives (rounding, for a resolved step whose two points nearly coincide) tells nothing. */
static int gw_step_end_unstable(gw_instance *I, double h, double t1, const double *fa, const double *xa,
                                double bound, const char *limit) {
    double df, dx;
    if (gw_rhs(I, t1, I->xnew, I->k[6]) != 0 || gw_first_nonfinite(I->k[6], I->m->nx) >= 0) return 0;
    I->k7_valid = 1;
    df = gw_scaled_diff(I, I->k[6], fa);
    dx = gw_scaled_diff(I, I->xnew, xa);
    if (!(h * df > bound * dx) || !(df > 1e-6 * gw_scaled_rate(I))) return 0;
    return gw_fixed_unstable(I, h, h * df / dx, limit);
}

static int gw_euler_step(gw_instance *I, double h, double t1) {
    int i, nx = I->m->nx;
    const double *k1 = I->k[0];
    for (i = 0; i < nx; i++) I->dx[i] = h * k1[i];
    gw_sum_update(I);
    I->k7_valid = 0;
    return gw_step_end_unstable(I, h, t1, k1, I->x, GW_EULER_UNSTABLE, "2") ? -1 : 0;
}

/* RK4's h |lambda| from its stages: for f = lambda y, |k3 - k2| / |k2 - k1| = h |lambda| / 2 */
static int gw_rk4_unstable(gw_instance *I, double h) {
    const double d21 = gw_scaled_diff(I, I->k[1], I->k[0]), d32 = gw_scaled_diff(I, I->k[2], I->k[1]);
    if (!(2.0 * d32 > GW_RK4_UNSTABLE * d21) || !(d32 > 1e-6 * gw_scaled_rate(I))) return 0;
    return gw_fixed_unstable(I, h, d21 > 0.0 ? 2.0 * d32 / d21 : HUGE_VAL, "2.8");
}

static int gw_rk4_step(gw_instance *I, double h, double t1) {
    int i, nx = I->m->nx;
    const double t = I->t, hh = 0.5 * h;
    const double *x = I->x;
    double *k1 = I->k[0], *k2 = I->k[1], *k3 = I->k[2], *k4 = I->k[3], *xt = I->xtmp;
    for (i = 0; i < nx; i++) xt[i] = x[i] + hh * k1[i];
    if (gw_rhs_checked(I, t + hh, xt, k2)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + hh * k2[i];
    if (gw_rhs_checked(I, t + hh, xt, k3)) return -1;
    if (gw_rk4_unstable(I, h)) return -1;
    for (i = 0; i < nx; i++) xt[i] = x[i] + h * k3[i];
    if (gw_rhs_checked(I, t1, xt, k4)) return -1;
    for (i = 0; i < nx; i++) I->dx[i] = (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    gw_sum_update(I); /* xnew; xt still holds the last stage's point x + h k3 */
    I->k7_valid = 0;
    return gw_step_end_unstable(I, h, t1, k4, xt, GW_RK4_UNSTABLE, "2.8") ? -1 : 0;
}


/* ---- the fixed-step loop ------------------------------------------------------ */

/* Substeps of max_step that cover [I->t, t_end] (at least 1).  A communication step meant to be
 * k max_step long (t_k = t0 + k h in the caller) comes out longer by the rounding of t: 1e-13 s
 * at t = 1000 s, 1e-10 of a 1 ms step.  That excess must not add a substep (twice the cost of a
 * real-time step, at random): up to 8 ulps of t are absorbed into the substeps, and never more
 * than a quarter of a step (far from t = 0 the doubles may be too coarse for max_step: refused
 * in gw_integrate_fixed, not absorbed).  Also the lower bound of every solver's step count that
 * the budget checks up front (gw_budget.c). */
GW_INTERNAL double gw_fixed_substeps(const gw_instance *I, double t_end) {
    const double t0 = I->t, H = t_end - t0;
    const double slack = fmin(1e-12 * I->max_step + 8.0 * DBL_EPSILON * fmax(fabs(t0), fabs(t_end)),
                              0.25 * I->max_step);
    const double nd = ceil((H - slack) / I->max_step);
    return nd < 1.0 ? 1.0 : nd;
}

GW_INTERNAL gw_int_result gw_integrate_fixed(gw_instance *I, double t_end) {
    const double t0 = I->t, H = t_end - t0;
    unsigned long long n, i;
    int events = 0, growing;
    double d_prev;
    n = (unsigned long long)gw_fixed_substeps(I, t_end); /* within the budget (gw_integrate) */
    d_prev = 0.0;
    growing = 0;
    for (i = 1; i <= n; i++) {
        /* deterministic grid: t_i = t0 + i*H/n, the last one exactly t_end */
        const double ti = (i == n) ? t_end : t0 + (double)i * H / (double)n;
        while (I->t < ti) {
            const double h = ti - I->t;
            gw_int_result r;
            if (h > 1.5 * I->max_step) {
                /* t_i rounded onto doubles spaced more than max_step / 8 apart: the step would
                 * silently be longer than the fixed step asked for */
                GW_LOG_ERR(I, "%s cannot take steps of max_step=%g at t=%.17g: doubles there are %g s "
                           "apart, so a step would be %g s; start nearer t = 0 or raise max_step",
                           gw_solver_name(I->solver_in_use), I->max_step, I->t, nextafter(I->t, HUGE_VAL) - I->t, h);
                return GW_INT_ERROR;
            }
            if ((double)I->n_call_steps >= I->max_internal_steps) { /* events restart substeps */
                gw_budget_message(I, "the budget of internal steps is spent", t_end - I->t, h);
                return GW_INT_ERROR;
            }
            I->n_call_steps++;
            if (gw_ensure_f0(I)) return GW_INT_ERROR;
            if (I->solver_in_use == GW_SOLVER_EULER) {
                /* Euler's instability: the step's h |lambda|, and increments that more than
                 * double, step after step */
                double d;
                if (gw_euler_step(I, h, ti)) return GW_INT_ERROR;
                d = gw_scaled_diff(I, I->xnew, I->x);
                growing = (d > 2.0 * d_prev && d_prev > 1e-12) ? growing + 1 : 0;
                d_prev = d;
                if (growing >= 4) {
                    GW_LOG_ERR(I, "euler is unstable at t=%.17g with max_step=%g: the increments grew "
                               "more than x2 per step for 4 steps; reduce max_step or use another solver",
                               I->t, h);
                    return GW_INT_ERROR;
                }
            } else if (gw_rk4_step(I, h, ti)) {
                return GW_INT_ERROR;
            }
            r = gw_accept_step(I, ti, &events);
            if (r != GW_INT_OK) return r;
        }
    }
    I->t = t_end;
    return GW_INT_OK;
}

#endif /* GW_UNITY_BUILD */
