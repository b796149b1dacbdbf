/*
 * test_fmi3_stickslip.c -- fmi3DoStep at update events (toy_stickslip.c: the mode switches of
 * stiction, GW_TOY_VR_BASE=1), beside fmi2DoStep over the same toy in the same program:
 *   without earlyReturnAllowed   the switches happen inside the step: every value bit-identical
 *                                to FMI 2.0's, with or without eventModeUsed
 *   earlyReturnAllowed           the step returns at each switch (earlyReturn,
 *                                lastSuccessfulTime): the switch times against the analytic
 *                                solution, the first bit-identical to FMI 2.0's located time
 *   ... and eventModeUsed        the step returns before the switch (eventHandlingNeeded); the
 *                                master's fmi3EnterEventMode, fmi3UpdateDiscreteStates,
 *                                fmi3EnterStepMode apply it: the same run, bit for bit
 */
#include "harness3.h"

#define TOKEN "{5t1c-k5l1-0000-0000-000000000006}"
#define BREAK (1.0 + 1e-9)
#define F0 1.2
#define L 1.0
#define T_END 7.0
#define N_SWITCH 8

enum { VR_TIME = 0, VR_F0 = 1, VR_POS = 3, VR_V = 4, VR_M = 5, VR_SOLVER = 7, VR_MAX_STEP = 10,
       VR_STUCK = 11 };

/* v(t) sliding with mode m from rest at t0 (F = F0 sin t, unit mass) */
static double v_slide(double m, double t0, double t) {
    return F0 * (cos(t0) - cos(t)) - L * m * (t - t0);
}

/* the first t in (a, b] with v_slide = 0, by bisection (m v > 0 at a, <= 0 at b) */
static double v_zero(double m, double t0, double a, double b) {
    int i;
    for (i = 0; i < 200; i++) {
        double c = 0.5 * (a + b);
        if (m * v_slide(m, t0, c) > 0.0)
            a = c;
        else
            b = c;
    }
    return b;
}

static fmi3Instance start3(int event_mode, int early_return) {
    fmi3Instance c = cs3_new("ss3", TOKEN, event_mode, early_return);
    CHECK3_STATUS(seti64(c, VR_SOLVER, 3), fmi3OK);
    CHECK3_STATUS(setf3(c, VR_MAX_STEP, 0.05), fmi3OK);
    CHECK3_STATUS(setf3(c, VR_F0, F0), fmi3OK);
    CHECK3_STATUS(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
    CHECK3_STATUS(fmi3ExitInitializationMode(c), fmi3OK);
    if (event_mode) {
        CHECK3_STATUS(fmi3UpdateDiscreteStates(c, NULL, NULL, NULL, NULL, NULL, NULL), fmi3OK);
        CHECK3_STATUS(fmi3EnterStepMode(c), fmi3OK);
    }
    return c;
}

static fmi2Component start2(void) {
    fmi2Component c = fmi2Instantiate("ss2", fmi2CoSimulation, TOKEN, NULL, &h_callbacks,
                                      fmi2False, fmi2False);
    fmi2String cats[1] = {"logEvents"};
    CHECK(c != NULL);
    CHECK_STATUS(fmi2SetDebugLogging(c, fmi2True, 1, cats), fmi2OK);
    CHECK_STATUS(seti(c, VR_SOLVER, 3), fmi2OK);
    CHECK_STATUS(setr(c, VR_MAX_STEP, 0.05), fmi2OK);
    CHECK_STATUS(setr(c, VR_F0, F0), fmi2OK);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    return c;
}

/* the switches inside the steps, as FMI 2.0 */
static void test_without_early_return(int event_mode) {
    fmi3Instance c3 = start3(event_mode, 0);
    fmi2Component c2 = start2();
    fmi3ValueReference vr3[3] = {VR_POS, VR_V, VR_M};
    fmi2ValueReference vr2[3] = {VR_POS, VR_V, VR_M};
    double t = 0.0, v3[3], v2[3];
    int k, same = 1, quiet = 1;
    for (k = 0; k < 70; k++, t += 0.1) {
        h_step3 r = dostep3(c3, t, 0.1);
        CHECK3_STATUS(r.status, fmi3OK);
        CHECK_STATUS(fmi2DoStep(c2, t, 0.1, fmi2True), fmi2OK);
        CHECK3_STATUS(fmi3GetFloat64(c3, vr3, 3, v3, 3), fmi3OK);
        CHECK_STATUS(fmi2GetReal(c2, vr2, 3, v2), fmi2OK);
        same &= memcmp(v2, v3, sizeof(v2)) == 0;
        quiet &= !r.early && !r.event_handling && !r.terminate && r.last == t + 0.1;
    }
    CHECK(same && quiet);
    CHECK(getb3(c3, VR_STUCK) == 1 && getb(c2, VR_STUCK) == fmi2True);
    fmi3FreeInstance(c3);
    fmi2FreeInstance(c2);
}

/* time of the first logged "event slip at t=" */
static double first_slip(void) {
    const char *p = strstr(h_log, "event slip at t=");
    return p ? strtod(p + strlen("event slip at t="), NULL) : NAN;
}

/* Steps of 0.1 from 0 to T_END, each from where the last one returned; the switch times into
 * te[] (their number returned), the state at the end into x_end.  With eventModeUsed every
 * early return leaves the switch to the master's Event Mode. */
static int run_early(int event_mode, double te[N_SWITCH], double x_end[3]) {
    fmi3Instance c = start3(event_mode, 1);
    fmi3ValueReference vr[3] = {VR_POS, VR_V, VR_M};
    double t = 0.0;
    int n = 0, k;
    for (k = 0; k < 200 && t < T_END; k++) {
        const double h = t + 0.1 < T_END ? 0.1 : T_END - t;
        h_step3 r = dostep3(c, t, h);
        CHECK3_STATUS(r.status, fmi3OK);
        CHECK(!r.terminate);
        if (!r.early) {
            CHECK(r.last == t + h && !r.event_handling);
            t += h;
            continue;
        }
        CHECK(r.last > t && r.last < t + h && getf3(c, VR_TIME) == r.last);
        CHECK(r.event_handling == (event_mode ? fmi3True : fmi3False));
        if (n < N_SWITCH) te[n] = r.last;
        n++;
        if (event_mode) { /* the state before the switch: the mode of the last interval */
            fmi3Boolean values_changed = fmi3False, terminate = fmi3True;
            const double m_before = getf3(c, VR_M);
            CHECK(m_before == (n % 2 == 1 ? 0.0 : (n == 2 ? 1.0 : -1.0)));
            CHECK3_STATUS(fmi3EnterEventMode(c), fmi3OK);
            CHECK3_STATUS(fmi3UpdateDiscreteStates(c, NULL, &terminate, NULL, &values_changed,
                                                   NULL, NULL), fmi3OK);
            CHECK(values_changed && !terminate);
            CHECK3_STATUS(fmi3EnterStepMode(c), fmi3OK);
        }
        /* after the switch: breaking away forwards, sticking, backwards, sticking */
        CHECK(getf3(c, VR_M) == (n % 2 == 0 ? 0.0 : (n == 1 ? 1.0 : -1.0)));
        CHECK(getf3(c, VR_V) == 0.0);
        t = r.last;
    }
    CHECK(t == T_END);
    CHECK3_STATUS(fmi3GetFloat64(c, vr, 3, x_end, 3), fmi3OK);
    CHECK3_STATUS(fmi3Terminate(c), fmi3OK);
    fmi3FreeInstance(c);
    return n;
}

static void test_early_return(void) {
    const double tb1 = asin(L * BREAK / F0), tb2 = 3.14159265358979323846 + tb1;
    const double ts1 = v_zero(1.0, tb1, tb1 + 1e-3, tb1 + 3.0);
    const double ts2 = v_zero(-1.0, tb2, tb2 + 1e-3, tb2 + 3.0);
    double te[N_SWITCH], te_em[N_SWITCH], x[3], x_em[3], tb1_fmi2, t = 0.0;
    fmi2Component c2 = start2();
    int n, n_em, k;
    /* FMI 2.0's first switch, located in its step [0.9, 1.0] (communication points as
     * run_early's: t += 0.1) */
    log_clear();
    for (k = 0; k < 10; k++, t += 0.1) CHECK_STATUS(fmi2DoStep(c2, t, 0.1, fmi2True), fmi2OK);
    tb1_fmi2 = first_slip();
    fmi2FreeInstance(c2);
    n = run_early(0, te, x);
    n_em = run_early(1, te_em, x_em);
    CHECK(n == 4 && n_em == 4);
    if (n != 4 || n_em != 4) return;
    CHECK(te[0] == tb1_fmi2);
    CHECK_NEAR(te[0], tb1, 1e-9);
    CHECK_NEAR(te[1], ts1, 1e-9);
    CHECK_NEAR(te[2], tb2, 1e-9);
    CHECK_NEAR(te[3], ts2, 1e-9);
    /* the master's Event Mode applies exactly what the step would have */
    CHECK(memcmp(te, te_em, 4 * sizeof(double)) == 0);
    CHECK(memcmp(x, x_em, sizeof(x)) == 0);
}

/* a step while the switch awaits the master's Event Mode is refused */
static void test_event_pending_refused(void) {
    fmi3Instance c = start3(1, 1);
    h_step3 r = dostep3(c, 0.0, 1.0); /* breaks away at tb1 = 0.985 */
    CHECK3_STATUS(r.status, fmi3OK);
    CHECK(r.early && r.event_handling);
    EXPECT3_ERROR(fmi3EnterEventMode(c) == fmi3OK ? fmi3EnterStepMode(c) : fmi3Fatal,
                  "fmi3EnterStepMode: the event at t=");
    fmi3FreeInstance(c);
    c = start3(1, 1);
    r = dostep3(c, 0.0, 1.0);
    EXPECT3_ERROR(dostep3(c, r.last, 0.1).status, "fmi3DoStep: the step returned early at an "
                                                  "event at t=");
    CHECK_LOG("enter Event Mode first");
    fmi3FreeInstance(c);
}

int main(void) {
    test_without_early_return(0);
    test_without_early_return(1);
    test_early_return();
    test_event_pending_refused();
    return h_finish("test_fmi3_stickslip");
}
