/*
 * gw_fmi2_cs.c -- FMI 2.0 Co-Simulation: fmi2DoStep over the core's gw_advance (internal
 * solver, events located inside the step, fmi2Discard at a terminating event), the status
 * functions, and the optional functions this FMU does not provide.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include "gw_fmi2.h"
#include "gw_front.h"

/* the frames of this file's functions (GW_FRAME, gw_fmi2.h): interface, legal states */
#define GW_IFACE_SetRealInputDerivatives fmi2CoSimulation
#define GW_IFACE_GetRealOutputDerivatives fmi2CoSimulation
#define GW_IFACE_DoStep fmi2CoSimulation
#define GW_IFACE_CancelStep fmi2CoSimulation
#define GW_IFACE_GetStatus fmi2CoSimulation
#define GW_IFACE_GetRealStatus fmi2CoSimulation
#define GW_IFACE_GetIntegerStatus fmi2CoSimulation
#define GW_IFACE_GetBooleanStatus fmi2CoSimulation
#define GW_IFACE_GetStringStatus fmi2CoSimulation
#define GW_MASK_SetRealInputDerivatives GW_MASK_NotSupported
#define GW_MASK_GetRealOutputDerivatives GW_MASK_NotSupported
#define GW_MASK_CancelStep GW_MASK_NotSupported
#define GW_MASK_DoStep GW_ST_STEP_COMPLETE
#define GW_MASK_Status (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_TERMINATED | GW_ST_ERROR)
#define GW_MASK_GetStatus GW_MASK_Status
#define GW_MASK_GetRealStatus GW_MASK_Status
#define GW_MASK_GetIntegerStatus GW_MASK_Status
#define GW_MASK_GetBooleanStatus GW_MASK_Status
#define GW_MASK_GetStringStatus GW_MASK_Status

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    GW_FRAME(SetRealInputDerivatives);
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    GW_FAIL("%s: not supported (canInterpolateInputs=false)", fn);
    GW_FRAME_END();
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    GW_FRAME(GetRealOutputDerivatives);
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    GW_FAIL("%s: not supported (MaxOutputDerivativeOrder=0)", fn);
    GW_FRAME_END();
}

static const char *gw_fmi2_status_name(int s) {
    switch (s) {
    case fmi2OK: return "OK";
    case fmi2Warning: return "Warning";
    case fmi2Discard: return "Discard";
    case fmi2Error: return "Error";
    case fmi2Fatal: return "Fatal";
    case fmi2Pending: return "Pending";
    default: return "?";
    }
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentCommunicationPoint) {
    const double tc = currentCommunicationPoint, h = communicationStepSize;
    double t_end;
    gw_front_counts c0;
    gw_status r;
    GW_FRAME_OPEN(DoStep);
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    if (I->terminated && (F->state == GW_ST_STEP_FAILED || F->state == GW_ST_TERMINATED)) {
        /* After a terminating event: masters such as ecospy ignore fmi2Discard and keep
         * stepping to their stop time.  Strictly a call outside StepComplete (FMI 2.0.4
         * section 4.2.4); answered truthfully instead: no part of the step can be computed
         * (fmi2Discard, "only a subinterval", here empty), the instance stays where it is,
         * fmi2LastSuccessfulTime and fmi2Terminated keep saying so.  The message is the same
         * for every such call, so a run of them is logged once and counted. */
        gw_log(I, GW_DISCARD, GW_LOG_DISCARD,
               "%s: the simulation terminated at t=%.17g (%s); no further step is "
               "computed (fmi2Discard until fmi2Reset)", fn, I->last_successful_time,
               gw_front_stop_reason(I));
        F->last_dostep_status = fmi2Discard;
        return fmi2Discard;
    }
    GW_FRAME_CHECK_STATE();
    GW_TRY(gw_front_step_check(I, fn, tc, h, &t_end));
    gw_front_counts_take(I, &c0);
    I->t = tc; /* the communication point, not the FMU's rounding of it */

    r = gw_advance(I, fn, t_end);
    if (r == GW_DISCARD) { /* a terminating event; its reason is logged whatever the settings */
        gw_fmi2_set_state(F, GW_ST_STEP_FAILED);
        gw_log(I, GW_DISCARD, GW_LOG_DISCARD,
               "%s: %s at t=%.17g: the simulation terminated inside the step to "
               "t=%.17g (fmi2Terminated = true, fmi2LastSuccessfulTime = %.17g)",
               fn, gw_front_stop_reason(I), I->t, t_end, I->t);
    }
    status = gw_fmi2_status(r);
    gw_front_step_log(I, fn, tc, h, &c0, gw_fmi2_status_name(status));
    F->last_dostep_status = status;
    GW_FRAME_END();
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    GW_FRAME(CancelStep);
    GW_FAIL("%s: fmi2DoStep is never asynchronous (canRunAsynchronuously=false)", fn);
    GW_FRAME_END();
}

/* ---- status ------------------------------------------------------------------------------- */

/* A status kind this function cannot report: fmi2Discard (FMI 2.0.4 section 4.2.3), logged. */
static fmi2Status gw_fmi2_no_status(gw_instance *I, const char *fn, int kind) {
    static const char *const kinds[] = {"fmi2DoStepStatus", "fmi2PendingStatus",
                                        "fmi2LastSuccessfulTime", "fmi2Terminated"};
    gw_log(I, GW_DISCARD, GW_LOG_DISCARD, "%s: status kind %s is not provided by this function",
           fn, kind >= 0 && kind < 4 ? kinds[kind] : "(unknown)");
    return fmi2Discard;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    GW_FRAME(GetStatus);
    if (!value) GW_FAIL("%s: value is NULL", fn);
    if (s == fmi2DoStepStatus)
        *value = F->last_dostep_status;
    else
        status = gw_fmi2_no_status(I, fn, s);
    GW_FRAME_END();
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    GW_FRAME(GetRealStatus);
    if (!value) GW_FAIL("%s: value is NULL", fn);
    if (s == fmi2LastSuccessfulTime)
        *value = I->last_successful_time;
    else
        status = gw_fmi2_no_status(I, fn, s);
    GW_FRAME_END();
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    GW_FRAME(GetIntegerStatus);
    (void)value;
    status = gw_fmi2_no_status(I, fn, s);
    GW_FRAME_END();
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    GW_FRAME(GetBooleanStatus);
    if (!value) GW_FAIL("%s: value is NULL", fn);
    if (s == fmi2Terminated)
        *value = I->terminated ? fmi2True : fmi2False;
    else
        status = gw_fmi2_no_status(I, fn, s);
    GW_FRAME_END();
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    GW_FRAME(GetStringStatus);
    (void)value;
    status = gw_fmi2_no_status(I, fn, s); /* never pending */
    GW_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
