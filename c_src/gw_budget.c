/*
 * gw_budget.c -- the budget of internal steps of the adaptive and fixed-step solvers: one call
 * (gw_advance) takes at most I->max_internal_steps of them and a run to its stop time at most
 * GW_RUN_BUDGETS times that; gw_next_attempt gives every solver loop its next attempt within
 * them.  Included by gw_core.c before gw_solver.c.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>

#include "gw_solver.h"

/* ---- the budget of internal steps --------------------------------------------------------
 * One call that advances time (gw_advance: fmi2DoStep, the core's front ends) takes at most
 * I->max_internal_steps internal steps, accepted and rejected together (a Rosenbrock
 * refactorisation after a singular W counts as a rejected step), so every call returns in a
 * time bounded by the budget times the cost of one step.  Four checks:
 *  1. up front (gw_budget_upfront): no internal step is longer than max_step, so a
 *     communication step H needs at least ceil(H / max_step) steps, exactly that many for
 *     euler and rk4; more than the budget is refused before any work.
 *  2. projection (gw_budget_projection, adaptive solvers): a window of gw_settle_attempts
 *     attempts in a row (GW_SETTLE at least, longer at tight tolerances: a stiff mode's
 *     transient holds h nearly constant for a while before h grows), h staying within a
 *     factor 2 either way of the window's first, each projecting that the rest of the step
 *     needs GW_PROJECTION_MARGIN times more steps of the controller's h than the budget has
 *     left: refused early with the estimate (a stiff transient resolved with tiny steps for a
 *     while, 39x over the budget in tests/c/test_stiff.c, is left to the budget).  Rejected
 *     steps do not reset this count.
 *  3. the budget itself (gw_next_attempt): when it is spent the call stops, with the estimate.
 *  4. the run (gw_budget_run, adaptive solvers, a stop time defined): the internal steps since
 *     initialisation (I->n_accepted + I->n_rejected) are at most GW_RUN_BUDGETS times the
 *     budget, and once they exceed one budget, a window of attempts in a row, h settled as in
 *     check 2, each projecting that the rest of the run to the stop time needs more steps of h
 *     than the run has left, refuse the call with the estimate.  Without it a run of many short
 *     communication steps costs up to the budget per step: a stiff onset that the explicit
 *     solvers resolve with ~1e-9 s steps took hours to run out (examples/scenes/euler_disk_end.toml,
 *     DOPRI5, 1 ms steps: ~4.6e5 internal steps per communication step, none refused;
 *     benchmarks/run_budget.py).
 * Refusing is GW_INT_ERROR: gw_advance restores the state at the start of the call. */
/* The budget the model declares (max_internal_steps' default): a run refused within what it
 * covers was stopped by the budget the user set lower, not by the dynamics. */
static double gw_default_budget(const gw_instance *I) {
    return I->m->default_max_internal_steps > 0.0 ? I->m->default_max_internal_steps
                                                  : GW_DEFAULT_MAX_INTERNAL_STEPS;
}

/* The message when a budget set below the default is what refuses `needed` internal steps,
 * which the default budget `covering` would allow; 1 if logged, 0 if not that case. */
static int gw_budget_set_too_low(gw_instance *I, const char *what, double needed, double covering,
                                 const char *scope, double taken, const char *since) {
    if (!(I->max_internal_steps < gw_default_budget(I)) || !(needed <= covering)) return 0;
    GW_LOG_ERR(I, "at t=%.17g (%s) the step budget max_internal_steps = %.0f is exhausted (%.0f steps "
               "taken %s): %s would need about %.3g internal steps, which the default "
               "max_internal_steps = %.0f covers; raise it", I->t, what, I->max_internal_steps, taken,
               since, scope, needed, gw_default_budget(I));
    return 1;
}

GW_INTERNAL void gw_budget_message(gw_instance *I, const char *what, double remaining, double h) {
    const char *hint = I->solver_in_use == GW_SOLVER_ROSENBROCK || I->solver_in_use == GW_SOLVER_EULER ||
                               I->solver_in_use == GW_SOLVER_RK4
                           ? ""
                           : " or stiff (try solver rosenbrock)";
    if (gw_budget_set_too_low(I, what, (double)I->n_call_steps + remaining / h, gw_default_budget(I),
                              "this communication step", (double)I->n_call_steps, "in this call"))
        return;
    GW_LOG_ERR(I, "at t=%.17g %s: the remaining %g s of this communication step (from t=%.17g) "
               "would need about %.3g internal steps of h=%g, more than the %.0f left of "
               "max_internal_steps = %.0f (%llu steps taken in this call): shorten the communication "
               "step or raise max_internal_steps; if steps of %g s are far below the time scale of "
               "the motion, the dynamics are too fast for the tolerance (huge rates?)%s",
               I->t, what, remaining, I->t_call, remaining / h, h,
               I->max_internal_steps - (double)I->n_call_steps, I->max_internal_steps,
               I->n_call_steps, h, hint);
}

/* check 1; 0 or -1 logged */
GW_INTERNAL int gw_budget_upfront(gw_instance *I, double t_end) {
    const double H = t_end - I->t, n_min = gw_fixed_substeps(I, t_end);
    if (!(n_min > I->max_internal_steps)) return 0;
    GW_LOG_ERR(I, "communication step %g s from t=%.17g would need %s%.3g internal steps of "
               "max_step=%g, more than max_internal_steps = %.0f: raise max_internal_steps or "
               "max_step, or shorten the communication step (refused before any work)", H, I->t,
               (I->solver_in_use == GW_SOLVER_EULER || I->solver_in_use == GW_SOLVER_RK4) ? "" : "at least ",
               n_min, I->max_step, I->max_internal_steps);
    return -1;
}

/* The attempts a window of settled step size lasts before a projection refuses (checks 2
 * and 4): GW_SETTLE, and at least GW_SETTLE_SPANS time scales h rel_tol^(-1/q).  With a local
 * error of order q (the controller's exponent 1/q: 5 DOPRI5, 8 DOP853, 4 Rosenbrock, the
 * Taylor order) a step h at rel_tol resolves a mode of time scale up to about
 * h rel_tol^(-1/q).  A decaying stiff mode that dominates a state holds h nearly constant
 * while the state decays relative to itself, until it nears abs_tol, and then h grows by
 * orders of magnitude (Rosenbrock, L-stable, leaves the decayed mode behind; an explicit
 * solver stops at its stability bound: settled).  Measured, Rosenbrock, a drag relaxation
 * of 1.4e-9 s (tests/test_budget_transients.py): the longest window of h within a factor 2
 * was 50, 146, 431, 1357, 4850 attempts at rel_tol 1e-6 ... 1e-14 (abs_tol rel_tol / 100),
 * growing like rel_tol^(-1/4), and 894 at rel_tol 1e-8 with abs_tol 1e-30; this gives 632,
 * 2000, 6325, 20000, 63246.  Units: attempts (a count). */
static double gw_settle_attempts(const gw_instance *I) {
    double q, n;
    switch (I->solver_in_use) {
    case GW_SOLVER_ROSENBROCK: q = 4.0; break;
    case GW_SOLVER_DOPRI5: q = 5.0; break;
#ifdef GW_TAYLOR_KERNEL
    case GW_SOLVER_TAYLOR: q = (double)gw_taylor_order(I->rel_tol); break;
#endif
    default: q = 8.0; break; /* DOP853 */
    }
    n = GW_SETTLE_SPANS * pow(I->rel_tol, -1.0 / q);
    return n > GW_SETTLE ? n : GW_SETTLE;
}

/* check 2: *h_ref is the step size at the start of the current window of attempts that all
 * project beyond the budget; a window in which h leaves [h_ref / 2, 2 h_ref] is a transient,
 * not settled, and starts again: growing past 2 h_ref, and shrinking below h_ref / 2 too (a
 * dip, e.g. the step size closing in on a zero crossing and opening again, projected from its
 * smallest steps would refuse a call that the budget covers).  0 or -1 logged. */
static int gw_budget_projection(gw_instance *I, double remaining, double h, double *h_ref,
                                unsigned long *n_fast) {
    const double left = I->max_internal_steps - (double)I->n_call_steps;
    if (!(remaining > GW_PROJECTION_MARGIN * left * h)) {
        *n_fast = 0;
        return 0;
    }
    if (*n_fast == 0 || h > 2.0 * *h_ref || h < 0.5 * *h_ref) {
        *h_ref = h;
        *n_fast = 1;
        return 0;
    }
    if ((double)++(*n_fast) <= gw_settle_attempts(I)) return 0;
    gw_budget_message(I, "the step size has settled", remaining, h);
    return -1;
}

/* check 4; 0 or -1 logged */
static int gw_budget_run(gw_instance *I, double h) {
    const double taken = (double)(I->n_accepted + I->n_rejected);
    const double left = GW_RUN_BUDGETS * I->max_internal_steps - taken;
    const double remaining = I->t_stop - I->t;
    const char *hint = I->solver_in_use == GW_SOLVER_ROSENBROCK ? "" : " or stiff (try solver rosenbrock)";
    if (!I->stop_defined || taken < I->max_internal_steps) return 0;
    if (left <= 0.0 || remaining > left * h) {
        if (left > 0.0 && (I->run_n_fast == 0 || h > 2.0 * I->run_h_ref || h < 0.5 * I->run_h_ref)) {
            I->run_h_ref = h;
            I->run_n_fast = 1;
            return 0;
        }
        if (left > 0.0 && (double)++I->run_n_fast <= gw_settle_attempts(I)) return 0;
        if (gw_budget_set_too_low(I, "the run's budget refuses the rest", taken + remaining / h, GW_RUN_BUDGETS * gw_default_budget(I),
                                  "the run to its stop time", taken, "since initialisation"))
            return -1;
        GW_LOG_ERR(I, "at t=%.17g the run's budget refuses the rest: the remaining %g s to the stop "
                   "time %.17g would need about %.3g internal steps of h=%g, more than the %.0f left "
                   "of the run's %.0f (%.0f x max_internal_steps = %.0f; %.0f steps taken since "
                   "initialisation): raise max_internal_steps or loosen the tolerance; if steps of "
                   "%g s are far below the time scale of the motion, the dynamics are too fast for "
                   "the tolerance%s", I->t, remaining, I->t_stop,
                   remaining / h, h, left > 0.0 ? left : 0.0, GW_RUN_BUDGETS * I->max_internal_steps,
                   GW_RUN_BUDGETS, I->max_internal_steps, taken, h, hint);
        return -1;
    }
    I->run_n_fast = 0;
    return 0;
}

GW_INTERNAL int gw_next_attempt(gw_instance *I, double t_end, int rejected_last, double *h_ref,
                        unsigned long *n_fast, double *h, double *t1, int *last) {
    const double remaining = t_end - I->t;
    (void)rejected_last;
    *h = I->h_adapt < I->max_step ? I->h_adapt : I->max_step;
    *last = 1.01 * *h >= remaining;
    if (*last) *h = remaining;
    *t1 = *last ? t_end : I->t + *h;
    if ((double)I->n_call_steps >= I->max_internal_steps) { /* check 3 */
        gw_budget_message(I, "the budget of internal steps is spent", remaining, *h);
        return -1;
    }
    I->n_call_steps++;
    if (gw_budget_run(I, *h)) return -1;
    if (*last) return 0;
    if (gw_budget_projection(I, remaining, *h, h_ref, n_fast)) return -1;
    if (*h < gw_h_min(I->t) || !(*t1 > I->t)) { /* steps that no longer advance time */
        GW_LOG_ERR(I, "step size underflow at t=%.17g (h=%g, solver %s)", I->t, *h,
                   gw_solver_name(I->solver_in_use));
        return -1;
    }
    return 0;
}

#endif /* GW_UNITY_BUILD */
