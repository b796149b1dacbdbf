/*
 * gw_fmi2_state.c -- fmi2Get/Set/FreeFMUstate and fmi2(De)SerializeFMUstate.  An fmi2FMUstate
 * is one blob (gw_state_blob.c) holding the core's serialised state (gw_state.c, layout
 * there) with the FMI state and the last fmi2DoStep status as the front end's two ints, so
 * get/set and (de)serialise share one code path.
 *
 * The fmi state may also be a Model Exchange one (EventMode, ContinuousTimeMode); a state of
 * one interface's own modes is refused by an instance of the other interface (the modes both
 * share -- Instantiated, InitializationMode, Terminated, Error -- hold nothing
 * interface-specific, so the layout needs no interface field).
 *
 * front[1] packs the last fmi2DoStep status (bits 0-3, fmi2OK..fmi2Fatal) and whether the
 * instance had been initialised (bit 4).  Both front ints are validated on
 * fmi2DeSerializeFMUstate and fmi2SetFMUstate, after the core's checksum and range checks
 * (gw_state.c), against each other and against the core's fields (gw_state_check_run: the
 * times, the events, the model's validity checks, given what the front ints say): a state
 * the instance could not have reached itself is refused with its reason, never applied.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include "gw_fmi2.h"

/* the frames of this file's functions (GW_FRAME, gw_fmi2.h): interface, legal states */
#define GW_MASK_FMUstate                                                                        \
    (GW_ST_INSTANTIATED | GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED |           \
     GW_ST_TERMINATED | GW_ST_ERROR | GW_ST_EVENT_MODE | GW_ST_CONT_TIME_MODE)
#define GW_IFACE_GetFMUstate GW_IFACE_BOTH
#define GW_IFACE_SetFMUstate GW_IFACE_BOTH
#define GW_IFACE_FreeFMUstate GW_IFACE_BOTH
#define GW_IFACE_SerializedFMUstateSize GW_IFACE_BOTH
#define GW_IFACE_SerializeFMUstate GW_IFACE_BOTH
#define GW_IFACE_DeSerializeFMUstate GW_IFACE_BOTH
#define GW_MASK_GetFMUstate GW_MASK_FMUstate
#define GW_MASK_SetFMUstate GW_MASK_FMUstate
#define GW_MASK_FreeFMUstate GW_MASK_FMUstate
#define GW_MASK_SerializedFMUstateSize GW_MASK_FMUstate
#define GW_MASK_SerializeFMUstate GW_MASK_FMUstate
#define GW_MASK_DeSerializeFMUstate GW_MASK_FMUstate

static int gw_fmi2_valid_state(int s) {
    return s == GW_ST_INSTANTIATED || s == GW_ST_INIT_MODE || s == GW_ST_STEP_COMPLETE ||
           s == GW_ST_STEP_FAILED || s == GW_ST_TERMINATED || s == GW_ST_ERROR ||
           s == GW_ST_EVENT_MODE || s == GW_ST_CONT_TIME_MODE;
}

#define GW_FRONT_STATUS_MASK 0xF
#define GW_FRONT_INITIALIZED 0x10

/* The front ints of a state the core accepted, for this instance (gw_blob_front_check): 1
 * and *facts, or 0 with the reason logged. */
static int gw_fmi2_check_front(void *front_end, const char *fn, const int front[2],
                               gw_state_facts *facts) {
    gw_fmu *F = (gw_fmu *)front_end;
    gw_instance *I = F->I;
    int st, last;
    st = front[0];
    last = front[1] & GW_FRONT_STATUS_MASK;
    if (!gw_fmi2_valid_state(st)) {
        GW_LOG_ERR(I, "%s: FMU state holds an invalid instance state %d", fn, st);
        return 0;
    }
    if ((front[1] & ~(GW_FRONT_STATUS_MASK | GW_FRONT_INITIALIZED)) != 0 || last > fmi2Fatal) {
        GW_LOG_ERR(I, "%s: FMU state holds an invalid status word %d", fn, front[1]);
        return 0;
    }
    if (((st & GW_ST_ME) && F->fmu_type != fmi2ModelExchange) ||
        ((st & (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED)) && F->fmu_type != fmi2CoSimulation)) {
        GW_LOG_ERR(I, "%s: FMU state of a %s instance cannot be set into a %s instance", fn,
                   gw_fmi2_is_me(F) ? "Co-Simulation" : "Model Exchange",
                   gw_fmi2_is_me(F) ? "Model Exchange" : "Co-Simulation");
        return 0;
    }
    facts->initialised = (front[1] & GW_FRONT_INITIALIZED) != 0;
    facts->time_free = gw_fmi2_is_me(F);
    facts->terminated = st == GW_ST_STEP_FAILED;
    /* the states before fmi2ExitInitializationMode succeeded, and those only it leads to;
     * Error may follow either */
    if (st != GW_ST_ERROR && facts->initialised != ((st & GW_ST_BEFORE_INIT_END) == 0)) {
        GW_LOG_ERR(I, "%s: FMU state holds instance state %s %s an initialisation", fn,
                   gw_fmi2_state_name(st), facts->initialised ? "after" : "without");
        return 0;
    }
    /* fmi2DoStep's status: fmi2OK until the first step, fmi2Discard in StepFailed */
    if ((!facts->initialised && last != fmi2OK) ||
        (st == GW_ST_STEP_FAILED && last != fmi2Discard)) {
        GW_LOG_ERR(I, "%s: FMU state holds last fmi2DoStep status %d in instance state %s", fn,
                   last, gw_fmi2_state_name(st));
        return 0;
    }
    return 1;
}

/* Apply a state that gw_blob_check accepted. */
static void gw_fmi2_apply_state(gw_fmu *F, const unsigned char *buf) {
    gw_instance *I = F->I;
    int front[2];
    gw_state_front(I, buf, front);
    gw_fmi2_set_state(F, front[0]);
    F->last_dostep_status = (fmi2Status)(front[1] & GW_FRONT_STATUS_MASK);
    F->initialized = (front[1] & GW_FRONT_INITIALIZED) != 0;
    I->in_setup = !F->initialized; /* also in Error, which may come before or after it */
    gw_state_apply(I, buf);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    int front[2];
    GW_FRAME(GetFMUstate);
    if (!FMUstate) GW_FAIL("%s: FMUstate is NULL", fn);
    front[0] = F->state;
    front[1] = (int)F->last_dostep_status | (F->initialized ? GW_FRONT_INITIALIZED : 0);
    GW_TRY(gw_blob_take(I, fn, FMUstate, front));
    GW_FRAME_END();
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    const gw_blob *b = (const gw_blob *)FMUstate;
    GW_FRAME(SetFMUstate);
    if (!b) GW_FAIL("%s: FMUstate is NULL", fn);
    if (gw_blob_check(I, fn, b->data, b->size, gw_fmi2_check_front, F))
        gw_fmi2_apply_state(F, b->data);
    else
        status = fmi2Error;
    GW_FRAME_END();
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    GW_FRAME(FreeFMUstate);
    gw_blob_free(I, FMUstate);
    GW_FRAME_END();
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    const gw_blob *b = (const gw_blob *)FMUstate;
    GW_FRAME(SerializedFMUstateSize);
    if (!b || !size) GW_FAIL("%s: FMUstate or size is NULL", fn);
    *size = b->size;
    GW_FRAME_END();
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    const gw_blob *b = (const gw_blob *)FMUstate;
    GW_FRAME(SerializeFMUstate);
    if (!b || !serializedState)
        GW_FAIL("%s: FMUstate or serializedState is NULL", fn);
    GW_TRY(gw_blob_serialize(I, fn, b, (unsigned char *)serializedState, size));
    GW_FRAME_END();
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    GW_FRAME(DeSerializeFMUstate);
    if (!FMUstate) GW_FAIL("%s: FMUstate is NULL", fn);
    if (!gw_blob_check(I, fn, (const unsigned char *)serializedState, size,
                       gw_fmi2_check_front, F)) {
        status = fmi2Error;
        goto END;
    }
    GW_TRY(gw_blob_load(I, fn, (const unsigned char *)serializedState, size, FMUstate));
    GW_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
