/*
 * gw_fmi3_me.c -- FMI 3.0 Model Exchange (FMI 3.0.2 chapter 3): the importer integrates.
 * Event and Continuous-Time Mode, time and states set by the importer, derivatives, event
 * indicators (the importer locates their crossings; gw_event_update decides what fired),
 * nominals.  Also the Event Mode of Co-Simulation (section 4.2.2, eventModeUsed):
 * fmi3EnterEventMode after an fmi3DoStep that returned early at an update event, and
 * fmi3UpdateDiscreteStates, which applies it.  The work on the core is gw_me.c's, shared
 * with the FMI 2.0 layer.
 *
 * After terminateSimulation the instance stays terminated and says so: fmi3UpdateDiscreteStates
 * and fmi3CompletedIntegratorStep keep answering terminateSimulation = true.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu3.c */
#else

#include "gw_fmi3.h"
#include "gw_front.h"

/* the frames of this file's functions (GW3_FRAME, gw_fmi3.h): interface, legal states
 * (FMI 3.0.2 sections 3.2 and 4.2, as modelica/Reference-FMUs' masks; the getters also in
 * Error, for diagnosis, and the nominals also before the initialisation, from the current
 * parameters, as the FMI 2.0 layer answers them) */
#define GW3_IFACE_EnterEventMode GW3_IFACE_ANY
#define GW3_IFACE_UpdateDiscreteStates GW3_IFACE_ANY
#define GW3_IFACE_EnterContinuousTimeMode GW3_IFACE_ME
#define GW3_IFACE_CompletedIntegratorStep GW3_IFACE_ME
#define GW3_IFACE_SetTime GW3_IFACE_ME
#define GW3_IFACE_SetContinuousStates GW3_IFACE_ME
#define GW3_IFACE_GetContinuousStateDerivatives GW3_IFACE_ME
#define GW3_IFACE_GetEventIndicators GW3_IFACE_ME
#define GW3_IFACE_GetContinuousStates GW3_IFACE_ME
#define GW3_IFACE_GetNominalsOfContinuousStates GW3_IFACE_ME
#define GW3_IFACE_GetNumberOfEventIndicators GW3_IFACE_ME
#define GW3_IFACE_GetNumberOfContinuousStates GW3_IFACE_ME
#define GW3_MASK_EnterEventMode (GW3_ST_CONT_TIME_MODE | GW3_ST_STEP_MODE)
#define GW3_MASK_UpdateDiscreteStates GW3_ST_EVENT_MODE
#define GW3_MASK_EnterContinuousTimeMode GW3_ST_EVENT_MODE
#define GW3_MASK_CompletedIntegratorStep GW3_ST_CONT_TIME_MODE
#define GW3_MASK_SetTime (GW3_ST_EVENT_MODE | GW3_ST_CONT_TIME_MODE)
#define GW3_MASK_SetContinuousStates GW3_ST_CONT_TIME_MODE
#define GW3_MASK_GetContinuousStateDerivatives                                                  \
    (GW3_ST_INIT_MODE | GW3_ST_EVENT_MODE | GW3_ST_CONT_TIME_MODE | GW3_ST_TERMINATED |         \
     GW3_ST_ERROR)
#define GW3_MASK_GetEventIndicators GW3_MASK_GetContinuousStateDerivatives
#define GW3_MASK_GetContinuousStates GW3_MASK_GetContinuousStateDerivatives
#define GW3_MASK_GetNominalsOfContinuousStates                                                  \
    (GW3_ST_INSTANTIATED | GW3_MASK_GetContinuousStateDerivatives)
#define GW3_MASK_GetNumberOfEventIndicators GW3_ST_ANY
#define GW3_MASK_GetNumberOfContinuousStates GW3_ST_ANY

static fmi3Boolean gw_fmi3_me_bool(int b) { return b ? fmi3True : fmi3False; }

/* Model Exchange: from Continuous-Time Mode.  Co-Simulation: from Step Mode, only for an
 * instance instantiated with eventModeUsed (section 4.2.2); the master calls it after an
 * fmi3DoStep that asked for event handling. */
fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    GW3_FRAME(EnterEventMode);
    if (!gw_fmi3_is_me(F) && !F->event_mode_used)
        GW3_FAIL("%s: this Co-Simulation instance was instantiated with eventModeUsed = false",
                 fn);
    gw_fmi3_set_state(F, GW3_ST_EVENT_MODE);
    GW3_FRAME_END();
}

/* The event update at the current point (section 3.2.2; Co-Simulation: section 4.2.2, the
 * update an early return left pending).  The output arguments the importer passes are
 * written (a NULL one is skipped, as modelica/Reference-FMUs do). */
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    gw_ev_result r;
    int jumped;
    GW3_FRAME(UpdateDiscreteStates);
    GW3_TRY(gw_me_event_update(I, fn, &r));
    F->event_pending = 0; /* the core's pending update is consumed, even by a failed one */
    if (r == GW_EV_ERROR)
        GW3_FAIL("%s: the event update at t=%.17g failed", fn, I->t);
    /* an update event (or the initial settling of the model's modes) changed the states */
    jumped = I->x_jumped;
    I->x_jumped = 0;
    if (discreteStatesNeedUpdate) *discreteStatesNeedUpdate = fmi3False;
    if (terminateSimulation) *terminateSimulation = gw_fmi3_me_bool(I->terminated);
    if (nominalsOfContinuousStatesChanged) *nominalsOfContinuousStatesChanged = fmi3False;
    if (valuesOfContinuousStatesChanged) *valuesOfContinuousStatesChanged = gw_fmi3_me_bool(jumped);
    if (nextEventTimeDefined) *nextEventTimeDefined = fmi3False;
    if (nextEventTime) *nextEventTime = 0.0;
    GW3_FRAME_END();
}

/* Also after terminateSimulation: importers call it once more before they look at the flag.
 * The transition is legal (section 3.2.2, Event Mode), so it is made; the instance stays
 * terminated (fmi3CompletedIntegratorStep keeps saying terminateSimulation) and
 * fmi3Terminate works. */
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    GW3_FRAME(EnterContinuousTimeMode);
    if (I->terminated && gw_log_enabled(I, GW_LOG_EVENTS))
        gw_log(I, GW_OK, GW_LOG_EVENTS,
               "%s: the simulation terminated at t=%.17g (%s); terminateSimulation stays "
               "true: call fmi3Terminate",
               fn, I->last_successful_time, gw_front_stop_reason(I));
    gw_fmi3_set_state(F, GW3_ST_CONT_TIME_MODE);
    GW3_FRAME_END();
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation) {
    GW3_FRAME(CompletedIntegratorStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!enterEventMode || !terminateSimulation)
        GW3_FAIL("%s: enterEventMode or terminateSimulation is NULL", fn);
    /* no step events: state events are located by the importer; a terminated simulation
     * keeps asking to terminate */
    *enterEventMode = fmi3False;
    *terminateSimulation = gw_fmi3_me_bool(I->terminated);
    GW3_FRAME_END();
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    GW3_FRAME(SetTime);
    GW3_TRY(gw_me_set_time(I, fn, time));
    GW3_FRAME_END();
}

/* nContinuousStates of a state-vector call must be the model's (in a frame: fn, I) */
#define GW3_CHECK_NX(arr, n)                                                                    \
    GW3_TRY(gw_me_check_size(I, fn, arr, n, I->m->nx, "nContinuousStates", "continuous states"))

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    GW3_FRAME(SetContinuousStates);
    GW3_CHECK_NX(continuousStates, nContinuousStates);
    GW3_TRY(gw_me_set_states(I, fn, continuousStates, nContinuousStates));
    GW3_FRAME_END();
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    GW3_FRAME(GetContinuousStateDerivatives);
    gw_fmi3_allow_discard(F);
    GW3_CHECK_NX(derivatives, nContinuousStates);
    GW3_TRY(gw_update_derivatives(I, fn));
    GW3_TRY(gw_fmi3_copy_finite(F, fn, derivatives, I->xdot, nContinuousStates,
                                "derivative of state", I->m->x_names));
    GW3_FRAME_END();
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators) {
    GW3_FRAME(GetEventIndicators);
    gw_fmi3_allow_discard(F);
    GW3_TRY(gw_me_check_size(I, fn, eventIndicators, nEventIndicators, I->m->ne,
                             "nEventIndicators", "event indicators"));
    GW3_TRY(gw_me_event_indicators(I, fn, eventIndicators, nEventIndicators));
    GW3_FRAME_END();
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    GW3_FRAME(GetContinuousStates);
    GW3_CHECK_NX(continuousStates, nContinuousStates);
    GW3_TRY(gw_me_current_states(I, fn));
    /* finite after the initialisation (checked wherever they are set); the initial state
     * from init(s, p) may not be: bad start values, fmi3Error */
    GW3_TRY(gw_fmi3_copy_finite(F, fn, continuousStates, I->x, nContinuousStates, "state",
                                I->m->x_names));
    GW3_FRAME_END();
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    GW3_FRAME(GetNominalsOfContinuousStates);
    GW3_CHECK_NX(nominals, nContinuousStates);
    GW3_TRY(gw_me_nominals(I, fn, nominals, nContinuousStates));
    GW3_FRAME_END();
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    GW3_FRAME(GetNumberOfEventIndicators);
    if (!nEventIndicators) GW3_FAIL("%s: nEventIndicators is NULL", fn);
    *nEventIndicators = (size_t)I->m->ne;
    GW3_FRAME_END();
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    GW3_FRAME(GetNumberOfContinuousStates);
    if (!nContinuousStates) GW3_FAIL("%s: nContinuousStates is NULL", fn);
    *nContinuousStates = (size_t)I->m->nx;
    GW3_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
