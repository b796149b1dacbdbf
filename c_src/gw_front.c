/*
 * gw_front.c -- the pieces the FMI 2.0 and FMI 3.0 layers share (gw_front.h).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>
#include <string.h>

#include "gw_front.h"

GW_INTERNAL void gw_front_escape(char *buf, size_t size, const char *raw) {
    size_t i, j = 0;
    for (i = 0; raw[i] != '\0' && j + 2 < size; i++) {
        if (raw[i] == '%') buf[j++] = '%';
        buf[j++] = raw[i];
    }
    buf[j] = '\0';
}

GW_INTERNAL unsigned long long gw_front_hash(const char *text, int status) {
    unsigned long long h = 14695981039346656037ULL ^ (unsigned long long)(unsigned)status;
    for (; *text; text++) {
        h ^= (unsigned char)*text;
        h *= 1099511628211ULL;
    }
    return h;
}

GW_INTERNAL const char *gw_front_stop_reason(const gw_instance *I) {
    const gw_model *m = I->m;
    int i;
    for (i = 0; i < m->ne; i++)
        if (gw_event_ended(I, i) && m->event_names && m->event_names[i])
            return m->event_names[i];
    return "a terminating event";
}

GW_INTERNAL gw_status gw_front_copy_finite(gw_instance *I, const char *fn, double *dst,
                                           const double *src, size_t n, const char *what,
                                           const char *const *names) {
    size_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(src[i])) {
            GW_LOG_NONFINITE(I, "%s: %s %s is not finite (%g) at t=%.17g; nothing returned", fn,
                             what, names && names[i] ? names[i] : "", src[i], I->t);
            return I->nonfinite_status;
        }
    if (n > 0) memcpy(dst, src, n * sizeof(double));
    return GW_OK;
}

/* ---- variables ------------------------------------------------------------------------------- */

GW_INTERNAL int gw_front_needs(const gw_instance *I, const gw_variable *v) {
    if (!v) return 0;
    switch (v->kind) {
    case GW_VAR_OUTPUT: return GW_NEED_OUTPUTS;
    case GW_VAR_START: return v->out_index >= 0 && !I->in_setup ? GW_NEED_OUTPUTS : 0;
    case GW_VAR_STATE: return I->in_setup ? GW_NEED_OUTPUTS : 0; /* x = init(s, p) */
    case GW_VAR_DERIVATIVE: return GW_NEED_DERIVATIVES;
    case GW_VAR_INDICATOR: return GW_NEED_INDICATORS;
    default: return 0;
    }
}

GW_INTERNAL gw_status gw_front_indicators(gw_instance *I, const char *fn) {
    if (I->in_setup && gw_eval_init(I, I->x) != 0) {
        GW_LOG_ERR(I, "%s: evaluation of the initial state failed", fn);
        return GW_ERROR;
    }
    if (gw_eval_evt(I, I->t, I->x, I->e_me) != 0) {
        GW_LOG_ERR(I, "%s: evaluation of the event indicators failed at t=%.17g", fn, I->t);
        return GW_ERROR;
    }
    return GW_OK;
}

GW_INTERNAL gw_status gw_front_get_finite(gw_instance *I, const char *fn, const gw_variable *v,
                                          double *d) {
    *d = gw_value_get(I, v);
    if (isfinite(*d)) return GW_OK;
    GW_LOG_NONFINITE(I, "%s: variable %s (vr=%u) is not finite (%g) at t=%.17g; nothing returned",
                     fn, v->name, v->vr, *d, I->t);
    return I->nonfinite_status;
}

GW_INTERNAL int gw_front_settable(gw_instance *I, const char *fn, const gw_variable *v,
                                  int input_ok, int tunable_ok, const char *state,
                                  const char *hint) {
    int ok;
    switch (v->kind) {
    case GW_VAR_PARAM: ok = v->tunable ? tunable_ok : I->in_setup; break;
    case GW_VAR_STATE:
        GW_LOG_ERR(I, "%s: variable %s (vr=%u) is a continuous state and cannot be set%s", fn,
                   v->name, v->vr, hint);
        return 0;
    case GW_VAR_DERIVATIVE:
        GW_LOG_ERR(I, "%s: variable %s (vr=%u) is a state derivative and cannot be set", fn,
                   v->name, v->vr);
        return 0;
    case GW_VAR_START:
    case GW_VAR_SETTING: ok = I->in_setup; break;
    case GW_VAR_INPUT: ok = input_ok; break;
    default:
        GW_LOG_ERR(I, "%s: variable %s (vr=%u) is read-only", fn, v->name, v->vr);
        return 0;
    }
    if (!ok)
        GW_LOG_ERR(I, "%s: variable %s (vr=%u) cannot be set in state %s", fn, v->name, v->vr,
                   state);
    return ok;
}

/* ---- Co-Simulation steps ---------------------------------------------------------------------- */

GW_INTERNAL gw_status gw_front_step_check(gw_instance *I, const char *fn, double tc, double h,
                                          double *t_end) {
    double tol;
    *t_end = tc + h;
    if (!isfinite(h) || !(h > 0.0)) {
        GW_LOG_ERR(I, "%s: communication step size %g must be finite and > 0", fn, h);
        return GW_ERROR;
    }
    if (!isfinite(tc)) {
        GW_LOG_ERR(I, "%s: currentCommunicationPoint is not finite", fn);
        return GW_ERROR;
    }
    if (tc + h == tc) {
        GW_LOG_ERR(I, "%s: communication step size %g is below the resolution of "
                   "currentCommunicationPoint %.17g (t + h == t): the step would not advance "
                   "time", fn, h, tc);
        return GW_ERROR;
    }
    tol = 1e-9 * (fabs(tc) > 1.0 ? fabs(tc) : 1.0);
    if (fabs(tc - I->t) > tol) {
        GW_LOG_ERR(I, "%s: currentCommunicationPoint %.17g does not match the FMU time %.17g",
                   fn, tc, I->t);
        return GW_ERROR;
    }
    if (I->stop_defined) {
        double eps = 1e-9 * (fabs(I->t_stop) > 1.0 ? fabs(I->t_stop) : 1.0);
        if (*t_end > I->t_stop + eps) {
            GW_LOG_ERR(I, "%s: step to t=%.17g goes beyond stopTime %.17g", fn, *t_end,
                       I->t_stop);
            return GW_ERROR;
        }
    }
    return GW_OK;
}

GW_INTERNAL void gw_front_counts_take(const gw_instance *I, gw_front_counts *c) {
    c->rhs = I->n_rhs;
    c->accepted = I->n_accepted;
    c->rejected = I->n_rejected;
}

GW_INTERNAL void gw_front_step_log(gw_instance *I, const char *fn, double tc, double h,
                                   const gw_front_counts *c0, const char *status) {
    if (gw_log_enabled(I, GW_LOG_SOLVER))
        gw_log(I, GW_OK, GW_LOG_SOLVER,
               "%s t=%.17g h=%.17g -> t=%.17g solver=%s accepted=%llu rejected=%llu "
               "rhs=%llu h_next=%g status=%s",
               fn, tc, h, I->t, gw_solver_name(I->solver_in_use), I->n_accepted - c0->accepted,
               I->n_rejected - c0->rejected, I->n_rhs - c0->rhs, I->h_adapt, status);
}

#endif /* GW_UNITY_BUILD */
