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
#include "gw_front.h"

/* the frames of this file's functions (GW_FRAME, gw_fmi2.h): interface, legal states */
#define GW_IFACE_SetDebugLogging GW_IFACE_BOTH
#define GW_IFACE_SetupExperiment GW_IFACE_BOTH
#define GW_IFACE_EnterInitializationMode GW_IFACE_BOTH
#define GW_IFACE_ExitInitializationMode GW_IFACE_BOTH
#define GW_IFACE_Terminate GW_IFACE_BOTH
#define GW_IFACE_Reset GW_IFACE_BOTH
#define GW_MASK_SetDebugLogging GW_ST_ANY
#define GW_MASK_Reset GW_ST_ANY
#define GW_MASK_SetupExperiment GW_ST_INSTANTIATED
#define GW_MASK_EnterInitializationMode GW_ST_INSTANTIATED
#define GW_MASK_ExitInitializationMode GW_ST_INIT_MODE
/* FMI 2.0.4 allows fmi2Terminate in StepComplete, StepFailed (CS), Event and Continuous-Time
 * Mode (ME); after an initialisation it is also answered in Terminated (a repeat: ignored)
 * and Error (the last consistent state is kept): see fmi2Terminate */
#define GW_MASK_Terminate                                                                       \
    (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_ME | GW_ST_TERMINATED | GW_ST_ERROR)

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
    /* the core evaluates the start values until the initialisation has ended; an error leaves
       that as it was (an instance refused a call before initialising still has only its start
       values: its getters and partials answer from them) */
    if (state != GW_ST_ERROR && state != GW_ST_FATAL) F->I->in_setup = (state & GW_ST_BEFORE_INIT_END) != 0;
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
    if (type == GW_IFACE_BOTH || F->fmu_type == type) return 1;
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
    F->I->nonfinite_status = GW_ERROR;
    if (status == fmi2Fatal)
        gw_fmi2_set_state(F, GW_ST_FATAL);
    else if (status == fmi2Error)
        gw_fmi2_set_state(F, GW_ST_ERROR);
    return status;
}

GW_INTERNAL void gw_fmi2_allow_discard(gw_fmu *F) {
    F->I->nonfinite_status = (gw_fmi2_is_me(F) && (F->state & GW_ST_ME)) ? GW_DISCARD : GW_ERROR;
}

GW_INTERNAL gw_status gw_fmi2_copy_finite(gw_fmu *F, const char *fn, double *dst,
                                          const double *src, size_t n, const char *what,
                                          const char *const *names) {
    return gw_front_copy_finite(F->I, fn, dst, src, n, what, names);
}

GW_INTERNAL void gw_fmi2_flush_log(gw_fmu *F) {
    char buf[128];
    if (F->log_repeats == 0 || !F->logger) return;
    snprintf(buf, sizeof(buf), "(the previous message was repeated %lu more time%s)",
             F->log_repeats, F->log_repeats == 1 ? "" : "s");
    F->log_repeats = 0;
    F->logger(F->env, F->I->name ? F->I->name : "", F->log_last_status, F->log_last_category,
              buf);
}

/* the core's logger: env is the gw_fmu.  A message with a status other than fmi2OK that
 * repeats the previous such message is counted, not passed on (an importer that ignores a
 * status and keeps calling gets one line, not one per call). */
static void gw_fmi2_logger(void *env, const char *name, gw_status status, const char *category,
                           const char *message) {
    gw_fmu *F = (gw_fmu *)env;
    char buf[2048];
    if (status != GW_OK) {
        unsigned long long h = gw_front_hash(message, (int)status);
        if (F->log_last_category && h == F->log_last_hash) {
            F->log_repeats++;
            return;
        }
        gw_fmi2_flush_log(F);
        F->log_last_hash = h;
        F->log_last_status = gw_fmi2_status(status);
        F->log_last_category = category;
    }
    gw_front_escape(buf, sizeof(buf), message);
    F->logger(F->env, name, gw_fmi2_status(status), category, buf);
}

/* a new run: the next message is logged whatever it repeats */
static void gw_fmi2_forget_log(gw_fmu *F) {
    gw_fmi2_flush_log(F);
    F->log_last_category = NULL;
    F->log_last_hash = 0;
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
    gw_front_escape(buf, sizeof(buf), raw);
    cb->logger(cb->componentEnvironment, name, fmi2Error, "logStatusError", buf);
}

/* ---- inquire version numbers and set debug logging ----------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    GW_FRAME(SetDebugLogging);
    GW_TRY(gw_set_logging(I, fn, loggingOn, nCategories, categories));
    GW_FRAME_END();
}

/* ---- creation and destruction ------------------------------------------------------------- */

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    GW_FN(Instantiate); /* no frame: there is no instance yet */
    const gw_model *m = &GW_MODEL;
    gw_fmu *F;
    gw_callbacks cb;
    const char *name = instanceName ? instanceName : "";
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions) return NULL;
    if (!functions->allocateMemory || !functions->freeMemory) {
        gw_fmi2_instantiate_error(functions, name,
                                  "%s: allocateMemory and freeMemory callbacks are required", fn);
        return NULL;
    }
    if (!instanceName || instanceName[0] == '\0') {
        gw_fmi2_instantiate_error(functions, name, "%s: missing instance name", fn);
        return NULL;
    }
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        gw_fmi2_instantiate_error(functions, name,
                                  "%s: %s: unknown fmuType %d (expected "
                                  "fmi2ModelExchange=%d or fmi2CoSimulation=%d)",
                                  fn, m->identifier, (int)fmuType, (int)fmi2ModelExchange,
                                  (int)fmi2CoSimulation);
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, m->token) != 0) {
        gw_fmi2_instantiate_error(functions, name,
                                  "%s: GUID \"%s\" does not match the model's \"%s\"",
                                  fn, fmuGUID ? fmuGUID : "(null)", m->token);
        return NULL;
    }
    if (!m->ode.eval || !m->init.eval || (m->ny > 0 && !m->out.eval) ||
        (m->ne > 0 && !m->evt.eval) || (m->nc > 0 && !m->chk.eval)) {
        gw_fmi2_instantiate_error(functions, name,
                                  "%s: model %s lacks a required function", fn, m->identifier);
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
        gw_fmi2_instantiate_error(functions, name, "%s: out of memory", fn);
        return NULL;
    }
    F->fmu_type = (int)fmuType;
    F->last_dostep_status = fmi2OK;
    /* non-finite values: fmi2Error, but fmi2Discard where a Model Exchange function may say
     * so (gw_fmi2_allow_discard) */
    F->I->nonfinite_status = GW_ERROR;
    gw_fmi2_set_state(F, GW_ST_INSTANTIATED);
    return (fmi2Component)F;
}

void fmi2FreeInstance(fmi2Component c) {
    gw_fmu *F = (gw_fmu *)c;
    fmi2CallbackFreeMemory free_memory;
    if (!F) return;
    gw_fmi2_flush_log(F);
    gw_instance_free(F->I);
    free_memory = F->free_memory;
    free_memory(F);
}

/* ---- initialisation, termination and reset -------------------------------------------------- */

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    GW_FRAME(SetupExperiment);
    GW_TRY(gw_setup_experiment(I, fn, toleranceDefined, tolerance,
                               startTime, stopTimeDefined, stopTime));
    GW_FRAME_END();
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    GW_FRAME(EnterInitializationMode);
    gw_fmi2_set_state(F, GW_ST_INIT_MODE);
    GW_FRAME_END();
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    gw_status st;
    GW_FRAME(ExitInitializationMode);
    /* CS and ME alike: every check first; a refusal is fmi2Error with its reasons and the
     * instance not half-initialised (fmi2Discard is not an answer of this function) */
    st = gw_initialize(I, fn);
    if (st > GW_WARNING) {
        status = fmi2Error;
        goto END;
    }
    /* ME continues in Event Mode */
    gw_fmi2_set_state(F, gw_fmi2_is_me(F) ? GW_ST_EVENT_MODE : GW_ST_STEP_COMPLETE);
    F->initialized = 1;
    F->last_dostep_status = fmi2OK;
    status = gw_fmi2_status(st);
    GW_FRAME_END();
}

/* Terminated, also as the answer to two habits of importers (FMI 2.0.4 section 2.1.6 lists
 * neither): a second fmi2Terminate is ignored, and one after an fmi2Error keeps the last
 * consistent state (every failed call restores it) readable.  Both say so (fmi2Warning). */
fmi2Status fmi2Terminate(fmi2Component c) {
    GW_FRAME(Terminate);
    gw_fmi2_flush_log(F);
    if (F->state == GW_ST_TERMINATED) {
        gw_log(I, GW_WARNING, GW_LOG_WARNING, "%s: already terminated; the call is ignored", fn);
        status = fmi2Warning;
        goto END;
    }
    if (F->state == GW_ST_ERROR) {
        if (!F->initialized) {
            GW_FAIL("%s: the instance failed before its initialisation ended; there is no "
                    "simulation to terminate (call fmi2Reset or fmi2FreeInstance)", fn);
        }
        gw_log(I, GW_WARNING, GW_LOG_WARNING,
               "%s: called after an fmi2Error (FMI 2.0.4 section 2.1.6 does not allow it): "
               "terminated at t=%.17g with the last consistent state", fn, I->t);
        status = fmi2Warning;
    }
    gw_fmi2_set_state(F, GW_ST_TERMINATED);
    GW_FRAME_END();
}

fmi2Status fmi2Reset(fmi2Component c) {
    GW_FRAME(Reset);
    gw_fmi2_forget_log(F);
    gw_instance_reset(I);
    gw_fmi2_set_state(F, GW_ST_INSTANTIATED);
    F->last_dostep_status = fmi2OK;
    F->initialized = 0;
    GW_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
