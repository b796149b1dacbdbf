/*
 * gw_simulation.c -- the simulation's phases: experiment set-up, initialisation (every
 * check of parameters, settings and the model's validity conditions, then the consistent
 * initial point), advancing in time with recovery on failure, and the outputs and state
 * derivatives at the current point.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "gw_instance.h"

#define GW_SIM_FAIL(...)                                                                      \
    do {                                                                                      \
        GW_LOG_ERR(I, __VA_ARGS__);                                                           \
        return GW_ERROR;                                                                      \
    } while (0)

GW_INTERNAL gw_status gw_experiment_check(gw_instance *I, const char *fn, int tolerance_defined,
                                          double tolerance, double start_time,
                                          int stop_time_defined, double stop_time) {
    if (!isfinite(start_time)) GW_SIM_FAIL("%s: startTime is not finite", fn);
    if (tolerance_defined &&
        !(tolerance >= GW_REL_TOL_MIN && tolerance <= GW_REL_TOL_MAX))
        GW_SIM_FAIL("%s: tolerance %g is outside the valid range of a relative tolerance "
                    "[%.17g, %g]", fn, tolerance, GW_REL_TOL_MIN, GW_REL_TOL_MAX);
    if (stop_time_defined) {
        if (!isfinite(stop_time) || stop_time < start_time)
            GW_SIM_FAIL("%s: stopTime %g must be finite and >= startTime %g", fn, stop_time,
                        start_time);
    }
    return GW_OK;
}

GW_API gw_status gw_setup_experiment(gw_instance *I, const char *fn, int tolerance_defined,
                                     double tolerance, double start_time, int stop_time_defined,
                                     double stop_time) {
    if (gw_experiment_check(I, fn, tolerance_defined, tolerance, start_time, stop_time_defined,
                            stop_time) != GW_OK)
        return GW_ERROR;
    /* the tolerance is resolved against rel_tol at initialisation (gw_resolve_tolerances),
     * so the order of this call and of setting rel_tol does not matter */
    I->tol_defined = tolerance_defined ? 1 : 0;
    I->tolerance = tolerance_defined ? tolerance : 0.0;
    I->t_start = start_time;
    I->t = start_time;
    I->stop_defined = stop_time_defined ? 1 : 0;
    I->t_stop = stop_time_defined ? stop_time : 0.0;
    return GW_OK;
}

/* The model's validity checks c(s, p) > 0 that fail, as one message ("M must be > 0; ..."),
 * or "" if all hold or they cannot be evaluated. */
static const char *gw_failed_checks(gw_instance *I, char *buf, size_t size) {
    const gw_model *m = I->m;
    size_t used = 0;
    int i;
    buf[0] = '\0';
    if (m->nc == 0 || gw_eval_chk(I, I->c) != 0) return buf;
    for (i = 0; i < m->nc && used + 3 < size; i++) {
        const char *msg = (m->check_messages && m->check_messages[i]) ? m->check_messages[i]
                                                                      : "a validity check";
        int n;
        if (I->c[i] > 0.0) continue;
        n = snprintf(buf + used, size - used, "%s%s", used ? "; " : "", msg);
        if (n < 0) break;
        used += (size_t)n < size - used ? (size_t)n : size - used - 1;
    }
    return buf;
}

/* Reason of a non-finite value in the set-up phase: the parameters or start values. */
static void gw_log_initial_nonfinite(gw_instance *I, const char *fn, const char *what,
                                     const char *name, double value) {
    char checks[512];
    gw_failed_checks(I, checks, sizeof(checks));
    GW_LOG_ERR(I, "%s: initial value of %s %s is not finite (%g) with the current parameters "
               "and start values%s%s", fn, what, name ? name : "?", value,
               checks[0] ? ": " : "", checks);
}

/* ---- outputs and derivatives at the current point ------------------------------------------ */

GW_API gw_status gw_update_outputs(gw_instance *I, const char *fn) {
    const gw_model *m = I->m;
    int i;
    if (I->in_setup) {
        if (gw_eval_init(I, I->x) != 0 || gw_eval_out(I, I->t, I->x, I->y) != 0) {
            GW_LOG_ERR(I, "%s: evaluation of the initial outputs failed", fn);
            return GW_ERROR;
        }
        for (i = 0; i < m->ny; i++)
            if (!isfinite(I->y[i])) {
                gw_log_initial_nonfinite(I, fn, "output", gw_variable_name(m, GW_VAR_OUTPUT, i),
                                         I->y[i]);
                return GW_ERROR; /* bad input, not a step to retry: never GW_DISCARD */
            }
        return GW_OK;
    }
    if (I->y_valid) return GW_OK;
    if (gw_eval_out(I, I->t, I->x, I->y) != 0) {
        GW_LOG_ERR(I, "%s: evaluation of the outputs failed at t=%.17g", fn, I->t);
        return GW_ERROR;
    }
    for (i = 0; i < m->ny; i++)
        if (!isfinite(I->y[i])) {
            const char *nm = gw_variable_name(m, GW_VAR_OUTPUT, i);
            GW_LOG_NONFINITE(I, "%s: output %s is not finite (%g) at t=%.17g", fn,
                             nm ? nm : "?", I->y[i], I->t);
            return I->nonfinite_status;
        }
    I->y_valid = 1;
    return GW_OK;
}

GW_API gw_status gw_update_derivatives(gw_instance *I, const char *fn) {
    const gw_model *m = I->m;
    int i, pre = I->in_setup;
    if (!pre && I->xdot_valid) return GW_OK;
    if (pre && gw_eval_init(I, I->x) != 0) {
        GW_LOG_ERR(I, "%s: evaluation of the initial state failed", fn);
        return GW_ERROR;
    }
    if (gw_rhs(I, I->t, I->x, I->xdot) != 0) {
        GW_LOG_ERR(I, "%s: evaluation of the right-hand side failed at t=%.17g", fn, I->t);
        return GW_ERROR;
    }
    for (i = 0; i < m->nx; i++)
        if (!isfinite(I->xdot[i])) {
            if (pre) { /* as for the initial outputs */
                gw_log_initial_nonfinite(I, fn, "the derivative of state",
                                         m->x_names ? m->x_names[i] : "?", I->xdot[i]);
                return GW_ERROR;
            }
            GW_LOG_NONFINITE(I, "%s: derivative of state %s is not finite (%g) at t=%.17g", fn,
                             m->x_names ? m->x_names[i] : "?", I->xdot[i], I->t);
            return I->nonfinite_status;
        }
    I->xdot_valid = !pre;
    return GW_OK;
}

/* ---- initialisation -------------------------------------------------------------------------- */

static int gw_check_finite_vec(gw_instance *I, const char *fn, const double *v, int n, int kind,
                               const char *what) {
    int i, ok = 1;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) {
            const char *nm = gw_variable_name(I->m, kind, i);
            GW_LOG_ERR(I, "%s: %s %s is not finite (%g)", fn, what, nm ? nm : "?", v[i]);
            ok = 0;
        }
    return ok;
}

/* The tolerance precedence of gw_core.h (gw_setup_experiment): an explicit rel_tol wins; a
 * set-up tolerance T replaces the scene's rel_tol and scales its abs_tol alike (unless set):
 * abs_tol = default_abs_tol * T / default_rel_tol.  A scene abs_tol of 0 ("follow rel_tol",
 * the scenes' default) stays 0, so the absolute tolerance in force follows T as
 * GW_ATOL_PER_RTOL * T (gw_update_atol_eff).  Either way the declared default tolerance
 * (T = default_rel_tol, DefaultExperiment's) gives exactly the scene's rel_tol, abs_tol and
 * atol_eff, so a tool that forwards it runs the scene's run. */
static void gw_resolve_tolerances(gw_instance *I) {
    const gw_model *m = I->m;
    if (!I->tol_defined || I->rel_tol_set) return;
    I->rel_tol = I->tolerance;
    if (!I->abs_tol_set && m->default_rel_tol > 0.0)
        I->abs_tol = m->default_abs_tol * (I->tolerance / m->default_rel_tol);
}

GW_INTERNAL void gw_update_atol_eff(gw_instance *I) {
    /* abs_tol = 0 follows rel_tol: no fixed absolute floor under a tolerance-only run */
    I->atol_eff = I->abs_tol > 0.0 ? I->abs_tol : GW_ATOL_PER_RTOL * I->rel_tol;
}

GW_INTERNAL gw_status gw_validity_check(gw_instance *I, const char *fn) {
    const gw_model *m = I->m;
    int i, ok = 1;
    if (m->nc == 0) return GW_OK;
    if (gw_eval_chk(I, I->c) != 0) GW_SIM_FAIL("%s: evaluation of the validity checks failed", fn);
    for (i = 0; i < m->nc; i++)
        if (!(I->c[i] > 0.0)) {
            GW_LOG_ERR(I, "%s: %s", fn,
                       (m->check_messages && m->check_messages[i]) ? m->check_messages[i]
                                                                   : "validity check failed");
            ok = 0;
        }
    return ok ? GW_OK : GW_ERROR;
}

GW_INTERNAL gw_status gw_nominals_check(gw_instance *I, const char *fn, double *nominal) {
    const gw_model *m = I->m;
    int i;
    if (gw_eval_nom(I, nominal) != 0)
        GW_SIM_FAIL("%s: evaluation of the state nominals failed", fn);
    for (i = 0; i < m->nx; i++)
        if (!(nominal[i] > 0.0) || !isfinite(nominal[i]))
            GW_SIM_FAIL("%s: nominal of state %s is %g (must be finite, > 0)", fn,
                        m->x_names ? m->x_names[i] : "?", nominal[i]);
    return GW_OK;
}

/* settings and the model's validity checks c(s, p) > 0 */
static gw_status gw_check_setup(gw_instance *I, const char *fn) {
    const gw_model *m = I->m;
    int ok;
    ok = gw_check_finite_vec(I, fn, I->p, m->np, GW_VAR_PARAM, "parameter");
    ok &= gw_check_finite_vec(I, fn, I->s, m->ns, GW_VAR_START, "start value");
    ok &= gw_check_finite_vec(I, fn, I->u, m->nu, GW_VAR_INPUT, "input");
    if (!ok) return GW_ERROR; /* each value logged by name: no summary line repeating them */
    gw_resolve_tolerances(I);
    /* the settings were checked when set; checked again for front ends that store directly
     * (and for settings a front end does not expose, e.g. the C API's max_internal_steps) */
    if (gw_settings_check(I, fn, NULL) != GW_OK) return GW_ERROR;
    gw_update_atol_eff(I);
    return gw_validity_check(I, fn);
}

/* The consistent initial point (gw_initialize after its checks); GW_ERROR on failure. */
static gw_status gw_initial_point(gw_instance *I, const char *fn) {
    const gw_model *m = I->m;
    int i;
    /* nominal values, initial state, outputs, event indicators */
    if (gw_nominals_check(I, fn, I->nominal) != GW_OK) return GW_ERROR;
    if (gw_eval_init(I, I->x) != 0) GW_SIM_FAIL("%s: evaluation of the initial state failed", fn);
    for (i = 0; i < m->nx; i++)
        if (!isfinite(I->x[i]))
            GW_SIM_FAIL("%s: initial state %s is not finite (%g)", fn,
                        m->x_names ? m->x_names[i] : "?", I->x[i]);
    /* the model's discrete state (stiction modes) is settled at the start: update events whose
     * indicator is <= 0 there fire now (gw_events_initial), before outputs and derivatives */
    I->x_jumped = 0;
    for (i = 0; i < m->ne; i++) {
        I->flags[i] = 0;
        I->t_events[i] = 0.0;
    }
    if (m->ne > 0 && gw_eval_evt(I, I->t, I->x, I->e) != 0)
        GW_SIM_FAIL("%s: evaluation of the event indicators failed", fn);
    if (m->ne > 0 && gw_events_initial(I, fn) != 0) return GW_ERROR;
    if (gw_eval_out(I, I->t, I->x, I->y) != 0)
        GW_SIM_FAIL("%s: evaluation of the initial outputs failed", fn);
    for (i = 0; i < m->ny; i++)
        if (!isfinite(I->y[i])) {
            gw_log_initial_nonfinite(I, fn, "output", gw_variable_name(m, GW_VAR_OUTPUT, i),
                                     I->y[i]);
            return GW_ERROR;
        }
    if (gw_rhs(I, I->t, I->x, I->k[0]) != 0)
        GW_SIM_FAIL("%s: evaluation of the right-hand side failed", fn);
    for (i = 0; i < m->nx; i++)
        if (!isfinite(I->k[0][i])) {
            gw_log_initial_nonfinite(I, fn, "the derivative of state",
                                     m->x_names ? m->x_names[i] : "?", I->k[0][i]);
            return GW_ERROR;
        }
    if (m->ne > 0 && gw_eval_evt(I, I->t, I->x, I->e) != 0)
        GW_SIM_FAIL("%s: evaluation of the event indicators failed", fn);
    for (i = 0; i < m->ne; i++)
        if (!isfinite(I->e[i]))
            GW_SIM_FAIL("%s: initial event indicator %s is not finite (%g)", fn,
                        m->event_names ? m->event_names[i] : "?", I->e[i]);
    /* An event whose condition holds already at the start cannot be crossed later:
     * a terminating one means an invalid initial state, a warning one is flagged now (update
     * events were settled above; one may be left at 0, a law starting to slide from rest). */
    for (i = 0; i < m->ne; i++)
        if (!(I->e[i] > 0.0) && !(m->event_actions && (m->event_actions[i] == GW_EVENT_WARN ||
                                                       m->event_actions[i] == GW_EVENT_UPDATE)))
            GW_SIM_FAIL("%s: the initial state already triggers event %s (indicator %g <= 0)",
                        fn, m->event_names ? m->event_names[i] : "?", I->e[i]);
    return GW_OK;
}

GW_API gw_status gw_initialize(gw_instance *I, const char *fn) {
    const gw_model *m = I->m;
    int i;
    gw_point_changed(I);
    /* every check first: a refusal leaves the instance in its set-up phase, untouched but for
     * the values the set-up phase recomputes anyway (x = init(s, p), y, the caches) */
    if (gw_check_setup(I, fn) != GW_OK || gw_initial_point(I, fn) != GW_OK) {
        I->in_setup = 1;
        gw_point_changed(I);
        I->fcur_valid = 0;
        return GW_ERROR;
    }
    gw_solver_select(I);
    if (gw_log_enabled(I, GW_LOG_SOLVER) && I->solver == GW_SOLVER_AUTO)
        gw_log(I, GW_OK, GW_LOG_SOLVER, "%s: solver auto: %s (%s)", fn,
               gw_solver_name(I->solver_in_use),
               !m->taylor.jet ? "no Taylor kernel"
               : m->upd.eval  ? "the model switches modes at events"
                              : "the model has the Taylor kernel");
    if (m->fixed_step_caveat && (I->solver == GW_SOLVER_EULER || I->solver == GW_SOLVER_RK4))
        gw_log(I, GW_WARNING, GW_LOG_WARNING, "%s: solver %s: %s", fn, gw_solver_name(I->solver),
               m->fixed_step_caveat);
    /* from here on y is the simulation's output */
    I->in_setup = 0;
    I->y_valid = 1;
    I->fcur_valid = 1;
    memcpy(I->xdot, I->k[0], (size_t)m->nx * sizeof(double));
    I->xdot_valid = 1;
    for (i = 0; i < m->ne; i++) {
        if (m->event_actions && m->event_actions[i] == GW_EVENT_UPDATE) continue; /* settled */
        I->flags[i] = 0;
        I->t_events[i] = 0.0;
        if (I->e[i] > 0.0) continue;
        I->flags[i] = 1; /* a warning event that holds already at the start */
        I->t_events[i] = I->t;
        if (gw_log_enabled(I, GW_LOG_EVENTS))
            gw_log(I, GW_WARNING, GW_LOG_EVENTS, "warning: event %s holds already at the start t=%.17g",
                   m->event_names ? m->event_names[i] : "?", I->t);
    }
    I->terminated = 0;
    I->h_adapt = 0.0;
    I->err_old = 0.0;
    memset(I->xc, 0, (size_t)m->nx * sizeof(double));
    memcpy(I->xc_x, I->x, (size_t)m->nx * sizeof(double));
    I->last_successful_time = I->t;
    I->n_rhs = I->n_accepted = I->n_rejected = I->n_evt = I->n_events = 0;
    return GW_OK;
}

/* ---- advancing in time ------------------------------------------------------------------------ */

/* Back to the state at the start of gw_advance. */
static void gw_restore_step_start(gw_instance *I, double t0, double h0, double err0) {
    const gw_model *m = I->m;
    memcpy(I->x, I->x_bak, (size_t)m->nx * sizeof(double));
    memcpy(I->xc, I->xc_bak, (size_t)m->nx * sizeof(double));
    memcpy(I->xc_x, I->x_bak, (size_t)m->nx * sizeof(double));
    I->err_old = err0;
    if (m->ne > 0) {
        memcpy(I->e, I->e_bak, (size_t)m->ne * sizeof(double));
        memcpy(I->flags, I->flags_bak, (size_t)m->ne * sizeof(int));
        memcpy(I->t_events, I->t_events_bak, (size_t)m->ne * sizeof(double));
    }
    I->t = t0;
    I->h_adapt = h0;
    I->fcur_valid = 0;
    gw_point_changed(I);
    gw_eval_out(I, I->t, I->x, I->y);
}

GW_API gw_status gw_advance(gw_instance *I, const char *fn, double t_end) {
    const gw_model *m = I->m;
    const double t0 = I->t, h0 = I->h_adapt, err0 = I->err_old;
    const size_t nxb = (size_t)m->nx * sizeof(double);
    gw_int_result r;
    /* the compensation belongs to the x the solver left; a front end that wrote x since
     * (Model Exchange, fmi2SetReal of a state) made it stale */
    if (memcmp(I->x, I->xc_x, nxb) != 0) memset(I->xc, 0, nxb);
    memcpy(I->x_bak, I->x, nxb);
    memcpy(I->xc_bak, I->xc, nxb);
    I->n_call_steps = 0;
    I->t_call = t0;
    I->run_n_fast = 0;
    I->stopped_at_update = 0;
    I->edot_valid = 0; /* a front end may have changed the state since */
    if (m->ne > 0) {
        memcpy(I->e_bak, I->e, (size_t)m->ne * sizeof(double));
        memcpy(I->flags_bak, I->flags, (size_t)m->ne * sizeof(int));
        memcpy(I->t_events_bak, I->t_events, (size_t)m->ne * sizeof(double));
    }
    gw_point_changed(I);
    r = gw_integrate(I, t_end);
    if (r != GW_INT_ERROR && gw_update_outputs(I, fn) != GW_OK) r = GW_INT_ERROR;
    if (r == GW_INT_ERROR) {
        gw_restore_step_start(I, t0, h0, err0);
        I->update_pending = 0;
        return GW_ERROR;
    }
    I->stopped_at_update = r == GW_INT_EVENT;
    memcpy(I->xc_x, I->x, nxb);
    if (r == GW_INT_TERMINATED) I->terminated = 1;
    I->last_successful_time = I->t;
    return r == GW_INT_TERMINATED ? GW_DISCARD : GW_OK;
}

#endif /* GW_UNITY_BUILD */
