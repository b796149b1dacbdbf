/*
 * gw_fmi2_cs.c -- FMI 2.0 Co-Simulation: fmi2DoStep over the core's gw_advance (internal
 * solver, events located inside the step, fmi2Discard at a terminating event), the status
 * functions, and the optional functions this FMU does not provide.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>

#include "gw_fmi2.h"

#define GW_MASK_DoStep GW_ST_STEP_COMPLETE
#define GW_MASK_Status (GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_TERMINATED | GW_ST_ERROR)

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    GW_BEGIN_CS("fmi2SetRealInputDerivatives", GW_MASK_NotSupported);
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    GW_FAIL("fmi2SetRealInputDerivatives: not supported (canInterpolateInputs=false)");
    GW_END_FUNCTION();
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    GW_BEGIN_CS("fmi2GetRealOutputDerivatives", GW_MASK_NotSupported);
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    GW_FAIL("fmi2GetRealOutputDerivatives: not supported (MaxOutputDerivativeOrder=0)");
    GW_END_FUNCTION();
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
    double t_end, tol;
    unsigned long long rhs0, acc0, rej0;
    gw_status r;
    gw_fmu *F = (gw_fmu *)c;
    gw_instance *I;
    fmi2Status status = fmi2OK;
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    if (!gw_fmi2_interface(F, "fmi2DoStep", fmi2CoSimulation)) return fmi2Error;
    I = F->I;
    if (I->terminated && (F->state == GW_ST_STEP_FAILED || F->state == GW_ST_TERMINATED)) {
        /* After a terminating event: masters such as ecospy ignore fmi2Discard and keep
         * stepping to their stop time.  Strictly a call outside StepComplete (FMI 2.0.4
         * section 4.2.4); answered truthfully instead: no part of the step can be computed
         * (fmi2Discard, "only a subinterval", here empty), the instance stays where it is,
         * fmi2LastSuccessfulTime and fmi2Terminated keep saying so.  The message is the same
         * for every such call, so a run of them is logged once and counted. */
        gw_log(I, GW_DISCARD, GW_LOG_DISCARD,
               "fmi2DoStep: the simulation terminated at t=%.17g (%s); no further step is "
               "computed (fmi2Discard until fmi2Reset)", I->last_successful_time,
               gw_fmi2_stop_reason(I));
        F->last_dostep_status = fmi2Discard;
        return fmi2Discard;
    }
    if (!gw_fmi2_begin(F, "fmi2DoStep", GW_MASK_DoStep)) return fmi2Error;
    if (!isfinite(h) || !(h > 0.0))
        GW_FAIL("fmi2DoStep: communication step size %g must be finite and > 0", h);
    if (!isfinite(tc)) GW_FAIL("fmi2DoStep: currentCommunicationPoint is not finite");
    if (tc + h == tc)
        GW_FAIL("fmi2DoStep: communication step size %g is below the resolution of "
                "currentCommunicationPoint %.17g (t + h == t): the step would not advance time",
                h, tc);
    tol = 1e-9 * (fabs(tc) > 1.0 ? fabs(tc) : 1.0);
    if (fabs(tc - I->t) > tol)
        GW_FAIL("fmi2DoStep: currentCommunicationPoint %.17g does not match the FMU time %.17g",
                tc, I->t);
    t_end = tc + h;
    if (I->stop_defined) {
        double eps = 1e-9 * (fabs(I->t_stop) > 1.0 ? fabs(I->t_stop) : 1.0);
        if (t_end > I->t_stop + eps)
            GW_FAIL("fmi2DoStep: step to t=%.17g goes beyond stopTime %.17g", t_end, I->t_stop);
    }
    rhs0 = I->n_rhs;
    acc0 = I->n_accepted;
    rej0 = I->n_rejected;
    I->t = tc; /* the communication point, not the FMU's rounding of it */

    r = gw_advance(I, "fmi2DoStep", t_end);
    if (r == GW_DISCARD) { /* a terminating event; its reason is logged whatever the settings */
        gw_fmi2_set_state(F, GW_ST_STEP_FAILED);
        gw_log(I, GW_DISCARD, GW_LOG_DISCARD,
               "fmi2DoStep: %s at t=%.17g: the simulation terminated inside the step to "
               "t=%.17g (fmi2Terminated = true, fmi2LastSuccessfulTime = %.17g)",
               gw_fmi2_stop_reason(I), I->t, t_end, I->t);
    }
    status = gw_fmi2_status(r);
    if (gw_log_enabled(I, GW_LOG_SOLVER))
        gw_log(I, GW_OK, GW_LOG_SOLVER,
               "fmi2DoStep t=%.17g h=%.17g -> t=%.17g solver=%s accepted=%llu rejected=%llu "
               "rhs=%llu h_next=%g status=%s",
               tc, h, I->t, gw_solver_name(I->solver), I->n_accepted - acc0,
               I->n_rejected - rej0, I->n_rhs - rhs0, I->h_adapt, gw_fmi2_status_name(status));
    F->last_dostep_status = status;
    GW_END_FUNCTION();
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    GW_BEGIN_CS("fmi2CancelStep", GW_MASK_NotSupported);
    GW_FAIL("fmi2CancelStep: fmi2DoStep is never asynchronous (canRunAsynchronuously=false)");
    GW_END_FUNCTION();
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
    GW_BEGIN_CS("fmi2GetStatus", GW_MASK_Status);
    if (!value) GW_FAIL("fmi2GetStatus: value is NULL");
    if (s == fmi2DoStepStatus)
        *value = F->last_dostep_status;
    else
        status = gw_fmi2_no_status(I, "fmi2GetStatus", s);
    GW_END_FUNCTION();
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    GW_BEGIN_CS("fmi2GetRealStatus", GW_MASK_Status);
    if (!value) GW_FAIL("fmi2GetRealStatus: value is NULL");
    if (s == fmi2LastSuccessfulTime)
        *value = I->last_successful_time;
    else
        status = gw_fmi2_no_status(I, "fmi2GetRealStatus", s);
    GW_END_FUNCTION();
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    GW_BEGIN_CS("fmi2GetIntegerStatus", GW_MASK_Status);
    (void)value;
    status = gw_fmi2_no_status(I, "fmi2GetIntegerStatus", s);
    GW_END_FUNCTION();
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    GW_BEGIN_CS("fmi2GetBooleanStatus", GW_MASK_Status);
    if (!value) GW_FAIL("fmi2GetBooleanStatus: value is NULL");
    if (s == fmi2Terminated)
        *value = I->terminated ? fmi2True : fmi2False;
    else
        status = gw_fmi2_no_status(I, "fmi2GetBooleanStatus", s);
    GW_END_FUNCTION();
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    GW_BEGIN_CS("fmi2GetStringStatus", GW_MASK_Status);
    (void)value;
    status = gw_fmi2_no_status(I, "fmi2GetStringStatus", s); /* never pending */
    GW_END_FUNCTION();
}

#endif /* GW_UNITY_BUILD */
