/*
 * gw_fmi2_me.c -- FMI 2.0 Model Exchange: the importer integrates.  Event and
 * continuous-time modes, time and states set by the importer, derivatives, event indicators
 * (the importer locates their crossings; gw_event_update decides what fired), nominals.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include "gw_fmi2.h"
#include "gw_front.h"

/* the frames of this file's functions (GW_FRAME, gw_fmi2.h): interface, legal states */
#define GW_IFACE_EnterEventMode fmi2ModelExchange
#define GW_IFACE_NewDiscreteStates fmi2ModelExchange
#define GW_IFACE_EnterContinuousTimeMode fmi2ModelExchange
#define GW_IFACE_CompletedIntegratorStep fmi2ModelExchange
#define GW_IFACE_SetTime fmi2ModelExchange
#define GW_IFACE_SetContinuousStates fmi2ModelExchange
#define GW_IFACE_GetDerivatives fmi2ModelExchange
#define GW_IFACE_GetEventIndicators fmi2ModelExchange
#define GW_IFACE_GetContinuousStates fmi2ModelExchange
#define GW_IFACE_GetNominalsOfContinuousStates fmi2ModelExchange
#define GW_MASK_EnterEventMode GW_ST_ME
#define GW_MASK_NewDiscreteStates GW_ST_EVENT_MODE
#define GW_MASK_EnterContinuousTimeMode GW_ST_EVENT_MODE
#define GW_MASK_CompletedIntegratorStep GW_ST_CONT_TIME_MODE
#define GW_MASK_SetTime GW_ST_ME
#define GW_MASK_SetContinuousStates GW_ST_CONT_TIME_MODE
#define GW_MASK_GetDerivatives (GW_ST_INIT_MODE | GW_ST_ME | GW_ST_TERMINATED | GW_ST_ERROR)
#define GW_MASK_GetEventIndicators GW_MASK_GetDerivatives
#define GW_MASK_GetContinuousStates GW_MASK_GetDerivatives
#define GW_MASK_GetNominalsOfContinuousStates                                                  \
    (GW_ST_INSTANTIATED | GW_ST_ME | GW_ST_TERMINATED | GW_ST_ERROR)

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    GW_FRAME(EnterEventMode);
    gw_fmi2_set_state(F, GW_ST_EVENT_MODE);
    GW_FRAME_END();
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    gw_ev_result r;
    GW_FRAME(NewDiscreteStates);
    if (!eventInfo) GW_FAIL("%s: eventInfo is NULL", fn);
    GW_TRY(gw_me_event_update(I, fn, &r));
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = I->terminated ? fmi2True : fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    /* an update event (or the initial settling of the model's modes) changed the states */
    eventInfo->valuesOfContinuousStatesChanged = I->x_jumped ? fmi2True : fmi2False;
    I->x_jumped = 0;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    GW_FRAME_END();
}

/* Also after terminateSimulation: OMSimulator and the FMU Compliance Checker call it once more
 * before they look at the flag.  The transition is legal (FMI 2.0.4 section 3.2.3, Event Mode),
 * so it is made; the instance stays terminated (fmi2CompletedIntegratorStep and
 * fmi2NewDiscreteStates keep saying terminateSimulation) and fmi2Terminate works. */
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    GW_FRAME(EnterContinuousTimeMode);
    if (I->terminated && gw_log_enabled(I, GW_LOG_EVENTS))
        gw_log(I, GW_OK, GW_LOG_EVENTS,
               "%s: the simulation terminated at t=%.17g (%s); terminateSimulation stays "
               "true: call fmi2Terminate",
               fn, I->last_successful_time, gw_front_stop_reason(I));
    gw_fmi2_set_state(F, GW_ST_CONT_TIME_MODE);
    GW_FRAME_END();
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    GW_FRAME(CompletedIntegratorStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!enterEventMode || !terminateSimulation)
        GW_FAIL("%s: enterEventMode or terminateSimulation is NULL", fn);
    /* no step events: state events are located by the importer; a terminated simulation
     * keeps asking to terminate */
    *enterEventMode = fmi2False;
    *terminateSimulation = I->terminated ? fmi2True : fmi2False;
    GW_FRAME_END();
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    GW_FRAME(SetTime);
    GW_TRY(gw_me_set_time(I, fn, time));
    GW_FRAME_END();
}

/* nx of a state-vector call must be the model's (in a frame: fn, I) */
#define GW_CHECK_NX(arr, n)                                                                     \
    GW_TRY(gw_me_check_size(I, fn, arr, n, I->m->nx, "nx", "continuous states"))

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    GW_FRAME(SetContinuousStates);
    GW_CHECK_NX(x, nx);
    GW_TRY(gw_me_set_states(I, fn, x, nx));
    GW_FRAME_END();
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    GW_FRAME(GetDerivatives);
    gw_fmi2_allow_discard(F);
    GW_CHECK_NX(derivatives, nx);
    GW_TRY(gw_update_derivatives(I, fn));
    GW_TRY(gw_fmi2_copy_finite(F, fn, derivatives, I->xdot, nx, "derivative of state",
                               I->m->x_names));
    GW_FRAME_END();
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    GW_FRAME(GetEventIndicators);
    gw_fmi2_allow_discard(F);
    GW_TRY(gw_me_check_size(I, fn, eventIndicators, ni, I->m->ne, "ni", "event indicators"));
    GW_TRY(gw_me_event_indicators(I, fn, eventIndicators, ni));
    GW_FRAME_END();
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    GW_FRAME(GetContinuousStates);
    GW_CHECK_NX(x, nx);
    GW_TRY(gw_me_current_states(I, fn));
    /* the states are finite after initialisation (checked wherever they are set); the
     * initial state from init(s, p) may not be: bad start values, fmi2Error */
    GW_TRY(gw_fmi2_copy_finite(F, fn, x, I->x, nx, "state", I->m->x_names));
    GW_FRAME_END();
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    GW_FRAME(GetNominalsOfContinuousStates);
    GW_CHECK_NX(x_nominal, nx);
    GW_TRY(gw_me_nominals(I, fn, x_nominal, nx));
    GW_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
