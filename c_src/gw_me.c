/*
 * gw_me.c -- the work of the Model Exchange calls on the core, shared by the FMI 2.0 and
 * FMI 3.0 layers (gw_fmi2_me.c, gw_fmi3_me.c): the importer sets time and states, reads
 * derivatives, event indicators, states and nominals, and asks for the event update at the
 * point it located.  Each function takes the calling fmi function's name (fn, the start of
 * every message) and returns a gw_status with its reason logged; the layers map the status
 * and run their own state machines.  Included by the unity files (gw_fmu.c, gw_fmu3.c)
 * after the core.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>
#include <string.h>

#include "gw_instance.h"

/* log the reason and return GW_ERROR */
#define GW_ME_FAIL(...)                                                                         \
    do {                                                                                        \
        GW_LOG_ERR(I, __VA_ARGS__);                                                             \
        return GW_ERROR;                                                                        \
    } while (0)

/* An array argument of n values where the model has `want`: n_name is the argument's name in
 * the calling function ("nx", "nContinuousStates"), what the model's count ("continuous
 * states", "event indicators"). */
GW_INTERNAL gw_status gw_me_check_size(gw_instance *I, const char *fn, const void *arr, size_t n,
                                       int want, const char *n_name, const char *what) {
    if (n != (size_t)want)
        GW_ME_FAIL("%s: %s = %lu, the model has %d %s", fn, n_name, (unsigned long)n, want, what);
    if (n > 0 && !arr) GW_ME_FAIL("%s: array is NULL", fn);
    return GW_OK;
}

/* The event update at the current point (fmi2NewDiscreteStates, fmi3UpdateDiscreteStates):
 * the indicators now against those of the last update decide what fired (gw_event_update);
 * an update event changes x (I->x_jumped), a terminating one ends the simulation for good.
 * *result: gw_event_update's answer (GW_EV_NONE for a model without events). */
GW_INTERNAL gw_status gw_me_event_update(gw_instance *I, const char *fn, gw_ev_result *result) {
    const gw_model *m = I->m;
    int i;
    *result = GW_EV_NONE;
    if (m->ne > 0) {
        if (gw_eval_evt(I, I->t, I->x, I->e_me) != 0)
            GW_ME_FAIL("%s: evaluation of the event indicators failed at t=%.17g", fn, I->t);
        *result = gw_event_update(I, I->e_me);
    }
    if (*result == GW_EV_TERMINATE && !I->terminated) {
        I->terminated = 1;
        I->last_successful_time = I->t;
        for (i = 0; i < m->ne; i++)
            if (gw_event_ended(I, i) && !(I->e[i] > 0.0) && gw_log_enabled(I, GW_LOG_EVENTS))
                gw_log(I, GW_OK, GW_LOG_EVENTS,
                       "%s: event %s: terminateSimulation = true at t=%.17g", fn,
                       m->event_names ? m->event_names[i] : "?", I->t);
    }
    return GW_OK;
}

GW_INTERNAL gw_status gw_me_set_time(gw_instance *I, const char *fn, double time) {
    if (!isfinite(time)) GW_ME_FAIL("%s: time %g is not finite", fn, time);
    if (time != I->t) {
        I->t = time;
        gw_point_changed(I);
    }
    return GW_OK;
}

/* x: nx values, nx checked by gw_me_check_size; every one finite */
GW_INTERNAL gw_status gw_me_set_states(gw_instance *I, const char *fn, const double *x, size_t nx) {
    size_t i;
    for (i = 0; i < nx; i++)
        if (!isfinite(x[i]))
            GW_ME_FAIL("%s: state %s = %g is not finite", fn,
                       I->m->x_names ? I->m->x_names[i] : "?", x[i]);
    if (nx > 0 && memcmp(I->x, x, nx * sizeof(double)) != 0) {
        memcpy(I->x, x, nx * sizeof(double));
        gw_point_changed(I);
    }
    return GW_OK;
}

/* Before the initialisation the states are init(s, p) of the current start values; after
 * it they are the instance's own. */
GW_INTERNAL gw_status gw_me_current_states(gw_instance *I, const char *fn) {
    if (I->in_setup && gw_eval_init(I, I->x) != 0)
        GW_ME_FAIL("%s: evaluation of the initial state failed", fn);
    return GW_OK;
}

/* ni values into e (ni checked by gw_me_check_size); non-finite ones are answered with
 * I->nonfinite_status and nothing copied.  After the initialisation a positive indicator
 * arms its event (gw_event_observe). */
GW_INTERNAL gw_status gw_me_event_indicators(gw_instance *I, const char *fn, double *e,
                                             size_t ni) {
    const gw_model *m = I->m;
    size_t i;
    if (ni == 0) return GW_OK;
    if (gw_me_current_states(I, fn) != GW_OK) return GW_ERROR;
    if (gw_eval_evt(I, I->t, I->x, I->e_me) != 0)
        GW_ME_FAIL("%s: evaluation of the event indicators failed at t=%.17g", fn, I->t);
    for (i = 0; i < ni; i++)
        if (!isfinite(I->e_me[i])) {
            GW_LOG_NONFINITE(I, "%s: event indicator %s is not finite (%g) at t=%.17g", fn,
                             m->event_names ? m->event_names[i] : "?", I->e_me[i], I->t);
            return I->nonfinite_status;
        }
    memcpy(e, I->e_me, ni * sizeof(double));
    if (!I->in_setup) gw_event_observe(I, I->e_me);
    return GW_OK;
}

/* Before the initialisation from the current parameters, 1 where not usable; after it the
 * instance's own (nx checked by gw_me_check_size). */
GW_INTERNAL gw_status gw_me_nominals(gw_instance *I, const char *fn, double *nominal, size_t nx) {
    size_t i;
    if (nx == 0) return GW_OK;
    if (!I->in_setup) {
        memcpy(nominal, I->nominal, nx * sizeof(double));
        return GW_OK;
    }
    if (gw_eval_nom(I, nominal) != 0) GW_ME_FAIL("%s: evaluation of the nominals failed", fn);
    for (i = 0; i < nx; i++)
        if (!(nominal[i] > 0.0) || !isfinite(nominal[i])) nominal[i] = 1.0;
    return GW_OK;
}

#undef GW_ME_FAIL

#endif /* GW_UNITY_BUILD */
