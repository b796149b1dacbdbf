/*
 * gw_fmi3_common.c -- FMI 3.0 functions common to Co-Simulation and Model Exchange: version,
 * debug logging, instantiation (the importer's logger adapted to the core's, the C library's
 * allocator), the state machine, initialisation (with the experiment, FMI 3.0.2 section
 * 3.2.1), termination and reset.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu3.c */
#else

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gw_fmi3.h"
#include "gw_front.h"

/* the frames of this file's functions (GW3_FRAME, gw_fmi3.h): interface, legal states */
#define GW3_IFACE_SetDebugLogging GW3_IFACE_ANY
#define GW3_IFACE_EnterInitializationMode GW3_IFACE_ANY
#define GW3_IFACE_ExitInitializationMode GW3_IFACE_ANY
#define GW3_IFACE_Terminate GW3_IFACE_ANY
#define GW3_IFACE_Reset GW3_IFACE_ANY
#define GW3_MASK_SetDebugLogging GW3_ST_ANY
#define GW3_MASK_Reset GW3_ST_ANY
#define GW3_MASK_EnterInitializationMode GW3_ST_INSTANTIATED
#define GW3_MASK_ExitInitializationMode GW3_ST_INIT_MODE
/* FMI 3.0.2 (section 2.3.1, the state machine) allows fmi3Terminate in Event, Step and
 * Continuous-Time Mode; as the FMI 2.0 layer, it is also answered in Terminated (a repeat:
 * ignored) and, after an initialisation, in Error (the last consistent state is kept) */
#define GW3_MASK_Terminate                                                                      \
    (GW3_ST_EVENT_MODE | GW3_ST_STEP_MODE | GW3_ST_CONT_TIME_MODE | GW3_ST_TERMINATED |         \
     GW3_ST_ERROR)

/* ---- statuses, states, logging ---------------------------------------------------------- */

GW_INTERNAL fmi3Status gw_fmi3_status(gw_status s) {
    switch (s) {
    case GW_OK: return fmi3OK;
    case GW_WARNING: return fmi3Warning;
    case GW_DISCARD: return fmi3Discard;
    case GW_ERROR: return fmi3Error;
    default: return fmi3Fatal;
    }
}

GW_INTERNAL const char *gw_fmi3_state_name(int state) {
    switch (state) {
    case GW3_ST_INSTANTIATED: return "Instantiated";
    case GW3_ST_INIT_MODE: return "InitializationMode";
    case GW3_ST_EVENT_MODE: return "EventMode";
    case GW3_ST_CONT_TIME_MODE: return "ContinuousTimeMode";
    case GW3_ST_STEP_MODE: return "StepMode";
    case GW3_ST_TERMINATED: return "Terminated";
    case GW3_ST_ERROR: return "Error";
    case GW3_ST_FATAL: return "Fatal";
    default: return "?";
    }
}

GW_INTERNAL void gw_fmi3_set_state(gw_fmu3 *F, int state) {
    F->state = state;
    /* the core evaluates the start values until the initialisation has ended; an error leaves
       that as it was (an instance refused a call before initialising still has only its start
       values: its getters and partials answer from them) */
    if (state != GW3_ST_ERROR && state != GW3_ST_FATAL) F->I->in_setup = (state & GW3_ST_BEFORE_INIT_END) != 0;
}

/* the Error state, unless the instance is already beyond repair */
static void gw_fmi3_enter_error(gw_fmu3 *F) {
    if (F->state != GW3_ST_FATAL) gw_fmi3_set_state(F, GW3_ST_ERROR);
}

GW_INTERNAL int gw_fmi3_begin(gw_fmu3 *F, const char *fn, int mask) {
    if (!F) return 0;
    if (!(F->state & mask)) {
        GW_LOG_ERR(F->I, "%s: illegal call in state %s", fn, gw_fmi3_state_name(F->state));
        gw_fmi3_enter_error(F);
        return 0;
    }
    return 1;
}

GW_INTERNAL int gw_fmi3_interface(gw_fmu3 *F, const char *fn, int iface) {
    if (!F) return 0;
    F->call = fn; /* every frame starts here: the name the logger puts before core messages */
    if (F->iface & iface) return 1;
    if (iface == GW3_IFACE_ME)
        GW_LOG_ERR(F->I, "%s: Model Exchange function, not available in an instance "
                   "instantiated for Co-Simulation", fn);
    else
        GW_LOG_ERR(F->I, "%s: Co-Simulation function, not available in an instance "
                   "instantiated for Model Exchange", fn);
    gw_fmi3_enter_error(F);
    return 0;
}

GW_INTERNAL fmi3Status gw_fmi3_end(gw_fmu3 *F, fmi3Status status) {
    F->I->nonfinite_status = GW_ERROR;
    if (status == fmi3Fatal)
        gw_fmi3_set_state(F, GW3_ST_FATAL);
    else if (status == fmi3Error)
        gw_fmi3_set_state(F, GW3_ST_ERROR);
    return status;
}

GW_INTERNAL GW_MAYBE_UNUSED void gw_fmi3_allow_discard(gw_fmu3 *F) {
    F->I->nonfinite_status = (gw_fmi3_is_me(F) &&
                              (F->state & (GW3_ST_EVENT_MODE | GW3_ST_CONT_TIME_MODE)))
                                 ? GW_DISCARD
                                 : GW_ERROR;
}

GW_INTERNAL GW_MAYBE_UNUSED gw_status gw_fmi3_copy_finite(gw_fmu3 *F, const char *fn,
                                                          double *dst, const double *src,
                                                          size_t n, const char *what,
                                                          const char *const *names) {
    return gw_front_copy_finite(F->I, fn, dst, src, n, what, names);
}

GW_INTERNAL void gw_fmi3_flush_log(gw_fmu3 *F) {
    char buf[128];
    if (F->log_repeats == 0 || !F->logger) return;
    snprintf(buf, sizeof(buf), "(the previous message was repeated %lu more time%s)",
             F->log_repeats, F->log_repeats == 1 ? "" : "s");
    F->log_repeats = 0;
    F->logger(F->env, F->log_last_status, F->log_last_category, buf);
}

/* the core's logger: env is the gw_fmu3.  A message with a status other than fmi3OK that
 * repeats the previous such message is counted, not passed on (an importer that ignores a
 * status and keeps calling gets one line, not one per call).  FMI 3.0's logger has no
 * instance name: the importer's instanceEnvironment tells the instance. */
static void gw_fmi3_logger(void *env, const char *name, gw_status status, const char *category,
                           const char *message) {
    gw_fmu3 *F = (gw_fmu3 *)env;
    char raw[2048], buf[2048];
    (void)name;
    /* The core's own messages (the solver's, the events') do not name the FMI call they come
     * from; in FMI 3 every message of a call starts with the call's name */
    if (F->call && strncmp(message, "fmi3", 4) != 0) {
        snprintf(raw, sizeof(raw), "%s: %s", F->call, message);
        message = raw;
    }
    if (status != GW_OK) {
        unsigned long long h = gw_front_hash(message, (int)status);
        if (F->log_last_category && h == F->log_last_hash) {
            F->log_repeats++;
            return;
        }
        gw_fmi3_flush_log(F);
        F->log_last_hash = h;
        F->log_last_status = gw_fmi3_status(status);
        F->log_last_category = category;
    }
    gw_front_escape(buf, sizeof(buf), message);
    F->logger(F->env, gw_fmi3_status(status), category, buf);
}

/* a new run: the next message is logged whatever it repeats */
static void gw_fmi3_forget_log(gw_fmu3 *F) {
    gw_fmi3_flush_log(F);
    F->log_last_category = NULL;
    F->log_last_hash = 0;
}

/* an error before there is an instance to log through */
static void gw_fmi3_instantiate_error(fmi3LogMessageCallback logger, fmi3InstanceEnvironment env,
                                      const char *fmt, ...) GW_PRINTF(3, 4);
static void gw_fmi3_instantiate_error(fmi3LogMessageCallback logger, fmi3InstanceEnvironment env,
                                      const char *fmt, ...) {
    va_list ap;
    char raw[1024], buf[2048];
    if (!logger) return;
    va_start(ap, fmt);
    vsnprintf(raw, sizeof(raw), fmt, ap);
    va_end(ap);
    gw_front_escape(buf, sizeof(buf), raw);
    logger(env, fmi3Error, "logStatusError", buf);
}

/* FMI 3.0 has no memory callbacks: the C library's allocator, through the core's gw_allocator
 * (its context is unused: no state outside the instance) */
static void *gw_fmi3_allocate(void *ctx, size_t n, size_t size) {
    (void)ctx;
    return calloc(n, size);
}

static void gw_fmi3_free(void *ctx, void *ptr) {
    (void)ctx;
    free(ptr);
}

/* the checks and allocation both instantiate functions share; NULL (reason logged) if refused */
static gw_fmu3 *gw_fmi3_new(const char *fn, fmi3String instanceName,
                            fmi3String instantiationToken, fmi3Boolean loggingOn,
                            fmi3InstanceEnvironment env, fmi3LogMessageCallback logger,
                            int iface) {
    const gw_model *m = &GW_MODEL;
    gw_fmu3 *F;
    gw_callbacks cb;
    gw_allocator alloc;
    if (!instanceName || instanceName[0] == '\0') {
        gw_fmi3_instantiate_error(logger, env, "%s: missing instance name", fn);
        return NULL;
    }
    if (!instantiationToken || strcmp(instantiationToken, m->token) != 0) {
        gw_fmi3_instantiate_error(logger, env,
                                  "%s: instantiationToken \"%s\" does not match the model's "
                                  "\"%s\"", fn, instantiationToken ? instantiationToken
                                                                   : "(null)", m->token);
        return NULL;
    }
    if (!m->ode.eval || !m->init.eval || (m->ny > 0 && !m->out.eval) ||
        (m->ne > 0 && !m->evt.eval) || (m->nc > 0 && !m->chk.eval)) {
        gw_fmi3_instantiate_error(logger, env, "%s: model %s lacks a required function", fn,
                                  m->identifier);
        return NULL;
    }
    F = (gw_fmu3 *)calloc(1, sizeof(gw_fmu3));
    if (F) {
        F->logger = logger;
        F->env = env;
        cb.logger = logger ? gw_fmi3_logger : NULL;
        cb.allocate = NULL; /* replaced by alloc */
        cb.free = NULL;
        cb.env = F;
        alloc.allocate = gw_fmi3_allocate;
        alloc.free = gw_fmi3_free;
        alloc.ctx = NULL;
        F->I = gw_instance_new_with(m, instanceName, &cb, &alloc, loggingOn);
        if (!F->I) {
            free(F);
            F = NULL;
        }
    }
    if (!F) {
        gw_fmi3_instantiate_error(logger, env, "%s: out of memory", fn);
        return NULL;
    }
    F->iface = iface;
    /* non-finite values: fmi3Error, but fmi3Discard where a Model Exchange function may say
     * so (gw_fmi3_allow_discard) */
    F->I->nonfinite_status = GW_ERROR;
    gw_fmi3_set_state(F, GW3_ST_INSTANTIATED);
    return F;
}

/* ---- inquire version number and set debug logging ----------------------------------------- */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn,
                               size_t nCategories, const fmi3String categories[]) {
    GW3_FRAME(SetDebugLogging);
    GW3_TRY(gw_set_logging(I, fn, loggingOn, nCategories, categories));
    GW3_FRAME_END();
}

/* ---- creation and destruction (FMI 3.0.2 sections 2.3.1, 3.2.1, 4.2.1) --------------------- */

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName,
                                          fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    GW3_FN(InstantiateModelExchange); /* no frame: there is no instance yet */
    (void)resourcePath;
    (void)visible;
    return (fmi3Instance)gw_fmi3_new(fn, instanceName, instantiationToken, loggingOn,
                                     instanceEnvironment, logMessage, GW3_IFACE_ME);
}

/* eventModeUsed: the master handles update events in Event Mode (fmi3DoStep returns early at
 * them when earlyReturnAllowed too, gw_fmi3_cs.c).  The FMU provides no intermediate update
 * (providesIntermediateUpdate="false"): required intermediate variables are refused. */
fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    GW3_FN(InstantiateCoSimulation); /* no frame: there is no instance yet */
    gw_fmu3 *F;
    (void)resourcePath;
    (void)visible;
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    if (nRequiredIntermediateVariables > 0) {
        gw_fmi3_instantiate_error(logMessage, instanceEnvironment,
                                  "%s: %lu required intermediate variables, but this FMU "
                                  "provides no intermediate update (providesIntermediateUpdate"
                                  "=\"false\")", fn, (unsigned long)nRequiredIntermediateVariables);
        return NULL;
    }
    F = gw_fmi3_new(fn, instanceName, instantiationToken, loggingOn, instanceEnvironment,
                    logMessage, GW3_IFACE_CS);
    if (F) {
        F->event_mode_used = eventModeUsed ? 1 : 0;
        F->early_return_allowed = earlyReturnAllowed ? 1 : 0;
    }
    return (fmi3Instance)F;
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    GW3_FN(InstantiateScheduledExecution);
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    gw_fmi3_instantiate_error(logMessage, instanceEnvironment,
                              "%s: this FMU has no Scheduled Execution interface (its "
                              "modelDescription.xml has no <ScheduledExecution>)", fn);
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    gw_fmu3 *F = (gw_fmu3 *)instance;
    if (!F) return;
    gw_fmi3_flush_log(F);
    gw_instance_free(F->I);
    free(F);
}

/* ---- initialisation, termination and reset -------------------------------------------------- */

/* FMI 3.0 passes the experiment here (fmi2SetupExperiment's arguments) */
fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    GW3_FRAME(EnterInitializationMode);
    GW3_TRY(gw_setup_experiment(I, fn, toleranceDefined, tolerance, startTime, stopTimeDefined,
                                stopTime));
    gw_fmi3_set_state(F, GW3_ST_INIT_MODE);
    GW3_FRAME_END();
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    gw_status st;
    GW3_FRAME(ExitInitializationMode);
    /* every check first; a refusal is fmi3Error with its reasons and the instance not
     * half-initialised */
    st = gw_initialize(I, fn);
    if (st > GW_WARNING) {
        status = fmi3Error;
        goto END;
    }
    /* ME, and CS with eventModeUsed, continue in Event Mode (FMI 3.0.2 sections 3.2.1,
     * 4.2.1): the master calls fmi3UpdateDiscreteStates, then leaves it */
    gw_fmi3_set_state(F, gw_fmi3_is_me(F) || F->event_mode_used ? GW3_ST_EVENT_MODE
                                                                : GW3_ST_STEP_MODE);
    F->initialized = 1;
    F->event_pending = 0;
    status = gw_fmi3_status(st);
    GW3_FRAME_END();
}

/* Terminated, also as the answer to two habits of importers: a second fmi3Terminate is
 * ignored, and one after an fmi3Error keeps the last consistent state (every failed call
 * restores it) readable.  Both say so (fmi3Warning). */
fmi3Status fmi3Terminate(fmi3Instance instance) {
    GW3_FRAME(Terminate);
    gw_fmi3_flush_log(F);
    if (F->state == GW3_ST_TERMINATED) {
        gw_log(I, GW_WARNING, GW_LOG_WARNING, "%s: already terminated; the call is ignored", fn);
        status = fmi3Warning;
        goto END;
    }
    if (F->state == GW3_ST_ERROR) {
        if (!F->initialized) {
            GW3_FAIL("%s: the instance failed before its initialisation ended; there is no "
                     "simulation to terminate (call fmi3Reset or fmi3FreeInstance)", fn);
        }
        gw_log(I, GW_WARNING, GW_LOG_WARNING,
               "%s: called after an fmi3Error: terminated at t=%.17g with the last consistent "
               "state", fn, I->t);
        status = fmi3Warning;
    }
    gw_fmi3_set_state(F, GW3_ST_TERMINATED);
    GW3_FRAME_END();
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    GW3_FRAME(Reset);
    gw_fmi3_forget_log(F);
    gw_instance_reset(I);
    gw_fmi3_set_state(F, GW3_ST_INSTANTIATED);
    F->initialized = 0;
    F->event_pending = 0;
    GW3_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
