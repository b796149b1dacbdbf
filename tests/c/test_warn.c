/*
 * test_warn.c -- drives the runtime linked with toy_warn.c: WARN events, inputs,
 * non-finite states and step size underflow.
 */
#include "harness.h"

#define TOKEN "{3a7b-warn-0000-0000-000000000002}"

enum { VR_TH = 0, VR_G = 1, VR_TH2 = 2, VR_X = 5, VR_X2 = 6, VR_U = 7, VR_SOLVER = 8,
       VR_REL_TOL = 9, VR_ABS_TOL = 10, VR_MAX_STEP = 11, VR_C1 = 12, VR_C2 = 13 };


static fmi2Component start(int solver, double max_step, int logging, const char *category) {
    fmi2Component c =
        fmi2Instantiate("warn", fmi2CoSimulation, TOKEN, NULL, &h_callbacks, fmi2False, fmi2False);
    fmi2ValueReference vr = VR_SOLVER;
    fmi2Integer s = solver;
    CHECK(c != NULL);
    if (logging) {
        fmi2String cats[1];
        cats[0] = category;
        CHECK_STATUS(fmi2SetDebugLogging(c, fmi2True, category ? 1 : 0, cats), fmi2OK);
    }
    CHECK_STATUS(fmi2SetInteger(c, &vr, 1, &s), fmi2OK);
    CHECK_STATUS(setr(c, VR_MAX_STEP, max_step), fmi2OK);
    CHECK_STATUS(setr(c, VR_REL_TOL, 1e-10), fmi2OK);
    CHECK_STATUS(setr(c, VR_ABS_TOL, 1e-12), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    return c;
}

/* time of the n-th (0-based) logged occurrence of "<name> at t=" */
static double event_time(const char *name, int n) {
    char key[64];
    const char *p = h_log;
    snprintf(key, sizeof(key), "%s at t=", name);
    while ((p = strstr(p, key)) != NULL) {
        if (n-- == 0) return strtod(p + strlen(key), NULL);
        p += strlen(key);
    }
    return NAN;
}

static int count(const char *s) {
    int n = 0;
    const char *p = h_log;
    while ((p = strstr(p, s)) != NULL) {
        n++;
        p += strlen(s);
    }
    return n;
}

static void test_warn_events(int solver, double max_step) {
    fmi2Component c = start(solver, max_step, 1, "logEvents");
    double t;
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    log_clear();
    long allocs = h_total;
    CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2OK); /* both events in one step */
    CHECK(h_total == allocs);
    CHECK_NEAR(event_time("crossed1", 0), 0.25, 1e-9);
    CHECK_NEAR(event_time("crossed2", 0), 0.5, 1e-9);
    CHECK_LOG("|1|logEvents] warning: event crossed1 at t=");
    CHECK(getb(c, VR_C1) == fmi2True && getb(c, VR_C2) == fmi2True);
    CHECK_NEAR(getr(c, VR_X), 1.0, 1e-9);
    CHECK_NEAR(getr(c, VR_X2), 2.0, 2e-9);
    CHECK_STATUS(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t), fmi2OK);
    CHECK(t == 1.0);
    /* go back below the threshold and cross again: fires again */
    CHECK_STATUS(setr(c, VR_U, -1.0), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 1.0, 0.9, fmi2True), fmi2OK);
    CHECK(h_log_count == 0); /* upward crossings do not fire */
    CHECK_NEAR(getr(c, VR_X), 0.1, 1e-9);
    CHECK_STATUS(setr(c, VR_U, 2.0), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 1.9, 0.1, fmi2True), fmi2OK);
    CHECK_NEAR(event_time("crossed1", 0), 1.975, 1e-9);
    CHECK(count("crossed1") == 1 && count("crossed2") == 0);
    CHECK_NEAR(getr(c, VR_X), 0.3, 1e-9);
    fmi2FreeInstance(c);
}

static void test_event_in_substep(void) {
    fmi2Component c = start(2, 0.1, 1, NULL); /* all categories */
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.2, fmi2True), fmi2OK);
    CHECK_LOG("accepted=2 ");
    CHECK(getb(c, VR_C1) == fmi2False);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.2, 0.1, fmi2True), fmi2OK);
    CHECK_LOG("accepted=2 "); /* [0.2, 0.25] and [0.25, 0.3] */
    CHECK(getb(c, VR_C1) == fmi2True);
    CHECK_NEAR(event_time("crossed1", 0), 0.25, 1e-12);
    fmi2FreeInstance(c);
}

static void test_warn_logging_categories(void) {
    fmi2Component c = start(3, 1.0, 0, NULL);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2OK);
    CHECK(h_log_count == 0); /* no debug logging: silent */
    CHECK(getb(c, VR_C1) == fmi2True);
    fmi2FreeInstance(c);

    c = start(3, 1.0, 1, "logStatusWarning");
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2OK);
    CHECK_LOG("|1|logStatusWarning] warning: event crossed1 at t=0.25");
    CHECK_NO_LOG("logSolver");
    fmi2FreeInstance(c);
}

static void test_nonfinite(void) {
    fmi2Component c = start(1, 0.5, 0, NULL);
    double t = -1;
    CHECK_STATUS(setr(c, VR_G, 1.0), fmi2OK);
    CHECK_STATUS(setr(c, VR_X, 1.2e154), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2Error);
    CHECK_LOG("state x is not finite");
    CHECK(getr(c, VR_X) == 1.2e154); /* restored, finite */
    CHECK(isfinite(getr(c, VR_X2)));
    CHECK_STATUS(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t), fmi2OK);
    CHECK(t == 0.0);
    fmi2FreeInstance(c);

    /* rk4 */
    c = start(2, 1.0, 0, NULL);
    CHECK_STATUS(setr(c, VR_G, 1.0), fmi2OK);
    CHECK_STATUS(setr(c, VR_X, 1.2e154), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2Error);
    CHECK_LOG("not finite");
    CHECK(getr(c, VR_X) == 1.2e154);
    fmi2FreeInstance(c);

    /* dopri5 through a finite-time blow-up x = 1/(1-t): step size underflow */
    c = start(3, 1.0, 0, NULL);
    CHECK_STATUS(setr(c, VR_G, 1.0), fmi2OK);
    CHECK_STATUS(setr(c, VR_X, 1.0), fmi2OK);
    CHECK_STATUS(setr(c, VR_U, 0.0), fmi2OK);
    CHECK_STATUS(setr(c, VR_TH, 1e300), fmi2OK); /* keep the WARN events out of the way */
    CHECK_STATUS(setr(c, VR_TH2, 1e300), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.5, fmi2True), fmi2OK);
    CHECK_NEAR(getr(c, VR_X), 2.0, 1e-8);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.5, 1.0, fmi2True), fmi2Error);
    CHECK(log_contains("step size underflow at t=") || log_contains("not finite") ||
          log_contains("internal steps of h="));
    CHECK_NEAR(getr(c, VR_X), 2.0, 1e-8); /* back at the start of the step */
    CHECK_STATUS(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t), fmi2OK);
    CHECK(t == 0.5);
    fmi2FreeInstance(c);

    /* huge derivative already at the initial state */
    c = start(3, 1.0, 0, NULL);
    CHECK_STATUS(setr(c, VR_G, 1e300), fmi2OK);
    CHECK_STATUS(setr(c, VR_X, 1e300), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2Error);
    CHECK_LOG("derivative of state x is not finite");
    fmi2FreeInstance(c);
}

static void test_inputs_and_checks(void) {
    fmi2Component c = start(2, 0.05, 0, NULL);
    fmi2ValueReference vr = VR_U;
    double v;
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2OK);
    CHECK_NEAR(getr(c, VR_X), 0.1, 1e-12);
    v = 3.0;
    CHECK_STATUS(fmi2SetReal(c, &vr, 1, &v), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.1, 0.1, fmi2True), fmi2OK);
    CHECK_NEAR(getr(c, VR_X), 0.4, 1e-12);
    v = INFINITY;
    log_clear();
    CHECK_STATUS(fmi2SetReal(c, &vr, 1, &v), fmi2Error);
    CHECK_LOG("variable u (vr=7) is not finite");
    fmi2FreeInstance(c);

    c = start(2, 0.05, 0, NULL);
    CHECK_STATUS(setr(c, VR_TH, 0.0), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2Error);
    CHECK_LOG("x_thresh must be > 0");
    fmi2FreeInstance(c);
}

int main(void) {
    test_warn_events(2, 0.01);
    test_warn_events(3, 1.0);
    test_warn_events(3, 0.01);
    test_warn_events(1, 0.01);
    test_event_in_substep();
    test_warn_logging_categories();
    test_nonfinite();
    test_inputs_and_checks();
    return h_finish("test_warn");
}
