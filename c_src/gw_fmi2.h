/*
 * gw_fmi2.h -- the FMI 2.0 layer over the simulation core: the only code that includes
 * fmi2Functions.h.  An fmi2Component is a gw_fmu: the core instance plus the FMI state
 * machine, the interface it was instantiated for and the importer's callbacks.  The layer
 * maps gw_status to fmi2Status, adapts the importer's logger, and checks every call against
 * the state machine (bit masks as in modelica/Reference-FMUs):
 *   CS: Instantiated -> InitializationMode -> StepComplete <-> StepFailed -> Terminated
 *   ME: Instantiated -> InitializationMode -> EventMode <-> ContinuousTimeMode -> Terminated
 * A function of the other interface fails with fmi2Error and a logged reason.
 *
 * After the simulation terminated (a terminating event: fmi2DoStep's fmi2Discard, Model
 * Exchange's terminateSimulation) the instance stays terminated and truthful; the calls
 * importers habitually make then are answered without an error (docs/fmi.md "After the
 * simulation terminated"): another fmi2DoStep is fmi2Discard, fmi2EnterContinuousTimeMode is
 * accepted (fmi2CompletedIntegratorStep keeps saying terminateSimulation), a second
 * fmi2Terminate is fmi2Warning.  Every status other than fmi2OK comes with one logged reason
 * (always, whatever the debug-logging settings); a run of identical messages is logged once
 * and counted ("repeated N more times").
 *
 * Files: gw_fmi2_common.c (life cycle), gw_fmi2_variables.c (fmi2Get/Set*),
 * gw_fmi2_cs.c (Co-Simulation), gw_fmi2_me.c (Model Exchange), gw_fmi2_dirder.c
 * (fmi2GetDirectionalDerivative), gw_fmi2_state.c (FMU states).
 */
#ifndef GW_FMI2_H
#define GW_FMI2_H

#include "fmi2Functions.h"
#include "gw_instance.h"

/* ---- FMI states (one bit each) ----------------------------------------------------------- */
enum {
    GW_ST_INSTANTIATED = 1 << 0,
    GW_ST_INIT_MODE = 1 << 1,
    GW_ST_STEP_COMPLETE = 1 << 2,
    GW_ST_STEP_FAILED = 1 << 3, /* after fmi2Discard (terminating event) */
    GW_ST_TERMINATED = 1 << 4,
    GW_ST_ERROR = 1 << 5,
    GW_ST_FATAL = 1 << 6
};
/* Model Exchange states (Co-Simulation never enters them) */
enum { GW_ST_EVENT_MODE = 1 << 7, GW_ST_CONT_TIME_MODE = 1 << 8 };

/* states in which each function may be called */
#define GW_ST_ME (GW_ST_EVENT_MODE | GW_ST_CONT_TIME_MODE)
#define GW_ST_ANY                                                                               \
    (GW_ST_INSTANTIATED | GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED |           \
     GW_ST_TERMINATED | GW_ST_ERROR | GW_ST_ME)
/* the core's set-up phase (I->in_setup) */
#define GW_ST_BEFORE_INIT_END (GW_ST_INSTANTIATED | GW_ST_INIT_MODE)
/* fmi2SetReal (FMI 2.0.4 tables of sections 3.2.3 and 4.2.4); which variable may be set
 * when is gw_fmi2_settable's rule.  StepFailed: inputs after a terminating event (stored,
 * harmless: the instance never steps again) */
#define GW_MASK_Set                                                                             \
    (GW_ST_INSTANTIATED | GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_ME)
/* fmi2SetInteger, fmi2SetBoolean, fmi2SetString: not in Continuous-Time Mode */
#define GW_MASK_SetDiscrete (GW_MASK_Set & ~GW_ST_CONT_TIME_MODE)
#define GW_MASK_NotSupported GW_ST_ANY

/* ---- the component ---------------------------------------------------------------------- */
typedef struct {
    gw_instance *I;
    int state;                     /* one GW_ST_* bit; set only by gw_fmi2_set_state */
    int fmu_type;                  /* fmi2ModelExchange or fmi2CoSimulation */
    fmi2Status last_dostep_status; /* of the last fmi2DoStep */
    int initialized; /* fmi2ExitInitializationMode succeeded since instantiation or reset */
    /* the last message with a status other than fmi2OK (hash) and how often it repeated
     * since: a run of identical reasons is logged once, then counted */
    unsigned long long log_last_hash;
    unsigned long log_repeats;
    fmi2Status log_last_status;
    const char *log_last_category;
    /* the importer's callbacks (the FMI 2.0.0 headers declare the fields of
     * fmi2CallbackFunctions const, which forbids copying the struct) */
    fmi2CallbackLogger logger;
    fmi2CallbackFreeMemory free_memory;
    fmi2ComponentEnvironment env;
} gw_fmu;

/* ---- gw_fmi2_common.c ---------------------------------------------------------------------- */
GW_INTERNAL fmi2Status gw_fmi2_status(gw_status s);
static inline fmi2Status gw_fmi2_worst(fmi2Status a, fmi2Status b) { return a > b ? a : b; }
GW_INTERNAL const char *gw_fmi2_state_name(int state);
/* the only way F->state changes: keeps the core's set-up phase in step */
GW_INTERNAL void gw_fmi2_set_state(gw_fmu *F, int state);
/* 1 if F is usable and its state is in mask; else logs, enters Error, returns 0 */
GW_INTERNAL int gw_fmi2_begin(gw_fmu *F, const char *fn, int mask);
/* 1 if F was instantiated for `type` (GW_IFACE_BOTH: any); else logs, enters Error, returns 0 */
GW_INTERNAL int gw_fmi2_interface(gw_fmu *F, const char *fn, int type);
/* the function's final status; fmi2Error / fmi2Fatal enter the Error / Fatal state; the
 * answer to non-finite values returns to fmi2Error (gw_fmi2_allow_discard) */
GW_INTERNAL fmi2Status gw_fmi2_end(gw_fmu *F, fmi2Status status);
/* Model Exchange functions that FMI 2.0.4 (section 2.1.3) lets answer fmi2Discard: the core
 * answers non-finite values with GW_DISCARD in Event and Continuous-Time Mode (the importer
 * may retry with a smaller step), with GW_ERROR otherwise (Initialization Mode: bad input) */
GW_INTERNAL void gw_fmi2_allow_discard(gw_fmu *F);
/* log "(the previous message was repeated N more times)" if a run of repeats is pending */
GW_INTERNAL void gw_fmi2_flush_log(gw_fmu *F);
/* copy n values to the caller's array only if every one is finite; else leaves dst untouched,
 * logs which value is not (names[i] or what) and returns the answer to non-finite values
 * (a gw_status, for GW_TRY) */
GW_INTERNAL gw_status gw_fmi2_copy_finite(gw_fmu *F, const char *fn, double *dst,
                                          const double *src, size_t n, const char *what,
                                          const char *const *names);

static inline int gw_fmi2_is_me(const gw_fmu *F) { return F->fmu_type == fmi2ModelExchange; }

/* ---- the frame of every fmi2 function ------------------------------------------------------
 * GW_FRAME(Name) opens the body of fmi2Name, Name being the function's name without its "fmi2"
 * prefix (as modelica/Reference-FMUs' BEGIN_FUNCTION(F) with MASK_fmi2##F and #F):
 *   fn       "fmi2Name" (GW_FN), the name every message of the function starts with;
 *   F, I     the component and its core instance; status: the worst status so far, fmi2OK;
 *   checks   the interface, GW_IFACE_Name (fmi2CoSimulation or fmi2ModelExchange: functions
 *            of that interface only; GW_IFACE_BOTH), then the state, GW_MASK_Name (the states
 *            in which FMI 2.0.4 allows the call, tables of sections 3.2.3 and 4.2.4): a call
 *            that fails either is logged, enters the Error state and returns fmi2Error.
 * The GW_IFACE_ and GW_MASK_ macros of a function stand next to it, in its file.  A function
 * that answers some calls before the state check (fmi2DoStep after a terminating event,
 * fmi2GetDirectionalDerivative of a model without partial derivatives) opens with
 * GW_FRAME_OPEN(Name) and checks with GW_FRAME_CHECK_STATE() after that answer.  GW_FRAME_END()
 * closes every frame: the final status through gw_fmi2_end. */
#define GW_IFACE_BOTH (-1)
#define GW_FN(name) static const char fn[] = "fmi2" #name
#define GW_FRAME_OPEN(name)                                                                     \
    GW_FN(name);                                                                                \
    const int gw_frame_mask = GW_MASK_##name;                                                   \
    gw_fmu *F = (gw_fmu *)c;                                                                    \
    gw_instance *I;                                                                             \
    fmi2Status status = fmi2OK;                                                                 \
    if (!gw_fmi2_interface(F, fn, GW_IFACE_##name)) return fmi2Error;                           \
    I = F->I;                                                                                   \
    (void)I;                                                                                    \
    if (0) goto END
#define GW_FRAME_CHECK_STATE()                                                                  \
    if (!gw_fmi2_begin(F, fn, gw_frame_mask)) return fmi2Error
#define GW_FRAME(name)                                                                          \
    GW_FRAME_OPEN(name);                                                                        \
    GW_FRAME_CHECK_STATE()

/* a core call's status, mapped; leave on anything worse than a warning */
#define GW_TRY(expr)                                                                            \
    do {                                                                                        \
        status = gw_fmi2_worst(status, gw_fmi2_status(expr));                                   \
        if (status > fmi2Warning) goto END;                                                     \
    } while (0)
/* log an error (in a frame, its text starts with "%s: " and fn) and leave with fmi2Error */
#define GW_FAIL(...)                                                                            \
    do {                                                                                        \
        GW_LOG_ERR(I, __VA_ARGS__);                                                             \
        status = fmi2Error;                                                                     \
        goto END;                                                                               \
    } while (0)
#define GW_FRAME_END()                                                                          \
    END:                                                                                        \
    return gw_fmi2_end(F, status)

#endif /* GW_FMI2_H */
