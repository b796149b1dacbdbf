/*
 * gw_fmi2.c -- the FMI 2.0 Co-Simulation interface: instance life cycle, state
 * machine, variable access through GW_MODEL.vars, initialisation, fmi2DoStep and
 * the status functions.  The FMU-state functions are in gw_state.c.  The Model
 * Exchange functions exist (every fmi2* function of fmi2Functions.h is exported)
 * but return fmi2Error.
 */
#include <math.h>
#include <string.h>

#include "gw_instance.h"
#include "gw_solver.h"

/* ---- states in which each function may be called ------------------------- */
#define ST_ANY                                                                              \
    (GW_ST_INSTANTIATED | GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED |      \
     GW_ST_TERMINATED | GW_ST_ERROR)
#define ST_BEFORE_INIT_END (GW_ST_INSTANTIATED | GW_ST_INIT_MODE)
#define MASK_SetDebugLogging ST_ANY
#define MASK_Reset ST_ANY
#define MASK_SetupExperiment GW_ST_INSTANTIATED
#define MASK_EnterInitializationMode GW_ST_INSTANTIATED
#define MASK_ExitInitializationMode GW_ST_INIT_MODE
#define MASK_Terminate (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED)
#define MASK_Get ST_ANY
#define MASK_Set (GW_ST_INSTANTIATED | GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE)
#define MASK_DoStep GW_ST_STEP_COMPLETE
#define MASK_Status (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_TERMINATED | GW_ST_ERROR)
#define MASK_NotSupported ST_ANY

static const char *state_name(int state) {
    switch (state) {
    case GW_ST_INSTANTIATED: return "Instantiated";
    case GW_ST_INIT_MODE: return "InitializationMode";
    case GW_ST_STEP_COMPLETE: return "StepComplete";
    case GW_ST_STEP_FAILED: return "StepFailed";
    case GW_ST_TERMINATED: return "Terminated";
    case GW_ST_ERROR: return "Error";
    case GW_ST_FATAL: return "Fatal";
    default: return "?";
    }
}

int gw_begin(gw_instance *I, const char *fn, int mask) {
    if (!I) return 0;
    if (!(I->state & mask)) {
        GW_ERROR(I, "%s: illegal call in state %s", fn, state_name(I->state));
        if (I->state != GW_ST_FATAL) I->state = GW_ST_ERROR;
        return 0;
    }
    return 1;
}

fmi2Status gw_end(gw_instance *I, fmi2Status status) {
    if (status == fmi2Fatal)
        I->state = GW_ST_FATAL;
    else if (status == fmi2Error)
        I->state = GW_ST_ERROR;
    return status;
}

/* BEGIN/END frame of every fmi2 function: check the state, keep the worst status. */
#define BEGIN(fn, mask)                                                                     \
    gw_instance *I = (gw_instance *)c;                                                      \
    fmi2Status status = fmi2OK;                                                             \
    if (!gw_begin(I, fn, mask)) return fmi2Error;                                           \
    if (0) goto END
#define CHECK(expr)                                                                         \
    do {                                                                                    \
        status = gw_worst(status, (expr));                                                  \
        if (status > fmi2Warning) goto END;                                                 \
    } while (0)
#define FAIL(...)                                                                           \
    do {                                                                                    \
        GW_ERROR(I, __VA_ARGS__);                                                           \
        status = fmi2Error;                                                                 \
        goto END;                                                                           \
    } while (0)
#define END_FUNCTION()                                                                      \
    END:                                                                                    \
    return gw_end(I, status)

/* ---- variables ---------------------------------------------------------------- */

static const gw_variable *find_var(const gw_model *m, fmi2ValueReference vr) {
    int lo = 0, hi = m->n_vars - 1;
    while (lo <= hi) {
        int mid = lo + (hi - lo) / 2;
        unsigned int v = m->vars[mid].vr;
        if (v == vr) return &m->vars[mid];
        if (v < vr)
            lo = mid + 1;
        else
            hi = mid - 1;
    }
    return NULL;
}

static const char *type_name(int type) {
    switch (type) {
    case GW_REAL: return "Real";
    case GW_INTEGER: return "Integer";
    case GW_BOOLEAN: return "Boolean";
    case GW_ENUM: return "Enumeration";
    default: return "?";
    }
}

/* name of the variable of a kind/index (for messages), or NULL */
static const char *name_of(const gw_model *m, int kind, int index) {
    int i;
    for (i = 0; i < m->n_vars; i++)
        if ((int)m->vars[i].kind == kind && m->vars[i].index == index) return m->vars[i].name;
    return NULL;
}

/* Look up vr and check that it is accessed through the right fmi2Get/SetXXX. */
static const gw_variable *lookup(gw_instance *I, const char *fn, fmi2ValueReference vr,
                                 int want_type) {
    const gw_variable *v = find_var(I->m, vr);
    int ok;
    if (!v) {
        GW_ERROR(I, "%s: unknown value reference %u", fn, vr);
        return NULL;
    }
    ok = want_type == GW_INTEGER ? (v->type == GW_INTEGER || v->type == GW_ENUM)
                                 : (int)v->type == want_type;
    if (!ok) {
        GW_ERROR(I, "%s: variable %s (vr=%u) is of type %s", fn, v->name, vr,
                 type_name(v->type));
        return NULL;
    }
    return v;
}

static int before_init_end(const gw_instance *I) {
    return (I->state & ST_BEFORE_INIT_END) != 0;
}

/* Make I->y hold the outputs at the current point.  Before initialisation ends
 * they are computed on the fly from x = init(s, p). */
static fmi2Status update_outputs(gw_instance *I, const char *fn) {
    const gw_model *m = I->m;
    int i;
    if (before_init_end(I)) {
        if (gw_eval_init(I, I->x) != 0 || gw_eval_out(I, I->t, I->x, I->y) != 0) {
            GW_ERROR(I, "%s: evaluation of the initial outputs failed", fn);
            return fmi2Error;
        }
        for (i = 0; i < m->ny; i++)
            if (!isfinite(I->y[i])) {
                const char *nm = name_of(m, GW_VAR_OUTPUT, i);
                gw_log(I, fmi2Warning, GW_LOG_WARNING,
                       "%s: initial value of output %s is not finite (check the parameters)",
                       fn, nm ? nm : "?");
                return fmi2Warning;
            }
        return fmi2OK;
    }
    if (I->y_valid) return fmi2OK;
    if (gw_eval_out(I, I->t, I->x, I->y) != 0) {
        GW_ERROR(I, "%s: evaluation of the outputs failed at t=%.17g", fn, I->t);
        return fmi2Error;
    }
    for (i = 0; i < m->ny; i++)
        if (!isfinite(I->y[i])) {
            const char *nm = name_of(m, GW_VAR_OUTPUT, i);
            GW_ERROR(I, "%s: output %s is not finite (%g) at t=%.17g", fn, nm ? nm : "?",
                     I->y[i], I->t);
            return fmi2Error;
        }
    I->y_valid = 1;
    return fmi2OK;
}

static int needs_outputs(const gw_instance *I, const fmi2ValueReference vr[], size_t nvr) {
    size_t k;
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = find_var(I->m, vr[k]);
        if (!v) continue;
        if (v->kind == GW_VAR_OUTPUT) return 1;
        if (v->kind == GW_VAR_START && v->out_index >= 0 && !before_init_end(I)) return 1;
    }
    return 0;
}

static double setting_value(const gw_instance *I, int index) {
    switch (index) {
    case GW_SET_SOLVER: return (double)I->solver;
    case GW_SET_REL_TOL: return I->rel_tol;
    case GW_SET_ABS_TOL: return I->abs_tol;
    case GW_SET_MAX_STEP: return I->max_step;
    default: return 0.0;
    }
}

static double value_of(const gw_instance *I, const gw_variable *v) {
    switch (v->kind) {
    case GW_VAR_PARAM: return I->p[v->index];
    case GW_VAR_START:
        return (before_init_end(I) || v->out_index < 0) ? I->s[v->index] : I->y[v->out_index];
    case GW_VAR_INPUT: return I->u[v->index];
    case GW_VAR_OUTPUT: return I->y[v->index];
    case GW_VAR_SETTING: return setting_value(I, v->index);
    case GW_VAR_EVENT: return I->flags[v->index] ? 1.0 : 0.0;
    default: return 0.0;
    }
}

/* Check that v may be set now; the value is already known to be valid. */
static int settable(gw_instance *I, const char *fn, const gw_variable *v) {
    int ok;
    switch (v->kind) {
    case GW_VAR_PARAM:
        ok = v->tunable ? (I->state & MASK_Set) != 0 : before_init_end(I);
        break;
    case GW_VAR_START:
    case GW_VAR_SETTING: ok = before_init_end(I); break;
    case GW_VAR_INPUT: ok = (I->state & MASK_Set) != 0; break;
    default:
        GW_ERROR(I, "%s: variable %s (vr=%u) is read-only", fn, v->name, v->vr);
        return 0;
    }
    if (!ok)
        GW_ERROR(I, "%s: variable %s (vr=%u) cannot be set in state %s", fn, v->name, v->vr,
                 state_name(I->state));
    return ok;
}

static void store(gw_instance *I, const gw_variable *v, double value) {
    switch (v->kind) {
    case GW_VAR_PARAM:
        I->p[v->index] = value;
        if (!before_init_end(I)) { /* tunable parameter during the simulation */
            I->y_valid = 0;
            I->fcur_valid = 0;
            gw_eval_nom(I, I->nominal);
        }
        break;
    case GW_VAR_START: I->s[v->index] = value; break;
    case GW_VAR_INPUT:
        I->u[v->index] = value;
        I->y_valid = 0;
        I->fcur_valid = 0;
        break;
    case GW_VAR_SETTING:
        switch (v->index) {
        case GW_SET_SOLVER: I->solver = (int)value; break;
        case GW_SET_REL_TOL: I->rel_tol = value; break;
        case GW_SET_ABS_TOL: I->abs_tol = value; break;
        case GW_SET_MAX_STEP: I->max_step = value; break;
        default: break;
        }
        break;
    default: break;
    }
}

#define CHECK_ARRAYS(fn, vr, nvr, value)                                                    \
    if ((nvr) > 0 && (!(vr) || !(value))) FAIL("%s: NULL array for %lu values", fn,        \
                                                (unsigned long)(nvr))

/* ---- inquire version numbers and set debug logging ----------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    BEGIN("fmi2SetDebugLogging", MASK_SetDebugLogging);
    CHECK(gw_set_debug_logging(I, loggingOn, nCategories, categories));
    END_FUNCTION();
}

/* ---- creation and destruction ---------------------------------------------- */

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    const gw_model *m = &GW_MODEL;
    gw_instance *I;
    gw_callbacks cb;
    const char *name = instanceName ? instanceName : "";
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions) return NULL;
    cb.logger = functions->logger;
    cb.allocateMemory = functions->allocateMemory;
    cb.freeMemory = functions->freeMemory;
    cb.componentEnvironment = functions->componentEnvironment;
    if (!functions->allocateMemory || !functions->freeMemory) {
        gw_log_cb(&cb, name, fmi2Error, "logStatusError",
                  "fmi2Instantiate: allocateMemory and freeMemory callbacks are required");
        return NULL;
    }
    if (!instanceName || instanceName[0] == '\0') {
        gw_log_cb(&cb, name, fmi2Error, "logStatusError",
                  "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        gw_log_cb(&cb, name, fmi2Error, "logStatusError",
                  "fmi2Instantiate: %s supports Co-Simulation only (fmuType=%d)",
                  m->identifier, (int)fmuType);
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, m->token) != 0) {
        gw_log_cb(&cb, name, fmi2Error, "logStatusError",
                  "fmi2Instantiate: GUID \"%s\" does not match the model's \"%s\"",
                  fmuGUID ? fmuGUID : "(null)", m->token);
        return NULL;
    }
    if (!m->ode.eval || !m->init.eval || (m->ny > 0 && !m->out.eval) ||
        (m->ne > 0 && !m->evt.eval) || (m->nc > 0 && !m->chk.eval)) {
        gw_log_cb(&cb, name, fmi2Error, "logStatusError",
                  "fmi2Instantiate: model %s lacks a required function", m->identifier);
        return NULL;
    }
    I = gw_instance_new(m, name, functions, loggingOn);
    if (!I) {
        gw_log_cb(&cb, name, fmi2Error, "logStatusError",
                  "fmi2Instantiate: out of memory");
        return NULL;
    }
    return (fmi2Component)I;
}

void fmi2FreeInstance(fmi2Component c) { gw_instance_free((gw_instance *)c); }

/* ---- initialisation, termination and reset ------------------------------- */

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    BEGIN("fmi2SetupExperiment", MASK_SetupExperiment);
    if (!isfinite(startTime)) FAIL("fmi2SetupExperiment: startTime is not finite");
    if (toleranceDefined) {
        if (!(tolerance > 0.0) || !isfinite(tolerance))
            FAIL("fmi2SetupExperiment: tolerance %g must be finite and > 0", tolerance);
        /* overrides rel_tol, also when rel_tol is set later (applied at init) */
        I->rel_tol = tolerance;
        I->tol_defined = 1;
        I->tolerance = tolerance;
    }
    if (stopTimeDefined) {
        if (!isfinite(stopTime) || stopTime < startTime)
            FAIL("fmi2SetupExperiment: stopTime %g must be finite and >= startTime %g",
                 stopTime, startTime);
    }
    I->t_start = startTime;
    I->t = startTime;
    if (!toleranceDefined) I->tol_defined = 0;
    I->stop_defined = stopTimeDefined ? 1 : 0;
    I->t_stop = stopTimeDefined ? stopTime : 0.0;
    END_FUNCTION();
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    BEGIN("fmi2EnterInitializationMode", MASK_EnterInitializationMode);
    I->state = GW_ST_INIT_MODE;
    END_FUNCTION();
}

static int check_finite_vec(gw_instance *I, const double *v, int n, int kind, const char *what) {
    int i, ok = 1;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) {
            const char *nm = name_of(I->m, kind, i);
            GW_ERROR(I, "fmi2ExitInitializationMode: %s %s is not finite (%g)", what,
                     nm ? nm : "?", v[i]);
            ok = 0;
        }
    return ok;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    const gw_model *m;
    int i, ok;
    BEGIN("fmi2ExitInitializationMode", MASK_ExitInitializationMode);
    m = I->m;
    ok = check_finite_vec(I, I->p, m->np, GW_VAR_PARAM, "parameter");
    ok &= check_finite_vec(I, I->s, m->ns, GW_VAR_START, "start value");
    ok &= check_finite_vec(I, I->u, m->nu, GW_VAR_INPUT, "input");
    if (!ok) FAIL("fmi2ExitInitializationMode: non-finite values");
    /* settings */
    if (I->tol_defined) I->rel_tol = I->tolerance;
    if (I->solver == GW_SOLVER_ROSENBROCK)
        FAIL("fmi2ExitInitializationMode: solver rosenbrock not available");
    if (I->solver != GW_SOLVER_EULER && I->solver != GW_SOLVER_RK4 &&
        I->solver != GW_SOLVER_DOPRI5)
        FAIL("fmi2ExitInitializationMode: unknown solver %d", I->solver);
    if (!(I->rel_tol > 0.0) || !isfinite(I->rel_tol))
        FAIL("fmi2ExitInitializationMode: rel_tol = %g must be finite and > 0", I->rel_tol);
    if (!(I->abs_tol > 0.0) || !isfinite(I->abs_tol))
        FAIL("fmi2ExitInitializationMode: abs_tol = %g must be finite and > 0", I->abs_tol);
    if (!(I->max_step > 0.0) || !isfinite(I->max_step))
        FAIL("fmi2ExitInitializationMode: max_step = %g must be finite and > 0", I->max_step);
    /* validity checks of the model */
    if (m->nc > 0) {
        if (gw_eval_chk(I, I->c) != 0)
            FAIL("fmi2ExitInitializationMode: evaluation of the validity checks failed");
        ok = 1;
        for (i = 0; i < m->nc; i++)
            if (!(I->c[i] > 0.0)) {
                GW_ERROR(I, "fmi2ExitInitializationMode: %s (check value %g)",
                         (m->check_messages && m->check_messages[i]) ? m->check_messages[i]
                                                                     : "validity check failed",
                         I->c[i]);
                ok = 0;
            }
        if (!ok) {
            status = fmi2Error;
            goto END;
        }
    }
    /* nominal values, initial state, outputs, event indicators */
    if (gw_eval_nom(I, I->nominal) != 0)
        FAIL("fmi2ExitInitializationMode: evaluation of the state nominals failed");
    for (i = 0; i < m->nx; i++)
        if (!(I->nominal[i] > 0.0) || !isfinite(I->nominal[i]))
            FAIL("fmi2ExitInitializationMode: nominal of state %s is %g (must be finite, > 0)",
                 m->x_names ? m->x_names[i] : "?", I->nominal[i]);
    if (gw_eval_init(I, I->x) != 0)
        FAIL("fmi2ExitInitializationMode: evaluation of the initial state failed");
    for (i = 0; i < m->nx; i++)
        if (!isfinite(I->x[i]))
            FAIL("fmi2ExitInitializationMode: initial state %s is not finite (%g)",
                 m->x_names ? m->x_names[i] : "?", I->x[i]);
    I->state = GW_ST_STEP_COMPLETE; /* from here on y is the simulation's output */
    I->y_valid = 0;
    CHECK(update_outputs(I, "fmi2ExitInitializationMode"));
    if (gw_rhs(I, I->t, I->x, I->k[0]) != 0)
        FAIL("fmi2ExitInitializationMode: evaluation of the right-hand side failed");
    for (i = 0; i < m->nx; i++)
        if (!isfinite(I->k[0][i]))
            FAIL("fmi2ExitInitializationMode: derivative of state %s is not finite (%g)",
                 m->x_names ? m->x_names[i] : "?", I->k[0][i]);
    I->fcur_valid = 1;
    if (m->ne > 0 && gw_eval_evt(I, I->t, I->x, I->e) != 0)
        FAIL("fmi2ExitInitializationMode: evaluation of the event indicators failed");
    /* An event whose condition holds already at the start cannot be crossed later:
     * a terminating one means an invalid initial state, a warning one is flagged now. */
    for (i = 0; i < m->ne; i++) {
        I->flags[i] = 0;
        if (I->e[i] > 0.0) continue;
        if (m->event_actions && m->event_actions[i] == GW_EVENT_WARN) {
            I->flags[i] = 1;
            gw_log(I, fmi2Warning, GW_LOG_EVENTS, "warning: event %s holds already at the start t=%.17g",
                   m->event_names ? m->event_names[i] : "?", I->t);
        } else {
            FAIL("fmi2ExitInitializationMode: the initial state already triggers event %s "
                 "(indicator %g <= 0)", m->event_names ? m->event_names[i] : "?", I->e[i]);
        }
    }
    I->terminated = 0;
    I->h_adapt = 0.0;
    I->last_successful_time = I->t;
    I->last_dostep_status = fmi2OK;
    I->n_rhs = I->n_accepted = I->n_rejected = I->n_evt = I->n_events = 0;
    END_FUNCTION();
}

fmi2Status fmi2Terminate(fmi2Component c) {
    BEGIN("fmi2Terminate", MASK_Terminate);
    I->state = GW_ST_TERMINATED;
    END_FUNCTION();
}

fmi2Status fmi2Reset(fmi2Component c) {
    BEGIN("fmi2Reset", MASK_Reset);
    gw_instance_defaults(I);
    END_FUNCTION();
}

/* ---- getting and setting variable values ------------------------------------ */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    size_t k;
    BEGIN("fmi2GetReal", MASK_Get);
    CHECK_ARRAYS("fmi2GetReal", vr, nvr, value);
    if (needs_outputs(I, vr, nvr)) CHECK(update_outputs(I, "fmi2GetReal"));
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = lookup(I, "fmi2GetReal", vr[k], GW_REAL);
        if (!v) {
            status = fmi2Error;
            goto END;
        }
        value[k] = value_of(I, v);
    }
    END_FUNCTION();
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    size_t k;
    BEGIN("fmi2GetInteger", MASK_Get);
    CHECK_ARRAYS("fmi2GetInteger", vr, nvr, value);
    if (needs_outputs(I, vr, nvr)) CHECK(update_outputs(I, "fmi2GetInteger"));
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = lookup(I, "fmi2GetInteger", vr[k], GW_INTEGER);
        double d;
        if (!v) {
            status = fmi2Error;
            goto END;
        }
        d = value_of(I, v);
        value[k] = isfinite(d) ? (fmi2Integer)floor(d + 0.5) : 0;
    }
    END_FUNCTION();
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    size_t k;
    BEGIN("fmi2GetBoolean", MASK_Get);
    CHECK_ARRAYS("fmi2GetBoolean", vr, nvr, value);
    if (needs_outputs(I, vr, nvr)) CHECK(update_outputs(I, "fmi2GetBoolean"));
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = lookup(I, "fmi2GetBoolean", vr[k], GW_BOOLEAN);
        if (!v) {
            status = fmi2Error;
            goto END;
        }
        value[k] = value_of(I, v) != 0.0 ? fmi2True : fmi2False;
    }
    END_FUNCTION();
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    BEGIN("fmi2GetString", MASK_Get);
    (void)value;
    if (nvr > 0)
        FAIL("fmi2GetString: unknown value reference %u (the model has no String variables)",
             vr ? vr[0] : 0u);
    END_FUNCTION();
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    size_t k;
    BEGIN("fmi2SetReal", MASK_Set);
    CHECK_ARRAYS("fmi2SetReal", vr, nvr, value);
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = lookup(I, "fmi2SetReal", vr[k], GW_REAL);
        if (!v || !settable(I, "fmi2SetReal", v)) {
            status = fmi2Error;
            goto END;
        }
        if (!isfinite(value[k]))
            FAIL("fmi2SetReal: value %g for variable %s (vr=%u) is not finite", value[k],
                 v->name, v->vr);
        store(I, v, value[k]);
    }
    END_FUNCTION();
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    size_t k;
    BEGIN("fmi2SetInteger", MASK_Set);
    CHECK_ARRAYS("fmi2SetInteger", vr, nvr, value);
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = lookup(I, "fmi2SetInteger", vr[k], GW_INTEGER);
        if (!v || !settable(I, "fmi2SetInteger", v)) {
            status = fmi2Error;
            goto END;
        }
        store(I, v, (double)value[k]);
    }
    END_FUNCTION();
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    size_t k;
    BEGIN("fmi2SetBoolean", MASK_Set);
    CHECK_ARRAYS("fmi2SetBoolean", vr, nvr, value);
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = lookup(I, "fmi2SetBoolean", vr[k], GW_BOOLEAN);
        if (!v || !settable(I, "fmi2SetBoolean", v)) {
            status = fmi2Error;
            goto END;
        }
        store(I, v, value[k] ? 1.0 : 0.0);
    }
    END_FUNCTION();
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    BEGIN("fmi2SetString", MASK_Set);
    (void)value;
    if (nvr > 0)
        FAIL("fmi2SetString: unknown value reference %u (the model has no String variables)",
             vr ? vr[0] : 0u);
    END_FUNCTION();
}

/* ---- directional derivatives (not provided yet) -------------------------- */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    BEGIN("fmi2GetDirectionalDerivative", MASK_NotSupported);
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    FAIL("fmi2GetDirectionalDerivative: not provided by this FMU "
         "(providesDirectionalDerivative=false)");
    END_FUNCTION();
}

/* ---- Model Exchange: not supported --------------------------------------- */

#define ME_NOT_SUPPORTED(fn)                                                                \
    BEGIN(fn, MASK_NotSupported);                                                           \
    FAIL("%s: Model Exchange is not supported by this FMU", fn);                            \
    END_FUNCTION()

fmi2Status fmi2EnterEventMode(fmi2Component c) { ME_NOT_SUPPORTED("fmi2EnterEventMode"); }

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    (void)eventInfo;
    ME_NOT_SUPPORTED("fmi2NewDiscreteStates");
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    ME_NOT_SUPPORTED("fmi2EnterContinuousTimeMode");
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint;
    (void)enterEventMode;
    (void)terminateSimulation;
    ME_NOT_SUPPORTED("fmi2CompletedIntegratorStep");
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    (void)time;
    ME_NOT_SUPPORTED("fmi2SetTime");
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    (void)x;
    (void)nx;
    ME_NOT_SUPPORTED("fmi2SetContinuousStates");
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    (void)derivatives;
    (void)nx;
    ME_NOT_SUPPORTED("fmi2GetDerivatives");
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    (void)eventIndicators;
    (void)ni;
    ME_NOT_SUPPORTED("fmi2GetEventIndicators");
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    (void)x;
    (void)nx;
    ME_NOT_SUPPORTED("fmi2GetContinuousStates");
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    (void)x_nominal;
    (void)nx;
    ME_NOT_SUPPORTED("fmi2GetNominalsOfContinuousStates");
}

/* ---- Co-Simulation ------------------------------------------------------------ */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    BEGIN("fmi2SetRealInputDerivatives", MASK_NotSupported);
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    FAIL("fmi2SetRealInputDerivatives: not supported (canInterpolateInputs=false)");
    END_FUNCTION();
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    BEGIN("fmi2GetRealOutputDerivatives", MASK_NotSupported);
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    FAIL("fmi2GetRealOutputDerivatives: not supported (MaxOutputDerivativeOrder=0)");
    END_FUNCTION();
}

static const char *status_name(int s) {
    switch (s) {
    case fmi2OK: return "OK";
    case fmi2Warning: return "Warning";
    case fmi2Discard: return "Discard";
    case fmi2Error: return "Error";
    case fmi2Fatal: return "Fatal";
    case fmi2Pending: return "Pending";
    default: return "?";
    }
}

/* Back to the state at the start of the communication step. */
static void restore_step_start(gw_instance *I, double t0, double h0) {
    const gw_model *m = I->m;
    memcpy(I->x, I->x_bak, (size_t)m->nx * sizeof(double));
    if (m->ne > 0) {
        memcpy(I->e, I->e_bak, (size_t)m->ne * sizeof(double));
        memcpy(I->flags, I->flags_bak, (size_t)m->ne * sizeof(int));
    }
    I->t = t0;
    I->h_adapt = h0;
    I->fcur_valid = 0;
    I->y_valid = 0;
    gw_eval_out(I, I->t, I->x, I->y);
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentCommunicationPoint) {
    const double tc = currentCommunicationPoint, h = communicationStepSize;
    const gw_model *m;
    double t_end, h0, tol;
    unsigned long long rhs0, acc0, rej0;
    gw_int_result r;
    gw_instance *I = (gw_instance *)c;
    fmi2Status status = fmi2OK;
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    if (I && I->terminated && (I->state == GW_ST_STEP_FAILED || I->state == GW_ST_TERMINATED)) {
        GW_ERROR(I, "fmi2DoStep: simulation terminated at t=%.17g; call fmi2Reset to restart",
                 I->last_successful_time);
        I->state = GW_ST_ERROR;
        return fmi2Error;
    }
    if (!gw_begin(I, "fmi2DoStep", MASK_DoStep)) return fmi2Error;
    m = I->m;
    if (!isfinite(h) || !(h > 0.0))
        FAIL("fmi2DoStep: communication step size %g must be finite and > 0", h);
    if (!isfinite(tc)) FAIL("fmi2DoStep: currentCommunicationPoint is not finite");
    tol = 1e-9 * (fabs(tc) > 1.0 ? fabs(tc) : 1.0);
    if (fabs(tc - I->t) > tol)
        FAIL("fmi2DoStep: currentCommunicationPoint %.17g does not match the FMU time %.17g", tc,
             I->t);
    t_end = tc + h;
    if (I->stop_defined) {
        double eps = 1e-9 * (fabs(I->t_stop) > 1.0 ? fabs(I->t_stop) : 1.0);
        if (t_end > I->t_stop + eps)
            FAIL("fmi2DoStep: step to t=%.17g goes beyond stopTime %.17g", t_end, I->t_stop);
    }
    /* backup for error recovery */
    memcpy(I->x_bak, I->x, (size_t)m->nx * sizeof(double));
    if (m->ne > 0) {
        memcpy(I->e_bak, I->e, (size_t)m->ne * sizeof(double));
        memcpy(I->flags_bak, I->flags, (size_t)m->ne * sizeof(int));
    }
    h0 = I->h_adapt;
    rhs0 = I->n_rhs;
    acc0 = I->n_accepted;
    rej0 = I->n_rejected;
    I->t = tc;
    I->y_valid = 0;

    r = gw_integrate(I, t_end);
    if (r != GW_INT_ERROR && update_outputs(I, "fmi2DoStep") != fmi2OK) r = GW_INT_ERROR;
    if (r == GW_INT_ERROR) {
        restore_step_start(I, tc, h0);
        status = fmi2Error;
    } else if (r == GW_INT_TERMINATED) {
        I->terminated = 1;
        I->last_successful_time = I->t;
        I->state = GW_ST_STEP_FAILED;
        status = fmi2Discard;
    } else {
        I->last_successful_time = I->t;
    }
    if (gw_log_enabled(I, GW_LOG_SOLVER))
        gw_log(I, fmi2OK, GW_LOG_SOLVER,
               "fmi2DoStep t=%.17g h=%.17g -> t=%.17g solver=%s accepted=%llu rejected=%llu "
               "rhs=%llu h_next=%g status=%s",
               tc, h, I->t, gw_solver_name(I->solver), I->n_accepted - acc0,
               I->n_rejected - rej0, I->n_rhs - rhs0, I->h_adapt, status_name(status));
    I->last_dostep_status = status;
    END_FUNCTION();
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    BEGIN("fmi2CancelStep", MASK_NotSupported);
    FAIL("fmi2CancelStep: fmi2DoStep is never asynchronous (canRunAsynchronuously=false)");
    END_FUNCTION();
}

/* ---- status ------------------------------------------------------------------ */

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    BEGIN("fmi2GetStatus", MASK_Status);
    if (!value) FAIL("fmi2GetStatus: value is NULL");
    if (s == fmi2DoStepStatus) {
        *value = (fmi2Status)I->last_dostep_status;
    } else {
        status = fmi2Discard; /* status kind not provided */
    }
    END_FUNCTION();
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    BEGIN("fmi2GetRealStatus", MASK_Status);
    if (!value) FAIL("fmi2GetRealStatus: value is NULL");
    if (s == fmi2LastSuccessfulTime)
        *value = I->last_successful_time;
    else
        status = fmi2Discard;
    END_FUNCTION();
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    BEGIN("fmi2GetIntegerStatus", MASK_Status);
    (void)s;
    (void)value;
    status = fmi2Discard; /* no integer status kinds */
    END_FUNCTION();
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    BEGIN("fmi2GetBooleanStatus", MASK_Status);
    if (!value) FAIL("fmi2GetBooleanStatus: value is NULL");
    if (s == fmi2Terminated)
        *value = I->terminated ? fmi2True : fmi2False;
    else
        status = fmi2Discard;
    END_FUNCTION();
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    BEGIN("fmi2GetStringStatus", MASK_Status);
    (void)s;
    (void)value;
    status = fmi2Discard; /* fmi2PendingStatus: never pending */
    END_FUNCTION();
}
