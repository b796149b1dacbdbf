/*
 * gw_events.c -- state events.  After every accepted internal step the event
 * indicators are evaluated at the end of the step; every indicator that went from
 * > 0 to <= 0 is located on the dense output by the Illinois method (bracketing,
 * safeguarded by bisection) to |dt| <= min(1e-12 max(1, |t|), 1e-9 of the step) (at
 * least 4 ulps of t).  The earliest crossing
 * wins; the state at the event is the dense output at the located time, which is
 * the right end of the final bracket, so the indicator there is <= 0 and it
 * cannot fire again until it has become positive.
 * gw_event_update serves a front end that locates crossings itself (Model Exchange).
 *
 * One event instant (gw_event_instant) serves both: the events found crossing fire; a
 * GW_EVENT_UPDATE event (a discrete mode switch, e.g. a stiction law sticking) replaces the
 * state by upd(t, x, u, p, k), after which the indicators are evaluated again and those the
 * jump made cross from > 0 to <= 0 fire in a next pass ("event iteration").  Each event fires
 * at most once per instant (the chattering guard: a law that has just stuck is not released
 * in the same instant); passes are bounded by GW_EVENT_ITER_MAX with an error.  The indicators
 * at the final state are the reference for the next crossing.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <float.h>
#include <math.h>
#include <string.h>

#include "gw_instance.h"

#define GW_EVENT_MAX_ITER 200
#define GW_EVENT_ITER_MAX 100 /* passes of one event instant */

static const char *gw_event_name(const gw_instance *I, int i) {
    return (I->m->event_names && I->m->event_names[i]) ? I->m->event_names[i] : "?";
}

/* g(t) = indicator i on the dense output; uses I->xtmp and I->eev as scratch. */
static int gw_event_indicator(gw_instance *I, int i, double t, double *g) {
    gw_dense_eval(I, t, I->xtmp);
    if (gw_eval_evt(I, t, I->xtmp, I->eev) != 0) return -1;
    *g = I->eev[i];
    return 0;
}

/* Locate the crossing of indicator i in [a, b], fa > 0 >= fb.  Returns the right end
 * of the final bracket (g <= 0 there). */
static int gw_event_locate(gw_instance *I, int i, double a, double fa, double b, double fb, double *t_out) {
    /* 1e-12 s (relative beyond |t| = 1), but never coarser than 1e-9 of the step: a step of
     * 1e-10 s (beta_dot = 1e9 rad/s) needs its event to 1e-19 s, not 1e-12 s = 1e-3 rad */
    const double t_abs = fabs(b) > fabs(a) ? fabs(b) : fabs(a);
    const double tol_t = 1e-12 * (t_abs > 1.0 ? t_abs : 1.0), tol_w = 1e-9 * (b - a);
    const double tol_eps = 4.0 * DBL_EPSILON * t_abs;
    const double tol = tol_t < tol_w ? tol_t : (tol_w > tol_eps ? tol_w : tol_eps);
    double width = b - a;
    int side = 0, bisect = 0, it;
    for (it = 0; it < GW_EVENT_MAX_ITER && (b - a) > tol; it++) {
        double c, fc, w;
        c = bisect ? 0.5 * (a + b) : b - fb * (b - a) / (fb - fa);
        if (!(c > a && c < b)) c = 0.5 * (a + b);
        if (c - a < 0.25 * tol) c = a + 0.25 * tol; /* always make progress */
        if (b - c < 0.25 * tol) c = b - 0.25 * tol;
        if (gw_event_indicator(I, i, c, &fc) != 0) return -1;
        if (!(fc > 0.0)) { /* <= 0 or NaN: the crossing is at or before c */
            b = c;
            fb = isfinite(fc) ? fc : -fa;
            if (side == -1) fa *= 0.5; /* Illinois modification */
            side = -1;
            if (fc == 0.0) break;
        } else {
            a = c;
            fa = fc;
            if (side == 1) fb *= 0.5;
            side = 1;
        }
        w = b - a;
        bisect = (w > 0.5 * width); /* no halving: bisect next */
        width = w;
    }
    *t_out = b;
    return 0;
}

static int gw_event_action_of(const gw_instance *I, int i) {
    return I->m->event_actions ? I->m->event_actions[i] : GW_EVENT_TERMINATE;
}

static void gw_event_log(const gw_instance *I, int i, double te, int terminate) {
    if (terminate) {
        if (gw_log_enabled(I, GW_LOG_EVENTS))
            gw_log(I, GW_OK, GW_LOG_EVENTS,
                   "event %s at t=%.17g: simulation terminated at t=%.17g", gw_event_name(I, i),
                   te, te);
    } else if (gw_log_enabled(I, GW_LOG_EVENTS)) {
        gw_log(I, GW_WARNING, GW_LOG_EVENTS, "warning: event %s at t=%.17g", gw_event_name(I, i),
               te);
    } else if (gw_log_enabled(I, GW_LOG_WARNING)) {
        gw_log(I, GW_WARNING, GW_LOG_WARNING, "warning: event %s at t=%.17g", gw_event_name(I, i),
               te);
    }
}

/* Apply the update of event i to x (in place); 0, or -1 with the reason logged. */
static int gw_event_apply_update(gw_instance *I, int i, double t, double *x) {
    const int nx = I->m->nx;
    int j;
    if (gw_eval_upd(I, t, x, i, I->x_upd) != 0) {
        GW_LOG_ERR(I, "evaluation of the update of event %s failed at t=%.17g", gw_event_name(I, i),
                   t);
        return -1;
    }
    for (j = 0; j < nx; j++)
        if (!isfinite(I->x_upd[j])) {
            GW_LOG_ERR(I, "the update of event %s at t=%.17g gives state %s = %g",
                       gw_event_name(I, i), t,
                       (I->m->x_names && I->m->x_names[j]) ? I->m->x_names[j] : "?", I->x_upd[j]);
            return -1;
        }
    memcpy(x, I->x_upd, (size_t)nx * sizeof(double));
    if (gw_log_enabled(I, GW_LOG_EVENTS))
        gw_log(I, GW_OK, GW_LOG_EVENTS, "event %s at t=%.17g: state updated", gw_event_name(I, i),
               t);
    return 0;
}

/* One event instant at (t, x) (see the file comment).  The events with I->ev_fired[i] == 1
 * fire: terminating and warning ones set their flag and are logged; unless one terminates,
 * the updates are applied to x in index order (their flags set too: switched at least once).  After a jump the indicators are evaluated
 * again; one that went from > 0 to <= 0 and has not fired in this instant fires in the next
 * pass (only update events when only_updates: initialisation checks the others itself).
 * e: in, the indicators at (t, x); out, those at the final state.  *jumped: x changed.
 * Returns TERMINATE, else UPDATE (x changed), else WARN or NONE; ERROR logged. */
static gw_ev_result gw_event_instant(gw_instance *I, double t, double *x, double *e,
                                     int only_updates, int *jumped) {
    const int ne = I->m->ne;
    int i, pass, terminate = 0, warn = 0;
    *jumped = 0;
    for (pass = 0;; pass++) {
        int updated = 0, pending = 0;
        if (pass >= GW_EVENT_ITER_MAX) {
            GW_LOG_ERR(I, "event iteration at t=%.17g did not settle in %d passes: events keep "
                       "triggering each other", t, GW_EVENT_ITER_MAX);
            return GW_EV_ERROR;
        }
        for (i = 0; i < ne; i++) { /* terminating and warning events first */
            const int action = gw_event_action_of(I, i);
            if (I->ev_fired[i] != 1 || action == GW_EVENT_UPDATE) continue;
            I->ev_fired[i] = 2;
            I->flags[i] = 1;
            I->t_events[i] = t;
            I->n_events++;
            if (action == GW_EVENT_WARN)
                warn = 1;
            else
                terminate = 1;
            gw_event_log(I, i, t, action != GW_EVENT_WARN);
        }
        for (i = 0; i < ne; i++) { /* the updates, unless the simulation ends here */
            if (I->ev_fired[i] != 1) continue;
            I->ev_fired[i] = 2;
            I->n_events++;
            if (terminate) continue;
            I->flags[i] = 1; /* an update event's flag: it has switched at least once */
            I->t_events[i] = t;
            if (gw_event_apply_update(I, i, t, x)) return GW_EV_ERROR;
            updated = 1;
        }
        if (!updated) break;
        *jumped = 1;
        I->x_jumped = 1;
        if (gw_eval_evt(I, t, x, I->e_upd) != 0) {
            GW_LOG_ERR(I, "evaluation of the event indicators failed at t=%.17g", t);
            return GW_EV_ERROR;
        }
        for (i = 0; i < ne; i++) {
            if (!I->ev_fired[i] && e[i] > 0.0 && !(I->e_upd[i] > 0.0) &&
                (!only_updates || gw_event_action_of(I, i) == GW_EVENT_UPDATE)) {
                I->ev_fired[i] = 1;
                pending = 1;
            }
            e[i] = I->e_upd[i];
        }
        if (!pending) break;
    }
    if (terminate) return GW_EV_TERMINATE;
    if (*jumped) return GW_EV_UPDATE;
    return warn ? GW_EV_WARN : GW_EV_NONE;
}

GW_INTERNAL gw_ev_result gw_events_check(gw_instance *I, double t0, double t1, double *t_event) {
    const gw_model *m = I->m;
    int i, ne = m->ne, winner = -1, jumped = 0;
    double best = t1;
    if (I->enew_ready) { /* from the Taylor kernel's series at (t1, xnew), GW_TL(evt) */
        I->enew_ready = 0;
        I->n_evt++;
    } else if (gw_eval_evt(I, t1, I->xnew, I->enew) != 0) {
        GW_LOG_ERR(I, "evaluation of the event indicators failed at t=%.17g", t1);
        return GW_EV_ERROR;
    }
    for (i = 0; i < ne; i++)
        if (I->e[i] > 0.0 && !(I->enew[i] > 0.0)) break;
    if (i == ne) return GW_EV_NONE;

    if (I->tl_fetch) I->tl_fetch(I, I->tl_fetch_env); /* the step's series into I->tl_w */
    gw_dense_prepare(I);
    for (; i < ne; i++) {
        double te;
        if (!(I->e[i] > 0.0 && !(I->enew[i] > 0.0))) continue;
        if (gw_event_locate(I, i, t0, I->e[i], t1, isfinite(I->enew[i]) ? I->enew[i] : -I->e[i], &te)) {
            GW_LOG_ERR(I, "evaluation of the event indicators failed while locating event %s",
                       gw_event_name(I, i));
            return GW_EV_ERROR;
        }
        if (winner < 0 || te < best) {
            best = te;
            winner = i;
        }
    }
    /* the state and the indicators at the event */
    gw_dense_eval(I, best, I->xev);
    if (gw_eval_evt(I, best, I->xev, I->eev) != 0) {
        GW_LOG_ERR(I, "evaluation of the event indicators failed at t=%.17g", best);
        return GW_EV_ERROR;
    }
    for (i = 0; i < ne; i++) {
        I->ev_fired[i] = (i == winner) || (I->e[i] > 0.0 && !(I->eev[i] > 0.0));
        if (I->ev_fired[i] && I->eev[i] > 0.0) I->eev[i] = 0.0; /* the winner is at its crossing */
    }
    *t_event = best;
    return gw_event_instant(I, best, I->xev, I->eev, 0, &jumped);
}

/* ---- Model Exchange ------------------------------------------------------------ */

/* The importer has located the crossing and set t and x there; this decides which
 * indicators fire.  A WARN or UPDATE indicator fires when it went from > 0 (at the
 * previous event update, or seen > 0 by gw_event_observe since) to <= 0; a TERMINATE
 * indicator fires when it is <= 0 now (it cannot be <= 0 at the start: gw_initialize
 * refuses that) and has not fired before.  A non-finite indicator counts as <= 0, as in
 * gw_events_check.  Updates change I->x here (the front end reports it to the importer). */
GW_API gw_ev_result gw_event_update(gw_instance *I, const double *e_now) {
    const gw_model *m = I->m;
    int i, jumped = 0;
    gw_ev_result r;
    for (i = 0; i < m->ne; i++) {
        const int was_positive = I->e[i] > 0.0;
        const int now_le = !(e_now[i] > 0.0);
        if (gw_event_action_of(I, i) == GW_EVENT_TERMINATE)
            I->ev_fired[i] = now_le && (was_positive || !I->flags[i]);
        else
            I->ev_fired[i] = now_le && was_positive;
        I->e[i] = e_now[i];
    }
    r = gw_event_instant(I, I->t, I->x, I->e, 0, &jumped);
    if (jumped) {
        gw_point_changed(I);
        I->fcur_valid = 0;
    }
    return r;
}

GW_API int gw_event_ended(const gw_instance *I, int i) {
    return I->flags[i] && gw_event_action_of(I, i) == GW_EVENT_TERMINATE;
}

GW_API void gw_event_observe(gw_instance *I, const double *e) {
    int i;
    for (i = 0; i < I->m->ne; i++)
        if (e[i] > 0.0) I->e[i] = e[i];
}

/* ---- initialisation --------------------------------------------------------------- */

GW_INTERNAL int gw_events_initial(gw_instance *I, const char *fn) {
    int i, any = 0, jumped = 0;
    for (i = 0; i < I->m->ne; i++) {
        I->ev_fired[i] = gw_event_action_of(I, i) == GW_EVENT_UPDATE && !(I->e[i] > 0.0);
        any |= I->ev_fired[i];
    }
    if (!any) return 0;
    if (gw_event_instant(I, I->t, I->x, I->e, 1, &jumped) == GW_EV_ERROR) {
        GW_LOG_ERR(I, "%s: the initial event iteration failed", fn);
        return -1;
    }
    return 0;
}

#endif /* GW_UNITY_BUILD */
