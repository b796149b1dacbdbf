/*
 * gw_fmi2.c -- the FMI 2.0 interfaces, Co-Simulation and Model Exchange in one
 * library: instance life cycle, state machine, variable access through
 * GW_MODEL.vars, initialisation, fmi2DoStep and the status functions (CS), the
 * continuous-time and event functions (ME), and fmi2GetDirectionalDerivative from
 * the model's `dir` function (both).  The FMU-state functions are in gw_state.c.
 *
 * State machine (bit masks as in modelica/Reference-FMUs):
 *   CS: Instantiated -> InitializationMode -> StepComplete <-> StepFailed -> Terminated
 *   ME: Instantiated -> InitializationMode -> EventMode <-> ContinuousTimeMode -> Terminated
 * A function of the other interface fails with fmi2Error and a logged reason.
 */
#include <math.h>
#include <string.h>

#include "gw_instance.h"
#include "gw_solver.h"

/* ---- states in which each function may be called ------------------------- */
#define ST_ME (GW_ST_EVENT_MODE | GW_ST_CONT_TIME_MODE)
#define ST_ANY                                                                              \
    (GW_ST_INSTANTIATED | GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED |      \
     GW_ST_TERMINATED | GW_ST_ERROR | ST_ME)
#define ST_BEFORE_INIT_END (GW_ST_INSTANTIATED | GW_ST_INIT_MODE)
#define MASK_SetDebugLogging ST_ANY
#define MASK_Reset ST_ANY
#define MASK_SetupExperiment GW_ST_INSTANTIATED
#define MASK_EnterInitializationMode GW_ST_INSTANTIATED
#define MASK_ExitInitializationMode GW_ST_INIT_MODE
#define MASK_Terminate (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | ST_ME)
#define MASK_Get ST_ANY
#define MASK_Set (GW_ST_INSTANTIATED | GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | ST_ME)
#define MASK_DoStep GW_ST_STEP_COMPLETE
#define MASK_Status (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_TERMINATED | GW_ST_ERROR)
#define MASK_NotSupported ST_ANY
/* Model Exchange */
#define MASK_EnterEventMode ST_ME
#define MASK_NewDiscreteStates GW_ST_EVENT_MODE
#define MASK_EnterContinuousTimeMode GW_ST_EVENT_MODE
#define MASK_CompletedIntegratorStep GW_ST_CONT_TIME_MODE
#define MASK_SetTime ST_ME
#define MASK_SetContinuousStates GW_ST_CONT_TIME_MODE
#define MASK_GetDerivatives (GW_ST_INIT_MODE | ST_ME | GW_ST_TERMINATED | GW_ST_ERROR)
#define MASK_GetEventIndicators MASK_GetDerivatives
#define MASK_GetContinuousStates MASK_GetDerivatives
#define MASK_GetNominals (GW_ST_INSTANTIATED | ST_ME | GW_ST_TERMINATED | GW_ST_ERROR)
/* both interfaces */
#define MASK_GetDirectionalDerivative                                                       \
    (GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_TERMINATED |        \
     GW_ST_ERROR | ST_ME)

static const char *state_name(int state) {
    switch (state) {
    case GW_ST_INSTANTIATED: return "Instantiated";
    case GW_ST_INIT_MODE: return "InitializationMode";
    case GW_ST_STEP_COMPLETE: return "StepComplete";
    case GW_ST_STEP_FAILED: return "StepFailed";
    case GW_ST_TERMINATED: return "Terminated";
    case GW_ST_ERROR: return "Error";
    case GW_ST_FATAL: return "Fatal";
    case GW_ST_EVENT_MODE: return "EventMode";
    case GW_ST_CONT_TIME_MODE: return "ContinuousTimeMode";
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
/* 1 if the instance was instantiated for `type`; else logs, enters Error, returns 0 */
static int check_interface(gw_instance *I, const char *fn, int type) {
    if (!I) return 0;
    if (I->fmu_type == type) return 1;
    if (type == fmi2ModelExchange)
        GW_ERROR(I, "%s: Model Exchange is not supported by this instance (instantiated for "
                 "Co-Simulation)", fn);
    else
        GW_ERROR(I, "%s: Co-Simulation function, not available in an instance instantiated "
                 "for Model Exchange", fn);
    if (I->state != GW_ST_FATAL) I->state = GW_ST_ERROR;
    return 0;
}
#define BEGIN_ME(fn, mask)                                                                  \
    gw_instance *I = (gw_instance *)c;                                                      \
    fmi2Status status = fmi2OK;                                                             \
    if (!check_interface(I, fn, fmi2ModelExchange)) return fmi2Error;                       \
    if (!gw_begin(I, fn, mask)) return fmi2Error;                                           \
    if (0) goto END
#define BEGIN_CS(fn, mask)                                                                  \
    gw_instance *I = (gw_instance *)c;                                                      \
    fmi2Status status = fmi2OK;                                                             \
    if (!check_interface(I, fn, fmi2CoSimulation)) return fmi2Error;                        \
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

static int is_me(const gw_instance *I) { return I->fmu_type == fmi2ModelExchange; }

/* t, x, u or p changed: the cached outputs, derivatives and Jacobian are stale. */
static void point_changed(gw_instance *I) {
    I->y_valid = 0;
    I->xdot_valid = 0;
    I->dir_valid = 0;
}

/* Status for non-finite model values: Model Exchange answers fmi2Discard (the importer
 * may retry with a smaller step, FMI 2.0 section 2.1.3), Co-Simulation fmi2Error. */
static fmi2Status nonfinite_status(const gw_instance *I) {
    return is_me(I) ? fmi2Discard : fmi2Error;
}
#define LOG_NONFINITE(I, ...)                                                               \
    gw_log((I), nonfinite_status(I), is_me(I) ? GW_LOG_WARNING : GW_LOG_ERROR, __VA_ARGS__)

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
            LOG_NONFINITE(I, "%s: output %s is not finite (%g) at t=%.17g", fn, nm ? nm : "?",
                          I->y[i], I->t);
            return nonfinite_status(I);
        }
    I->y_valid = 1;
    return fmi2OK;
}

/* Make I->xdot hold ode(t, x, u, p) at the current point (before initialisation ends:
 * at x = init(s, p), not cached). */
static fmi2Status update_derivatives(gw_instance *I, const char *fn) {
    const gw_model *m = I->m;
    int i, pre = before_init_end(I);
    if (!pre && I->xdot_valid) return fmi2OK;
    if (pre && gw_eval_init(I, I->x) != 0) {
        GW_ERROR(I, "%s: evaluation of the initial state failed", fn);
        return fmi2Error;
    }
    if (gw_rhs(I, I->t, I->x, I->xdot) != 0) {
        GW_ERROR(I, "%s: evaluation of the right-hand side failed at t=%.17g", fn, I->t);
        return fmi2Error;
    }
    for (i = 0; i < m->nx; i++)
        if (!isfinite(I->xdot[i])) {
            if (pre) { /* as for the initial outputs: the parameters may still change */
                gw_log(I, fmi2Warning, GW_LOG_WARNING,
                       "%s: initial derivative of state %s is not finite (check the "
                       "parameters)", fn, m->x_names ? m->x_names[i] : "?");
                return fmi2Warning;
            }
            LOG_NONFINITE(I, "%s: derivative of state %s is not finite (%g) at t=%.17g", fn,
                          m->x_names ? m->x_names[i] : "?", I->xdot[i], I->t);
            return nonfinite_status(I);
        }
    I->xdot_valid = !pre;
    return fmi2OK;
}

static int needs_derivatives(const gw_instance *I, const fmi2ValueReference vr[], size_t nvr) {
    size_t k;
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = find_var(I->m, vr[k]);
        if (v && v->kind == GW_VAR_DERIVATIVE) return 1;
    }
    return 0;
}

static int needs_outputs(const gw_instance *I, const fmi2ValueReference vr[], size_t nvr) {
    size_t k;
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = find_var(I->m, vr[k]);
        if (!v) continue;
        if (v->kind == GW_VAR_OUTPUT) return 1;
        if (v->kind == GW_VAR_START && v->out_index >= 0 && !before_init_end(I)) return 1;
        if (v->kind == GW_VAR_STATE && before_init_end(I)) return 1; /* x = init(s, p) */
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
    case GW_VAR_STATE: return I->x[v->index];
    case GW_VAR_DERIVATIVE: return I->xdot[v->index];
    default: return 0.0;
    }
}

/* Check that v may be set now; the value is already known to be valid. */
static int settable(gw_instance *I, const char *fn, const gw_variable *v) {
    int ok;
    switch (v->kind) {
    case GW_VAR_PARAM: /* tunable: in Model Exchange only in Event Mode, not in CT Mode */
        ok = v->tunable ? (I->state & MASK_Set & ~GW_ST_CONT_TIME_MODE) != 0
                        : before_init_end(I);
        break;
    case GW_VAR_STATE:
        GW_ERROR(I, "%s: variable %s (vr=%u) is a continuous state and cannot be set%s", fn,
                 v->name, v->vr,
                 is_me(I) ? " (use fmi2SetContinuousStates)" : "");
        return 0;
    case GW_VAR_DERIVATIVE:
        GW_ERROR(I, "%s: variable %s (vr=%u) is a state derivative and cannot be set", fn,
                 v->name, v->vr);
        return 0;
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
            point_changed(I);
            I->fcur_valid = 0;
            gw_eval_nom(I, I->nominal);
        }
        break;
    case GW_VAR_START: I->s[v->index] = value; break;
    case GW_VAR_INPUT:
        I->u[v->index] = value;
        point_changed(I);
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
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        gw_log_cb(&cb, name, fmi2Error, "logStatusError",
                  "fmi2Instantiate: %s: unknown fmuType %d (expected fmi2ModelExchange=%d or "
                  "fmi2CoSimulation=%d)", m->identifier, (int)fmuType, (int)fmi2ModelExchange,
                  (int)fmi2CoSimulation);
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
    if (I && gw_instance_me_alloc(I) != 0) {
        gw_instance_free(I);
        I = NULL;
    }
    if (!I) {
        gw_log_cb(&cb, name, fmi2Error, "logStatusError",
                  "fmi2Instantiate: out of memory");
        return NULL;
    }
    I->fmu_type = (int)fmuType;
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
    point_changed(I);
    ok = check_finite_vec(I, I->p, m->np, GW_VAR_PARAM, "parameter");
    ok &= check_finite_vec(I, I->s, m->ns, GW_VAR_START, "start value");
    ok &= check_finite_vec(I, I->u, m->nu, GW_VAR_INPUT, "input");
    if (!ok) FAIL("fmi2ExitInitializationMode: non-finite values");
    /* settings */
    if (I->tol_defined) I->rel_tol = I->tolerance;
    if (!gw_solver_available(I->solver))
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
    /* from here on y is the simulation's output; ME continues in Event Mode */
    I->state = is_me(I) ? GW_ST_EVENT_MODE : GW_ST_STEP_COMPLETE;
    I->y_valid = 0;
    CHECK(update_outputs(I, "fmi2ExitInitializationMode"));
    if (gw_rhs(I, I->t, I->x, I->k[0]) != 0)
        FAIL("fmi2ExitInitializationMode: evaluation of the right-hand side failed");
    for (i = 0; i < m->nx; i++)
        if (!isfinite(I->k[0][i]))
            FAIL("fmi2ExitInitializationMode: derivative of state %s is not finite (%g)",
                 m->x_names ? m->x_names[i] : "?", I->k[0][i]);
    I->fcur_valid = 1;
    memcpy(I->xdot, I->k[0], (size_t)m->nx * sizeof(double));
    I->xdot_valid = 1;
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
    point_changed(I);
    END_FUNCTION();
}

/* ---- getting and setting variable values ------------------------------------ */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    size_t k;
    BEGIN("fmi2GetReal", MASK_Get);
    CHECK_ARRAYS("fmi2GetReal", vr, nvr, value);
    if (needs_outputs(I, vr, nvr)) CHECK(update_outputs(I, "fmi2GetReal"));
    if (needs_derivatives(I, vr, nvr)) CHECK(update_derivatives(I, "fmi2GetReal"));
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

/* ---- directional derivatives (both interfaces) ------------------------------- */

/* Row of D for an unknown: 0..nx-1 xdot, nx.. y; or *xrow >= 0 for the identity row of
 * a continuous state.  0 if v is no output, state or derivative. */
static int dd_unknown(const gw_model *m, const gw_variable *v, int *row, int *xrow) {
    *row = -1;
    *xrow = -1;
    if (v->type != GW_REAL) return 0;
    switch (v->kind) {
    case GW_VAR_OUTPUT: *row = m->nx + v->index; return 1;
    case GW_VAR_DERIVATIVE: *row = v->index; return 1;
    case GW_VAR_STATE: *xrow = v->state_index >= 0 ? v->state_index : v->index; return 1;
    case GW_VAR_START:
        if (v->state_index >= 0) {
            *xrow = v->state_index;
            return 1;
        }
        if (v->out_index >= 0) {
            *row = m->nx + v->out_index;
            return 1;
        }
        return 0;
    default: return 0;
    }
}

/* Column of D for a known: 0..nx-1 x, nx.. u.  -1 if v is no state or input. */
static int dd_known(const gw_model *m, const gw_variable *v) {
    if (v->type != GW_REAL) return -1;
    if (v->kind == GW_VAR_INPUT) return m->nx + v->index;
    if (v->kind == GW_VAR_STATE) return v->state_index >= 0 ? v->state_index : v->index;
    if (v->kind == GW_VAR_START && v->state_index >= 0) return v->state_index;
    return -1;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    static const char fn[] = "fmi2GetDirectionalDerivative";
    const gw_model *m;
    size_t i, j;
    int nrow;
    gw_instance *I = (gw_instance *)c;
    fmi2Status status = fmi2OK;
    /* a function the model does not provide fails alike in every state */
    if (I && !I->f_dir.eval && I->state != GW_ST_FATAL) {
        GW_ERROR(I, "%s: not provided by this FMU (providesDirectionalDerivative=false)", fn);
        I->state = GW_ST_ERROR;
        return fmi2Error;
    }
    if (!gw_begin(I, fn, MASK_GetDirectionalDerivative)) return fmi2Error;
    m = I->m;
    nrow = m->nx + m->ny;
    if (nUnknown > 0 && (!vUnknown_ref || !dvUnknown))
        FAIL("%s: NULL array for %lu unknowns", fn, (unsigned long)nUnknown);
    if (nKnown > 0 && (!vKnown_ref || !dvKnown))
        FAIL("%s: NULL array for %lu knowns", fn, (unsigned long)nKnown);
    /* check every reference before computing anything */
    for (i = 0; i < nUnknown; i++) {
        const gw_variable *v = find_var(m, vUnknown_ref[i]);
        int row, xrow;
        if (!v) FAIL("%s: unknown value reference %u (vUnknown_ref[%lu])", fn, vUnknown_ref[i],
                     (unsigned long)i);
        if (!dd_unknown(m, v, &row, &xrow))
            FAIL("%s: unknown %s (vr=%u) is not a Real output, continuous state or state "
                 "derivative", fn, v->name, v->vr);
    }
    for (j = 0; j < nKnown; j++) {
        const gw_variable *v = find_var(m, vKnown_ref[j]);
        if (!v) FAIL("%s: unknown value reference %u (vKnown_ref[%lu])", fn, vKnown_ref[j],
                     (unsigned long)j);
        if (dd_known(m, v) < 0)
            FAIL("%s: known %s (vr=%u) is not a continuous state or a Real input", fn, v->name,
                 v->vr);
        if (!isfinite(dvKnown[j]))
            FAIL("%s: seed dvKnown[%lu] for %s is not finite", fn, (unsigned long)j, v->name);
    }
    /* D at the current point (before initialisation ends: at x = init(s, p)) */
    if (before_init_end(I) || !I->dir_valid) {
        int k, n = nrow * (m->nx + m->nu);
        if (before_init_end(I) && gw_eval_init(I, I->x) != 0)
            FAIL("%s: evaluation of the initial state failed", fn);
        I->dir_valid = 0;
        if (gw_eval_dir(I, I->t, I->x, I->dir_D) != 0)
            FAIL("%s: evaluation of the Jacobian failed at t=%.17g", fn, I->t);
        for (k = 0; k < n; k++)
            if (!isfinite(I->dir_D[k])) {
                LOG_NONFINITE(I, "%s: Jacobian entry (%d, %d) is not finite at t=%.17g", fn,
                              k % nrow, k / nrow, I->t);
                status = nonfinite_status(I);
                goto END;
            }
        I->dir_valid = !before_init_end(I);
    }
    for (i = 0; i < nUnknown; i++) {
        const gw_variable *v = find_var(m, vUnknown_ref[i]);
        double sum = 0.0;
        int row, xrow;
        dd_unknown(m, v, &row, &xrow);
        for (j = 0; j < nKnown; j++) {
            int col = dd_known(m, find_var(m, vKnown_ref[j]));
            if (xrow >= 0)
                sum += (col == xrow) ? dvKnown[j] : 0.0;
            else
                sum += I->dir_D[(size_t)row + (size_t)col * (size_t)nrow] * dvKnown[j];
        }
        dvUnknown[i] = sum;
    }
    END_FUNCTION();
}

/* ---- Model Exchange -------------------------------------------------------------- */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    BEGIN_ME("fmi2EnterEventMode", MASK_EnterEventMode);
    I->state = GW_ST_EVENT_MODE;
    END_FUNCTION();
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    const gw_model *m;
    int i;
    gw_ev_result r = GW_EV_NONE;
    BEGIN_ME("fmi2NewDiscreteStates", MASK_NewDiscreteStates);
    m = I->m;
    if (!eventInfo) FAIL("fmi2NewDiscreteStates: eventInfo is NULL");
    if (m->ne > 0) {
        if (gw_eval_evt(I, I->t, I->x, I->e_me) != 0)
            FAIL("fmi2NewDiscreteStates: evaluation of the event indicators failed at t=%.17g",
                 I->t);
        r = gw_events_me_update(I, I->e_me);
    }
    if (r == GW_EV_TERMINATE && !I->terminated) {
        I->terminated = 1;
        I->last_successful_time = I->t;
        for (i = 0; i < m->ne; i++)
            if (I->flags[i] && !(I->e[i] > 0.0) &&
                !(m->event_actions && m->event_actions[i] == GW_EVENT_WARN) &&
                gw_log_enabled(I, GW_LOG_EVENTS))
                gw_log(I, fmi2OK, GW_LOG_EVENTS,
                       "fmi2NewDiscreteStates: event %s: terminateSimulation = true at t=%.17g",
                       m->event_names ? m->event_names[i] : "?", I->t);
    }
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = I->terminated ? fmi2True : fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    END_FUNCTION();
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    BEGIN_ME("fmi2EnterContinuousTimeMode", MASK_EnterContinuousTimeMode);
    if (I->terminated)
        FAIL("fmi2EnterContinuousTimeMode: the simulation terminated at t=%.17g "
             "(terminateSimulation = true); call fmi2Terminate or fmi2Reset",
             I->last_successful_time);
    I->state = GW_ST_CONT_TIME_MODE;
    END_FUNCTION();
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    BEGIN_ME("fmi2CompletedIntegratorStep", MASK_CompletedIntegratorStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!enterEventMode || !terminateSimulation)
        FAIL("fmi2CompletedIntegratorStep: enterEventMode or terminateSimulation is NULL");
    /* no step events: state events are located by the importer */
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    END_FUNCTION();
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    BEGIN_ME("fmi2SetTime", MASK_SetTime);
    if (!isfinite(time)) FAIL("fmi2SetTime: time %g is not finite", time);
    if (time != I->t) {
        I->t = time;
        point_changed(I);
    }
    END_FUNCTION();
}

/* nx of a state-vector call must be the model's */
#define CHECK_NX(fn, arr, n)                                                                \
    do {                                                                                    \
        if ((n) != (size_t)I->m->nx)                                                        \
            FAIL("%s: nx = %lu, the model has %d continuous states", fn, (unsigned long)(n), \
                 I->m->nx);                                                                 \
        if ((n) > 0 && !(arr)) FAIL("%s: array is NULL", fn);                              \
    } while (0)

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    size_t i;
    BEGIN_ME("fmi2SetContinuousStates", MASK_SetContinuousStates);
    CHECK_NX("fmi2SetContinuousStates", x, nx);
    for (i = 0; i < nx; i++)
        if (!isfinite(x[i]))
            FAIL("fmi2SetContinuousStates: state %s = %g is not finite",
                 I->m->x_names ? I->m->x_names[i] : "?", x[i]);
    if (nx > 0 && memcmp(I->x, x, nx * sizeof(double)) != 0) {
        memcpy(I->x, x, nx * sizeof(double));
        point_changed(I);
    }
    END_FUNCTION();
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    BEGIN_ME("fmi2GetDerivatives", MASK_GetDerivatives);
    CHECK_NX("fmi2GetDerivatives", derivatives, nx);
    CHECK(update_derivatives(I, "fmi2GetDerivatives"));
    if (nx > 0) memcpy(derivatives, I->xdot, nx * sizeof(double));
    END_FUNCTION();
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    const gw_model *m;
    int i;
    BEGIN_ME("fmi2GetEventIndicators", MASK_GetEventIndicators);
    m = I->m;
    if (ni != (size_t)m->ne)
        FAIL("fmi2GetEventIndicators: ni = %lu, the model has %d event indicators",
             (unsigned long)ni, m->ne);
    if (ni == 0) goto END;
    if (!eventIndicators) FAIL("fmi2GetEventIndicators: array is NULL");
    if (before_init_end(I) && gw_eval_init(I, I->x) != 0)
        FAIL("fmi2GetEventIndicators: evaluation of the initial state failed");
    if (gw_eval_evt(I, I->t, I->x, I->e_me) != 0)
        FAIL("fmi2GetEventIndicators: evaluation of the event indicators failed at t=%.17g",
             I->t);
    for (i = 0; i < m->ne; i++)
        if (!isfinite(I->e_me[i])) {
            LOG_NONFINITE(I, "fmi2GetEventIndicators: event indicator %s is not finite (%g) "
                          "at t=%.17g", m->event_names ? m->event_names[i] : "?", I->e_me[i],
                          I->t);
            status = nonfinite_status(I);
            goto END;
        }
    memcpy(eventIndicators, I->e_me, ni * sizeof(double));
    END_FUNCTION();
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    BEGIN_ME("fmi2GetContinuousStates", MASK_GetContinuousStates);
    CHECK_NX("fmi2GetContinuousStates", x, nx);
    if (before_init_end(I) && gw_eval_init(I, I->x) != 0)
        FAIL("fmi2GetContinuousStates: evaluation of the initial state failed");
    if (nx > 0) memcpy(x, I->x, nx * sizeof(double));
    END_FUNCTION();
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    size_t i;
    BEGIN_ME("fmi2GetNominalsOfContinuousStates", MASK_GetNominals);
    CHECK_NX("fmi2GetNominalsOfContinuousStates", x_nominal, nx);
    if (nx == 0) goto END;
    if (before_init_end(I)) { /* from the current parameters; 1 where not usable */
        if (gw_eval_nom(I, x_nominal) != 0)
            FAIL("fmi2GetNominalsOfContinuousStates: evaluation of the nominals failed");
        for (i = 0; i < nx; i++)
            if (!(x_nominal[i] > 0.0) || !isfinite(x_nominal[i])) x_nominal[i] = 1.0;
    } else {
        memcpy(x_nominal, I->nominal, nx * sizeof(double));
    }
    END_FUNCTION();
}

/* ---- Co-Simulation ------------------------------------------------------------ */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    BEGIN_CS("fmi2SetRealInputDerivatives", MASK_NotSupported);
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    FAIL("fmi2SetRealInputDerivatives: not supported (canInterpolateInputs=false)");
    END_FUNCTION();
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    BEGIN_CS("fmi2GetRealOutputDerivatives", MASK_NotSupported);
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
    point_changed(I);
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
    if (!check_interface(I, "fmi2DoStep", fmi2CoSimulation)) return fmi2Error;
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
    point_changed(I);

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
    BEGIN_CS("fmi2CancelStep", MASK_NotSupported);
    FAIL("fmi2CancelStep: fmi2DoStep is never asynchronous (canRunAsynchronuously=false)");
    END_FUNCTION();
}

/* ---- status ------------------------------------------------------------------ */

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    BEGIN_CS("fmi2GetStatus", MASK_Status);
    if (!value) FAIL("fmi2GetStatus: value is NULL");
    if (s == fmi2DoStepStatus) {
        *value = (fmi2Status)I->last_dostep_status;
    } else {
        status = fmi2Discard; /* status kind not provided */
    }
    END_FUNCTION();
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    BEGIN_CS("fmi2GetRealStatus", MASK_Status);
    if (!value) FAIL("fmi2GetRealStatus: value is NULL");
    if (s == fmi2LastSuccessfulTime)
        *value = I->last_successful_time;
    else
        status = fmi2Discard;
    END_FUNCTION();
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    BEGIN_CS("fmi2GetIntegerStatus", MASK_Status);
    (void)s;
    (void)value;
    status = fmi2Discard; /* no integer status kinds */
    END_FUNCTION();
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    BEGIN_CS("fmi2GetBooleanStatus", MASK_Status);
    if (!value) FAIL("fmi2GetBooleanStatus: value is NULL");
    if (s == fmi2Terminated)
        *value = I->terminated ? fmi2True : fmi2False;
    else
        status = fmi2Discard;
    END_FUNCTION();
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    BEGIN_CS("fmi2GetStringStatus", MASK_Status);
    (void)s;
    (void)value;
    status = fmi2Discard; /* fmi2PendingStatus: never pending */
    END_FUNCTION();
}
