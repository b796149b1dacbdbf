/*
 * gw_solver.h -- the integrators of the core: one step driver (gw_solver.c) and one file per
 * solver family.  gw_integrate(I, t_end) integrates from (I->t, I->x) exactly to t_end with
 * the solver selected in I->solver, locating events (gw_events.c) on the dense output of
 * every accepted step.
 *
 * Files and solvers (gw_solver enumeration of gw_model.h):
 *   gw_solver.c         step driver: dispatch, accepted steps and events, the step size
 *                       guards, Hairer's initial step, the adaptive loop shared by DOP853 and
 *                       RODAS4, dense output dispatch, work memory
 *   gw_solver_fixed.c   GW_SOLVER_EULER / GW_SOLVER_RK4: explicit Euler and classical RK4,
 *                       fixed step: n = ceil(h / max_step) equal substeps, with instability
 *                       detection; cubic Hermite dense output (in gw_solver.c)
 *   gw_solver_dopri5.c  GW_SOLVER_DOPRI5: Dormand-Prince 5(4), error control (RMS norm of
 *                       err_i / (abs_tol*nominal_i + rel_tol*max(|x_i|,|xnew_i|))), FSAL,
 *                       its own loop; 4th-order continuous extension
 *   gw_solver_dop853.c  GW_SOLVER_DOP853: Dormand-Prince 8(5,3) (Hairer's DOP853): 12 stages +
 *                       FSAL, Hairer's combined 5th/3rd-order error estimate with the same
 *                       weights, for tight tolerances; 7th-order dense output (3 extra stages,
 *                       evaluated only when an event needs them)
 *   gw_solver_rodas4.c  GW_SOLVER_ROSENBROCK: RODAS4 (Hairer & Wanner): linearly implicit, 6
 *                       stages, order 4(3), stiffly accurate, L-stable, for stiff problems.
 *                       Jacobian: the model's `jac` function; if the model has none, forward
 *                       differences (nx RHS evaluations, increment sqrt(eps)*max(|x_j|,
 *                       nominal_j)).  d f/d t by a forward difference (one RHS evaluation per
 *                       step).  W = I/(gamma h) - J is LU-factored with partial pivoting
 *                       (dense, in the instance's work arrays); J is evaluated once per
 *                       accepted step, a rejected step only refactors.  Error = weighted RMS
 *                       norm of the embedded difference, same weights.  3rd-order dense output.
 *   gw_solver_taylor.c  GW_SOLVER_TAYLOR: Taylor series of adaptive order (Jorba & Zou) with
 *                       the model's generated kernel; its polynomial is the dense output
 * All adaptive solvers land exactly on t_end, respect max_step, carry the step size between
 * communication steps in I->h_adapt (the only solver memory kept between steps, part of a
 * saved state) and fail with "step size underflow" below gw_h_min.  Dense output: all in the
 * nested form of gw_dense_eval.  No memory is allocated while integrating.
 */
#ifndef GW_SOLVER_H
#define GW_SOLVER_H

#include "gw_instance.h"

#define GW_DOPRI5_FAC_MIN 0.2  /* largest decrease of h per step */
#define GW_DOPRI5_FAC_MAX 10.0 /* largest increase of h per step */
#define GW_MAX_EVENTS_PER_STEP 1000

/* The budget of internal steps of one call (I->max_internal_steps; gw_budget.c): refused up
 * front when ceil(H / max_step) exceeds it, refused when a window of settled attempts in a row
 * (GW_SETTLE at least) project beyond it, stopped when it is spent. */
#define GW_SETTLE 100
/* ... and at least this many time scales h rel_tol^(-1/q) of the solver's order q
 * (gw_settle_attempts, gw_budget.c): a stiff mode's transient is not a settled step size */
#define GW_SETTLE_SPANS 20.0
/* The least first step of an adaptive solver, in step-size floors gw_h_min (gw_initial_step) */
#define GW_H0_FLOORS 1000.0
#define GW_PROJECTION_MARGIN 100.0
/* The budget of a whole run to a defined stop time (gw_budget_run): GW_RUN_BUDGETS times
 * max_internal_steps internal steps of the adaptive solvers in all. */
#define GW_RUN_BUDGETS 100.0
/* step size stabilisation of DOP853 and DOPRI5 (Hairer's BETA; benchmarks/work_precision.py
 * measures the rejected-step fraction) */
#define GW_DOP853_BETA 0.04
#define GW_DOPRI5_BETA 0.0

/* ---- gw_budget.c: the budget of internal steps ----------------------------------------------- */
/* log that the budget of internal steps refuses the rest of the call (what: why now) */
GW_INTERNAL void gw_budget_message(gw_instance *I, const char *what, double remaining, double h);
/* refuse before any work a call to t_end that needs more steps of max_step than the budget;
 * 0 or -1 logged */
GW_INTERNAL int gw_budget_upfront(gw_instance *I, double t_end);
/* The next attempt of an adaptive loop: the controller's h, bounded by max_step and shortened
 * to land exactly on t_end (*last), refused by the budget or when it no longer advances time.
 * *h_ref and *n_fast hold the window of the budget projection (zero at the call's start).
 * Returns 0, or -1 with the reason logged. */
GW_INTERNAL int gw_next_attempt(gw_instance *I, double t_end, int rejected_last, double *h_ref,
                                unsigned long *n_fast, double *h, double *t1, int *last);

/* ---- gw_solver.c: the step driver's helpers, shared by the families ----------------------- */
/* smallest step size allowed at time t before "step size underflow" */
GW_INTERNAL double gw_h_min(double t);
GW_INTERNAL const char *gw_x_name(const gw_instance *I, int i);
GW_INTERNAL int gw_first_nonfinite(const double *v, int n); /* index, or -1 */
/* Make k[0] = f(t, x) (reused across steps: FSAL / end-point derivative); 0 or -1 logged. */
GW_INTERNAL int gw_ensure_f0(gw_instance *I);
/* gw_rhs with a logged error; 0 or -1 */
GW_INTERNAL int gw_rhs_checked(gw_instance *I, double t, const double *x, double *xdot);
/* Accepted step (I->t, I->x) -> (t1, I->xnew): finiteness, events, commit.
 * *events counts events in this communication step (loop guard). */
GW_INTERNAL gw_int_result gw_accept_step(gw_instance *I, double t1, int *events);
/* weighted RMS norm of v with the error weights at x */
GW_INTERNAL double gw_rms_weighted(const gw_instance *I, const double *v, const double *x);
/* Step size factor h_new / h of Hairer's controller with stabilisation beta and weight w (PI);
 * updates I->err_old on accepted steps. */
GW_INTERNAL double gw_step_factor(gw_instance *I, double err, double q, double beta, double w,
                                  double fac_min, double fac_max, int accepted, int rejected_last);
/* I->xnew, I->xcnew = I->x + I->dx with compensated summation (TwoSum) */
GW_INTERNAL void gw_sum_update(gw_instance *I);
/* Hairer's initial step size estimate (one extra RHS evaluation). */
GW_INTERNAL double gw_initial_step(gw_instance *I, double hmax, double order);

/* ---- gw_solver_fixed.c ------------------------------------------------------------------------ */
/* ceil((t_end - I->t) / max_step) less the rounding of t (>= 1): the fixed-step solvers' exact
 * substep count, a lower bound for the adaptive ones */
GW_INTERNAL double gw_fixed_substeps(const gw_instance *I, double t_end);
GW_INTERNAL gw_int_result gw_integrate_fixed(gw_instance *I, double t_end);

/* ---- gw_solver_dopri5.c ----------------------------------------------------------------------- */
GW_INTERNAL gw_int_result gw_integrate_dopri5(gw_instance *I, double t_end);
/* rcont[4] of the last accepted step (the rest is the cubic Hermite base) */
GW_INTERNAL void gw_dopri5_dense(gw_instance *I);

/* ---- gw_solver_dop853.c ----------------------------------------------------------------------- */
/* One step of size h to t1 into I->xnew; *err = error norm.  f(t1, xnew) not evaluated. */
GW_INTERNAL int gw_dop853_step(gw_instance *I, double h, double t1, double *err);
/* rcont[4] and rcx of the last accepted step (3 more stages) */
GW_INTERNAL void gw_dop853_dense(gw_instance *I);
/* x_out at th in [0, 1) of the step, th1 = 1 - th */
GW_INTERNAL void gw_dop853_dense_eval(const gw_instance *I, double th, double th1, double *x_out);

/* ---- gw_solver_rodas4.c ----------------------------------------------------------------------- */
/* I->jac and d f / d t (I->kx[2]) at (I->t, I->x); needs k[0] = f(t, x).  0 or -1 logged. */
GW_INTERNAL int gw_rodas4_linearise(gw_instance *I);
/* LU factors of W = I/(gamma h) - J; 0, or 1 if W is singular to working precision */
GW_INTERNAL int gw_rodas4_factor(gw_instance *I, double h);
GW_INTERNAL int gw_rodas4_step(gw_instance *I, double h, double t1, double *err);
/* rcont of the last accepted step (order 3) */
GW_INTERNAL void gw_rodas4_dense(gw_instance *I);

/* ---- gw_solver_taylor.c ----------------------------------------------------------------------- */
#define GW_TAYLOR_MAX_ORDER 30 /* the work memory holds series of this order */
/* orders above the tolerance's p0 = ceil(-ln(rel_tol) / 2 + 1) (gw_solver_taylor.c: fewer,
 * longer steps for the same error, measured in benchmarks/taylor_order_ab.py) */
#ifndef GW_TAYLOR_EXTRA_ORDER
#define GW_TAYLOR_EXTRA_ORDER 4
#endif
/* the step's parts, defined only in a unit with the model's Taylor kernel (GW_TAYLOR_KERNEL,
 * gw_taylor.c; without it gw_solver_taylor.c has only the four functions at the end) */
#ifdef GW_TAYLOR_KERNEL
/* order of the series for a relative tolerance: p0 in [3, MAX] plus GW_TAYLOR_EXTRA_ORDER */
GW_INTERNAL int gw_taylor_order(double rel_tol);
/* 1: an accepted step's event indicators at its end (t1, xnew) are read from the kernel's
 * series there (GW_TL(evt) of gw_taylor_model.h, taylor/events.py) where the model
 * has it, instead of evaluating gw_evt; 0: gw_evt always (tests compare the two) */
#ifndef GW_TAYLOR_KERNEL_EVT
#define GW_TAYLOR_KERNEL_EVT 1
#endif
/* The bookkeeping of one integration call (feasibility guard, event count, steps) and the
 * step size rule's constant for the call's tolerance and order. */
typedef struct {
    int events;
    unsigned long n_fast, steps, rejected;
    double h_prev;
    double log2_c; /* log2(h / rho) of the step size rule (gw_taylor_begin) */
} gw_taylor_run;
/* Jorba-Zou step size from the coefficients of orders p-1 and p of X, the states' series with
 * state i's coefficient k at X[i si + k so]; 0 and *bad_order = j if order j is not finite. */
GW_INTERNAL double gw_taylor_step(const gw_instance *I, const gw_taylor_run *run, const double *X,
                                  size_t si, size_t so, int order, int *bad_order);
/* the same from the norms N_{p-1} = n1, N_p = n2 (the ensemble's lane-innermost pass) */
GW_INTERNAL double gw_taylor_step_size(const gw_taylor_run *run, int order, double n1, double n2,
                                       int *bad_order);
/* dx = sum_{k>=1} X_k h^k of lane `lane` (the state's increment; gw_sum_update adds it) and,
 * unless dp is NULL, dp = P'(h), the polynomial's derivative (for the defect check) */
GW_INTERNAL void gw_taylor_increment(const double *X, int order, int lanes, int lane, int nx,
                                     double h, double *dx, double *dp);
/* Start an integration call: kernel present, order from rel_tol. */
GW_INTERNAL int gw_taylor_begin(gw_instance *I, gw_taylor_run *run);
/* A step in two halves, so that the defect check can take f(t1, P(h)) from the series the
 * next step needs anyway (gw_integrate_taylor, and the ensemble path's batch, gw_ensemble.c):
 * gw_taylor_attempt: from the series of (I->t, I->x) in I->tl_w, the step size, its first
 *   attempt (t1, I->xnew) and *last (it lands on t_end); GW_INT_OK or GW_INT_ERROR (logged).
 * gw_taylor_conclude: the defect check of the attempt with f1 = f(t1, I->xnew) (f1[i * stride],
 *   or NULL: one right-hand side evaluation), rejected attempts shortened and checked with the
 *   right-hand side, then the accepted step (events, gw_accept_step).  *fresh = 1 when the
 *   step was accepted at its first attempt and no event moved the state: (I->t, I->x) is then
 *   the point f1 came from (its series, if computed, serves the next step). */
GW_INTERNAL gw_int_result gw_taylor_attempt(gw_instance *I, double t_end, gw_taylor_run *run,
                                            double *h, double *t1, int *last);
GW_INTERNAL gw_int_result gw_taylor_conclude(gw_instance *I, double t_end, gw_taylor_run *run,
                                             double h, double t1, const double *f1,
                                             size_t stride, int *fresh);
/* The halves as the ensemble's batch uses them (its lane-innermost passes compute the norms of
 * the step size, the increment and the defect for all lanes at once): gw_taylor_attempt
 * without the increment (norms: N_{p-1}, N_p, the step size gw_taylor_step_size computes from
 * them and 1 if order 1 is known finite (0: checked here on I->tl_w), or NULL: all from
 * I->tl_w); gw_taylor_conclude with
 * the defect err of the first attempt given (from_series: f1 came from the series at t1). */
GW_INTERNAL gw_int_result gw_taylor_attempt_size(gw_instance *I, double t_end,
                                                 gw_taylor_run *run, const double *norms,
                                                 double *h, double *t1, int *last);
GW_INTERNAL gw_int_result gw_taylor_conclude_err(gw_instance *I, double t_end, gw_taylor_run *run,
                                                 double h, double t1, double err, int from_series,
                                                 int *fresh);
#endif /* GW_TAYLOR_KERNEL */
/* solver taylor's integration call (without a kernel: refused, logged) */
GW_INTERNAL gw_int_result gw_integrate_taylor(gw_instance *I, double t_end);
/* the Taylor polynomial of the last step at t */
GW_INTERNAL void gw_taylor_dense_eval(const gw_instance *I, double t, double *x_out);
GW_INTERNAL int gw_taylor_alloc(gw_instance *I); /* nothing if the model has no kernel */
GW_INTERNAL void gw_taylor_free(gw_instance *I);

#endif /* GW_SOLVER_H */
