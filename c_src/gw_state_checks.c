/*
 * gw_state_checks.c -- what a state must be before it is restored: every field within the
 * range fmi2Set* and the core accept (gw_state_check), and the fields against each other and
 * the model, through the live path's own checks (gw_state_check_run: the settings and the
 * experiment, the times in order, the events and their flags with the indicators recomputed
 * from the state, the parameters and start values).  So a restored state is one the instance could have reached itself.  The layout
 * and its reader are gw_state.c's; this file is included after it by gw_core.c.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "gw_instance.h"

/* "fn: FMU state", the start of the messages of the live path's checks run on a state */
static const char *gw_state_where(char *buf, size_t size, const char *fn) {
    snprintf(buf, size, "%s: FMU state", fn);
    return buf;
}

/* The settings through gw_settings_check (gw_value_check's ranges) and the experiment through
 * gw_experiment_check (fmi2SetupExperiment's), the functions the live path calls; an
 * experiment value that was not defined is stored as 0 (gw_setup_experiment).  1 or reason
 * logged. */
static int gw_state_check_settings(gw_instance *I, const char *fn, const gw_state_scalars *sc) {
    double value[GW_N_SETTINGS];
    char where[160];
    value[GW_SET_SOLVER] = (double)sc->ints[GW_SI_SOLVER];
    value[GW_SET_REL_TOL] = sc->dbl[GW_SD_REL_TOL];
    value[GW_SET_ABS_TOL] = sc->dbl[GW_SD_ABS_TOL];
    value[GW_SET_MAX_STEP] = sc->dbl[GW_SD_MAX_STEP];
    value[GW_SET_MAX_INTERNAL_STEPS] = sc->dbl[GW_SD_MAX_INTERNAL_STEPS];
    if (gw_settings_check(I, fn, value) != GW_OK) return 0;
    if (gw_experiment_check(I, gw_state_where(where, sizeof(where), fn), sc->ints[GW_SI_TOL_DEF],
                            sc->dbl[GW_SD_TOLERANCE], sc->dbl[GW_SD_T_START],
                            sc->ints[GW_SI_STOP_DEF], sc->dbl[GW_SD_T_STOP]) != GW_OK)
        return 0;
    if (!sc->ints[GW_SI_TOL_DEF] && sc->dbl[GW_SD_TOLERANCE] != 0.0) {
        GW_LOG_ERR(I, "%s: FMU state holds tolerance = %g with tol_defined = 0 (an undefined "
                   "tolerance is stored as 0)", fn, sc->dbl[GW_SD_TOLERANCE]);
        return 0;
    }
    if (!sc->ints[GW_SI_STOP_DEF] && sc->dbl[GW_SD_T_STOP] != 0.0) {
        GW_LOG_ERR(I, "%s: FMU state holds t_stop = %g with stop_defined = 0 (an undefined "
                   "stop time is stored as 0)", fn, sc->dbl[GW_SD_T_STOP]);
        return 0;
    }
    return 1;
}

/* every field within the range fmi2Set* and the core accept; 1 or reason logged */
static int gw_state_check_fields(gw_instance *I, const char *fn, const unsigned char *buf) {
    static const int flags01[] = {GW_SI_STOP_DEF, GW_SI_TOL_DEF, GW_SI_TERMINATED, GW_SI_Y_VALID,
                                  GW_SI_REL_SET, GW_SI_ABS_SET};
    static const char *const flag_names[] = {"stop_defined", "tol_defined", "terminated",
                                             "y_valid", "rel_tol_set", "abs_tol_set"};
    static const char *const dbl_names[GW_STATE_NDBL] = {
        "t", "t_start", "t_stop", "tolerance", "last_successful_time", "rel_tol", "abs_tol",
        "max_step", "max_internal_steps", "h_adapt", "err_old"};
    const gw_model *m = I->m;
    gw_reader r = gw_state_body(I, buf);
    gw_state_scalars sc;
    double *vec[GW_STATE_NVEC];
    int len[GW_STATE_NVEC], i, k;
    size_t j, x_pos;
    gw_read_scalars(&r, &sc);
    for (j = 0; j < sizeof(flags01) / sizeof(flags01[0]); j++)
        if (sc.ints[flags01[j]] != 0 && sc.ints[flags01[j]] != 1) {
            GW_LOG_ERR(I, "%s: FMU state holds %s = %d (must be 0 or 1)", fn, flag_names[j],
                       sc.ints[flags01[j]]);
            return 0;
        }
    for (k = 0; k < GW_STATE_NDBL; k++)
        if (!isfinite(sc.dbl[k])) {
            GW_LOG_ERR(I, "%s: FMU state holds a non-finite %s (%g)", fn, dbl_names[k], sc.dbl[k]);
            return 0;
        }
    if (sc.dbl[GW_SD_H] < 0.0) {
        GW_LOG_ERR(I, "%s: FMU state holds a negative step size %g", fn, sc.dbl[GW_SD_H]);
        return 0;
    }
    if (!(sc.dbl[GW_SD_ERR_OLD] >= 0.0 && sc.dbl[GW_SD_ERR_OLD] <= 1.0)) {
        GW_LOG_ERR(I, "%s: FMU state holds err_old = %g (the error norm of an accepted step: "
                   "0 to 1)", fn, sc.dbl[GW_SD_ERR_OLD]);
        return 0;
    }
    if (!gw_state_check_settings(I, fn, &sc)) return 0;
    gw_vectors_of(I, vec, len);
    x_pos = r.pos; /* x is the first vector */
    for (k = 0; k < GW_STATE_NVEC; k++)
        for (i = 0; i < len[k]; i++) {
            double d, x = 0.0;
            const char *why = "not finite";
            gw_get(&r, &d, 8);
            if (k == GW_STATE_VEC_XC) memcpy(&x, buf + x_pos + 8 * (size_t)i, 8);
            if (isfinite(d) && k == GW_STATE_VEC_NOMINAL && !(d > 0.0))
                why = "a nominal must be finite and > 0";
            else if (isfinite(d) && k == GW_STATE_VEC_XC && !(fabs(d) <= DBL_EPSILON * fabs(x)))
                why = "a compensation is at most an ulp of its state";
            else if (isfinite(d))
                continue;
            GW_LOG_ERR(I, "%s: FMU state holds an invalid %s[%d] = %g (%s)", fn, gw_vec_names[k],
                       i, d, why);
            return 0;
        }
    for (i = 0; i < m->ne; i++) {
        unsigned char f;
        gw_get(&r, &f, 1);
        if (f > (GW_STATE_FLAG_FIRED | GW_STATE_FLAG_PENDING)) {
            GW_LOG_ERR(I, "%s: FMU state holds event flag %d = %u (must be 0 or 1; 2 or 3 with "
                       "an event update pending)", fn, i, (unsigned)f);
            return 0;
        }
    }
    return 1;
}

GW_API int gw_state_check(gw_instance *I, const char *fn, const unsigned char *buf, size_t size) {
    return gw_state_check_header(I, fn, buf, size) && gw_state_check_fields(I, fn, buf);
}

/* the double of vector k, element i, of a checked blob (copied: the blob is not aligned) */
static double gw_state_vec_at(const gw_instance *I, const unsigned char *buf, int k, int i) {
    gw_reader r = gw_state_body(I, buf);
    gw_state_scalars sc;
    double *vec[GW_STATE_NVEC], d;
    int len[GW_STATE_NVEC], j;
    gw_read_scalars(&r, &sc);
    gw_vectors_of(I, vec, len);
    for (j = 0; j < k; j++) r.pos += 8 * (size_t)len[j];
    memcpy(&d, buf + r.pos + 8 * (size_t)i, 8);
    return d;
}

/* the byte of event i of a checked blob, after its vectors (GW_STATE_FLAG_* bits) */
static unsigned gw_state_flag_at(const gw_instance *I, const unsigned char *buf, int i) {
    gw_reader r = gw_state_body(I, buf);
    gw_state_scalars sc;
    double *vec[GW_STATE_NVEC];
    int len[GW_STATE_NVEC], j;
    gw_read_scalars(&r, &sc);
    gw_vectors_of(I, vec, len);
    for (j = 0; j < GW_STATE_NVEC; j++) r.pos += 8 * (size_t)len[j];
    return buf[r.pos + (size_t)i];
}

/* The times against each other: before the initialisation t is the start time and nothing has
 * succeeded yet (gw_setup_experiment, gw_instance_reset); after it, unless the front end lets
 * its caller set the time (Model Exchange: fmi2SetTime takes any finite time),
 * t_start <= last_successful_time <= t (to the tolerance fmi2DoStep allows between its
 * communication point and t) <= the stop time.  1 or reason logged. */
static int gw_state_check_times(gw_instance *I, const char *fn, const gw_state_scalars *sc,
                                const gw_state_facts *facts) {
    const double t = sc->dbl[GW_SD_T], t0 = sc->dbl[GW_SD_T_START];
    const double last = sc->dbl[GW_SD_LAST_TIME], stop = sc->dbl[GW_SD_T_STOP];
    const double tol_t = 1e-9 * (fabs(t) > 1.0 ? fabs(t) : 1.0);
    const double tol_stop = 1e-9 * (fabs(stop) > 1.0 ? fabs(stop) : 1.0);
    if (!facts->initialised) {
        if (t != t0) {
            GW_LOG_ERR(I, "%s: FMU state holds t = %.17g, t_start = %.17g before the "
                       "initialisation (the time is the start time until then)", fn, t, t0);
            return 0;
        }
        if (last != 0.0) {
            GW_LOG_ERR(I, "%s: FMU state holds last_successful_time = %.17g before the "
                       "initialisation (nothing has been computed: 0)", fn, last);
            return 0;
        }
        return 1;
    }
    if (facts->time_free) return 1;
    if (!(t0 <= last)) {
        GW_LOG_ERR(I, "%s: FMU state holds t_start = %.17g after last_successful_time = %.17g",
                   fn, t0, last);
        return 0;
    }
    if (!(last <= t + tol_t)) {
        GW_LOG_ERR(I, "%s: FMU state holds last_successful_time = %.17g after t = %.17g", fn,
                   last, t);
        return 0;
    }
    if (sc->ints[GW_SI_STOP_DEF] && !(t <= stop + tol_stop)) {
        GW_LOG_ERR(I, "%s: FMU state holds t = %.17g after t_stop = %.17g", fn, t, stop);
        return 0;
    }
    return 1;
}

/* The event indicators at the blob's own point, evt(t, x, u, p) with ode_pre(p), into e_out
 * (ne); the instance's functions are called on copies of the blob's x, u, p and a scratch
 * ode_pre, and every binding is put back: nothing of the instance changes (not even its count
 * of indicator evaluations).  1 or reason logged. */
static int gw_state_indicators(gw_instance *I, const char *fn, const unsigned char *buf, double t,
                               double *e_out) {
    const gw_model *m = I->m;
    const int n_pre = I->f_pre.eval ? m->n_pre : 0;
    double *x, *u, *p, *pre;
    const double *bound[5];
    int i, r = 0;
    if (!I->f_evt.eval) return 1; /* ne == 0 */
    x = (double *)gw_alloc(I, (size_t)(m->nx + m->nu + m->np + n_pre) + 1, sizeof(double));
    if (!x) {
        GW_LOG_ERR(I, "%s: out of memory", fn);
        return 0;
    }
    u = x + m->nx;
    p = u + m->nu;
    pre = p + m->np;
    for (i = 0; i < m->nx; i++) x[i] = gw_state_vec_at(I, buf, 0, i);
    for (i = 0; i < m->nu; i++) u[i] = gw_state_vec_at(I, buf, 2, i);
    for (i = 0; i < m->np; i++) p[i] = gw_state_vec_at(I, buf, 3, i);
    for (i = 0; i < 5; i++) bound[i] = i < I->f_evt.n_arg ? I->f_evt.arg[i] : NULL;
    if (n_pre > 0) {
        const double *pre_arg = I->f_pre.arg[0];
        double *pre_res = I->f_pre.res[0];
        I->f_pre.arg[0] = p;
        I->f_pre.res[0] = pre;
        r = gw_fun_call(&I->f_pre);
        I->f_pre.arg[0] = pre_arg;
        I->f_pre.res[0] = pre_res;
        I->f_evt.arg[4] = pre;
    }
    I->f_evt.arg[2] = u;
    I->f_evt.arg[3] = p;
    if (r == 0) r = gw_fun_call_txup(&I->f_evt, t, x, e_out);
    for (i = 0; i < 5 && i < I->f_evt.n_arg; i++) I->f_evt.arg[i] = bound[i];
    gw_free(I, x);
    if (r != 0) GW_LOG_ERR(I, "%s: evaluation of the FMU state's event indicators failed", fn);
    return r == 0;
}

/* The events against the run (after the initialisation; before it, gw_initialize recomputes
 * them): an event whose indicator is at or below 0 has fired or fires in the pending update
 * (every event fires when its indicator reaches 0: gw_events_check, gw_event_update,
 * gw_events_initial), a flag and its firing time go together (0 and 0, or 1 and a time of
 * the run), and the run terminated exactly when a terminating event fired.  The indicator is
 * both the stored one (the one at the last event update or, once positive, seen since, or at
 * the crossing whose update is pending: gw_event_update, gw_event_observe, gw_events_check)
 * and, unless the front end lets its caller set the state (Model Exchange:
 * fmi2SetContinuousStates takes any finite state, past a crossing until the next event
 * update), the one recomputed from the state's own t, x, u, p (gw_state_indicators): a step
 * ends at a crossing, so a state past it with the event not fired (a fallen wheel not fallen)
 * is refused.  1 or reason logged. */
static int gw_state_check_events(gw_instance *I, const char *fn, const unsigned char *buf,
                                 const gw_state_scalars *sc, const gw_state_facts *facts) {
    const gw_model *m = I->m;
    const double t = sc->dbl[GW_SD_T];
    const double tol_t = 1e-9 * (fabs(t) > 1.0 ? fabs(t) : 1.0);
    double *e_now = NULL;
    int i, ended = 0, ok = 1;
    if (!facts->initialised) return 1;
    if (!facts->time_free && m->ne > 0) {
        e_now = (double *)gw_alloc(I, (size_t)m->ne, sizeof(double));
        if (!e_now) {
            GW_LOG_ERR(I, "%s: out of memory", fn);
            return 0;
        }
        ok = gw_state_indicators(I, fn, buf, t, e_now);
    }
    for (i = 0; ok && i < m->ne; i++) {
        const char *name = m->event_names && m->event_names[i] ? m->event_names[i] : "?";
        const double e = gw_state_vec_at(I, buf, 5, i), te = gw_state_vec_at(I, buf, 7, i);
        const unsigned byte = gw_state_flag_at(I, buf, i);
        const int flag = (byte & GW_STATE_FLAG_FIRED) != 0;
        const int fires = (byte & GW_STATE_FLAG_PENDING) != 0;
        if (!(e > 0.0) && !flag && !fires) {
            GW_LOG_ERR(I, "%s: FMU state holds e[%d] = %g (event %s) at or below 0 but the "
                       "event has not fired (an event fires when its indicator reaches 0)", fn,
                       i, e, name);
            ok = 0;
        } else if (e_now && !(e_now[i] > 0.0) && !flag && !fires) {
            GW_LOG_ERR(I, "%s: FMU state holds a state at which event %s has indicator %.4g, at or "
                       "below 0, but the event has not fired (a step ends where an indicator "
                       "reaches 0)", fn, name, e_now[i]);
            ok = 0;
        } else if (!flag && te != 0.0) {
            GW_LOG_ERR(I, "%s: FMU state holds t_events[%d] = %.17g (event %s) but the event has "
                       "not fired (then 0)", fn, i, te, name);
            ok = 0;
        } else if (flag && !facts->time_free &&
                   !(te >= sc->dbl[GW_SD_T_START] && te <= t + tol_t)) {
            GW_LOG_ERR(I, "%s: FMU state holds t_events[%d] = %.17g (event %s) outside the run "
                       "[t_start, t] = [%.17g, %.17g]", fn, i, te, name, sc->dbl[GW_SD_T_START], t);
            ok = 0;
        }
        if (flag && gw_event_action_of(I, i) == GW_EVENT_TERMINATE) ended = 1;
    }
    gw_free(I, e_now);
    if (!ok) return 0;
    if (sc->ints[GW_SI_TERMINATED] != ended || (facts->terminated && !ended)) {
        GW_LOG_ERR(I, "%s: FMU state holds terminated = %d, but %s terminating event has fired%s",
                   fn, sc->ints[GW_SI_TERMINATED], ended ? "a" : "no",
                   facts->terminated ? " (its instance state is one after a terminating event)"
                                     : "");
        return 0;
    }
    return 1;
}

/* The parameters and start values through the live path's own checks, as
 * fmi2ExitInitializationMode runs them (gw_validity_check: c(s, p) > 0; gw_nominals_check),
 * on a copy of the state's s and p in the instance's place for the call.  Before the
 * initialisation any finite value is what fmi2SetReal accepts.  1 or reason logged. */
static int gw_state_check_model(gw_instance *I, const char *fn, const unsigned char *buf,
                                const gw_state_facts *facts) {
    const gw_model *m = I->m;
    double *scratch, *own_s = I->s, *own_p = I->p;
    char where[160];
    int i, ok;
    if (!facts->initialised) return 1;
    scratch = (double *)gw_alloc(I, (size_t)(m->ns + m->np + m->nx) + 1, sizeof(double));
    if (!scratch) {
        GW_LOG_ERR(I, "%s: out of memory", fn);
        return 0;
    }
    for (i = 0; i < m->ns; i++) scratch[i] = gw_state_vec_at(I, buf, 1, i);
    for (i = 0; i < m->np; i++) scratch[m->ns + i] = gw_state_vec_at(I, buf, 3, i);
    I->s = scratch;
    I->p = scratch + m->ns;
    gw_state_where(where, sizeof(where), fn);
    ok = gw_validity_check(I, where) == GW_OK &&
         gw_nominals_check(I, where, scratch + m->ns + m->np) == GW_OK;
    I->s = own_s;
    I->p = own_p;
    gw_free(I, scratch);
    return ok;
}

/* The pending update (the event bytes' GW_STATE_FLAG_PENDING, gw_state.c) against the front
 * end's word (facts->pending_event): both or neither.  It is what gw_events_check leaves
 * pending (gw_event_deferred): its events at their crossing (indicator at or below 0), at
 * least one update event and no terminating one, in a run that has not terminated.  1 or
 * reason logged. */
static int gw_state_check_pending(gw_instance *I, const char *fn, const unsigned char *buf,
                                  const gw_state_scalars *sc, const gw_state_facts *facts) {
    const gw_model *m = I->m;
    int i, fires = 0, update = 0;
    for (i = 0; i < m->ne; i++) {
        const char *name = m->event_names && m->event_names[i] ? m->event_names[i] : "?";
        const unsigned byte = gw_state_flag_at(I, buf, i);
        const double e = gw_state_vec_at(I, buf, 5, i);
        if (!(byte & GW_STATE_FLAG_PENDING)) continue;
        if (!facts->pending_event) {
            GW_LOG_ERR(I, "%s: FMU state holds event flag %d = %u (must be 0 or 1)", fn, i, byte);
            return 0;
        }
        if (gw_event_action_of(I, i) == GW_EVENT_TERMINATE) {
            GW_LOG_ERR(I, "%s: FMU state holds terminating event %s in its pending update (a "
                       "step stops before an update only without one)", fn, name);
            return 0;
        }
        if (e > 0.0) {
            GW_LOG_ERR(I, "%s: FMU state holds e[%d] = %g (event %s) above 0 in its pending "
                       "update (an event fires where its indicator reaches 0)", fn, i, e, name);
            return 0;
        }
        fires = 1;
        update |= gw_event_action_of(I, i) == GW_EVENT_UPDATE;
    }
    if (facts->pending_event && !update) {
        GW_LOG_ERR(I, "%s: FMU state holds an event pending for Event Mode but no update event "
                   "to apply", fn);
        return 0;
    }
    if (fires && sc->ints[GW_SI_TERMINATED]) {
        GW_LOG_ERR(I, "%s: FMU state holds an update pending after the simulation terminated",
                   fn);
        return 0;
    }
    return 1;
}

GW_API int gw_state_check_run(gw_instance *I, const char *fn, const unsigned char *buf,
                              const gw_state_facts *facts) {
    gw_reader r = gw_state_body(I, buf);
    gw_state_scalars sc;
    gw_read_scalars(&r, &sc);
    return gw_state_check_pending(I, fn, buf, &sc, facts) &&
           gw_state_check_times(I, fn, &sc, facts) &&
           gw_state_check_events(I, fn, buf, &sc, facts) &&
           gw_state_check_model(I, fn, buf, facts);
}

#endif /* GW_UNITY_BUILD */
