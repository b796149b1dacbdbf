/*
 * gw_fmi2_common.c -- FMI 2.0 functions common to Co-Simulation and Model Exchange: version,
 * debug logging, instantiation (the importer's callbacks adapted to the core's), the state
 * machine, experiment set-up, initialisation, termination and reset.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "gw_fmi2.h"

#define GW_MASK_SetDebugLogging GW_ST_ANY
#define GW_MASK_Reset GW_ST_ANY
#define GW_MASK_SetupExperiment GW_ST_INSTANTIATED
#define GW_MASK_EnterInitializationMode GW_ST_INSTANTIATED
#define GW_MASK_ExitInitializationMode GW_ST_INIT_MODE
#define GW_MASK_Terminate (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_ME)

/* ---- statuses, states, logging ---------------------------------------------------------- */

GW_INTERNAL fmi2Status gw_fmi2_status(gw_status s) {
    switch (s) {
    case GW_OK: return fmi2OK;
    case GW_WARNING: return fmi2Warning;
    case GW_DISCARD: return fmi2Discard;
    case GW_ERROR: return fmi2Error;
    default: return fmi2Fatal;
    }
}

GW_INTERNAL const char *gw_fmi2_state_name(int state) {
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

GW_INTERNAL void gw_fmi2_set_state(gw_fmu *F, int state) {
    F->state = state;
    F->I->in_setup = (state & GW_ST_BEFORE_INIT_END) != 0;
}

/* the Error state, unless the instance is already beyond repair */
static void gw_fmi2_enter_error(gw_fmu *F) {
    if (F->state != GW_ST_FATAL) gw_fmi2_set_state(F, GW_ST_ERROR);
}

GW_INTERNAL int gw_fmi2_begin(gw_fmu *F, const char *fn, int mask) {
    if (!F) return 0;
    if (!(F->state & mask)) {
        GW_LOG_ERR(F->I, "%s: illegal call in state %s", fn, gw_fmi2_state_name(F->state));
        gw_fmi2_enter_error(F);
        return 0;
    }
    return 1;
}

GW_INTERNAL int gw_fmi2_interface(gw_fmu *F, const char *fn, int type) {
    if (!F) return 0;
    if (F->fmu_type == type) return 1;
    if (type == fmi2ModelExchange)
        GW_LOG_ERR(F->I, "%s: Model Exchange is not supported by this instance (instantiated "
                   "for Co-Simulation)", fn);
    else
        GW_LOG_ERR(F->I, "%s: Co-Simulation function, not available in an instance instantiated "
                   "for Model Exchange", fn);
    gw_fmi2_enter_error(F);
    return 0;
}

GW_INTERNAL fmi2Status gw_fmi2_end(gw_fmu *F, fmi2Status status) {
    if (status == fmi2Fatal)
        gw_fmi2_set_state(F, GW_ST_FATAL);
    else if (status == fmi2Error)
        gw_fmi2_set_state(F, GW_ST_ERROR);
    return status;
}

/* Escape '%': importers may treat the message as a printf format. */
static void gw_fmi2_escape(char *buf, size_t size, const char *raw) {
    size_t i, j = 0;
    for (i = 0; raw[i] != '\0' && j + 2 < size; i++) {
        if (raw[i] == '%') buf[j++] = '%';
        buf[j++] = raw[i];
    }
    buf[j] = '\0';
}

/* the core's logger: env is the gw_fmu */
static void gw_fmi2_logger(void *env, const char *name, gw_status status, const char *category,
                           const char *message) {
    const gw_fmu *F = (const gw_fmu *)env;
    char buf[2048];
    gw_fmi2_escape(buf, sizeof(buf), message);
    F->logger(F->env, name, gw_fmi2_status(status), category, buf);
}

/* an error before there is an instance to log through */
static void gw_fmi2_instantiate_error(const fmi2CallbackFunctions *cb, const char *name,
                                      const char *fmt, ...) GW_PRINTF(3, 4);
static void gw_fmi2_instantiate_error(const fmi2CallbackFunctions *cb, const char *name,
                                      const char *fmt, ...) {
    va_list ap;
    char raw[1024], buf[2048];
    if (!cb->logger) return;
    va_start(ap, fmt);
    vsnprintf(raw, sizeof(raw), fmt, ap);
    va_end(ap);
    gw_fmi2_escape(buf, sizeof(buf), raw);
    cb->logger(cb->componentEnvironment, name, fmi2Error, "logStatusError", buf);
}

/* ---- inquire version numbers and set debug logging ----------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    GW_BEGIN("fmi2SetDebugLogging", GW_MASK_SetDebugLogging);
    GW_TRY(gw_set_logging(I, "fmi2SetDebugLogging", loggingOn, nCategories, categories));
    GW_END_FUNCTION();
}

/* ---- creation and destruction ------------------------------------------------------------- */

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    const gw_model *m = &GW_MODEL;
    gw_fmu *F;
    gw_callbacks cb;
    const char *name = instanceName ? instanceName : "";
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions) return NULL;
    if (!functions->allocateMemory || !functions->freeMemory) {
        gw_fmi2_instantiate_error(functions, name, "fmi2Instantiate: allocateMemory and "
                                  "freeMemory callbacks are required");
        return NULL;
    }
    if (!instanceName || instanceName[0] == '\0') {
        gw_fmi2_instantiate_error(functions, name, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        gw_fmi2_instantiate_error(functions, name,
                                  "fmi2Instantiate: %s: unknown fmuType %d (expected "
                                  "fmi2ModelExchange=%d or fmi2CoSimulation=%d)",
                                  m->identifier, (int)fmuType, (int)fmi2ModelExchange,
                                  (int)fmi2CoSimulation);
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, m->token) != 0) {
        gw_fmi2_instantiate_error(functions, name,
                                  "fmi2Instantiate: GUID \"%s\" does not match the model's \"%s\"",
                                  fmuGUID ? fmuGUID : "(null)", m->token);
        return NULL;
    }
    if (!m->ode.eval || !m->init.eval || (m->ny > 0 && !m->out.eval) ||
        (m->ne > 0 && !m->evt.eval) || (m->nc > 0 && !m->chk.eval)) {
        gw_fmi2_instantiate_error(functions, name,
                                  "fmi2Instantiate: model %s lacks a required function",
                                  m->identifier);
        return NULL;
    }
    F = (gw_fmu *)functions->allocateMemory(1, sizeof(gw_fmu));
    if (F) {
        memset(F, 0, sizeof(*F));
        F->logger = functions->logger;
        F->free_memory = functions->freeMemory;
        F->env = functions->componentEnvironment;
        cb.logger = functions->logger ? gw_fmi2_logger : NULL;
        cb.allocate = functions->allocateMemory;
        cb.free = functions->freeMemory;
        cb.env = F;
        F->I = gw_instance_new(m, name, &cb, loggingOn);
        if (!F->I) {
            functions->freeMemory(F);
            F = NULL;
        }
    }
    if (!F) {
        gw_fmi2_instantiate_error(functions, name, "fmi2Instantiate: out of memory");
        return NULL;
    }
    F->fmu_type = (int)fmuType;
    F->last_dostep_status = fmi2OK;
    /* non-finite values: ME answers fmi2Discard (the importer may retry with a smaller step,
     * FMI 2.0 section 2.1.3), Co-Simulation fmi2Error */
    F->I->nonfinite_status = fmuType == fmi2ModelExchange ? GW_DISCARD : GW_ERROR;
    gw_fmi2_set_state(F, GW_ST_INSTANTIATED);
    return (fmi2Component)F;
}

void fmi2FreeInstance(fmi2Component c) {
    gw_fmu *F = (gw_fmu *)c;
    fmi2CallbackFreeMemory free_memory;
    if (!F) return;
    gw_instance_free(F->I);
    free_memory = F->free_memory;
    free_memory(F);
}

/* ---- initialisation, termination and reset -------------------------------------------------- */

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    GW_BEGIN("fmi2SetupExperiment", GW_MASK_SetupExperiment);
    GW_TRY(gw_setup_experiment(I, "fmi2SetupExperiment", toleranceDefined, tolerance,
                               startTime, stopTimeDefined, stopTime));
    GW_END_FUNCTION();
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    GW_BEGIN("fmi2EnterInitializationMode", GW_MASK_EnterInitializationMode);
    gw_fmi2_set_state(F, GW_ST_INIT_MODE);
    GW_END_FUNCTION();
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    gw_status st;
    GW_BEGIN("fmi2ExitInitializationMode", GW_MASK_ExitInitializationMode);
    st = gw_initialize(I, "fmi2ExitInitializationMode");
    /* once the state is consistent the instance has left Initialization Mode;
     * ME continues in Event Mode */
    if (!I->in_setup)
        gw_fmi2_set_state(F, gw_fmi2_is_me(F) ? GW_ST_EVENT_MODE : GW_ST_STEP_COMPLETE);
    status = gw_fmi2_status(st);
    if (status <= fmi2Warning) F->last_dostep_status = fmi2OK;
    GW_END_FUNCTION();
}

fmi2Status fmi2Terminate(fmi2Component c) {
    GW_BEGIN("fmi2Terminate", GW_MASK_Terminate);
    gw_fmi2_set_state(F, GW_ST_TERMINATED);
    GW_END_FUNCTION();
}

fmi2Status fmi2Reset(fmi2Component c) {
    GW_BEGIN("fmi2Reset", GW_MASK_Reset);
    gw_instance_reset(I);
    gw_fmi2_set_state(F, GW_ST_INSTANTIATED);
    F->last_dostep_status = fmi2OK;
    GW_END_FUNCTION();
}

#endif /* GW_UNITY_BUILD */
