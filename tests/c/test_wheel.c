/*
 * test_wheel.c -- the real generated wheel model (CasADi code + model_desc.c) with the
 * runtime, driven like an importer: two instances side by side, a long run, the fall
 * event, FMU state round trips, a bad parameter, reset. Built under ASan/UBSan and
 * valgrind by tests/test_c_wheel.py; allocation balance checked by the harness.
 * The FMU's unity file is included (GW_MODEL has internal linkage): one translation unit.
 */
#include "gw_fmu.c"

#include "harness.h"

static fmi2ValueReference vr_of(const char *name) {
    int i;
    for (i = 0; i < GW_MODEL.n_vars; i++)
        if (strcmp(GW_MODEL.vars[i].name, name) == 0) return GW_MODEL.vars[i].vr;
    fprintf(stderr, "no variable %s\n", name);
    exit(2);
}

static double get_real(fmi2Component c, const char *name) {
    fmi2ValueReference vr = vr_of(name);
    double v = NAN;
    CHECK_STATUS(fmi2GetReal(c, &vr, 1, &v), fmi2OK);
    return v;
}

static void set_real(fmi2Component c, const char *name, double value, fmi2Status expected) {
    fmi2ValueReference vr = vr_of(name);
    CHECK_STATUS(fmi2SetReal(c, &vr, 1, &value), expected);
}

static fmi2Component start(const char *name, double g, double gamma_dot, double beta_min) {
    fmi2Component c = fmi2Instantiate(name, fmi2CoSimulation, GW_MODEL.token, "", &h_callbacks,
                                      fmi2False, fmi2True);
    CHECK(c != NULL);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    set_real(c, "g", g, fmi2OK);
    set_real(c, "gamma_dot", gamma_dot, fmi2OK);
    set_real(c, "beta_min", beta_min, fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    return c;
}

static void all_outputs_finite(fmi2Component c) {
    int i;
    for (i = 0; i < GW_MODEL.n_vars; i++) {
        if (GW_MODEL.vars[i].type != GW_REAL) continue;
        CHECK(isfinite(get_real(c, GW_MODEL.vars[i].name)));
    }
}

int main(void) {
    fmi2Component earth, moon, c;
    fmi2FMUstate state = NULL, state2 = NULL;
    fmi2Byte *blob;
    size_t size = 0;
    fmi2Boolean terminated = fmi2False;
    double t = 0.0, e0, beta_a, beta_b, t_event = 0.0;
    int i;

    /* two instances, interleaved, different gravity */
    earth = start("earth", 9.81, 6.0, 0.02);
    moon = start("moon", 1.625, 6.0, 0.02);
    e0 = get_real(earth, "energy");
    for (i = 0; i < 500; i++, t += 0.01) {
        CHECK_STATUS(fmi2DoStep(earth, t, 0.01, fmi2True), fmi2OK);
        CHECK_STATUS(fmi2DoStep(moon, t, 0.01, fmi2True), fmi2OK);
    }
    CHECK_NEAR(get_real(earth, "energy"), e0, 1e-6 * e0);
    CHECK(fabs(get_real(earth, "beta") - get_real(moon, "beta")) > 1e-3);
    all_outputs_finite(earth);

    /* FMU state: get, step, set, step again: identical; serialize round trip */
    CHECK_STATUS(fmi2GetFMUstate(earth, &state), fmi2OK);
    CHECK_STATUS(fmi2DoStep(earth, t, 0.5, fmi2True), fmi2OK);
    beta_a = get_real(earth, "beta");
    CHECK_STATUS(fmi2SerializedFMUstateSize(earth, state, &size), fmi2OK);
    blob = (fmi2Byte *)malloc(size);
    CHECK_STATUS(fmi2SerializeFMUstate(earth, state, blob, size), fmi2OK);
    CHECK_STATUS(fmi2DeSerializeFMUstate(moon, blob, size, &state2), fmi2OK); /* same model */
    CHECK_STATUS(fmi2SetFMUstate(moon, state2), fmi2OK);
    CHECK_STATUS(fmi2DoStep(moon, t, 0.5, fmi2True), fmi2OK);
    beta_b = get_real(moon, "beta");
    CHECK(beta_a == beta_b);
    blob[0] = 'X';
    CHECK_STATUS(fmi2DeSerializeFMUstate(moon, blob, size, &state2), fmi2Error);
    free(blob);
    CHECK_STATUS(fmi2FreeFMUstate(earth, &state), fmi2OK);
    CHECK_STATUS(fmi2FreeFMUstate(moon, &state2), fmi2OK);
    fmi2FreeInstance(moon);

    /* reset, then a wheel that falls: slow roll dips below beta_min = 0.1 */
    CHECK_STATUS(fmi2Reset(earth), fmi2OK);
    fmi2FreeInstance(earth);
    log_clear();  /* the solver log of the runs above would crowd out the fall's line */
    c = start("falling", 9.81, 1.0, 0.1);
    for (t = 0.0, i = 0; i < 200; i++, t += 0.1) {
        fmi2Status s = fmi2DoStep(c, t, 0.1, fmi2True);
        if (s == fmi2Discard) break;
        CHECK_STATUS(s, fmi2OK);
    }
    CHECK(i < 200);
    CHECK_STATUS(fmi2GetBooleanStatus(c, fmi2Terminated, &terminated), fmi2OK);
    CHECK(terminated == fmi2True);
    CHECK_STATUS(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t_event), fmi2OK);
    CHECK(t_event > t && t_event < t + 0.1);
    CHECK_NEAR(sin(get_real(c, "beta")), sin(0.1), 1e-9);
    all_outputs_finite(c);
    CHECK_LOG("fall");
    fmi2FreeInstance(c);

    /* a bad parameter: error at initialisation, reason logged, instance freed cleanly */
    log_clear();
    c = fmi2Instantiate("bad", fmi2CoSimulation, GW_MODEL.token, "", &h_callbacks, fmi2False, fmi2True);
    CHECK(c != NULL);
    set_real(c, "M", -2.0, fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2Error);
    CHECK_LOG("M (mass) must be > 0");
    set_real(c, "R", NAN, fmi2Error);
    fmi2FreeInstance(c);
    return h_finish("test_wheel");
}
