/*
 * gw_capi.c -- the exported C API over the simulation core (gw_core.h): life cycle, inputs,
 * advancing in time, reading values and events, diagnostics.  Every public function is
 * GWC(name), i.e. <model>_name; everything else is static.  Saving and restoring:
 * gw_capi_state.c; the names/units table and the defaults: gw_capi_names.c.
 *
 * Errors: each failing call leaves one line in last_error.  Values the caller gives are checked
 * here first (NaN -> GYROWHEEL_ERR_NOT_FINITE naming the variable), then by the core, whose
 * logged reasons (GW_ERROR) are collected in `pending` during the call and become last_error if
 * the call fails (docs/c_api.md lists which code means what).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see <model>.c */
#else

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gw_capi.h"

/* the API's solver codes are the core's */
#define GWC_SAME(a, b) ((int)GYROWHEEL_SOLVER_##a == (int)GW_SOLVER_##b)
typedef char gwc_solver_codes_match[(GWC_SAME(EULER, EULER) && GWC_SAME(RK4, RK4) &&
                                     GWC_SAME(DOPRI5, DOPRI5) && GWC_SAME(ROSENBROCK, ROSENBROCK) &&
                                     GWC_SAME(DOP853, DOP853) && GWC_SAME(TAYLOR, TAYLOR) &&
                                     GWC_SAME(AUTO, AUTO))
                                        ? 1
                                        : -1];

/* ---- messages ------------------------------------------------------------------------------ */

static gyrowheel_status gwc_fail(const struct GWC_T *w, gyrowheel_status code, const char *fmt,
                                 ...) {
    va_list ap;
    /* last_error is the one field a const call writes; instances are never const objects */
    struct GWC_T *mw = (struct GWC_T *)w;
    if (!w) return code;
    va_start(ap, fmt);
    vsnprintf(mw->last_error, sizeof(mw->last_error), fmt, ap);
    va_end(ap);
    if (w->logger) w->logger(w->logger_env, GYROWHEEL_LOG_ERROR, w->last_error);
    return code;
}

static gyrowheel_status gwc_null(const struct GWC_T *w, const char *fn, const char *what) {
    return gwc_fail(w, GYROWHEEL_ERR_ARGUMENT, "%s: %s is NULL", fn, what);
}

static void gwc_begin(struct GWC_T *w) {
    w->pending[0] = '\0';
    w->pending_len = 0;
}

static gyrowheel_status gwc_fail_core(struct GWC_T *w, gyrowheel_status code,
                                      const char *fallback) {
    if (!w->pending_len) return gwc_fail(w, code, "%s", fallback);
    /* the core's messages reached the logger as they were logged (gwc_core_logger) */
    snprintf(w->last_error, sizeof(w->last_error), "%s", w->pending);
    return code;
}

/* The core's logger: errors are kept for last_error, everything goes to the caller's logger. */
static void gwc_core_logger(void *env, const char *instance_name, gw_status status,
                            const char *category, const char *message) {
    struct GWC_T *w = (struct GWC_T *)env;
    (void)instance_name;
    (void)category;
    if (status >= GW_ERROR && w->pending_len + 3 < sizeof(w->pending)) {
        int n = snprintf(w->pending + w->pending_len, sizeof(w->pending) - w->pending_len,
                         "%s%s", w->pending_len ? "; " : "", message);
        if (n > 0) w->pending_len += (size_t)n;
        if (w->pending_len >= sizeof(w->pending)) w->pending_len = sizeof(w->pending) - 1;
    }
    if (w->logger)
        w->logger(w->logger_env,
                  status >= GW_ERROR     ? GYROWHEEL_LOG_ERROR
                  : status >= GW_WARNING ? GYROWHEEL_LOG_WARNING
                                         : GYROWHEEL_LOG_INFO,
                  message);
}

GYROWHEEL_EXPORT const char *GWC(last_error)(const GWC_T *w) {
    if (!w)
        return GWC_FN(last_error) ": no instance (create was given a NULL instance pointer, "
                                  "an allocator without both functions, or ran out of memory)";
    return w->last_error;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(set_logger)(GWC_T *w, gyrowheel_logger logger, void *env) {
    if (!w) return GYROWHEEL_ERR_ARGUMENT;
    w->logger = logger;
    w->logger_env = env;
    gw_set_logging(w->I, GWC_FN(set_logger), logger != NULL, 0, NULL);
    return GYROWHEEL_OK;
}

/* ---- memory: the caller's allocator (or malloc/free) behind the core's ---------------------- */

static void *gwc_malloc(void *ctx, size_t size) {
    (void)ctx;
    return malloc(size ? size : 1);
}
static void gwc_free_default(void *ctx, void *ptr) {
    (void)ctx;
    free(ptr);
}
static void *gwc_core_allocate(void *ctx, size_t n, size_t size) {
    const gyrowheel_allocator *a = (const gyrowheel_allocator *)ctx;
    if (size != 0 && n > (size_t)-1 / size) return NULL;
    return a->allocate(a->ctx, n * size);
}
static void gwc_core_free(void *ctx, void *ptr) {
    const gyrowheel_allocator *a = (const gyrowheel_allocator *)ctx;
    a->free(a->ctx, ptr);
}

static void *gwc_alloc(GWC_T *w, size_t n, size_t size) {
    return gwc_core_allocate(&w->alloc, n ? n : 1, size);
}

GYROWHEEL_EXPORT void GWC(free)(GWC_T *w) {
    gyrowheel_allocator a;
    if (!w) return;
    a = w->alloc;
    gw_instance_free(w->I);
    if (w->p_tmp) a.free(a.ctx, w->p_tmp);
    if (w->s_tmp) a.free(a.ctx, w->s_tmp);
    a.free(a.ctx, w);
}

/* An instance with all its memory, not yet initialised; NULL if out of memory. */
static GWC_T *gwc_new(const gyrowheel_allocator *allocator) {
    static const gyrowheel_allocator malloc_free = {gwc_malloc, gwc_free_default, NULL};
    const gyrowheel_allocator *a = allocator ? allocator : &malloc_free;
    gw_callbacks cb;
    gw_allocator core_alloc;
    GWC_T *w = (GWC_T *)a->allocate(a->ctx, sizeof(GWC_T));
    const gw_model *m = &GW_MODEL;
    if (!w) return NULL;
    memset(w, 0, sizeof(*w));
    w->alloc = *a;
    cb.logger = gwc_core_logger;
    cb.allocate = NULL;
    cb.free = NULL;
    cb.env = w;
    core_alloc.allocate = gwc_core_allocate;
    core_alloc.free = gwc_core_free;
    core_alloc.ctx = &w->alloc; /* lives as long as the instance */
    w->I = gw_instance_new_with(m, m->identifier, &cb, &core_alloc, 0);
    if (!w->I) goto fail;
    w->core_state_size = gw_state_size(w->I);
    w->p_tmp = (double *)gwc_alloc(w, (size_t)m->np, sizeof(double));
    w->s_tmp = (double *)gwc_alloc(w, (size_t)m->ns, sizeof(double));
    if (!w->p_tmp || !w->s_tmp) goto fail;
    return w;
fail:
    GWC(free)(w);
    return NULL;
}

/* ---- initialisation ---------------------------------------------------------------------- */

static gyrowheel_status gwc_check_values(GWC_T *w, const char *fn, gyrowheel_kind kind,
                                         const double *v, const char *what) {
    int i;
    if (!v) return GYROWHEEL_OK;
    for (i = 0; i < GWC_TABLE.count[kind]; i++)
        if (!isfinite(v[i]))
            return gwc_fail(w, GYROWHEEL_ERR_NOT_FINITE, "%s: %s %s is not finite (%g)", fn, what,
                            GWC_TABLE.rows[kind][i].name, v[i]);
    return GYROWHEEL_OK;
}

static gyrowheel_status gwc_check_settings(GWC_T *w, const char *fn, const gyrowheel_settings *s) {
    static const char *const names[3] = {"rel_tol", "abs_tol", "max_step"};
    const double v[3] = {s->rel_tol, s->abs_tol, s->max_step};
    int i;
    if (!isfinite(s->start_time))
        return gwc_fail(w, GYROWHEEL_ERR_NOT_FINITE, "%s: start_time is not finite (%g)", fn,
                        s->start_time);
    if (!gw_solver_available(s->solver)) {
        char valid[256];
        size_t len = 0;
        int k;
        valid[0] = '\0';
        for (k = 0; k < 64 && len < sizeof(valid); k++)
            if (gw_solver_available(k)) {
                int n = snprintf(valid + len, sizeof(valid) - len, "%s%d %s", len ? ", " : "", k,
                                 gw_solver_name(k));
                if (n > 0) len += (size_t)n;
            }
        return gwc_fail(w, GYROWHEEL_ERR_INVALID, "%s: unknown solver %d; valid: %s", fn,
                        s->solver, valid);
    }
    for (i = 0; i < 3; i++) {
        if (!isfinite(v[i]))
            return gwc_fail(w, GYROWHEEL_ERR_NOT_FINITE, "%s: %s is not finite (%g)", fn, names[i],
                            v[i]);
        if (!(v[i] > 0.0) && !(i == 1 && v[i] == 0.0)) /* abs_tol 0: rel_tol / 100 */
            return gwc_fail(w, GYROWHEEL_ERR_INVALID, "%s: %s = %g must be > 0%s", fn, names[i],
                            v[i], i == 1 ? " (or 0: follow rel_tol)" : "");
    }
    if (s->max_internal_steps < 0 || (double)s->max_internal_steps > GW_MAX_INTERNAL_STEPS_MAX)
        return gwc_fail(w, GYROWHEEL_ERR_INVALID,
                        "%s: max_internal_steps = %ld must lie in [1, 2147483647] (or 0: the "
                        "scene's)", fn, s->max_internal_steps);
    return GYROWHEEL_OK;
}

/* A run from these values (NULL: the scene's) at settings->start_time. */
static gyrowheel_status gwc_setup(GWC_T *w, const char *fn, const double *p, const double *s,
                                  const gyrowheel_settings *settings) {
    gw_instance *I = w->I;
    const gw_model *m = I->m;
    gyrowheel_settings st;
    gyrowheel_status r;
    w->ready = 0;
    if (settings)
        st = *settings;
    else
        GWC(default_settings)(&st);
    if ((r = gwc_check_values(w, fn, GYROWHEEL_KIND_PARAMETER, p, "parameter")) < 0) return r;
    if ((r = gwc_check_values(w, fn, GYROWHEEL_KIND_INITIAL, s, "initial value")) < 0) return r;
    if ((r = gwc_check_settings(w, fn, &st)) < 0) return r;
    gw_instance_reset(I); /* the scene's values, set-up phase */
    if (p && m->np > 0) memmove(I->p, p, (size_t)m->np * sizeof(double));
    if (s && m->ns > 0) memmove(I->s, s, (size_t)m->ns * sizeof(double));
    I->solver = st.solver;
    I->rel_tol = st.rel_tol;
    I->abs_tol = st.abs_tol;
    I->max_step = st.max_step;
    if (st.max_internal_steps > 0) I->max_internal_steps = (double)st.max_internal_steps;
    if (gw_setup_experiment(I, fn, 0, 0.0, st.start_time, 0, 0.0) != GW_OK)
        return gwc_fail_core(w, GYROWHEEL_ERR_INVALID, "experiment set-up failed");
    if (gw_initialize(I, fn) > GW_WARNING)
        return gwc_fail_core(w, GYROWHEEL_ERR_INVALID, "initialisation failed");
    w->ready = 1;
    return GYROWHEEL_OK;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(reset)(GWC_T *w, const double *parameters,
                                             const double *initial,
                                             const gyrowheel_settings *settings) {
    if (!w) return GYROWHEEL_ERR_ARGUMENT;
    gwc_begin(w);
    return gwc_setup(w, GWC_FN(reset), parameters, initial, settings);
}

static gyrowheel_status gwc_create(const gyrowheel_allocator *allocator, GWC_T **instance) {
    if (!instance) return GYROWHEEL_ERR_ARGUMENT;
    *instance = NULL;
    if (allocator && (!allocator->allocate || !allocator->free)) return GYROWHEEL_ERR_ARGUMENT;
    *instance = gwc_new(allocator);
    if (!*instance) return GYROWHEEL_ERR_MEMORY;
    return GYROWHEEL_OK;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(create)(const double *parameters, const double *initial,
                                              const gyrowheel_settings *settings,
                                              const gyrowheel_allocator *allocator,
                                              GWC_T **instance) {
    gyrowheel_status r = gwc_create(allocator, instance);
    if (r < 0) return r;
    return gwc_setup(*instance, GWC_FN(create), parameters, initial, settings);
}

/* ---- by name -------------------------------------------------------------------------------- */

/* settings by name: solver, rel_tol, abs_tol, max_step, max_internal_steps (the model's
 * GW_VAR_SETTING variables) and start_time; 0 if `name` is none of them */
static int gwc_named_setting(GWC_T *w, const char *fn, gyrowheel_settings *st, const char *name,
                             double value, gyrowheel_status *r) {
    *r = GYROWHEEL_OK;
    if (strcmp(name, "start_time") == 0) {
        st->start_time = value;
        return 1;
    }
    if (strcmp(name, "solver") == 0) {
        if (!(value >= 0.0 && value <= 1000.0) || value != floor(value))
            *r = gwc_fail(w, isfinite(value) ? GYROWHEEL_ERR_INVALID : GYROWHEEL_ERR_NOT_FINITE,
                          "%s: solver %g is not a solver code (gyrowheel_solver)", fn, value);
        else
            st->solver = (int)value;
        return 1;
    }
    if (strcmp(name, "rel_tol") == 0) {
        st->rel_tol = value;
        return 1;
    }
    if (strcmp(name, "abs_tol") == 0) {
        st->abs_tol = value;
        return 1;
    }
    if (strcmp(name, "max_step") == 0) {
        st->max_step = value;
        return 1;
    }
    if (strcmp(name, "max_internal_steps") == 0) {
        if (!(value >= 0.0 && value <= GW_MAX_INTERNAL_STEPS_MAX) || value != floor(value))
            *r = gwc_fail(w, isfinite(value) ? GYROWHEEL_ERR_INVALID : GYROWHEEL_ERR_NOT_FINITE,
                          "%s: max_internal_steps = %g must be a whole number in [1, 2147483647] "
                          "(or 0: the scene's)", fn, value);
        else
            st->max_internal_steps = (long)value;
        return 1;
    }
    return 0;
}

/* "M, R, ..." of a kind into buf */
static void gwc_name_list(char *buf, size_t size, gyrowheel_kind kind) {
    size_t len = 0;
    int i;
    buf[0] = '\0';
    for (i = 0; i < GWC_TABLE.count[kind] && len + 1 < size; i++) {
        int n = snprintf(buf + len, size - len, "%s%s", i ? ", " : "",
                         GWC_TABLE.rows[kind][i].name);
        if (n > 0) len += (size_t)n;
    }
}

static gyrowheel_status gwc_unknown_name(GWC_T *w, const char *fn, const char *name) {
    char params[400], initial[400];
    gwc_name_list(params, sizeof(params), GYROWHEEL_KIND_PARAMETER);
    gwc_name_list(initial, sizeof(initial), GYROWHEEL_KIND_INITIAL);
    return gwc_fail(w, GYROWHEEL_ERR_NAME,
                    "%s: unknown name \"%s\"; parameters: %s; initial values: %s; settings: "
                    "solver, rel_tol, abs_tol, max_step, max_internal_steps, start_time",
                    fn, name, params, initial);
}

static gyrowheel_status gwc_setup_named(GWC_T *w, const char *fn, size_t n,
                                        const char *const *names, const double *values) {
    gyrowheel_settings st;
    gyrowheel_status r;
    size_t k, j;
    w->ready = 0;
    if (n > 0 && (!names || !values))
        return gwc_fail(w, GYROWHEEL_ERR_ARGUMENT, "%s: names or values is NULL with n = %lu", fn,
                        (unsigned long)n);
    GWC(default_parameters)(w->p_tmp);
    GWC(default_initial)(w->s_tmp);
    GWC(default_settings)(&st);
    for (k = 0; k < n; k++) {
        int i;
        if (!names[k]) return gwc_fail(w, GYROWHEEL_ERR_ARGUMENT, "%s: names[%lu] is NULL", fn,
                                       (unsigned long)k);
        for (j = 0; j < k; j++)
            if (strcmp(names[j], names[k]) == 0)
                return gwc_fail(w, GYROWHEEL_ERR_ARGUMENT, "%s: \"%s\" is given twice", fn,
                                names[k]);
        if ((i = GWC(index)(GYROWHEEL_KIND_PARAMETER, names[k])) >= 0)
            w->p_tmp[i] = values[k];
        else if ((i = GWC(index)(GYROWHEEL_KIND_INITIAL, names[k])) >= 0)
            w->s_tmp[i] = values[k];
        else if (gwc_named_setting(w, fn, &st, names[k], values[k], &r)) {
            if (r < 0) return r;
        } else
            return gwc_unknown_name(w, fn, names[k]);
    }
    return gwc_setup(w, fn, w->p_tmp, w->s_tmp, &st);
}

GYROWHEEL_EXPORT gyrowheel_status GWC(reset_named)(GWC_T *w, size_t n, const char *const *names,
                                                   const double *values) {
    if (!w) return GYROWHEEL_ERR_ARGUMENT;
    gwc_begin(w);
    return gwc_setup_named(w, GWC_FN(reset_named), n, names, values);
}

GYROWHEEL_EXPORT gyrowheel_status GWC(create_named)(size_t n, const char *const *names,
                                                    const double *values,
                                                    const gyrowheel_allocator *allocator,
                                                    GWC_T **instance) {
    gyrowheel_status r = gwc_create(allocator, instance);
    if (r < 0) return r;
    return gwc_setup_named(*instance, GWC_FN(create_named), n, names, values);
}

/* ---- the calls of a run ------------------------------------------------------------------- */

static gyrowheel_status gwc_set_input(GWC_T *w, const char *fn, int index, double value) {
    gw_variable v;
    if (!isfinite(value))
        return gwc_fail(w, GYROWHEEL_ERR_NOT_FINITE, "%s: input %s is not finite (%g)", fn,
                        GWC_TABLE.rows[GYROWHEEL_KIND_INPUT][index].name, value);
    memset(&v, 0, sizeof(v));
    v.kind = GW_VAR_INPUT;
    v.index = index;
    gw_value_set(w->I, &v, value);
    return GYROWHEEL_OK;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(set_input)(GWC_T *w, int index, double value) {
    GWC_REQUIRE_READY(w, GWC_FN(set_input));
    if (index < 0 || index >= GWC_TABLE.count[GYROWHEEL_KIND_INPUT])
        return gwc_fail(w, GYROWHEEL_ERR_ARGUMENT, "%s: input index %d out of range 0..%d",
                        GWC_FN(set_input), index, GWC_TABLE.count[GYROWHEEL_KIND_INPUT] - 1);
    return gwc_set_input(w, GWC_FN(set_input), index, value);
}

GYROWHEEL_EXPORT gyrowheel_status GWC(set_input_by_name)(GWC_T *w, const char *name,
                                                         double value) {
    int i;
    GWC_REQUIRE_READY(w, GWC_FN(set_input_by_name));
    if (!name) return gwc_null(w, GWC_FN(set_input_by_name), "name");
    i = GWC(index)(GYROWHEEL_KIND_INPUT, name);
    if (i < 0) {
        char valid[400];
        gwc_name_list(valid, sizeof(valid), GYROWHEEL_KIND_INPUT);
        return gwc_fail(w, GYROWHEEL_ERR_NAME, "%s: no input \"%s\"; inputs: %s",
                        GWC_FN(set_input_by_name), name, valid[0] ? valid : "none");
    }
    return gwc_set_input(w, GWC_FN(set_input_by_name), i, value);
}

GYROWHEEL_EXPORT gyrowheel_status GWC(set_inputs)(GWC_T *w, const double *inputs) {
    int i;
    gyrowheel_status r;
    GWC_REQUIRE_READY(w, GWC_FN(set_inputs));
    if (GWC_TABLE.count[GYROWHEEL_KIND_INPUT] == 0) return GYROWHEEL_OK;
    if (!inputs) return gwc_null(w, GWC_FN(set_inputs), "inputs");
    if ((r = gwc_check_values(w, GWC_FN(set_inputs), GYROWHEEL_KIND_INPUT, inputs, "input")) < 0)
        return r;
    for (i = 0; i < GWC_TABLE.count[GYROWHEEL_KIND_INPUT]; i++)
        gwc_set_input(w, GWC_FN(set_inputs), i, inputs[i]);
    return GYROWHEEL_OK;
}

static const char *gwc_fired_terminating(const gw_instance *I) {
    int i;
    for (i = 0; i < I->m->ne; i++)
        if (gw_event_ended(I, i))
            return GWC_TABLE.rows[GYROWHEEL_KIND_EVENT][i].name;
    return "?";
}

GYROWHEEL_EXPORT gyrowheel_status GWC(advance)(GWC_T *w, double t) {
    gw_instance *I;
    unsigned long long events;
    gw_status r;
    GWC_REQUIRE_READY(w, GWC_FN(advance));
    I = w->I;
    gwc_begin(w);
    if (!isfinite(t))
        return gwc_fail(w, GYROWHEEL_ERR_TIME, "%s: time %g is not finite", GWC_FN(advance), t);
    if (I->terminated)
        return gwc_fail(w, GYROWHEEL_ERR_TERMINATED,
                        "%s: the run ended at t=%.17g (%s); reset or restore a saved state",
                        GWC_FN(advance), I->t, gwc_fired_terminating(I));
    if (t < I->t)
        return gwc_fail(w, GYROWHEEL_ERR_TIME,
                        "%s: cannot advance backwards, from t=%.17g to %.17g", GWC_FN(advance),
                        I->t, t);
    if (t == I->t) return GYROWHEEL_OK;
    events = I->n_events;
    r = gw_advance(I, GWC_FN(advance), t);
    if (r == GW_OK) return I->n_events > events ? GYROWHEEL_FIRED : GYROWHEEL_OK;
    if (r == GW_DISCARD) return GYROWHEEL_TERMINATED;
    return gwc_fail_core(w, GYROWHEEL_ERR_SIMULATION, "integration failed");
}

GYROWHEEL_EXPORT double GWC(time)(const GWC_T *w) { return w ? w->I->t : NAN; }

GYROWHEEL_EXPORT int GWC(terminated)(const GWC_T *w) { return (w && w->I->terminated) ? 1 : 0; }

/* ---- reading ------------------------------------------------------------------------------- */

GYROWHEEL_EXPORT gyrowheel_status GWC(get_states)(const GWC_T *w, double *states) {
    GWC_REQUIRE_READY(w, GWC_FN(get_states));
    if (!states) return gwc_null(w, GWC_FN(get_states), "states");
    if (w->I->m->nx > 0) memcpy(states, w->I->x, (size_t)w->I->m->nx * sizeof(double));
    return GYROWHEEL_OK;
}

/* I->y current */
static gyrowheel_status gwc_outputs_current(GWC_T *w, const char *fn) {
    gwc_begin(w);
    if (gw_update_outputs(w->I, fn) != GW_OK)
        return gwc_fail_core(w, GYROWHEEL_ERR_SIMULATION, "evaluation of the outputs failed");
    return GYROWHEEL_OK;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(get_outputs)(GWC_T *w, double *outputs) {
    gyrowheel_status r;
    int i;
    GWC_REQUIRE_READY(w, GWC_FN(get_outputs));
    if (!outputs) return gwc_null(w, GWC_FN(get_outputs), "outputs");
    if ((r = gwc_outputs_current(w, GWC_FN(get_outputs))) < 0) return r;
    for (i = 0; i < GWC_TABLE.count[GYROWHEEL_KIND_OUTPUT]; i++)
        outputs[i] = w->I->y[GWC_TABLE.output_y[i]];
    return GYROWHEEL_OK;
}

static gyrowheel_status gwc_get(GWC_T *w, const char *fn, gyrowheel_kind kind, int i, double *v) {
    const gw_instance *I = w->I;
    gyrowheel_status r;
    switch (kind) {
    case GYROWHEEL_KIND_PARAMETER: *v = I->p[i]; break;
    case GYROWHEEL_KIND_INITIAL: *v = I->s[i]; break;
    case GYROWHEEL_KIND_INPUT: *v = I->u[i]; break;
    case GYROWHEEL_KIND_STATE: *v = I->x[i]; break;
    case GYROWHEEL_KIND_OUTPUT:
        if ((r = gwc_outputs_current(w, fn)) < 0) return r;
        *v = I->y[GWC_TABLE.output_y[i]];
        break;
    case GYROWHEEL_KIND_EVENT: *v = I->flags[i] ? 1.0 : 0.0; break;
    default: return GYROWHEEL_ERR_ARGUMENT;
    }
    return GYROWHEEL_OK;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(get)(GWC_T *w, gyrowheel_kind kind, int index,
                                           double *value) {
    const int n = GWC(count)(kind);
    GWC_REQUIRE_READY(w, GWC_FN(get));
    if (!value) return gwc_null(w, GWC_FN(get), "value");
    if (n < 0)
        return gwc_fail(w, GYROWHEEL_ERR_ARGUMENT, "%s: unknown kind %d", GWC_FN(get), (int)kind);
    if (index < 0 || index >= n)
        return gwc_fail(w, GYROWHEEL_ERR_ARGUMENT, "%s: index %d out of range 0..%d for kind %d",
                        GWC_FN(get), index, n - 1, (int)kind);
    return gwc_get(w, GWC_FN(get), kind, index, value);
}

GYROWHEEL_EXPORT gyrowheel_status GWC(get_by_name)(GWC_T *w, const char *name, double *value) {
    static const gyrowheel_kind order[5] = {GYROWHEEL_KIND_OUTPUT, GYROWHEEL_KIND_STATE,
                                            GYROWHEEL_KIND_INPUT, GYROWHEEL_KIND_PARAMETER,
                                            GYROWHEEL_KIND_EVENT};
    int k;
    GWC_REQUIRE_READY(w, GWC_FN(get_by_name));
    if (!name || !value)
        return gwc_null(w, GWC_FN(get_by_name), "name or value");
    for (k = 0; k < 5; k++) {
        int i = GWC(index)(order[k], name);
        if (i >= 0) return gwc_get(w, GWC_FN(get_by_name), order[k], i, value);
    }
    return gwc_fail(w, GYROWHEEL_ERR_NAME,
                    "%s: no output, state, input, parameter or event \"%s\" (%s_variable lists "
                    "them)",
                    GWC_FN(get_by_name), name, GWC_STR(GW_CAPI_MODEL));
}

GYROWHEEL_EXPORT gyrowheel_status GWC(get_event)(const GWC_T *w, int index, int *fired,
                                                 double *time) {
    const gw_instance *I;
    GWC_REQUIRE_READY(w, GWC_FN(get_event));
    I = w->I;
    if (index < 0 || index >= I->m->ne)
        return gwc_fail(w, GYROWHEEL_ERR_ARGUMENT, "%s: event index %d out of range 0..%d",
                        GWC_FN(get_event), index, I->m->ne - 1);
    if (fired) *fired = I->flags[index] ? 1 : 0;
    if (time) *time = I->flags[index] ? I->t_events[index] : NAN;
    return GYROWHEEL_OK;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(get_statistics)(const GWC_T *w,
                                                      gyrowheel_statistics *statistics) {
    if (!w) return GYROWHEEL_ERR_ARGUMENT;
    if (!statistics)
        return gwc_null(w, GWC_FN(get_statistics), "statistics");
    statistics->rhs_evaluations = w->I->n_rhs;
    statistics->steps_accepted = w->I->n_accepted;
    statistics->steps_rejected = w->I->n_rejected;
    statistics->events = w->I->n_events;
    return GYROWHEEL_OK;
}

#endif /* GW_UNITY_BUILD */
