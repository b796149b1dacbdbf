/*
 * test_oscillator.c -- drives the runtime like a Co-Simulation importer, linked statically with
 * toy_oscillator.c (harmonic oscillator, TERMINATE event "hit" at acos(pos_lim)): the interface.
 * Instantiation (bad arguments, no logger, out of memory at every allocation), start values
 * and variables with their errors, debug logging, checks and settings refused at the call,
 * fmi2DoStep's errors and the state machine, the status functions and the unsupported ones,
 * reset and inputs.  The integration itself: test_oscillator_simulation.c.
 */
#include "harness.h"
#include "oscillator_importer.h"

static void test_instantiate(void) {
    fmi2CallbackFunctions no_alloc = {h_logger, NULL, h_free, NULL, NULL};
    fmi2CallbackFunctions no_logger = {NULL, h_alloc, h_free, NULL, NULL};
    fmi2Component c;
    int k, ok = 0;
    log_clear();
    /* Model Exchange is supported too (tests/c/test_me.c); an unknown fmuType is not */
    c = fmi2Instantiate("a", fmi2ModelExchange, TOKEN, "", &h_callbacks, 0, 0);
    CHECK(c != NULL);
    fmi2FreeInstance(c);
    CHECK(fmi2Instantiate("a", (fmi2Type)7, TOKEN, "", &h_callbacks, 0, 0) == NULL);
    CHECK_LOG("unknown fmuType 7");
    CHECK(fmi2Instantiate("a", fmi2CoSimulation, "{wrong}", "", &h_callbacks, 0, 0) == NULL);
    CHECK_LOG("does not match");
    CHECK(fmi2Instantiate("a", fmi2CoSimulation, NULL, "", &h_callbacks, 0, 0) == NULL);
    CHECK(fmi2Instantiate("a", fmi2CoSimulation, TOKEN, "", &no_alloc, 0, 0) == NULL);
    CHECK_LOG("required");
    CHECK(fmi2Instantiate("", fmi2CoSimulation, TOKEN, "", &h_callbacks, 0, 0) == NULL);
    CHECK_LOG("missing instance name");
    CHECK(fmi2Instantiate("a", fmi2CoSimulation, TOKEN, "", NULL, 0, 0) == NULL);
    CHECK(h_live == 0);

    /* no logger: everything works, errors just are not reported */
    c = fmi2Instantiate("quiet", fmi2CoSimulation, TOKEN, "", &no_logger, fmi2True, fmi2True);
    CHECK(c != NULL);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2Error);
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2OK);
    fmi2FreeInstance(c);
    fmi2FreeInstance(NULL);
    CHECK(h_live == 0);

    /* every allocation failing in turn: NULL, logged, nothing leaked */
    for (k = 0; k < 200; k++) {
        log_clear();
        h_fail_after = k;
        c = inst("oom");
        h_fail_after = -1;
        if (c) {
            ok = 1;
            fmi2FreeInstance(c);
            break;
        }
        CHECK_LOG("out of memory");
        CHECK(h_live == 0);
    }
    CHECK(ok);
    CHECK(k > 10);
    CHECK(h_live == 0);
}

static void test_initial_values(void) {
    fmi2Component c = inst("init");
    fmi2ValueReference vrs[3] = {VR_POS, VR_VEL, VR_ENERGY};
    double v[3];
    fmi2Integer iv = -1;
    fmi2ValueReference vr;
    /* readable already in Instantiated */
    CHECK_NEAR(getr(c, VR_POS), 1.0, 0.0);
    CHECK_NEAR(getr(c, VR_ENERGY), 0.5, 1e-15);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2True, 1e-9, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_NEAR(getr(c, VR_REL_TOL), 1e-6, 0.0); /* resolved at initialisation */
    CHECK_STATUS(setr(c, VR_REL_TOL, 1e-3), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(setr(c, VR_POS, 0.8), fmi2OK);
    CHECK_STATUS(setr(c, VR_VEL, 0.0), fmi2OK);
    CHECK_STATUS(fmi2GetReal(c, vrs, 3, v), fmi2OK);
    CHECK_NEAR(v[0], 0.8, 0.0);
    CHECK_NEAR(v[2], 0.32, 1e-15);
    CHECK_STATUS(setr(c, VR_K, 2.0), fmi2OK);
    CHECK_NEAR(getr(c, VR_ENERGY), 0.64, 1e-15);
    CHECK_NEAR(getr(c, VR_ABS_TOL), 1e-8, 0.0);
    CHECK_NEAR(getr(c, VR_MAX_STEP), 0.01, 0.0);
    vr = VR_SOLVER;
    CHECK_STATUS(fmi2GetInteger(c, &vr, 1, &iv), fmi2OK);
    CHECK(iv == 3);
    vr = VR_N_INT;
    CHECK_STATUS(fmi2GetInteger(c, &vr, 1, &iv), fmi2OK);
    CHECK(iv == 3);
    CHECK_STATUS(seti(c, VR_N_INT, 7), fmi2OK);
    CHECK_STATUS(fmi2GetInteger(c, &vr, 1, &iv), fmi2OK);
    CHECK(iv == 7);
    CHECK(getb(c, VR_USE_FORCE) == fmi2True);
    CHECK(getb(c, VR_HIT) == fmi2False);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_NEAR(getr(c, VR_REL_TOL), 1e-3, 0.0); /* an explicit rel_tol wins over the tolerance */
    CHECK_NEAR(getr(c, VR_ABS_TOL), 1e-8, 0.0); /* ... and abs_tol keeps its default */
    CHECK_NEAR(getr(c, VR_POS), 0.8, 0.0);
    CHECK_NEAR(getr(c, VR_ENERGY), 0.64, 1e-15);
    CHECK_STATUS(fmi2GetString(c, NULL, 0, NULL), fmi2OK);
    CHECK_STATUS(fmi2SetString(c, NULL, 0, NULL), fmi2OK);
    fmi2FreeInstance(c);
}

static void test_variable_errors(void) {
    fmi2Component c = inst("vars");
    fmi2ValueReference vr;
    fmi2Integer iv = 1;
    fmi2Boolean bv = fmi2True;
    double r;
    fmi2String sv = "x";
    EXPECT_ERROR(c, setr(c, 99, 1.0), "unknown value reference 99");
    vr = 25;
    EXPECT_ERROR(c, fmi2GetReal(c, &vr, 1, &r), "unknown value reference 25");
    EXPECT_ERROR(c, seti(c, VR_K, 1), "k (vr=0) is of type Real");
    vr = VR_N_INT;
    EXPECT_ERROR(c, fmi2GetReal(c, &vr, 1, &r), "n_int (vr=2) is of type Integer");
    vr = VR_POS;
    EXPECT_ERROR(c, fmi2SetBoolean(c, &vr, 1, &bv), "pos (vr=10) is of type Real");
    EXPECT_ERROR(c, setr(c, VR_K, NAN), "variable k (vr=0) is not finite");
    EXPECT_ERROR(c, setr(c, VR_POS, INFINITY), "variable pos (vr=10) is not finite");
    EXPECT_ERROR(c, setr(c, VR_ENERGY, 1.0), "energy (vr=20) is read-only");
    vr = VR_HIT;
    EXPECT_ERROR(c, fmi2SetBoolean(c, &vr, 1, &bv), "hit (vr=50) is read-only");
    vr = 0;
    EXPECT_ERROR(c, fmi2GetString(c, &vr, 1, &sv), "no String variables");
    EXPECT_ERROR(c, fmi2SetString(c, &vr, 1, &sv), "no String variables");
    (void)iv;
    fmi2FreeInstance(c);

    /* after initialisation: starts, settings and fixed parameters are frozen */
    c = start("frozen", 3, 1e-6, 1e-8, 0.1, -2.0);
    EXPECT_ERROR(c, setr(c, VR_POS, 0.5), "pos (vr=10) cannot be set in state StepComplete");
    c = (fmi2FreeInstance(c), start("frozen", 3, 1e-6, 1e-8, 0.1, -2.0));
    EXPECT_ERROR(c, setr(c, VR_K, 2.0), "k (vr=0) cannot be set");
    c = (fmi2FreeInstance(c), start("frozen", 3, 1e-6, 1e-8, 0.1, -2.0));
    EXPECT_ERROR(c, setr(c, VR_REL_TOL, 1e-3), "rel_tol (vr=41) cannot be set");
    c = (fmi2FreeInstance(c), start("frozen", 3, 1e-6, 1e-8, 0.1, -2.0));
    EXPECT_ERROR(c, seti(c, VR_SOLVER, 1), "solver (vr=40) cannot be set");
    c = (fmi2FreeInstance(c), start("frozen", 3, 1e-6, 1e-8, 0.1, -2.0));
    CHECK_STATUS(setr(c, VR_POS_LIM, -3.0), fmi2OK); /* tunable */
    CHECK_STATUS(setr(c, VR_F, 0.0), fmi2OK);        /* input */
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2OK);
    fmi2FreeInstance(c);
}

static void test_logging(void) {
    fmi2Component c = start("log", 2, 1e-6, 1e-8, 0.1, -2.0);
    fmi2String bad[2] = {"logSolver", "logFoo"};
    fmi2String solver_cat[1] = {"logSolver"};
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.3, fmi2True), fmi2OK);
    CHECK(h_log_count == 0);
    CHECK_STATUS(fmi2SetDebugLogging(c, fmi2True, 1, solver_cat), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.3, 0.3, fmi2True), fmi2OK);
    CHECK_LOG("|logSolver] fmi2DoStep t=0.29999999999999999 h=0.29999999999999999");
    CHECK_LOG("solver=rk4 accepted=3 rejected=0 rhs=");
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.6, 0.25, fmi2True), fmi2OK);
    CHECK_LOG("accepted=3");
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.85, 0.2, fmi2True), fmi2OK);
    CHECK_LOG("accepted=2");
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 1.05, 1e-7, fmi2True), fmi2OK);
    CHECK_LOG("accepted=1");
    CHECK_STATUS(fmi2SetDebugLogging(c, fmi2False, 0, NULL), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 1.05 + 1e-7, 0.1, fmi2True), fmi2OK);
    CHECK(h_log_count == 0);
    CHECK_STATUS(fmi2SetDebugLogging(c, fmi2True, 0, NULL), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 1.15 + 1e-7, 0.1, fmi2True), fmi2OK);
    CHECK_LOG("logSolver");
    EXPECT_ERROR(c, fmi2SetDebugLogging(c, fmi2True, 2, bad), "unknown log category \"logFoo\"");
    fmi2FreeInstance(c);
}

static void test_checks_and_settings(void) {
    fmi2Component c = inst("chk");
    struct {
        fmi2ValueReference vr;
        double v;
        const char *msg;
    } cases[] = {
        {VR_K, -1.0, "k must be > 0"},
        {VR_K, 0.0, "k must be > 0"},
    };
    /* settings outside their ranges are refused at the call (gw_core.h, docs/fmi.md) */
    static const struct {
        fmi2ValueReference vr;
        double v;
        const char *msg;
    } settings[] = {
        {VR_REL_TOL, 0.0, "rel_tol = 0 is outside its valid range [2.2204460492503131e-15, 1]"},
        {VR_REL_TOL, 1e-16, "rel_tol = 1e-16 is outside its valid range"},
        {VR_REL_TOL, 1e6, "rel_tol = 1e+06 is outside its valid range"},
        {VR_ABS_TOL, -1e-9, "abs_tol = -1e-09 is outside its valid range [1e-30, 1]"},
        {VR_ABS_TOL, 2.0, "abs_tol = 2 is outside its valid range"},
        {VR_MAX_STEP, -0.1, "max_step = -0.1 must be > 0"},
        {VR_MAX_STEP, 0.0, "max_step = 0 must be > 0"},
        {VR_ABS_TOL, 1e-40, "abs_tol = 1e-40 is outside its valid range [1e-30, 1] or 0"},
    };
    size_t i;
    for (i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
        CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
        CHECK_STATUS(setr(c, cases[i].vr, cases[i].v), fmi2OK);
        EXPECT_ERROR(c, fmi2ExitInitializationMode(c), cases[i].msg);
    }
    for (i = 0; i < sizeof(settings) / sizeof(settings[0]); i++)
        EXPECT_ERROR(c, setr(c, settings[i].vr, settings[i].v), settings[i].msg);
    /* 4 rosenbrock, 5 dop853: test_c_solvers */
    EXPECT_ERROR(c, seti(c, VR_SOLVER, 8), "solver = 8 is not a solver: valid are 1 (euler)");
    EXPECT_ERROR(c, seti(c, VR_SOLVER, 0), "solver = 0 is not a solver");
    EXPECT_ERROR(c, seti(c, VR_SOLVER, 99), "solver = 99 is not a solver");
    /* the budget of internal steps, an Integer setting: refused at the call (fmi2SetInteger) */
    EXPECT_ERROR(c, seti(c, VR_MAX_INTERNAL_STEPS, 0),
                 "max_internal_steps = 0 must be a whole number from 1 to 2147483647");
    EXPECT_ERROR(c, seti(c, VR_MAX_INTERNAL_STEPS, -5),
                 "max_internal_steps = -5 must be a whole number from 1 to 2147483647");
    EXPECT_ERROR(c, fmi2SetupExperiment(c, fmi2True, 2.0, 0.0, fmi2False, 0.0),
                 "tolerance 2 is outside the valid range of a relative tolerance");
    /* after all that, defaults are back and the instance works */
    CHECK_NEAR(getr(c, VR_K), 1.0, 0.0);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2OK);
    CHECK_NEAR(getr(c, VR_POS), cos(1.0), 1e-5);
    fmi2FreeInstance(c);
}

static void test_dostep_errors(void) {
    fmi2Component c = inst("dostep");
    fmi2Status st;
    int i;
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2Error);
    CHECK_LOG("fmi2DoStep: illegal call in state Instantiated");
    fmi2FreeInstance(c);

    c = start("dostep", 3, 1e-6, 1e-8, 0.1, -2.0);
    EXPECT_ERROR(c, fmi2DoStep(c, 0.0, 0.0, fmi2True), "step size 0 must be finite and > 0");
    fmi2FreeInstance(c);
    c = start("dostep", 3, 1e-6, 1e-8, 0.1, -2.0);
    EXPECT_ERROR(c, fmi2DoStep(c, 0.0, -1.0, fmi2True), "must be finite and > 0");
    fmi2FreeInstance(c);
    c = start("dostep", 3, 1e-6, 1e-8, 0.1, -2.0);
    EXPECT_ERROR(c, fmi2DoStep(c, 0.0, NAN, fmi2True), "must be finite and > 0");
    fmi2FreeInstance(c);
    c = start("dostep", 3, 1e-6, 1e-8, 0.1, -2.0);
    EXPECT_ERROR(c, fmi2DoStep(c, 0.5, 0.1, fmi2True), "does not match the FMU time");
    fmi2FreeInstance(c);

    /* stop time */
    c = inst("stop");
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, 1.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    st = fmi2OK;
    for (i = 0; i < 10; i++) st = gw_worst_test(st, fmi2DoStep(c, i * 0.1, 0.1, fmi2True));
    CHECK(st == fmi2OK);
    EXPECT_ERROR(c, fmi2DoStep(c, 1.0, 0.1, fmi2True), "goes beyond stopTime");
    fmi2FreeInstance(c);

    /* state machine */
    c = inst("sm");
    log_clear();
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2Error);
    CHECK_LOG("fmi2ExitInitializationMode: illegal call in state Instantiated");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    EXPECT_ERROR(c, fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0), "illegal call");
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    EXPECT_ERROR(c, fmi2Terminate(c), "fmi2Terminate: illegal call in state InitializationMode");
    fmi2FreeInstance(c);
}

static void test_status_and_unsupported(void) {
    fmi2Component c = start("status", 3, 1e-6, 1e-8, 0.1, -2.0);
    fmi2Status sv = fmi2Fatal;
    fmi2Integer iv;
    fmi2String strv;
    fmi2Boolean bv = fmi2True;
    double r;
    fmi2ValueReference vr = VR_POS;
    fmi2Integer order = 1;
    fmi2EventInfo ei;
    CHECK(strcmp(fmi2GetTypesPlatform(), "default") == 0);
    CHECK(strcmp(fmi2GetVersion(), "2.0") == 0);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2GetStatus(c, fmi2DoStepStatus, &sv), fmi2OK);
    CHECK(sv == fmi2OK);
    CHECK_STATUS(fmi2GetStatus(c, fmi2PendingStatus, &sv), fmi2Discard);
    CHECK_STATUS(fmi2GetIntegerStatus(c, fmi2DoStepStatus, &iv), fmi2Discard);
    CHECK_STATUS(fmi2GetStringStatus(c, fmi2PendingStatus, &strv), fmi2Discard);
    CHECK_STATUS(fmi2GetRealStatus(c, fmi2DoStepStatus, &r), fmi2Discard);
    CHECK_STATUS(fmi2GetBooleanStatus(c, fmi2DoStepStatus, &bv), fmi2Discard);
    CHECK_STATUS(fmi2GetBooleanStatus(c, fmi2Terminated, &bv), fmi2OK);
    CHECK(bv == fmi2False);
    CHECK(last_time(c) == 0.1);
    CHECK_STATUS(fmi2DoStep(c, 0.1, 0.1, fmi2True), fmi2OK); /* Discard changed nothing */

    EXPECT_ERROR(c, fmi2CancelStep(c), "never asynchronous");
    CHECK_STATUS(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &r), fmi2Error); /* Instantiated */
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    EXPECT_ERROR(c, fmi2SetRealInputDerivatives(c, &vr, 1, &order, &r), "canInterpolateInputs");
    EXPECT_ERROR(c, fmi2GetRealOutputDerivatives(c, &vr, 1, &order, &r),
                 "MaxOutputDerivativeOrder");
    EXPECT_ERROR(c, fmi2GetDirectionalDerivative(c, &vr, 1, &vr, 1, &r, &r), "not provided");
    EXPECT_ERROR(c, fmi2EnterEventMode(c), "fmi2EnterEventMode: Model Exchange is not supported");
    EXPECT_ERROR(c, fmi2NewDiscreteStates(c, &ei), "Model Exchange");
    EXPECT_ERROR(c, fmi2EnterContinuousTimeMode(c), "Model Exchange");
    EXPECT_ERROR(c, fmi2CompletedIntegratorStep(c, fmi2True, &bv, &bv), "Model Exchange");
    EXPECT_ERROR(c, fmi2SetTime(c, 0.0), "Model Exchange");
    EXPECT_ERROR(c, fmi2SetContinuousStates(c, &r, 1), "Model Exchange");
    EXPECT_ERROR(c, fmi2GetDerivatives(c, &r, 1), "Model Exchange");
    EXPECT_ERROR(c, fmi2GetEventIndicators(c, &r, 1), "Model Exchange");
    EXPECT_ERROR(c, fmi2GetContinuousStates(c, &r, 1), "Model Exchange");
    EXPECT_ERROR(c, fmi2GetNominalsOfContinuousStates(c, &r, 1), "Model Exchange");
    fmi2FreeInstance(c);
}

static void test_reset_and_inputs(void) {
    fmi2Component c = start("reset", 3, 1e-10, 1e-12, 1.0, -2.0);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    CHECK_NEAR(getr(c, VR_K), 1.0, 0.0);
    CHECK_NEAR(getr(c, VR_POS), 1.0, 0.0);
    CHECK_NEAR(getr(c, VR_POS_LIM), -2.0, 0.0);
    CHECK_NEAR(getr(c, VR_REL_TOL), 1e-6, 0.0);
    CHECK(getb(c, VR_HIT) == fmi2False);
    CHECK_STATUS(setr(c, VR_REL_TOL, 1e-10), fmi2OK);
    CHECK_STATUS(setr(c, VR_ABS_TOL, 1e-12), fmi2OK);
    CHECK_STATUS(setr(c, VR_F, 1.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    /* f = 1: equilibrium at pos = 1 */
    CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2OK);
    CHECK_NEAR(getr(c, VR_POS), 1.0, 1e-10);
    CHECK_NEAR(getr(c, VR_FORCE), 1.0, 0.0);
    CHECK_STATUS(setr(c, VR_F, 2.0), fmi2OK);
    CHECK_NEAR(getr(c, VR_FORCE), 2.0, 0.0); /* outputs follow the new input */
    CHECK_STATUS(fmi2DoStep(c, 1.0, 1.0, fmi2True), fmi2OK);
    CHECK_NEAR(getr(c, VR_POS), 2.0 - cos(1.0), 1e-8);
    EXPECT_ERROR(c, setr(c, VR_F, NAN), "f (vr=30) is not finite");
    fmi2FreeInstance(c);
}

int main(void) {
    test_instantiate();
    test_initial_values();
    test_variable_errors();
    test_logging();
    test_checks_and_settings();
    test_dostep_errors();
    test_status_and_unsupported();
    test_reset_and_inputs();
    return h_finish("test_oscillator");
}
