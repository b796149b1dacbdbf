/*
 * oscillator_importer.h -- toy_oscillator.c (harmonic oscillator, TERMINATE event "hit" at
 * acos(pos_lim)) as a Co-Simulation importer sees it: its token and value references, and the
 * steps the tests of test_oscillator.c, test_oscillator_simulation.c and test_solvers_osc.c
 * start from.
 * Test code only (include after harness.h).
 */
#ifndef GW_TEST_OSCILLATOR_IMPORTER_H
#define GW_TEST_OSCILLATOR_IMPORTER_H

#define TOKEN "{0sc1-11a7-0r00-0000-000000000001}"
#define PI 3.14159265358979323846

enum { VR_K = 0, VR_POS_LIM = 1, VR_N_INT = 2, VR_USE_FORCE = 3, VR_POS = 10, VR_VEL = 11,
       VR_ENERGY = 20, VR_FORCE = 21, VR_F = 30, VR_SOLVER = 40, VR_REL_TOL = 41,
       VR_ABS_TOL = 42, VR_MAX_STEP = 43, VR_MAX_INTERNAL_STEPS = 44, VR_HIT = 50 };

static fmi2Component inst(const char *name) {
    return fmi2Instantiate(name, fmi2CoSimulation, TOKEN, "", &h_callbacks, fmi2False, fmi2False);
}

/* instantiate, configure, initialise */
static fmi2Component start(const char *name, int solver, double rtol, double atol, double max_step,
                           double pos_lim) {
    fmi2Component c = inst(name);
    CHECK(c != NULL);
    CHECK_STATUS(seti(c, VR_SOLVER, solver), fmi2OK);
    CHECK_STATUS(setr(c, VR_REL_TOL, rtol), fmi2OK);
    CHECK_STATUS(setr(c, VR_ABS_TOL, atol), fmi2OK);
    CHECK_STATUS(setr(c, VR_MAX_STEP, max_step), fmi2OK);
    CHECK_STATUS(setr(c, VR_POS_LIM, pos_lim), fmi2OK);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    return c;
}

static double last_time(fmi2Component c) {
    double t = NAN;
    CHECK_STATUS(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t), fmi2OK);
    return t;
}

/* A call that must fail with fmi2Error, log `msg`, and leave the instance in Error. */
#define EXPECT_ERROR(c, call, msg)                                                           \
    do {                                                                                     \
        log_clear();                                                                         \
        CHECK_STATUS(call, fmi2Error);                                                       \
        CHECK_LOG(msg);                                                                      \
        log_clear();                                                                         \
        CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2Error);                             \
        CHECK_LOG("illegal call in state Error");                                            \
        CHECK_STATUS(fmi2Reset(c), fmi2OK);                                                  \
    } while (0)

#endif
