/*
 * test_stickslip.c -- drives the runtime linked with toy_stickslip.c: GW_EVENT_UPDATE events
 * (state jumps at located times, the integrator restarted), the event iteration (a WARN
 * event crossed by the jump fires in the same instant), the once-per-instant guard, the
 * initial settling of the mode, Model Exchange (fmi2NewDiscreteStates reports the jump), and
 * FMU state save/restore across a switch.  Event times against the analytic solution
 * (toy_stickslip.c), found here by bisection.
 */
#include "harness.h"

#define TOKEN "{5t1c-k5l1-0000-0000-000000000006}"
#define BREAK (1.0 + 1e-9)

enum { VR_F0 = 0, VR_L = 1, VR_POS = 2, VR_V = 3, VR_M = 4, VR_FRICTION = 5, VR_SOLVER = 6,
       VR_REL_TOL = 7, VR_ABS_TOL = 8, VR_MAX_STEP = 9, VR_STUCK = 10 };

/* v(t) sliding with mode m from rest at t0 (F = F0 sin t, unit mass) */
static double v_slide(double F0, double L, double m, double t0, double t) {
    return F0 * (cos(t0) - cos(t)) - L * m * (t - t0);
}

/* the first t in (a, b] with v_slide = 0, by bisection (m v > 0 at a, <= 0 at b) */
static double v_zero(double F0, double L, double m, double t0, double a, double b) {
    int i;
    for (i = 0; i < 200; i++) {
        double c = 0.5 * (a + b);
        if (m * v_slide(F0, L, m, t0, c) > 0.0)
            a = c;
        else
            b = c;
    }
    return b;
}

/* time of the n-th (0-based) logged "event <name> at t=" */
static double event_time(const char *name, int n) {
    char key[64];
    const char *p = h_log;
    snprintf(key, sizeof(key), "event %s at t=", name);
    while ((p = strstr(p, key)) != NULL) {
        if (n-- == 0) return strtod(p + strlen(key), NULL);
        p += strlen(key);
    }
    return NAN;
}

static fmi2Component start(fmi2Type type, int solver, double max_step, double F0) {
    fmi2Component c = fmi2Instantiate("ss", type, TOKEN, NULL, &h_callbacks, fmi2False, fmi2False);
    fmi2String cats[1] = {"logEvents"};
    CHECK(c != NULL);
    CHECK_STATUS(fmi2SetDebugLogging(c, fmi2True, 1, cats), fmi2OK);
    CHECK_STATUS(seti(c, VR_SOLVER, solver), fmi2OK);
    CHECK_STATUS(setr(c, VR_MAX_STEP, max_step), fmi2OK);
    CHECK_STATUS(setr(c, VR_F0, F0), fmi2OK);
    return c;
}

/* F0 = 1.2, L = 1 from rest at t = 0: break away (+1), stick, break away (-1), stick */
static void test_stick_slip_times(int solver, double max_step, double tol) {
    const double F0 = 1.2, L = 1.0;
    const double tb1 = asin(L * BREAK / F0), tb2 = 3.14159265358979323846 + tb1;
    const double ts1 = v_zero(F0, L, 1.0, tb1, tb1 + 1e-3, tb1 + 3.0);
    const double ts2 = v_zero(F0, L, -1.0, tb2, tb2 + 1e-3, tb2 + 3.0);
    fmi2Component c = start(fmi2CoSimulation, solver, max_step, F0);
    double t = 0.0, pos_stuck = 0.0;
    int k;
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK(getr(c, VR_M) == 0.0); /* starts stuck: F(0) = 0 */
    log_clear();
    for (k = 0; k < 70; k++, t += 0.1) {
        CHECK_STATUS(fmi2DoStep(c, t, 0.1, fmi2True), fmi2OK);
        if (k == 29) { /* t = 3.0: stuck since ts1 = 2.7638 */
            CHECK(getr(c, VR_M) == 0.0);
            CHECK(getr(c, VR_V) == 0.0); /* exactly: v' = m^2 (...) = 0 */
            pos_stuck = getr(c, VR_POS);
            CHECK(fabs(getr(c, VR_FRICTION)) < L); /* the holding force is within the limit */
        }
        if (k == 39) CHECK(getr(c, VR_POS) == pos_stuck); /* t = 4.0 < tb2: not moved at all */
    }
    CHECK_NEAR(event_time("slip", 0), tb1, tol);
    CHECK_NEAR(event_time("slip", 1), ts1, tol);
    CHECK_NEAR(event_time("stuck", 0), ts1, tol); /* crossed by the jump, same instant */
    CHECK(event_time("stuck", 0) == event_time("slip", 1));
    CHECK_NEAR(event_time("slip", 2), tb2, tol);
    CHECK_NEAR(event_time("slip", 3), ts2, tol);
    CHECK(isnan(event_time("slip", 4))); /* next break away at 2 pi + tb1 > 7 */
    CHECK(getr(c, VR_M) == 0.0 && getr(c, VR_V) == 0.0);
    CHECK(getb(c, VR_STUCK) == fmi2True);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
}

/* F0 = 2: at the first zero of v the force exceeds the limit, the mass turns back (-1) */
static void test_reversal(void) {
    const double F0 = 2.0, L = 1.0, tb1 = asin(L * BREAK / F0);
    const double tz = v_zero(F0, L, 1.0, tb1, tb1 + 1e-3, tb1 + 4.0);
    fmi2Component c = start(fmi2CoSimulation, 3, 0.05, F0);
    CHECK(fabs(F0 * sin(tz)) > L * BREAK);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, tz + 0.05, fmi2True), fmi2OK);
    CHECK_NEAR(event_time("slip", 1), tz, 1e-9);
    CHECK(getr(c, VR_M) == -1.0 && getr(c, VR_V) < 0.0);
    CHECK(isnan(event_time("stuck", 0))); /* never stuck: no warning */
    fmi2Terminate(c);
    fmi2FreeInstance(c);
}

/* Start at t0 = 1.5 where |F| > L: the initial event iteration breaks it away at once */
static void test_initial_settling(void) {
    fmi2Component c = start(fmi2CoSimulation, 3, 0.05, 1.2);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 1.5, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK(getr(c, VR_M) == 0.0); /* from init(s, p): sign(v0) */
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK(getr(c, VR_M) == 1.0);
    CHECK_STATUS(fmi2DoStep(c, 1.5, 0.1, fmi2True), fmi2OK);
    CHECK(getr(c, VR_V) > 0.0);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
}

/* FMU state saved before a switch and restored: the same switch at the same time */
static void test_state_across_switch(void) {
    fmi2Component c = start(fmi2CoSimulation, 3, 0.05, 1.2);
    fmi2FMUstate s = NULL;
    double t1, t2, v1;
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.0, 2.0, fmi2True), fmi2OK); /* sliding, before ts1 */
    CHECK_STATUS(fmi2GetFMUstate(c, &s), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 2.0, 1.0, fmi2True), fmi2OK);
    t1 = event_time("slip", 0);
    v1 = getr(c, VR_POS);
    CHECK(getr(c, VR_M) == 0.0);
    CHECK_STATUS(fmi2SetFMUstate(c, s), fmi2OK);
    CHECK(getr(c, VR_M) == 1.0);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 2.0, 1.0, fmi2True), fmi2OK);
    t2 = event_time("slip", 0);
    CHECK(t1 == t2 && getr(c, VR_POS) == v1 && getr(c, VR_M) == 0.0);
    CHECK_STATUS(fmi2FreeFMUstate(c, &s), fmi2OK);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
}

static fmi2Boolean nds(fmi2Component c, fmi2EventInfo *info) {
    CHECK_STATUS(fmi2NewDiscreteStates(c, info), fmi2OK);
    CHECK(info->newDiscreteStatesNeeded == fmi2False && info->terminateSimulation == fmi2False);
    return info->valuesOfContinuousStatesChanged;
}

/* Model Exchange: the importer locates, the FMU switches in fmi2NewDiscreteStates */
static void test_model_exchange(void) {
    const double F0 = 1.2, L = 1.0, tb1 = asin(L * BREAK / F0);
    fmi2Component c = start(fmi2ModelExchange, 3, 0.05, F0);
    fmi2EventInfo info;
    double x[3], z[2];
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    CHECK(nds(c, &info) == fmi2False); /* nothing to settle: stuck at rest */
    CHECK_STATUS(fmi2EnterContinuousTimeMode(c), fmi2OK);
    /* the importer reaches the breakaway (indicator <= 0 just after tb1) */
    CHECK_STATUS(fmi2SetTime(c, tb1 + 1e-12), fmi2OK);
    CHECK_STATUS(fmi2GetEventIndicators(c, z, 2), fmi2OK);
    CHECK(z[0] <= 0.0);
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
    CHECK(nds(c, &info) == fmi2True); /* the mode switched: states changed */
    CHECK_STATUS(fmi2GetContinuousStates(c, x, 3), fmi2OK);
    CHECK(x[2] == 1.0 && x[1] == 0.0);
    CHECK(nds(c, &info) == fmi2False); /* same instant again: no second switch */
    CHECK_STATUS(fmi2GetContinuousStates(c, x, 3), fmi2OK);
    CHECK(x[2] == 1.0);
    CHECK_STATUS(fmi2EnterContinuousTimeMode(c), fmi2OK);
    /* sliding: the indicator m v starts at 0, is seen > 0, then reaches 0 where |F| < L */
    x[1] = 0.3;
    CHECK_STATUS(fmi2SetTime(c, 2.0), fmi2OK);
    CHECK_STATUS(fmi2SetContinuousStates(c, x, 3), fmi2OK);
    CHECK_STATUS(fmi2GetEventIndicators(c, z, 2), fmi2OK);
    CHECK(z[0] > 0.0);
    x[1] = -1e-15;
    CHECK_STATUS(fmi2SetTime(c, 2.8), fmi2OK); /* |F(2.8)| = 0.40 < L */
    CHECK_STATUS(fmi2SetContinuousStates(c, x, 3), fmi2OK);
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
    log_clear();
    CHECK(nds(c, &info) == fmi2True);
    CHECK_STATUS(fmi2GetContinuousStates(c, x, 3), fmi2OK);
    CHECK(x[2] == 0.0 && x[1] == 0.0); /* stuck, the rate set exactly to 0 */
    CHECK_LOG("event stuck at t=2.7999999999999998"); /* crossed by the jump */
    CHECK(getb(c, VR_STUCK) == fmi2True);
    CHECK_STATUS(fmi2EnterContinuousTimeMode(c), fmi2OK);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
}

int main(void) {
    test_stick_slip_times(3, 0.05, 1e-9);  /* dopri5 */
    test_stick_slip_times(5, 0.05, 1e-9);  /* dop853 */
    test_stick_slip_times(4, 0.05, 1e-7);  /* rosenbrock: 3rd-order dense output */
    test_stick_slip_times(2, 1e-3, 1e-9);  /* rk4, fixed step */
    test_reversal();
    test_initial_settling();
    test_state_across_switch();
    test_model_exchange();
    return h_finish("test_stickslip");
}
