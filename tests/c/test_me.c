/*
 * test_me.c -- drives the runtime as a Model Exchange importer, linked statically with
 * toy_me.c (forced Duffing oscillator with a local state, TERMINATE event "hit", WARN event
 * "slow", exact `dir`).  Covers the ME state machine, an RK4 outer loop with importer-side
 * event location, state/derivative variables, lazy outputs, FMU states in ME, and the error
 * paths with their reasons.  Directional derivatives: test_me_dirder.c.
 */
#include "harness.h"
#include "me_importer.h"

/* ---- an explicit RK4 importer ------------------------------------------------------ */

static void deriv(fmi2Component c, double t, const double *x, double *dx) {
    CHECK_STATUS(fmi2SetTime(c, t), fmi2OK);
    CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK);
    CHECK_STATUS(fmi2GetDerivatives(c, dx, NX), fmi2OK);
}

static void rk4(fmi2Component c, double t, const double *x, double h, double *out) {
    double k1[NX], k2[NX], k3[NX], k4[NX], xt[NX];
    int i;
    deriv(c, t, x, k1);
    for (i = 0; i < NX; i++) xt[i] = x[i] + 0.5 * h * k1[i];
    deriv(c, t + 0.5 * h, xt, k2);
    for (i = 0; i < NX; i++) xt[i] = x[i] + 0.5 * h * k2[i];
    deriv(c, t + 0.5 * h, xt, k3);
    for (i = 0; i < NX; i++) xt[i] = x[i] + h * k3[i];
    deriv(c, t + h, xt, k4);
    for (i = 0; i < NX; i++) out[i] = x[i] + h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
}

static void indicators(fmi2Component c, double t, const double *x, double *e) {
    CHECK_STATUS(fmi2SetTime(c, t), fmi2OK);
    CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK);
    CHECK_STATUS(fmi2GetEventIndicators(c, e, NE), fmi2OK);
}

typedef struct {
    double t_slow, t_hit; /* event times found (NAN: none) */
    double x_hit[NX];
    int n_warn_events;
    int terminated;
} run_result;

/* Integrate in CT mode from t = 0 with RK4 step h until terminateSimulation or t_end.
 * A sign change of an indicator from > 0 to <= 0 is located by bisection on the RK4
 * step length (to 1e-13); the importer then sets the right end (indicator <= 0) and
 * goes through Event Mode. */
static run_result simulate(fmi2Component c, double h, double t_end) {
    run_result res;
    double t = 0.0, x[NX], xn[NX], e[NE], en[NE];
    int i, steps = 0;
    res.t_slow = res.t_hit = NAN;
    res.n_warn_events = 0;
    res.terminated = 0;
    CHECK_STATUS(fmi2GetContinuousStates(c, x, NX), fmi2OK);
    indicators(c, t, x, e);
    while (t < t_end - 1e-12 && steps < 1000000) {
        int crossed = -1;
        steps++;
        rk4(c, t, x, h, xn);
        indicators(c, t + h, xn, en);
        for (i = 0; i < NE; i++)
            if (e[i] > 0.0 && en[i] <= 0.0) crossed = i;
        if (crossed >= 0) {
            double a = 0.0, b = h, xb[NX], eb[NE];
            fmi2EventInfo ei;
            memcpy(xb, xn, sizeof(xb));
            memcpy(eb, en, sizeof(eb));
            while (b - a > 1e-13) {
                double m = 0.5 * (a + b), xm[NX], em[NE];
                int any = 0;
                rk4(c, t, x, m, xm);
                indicators(c, t + m, xm, em);
                for (i = 0; i < NE; i++)
                    if (e[i] > 0.0 && em[i] <= 0.0) any = 1;
                if (any) {
                    b = m;
                    memcpy(xb, xm, sizeof(xb));
                    memcpy(eb, em, sizeof(eb));
                } else {
                    a = m;
                }
            }
            t += b;
            memcpy(x, xb, sizeof(x));
            CHECK_STATUS(fmi2SetTime(c, t), fmi2OK);
            CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK);
            CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
            CHECK_STATUS(fmi2NewDiscreteStates(c, &ei), fmi2OK);
            CHECK(ei.newDiscreteStatesNeeded == fmi2False);
            if (eb[0] <= 0.0) {
                CHECK(ei.terminateSimulation == fmi2True);
                res.t_hit = t;
                memcpy(res.x_hit, x, sizeof(x));
                res.terminated = 1;
                return res;
            }
            CHECK(ei.terminateSimulation == fmi2False);
            if (eb[1] <= 0.0) {
                res.t_slow = t;
                res.n_warn_events++;
            }
            CHECK_STATUS(fmi2EnterContinuousTimeMode(c), fmi2OK);
            memcpy(e, eb, sizeof(e));
            continue;
        }
        t += h;
        memcpy(x, xn, sizeof(x));
        memcpy(e, en, sizeof(e));
        /* the importer completes the step (not needed, but it must work) */
        {
            fmi2Boolean enter = fmi2True, term = fmi2True;
            CHECK_STATUS(fmi2SetTime(c, t), fmi2OK);
            CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK);
            CHECK_STATUS(fmi2CompletedIntegratorStep(c, fmi2True, &enter, &term), fmi2OK);
            CHECK(enter == fmi2False && term == fmi2False);
        }
    }
    return res;
}

static void test_rk4_importer_with_events(void) {
    /* c = 0, f = 0.3: pos = 0.3 + 0.7 cos t, vel = -0.7 sin t, w = 0.3 (pos - 1)
     * "slow" (vel <= -0.35) at t = pi/6 (WARN), "hit" (pos <= -0.2) at acos(-5/7). */
    setup s = {0.0, 0.3, -0.2, -0.35};
    const double t_slow = asin(0.5), t_hit = acos(-5.0 / 7.0);
    fmi2Component c = me("rk4");
    fmi2FMUstate fs = NULL;
    run_result r;
    double x[NX];
    to_ct_mode(c, &s);
    log_clear();
    r = simulate(c, 1e-3, 10.0);
    CHECK(r.terminated);
    CHECK(r.n_warn_events == 1);
    CHECK_NEAR(r.t_slow, t_slow, 1e-10);
    CHECK_NEAR(r.t_hit, t_hit, 1e-10);
    CHECK_NEAR(r.x_hit[0], -0.2, 1e-12);
    CHECK_NEAR(r.x_hit[1], -0.7 * sin(t_hit), 1e-10);
    CHECK_NEAR(r.x_hit[2], 0.3 * (-0.2 - 1.0), 1e-10);
    CHECK_LOG("warning: event slow at t=");
    CHECK_LOG("event hit at t=");
    CHECK_LOG("terminateSimulation = true");
    /* flags, and the values in Event Mode at the event */
    CHECK(getb(c, VR_HIT) == fmi2True);
    CHECK(getb(c, VR_SLOW) == fmi2True);
    CHECK_NEAR(getr(c, VR_POS), r.x_hit[0], 0.0);
    CHECK_NEAR(getr(c, VR_W), r.x_hit[2], 0.0);
    CHECK(isfinite(getr(c, VR_ENERGY)) && isfinite(getr(c, VR_DVEL)));
    CHECK_NEAR(getr(c, VR_WPOS), r.x_hit[0] * r.x_hit[2], 1e-15);
    /* a second NewDiscreteStates still says terminate, without firing again */
    {
        fmi2EventInfo ei;
        log_clear();
        CHECK_STATUS(fmi2NewDiscreteStates(c, &ei), fmi2OK);
        CHECK(ei.terminateSimulation == fmi2True);
        CHECK_NO_LOG("event hit at t=");
    }
    /* OMSimulator and the FMU Compliance Checker enter Continuous-Time Mode once more before
     * they look at terminateSimulation: accepted, the instance stays terminated */
    CHECK_STATUS(fmi2EnterContinuousTimeMode(c), fmi2OK);
    {
        fmi2Boolean enter = fmi2True, term = fmi2False;
        CHECK_STATUS(fmi2CompletedIntegratorStep(c, fmi2True, &enter, &term), fmi2OK);
        CHECK(!enter && term);
    }
    CHECK(!isnan(getr(c, VR_ENERGY)));
    CHECK_STATUS(fmi2Terminate(c), fmi2OK);
    CHECK_STATUS(fmi2Reset(c), fmi2OK);

    /* again, with an FMU state taken in CT mode just before the WARN event */
    to_ct_mode(c, &s);
    CHECK_STATUS(fmi2GetFMUstate(c, &fs), fmi2OK);
    r = simulate(c, 1e-3, 0.4);
    CHECK(!r.terminated && r.n_warn_events == 0);
    CHECK_STATUS(fmi2GetContinuousStates(c, x, NX), fmi2OK);
    CHECK_NEAR(x[0], 0.3 + 0.7 * cos(0.4), 1e-11);
    CHECK_NEAR(x[2], 0.3 * (x[0] - 1.0), 1e-11);
    CHECK_STATUS(fmi2SetFMUstate(c, fs), fmi2OK); /* back to t = 0, CT mode */
    CHECK_STATUS(fmi2GetContinuousStates(c, x, NX), fmi2OK);
    CHECK(x[0] == 1.0 && x[1] == 0.0 && x[2] == 0.0);
    CHECK(getb(c, VR_SLOW) == fmi2False);
    r = simulate(c, 1e-3, 10.0);
    CHECK(r.terminated && r.n_warn_events == 1);
    CHECK_NEAR(r.t_hit, t_hit, 1e-10);
    /* serialised round trip of the CT-mode state */
    {
        size_t size = 0;
        fmi2Byte *bytes;
        fmi2FMUstate fs2 = NULL;
        CHECK_STATUS(fmi2SerializedFMUstateSize(c, fs, &size), fmi2OK);
        bytes = (fmi2Byte *)malloc(size);
        CHECK_STATUS(fmi2SerializeFMUstate(c, fs, bytes, size), fmi2OK);
        CHECK_STATUS(fmi2DeSerializeFMUstate(c, bytes, size, &fs2), fmi2OK);
        CHECK_STATUS(fmi2SetFMUstate(c, fs2), fmi2OK);
        CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK); /* CT mode again */
        CHECK_STATUS(fmi2FreeFMUstate(c, &fs2), fmi2OK);
        free(bytes);
    }
    CHECK_STATUS(fmi2FreeFMUstate(c, &fs), fmi2OK);
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
    CHECK_STATUS(fmi2Terminate(c), fmi2OK);
    CHECK(!isnan(getr(c, VR_ENERGY))); /* readable after Terminate */
    fmi2FreeInstance(c);
}

/* ---- variables in Model Exchange ---------------------------------------------------- */

static void test_variables(void) {
    setup s = {0.5, 0.2, -0.5, -10.0};
    fmi2Component c = me("vars");
    double x[NX], dx[NX], nom[NX], v[3], e[NE];
    fmi2ValueReference dvr[3] = {VR_DPOS, VR_DVEL, VR_DW};
    fmi2ValueReference svr[3] = {VR_POS, VR_VEL, VR_W};
    /* nominals already in Instantiated */
    CHECK_STATUS(fmi2GetNominalsOfContinuousStates(c, nom, NX), fmi2OK);
    CHECK(nom[0] == 1.0 && nom[1] == 2.0 && nom[2] == 0.5);
    configure(c, &s);
    CHECK_STATUS(setr(c, VR_POS, 0.8), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    /* Initialization Mode: x = init(s, p) */
    CHECK_STATUS(fmi2GetContinuousStates(c, x, NX), fmi2OK);
    CHECK(x[0] == 0.8 && x[1] == 0.0 && x[2] == 0.0);
    CHECK_STATUS(fmi2GetDerivatives(c, dx, NX), fmi2OK);
    CHECK_NEAR(dx[1], -0.8 - 0.5 * 0.8 * 0.8 * 0.8 + 0.2, 1e-15);
    CHECK_STATUS(fmi2GetReal(c, dvr, 3, v), fmi2OK);
    CHECK(v[0] == dx[0] && v[1] == dx[1] && v[2] == dx[2]);
    CHECK_STATUS(fmi2GetEventIndicators(c, e, NE), fmi2OK);
    CHECK_NEAR(e[0], 1.3, 1e-15);
    CHECK_NEAR(getr(c, VR_W), 0.0, 0.0);
    CHECK_NEAR(getr(c, VR_POS), 0.8, 0.0); /* the start value */
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    /* Event Mode: start variables now read the outputs (= the states) */
    CHECK_NEAR(getr(c, VR_POS), 0.8, 0.0);
    CHECK_STATUS(fmi2EnterContinuousTimeMode(c), fmi2OK);
    CHECK_STATUS(fmi2GetNominalsOfContinuousStates(c, nom, NX), fmi2OK);
    CHECK(nom[0] == 1.0 && nom[1] == 2.0 && nom[2] == 0.5);

    /* lazily recomputed outputs and derivatives after each change of t, x, u */
    x[0] = 0.3;
    x[1] = -0.4;
    x[2] = 0.25;
    CHECK_STATUS(fmi2SetTime(c, 0.7), fmi2OK);
    CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK);
    CHECK_STATUS(fmi2GetReal(c, svr, 3, v), fmi2OK);
    CHECK(v[0] == 0.3 && v[1] == -0.4 && v[2] == 0.25);
    CHECK_NEAR(getr(c, VR_ENERGY), 0.5 * 0.16 + 0.5 * 0.09 + 0.125 * 0.0081, 1e-15);
    CHECK_NEAR(getr(c, VR_WPOS), 0.075, 1e-15);
    CHECK_STATUS(fmi2GetReal(c, dvr, 3, v), fmi2OK);
    CHECK_NEAR(v[0], -0.4, 0.0);
    CHECK_NEAR(v[1], -0.3 - 0.5 * 0.027 + 0.2, 1e-15);
    CHECK_NEAR(v[2], 0.2 * -0.4, 1e-15);
    CHECK_STATUS(setr(c, VR_F, 1.0), fmi2OK); /* inputs may change in CT mode */
    CHECK_NEAR(getr(c, VR_DVEL), -0.3 - 0.5 * 0.027 + 1.0, 1e-15);
    CHECK_NEAR(getr(c, VR_FORCE), 1.0, 0.0);
    CHECK_STATUS(fmi2GetDerivatives(c, dx, NX), fmi2OK);
    CHECK_NEAR(dx[2], -0.4, 1e-15);
    x[2] = 2.0;
    CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK);
    CHECK_NEAR(getr(c, VR_WPOS), 0.6, 1e-15);
    CHECK_NEAR(getr(c, VR_W), 2.0, 0.0);

    /* a tunable parameter: not in CT mode, but in Event Mode */
    EXPECT_ERROR(setr(c, VR_C, 1.0), "c (vr=1) cannot be set in state ContinuousTimeMode");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK); /* legal in Event Mode too */
    CHECK_STATUS(setr(c, VR_C, 1.0), fmi2OK);
    CHECK_NEAR(getr(c, VR_DVEL), -1.0 - 1.0 + 0.2, 1e-15);
    EXPECT_ERROR(setr(c, VR_K, 2.0), "k (vr=0) cannot be set in state EventMode");
    fmi2FreeInstance(c);
}

/* ---- error paths ------------------------------------------------------------------- */

static void test_errors(void) {
    setup s = {0.5, 0.0, -0.5, -10.0};
    fmi2Component c = me("err"), d;
    double x[NX] = {0.1, 0.2, 0.3}, r[4], seed[2] = {1.0, 1.0};
    fmi2EventInfo ei;
    fmi2Boolean b1, b2;
    fmi2Status st;
    fmi2ValueReference vr;
    fmi2FMUstate fs = NULL;

    /* illegal calls in each state (Reference-FMUs masks) */
    EXPECT_ERROR(fmi2GetDerivatives(c, r, NX), "fmi2GetDerivatives: illegal call in state Instantiated");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    EXPECT_ERROR(fmi2SetTime(c, 1.0), "fmi2SetTime: illegal call in state Instantiated");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    EXPECT_ERROR(fmi2EnterEventMode(c), "illegal call in state InitializationMode");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2NewDiscreteStates(c, &ei), "illegal call in state ContinuousTimeMode");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2EnterContinuousTimeMode(c), "illegal call in state ContinuousTimeMode");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
    EXPECT_ERROR(fmi2SetContinuousStates(c, x, NX), "fmi2SetContinuousStates: illegal call in state EventMode");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
    EXPECT_ERROR(fmi2CompletedIntegratorStep(c, fmi2True, &b1, &b2), "illegal call in state EventMode");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2ExitInitializationMode(c), "illegal call in state ContinuousTimeMode");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    CHECK_STATUS(fmi2Terminate(c), fmi2OK); /* from CT mode */
    EXPECT_ERROR(fmi2SetTime(c, 1.0), "illegal call in state Terminated");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);

    /* Co-Simulation functions in an ME instance */
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2DoStep(c, 0.0, 0.1, fmi2True), "fmi2DoStep: Co-Simulation function");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    EXPECT_ERROR(fmi2GetBooleanStatus(c, fmi2Terminated, &b1), "fmi2GetBooleanStatus: Co-Simulation function");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    EXPECT_ERROR(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, r), "Co-Simulation function");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    EXPECT_ERROR(fmi2GetStatus(c, fmi2DoStepStatus, &st), "Co-Simulation function");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    EXPECT_ERROR(fmi2CancelStep(c), "Co-Simulation function");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);

    /* bad arguments */
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2SetContinuousStates(c, x, 2), "nx = 2, the model has 3 continuous states");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2GetDerivatives(c, r, 4), "fmi2GetDerivatives: nx = 4");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2GetContinuousStates(c, NULL, NX), "fmi2GetContinuousStates: array is NULL");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2GetEventIndicators(c, r, 1), "ni = 1, the model has 2 event indicators");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2GetNominalsOfContinuousStates(c, r, 1), "nx = 1");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2SetTime(c, NAN), "fmi2SetTime: time nan is not finite");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    x[1] = INFINITY;
    EXPECT_ERROR(fmi2SetContinuousStates(c, x, NX), "state vel = inf is not finite");
    x[1] = 0.2;
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2NewDiscreteStates(c, NULL), "illegal call in state ContinuousTimeMode");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    CHECK_STATUS(fmi2EnterEventMode(c), fmi2OK);
    EXPECT_ERROR(fmi2NewDiscreteStates(c, NULL), "eventInfo is NULL");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2CompletedIntegratorStep(c, fmi2True, NULL, &b2), "is NULL");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);

    /* state and derivative variables are not settable */
    to_ct_mode(c, &s);
    EXPECT_ERROR(setr(c, VR_W, 1.0), "w (vr=12) is a continuous state and cannot be set (use fmi2SetContinuousStates)");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    EXPECT_ERROR(setr(c, VR_DVEL, 1.0), "der(vel) (vr=61) is a state derivative and cannot be set");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);

    /* directional derivatives: wrong kinds are named */
    to_ct_mode(c, &s);
    vr = VR_K;
    EXPECT_ERROR(fmi2GetDirectionalDerivative(c, &vr, 1, KNOWN, 1, seed, r),
                 "k (vr=0) is not an unknown (a Real output, continuous state or state derivative)");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    vr = VR_HIT;
    EXPECT_ERROR(fmi2GetDirectionalDerivative(c, &vr, 1, KNOWN, 1, seed, r), "hit (vr=50) is not an unknown");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    vr = VR_ENERGY;
    EXPECT_ERROR(fmi2GetDirectionalDerivative(c, UNK, 1, &vr, 1, seed, r),
                 "known energy (vr=20) is not a continuous state or a Real input");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    vr = VR_DPOS;
    EXPECT_ERROR(fmi2GetDirectionalDerivative(c, UNK, 1, &vr, 1, seed, r), "known der(pos) (vr=60)");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    vr = VR_C;
    EXPECT_ERROR(fmi2GetDirectionalDerivative(c, UNK, 1, &vr, 1, seed, r), "known c (vr=1)");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    vr = 999;
    EXPECT_ERROR(fmi2GetDirectionalDerivative(c, UNK, 1, &vr, 1, seed, r), "unknown value reference 999");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    to_ct_mode(c, &s);
    EXPECT_ERROR(fmi2GetDirectionalDerivative(c, UNK, 1, KNOWN, 1, NULL, r), "NULL array for 1 knowns");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);

    /* non-finite derivatives: fmi2Discard with a reason, the array untouched */
    to_ct_mode(c, &s);
    x[0] = 1e200;
    CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK);
    r[0] = r[1] = r[2] = 42.0;
    log_clear();
    CHECK_STATUS(fmi2GetDerivatives(c, r, NX), fmi2Discard);
    CHECK_LOG("derivative of state vel is not finite");
    CHECK(r[0] == 42.0 && r[1] == 42.0 && r[2] == 42.0);
    x[0] = 0.1;
    CHECK_STATUS(fmi2SetContinuousStates(c, x, NX), fmi2OK); /* usable after Discard */
    CHECK_STATUS(fmi2GetDerivatives(c, r, NX), fmi2OK);
    CHECK(isfinite(r[1]));

    /* FMU states of the other interface are refused */
    d = fmi2Instantiate("cs", fmi2CoSimulation, TOKEN, "", &h_callbacks, fmi2False, fmi2False);
    configure(d, &s);
    CHECK_STATUS(fmi2EnterInitializationMode(d), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(d), fmi2OK);
    CHECK_STATUS(fmi2GetFMUstate(d, &fs), fmi2OK);
    EXPECT_ERROR(fmi2SetFMUstate(c, fs),
                 "FMU state of a Co-Simulation instance cannot be set into a Model Exchange instance");
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    CHECK_STATUS(fmi2FreeFMUstate(d, &fs), fmi2OK);
    to_ct_mode(c, &s);
    CHECK_STATUS(fmi2GetFMUstate(c, &fs), fmi2OK);
    EXPECT_ERROR(fmi2SetFMUstate(d, fs),
                 "FMU state of a Model Exchange instance cannot be set into a Co-Simulation instance");
    CHECK_STATUS(fmi2FreeFMUstate(c, &fs), fmi2OK);
    fmi2FreeInstance(d);

    /* an initial state that already triggers the terminating event */
    CHECK_STATUS(fmi2Reset(c), fmi2OK);
    s.pos_lim = 2.0;
    configure(c, &s);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    EXPECT_ERROR(fmi2ExitInitializationMode(c), "already triggers event hit");
    fmi2FreeInstance(c);

    /* instantiation */
    log_clear();
    CHECK(fmi2Instantiate("x", fmi2ModelExchange, "{wrong}", "", &h_callbacks, 0, 0) == NULL);
    CHECK_LOG("does not match");
    CHECK(fmi2Instantiate("", fmi2ModelExchange, TOKEN, "", &h_callbacks, 0, 0) == NULL);
    CHECK_LOG("missing instance name");
    {
        int k, ok = 0;
        for (k = 0; k < 200 && !ok; k++) { /* every allocation failing in turn */
            h_fail_after = k;
            c = fmi2Instantiate("oom", fmi2ModelExchange, TOKEN, "", &h_callbacks, 0, 0);
            h_fail_after = -1;
            if (c) {
                ok = 1;
                fmi2FreeInstance(c);
            } else {
                CHECK(h_live == 0);
            }
        }
        CHECK(ok);
    }
}

int main(void) {
    test_rk4_importer_with_events();
    test_variables();
    test_errors();
    return h_finish("test_me");
}
