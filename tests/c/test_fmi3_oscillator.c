/*
 * test_fmi3_oscillator.c -- the FMI 3.0 layer over toy_oscillator.c (value references from 1,
 * GW_TOY_VR_BASE=1, time being 0), beside the FMI 2.0 layer over the same toy in the same
 * program: the state machine (illegal calls: fmi3Error, reason logged, Error state), every
 * typed getter and setter with its refusals, Co-Simulation steps bit-identical to fmi2DoStep,
 * and the terminating event "hit" inside a step (lastSuccessfulTime = fmi2LastSuccessfulTime).
 */
#include "harness3.h"

#define TOKEN "{0sc1-11a7-0r00-0000-000000000001}"

enum { VR_TIME = 0, VR_K = 1, VR_POS_LIM = 2, VR_N_INT = 3, VR_USE_FORCE = 4, VR_POS = 11,
       VR_VEL = 12, VR_ENERGY = 21, VR_F = 31, VR_SOLVER = 41, VR_REL_TOL = 42,
       VR_MAX_INTERNAL_STEPS = 45, VR_HIT = 51, VR_HIT_INDICATOR = 61 };

static fmi3Instance cs3(int event_mode, int early_return) {
    return cs3_new("osc3", TOKEN, event_mode, early_return);
}

static fmi2Component cs2(void) {
    fmi2Component c = fmi2Instantiate("osc2", fmi2CoSimulation, TOKEN, NULL, &h_callbacks,
                                      fmi2False, fmi2False);
    CHECK(c != NULL);
    return c;
}

static void test_instantiation_refusals(void) {
    const fmi3ValueReference vr = VR_POS;
    log_clear();
    CHECK(fmi3InstantiateCoSimulation("x", "{wrong}", NULL, fmi3False, fmi3False, fmi3False,
                                      fmi3False, NULL, 0, NULL, h_logger3, NULL) == NULL);
    CHECK_LOG("fmi3InstantiateCoSimulation: instantiationToken \"{wrong}\" does not match");
    CHECK(fmi3InstantiateModelExchange("", TOKEN, NULL, fmi3False, fmi3False, NULL,
                                       h_logger3) == NULL);
    CHECK_LOG("fmi3InstantiateModelExchange: missing instance name");
    CHECK(fmi3InstantiateCoSimulation("x", TOKEN, NULL, fmi3False, fmi3False, fmi3True,
                                      fmi3True, &vr, 1, NULL, h_logger3, NULL) == NULL);
    CHECK_LOG("fmi3InstantiateCoSimulation: 1 required intermediate variables, but this FMU "
              "provides no intermediate update");
    CHECK(fmi3InstantiateScheduledExecution("x", TOKEN, NULL, fmi3False, fmi3False, NULL,
                                            h_logger3, NULL, NULL, NULL) == NULL);
    CHECK_LOG("fmi3InstantiateScheduledExecution: this FMU has no Scheduled Execution");
    CHECK(strcmp(fmi3GetVersion(), "3.0") == 0 || strncmp(fmi3GetVersion(), "3.", 2) == 0);
}

static void test_state_machine(void) {
    fmi3Instance c = cs3(0, 0), m;
    h_step3 r;
    /* a step before the initialisation: illegal, Error, and Error refuses what follows */
    log_clear();
    r = dostep3(c, 0.0, 0.1);
    CHECK3_STATUS(r.status, fmi3Error);
    CHECK_LOG("fmi3DoStep: illegal call in state Instantiated");
    EXPECT3_ERROR(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0),
                  "fmi3EnterInitializationMode: illegal call in state Error");
    log_clear();
    CHECK3_STATUS(fmi3Terminate(c), fmi3Error); /* nothing initialised to terminate */
    CHECK_LOG("fmi3Terminate: the instance failed before its initialisation ended");
    CHECK3_STATUS(fmi3Reset(c), fmi3OK);
    /* Step Mode after the initialisation without eventModeUsed */
    CHECK3_STATUS(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3True, 1.0), fmi3OK);
    CHECK3_STATUS(fmi3ExitInitializationMode(c), fmi3OK);
    EXPECT3_ERROR(fmi3EnterStepMode(c), "fmi3EnterStepMode: illegal call in state StepMode");
    CHECK3_STATUS(fmi3Reset(c), fmi3OK);
    CHECK3_STATUS(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3True, 1.0), fmi3OK);
    CHECK3_STATUS(fmi3ExitInitializationMode(c), fmi3OK);
    r = dostep3(c, 0.0, 0.5);
    CHECK3_STATUS(r.status, fmi3OK);
    CHECK(r.last == 0.5 && !r.early && !r.terminate && !r.event_handling);
    EXPECT3_ERROR(dostep3(c, 0.5, 0.6).status, "fmi3DoStep: step to t=1.1000000000000001 goes "
                                               "beyond stopTime 1");
    log_clear();
    CHECK3_STATUS(fmi3Terminate(c), fmi3Warning); /* after an error: the last consistent state */
    CHECK_LOG("fmi3Terminate: called after an fmi3Error");
    CHECK3_STATUS(fmi3Terminate(c), fmi3Warning);
    CHECK_LOG("fmi3Terminate: already terminated");
    fmi3FreeInstance(c);

    /* eventModeUsed: Event Mode after the initialisation, a step only from Step Mode */
    c = cs3(1, 1);
    CHECK3_STATUS(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
    CHECK3_STATUS(fmi3ExitInitializationMode(c), fmi3OK);
    EXPECT3_ERROR(dostep3(c, 0.0, 0.1).status, "fmi3DoStep: illegal call in state EventMode");
    fmi3FreeInstance(c);
    c = cs3(1, 1);
    CHECK3_STATUS(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
    CHECK3_STATUS(fmi3ExitInitializationMode(c), fmi3OK);
    CHECK3_STATUS(fmi3EnterStepMode(c), fmi3OK);
    CHECK3_STATUS(dostep3(c, 0.0, 0.1).status, fmi3OK);
    EXPECT3_ERROR(fmi3GetOutputDerivatives(c, NULL, 0, NULL, NULL, 0),
                  "fmi3GetOutputDerivatives: not supported (maxOutputDerivativeOrder=0)");
    fmi3FreeInstance(c);

    /* a Co-Simulation function in a Model Exchange instance */
    m = fmi3InstantiateModelExchange("me3", TOKEN, NULL, fmi3False, fmi3False, NULL, h_logger3);
    CHECK(m != NULL);
    EXPECT3_ERROR(dostep3(m, 0.0, 0.1).status,
                  "fmi3DoStep: Co-Simulation function, not available in an instance "
                  "instantiated for Model Exchange");
    fmi3FreeInstance(m);
}

static void test_variables(void) {
    fmi3Instance c = cs3(0, 0);
    fmi3ValueReference vr[3] = {VR_TIME, VR_POS, VR_ENERGY};
    double v[3];
    fmi3Int64 solver = 0;
    fmi3Int32 n = 0;
    fmi3Int8 i8 = 0;
    fmi3String str = NULL;
    fmi3Float32 f32 = 0;
    fmi3Boolean b = fmi3False;
    CHECK3_STATUS(seti64(c, VR_SOLVER, 5), fmi3OK); /* dop853 */
    CHECK3_STATUS(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.25, fmi3False, 0.0), fmi3OK);
    CHECK(getf3(c, VR_TIME) == 0.25);
    CHECK3_STATUS(setf3(c, VR_POS, 0.8), fmi3OK);
    CHECK3_STATUS(fmi3ExitInitializationMode(c), fmi3OK);
    CHECK3_STATUS(fmi3GetFloat64(c, vr, 3, v, 3), fmi3OK);
    CHECK(v[0] == 0.25 && v[1] == 0.8);
    CHECK_NEAR(v[2], 0.32, 1e-15);
    CHECK3_STATUS(fmi3GetInt64(c, &vr[0], 0, &solver, 0), fmi3OK);
    vr[0] = VR_SOLVER;
    CHECK3_STATUS(fmi3GetInt64(c, vr, 1, &solver, 1), fmi3OK);
    CHECK(solver == 5);
    vr[0] = VR_N_INT;
    CHECK3_STATUS(fmi3GetInt32(c, vr, 1, &n, 1), fmi3OK);
    CHECK(n == 3);
    vr[0] = VR_USE_FORCE;
    CHECK3_STATUS(fmi3GetBoolean(c, vr, 1, &b, 1), fmi3OK);
    CHECK(b == fmi3True);
    CHECK(getb3(c, VR_HIT) == 0);
    /* the event indicator as a variable: evt = pos - pos_lim */
    CHECK(getf3(c, VR_HIT_INDICATOR) == 0.8 - (-2.0));
    CHECK3_STATUS(dostep3(c, 0.25, 0.5).status, fmi3OK);
    CHECK(getf3(c, VR_TIME) == 0.75);
    CHECK(getf3(c, VR_HIT_INDICATOR) == getf3(c, VR_POS) + 2.0);
    /* the types without variables: nothing asked is fmi3OK */
    CHECK3_STATUS(fmi3GetFloat32(c, NULL, 0, NULL, 0), fmi3OK);
    CHECK3_STATUS(fmi3SetUInt64(c, NULL, 0, NULL, 0), fmi3OK);
    CHECK3_STATUS(fmi3GetBinary(c, NULL, 0, NULL, NULL, 0), fmi3OK);
    CHECK3_STATUS(fmi3GetString(c, NULL, 0, NULL, 0), fmi3OK);
    /* refusals: each fmi3Error with its reason, the instance in Error; Reset between */
#define REFUSED(call, reason)                                                                 \
    do {                                                                                      \
        EXPECT3_ERROR(call, reason);                                                          \
        CHECK3_STATUS(fmi3Reset(c), fmi3OK);                                                  \
    } while (0)
    vr[0] = VR_POS;
    REFUSED(fmi3GetInt8(c, vr, 1, &i8, 1), "fmi3GetInt8: value reference 11 (pos) is a Float64 "
                                           "variable");
    REFUSED(fmi3GetFloat32(c, vr, 1, &f32, 1), "fmi3GetFloat32: value reference 11 (pos) is a "
                                               "Float64 variable");
    vr[0] = VR_TIME;
    REFUSED(fmi3GetString(c, vr, 1, &str, 1), "fmi3GetString: value reference 0 (time) is a "
                                              "Float64 variable");
    REFUSED(setf3(c, VR_TIME, 1.0), "fmi3SetFloat64: value reference 0 (time) is the independent "
                                    "variable and cannot be set");
    vr[0] = VR_SOLVER;
    REFUSED(fmi3SetInt32(c, vr, 1, &n, 1), "fmi3SetInt32: value reference 41 (solver) is an "
                                           "Enumeration (Int64) variable");
    vr[0] = VR_N_INT;
    REFUSED(fmi3GetInt64(c, vr, 1, &solver, 1), "fmi3GetInt64: value reference 3 (n_int) is an "
                                                "Int32 variable");
    vr[0] = 999;
    REFUSED(fmi3GetFloat64(c, vr, 1, v, 1), "fmi3GetFloat64: unknown value reference 999");
    vr[0] = VR_POS;
    REFUSED(fmi3GetFloat64(c, vr, 1, v, 2), "fmi3GetFloat64: nValues = 2 for 1 value references");
    REFUSED(seti64(c, VR_SOLVER, 99), "fmi3SetInt64: solver");
    REFUSED(setf3(c, VR_ENERGY, 1.0), "fmi3SetFloat64: variable energy (vr=21) is read-only");
    REFUSED(setf3(c, VR_HIT_INDICATOR, 1.0), "hit_indicator (vr=61) is read-only");
    /* what may be set when: a start value not after the initialisation */
    CHECK3_STATUS(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
    CHECK3_STATUS(fmi3ExitInitializationMode(c), fmi3OK);
    EXPECT3_ERROR(setf3(c, VR_POS, 0.5), "fmi3SetFloat64: variable pos (vr=11) cannot be set in "
                                         "state StepMode");
    fmi3FreeInstance(c);
#undef REFUSED
}

/* the same run through both layers: every value bit-identical */
static void test_steps_equal_fmi2(int solver) {
    fmi3Instance c3 = cs3(0, 1);
    fmi2Component c2 = cs2();
    fmi3ValueReference vr3[3] = {VR_POS, VR_VEL, VR_ENERGY};
    fmi2ValueReference vr2[3] = {VR_POS, VR_VEL, VR_ENERGY};
    double t = 0.0, v3[3], v2[3];
    int k, same = 1;
    CHECK3_STATUS(seti64(c3, VR_SOLVER, solver), fmi3OK);
    CHECK_STATUS(seti(c2, VR_SOLVER, solver), fmi2OK);
    CHECK3_STATUS(setf3(c3, VR_K, 2.5), fmi3OK);
    CHECK_STATUS(setr(c2, VR_K, 2.5), fmi2OK);
    CHECK3_STATUS(fmi3EnterInitializationMode(c3, fmi3True, 1e-7, 0.0, fmi3False, 0.0), fmi3OK);
    CHECK_STATUS(fmi2SetupExperiment(c2, fmi2True, 1e-7, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c2), fmi2OK);
    CHECK3_STATUS(fmi3ExitInitializationMode(c3), fmi3OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c2), fmi2OK);
    for (k = 0; k < 40; k++, t += 0.137) {
        h_step3 r;
        double f = 0.3 * sin(t);
        CHECK3_STATUS(setf3(c3, VR_F, f), fmi3OK);
        CHECK_STATUS(setr(c2, VR_F, f), fmi2OK);
        r = dostep3(c3, t, 0.137);
        CHECK3_STATUS(r.status, fmi3OK);
        CHECK_STATUS(fmi2DoStep(c2, t, 0.137, fmi2True), fmi2OK);
        CHECK3_STATUS(fmi3GetFloat64(c3, vr3, 3, v3, 3), fmi3OK);
        CHECK_STATUS(fmi2GetReal(c2, vr2, 3, v2), fmi2OK);
        same &= memcmp(v2, v3, sizeof(v2)) == 0 && r.last == t + 0.137 && !r.early;
    }
    CHECK(same);
    CHECK(getf3(c3, VR_TIME) == t);
    fmi3FreeInstance(c3);
    fmi2FreeInstance(c2);
}

/* "hit" at acos(0.5) inside the step [0.9, 1.2]: the located state, fmi3OK, terminateSimulation,
 * lastSuccessfulTime = FMI 2.0's; a later step is fmi3Discard */
static void test_terminating_event(int early_return) {
    fmi3Instance c3 = cs3(0, early_return);
    fmi2Component c2 = cs2();
    double t = 0.0, last2 = NAN;
    h_step3 r;
    int k;
    CHECK3_STATUS(setf3(c3, VR_POS_LIM, 0.5), fmi3OK);
    CHECK_STATUS(setr(c2, VR_POS_LIM, 0.5), fmi2OK);
    CHECK3_STATUS(fmi3EnterInitializationMode(c3, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
    CHECK3_STATUS(fmi3ExitInitializationMode(c3), fmi3OK);
    CHECK_STATUS(fmi2SetupExperiment(c2, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c2), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c2), fmi2OK);
    for (k = 0; k < 3; k++, t += 0.3) {
        CHECK3_STATUS(dostep3(c3, t, 0.3).status, fmi3OK);
        CHECK_STATUS(fmi2DoStep(c2, t, 0.3, fmi2True), fmi2OK);
    }
    r = dostep3(c3, t, 0.3);
    CHECK_STATUS(fmi2DoStep(c2, t, 0.3, fmi2True), fmi2Discard);
    CHECK_STATUS(fmi2GetRealStatus(c2, fmi2LastSuccessfulTime, &last2), fmi2OK);
    CHECK3_STATUS(r.status, fmi3OK);
    CHECK(r.terminate && !r.event_handling);
    CHECK(r.early == (early_return ? fmi3True : fmi3False));
    CHECK(r.last == last2);
    CHECK_NEAR(r.last, acos(0.5), 1e-6);
    CHECK(getf3(c3, VR_TIME) == last2);
    CHECK(getf3(c3, VR_POS) == getr(c2, VR_POS) && getf3(c3, VR_VEL) == getr(c2, VR_VEL));
    CHECK(getb3(c3, VR_HIT) == 1);
    log_clear();
    r = dostep3(c3, last2, 0.3);
    CHECK3_STATUS(r.status, fmi3Discard);
    CHECK(r.terminate && r.last == last2);
    CHECK_LOG("fmi3DoStep: the simulation terminated at t=");
    CHECK_LOG("(hit)");
    CHECK3_STATUS(fmi3Terminate(c3), fmi3OK);
    fmi3FreeInstance(c3);
    fmi2FreeInstance(c2);
}

int main(void) {
    test_instantiation_refusals();
    test_state_machine();
    test_variables();
    test_steps_equal_fmi2(3); /* dopri5 */
    test_steps_equal_fmi2(5); /* dop853 */
    test_steps_equal_fmi2(2); /* rk4 */
    test_terminating_event(1);
    test_terminating_event(0);
    return h_finish("test_fmi3_oscillator");
}
