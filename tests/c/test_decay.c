/*
 * test_decay.c -- the runtime with the smallest model (toy_decay.c): no inputs,
 * parameters, events, checks or nominals; x' = -x.
 */
#include "harness.h"

#define TOKEN "{decay-0000-0000-0000-000000000003}"


static void run(int solver, double max_step, double h, double tol) {
    fmi2Component c =
        fmi2Instantiate("decay", fmi2CoSimulation, TOKEN, NULL, &h_callbacks, fmi2False, fmi2True);
    fmi2ValueReference vr = 1;
    fmi2Integer s = solver;
    double t = 2.0, x0 = 2.0;
    int i, n = (int)(5.0 / h + 0.5);
    fmi2FMUstate st = NULL;
    size_t size = 0;
    CHECK_STATUS(fmi2SetInteger(c, &vr, 1, &s), fmi2OK);
    vr = 4;
    CHECK_STATUS(fmi2SetReal(c, &vr, 1, &max_step), fmi2OK);
    vr = 0;
    CHECK_STATUS(fmi2SetReal(c, &vr, 1, &x0), fmi2OK);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, t, fmi2True, t + 5.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_NEAR(getr(c, 0), 2.0, 0.0);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    for (i = 0; i < n; i++) {
        CHECK_STATUS(fmi2DoStep(c, t, h, fmi2True), fmi2OK);
        t = 2.0 + (i + 1) * h;
    }
    CHECK_NEAR(getr(c, 0), 2.0 * exp(-5.0), tol);
    CHECK_STATUS(fmi2GetFMUstate(c, &st), fmi2OK);
    CHECK_STATUS(fmi2SerializedFMUstateSize(c, st, &size), fmi2OK);
    /* layout 3 (c_src/gw_state.c): the header, t_events, y_valid, the tolerance flags and a
     * CRC-32, the budget max_internal_steps, the controller memory err_old and the
     * compensation xc (nx = 1: x, s, y, nominal, xc) */
    CHECK(size == 44 + 35 + 9 * 4 + 11 * 8 + 5 * 8 + 8 * 5 + 4);
    CHECK_STATUS(fmi2SetFMUstate(c, st), fmi2OK);
    CHECK_STATUS(fmi2FreeFMUstate(c, &st), fmi2OK);
    CHECK_STATUS(fmi2Terminate(c), fmi2OK);
    fmi2FreeInstance(c);
}

int main(void) {
    run(3, 0.1, 0.1, 1e-8);
    run(3, 10.0, 5.0, 1e-8);
    run(2, 0.01, 0.1, 1e-9);
    run(1, 1e-4, 0.5, 1e-4);
    return h_finish("test_decay");
}
