/*
 * gw_fmi3_cs.c -- FMI 3.0 Co-Simulation (FMI 3.0.2 section 4): fmi3DoStep over the core's
 * gw_advance (internal solver, events located inside the step), with early return, Event
 * Mode for the master (eventModeUsed), fmi3EnterStepMode, and output derivatives (none).
 *
 * What a step does at an event inside it:
 *   terminating event   the state at the located time; fmi3OK, terminateSimulation, and
 *                       lastSuccessfulTime the event's time (earlyReturn if allowed); the
 *                       instance never steps again (a later fmi3DoStep: fmi3Discard).
 *   update event        (a mode switch) without earlyReturnAllowed: applied inside the step,
 *                       which goes on to its end (the FMI 2.0 layer's step).  With it: the step
 *                       returns early at the event's time (earlyReturn, lastSuccessfulTime);
 *                       with eventModeUsed the update is left to the master's Event Mode
 *                       (eventHandlingNeeded: fmi3EnterEventMode, fmi3UpdateDiscreteStates,
 *                       fmi3EnterStepMode), otherwise it is applied before the return.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu3.c */
#else

#include "gw_fmi3.h"
#include "gw_front.h"

/* the frames of this file's functions (GW3_FRAME, gw_fmi3.h): interface, legal states */
#define GW3_IFACE_DoStep GW3_IFACE_CS
#define GW3_IFACE_EnterStepMode GW3_IFACE_CS
#define GW3_IFACE_GetOutputDerivatives GW3_IFACE_CS
#define GW3_MASK_DoStep GW3_ST_STEP_MODE
#define GW3_MASK_EnterStepMode GW3_ST_EVENT_MODE
#define GW3_MASK_GetOutputDerivatives GW3_MASK_NotSupported

static const char *gw_fmi3_status_name(fmi3Status s) {
    switch (s) {
    case fmi3OK: return "OK";
    case fmi3Warning: return "Warning";
    case fmi3Discard: return "Discard";
    case fmi3Error: return "Error";
    case fmi3Fatal: return "Fatal";
    default: return "?";
    }
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    const double tc = currentCommunicationPoint, h = communicationStepSize;
    double t_end;
    gw_front_counts c0;
    gw_status r;
    GW3_FRAME_OPEN(DoStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        GW3_FAIL("%s: NULL eventHandlingNeeded, terminateSimulation, earlyReturn or "
                 "lastSuccessfulTime", fn);
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = I->t;
    if (I->terminated && (F->state & (GW3_ST_STEP_MODE | GW3_ST_TERMINATED))) {
        /* After a terminating event, as the FMI 2.0 layer: masters that keep stepping to their
         * stop time are answered truthfully (fmi3Discard: no part of the step can be
         * computed), the instance stays where it is.  A run of such calls is logged once and
         * counted. */
        *terminateSimulation = fmi3True;
        *lastSuccessfulTime = I->last_successful_time;
        gw_log(I, GW_DISCARD, GW_LOG_DISCARD,
               "%s: the simulation terminated at t=%.17g (%s); no further step is "
               "computed (fmi3Discard until fmi3Reset)", fn, I->last_successful_time,
               gw_front_stop_reason(I));
        return fmi3Discard;
    }
    GW3_FRAME_CHECK_STATE();
    if (F->event_pending)
        GW3_FAIL("%s: the step returned early at an event at t=%.17g that awaits its handling: "
                 "enter Event Mode first (fmi3EnterEventMode, fmi3UpdateDiscreteStates, "
                 "fmi3EnterStepMode); refused, so the instance is in the Error state now "
                 "(fmi3Reset, or fmi3SetFMUState of a state taken before, continue)", fn, I->t);
    GW3_TRY(gw_front_step_check(I, fn, tc, h, &t_end));
    gw_front_counts_take(I, &c0);
    I->t = tc; /* the communication point, not the FMU's rounding of it */

    I->stop_at_update = !F->early_return_allowed ? GW_STOP_NEVER
                        : F->event_mode_used     ? GW_STOP_BEFORE_UPDATE
                                                 : GW_STOP_AFTER_UPDATE;
    r = gw_advance(I, fn, t_end);
    I->stop_at_update = GW_STOP_NEVER;
    *lastSuccessfulTime = I->t;
    if (r == GW_DISCARD) { /* a terminating event: the step ends there, the simulation too */
        *terminateSimulation = fmi3True;
        *earlyReturn = F->early_return_allowed ? fmi3True : fmi3False;
        if (gw_log_enabled(I, GW_LOG_EVENTS))
            gw_log(I, GW_OK, GW_LOG_EVENTS,
                   "%s: %s at t=%.17g: the simulation terminated inside the step to t=%.17g "
                   "(terminateSimulation = true, lastSuccessfulTime = %.17g)",
                   fn, gw_front_stop_reason(I), I->t, t_end, I->t);
        r = GW_OK;
    } else if (r <= GW_WARNING && I->stopped_at_update) {
        *earlyReturn = fmi3True;
        if (I->update_pending) { /* the master applies it in Event Mode */
            *eventHandlingNeeded = fmi3True;
            F->event_pending = 1;
        }
    }
    status = gw_fmi3_status(r);
    gw_front_step_log(I, fn, tc, h, &c0, gw_fmi3_status_name(status));
    GW3_FRAME_END();
}

/* Event Mode -> Step Mode (FMI 3.0.2 section 4.2.2), once the event is handled */
fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    GW3_FRAME(EnterStepMode);
    if (F->event_pending)
        GW3_FAIL("%s: the event at t=%.17g is not handled yet (call fmi3UpdateDiscreteStates "
                 "first); refused, so the instance is in the Error state now (fmi3Reset, or "
                 "fmi3SetFMUState of a state taken before, continue)", fn, I->t);
    gw_fmi3_set_state(F, GW3_ST_STEP_MODE);
    GW3_FRAME_END();
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[],
                                    fmi3Float64 values[], size_t nValues) {
    GW3_FRAME(GetOutputDerivatives);
    (void)valueReferences;
    (void)nValueReferences;
    (void)orders;
    (void)values;
    (void)nValues;
    GW3_FAIL("%s: not supported (maxOutputDerivativeOrder=0)", fn);
    GW3_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
