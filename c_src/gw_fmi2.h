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
#define GW_MASK_Set (GW_ST_INSTANTIATED | GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_ME)
#define GW_MASK_NotSupported GW_ST_ANY

/* ---- the component ---------------------------------------------------------------------- */
typedef struct {
    gw_instance *I;
    int state;                     /* one GW_ST_* bit; set only by gw_fmi2_set_state */
    int fmu_type;                  /* fmi2ModelExchange or fmi2CoSimulation */
    fmi2Status last_dostep_status; /* of the last fmi2DoStep */
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
/* 1 if F was instantiated for `type`; else logs, enters Error, returns 0 */
GW_INTERNAL int gw_fmi2_interface(gw_fmu *F, const char *fn, int type);
/* the function's final status; fmi2Error / fmi2Fatal enter the Error / Fatal state */
GW_INTERNAL fmi2Status gw_fmi2_end(gw_fmu *F, fmi2Status status);

static inline int gw_fmi2_is_me(const gw_fmu *F) { return F->fmu_type == fmi2ModelExchange; }

/* BEGIN/END frame of every fmi2 function: check the state, keep the worst status. */
#define GW_BEGIN(fn, mask)                                                                      \
    gw_fmu *F = (gw_fmu *)c;                                                                    \
    gw_instance *I;                                                                             \
    fmi2Status status = fmi2OK;                                                                 \
    if (!gw_fmi2_begin(F, fn, mask)) return fmi2Error;                                          \
    I = F->I;                                                                                   \
    (void)I;                                                                                    \
    if (0) goto END
#define GW_BEGIN_FOR(type, fn, mask)                                                            \
    gw_fmu *F = (gw_fmu *)c;                                                                    \
    gw_instance *I;                                                                             \
    fmi2Status status = fmi2OK;                                                                 \
    if (!gw_fmi2_interface(F, fn, type)) return fmi2Error;                                      \
    if (!gw_fmi2_begin(F, fn, mask)) return fmi2Error;                                          \
    I = F->I;                                                                                   \
    (void)I;                                                                                    \
    if (0) goto END
#define GW_BEGIN_ME(fn, mask) GW_BEGIN_FOR(fmi2ModelExchange, fn, mask)
#define GW_BEGIN_CS(fn, mask) GW_BEGIN_FOR(fmi2CoSimulation, fn, mask)
/* a core call's status, mapped; leave on anything worse than a warning */
#define GW_TRY(expr)                                                                            \
    do {                                                                                        \
        status = gw_fmi2_worst(status, gw_fmi2_status(expr));                                   \
        if (status > fmi2Warning) goto END;                                                     \
    } while (0)
#define GW_FAIL(...)                                                                            \
    do {                                                                                        \
        GW_LOG_ERR(I, __VA_ARGS__);                                                             \
        status = fmi2Error;                                                                     \
        goto END;                                                                               \
    } while (0)
#define GW_END_FUNCTION()                                                                       \
    END:                                                                                        \
    return gw_fmi2_end(F, status)

#endif /* GW_FMI2_H */
