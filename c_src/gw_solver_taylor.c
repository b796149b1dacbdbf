/*
 * gw_solver_taylor.c -- GW_SOLVER_TAYLOR: the Taylor series method of adaptive order with the
 * model's generated Taylor kernel (GW_MODEL.taylor; gw_taylor.c, taylor/kernel_c.py).
 *
 * One step from (t, x): the kernel computes the Taylor coefficients x_i^[k], k = 0..p, of the
 * solution through t (automatic differentiation of the right-hand side's expression graph);
 * then (A. Jorba, M. Zou, A software package for the numerical integration of ODEs by means
 * of high-order Taylor methods, Exp. Math. 14 (2005) 99-117, sect. 3.2-3.3):
 *   order   p = p0 + GW_TAYLOR_EXTRA_ORDER (4), p0 = ceil(-ln(eps) / 2 + 1), eps = rel_tol,
 *           p0 clamped to [3, GW_TAYLOR_MAX_ORDER] (at order 2 the step h ~ 0.07 (|x_i| +
 *           floor) / |x_i'| closes in on every zero of a state geometrically when the floor
 *           atol / rel_tol is small, so rel_tol > e^-2 took 15x the steps of rel_tol 0.1
 *           (48,000 against 3,200 on the paper's 20 s); from order 3 h ~ |x_i|^(1/2) near a
 *           zero and crosses it in a few steps).  p0 is Jorba & Zou's and heyoka's order
 *           (Biscani & Izzo, MNRAS 504 (2021) 2614, sect. 4), optimal when a step costs ~p^2;
 *           this kernel's cost per step grows nearly linearly with p (a fixed part, the linear
 *           nodes, few products), so fewer, longer steps of a higher order reach the same
 *           error sooner (paper scenario: 13-25% less time to each error, docs/taylor.md;
 *           re-measured against + 2, + 3, + 5, + 6 with the present kernel, fewer orders at
 *           loose tolerances included: benchmarks/taylor_order_ab.py)
 *   step    h = rho exp(c),  rho = min_{j = p-1, p} N_j^(-1/j),
 *           N_j = max_i |x_i^[j]| / sc_i,  sc_i = |x_i| + (atol / rel_tol) nominal_i,
 *           c = -(2 + 0.7 / (q - 1)) (q + 1) / (p + 1), q = -ln(eps) / 2 + 3/2 (>= 3): the
 *           first neglected term (h / rho)^(p+1) is the one of Jorba & Zou's step
 *           rho / e^2 exp(-0.7 / (q - 1)) at order q, about eps sc_i = rel_tol |x_i| + atol
 *           nominal_i, the error weight of every solver (atol: abs_tol, or rel_tol / 100 when
 *           abs_tol = 0); q follows eps continuously (at the integer p0 the term stayed put over
 *           each p0's range of eps and fell e^2 at its end; q - 1/2 = the unrounded p0, so on
 *           average over that range the term is the former one); log2 and 2^y to 6e-6
 *           (gw_fm_step: exponent bits and short polynomials, no pow, no libm);
 *   update  dx_i = sum_{k=1..p} x_i^[k] h^k (Horner, with P'(h) in the same pass), added to
 *           the state with the TwoSum compensation every solver shares (gw_sum_update: x + xc,
 *           xc part of a saved state, layout v3), so that rounding does not accumulate;
 *   dense   the Taylor polynomial itself: x(t + s) for s in [0, h], exact to the order of the
 *           step, used by the event location (gw_events.c) like every dense output.
 *   check   the defect of the polynomial at the step's end, f(t1, P(h)) - P'(h)
 *           (gw_taylor_defect): the estimate from the last two orders misses a near complex
 *           pole or a stiff mode (lunar_rover's smoothed rolling resistance tanh(omega/eps)
 *           near the fall: steps 100x too long, rates 0.7 rad/s off); a step whose defect
 *           exceeds the error weight is shortened on the same series and counted as rejected.
 *           f(t1, P(h)) is order 1 of the series at (t1, P(h)), which the next step needs:
 *           the kernel runs there before the step is accepted (gw_integrate_taylor), so the
 *           check costs nothing when the step is accepted; the last step of a call, and the
 *           retries of a rejected step, evaluate the right-hand side instead.
 * As in the other adaptive solvers the step is bounded by max_step, lands exactly on t_end,
 * counts against the budget max_internal_steps (every attempt) and is refused by the
 * feasibility guard (gw_next_attempt), and below gw_h_min ("step size underflow"); a
 * non-finite derivative, a non-finite coefficient of the orders that set h, or a non-finite
 * state is an error with its reason.  One kernel call counts as one right-hand side
 * evaluation in n_rhs.
 * All of this is compiled only with the model's kernel (GW_TAYLOR_KERNEL, gw_taylor.c); without
 * it the file is the four functions the core calls, refusing solver taylor.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <float.h>
#include <math.h>
#include <string.h>

#include "gw_solver.h"

#ifndef GW_TAYLOR_KERNEL
/* A model without the Taylor kernel (gw_taylor.c): no Taylor code at all, only what the rest of
 * the core calls.  Solver taylor cannot be chosen (gw_values.c refuses it, naming why); a call
 * here regardless is refused too. */
GW_INTERNAL gw_int_result gw_integrate_taylor(gw_instance *I, double t_end) {
    (void)t_end;
    GW_LOG_ERR(I, "solver taylor is not available in this model: %s",
               I->m->taylor.why_absent ? I->m->taylor.why_absent
                                       : "it was built without a Taylor kernel");
    return GW_INT_ERROR;
}

GW_INTERNAL void gw_taylor_dense_eval(const gw_instance *I, double t, double *x_out) {
    (void)t; /* no Taylor step was taken: the state at the step's end */
    memcpy(x_out, I->xnew, (size_t)I->m->nx * sizeof(double));
}

GW_INTERNAL int gw_taylor_alloc(gw_instance *I) {
    (void)I;
    return 0;
}

GW_INTERNAL void gw_taylor_free(gw_instance *I) { (void)I; }

#else /* GW_TAYLOR_KERNEL */

#include "gw_solver_taylor_step.h" /* gw_fm_step: the step size */

/* The rejection rule's ln and exp (a rejected step's shorter retry; the step size itself is
 * gw_fm_step's, gw_taylor_step_size): libm's in the FMU, gw_fm_logexp.h's in the ensemble library
 * (gw_ensemble_lib.c: GW_TAYLOR_STEP_FM 1) */
#ifndef GW_TAYLOR_STEP_FM
#define GW_TAYLOR_STEP_FM 0
#endif
#if GW_TAYLOR_STEP_FM
#include "gw_fm_logexp.h"
#define GW_TL_LN gw_fm_log
#define GW_TL_EXP gw_fm_exp
#else
#define GW_TL_LN log
#define GW_TL_EXP exp
#endif

/* p0 = ceil(-ln(eps) / 2 + 1) in [3, MAX], the order of Jorba & Zou's rule for eps */
static int gw_taylor_base_order(double rel_tol) {
    const double eps = rel_tol > DBL_EPSILON ? rel_tol : DBL_EPSILON;
    int p = (int)ceil(-0.5 * log(eps) + 1.0);
    if (p < 3) p = 3;
    if (p > GW_TAYLOR_MAX_ORDER) p = GW_TAYLOR_MAX_ORDER;
    return p;
}

GW_INTERNAL int gw_taylor_order(double rel_tol) {
    const int p = gw_taylor_base_order(rel_tol) + GW_TAYLOR_EXTRA_ORDER;
    return p < GW_TAYLOR_MAX_ORDER ? p : GW_TAYLOR_MAX_ORDER;
}

GW_INTERNAL double gw_taylor_step(const gw_instance *I, const gw_taylor_run *run, const double *X,
                                  size_t si, size_t so, int order, int *bad_order) {
    const int nx = I->m->nx;
    const double floor_scale = I->atol_eff / I->rel_tol;
    const double *nominal = I->nominal;
    double n1 = 0.0, n2 = 0.0, z1 = 0.0, z2 = 0.0;
    int i;
    for (i = 0; i < nx; i++) { /* N_j = max_i |x_i^[j]| / sc_i, j = p-1 and p, in one pass */
        const double *xi = X + (size_t)i * si;
        const double rsc = 1.0 / (fabs(xi[0]) + floor_scale * nominal[i]);
        const double r1 = fabs(xi[(size_t)(order - 1) * so]) * rsc;
        const double r2 = fabs(xi[(size_t)order * so]) * rsc;
        /* the maxima without a branch on the data (maxsd; which ratio is largest is not
         * predictable); z_j turns NaN with any non-finite ratio, a NaN the maximum skips */
        n1 = r1 > n1 ? r1 : n1;
        n2 = r2 > n2 ? r2 : n2;
        z1 += r1 - r1;
        z2 += r2 - r2;
    }
    if (z1 != z1 && !(n1 > DBL_MAX)) n1 = z1; /* gw_taylor_bad_order names the order */
    if (z2 != z2 && !(n2 > DBL_MAX)) n2 = z2;
    return gw_taylor_step_size(run, order, n1, n2, bad_order);
}

/* the order whose norm is not finite (NaN or inf), else 0 */
static int gw_taylor_bad_order(int order, double n1, double n2) {
    return !(n1 <= DBL_MAX) ? order - 1 : !(n2 <= DBL_MAX) ? order : 0;
}

GW_INTERNAL double gw_taylor_step_size(const gw_taylor_run *run, int order, double n1, double n2,
                                       int *bad_order) {
    *bad_order = gw_taylor_bad_order(order, n1, n2);
    if (*bad_order) return 0.0;
    /* log2 rho = min_j log2(N_j^(-1/j)), h = 2^(log2 rho + log2 c): gw_fm_step's short log2 and
     * exp2 (gw_solver_taylor_step.h, 6e-6 of the exact rule), the same body as the ensemble's norms pass
     * over its lanes (gw_ens_norms, gw_fm_step4) */
    return gw_fm_step(n1, n2, 1.0 / (order - 1), 1.0 / order, run->log2_c);
}

/* The increments (gw_solver_taylor_increment.h), one copy per copy of the kernel
 * (gw_taylor.c): fused multiply-adds on x86-64-v3 (the Horner chains' latency bounds them), the
 * portable code elsewhere; gw_taylor_increment_strided asks the CPU as the kernel's entry points
 * do.  Full blocks of 8 components go through GCC's and clang's vector extension (one SSE2
 * register: a pair of components); other C99 compilers run the scalar loop (same operations). */
#if defined(__GNUC__) || defined(__clang__)
#define GW_TL_INCREMENT8 1
typedef double gw_tl_v2 __attribute__((vector_size(16))); /* one SSE2 register */
typedef double gw_tl_v2u __attribute__((vector_size(16), aligned(sizeof(double)), may_alias));
#define GW_TL_LD2(p) (*(const gw_tl_v2u *)(const void *)(p))
#else
#define GW_TL_INCREMENT8 0
#endif
#define GW_TLI(name) gw_taylor_##name##_base
#define GW_TLI_ATTR GW_TAYLOR_BASE_ATTR
#include "gw_solver_taylor_increment.h"
#undef GW_TLI
#undef GW_TLI_ATTR
#if GW_TAYLOR_FAST
#define GW_TLI(name) gw_taylor_##name##_fast
#define GW_TLI_ATTR GW_TAYLOR_FAST_ATTR
#include "gw_solver_taylor_increment.h"
#undef GW_TLI
#undef GW_TLI_ATTR
#endif
#undef GW_TL_LD2

static void gw_taylor_increment_strided(const double *X, size_t si, size_t so, int order, int nx,
                                        double h, double *dx, double *dp) {
    GW_TAYLOR_PICK(gw_taylor_increment_strided_fast,
                   gw_taylor_increment_strided_base)(X, si, so, order, nx, h, dx, dp);
}

/* lane `lane` of lanes-interleaved series in jet's layout (the ensemble's one-lane check build) */
GW_INTERNAL GW_MAYBE_UNUSED void gw_taylor_increment(const double *X, int order, int lanes,
                                                     int lane, int nx, double h, double *dx,
                                                     double *dp) {
    gw_taylor_increment_strided(X + lane, (size_t)(order + 1) * (size_t)lanes, (size_t)lanes,
                                order, nx, h, dx, dp);
}

GW_INTERNAL void gw_taylor_dense_eval(const gw_instance *I, double t, double *x_out) {
    const int nx = I->m->nx, p = I->tl_order;
    const size_t so = (size_t)I->tl_so;
    const double s = t - I->dense_t0;
    int i, k;
    for (i = 0; i < nx; i++) {
        const double *xi = I->tl_w + (size_t)i * (size_t)I->tl_si;
        double v = xi[(size_t)p * so];
        for (k = p - 1; k >= 0; k--) v = v * s + xi[(size_t)k * so];
        x_out[i] = v;
    }
}

GW_INTERNAL int gw_taylor_begin(gw_instance *I, gw_taylor_run *run) {
    const gw_taylor_kernel *tk = &I->m->taylor;
    int p;
    double q;
    if (!tk->jet || !I->tl_w) {
        GW_LOG_ERR(I, "solver taylor is not available in this model: %s",
                   tk->why_absent ? tk->why_absent : "it was built without a Taylor kernel");
        return -1;
    }
    memset(run, 0, sizeof *run);
    p = I->tl_order = gw_taylor_order(I->rel_tol);
    I->tl_si = p + 1; /* the layout of jet (the ensemble's); gw_integrate_taylor sets its own */
    I->tl_so = 1;
    /* (h / rho)^(p+1), the size of the first neglected term, as with Jorba & Zou's rule at the
     * order q, h0 = rho / e^2 exp(-0.7 / (q - 1)): ln(h / rho) = ln(h0 / rho) (q + 1) / (p + 1).
     * q = -ln(eps) / 2 + 3/2 follows rel_tol continuously, where the integer p0 = ceil(q - 1/2)
     * jumps (with p0 the neglected term would fall e^2 at once at each p0 and stay put in
     * between: rel_tol 3e-4 and 1e-4 would take the same steps); ln of the term is that of p0's rule averaged
     * over rel_tol's range of p0 (q - 1/2 runs through (p0 - 1, p0]), equal to it mid-range */
    q = -0.5 * log(I->rel_tol > DBL_EPSILON ? I->rel_tol : DBL_EPSILON) + 1.5;
    if (q < 3.0) q = 3.0; /* rel_tol > e^-3: order 3's rule (p0 = 3 up to e^-4) */
    run->log2_c = -(2.0 + 0.7 / (q - 1.0)) * (q + 1.0) / (p + 1) / log(2.0);
    return 0;
}

/* The defect of the step's polynomial P at its end (Corless & Corliss 1992; Jorba & Zou 2005,
 * sect. 3.3 note that the estimate from the last two coefficients can fail): d = f(t1, P(h)) -
 * P'(h).  With the remainder R ~ c_{p+1} s^{p+1} of the series, h d ~ (p+1) R(h), plus J R(h) h
 * where the step excites a stiff mode; so the step is accepted when
 *     err = max_i h |d_i| / ((p + 1) w_i) <= 1,  w_i = rel_tol |xnew_i| + atol nominal_i,
 * the error weight of every solver.  f1[i * stride] = f_i(t1, P(h)): the next step's series
 * (order 1) when the caller computed it, else (f1 NULL) one right-hand side evaluation into
 * I->k[1].  Returns err, or 0 when err <= 1 (an accepted step: its value is not used), or -1
 * if the right-hand side failed (logged). */
static double gw_taylor_defect(gw_instance *I, double t1, double h, const double *f1,
                               size_t stride) {
    const int nx = I->m->nx;
    const double scale = h / (I->tl_order + 1), rtol = I->rel_tol, atol = I->atol_eff;
    const double *dp = I->k[2], *xnew = I->xnew, *nominal = I->nominal; /* P'(h): attempt's */
    double err = 0.0;
    int i;
    if (!f1) {
        if (gw_rhs_checked(I, t1, I->xnew, I->k[1])) return -1.0;
        f1 = I->k[1];
        stride = 1;
    }
    for (i = 0; i < nx; i++) { /* the usual case first, without divisions: every r <= 1 */
        const double num = fabs(f1[(size_t)i * stride] - dp[i]) * scale,
                     den = rtol * fabs(xnew[i]) + atol * nominal[i];
        if (!(num <= den && den > 0.0 && den < HUGE_VAL)) break; /* inf <= inf: NaN below */
    }
    if (i == nx) return 0.0; /* num <= den, so r = num / den <= 1 exactly (monotone rounding) */
    for (i = 0; i < nx; i++) {
        const double r = fabs(f1[(size_t)i * stride] - dp[i]) * scale /
                         (rtol * fabs(xnew[i]) + atol * nominal[i]);
        if (!(r <= err)) {
            err = r;
            if (r != r) break; /* NaN: a rejection (a later finite r would have replaced it) */
        }
    }
    return isfinite(err) ? err : HUGE_VAL;
}

/* The solution's time scale from its series where some orders are not finite: the least
 * N_k^(-1/k) over the orders k = 1..order whose N_k (gw_taylor_step's norm) is finite and
 * positive; HUGE_VAL if none.  Only for the error message: a strongly damped mode of rate
 * lambda has N_k ~ lambda^k and gives about 1 / lambda. */
static double gw_taylor_time_scale(const gw_instance *I, int order) {
    const double floor_scale = I->atol_eff / I->rel_tol;
    double scale = HUGE_VAL;
    int i, k;
    for (k = 1; k <= order; k++) {
        double n = 0.0;
        for (i = 0; i < I->m->nx; i++) {
            const double *xi = I->tl_w + (size_t)i * (size_t)I->tl_si;
            const double r = fabs(xi[(size_t)k * (size_t)I->tl_so]) /
                             (fabs(xi[0]) + floor_scale * I->nominal[i]);
            n = r > n ? r : n;
        }
        if (n > 0.0 && n <= DBL_MAX) {
            const double rho = pow(n, -1.0 / k);
            scale = rho < scale ? rho : scale;
        }
    }
    return scale;
}

GW_INTERNAL gw_int_result gw_taylor_attempt_size(gw_instance *I, double t_end,
                                                 gw_taylor_run *run, const double *norms,
                                                 double *h, double *t1, int *last) {
    const int nx = I->m->nx, p = I->tl_order;
    double hs;
    int bad, i;
    for (i = norms && norms[3] != 0.0 ? nx : 0; i < nx; i++) { /* unless checked by the caller */
        const double f = I->tl_w[(size_t)i * (size_t)I->tl_si + (size_t)I->tl_so];
        if (!isfinite(f)) {
            GW_LOG_ERR(I, "derivative of state %s is not finite (%g) at t=%.17g", gw_x_name(I, i),
                       f, I->t);
            return GW_INT_ERROR;
        }
    }
    if (norms) { /* the ensemble's passes: N_{p-1}, N_p, the step size from them, and whether
                  * every derivative (order 1) is finite */
        bad = gw_taylor_bad_order(p, norms[0], norms[1]);
        hs = norms[2];
    } else {
        hs = gw_taylor_step(I, run, I->tl_w, (size_t)I->tl_si, (size_t)I->tl_so, p, &bad);
    }
    if (bad) {
        double scale;
        if (I->tl_fetch) I->tl_fetch(I, I->tl_fetch_env); /* an ensemble lane: its series */
        scale = gw_taylor_time_scale(I, p);
        if (scale < gw_h_min(I->t))
            GW_LOG_ERR(I, "Taylor coefficients of order %d are not finite at t=%.17g: the solution's "
                       "time scale, %.2g s from the finite orders, is below the smallest step, 16 eps "
                       "max(|t|, 1) s (too stiff for an explicit method)", bad, I->t, scale);
        else
            GW_LOG_ERR(I, "Taylor coefficients of order %d are not finite at t=%.17g (the solution's "
                       "series diverges: a singularity of the right-hand side?)", bad, I->t);
        return GW_INT_ERROR;
    }
    I->h_adapt = hs < I->max_step ? hs : I->max_step;
    if (gw_next_attempt(I, t_end, 0, &run->h_prev, &run->n_fast, h, t1, last)) return GW_INT_ERROR;
    return GW_INT_OK;
}

GW_INTERNAL gw_int_result gw_taylor_attempt(gw_instance *I, double t_end, gw_taylor_run *run,
                                            double *h, double *t1, int *last) {
    gw_int_result r = gw_taylor_attempt_size(I, t_end, run, NULL, h, t1, last);
    if (r != GW_INT_OK) return r;
    gw_taylor_increment_strided(I->tl_w, (size_t)I->tl_si, (size_t)I->tl_so, I->tl_order, I->m->nx,
                                *h, I->dx, I->k[2]);
    gw_sum_update(I); /* xnew, xcnew; an event restarts the compensation (gw_accept_step) */
    return GW_INT_OK;
}

GW_INTERNAL gw_int_result gw_taylor_conclude(gw_instance *I, double t_end, gw_taylor_run *run,
                                             double h, double t1, const double *f1,
                                             size_t stride, int *fresh) {
    return gw_taylor_conclude_err(I, t_end, run, h, t1, gw_taylor_defect(I, t1, h, f1, stride),
                                  f1 != NULL, fresh);
}

GW_INTERNAL gw_int_result gw_taylor_conclude_err(gw_instance *I, double t_end, gw_taylor_run *run,
                                                 double h, double t1, double err, int from_series,
                                                 int *fresh) {
    const int nx = I->m->nx, p = I->tl_order;
    gw_int_result r;
    int last;
    *fresh = 0;
    while (err > 1.0) {
        I->enew_ready = I->edot_new_ready = 0; /* xnew moves: gw_evt at the retry's end */
        I->tl_fnew = NULL; /* and the series there is not its */
        /* the coefficients' step was too long (a near pole the last two orders do not show, a
         * stiff mode): shorter steps on the same series, as a rejected step of any solver */
        I->n_rejected++;
        run->rejected++;
        if (gw_log_enabled(I, GW_LOG_SOLVER))
            gw_log(I, GW_OK, GW_LOG_SOLVER, "taylor step rejected at t=%.17g: h=%.17g defect %g",
                   I->t, h, err);
        h *= err < 1e30 ? fmax(0.2, 0.9 * GW_TL_EXP(-GW_TL_LN(err) / p)) : 0.2;
        I->h_adapt = h;
        if (h < gw_h_min(I->t)) {
            GW_LOG_ERR(I, "step size underflow at t=%.17g (h=%g, solver taylor: defect %g of "
                       "the Taylor polynomial)", I->t, h, err);
            return GW_INT_ERROR;
        }
        if (gw_next_attempt(I, t_end, 0, &run->h_prev, &run->n_fast, &h, &t1, &last))
            return GW_INT_ERROR;
        gw_taylor_increment_strided(I->tl_w, (size_t)I->tl_si, (size_t)I->tl_so, p, nx, h, I->dx,
                                    I->k[2]);
        gw_sum_update(I);
        from_series = 0; /* retries: one right-hand side evaluation each */
        err = gw_taylor_defect(I, t1, h, NULL, 1);
    }
    if (!(err >= 0.0)) return GW_INT_ERROR; /* the right-hand side failed (logged) */
    run->steps++;
    r = gw_accept_step(I, t1, &run->events);
    *fresh = r == GW_INT_OK && from_series && I->t == t1;
    return r;
}

static void gw_swap_series(double **a, double **b) {
    double *tmp = *a;
    *a = *b;
    *b = tmp;
}

/* 1: every step checks with a right-hand side evaluation instead of the next step's series (for
 * tests/test_taylor_near_pole.py::test_deferred_defect_check_rejects_where_the_rhs_check_does) */
#ifndef GW_TAYLOR_DEFECT_RHS
#define GW_TAYLOR_DEFECT_RHS 0
#endif

/* Each step: the series at its start (in I->tl_w), the attempt, then the series at the
 * attempt's end point (I->tl_wn), whose order 1 is f(t1, P(h)) for the defect check; accepted
 * as it was, that series is the next step's.  The last step of the call checks with one
 * right-hand side evaluation instead (the next call may change inputs or the state). */
GW_INTERNAL gw_int_result gw_integrate_taylor(gw_instance *I, double t_end) {
    gw_taylor_run run;
    gw_int_result result = GW_INT_OK;
    const double t_begin = I->t;
    int have = 0; /* I->tl_w holds the series at (I->t, I->x) */
    if (gw_taylor_begin(I, &run)) return GW_INT_ERROR;
    I->tl_si = 1; /* the series as the kernel leaves them, coefficient k of state i at
                   * [k GW_TL_NODES + i]: no copy to jet's layout (8% of a jet at order 10) */
    I->tl_so = GW_TL_NODES;
    gw_tl1_cst(I->u, I->p, I->tl_c);
    while (I->t < t_end) {
        double h, t1;
        int last, fresh;
        if (!have) {
            double tt = I->t;
            gw_tl1_series(I->tl_order, &tt, I->x, I->tl_c, I->tl_w);
            I->n_rhs++;
        }
        result = gw_taylor_attempt(I, t_end, &run, &h, &t1, &last);
        if (result != GW_INT_OK) break;
        if (GW_TAYLOR_DEFECT_RHS) last = 1;
        if (!last) {
            double tt = t1;
            gw_tl1_series(I->tl_order, &tt, I->xnew, I->tl_c, I->tl_wn);
            I->n_rhs++;
#if defined(GW_TL_HAS_EVT) && GW_TL_HAS_EVT && GW_TAYLOR_KERNEL_EVT
            if (I->m->ne > 0 && gw_eval_pre(I) == 0) { /* the indicators there: its order 0 */
#if defined(GW_TL_HAS_EVT_SLOPE) && GW_TL_HAS_EVT_SLOPE /* and their slopes: order 1 */
                gw_tl1_evt_slope(I->tl_wn, I->tl_wn + I->tl_so, t1, I->u, I->p, I->pre_c,
                                 I->enew, I->edot_new);
                I->edot_new_ready = 1;
#else
                gw_tl1_evt(I->tl_wn, t1, I->u, I->p, I->pre_c, I->enew);
#endif
                I->enew_ready = 1;
            }
#endif
        }
        I->tl_fnew = last ? NULL : I->tl_wn + I->tl_so; /* tl_si 1: contiguous */
        result = gw_taylor_conclude(I, t_end, &run, h, t1, I->tl_fnew, (size_t)I->tl_si, &fresh);
        I->enew_ready = I->edot_new_ready = 0;
        I->tl_fnew = NULL;
        if (result != GW_INT_OK) break;
        have = fresh;
        if (have) gw_swap_series(&I->tl_w, &I->tl_wn);
    }
    if (result == GW_INT_OK) I->t = t_end;
    if (gw_log_enabled(I, GW_LOG_SOLVER))
        gw_log(I, GW_OK, GW_LOG_SOLVER, "taylor t=%.17g -> t=%.17g order=%d steps=%lu rejected=%lu",
               t_begin, I->t, I->tl_order, run.steps, run.rejected);
    return result;
}

GW_INTERNAL int gw_taylor_alloc(gw_instance *I) {
    const gw_taylor_kernel *tk = &I->m->taylor;
    if (!tk->jet) return 0;
    I->tl_w = (double *)gw_alloc(I, (size_t)tk->n_var * (GW_TAYLOR_MAX_ORDER + 1), sizeof(double));
    I->tl_wn = (double *)gw_alloc(I, (size_t)tk->n_var * (GW_TAYLOR_MAX_ORDER + 1), sizeof(double));
    I->tl_c = (double *)gw_alloc(I, (size_t)(tk->n_cst > 0 ? tk->n_cst : 1), sizeof(double));
    return (I->tl_w && I->tl_wn && I->tl_c) ? 0 : -1;
}

GW_INTERNAL void gw_taylor_free(gw_instance *I) {
    gw_free(I, I->tl_w);
    gw_free(I, I->tl_wn);
    gw_free(I, I->tl_c);
    I->tl_w = I->tl_wn = I->tl_c = NULL;
}

#endif /* GW_TAYLOR_KERNEL */
#endif /* GW_UNITY_BUILD */
