/*
 * gw_fmi3.h -- the FMI 3.0 layer over the simulation core: the only code that includes
 * fmi3Functions.h.  An fmi3Instance is a gw_fmu3: the core instance plus the FMI 3 state
 * machine, the interface it was instantiated for and the importer's callbacks.  It mirrors
 * the FMI 2.0 layer (gw_fmi2.h) over the same core: the same statuses, checks and messages,
 * FMI 3.0's states and functions.  Calls are checked against the state machine (bit masks
 * as in modelica/Reference-FMUs, FMI 3.0.2 sections 3.2 and 4.2):
 *   CS: Instantiated -> InitializationMode -> StepMode <-> EventMode (eventModeUsed)
 *       -> Terminated
 *   ME: Instantiated -> InitializationMode -> EventMode <-> ContinuousTimeMode -> Terminated
 * A function of the other interface, or of an interface this FMU does not have (Scheduled
 * Execution, clocks, configuration mode), fails with fmi3Error and a logged reason.
 *
 * Every status other than fmi3OK comes with one logged reason (always, whatever the
 * debug-logging settings); a run of identical messages is logged once and counted.
 * FMI 3.0 has no memory callbacks: the instance allocates with the C library's allocator.
 *
 * Files: gw_fmi3_common.c (life cycle, logging, state machine), gw_fmi3_variables.c
 * (fmi3Get/Set*), gw_fmi3_cs.c (Co-Simulation: fmi3DoStep with early return, event mode),
 * gw_fmi3_me.c (Model Exchange), gw_fmi3_dirder.c (directional and adjoint derivatives),
 * gw_fmi3_state.c (FMU states), gw_fmi3_absent.c (the functions of what this FMU does not
 * have: clocks, Scheduled Execution, configuration mode, binaries, strings).
 */
#ifndef GW_FMI3_H
#define GW_FMI3_H

/* fmi3FunctionTypes.h (FMI 3.0.2) declares the preemption-lock callbacks without a prototype,
 * `void (*)()`, which clang 15 and later report under -Wpedantic (-Wstrict-prototypes; zig's
 * clang builds the other platforms' binaries with the FMU's -Werror): the standard's header is
 * shipped as it is, the warning kept off for it alone */
#if defined(__clang__)
#pragma clang diagnostic push
#pragma clang diagnostic ignored "-Wstrict-prototypes"
#endif
#include "fmi3Functions.h"
#if defined(__clang__)
#pragma clang diagnostic pop
#endif
#include "gw_instance.h"

/* ---- FMI 3 states (one bit each) --------------------------------------------------------- */
enum {
    GW3_ST_INSTANTIATED = 1 << 0,
    GW3_ST_INIT_MODE = 1 << 1,
    GW3_ST_EVENT_MODE = 1 << 2,
    GW3_ST_CONT_TIME_MODE = 1 << 3, /* Model Exchange */
    GW3_ST_STEP_MODE = 1 << 4,      /* Co-Simulation */
    GW3_ST_TERMINATED = 1 << 5,
    GW3_ST_ERROR = 1 << 6,
    GW3_ST_FATAL = 1 << 7
};

/* states in which each function may be called */
#define GW3_ST_ANY                                                                              \
    (GW3_ST_INSTANTIATED | GW3_ST_INIT_MODE | GW3_ST_EVENT_MODE | GW3_ST_CONT_TIME_MODE |       \
     GW3_ST_STEP_MODE | GW3_ST_TERMINATED | GW3_ST_ERROR)
#define GW3_ST_BEFORE_INIT_END (GW3_ST_INSTANTIATED | GW3_ST_INIT_MODE)
#define GW3_MASK_NotSupported GW3_ST_ANY

/* the interface an instance was instantiated for */
enum { GW3_IFACE_ME = 1, GW3_IFACE_CS = 2, GW3_IFACE_ANY = 3 };

/* ---- the instance ------------------------------------------------------------------------ */
typedef struct {
    gw_instance *I;
    int state;   /* one GW3_ST_* bit; set only by gw_fmi3_set_state */
    int iface;   /* GW3_IFACE_ME or GW3_IFACE_CS */
    int initialized; /* fmi3ExitInitializationMode succeeded since instantiation or reset */
    /* Co-Simulation: the importer's choices at instantiation, and what the last fmi3DoStep
     * left (an event the master must handle in Event Mode before the next step) */
    int event_mode_used;
    int early_return_allowed;
    int event_pending;
    const char *call; /* name of the fmi3 function being called (set by its frame) */
    /* the last message with a status other than fmi3OK (hash) and how often it repeated
     * since: a run of identical reasons is logged once, then counted */
    unsigned long long log_last_hash;
    unsigned long log_repeats;
    fmi3Status log_last_status;
    const char *log_last_category;
    /* the importer's callbacks */
    fmi3LogMessageCallback logger;
    fmi3InstanceEnvironment env;
} gw_fmu3;

/* ---- gw_fmi3_common.c -------------------------------------------------------------------- */
GW_INTERNAL fmi3Status gw_fmi3_status(gw_status s);
static inline fmi3Status gw_fmi3_worst(fmi3Status a, fmi3Status b) { return a > b ? a : b; }
GW_INTERNAL const char *gw_fmi3_state_name(int state);
/* the only way F->state changes: keeps the core's set-up phase in step */
GW_INTERNAL void gw_fmi3_set_state(gw_fmu3 *F, int state);
/* 1 if F is usable and its state is in mask; else logs, enters Error, returns 0 */
GW_INTERNAL int gw_fmi3_begin(gw_fmu3 *F, const char *fn, int mask);
/* 1 if F was instantiated for an interface in `iface` (GW3_IFACE_*); else logs, enters Error,
 * returns 0 */
GW_INTERNAL int gw_fmi3_interface(gw_fmu3 *F, const char *fn, int iface);
/* the function's final status; fmi3Error / fmi3Fatal enter the Error / Fatal state */
GW_INTERNAL fmi3Status gw_fmi3_end(gw_fmu3 *F, fmi3Status status);
/* Model Exchange functions that may answer fmi3Discard for non-finite values (the importer
 * may retry with a smaller step): GW_DISCARD in Event and Continuous-Time Mode, else GW_ERROR */
GW_INTERNAL void gw_fmi3_allow_discard(gw_fmu3 *F);
/* log "(the previous message was repeated N more times)" if a run of repeats is pending */
GW_INTERNAL void gw_fmi3_flush_log(gw_fmu3 *F);
/* copy n values to the caller's array only if every one is finite; else leaves dst untouched,
 * logs which value is not and returns the answer to non-finite values (a gw_status) */
GW_INTERNAL gw_status gw_fmi3_copy_finite(gw_fmu3 *F, const char *fn, double *dst,
                                          const double *src, size_t n, const char *what,
                                          const char *const *names);

static inline int gw_fmi3_is_me(const gw_fmu3 *F) { return F->iface == GW3_IFACE_ME; }

/* ---- gw_fmi3_variables.c ------------------------------------------------------------------ */
/* the array variable of value reference vr (gw_model.h, gw_array), or NULL */
GW_INTERNAL const gw_array *gw_fmi3_array_find(const gw_model *m, unsigned int vr);

/* ---- the frame of every fmi3 function ------------------------------------------------------
 * GW3_FRAME(Name) opens the body of fmi3Name (as GW_FRAME of gw_fmi2.h): fn is "fmi3Name",
 * F, I the instance and its core, status the worst status so far.  It checks the interface
 * GW3_IFACE_Name (GW3_IFACE_ME, GW3_IFACE_CS or GW3_IFACE_ANY), then the state GW3_MASK_Name
 * (the states in which FMI 3.0.2 allows the call); a failed check is logged, enters the
 * Error state and returns fmi3Error.  GW3_FRAME_OPEN / GW3_FRAME_CHECK_STATE split the two
 * for a function that answers some calls before the state check.  GW3_FRAME_END() closes
 * every frame through gw_fmi3_end. */
#define GW3_FN(name) static const char fn[] = "fmi3" #name
#define GW3_FRAME_OPEN(name)                                                                    \
    GW3_FN(name);                                                                               \
    const int gw_frame_mask = GW3_MASK_##name;                                                  \
    gw_fmu3 *F = (gw_fmu3 *)instance;                                                           \
    gw_instance *I;                                                                             \
    fmi3Status status = fmi3OK;                                                                 \
    if (!gw_fmi3_interface(F, fn, GW3_IFACE_##name)) return fmi3Error;                          \
    I = F->I;                                                                                   \
    (void)I;                                                                                    \
    if (0) goto END
#define GW3_FRAME_CHECK_STATE()                                                                 \
    if (!gw_fmi3_begin(F, fn, gw_frame_mask)) return fmi3Error
#define GW3_FRAME(name)                                                                         \
    GW3_FRAME_OPEN(name);                                                                       \
    GW3_FRAME_CHECK_STATE()

/* a core call's status, mapped; leave on anything worse than a warning */
#define GW3_TRY(expr)                                                                           \
    do {                                                                                        \
        status = gw_fmi3_worst(status, gw_fmi3_status(expr));                                   \
        if (status > fmi3Warning) goto END;                                                     \
    } while (0)
/* log an error (its text starts with "%s: " and fn) and leave with fmi3Error */
#define GW3_FAIL(...)                                                                           \
    do {                                                                                        \
        GW_LOG_ERR(I, __VA_ARGS__);                                                             \
        status = fmi3Error;                                                                     \
        goto END;                                                                               \
    } while (0)
#define GW3_FRAME_END()                                                                         \
    END:                                                                                        \
    return gw_fmi3_end(F, status)

#endif /* GW_FMI3_H */
