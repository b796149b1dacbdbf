/*
 * test_me_nodir.c -- Model Exchange with a model that has no `dir` function
 * (toy_oscillator.c, harmonic oscillator, TERMINATE event "hit"): the ME functions
 * work, fmi2GetDirectionalDerivative fails with "not provided" in every state.
 */
#include "harness.h"

#define TOKEN "{0sc1-11a7-0r00-0000-000000000001}"

enum { VR_POS_LIM = 1, VR_POS = 10, VR_VEL = 11, VR_ENERGY = 20, VR_HIT = 50 };

int main(void) {
    fmi2Component c =
        fmi2Instantiate("nodir", fmi2ModelExchange, TOKEN, "", &h_callbacks, fmi2False, fmi2False);
    fmi2ValueReference vr = VR_POS;
    fmi2EventInfo ei;
    double x[2], dx[2], e[1], nom[2], r = 1.0, dv = 0.0, t = 0.0, h = 1e-4;
    CHECK(c != NULL);
    log_clear();
    CHECK_STATUS(fmi2GetDirectionalDerivative(c, &vr, 1, &vr, 1, &r, &dv), fmi2Error);
    CHECK_LOG("fmi2GetDirectionalDerivative: not provided by this FMU");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    CHECK_STATUS(fmi2SetReal(c, (fmi2ValueReference[]){VR_POS_LIM}, 1, (double[]){0.5}), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2NewDiscreteStates(c, &ei), fmi2OK);
    CHECK_STATUS(fmi2EnterContinuousTimeMode(c), fmi2OK);
    CHECK_STATUS(fmi2GetNominalsOfContinuousStates(c, nom, 2), fmi2OK);
    CHECK(nom[0] == 1.0 && nom[1] == 2.0);
    log_clear();
    CHECK_STATUS(fmi2GetDirectionalDerivative(c, &vr, 1, &vr, 1, &r, &dv), fmi2Error);
    CHECK_LOG("not provided");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    CHECK_STATUS(fmi2SetReal(c, (fmi2ValueReference[]){VR_POS_LIM}, 1, (double[]){0.5}), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2NewDiscreteStates(c, &ei), fmi2OK);
    CHECK_STATUS(fmi2EnterContinuousTimeMode(c), fmi2OK);
    /* explicit Euler until "hit" (pos = cos t <= 0.5 at t = pi/3) */
    CHECK_STATUS(fmi2GetContinuousStates(c, x, 2), fmi2OK);
    for (;;) {
        CHECK_STATUS(fmi2GetDerivatives(c, dx, 2), fmi2OK);
        x[0] += h * dx[0];
        x[1] += h * dx[1];
        t += h;
        CHECK_STATUS(fmi2SetTime(c, t), fmi2OK);
        CHECK_STATUS(fmi2SetContinuousStates(c, x, 2), fmi2OK);
        CHECK_STATUS(fmi2GetEventIndicators(c, e, 1), fmi2OK);
        if (e[0] <= 0.0 || t > 5.0) break;
    }
    CHECK_NEAR(t, acos(0.5), 2e-4);
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
    CHECK_STATUS(fmi2NewDiscreteStates(c, &ei), fmi2OK);
    CHECK(ei.terminateSimulation == fmi2True);
    {
        fmi2ValueReference hv = VR_HIT, ev = VR_ENERGY;
        fmi2Boolean hit = fmi2False;
        double en = NAN;
        CHECK_STATUS(fmi2GetBoolean(c, &hv, 1, &hit), fmi2OK);
        CHECK(hit == fmi2True);
        CHECK_STATUS(fmi2GetReal(c, &ev, 1, &en), fmi2OK);
        CHECK_NEAR(en, 0.5, 1e-3); /* Euler drifts a little */
    }
    CHECK_STATUS(fmi2Terminate(c), fmi2OK);
    fmi2FreeInstance(c);
    return h_finish("test_me_nodir");
}
