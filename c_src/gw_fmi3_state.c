/*
 * gw_fmi3_state.c -- fmi3Get/Set/FreeFMUState and fmi3(De)SerializeFMUState (FMI 3.0.2
 * section 2.2.6.4).  An fmi3FMUState is one blob (gw_state_blob.c, shared with the FMI 2.0
 * layer) holding the core's serialised state (gw_state.c, layout there) with the front end's
 * two ints:
 *   front[0]  the FMI 3 state the state was taken in (one GW3_ST_* bit)
 *   front[1]  GW3_FRONT_FMI3 (this layer's mark), GW3_FRONT_INITIALIZED (fmi3ExitInitialization
 *             Mode had succeeded), GW3_FRONT_EVENT_PENDING (Co-Simulation: an fmi3DoStep
 *             returned early at an update event that Event Mode has not applied yet; the
 *             core's state holds that update itself, the events it fires: gw_state.c)
 * so that restoring gives back the instance exactly, Event Mode and pending event included:
 * fmi3UpdateDiscreteStates after a restore applies the update it would have applied.
 * The mark keeps the two layers' states apart: the FMI 2.0 layer refuses a word with bits it
 * does not know, this one a word without the mark.
 *
 * Both ints are validated on fmi3DeserializeFMUState and fmi3SetFMUState, after the core's
 * checksum and range checks (gw_state.c), against each other, against this instance
 * (interface, eventModeUsed) and against the core's fields (gw_state_check_run): a state the
 * instance could not have reached itself is refused with its reason, never applied.
 * The instantiation choices (interface, eventModeUsed, earlyReturnAllowed) belong to the
 * instance, not to a state.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu3.c */
#else

#include "gw_fmi3.h"

/* the frames of this file's functions (GW3_FRAME, gw_fmi3.h): both interfaces, every state
 * but Fatal (as modelica/Reference-FMUs) */
#define GW3_MASK_FMUState GW3_ST_ANY
#define GW3_IFACE_GetFMUState GW3_IFACE_ANY
#define GW3_IFACE_SetFMUState GW3_IFACE_ANY
#define GW3_IFACE_FreeFMUState GW3_IFACE_ANY
#define GW3_IFACE_SerializedFMUStateSize GW3_IFACE_ANY
#define GW3_IFACE_SerializeFMUState GW3_IFACE_ANY
#define GW3_IFACE_DeserializeFMUState GW3_IFACE_ANY
#define GW3_MASK_GetFMUState GW3_MASK_FMUState
#define GW3_MASK_SetFMUState GW3_MASK_FMUState
#define GW3_MASK_FreeFMUState GW3_MASK_FMUState
#define GW3_MASK_SerializedFMUStateSize GW3_MASK_FMUState
#define GW3_MASK_SerializeFMUState GW3_MASK_FMUState
#define GW3_MASK_DeserializeFMUState GW3_MASK_FMUState

#define GW3_FRONT_INITIALIZED 0x10
#define GW3_FRONT_EVENT_PENDING 0x20
#define GW3_FRONT_FMI3 0x100

static int gw_fmi3_valid_state(int s) {
    return s == GW3_ST_INSTANTIATED || s == GW3_ST_INIT_MODE || s == GW3_ST_EVENT_MODE ||
           s == GW3_ST_CONT_TIME_MODE || s == GW3_ST_STEP_MODE || s == GW3_ST_TERMINATED ||
           s == GW3_ST_ERROR;
}

/* The interface's own states: Continuous-Time Mode is Model Exchange's, Step Mode
 * Co-Simulation's, Event Mode both (Co-Simulation's with eventModeUsed only).  NULL if this
 * instance may be in state st, else why not. */
static const char *gw_fmi3_foreign_state(const gw_fmu3 *F, int st) {
    if (gw_fmi3_is_me(F))
        return st == GW3_ST_STEP_MODE ? "a Co-Simulation instance" : NULL;
    if (st == GW3_ST_CONT_TIME_MODE) return "a Model Exchange instance";
    if (st == GW3_ST_EVENT_MODE && !F->event_mode_used)
        return "an instance in Event Mode; this one was instantiated with eventModeUsed = false";
    return NULL;
}

/* The front ints of a state the core accepted, for this instance (gw_blob_front_check): 1
 * and *facts, or 0 with the reason logged. */
static int gw_fmi3_check_front(void *front_end, const char *fn, const int front[2],
                               gw_state_facts *facts) {
    gw_fmu3 *F = (gw_fmu3 *)front_end;
    gw_instance *I = F->I;
    const int st = front[0], word = front[1];
    const int pending = (word & GW3_FRONT_EVENT_PENDING) != 0;
    const char *foreign;
    if (!(word & GW3_FRONT_FMI3)) {
        GW_LOG_ERR(I, "%s: FMU state of an FMI 2.0 instance (status word %d); an FMI 3.0 "
                   "instance takes only its own", fn, word);
        return 0;
    }
    if (!gw_fmi3_valid_state(st)) {
        GW_LOG_ERR(I, "%s: FMU state holds an invalid instance state %d", fn, st);
        return 0;
    }
    if ((word & ~(GW3_FRONT_FMI3 | GW3_FRONT_INITIALIZED | GW3_FRONT_EVENT_PENDING)) != 0) {
        GW_LOG_ERR(I, "%s: FMU state holds an invalid status word %d", fn, word);
        return 0;
    }
    foreign = gw_fmi3_foreign_state(F, st);
    if (foreign) {
        GW_LOG_ERR(I, "%s: FMU state in %s of %s cannot be set into this %s instance", fn,
                   gw_fmi3_state_name(st), foreign,
                   gw_fmi3_is_me(F) ? "Model Exchange" : "Co-Simulation");
        return 0;
    }
    facts->initialised = (word & GW3_FRONT_INITIALIZED) != 0;
    facts->time_free = gw_fmi3_is_me(F);
    facts->pending_event = pending;
    /* the states before fmi3ExitInitializationMode succeeded, and those only it leads to;
     * Error may follow either */
    if (st != GW3_ST_ERROR && facts->initialised != ((st & GW3_ST_BEFORE_INIT_END) == 0)) {
        GW_LOG_ERR(I, "%s: FMU state holds instance state %s %s an initialisation", fn,
                   gw_fmi3_state_name(st), facts->initialised ? "after" : "without");
        return 0;
    }
    /* only an initialised Co-Simulation instance that uses Event Mode has an event pending */
    if (pending && (gw_fmi3_is_me(F) || !F->event_mode_used || !facts->initialised)) {
        GW_LOG_ERR(I, "%s: FMU state holds an event pending for Event Mode in instance state "
                   "%s, which this %s instance cannot have", fn, gw_fmi3_state_name(st),
                   gw_fmi3_is_me(F) ? "Model Exchange" : "Co-Simulation");
        return 0;
    }
    return 1;
}

/* Apply a state that gw_blob_check accepted. */
static void gw_fmi3_apply_state(gw_fmu3 *F, const unsigned char *buf) {
    gw_instance *I = F->I;
    int front[2];
    gw_state_front(I, buf, front);
    gw_fmi3_set_state(F, front[0]);
    F->initialized = (front[1] & GW3_FRONT_INITIALIZED) != 0;
    F->event_pending = (front[1] & GW3_FRONT_EVENT_PENDING) != 0;
    I->in_setup = !F->initialized; /* also in Error, which may come before or after it */
    gw_state_apply(I, buf);
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    int front[2];
    GW3_FRAME(GetFMUState);
    if (!FMUState) GW3_FAIL("%s: FMUState is NULL", fn);
    front[0] = F->state;
    front[1] = GW3_FRONT_FMI3 | (F->initialized ? GW3_FRONT_INITIALIZED : 0) |
               (F->event_pending ? GW3_FRONT_EVENT_PENDING : 0);
    GW3_TRY(gw_blob_take(I, fn, FMUState, front));
    GW3_FRAME_END();
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    const gw_blob *b = (const gw_blob *)FMUState;
    GW3_FRAME(SetFMUState);
    if (!b) GW3_FAIL("%s: FMUState is NULL", fn);
    if (!gw_blob_check(I, fn, b->data, b->size, gw_fmi3_check_front, F)) {
        status = fmi3Error;
        goto END;
    }
    gw_fmi3_apply_state(F, b->data);
    GW3_FRAME_END();
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    GW3_FRAME(FreeFMUState);
    gw_blob_free(I, FMUState);
    GW3_FRAME_END();
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState,
                                      size_t *size) {
    const gw_blob *b = (const gw_blob *)FMUState;
    GW3_FRAME(SerializedFMUStateSize);
    if (!b || !size) GW3_FAIL("%s: FMUState or size is NULL", fn);
    *size = b->size;
    GW3_FRAME_END();
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size) {
    const gw_blob *b = (const gw_blob *)FMUState;
    GW3_FRAME(SerializeFMUState);
    if (!b || !serializedState) GW3_FAIL("%s: FMUState or serializedState is NULL", fn);
    GW3_TRY(gw_blob_serialize(I, fn, b, serializedState, size));
    GW3_FRAME_END();
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState) {
    GW3_FRAME(DeserializeFMUState);
    if (!FMUState) GW3_FAIL("%s: FMUState is NULL", fn);
    if (!gw_blob_check(I, fn, serializedState, size, gw_fmi3_check_front, F)) {
        status = fmi3Error;
        goto END;
    }
    GW3_TRY(gw_blob_load(I, fn, serializedState, size, FMUState));
    GW3_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
