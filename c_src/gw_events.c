/*
 * gw_events.c -- state events.  After every accepted internal step the event
 * indicators are evaluated at the end of the step; every indicator that went from
 * > 0 to <= 0 is located on the dense output by the Illinois method (bracketing,
 * safeguarded by bisection) to |dt| <= min(1e-12 max(1, |t|), 1e-9 of the step) (at
 * least 4 ulps of t).  An indicator > 0 at both ends can still cross twice inside the
 * step (a short dip below 0): the cubic Hermite interpolant of its values and slopes at the
 * ends (the slopes by one more evaluation per step, a difference along f) flags a dip that
 * may reach 0, which is then searched for on the dense output (gw_event_dip) and located
 * from the step's start.  The earliest crossing wins (an indicator found <= 0 at the
 * winner's time without having been located is located before it, and may win instead);
 * the state at the event is the dense output at the located time, which is the right end
 * of the final bracket, so the indicator there is <= 0 and it cannot fire again until it
 * has become positive.
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
#include <stdio.h>
#include <string.h>

#include "gw_instance.h"

#define GW_EVENT_MAX_ITER 200
#define GW_EVENT_ITER_MAX 100 /* passes of one event instant */
#define GW_EVENT_SLOPE_STEP 1.0e-8 /* an indicator's slope: difference over this part of the step */
#define GW_EVENT_DIP_ITER 40       /* golden-section evaluations of one dip: 0.618^40 = 4e-9 of the step */

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

/* The names of the events that fired in the present gw_advance (last firing after I->t_call, or
 * at te, the latest instant), comma-separated into buf (size > 4; cut with "..." where they do
 * not fit).  Returns 1 if one of them is an update event (a mode switch), else 0. */
static int gw_events_fired_names(const gw_instance *I, double te, char *buf, size_t size) {
    int i, update = 0;
    size_t used = 0;
    buf[0] = '\0';
    for (i = 0; i < I->m->ne; i++) {
        int n;
        if (!I->flags[i] || !(I->t_events[i] > I->t_call || I->t_events[i] == te)) continue;
        if (gw_event_action_of(I, i) == GW_EVENT_UPDATE) update = 1;
        n = snprintf(buf + used, size - used, "%s%s", used ? ", " : "", gw_event_name(I, i));
        if (n < 0 || (size_t)n >= size - used) {
            memcpy(buf + size - 4, "...", 4);
            break;
        }
        used += (size_t)n;
    }
    return update;
}

/* More than `limit` events in one communication step: which events, what it
 * means (a mode that switches back and forth faster than the solver's steps: a time scale of
 * the law far below the step) and what to try (docs/runtime.md, "Events and state updates"). */
GW_INTERNAL void gw_events_log_too_many(const gw_instance *I, double te, int limit) {
    char names[256];
    const int rosenbrock = I->solver_in_use == GW_SOLVER_ROSENBROCK;
    if (gw_events_fired_names(I, te, names, sizeof names))
        GW_LOG_ERR(I, "more than %d events in one communication step, from t=%.17g to t=%.17g: "
                   "%s kept firing: a mode switches back and forth faster than solver %s can "
                   "follow, each switch undone within a step (a law's time scale far below the "
                   "step, such as a stiction law's viscous one, inertia / damping); %sa law with "
                   "a longer time scale (for a viscous part, a smaller damping coefficient)",
                   limit, I->t_call, te, names, gw_solver_name(I->solver_in_use),
                   rosenbrock ? "try " : "try solver rosenbrock (implicit, it follows such a "
                                         "fast mode), or ");
    else
        GW_LOG_ERR(I, "more than %d events in one communication step, from t=%.17g to t=%.17g: "
                   "%s kept firing (solver %s): the event indicators cross zero again and "
                   "again; the limit is per communication step: try a shorter one",
                   limit, I->t_call, te, names, gw_solver_name(I->solver_in_use));
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

/* ---- crossings inside a step ---------------------------------------------------- */

/* d[i] = d g_i / d t at (t, x), g = e there: a difference over dt along the solution, on the
 * straight line x + dt f when f (= f(t, x)) is given, else on the step's dense output (dt < 0:
 * backwards from the step's end).  Uses I->xtmp and I->eev as scratch. */
static int gw_event_slopes(gw_instance *I, double t, const double *x, const double *g,
                           const double *f, double dt, double *d) {
    const int nx = I->m->nx, ne = I->m->ne;
    int j;
    if (f) {
        for (j = 0; j < nx; j++) I->xtmp[j] = x[j] + dt * f[j];
    } else {
        gw_dense_prepare(I);
        gw_dense_eval(I, t + dt, I->xtmp);
    }
    if (gw_eval_evt(I, t + dt, I->xtmp, I->eev) != 0) return -1;
    for (j = 0; j < ne; j++) d[j] = (I->eev[j] - g[j]) / dt;
    return 0;
}

/* The slopes of the indicators at both ends of the step [t0, t1] (I->edot, I->edot_new). */
static int gw_event_end_slopes(gw_instance *I, double t0, double t1) {
    const double dt = GW_EVENT_SLOPE_STEP * (t1 - t0);
    if (!(I->edot_valid && I->edot_t == t0)) {
        if (gw_event_slopes(I, t0, I->x, I->e, I->fcur_valid ? I->k[0] : NULL, dt, I->edot))
            return -1;
        I->edot_t = t0;
        I->edot_valid = 1;
    }
    if (!I->k7_valid && I->solver_in_use != GW_SOLVER_TAYLOR && I->solver_in_use != GW_SOLVER_ROSENBROCK)
        gw_dense_prepare(I); /* euler, rk4: f(t1, xnew) into k[6], reused by the next step */
    if (I->edot_new_ready) { /* from the Taylor series at t1 (GW_TL(evt_slope)): exact */
        I->edot_new_ready = 0;
        return 0;
    }
    if (I->k7_valid) return gw_event_slopes(I, t1, I->xnew, I->enew, I->k[6], dt, I->edot_new);
    if (I->tl_fnew) return gw_event_slopes(I, t1, I->xnew, I->enew, I->tl_fnew, dt, I->edot_new);
    return gw_event_slopes(I, t1, I->xnew, I->enew, NULL, -dt, I->edot_new);
}

/* g_i at th in (0, 1) of the step: I->xtmp, I->eev as scratch; non-finite counts as <= 0 */
static int gw_event_at(gw_instance *I, int i, double t0, double h, double th, double *g) {
    if (gw_event_indicator(I, i, t0 + th * h, g) != 0) return -1;
    if (!isfinite(*g)) *g = -1.0;
    return 0;
}

/* An indicator with the same sign at both ends of the step may still cross inside it: one
 * > 0 at both ends can dip to <= 0 (and back), one <= 0 at both ends (a warning that has
 * fired) can rise above 0 and fall back to <= 0, a new firing (a short second slip).  The
 * cubic Hermite interpolant p of g on [t0, t0 + h] from g and its slope at both ends (one
 * indicator evaluation per step, gw_event_end_slopes) shows where g has an interior minimum
 * (maximum); only when p's extremum is beyond half the end value nearer to 0 (a dip that a
 * step resolved to the tolerance could take across 0) is g itself searched on the dense
 * output: at p's extremum, then by golden-section search (GW_EVENT_DIP_ITER evaluations at
 * most) until a point across 0 is found.  Returns 1 with the bracket [*ta, *tb] of a crossing
 * from > 0 (*fa) to <= 0 (*fb), 0 if none, -1 on a failed evaluation. */
static int gw_event_dip(gw_instance *I, int i, double t0, double t1, double *ta, double *fa,
                        double *tb, double *fb) {
    const double h = t1 - t0, g0 = I->e[i], g1 = I->enew[i];
    const double d0 = h * I->edot[i], d1 = h * I->edot_new[i];
    const double A = 3.0 * (2.0 * (g0 - g1) + d0 + d1), B = -2.0 * (3.0 * (g0 - g1) + 2.0 * d0 + d1);
    const double C = d0;
    /* s = 1: the minimum of g (both ends > 0); s = -1: its maximum (both <= 0) */
    const double s = g0 > 0.0 ? 1.0 : -1.0, q0 = s * g0, q1 = s * g1;
    double roots[2], th = -1.0, a = 0.0, b = 1.0, c, qa = q0, qb = q1, qc, gc, pc;
    int n = 0, k, it;
    if ((g0 > 0.0) != (g1 > 0.0) || !isfinite(g0) || !isfinite(g1) || !isfinite(d0) ||
        !isfinite(d1))
        return 0;
    /* p's Bernstein coefficients g0, g0 + d0/3, g1 - d1/3, g1 bound s p from below (convex
     * hull): with the inner two at or beyond half the nearer end value, so is p's extremum and
     * the test below fails; most steps end here, without the roots' sqrt and divisions */
    if (s * (g0 + d0 * (1.0 / 3.0)) >= 0.5 * (q0 < q1 ? q0 : q1) &&
        s * (g1 - d1 * (1.0 / 3.0)) >= 0.5 * (q0 < q1 ? q0 : q1))
        return 0;
    /* p'(th) = A th^2 + B th + C; a minimum of s p where s p'' = s (2 A th + B) > 0 */
    if (A == 0.0) {
        if (B != 0.0) roots[n++] = -C / B;
    } else {
        const double disc = B * B - 4.0 * A * C;
        if (disc >= 0.0) {
            const double q = -0.5 * (B + (B >= 0.0 ? sqrt(disc) : -sqrt(disc)));
            if (q != 0.0) roots[n++] = C / q;
            roots[n++] = q / A;
        }
    }
    for (k = 0; k < n; k++)
        if (roots[k] > 0.0 && roots[k] < 1.0 && s * (2.0 * A * roots[k] + B) > 0.0) th = roots[k];
    if (th < 0.0) return 0;
    pc = g0 * (1.0 + th * th * (2.0 * th - 3.0)) + g1 * th * th * (3.0 - 2.0 * th) +
         d0 * th * (1.0 - th) * (1.0 - th) + d1 * th * th * (th - 1.0);
    if (!(s * pc < 0.5 * (q0 < q1 ? q0 : q1))) return 0;
    gw_dense_prepare(I);
    c = th;
    if (gw_event_at(I, i, t0, h, c, &gc)) return -1;
    qc = s * gc;
    for (it = 0; s > 0.0 ? gc > 0.0 : !(gc > 0.0); it++) {
        double x, gx, qx;
        if (it >= GW_EVENT_DIP_ITER || !(qc < qa && qc < qb)) return 0; /* not across 0 */
        x = (c - a > b - c) ? c - 0.381966011250105 * (c - a) : c + 0.381966011250105 * (b - c);
        if (gw_event_at(I, i, t0, h, x, &gx)) return -1;
        qx = s * gx;
        if (qx < qc) { /* x is the new middle */
            if (x < c) b = c, qb = qc; else a = c, qa = qc;
            c = x;
            qc = qx;
            gc = gx;
        } else if (x < c) {
            a = x, qa = qx;
        } else {
            b = x, qb = qx;
        }
    }
    if (s > 0.0) { /* [t0, the point <= 0] */
        *ta = t0, *fa = g0, *tb = t0 + c * h, *fb = gc;
    } else {       /* [the point > 0, t1] */
        *ta = t0 + c * h, *fa = gc, *tb = t1, *fb = g1;
    }
    return 1;
}

/* I->stop_at_update == GW_STOP_BEFORE_UPDATE: the located instant (I->ev_fired) is left
 * pending if an update event fires in it and no terminating one (the end needs no Event Mode) */
static int gw_event_deferred(const gw_instance *I) {
    int i, update = 0;
    for (i = 0; i < I->m->ne; i++) {
        if (!I->ev_fired[i]) continue;
        if (gw_event_action_of(I, i) == GW_EVENT_TERMINATE) return 0;
        if (gw_event_action_of(I, i) == GW_EVENT_UPDATE) update = 1;
    }
    return update;
}

GW_INTERNAL gw_ev_result gw_events_check(gw_instance *I, double t0, double t1, double *t_event) {
    const gw_model *m = I->m;
    /* An ensemble lane (its series fetched lazily, I->tl_fetch) looks at the step's ends only,
     * as its batch's fast path does (gw_ensemble_batch.h): a lane's steps must not depend on
     * which of the two concluded them. */
    const int inside = (I->tl_fetch == NULL);
    int i, ne = m->ne, winner = -1, jumped = 0, pass;
    double best = t1;
    if (I->enew_ready) { /* from the Taylor kernel's series at (t1, xnew), GW_TL(evt) */
        I->enew_ready = 0;
        I->n_evt++;
    } else if (gw_eval_evt(I, t1, I->xnew, I->enew) != 0) {
        GW_LOG_ERR(I, "evaluation of the event indicators failed at t=%.17g", t1);
        return GW_EV_ERROR;
    }
    if (!inside) {
        for (i = 0; i < ne; i++)
            if (I->e[i] > 0.0 && !(I->enew[i] > 0.0)) break;
        if (i == ne) return GW_EV_NONE;
    }
    if (I->tl_fetch) I->tl_fetch(I, I->tl_fetch_env); /* the step's series into I->tl_w */
    if (inside && gw_event_end_slopes(I, t0, t1) != 0) {
        GW_LOG_ERR(I, "evaluation of the event indicators failed at t=%.17g", t1);
        return GW_EV_ERROR;
    }
    for (i = 0; i < ne; i++) {
        double a = t0, fa = I->e[i], b = t1, fb = isfinite(I->enew[i]) ? I->enew[i] : -I->e[i], te;
        I->ev_fired[i] = 0; /* here: 1 once its crossing is located */
        if (!(I->e[i] > 0.0) || I->enew[i] > 0.0) {
            /* no crossing seen at the ends: one that starts and ends inside the step? */
            const int dip = inside ? gw_event_dip(I, i, t0, t1, &a, &fa, &b, &fb) : 0;
            if (dip < 0) {
                GW_LOG_ERR(I, "evaluation of the event indicators failed while searching "
                           "event %s inside the step", gw_event_name(I, i));
                return GW_EV_ERROR;
            }
            if (!dip || (winner >= 0 && a >= best)) continue;
        }
        gw_dense_prepare(I);
        I->ev_fired[i] = 1;
        if (gw_event_locate(I, i, a, fa, b, fb, &te)) {
            GW_LOG_ERR(I, "evaluation of the event indicators failed while locating event %s",
                       gw_event_name(I, i));
            return GW_EV_ERROR;
        }
        if (winner < 0 || te < best) {
            best = te;
            winner = i;
        }
    }
    if (winner < 0) return GW_EV_NONE;
    /* the state and the indicators at the event; an indicator <= 0 there that was not located
     * (it crossed inside the step, unseen at its ends) is located in [t0, best] and may win */
    for (pass = 0;; pass++) {
        int earlier = -1;
        double te = best;
        gw_dense_eval(I, best, I->xev);
        if (gw_eval_evt(I, best, I->xev, I->eev) != 0) {
            GW_LOG_ERR(I, "evaluation of the event indicators failed at t=%.17g", best);
            return GW_EV_ERROR;
        }
        if (pass > ne) break;
        for (i = 0; i < ne && earlier < 0; i++) {
            if (I->ev_fired[i] || !(I->e[i] > 0.0) || I->eev[i] > 0.0) continue;
            I->ev_fired[i] = 1;
            if (gw_event_locate(I, i, t0, I->e[i], best,
                                isfinite(I->eev[i]) ? I->eev[i] : -I->e[i], &te)) {
                GW_LOG_ERR(I, "evaluation of the event indicators failed while locating "
                           "event %s", gw_event_name(I, i));
                return GW_EV_ERROR;
            }
            if (te < best) earlier = i;
        }
        if (earlier < 0) break;
        best = te;
        winner = earlier;
    }
    for (i = 0; i < ne; i++) {
        I->ev_fired[i] = (i == winner) || (I->e[i] > 0.0 && !(I->eev[i] > 0.0));
        if (I->ev_fired[i] && I->eev[i] > 0.0) I->eev[i] = 0.0; /* the winner is at its crossing */
    }
    *t_event = best;
    if (I->stop_at_update == GW_STOP_BEFORE_UPDATE && gw_event_deferred(I)) {
        I->update_pending = 1; /* gw_event_update applies it: the instant as located here */
        return GW_EV_UPDATE;
    }
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
    /* an instant gw_advance stopped at (GW_STOP_BEFORE_UPDATE): its events and indicators as
     * located there, exactly what integrating through it would have applied */
    for (i = 0; i < m->ne && !I->update_pending; i++) {
        const int was_positive = I->e[i] > 0.0;
        const int now_le = !(e_now[i] > 0.0);
        if (gw_event_action_of(I, i) == GW_EVENT_TERMINATE)
            I->ev_fired[i] = now_le && (was_positive || !I->flags[i]);
        else
            I->ev_fired[i] = now_le && was_positive;
        I->e[i] = e_now[i];
    }
    I->update_pending = 0;
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
