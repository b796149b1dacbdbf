/*
 * test_oscillator_simulation.c -- drives the runtime like a Co-Simulation importer, linked
 * statically with toy_oscillator.c (harmonic oscillator, TERMINATE event "hit" at
 * acos(pos_lim)): the integration.  abs_tol = 0 and the budget of internal steps, each
 * solver's accuracy against the exact solution, the terminating event located (also for an
 * importer that steps on after it), landing on communication points, FMU states (restore bit
 * for bit, serialise, corrupt byte streams refused), two instances side by side.  The
 * interface: test_oscillator.c.
 */
#include "harness.h"
#include "oscillator_importer.h"

/* abs_tol = 0 follows rel_tol, under the checks at the call and the tolerance precedence
 * (docs/fmi.md, "Tolerances"); the budget max_internal_steps bounds a call and survives a state */
static void test_abs_tol_zero_and_budget(void) {
    fmi2Component a = inst("zero"), b = inst("explicit"), c;
    fmi2FMUstate s = NULL;
    int i;
    CHECK_STATUS(setr(a, VR_ABS_TOL, 0.0), fmi2OK); /* valid at the call */
    CHECK_STATUS(setr(b, VR_ABS_TOL, 1e-2 * 1e-7), fmi2OK);
    /* a forwarded tolerance 1e-7 replaces rel_tol of both; abs_tol set explicitly stays, and 0
     * follows it: the same run as rel_tol / 100 set by hand, bit for bit */
    CHECK_STATUS(fmi2SetupExperiment(a, fmi2True, 1e-7, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2SetupExperiment(b, fmi2True, 1e-7, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(a), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(a), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(b), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(b), fmi2OK);
    CHECK(getr(a, VR_REL_TOL) == 1e-7 && getr(a, VR_ABS_TOL) == 0.0);
    for (i = 0; i < 5; i++) {
        CHECK_STATUS(fmi2DoStep(a, i * 0.2, 0.2, fmi2True), fmi2OK);
        CHECK_STATUS(fmi2DoStep(b, i * 0.2, 0.2, fmi2True), fmi2OK);
    }
    CHECK(getr(a, VR_POS) == getr(b, VR_POS) && getr(a, VR_VEL) == getr(b, VR_VEL));
    CHECK_NEAR(getr(a, VR_POS), cos(1.0), 1e-6);
    fmi2FreeInstance(b);
    fmi2FreeInstance(a);

    /* the budget: 10 steps of max_step 0.01 allowed, an 0.2 s step refused up front and the
     * state kept; a 0.1 s step runs; the budget comes back with a saved state */
    c = inst("budget");
    CHECK_STATUS(seti(c, VR_SOLVER, 2), fmi2OK);
    CHECK_STATUS(setr(c, VR_MAX_STEP, 0.01), fmi2OK);
    CHECK_STATUS(seti(c, VR_MAX_INTERNAL_STEPS, 10), fmi2OK);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2GetFMUstate(c, &s), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.1, 0.2, fmi2True), fmi2Error);
    CHECK_LOG("more than max_internal_steps = 10");
    CHECK(last_time(c) == 0.1);
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    CHECK_STATUS(fmi2SetFMUstate(c, s), fmi2OK);
    {
        fmi2ValueReference vr = VR_MAX_INTERNAL_STEPS;
        fmi2Integer n = 0;
        CHECK_STATUS(fmi2GetInteger(c, &vr, 1, &n), fmi2OK);
        CHECK(n == 10);
    }
    CHECK_STATUS(fmi2DoStep(c, 0.1, 0.1, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2FreeFMUstate(c, &s), fmi2OK);
    fmi2FreeInstance(c);
}

static void run_accuracy(int solver, double rtol, double max_step, double tol) {
    fmi2Component c = start("acc", solver, rtol, rtol * 1e-2, max_step, -2.0);
    int i;
    fmi2Status st = fmi2OK;
    long allocs = h_total;
    for (i = 0; i < 20; i++) st = gw_worst_test(st, fmi2DoStep(c, i * 0.1, 0.1, fmi2True));
    CHECK(st == fmi2OK);
    CHECK(h_total == allocs); /* fmi2DoStep never allocates */
    CHECK_NEAR(getr(c, VR_POS), cos(2.0), tol);
    CHECK_NEAR(getr(c, VR_VEL), -sin(2.0), tol);
    CHECK_NEAR(getr(c, VR_ENERGY), 0.5, 2 * tol);
    CHECK(last_time(c) == 19 * 0.1 + 0.1);
    fmi2FreeInstance(c);
}

static void test_accuracy(void) {
    run_accuracy(3, 1e-10, 1.0, 1e-8);
    run_accuracy(3, 1e-6, 0.01, 1e-5);
    run_accuracy(2, 1e-6, 1e-3, 1e-10);
    run_accuracy(1, 1e-6, 1e-5, 1e-4);
}

static void run_terminate(int solver, double rtol, double max_step, double h, double tol) {
    fmi2Component c = start("term", solver, rtol, rtol * 1e-2, max_step, 0.5);
    const double te = PI / 3.0;
    double t = 0.0, v[2];
    fmi2ValueReference vrs[2] = {VR_POS, VR_VEL};
    fmi2Boolean term = fmi2True;
    fmi2Status st = fmi2OK;
    int n = 0;
    long allocs = h_total;
    while (n < 1000) {
        st = fmi2DoStep(c, t, h, fmi2True);
        if (st != fmi2OK) break;
        CHECK_STATUS(fmi2GetBooleanStatus(c, fmi2Terminated, &term), fmi2OK);
        CHECK(term == fmi2False);
        CHECK(getb(c, VR_HIT) == fmi2False);
        t += h;
        n++;
    }
    CHECK(st == fmi2Discard);
    CHECK(h_total == allocs);
    CHECK(t < te && t + h > te);
    CHECK_STATUS(fmi2GetBooleanStatus(c, fmi2Terminated, &term), fmi2OK);
    CHECK(term == fmi2True);
    CHECK_NEAR(last_time(c), te, tol);
    CHECK_STATUS(fmi2GetReal(c, vrs, 2, v), fmi2OK);
    CHECK(isfinite(v[0]) && isfinite(v[1]));
    CHECK_NEAR(v[0], 0.5, tol);
    CHECK(v[0] <= 0.5);
    CHECK_NEAR(v[1], -sin(te), tol);
    CHECK(getb(c, VR_HIT) == fmi2True);
    /* the reason of the Discard is logged, whatever the logging settings */
    CHECK_LOG("fmi2DoStep: hit at t=1.0471");
    /* a master that ignores fmi2Discard and keeps stepping (ecospy): every further step is
     * fmi2Discard with one logged reason, the state stays the fall's, terminate works */
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, t, h, fmi2True), fmi2Discard);
    CHECK_LOG("the simulation terminated at t=1.0471");
    CHECK_LOG("no further step is computed");
    for (n = 0; n < 50; n++) CHECK_STATUS(fmi2DoStep(c, t + n * h, h, fmi2True), fmi2Discard);
    CHECK_NEAR(last_time(c), te, tol);
    CHECK_STATUS(fmi2GetBooleanStatus(c, fmi2Terminated, &term), fmi2OK);
    CHECK(term == fmi2True);
    CHECK_NEAR(getr(c, VR_POS), 0.5, tol); /* still the state at the fall */
    CHECK_STATUS(fmi2Terminate(c), fmi2OK);
    CHECK_LOG("(the previous message was repeated 50 more times)");
    CHECK_NEAR(getr(c, VR_POS), 0.5, tol);
    CHECK_STATUS(fmi2Terminate(c), fmi2Warning); /* a second Terminate (PyFMI) is ignored */
    CHECK_LOG("fmi2Terminate: already terminated; the call is ignored");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    fmi2FreeInstance(c);
}

static void test_terminate_event(void) {
    fmi2Component c;
    fmi2Boolean term;
    run_terminate(3, 1e-12, 1.0, 0.1, 1e-9);
    run_terminate(3, 1e-12, 1.0, 100.0, 1e-9);
    run_terminate(3, 1e-12, 0.01, 0.01, 1e-9);
    run_terminate(2, 1e-6, 1e-3, 0.1, 1e-9);
    run_terminate(2, 1e-6, 1e-3, 2.0, 1e-9);
    run_terminate(1, 1e-6, 1e-6, 0.5, 1e-5);

    /* fmi2Terminate after the Discard, then stepping is refused */
    c = start("term2", 3, 1e-8, 1e-10, 1.0, 0.5);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 2.0, fmi2True), fmi2Discard);
    CHECK_STATUS(fmi2Terminate(c), fmi2OK);
    CHECK_NEAR(getr(c, VR_POS), 0.5, 1e-7);
    CHECK_STATUS(fmi2GetBooleanStatus(c, fmi2Terminated, &term), fmi2OK);
    CHECK(term == fmi2True);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 2.0, 1.0, fmi2True), fmi2Discard);
    CHECK_LOG("the simulation terminated at t=");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 2.0, fmi2True), fmi2OK); /* pos_lim back to -2 */
    fmi2FreeInstance(c);

    /* tunable pos_lim set during the simulation */
    c = start("term3", 3, 1e-12, 1e-14, 1.0, -2.0);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.5, fmi2True), fmi2OK);
    CHECK_STATUS(setr(c, VR_POS_LIM, 0.0), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.5, 1.5, fmi2True), fmi2Discard);
    CHECK_NEAR(last_time(c), PI / 2, 1e-9);
    CHECK_NEAR(getr(c, VR_POS), 0.0, 1e-9);
    fmi2FreeInstance(c);
}

static void test_landing(void) {
    fmi2Component c = start("land", 3, 1e-10, 1e-12, 1.0, -2.0);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 100.0, fmi2True), fmi2OK);
    CHECK(last_time(c) == 100.0);
    CHECK_NEAR(getr(c, VR_POS), cos(100.0), 1e-6);
    CHECK_STATUS(fmi2DoStep(c, 100.0, 1e-7, fmi2True), fmi2OK);
    CHECK(last_time(c) == 100.0 + 1e-7);
    CHECK_NEAR(getr(c, VR_POS), cos(100.0 + 1e-7), 1e-6);
    /* tiny relative mismatch of the communication point is accepted */
    CHECK_STATUS(fmi2DoStep(c, 100.0 + 1e-7 + 1e-12, 0.5, fmi2True), fmi2OK);
    fmi2FreeInstance(c);

    c = start("land4", 2, 1e-6, 1e-8, 0.01, -2.0);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 100.0, fmi2True), fmi2OK);
    CHECK(last_time(c) == 100.0);
    CHECK_NEAR(getr(c, VR_POS), cos(100.0), 1e-7);
    CHECK_STATUS(fmi2DoStep(c, 100.0, 1e-7, fmi2True), fmi2OK);
    CHECK(last_time(c) == 100.0 + 1e-7);
    fmi2FreeInstance(c);
}

static void test_fmu_state(void) {
    fmi2Component c = start("state", 3, 1e-8, 1e-10, 1.0, 0.5), d;
    fmi2FMUstate s = NULL, s2 = NULL, s3 = NULL, bad = NULL;
    size_t size = 0;
    fmi2Byte *bytes, *copy;
    double p1, p2, p3, v1;
    int i;
    for (i = 0; i < 5; i++) CHECK_STATUS(fmi2DoStep(c, i * 0.1, 0.1, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2GetFMUstate(c, &s), fmi2OK);
    CHECK_STATUS(fmi2GetFMUstate(c, &s), fmi2OK); /* overwrite in place */
    CHECK_STATUS(fmi2DoStep(c, 0.5, 0.3, fmi2True), fmi2OK);
    p1 = getr(c, VR_POS);
    v1 = getr(c, VR_VEL);
    /* into the terminating event, then back */
    CHECK_STATUS(fmi2DoStep(c, 0.8, 0.5, fmi2True), fmi2Discard);
    CHECK_STATUS(fmi2SetFMUstate(c, s), fmi2OK);
    CHECK(last_time(c) == 0.5);
    CHECK(getb(c, VR_HIT) == fmi2False);
    CHECK_STATUS(fmi2DoStep(c, 0.5, 0.3, fmi2True), fmi2OK);
    p2 = getr(c, VR_POS);
    CHECK(p1 == p2); /* bitwise: step size and FSAL restored */
    CHECK(v1 == getr(c, VR_VEL));

    CHECK_STATUS(fmi2SerializedFMUstateSize(c, s, &size), fmi2OK);
    CHECK(size > 44);
    bytes = (fmi2Byte *)malloc(size);
    copy = (fmi2Byte *)malloc(size);
    CHECK_STATUS(fmi2SerializeFMUstate(c, s, bytes, size), fmi2OK);
    CHECK(memcmp(bytes, "GWST", 4) == 0);
    CHECK_STATUS(fmi2SerializeFMUstate(c, s, bytes, size - 1), fmi2Error);
    CHECK_STATUS(fmi2Reset(c), fmi2OK);

    /* deserialize into another instance */
    d = inst("state2");
    CHECK_STATUS(fmi2DeSerializeFMUstate(d, bytes, size, &s2), fmi2OK);
    CHECK_STATUS(fmi2DeSerializeFMUstate(d, bytes, size, &s2), fmi2OK); /* reuse */
    CHECK_STATUS(fmi2SetFMUstate(d, s2), fmi2OK);
    CHECK_NEAR(getr(d, VR_POS_LIM), 0.5, 0.0);
    CHECK_STATUS(fmi2DoStep(d, 0.5, 0.3, fmi2True), fmi2OK);
    p3 = getr(d, VR_POS);
    CHECK(p3 == p1);

    /* corrupted byte streams */
#define BAD_STREAM(mutate, n, msg)                                                           \
    do {                                                                                     \
        memcpy(copy, bytes, size);                                                           \
        mutate;                                                                              \
        log_clear();                                                                         \
        CHECK_STATUS(fmi2DeSerializeFMUstate(d, copy, n, &bad), fmi2Error);                  \
        CHECK(bad == NULL);                                                                  \
        CHECK_LOG(msg);                                                                      \
        CHECK_STATUS(fmi2SetFMUstate(d, s2), fmi2OK); /* recovers from Error */            \
    } while (0)
    BAD_STREAM(copy[0] = 'X', size, "bad magic");
    BAD_STREAM((void)0, 10, "bad magic or too short");
    BAD_STREAM(copy[4] = 7, size, "layout version 7");
    BAD_STREAM(copy[12] = 9, size, "do not match this model");
    BAD_STREAM(copy[46] ^= 1, size, "belongs to another model");
    BAD_STREAM((void)0, size - 1, "expected");
    BAD_STREAM(copy[8] ^= 1, size, "expected");
    CHECK_STATUS(fmi2DoStep(d, 0.5, 0.3, fmi2True), fmi2OK);
    CHECK(getr(d, VR_POS) == p1);

    /* a state of the Error state, restore of an errored instance */
    CHECK_STATUS(fmi2DoStep(d, 0.0, 0.3, fmi2True), fmi2Error);
    CHECK_STATUS(fmi2GetFMUstate(d, &s3), fmi2OK);
    CHECK_STATUS(fmi2SetFMUstate(d, s2), fmi2OK);
    CHECK_STATUS(fmi2DoStep(d, 0.5, 0.1, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2SetFMUstate(d, s3), fmi2OK);
    CHECK_STATUS(fmi2DoStep(d, 0.8, 0.1, fmi2True), fmi2Error);

    CHECK_STATUS(fmi2FreeFMUstate(d, &s3), fmi2OK);
    CHECK(s3 == NULL);
    CHECK_STATUS(fmi2FreeFMUstate(d, &s3), fmi2OK);
    CHECK_STATUS(fmi2FreeFMUstate(d, &s2), fmi2OK);
    CHECK_STATUS(fmi2FreeFMUstate(c, &s), fmi2OK);
    free(bytes);
    free(copy);
    fmi2FreeInstance(c);
    fmi2FreeInstance(d);
}

static void test_two_instances(void) {
    fmi2Component a = inst("A"), b = inst("B");
    int i;
    CHECK_STATUS(setr(b, VR_K, 4.0), fmi2OK);
    CHECK_STATUS(setr(a, VR_REL_TOL, 1e-10), fmi2OK);
    CHECK_STATUS(setr(b, VR_REL_TOL, 1e-10), fmi2OK);
    CHECK_STATUS(setr(a, VR_ABS_TOL, 1e-12), fmi2OK);
    CHECK_STATUS(setr(b, VR_ABS_TOL, 1e-12), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(a), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(b), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(b), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(a), fmi2OK);
    for (i = 0; i < 10; i++) {
        CHECK_STATUS(fmi2DoStep(a, i * 0.2, 0.2, fmi2True), fmi2OK);
        CHECK_STATUS(fmi2DoStep(b, i * 0.2, 0.2, fmi2True), fmi2OK);
        CHECK_NEAR(getr(a, VR_POS), cos((i + 1) * 0.2), 1e-8);
        CHECK_NEAR(getr(b, VR_POS), cos(2.0 * (i + 1) * 0.2), 1e-8);
    }
    fmi2FreeInstance(a);
    fmi2FreeInstance(b);
}

int main(void) {
    test_abs_tol_zero_and_budget();
    test_accuracy();
    test_terminate_event();
    test_landing();
    test_fmu_state();
    test_two_instances();
    return h_finish("test_oscillator_simulation");
}
