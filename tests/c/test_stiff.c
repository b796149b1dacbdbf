/*
 * test_stiff.c -- the Rosenbrock (RODAS4) and DOP853 solvers of the runtime on the
 * stiff linear toy model (toy_stiff.c, exact solution known), like an importer.
 */
#include "harness.h"
#include "solver_counts.h"

#define TOKEN "{st1ff-0000-0000-0000-000000000004}"

enum { VR_KSLOW = 0, VR_KFAST = 1, VR_W = 2, VR_YLIM = 3, VR_TNAN = 4, VR_Y1 = 10, VR_Y2 = 11,
       VR_SOLVER = 40, VR_REL_TOL = 41, VR_ABS_TOL = 42, VR_MAX_STEP = 43, VR_LOW = 50 };
enum { EULER = 1, RK4 = 2, DOPRI5 = 3, ROSENBROCK = 4, DOP853 = 5 };

typedef struct {
    double k_slow, k_fast, w, y_lim, t_nan;
} params;
static const params DEFAULTS = {1.0, 1e5, 0.0, -10.0, 1e300};

static double last_time(fmi2Component c) {
    double t = NAN;
    CHECK_STATUS(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t), fmi2OK);
    return t;
}

/* exact solution from y(0) = (2, 0) */
static void exact(const params *p, double t, double y[2]) {
    const double l = -p->k_slow, Q = -p->w / (1.0 + l * l), P = l * Q;
    const double z1 = (1.0 - Q) * exp(l * t) + P * sin(t) + Q * cos(t);
    const double z2 = exp(-p->k_fast * t);
    y[0] = z1 + z2;
    y[1] = z1 - z2;
}

static fmi2Component start(const char *name, int solver, double rtol, double atol,
                           double max_step, const params *p) {
    fmi2Component c =
        fmi2Instantiate(name, fmi2CoSimulation, TOKEN, "", &h_callbacks, fmi2False, fmi2False);
    CHECK(c != NULL);
    CHECK_STATUS(seti(c, VR_SOLVER, solver), fmi2OK);
    CHECK_STATUS(setr(c, VR_REL_TOL, rtol), fmi2OK);
    CHECK_STATUS(setr(c, VR_ABS_TOL, atol), fmi2OK);
    CHECK_STATUS(setr(c, VR_MAX_STEP, max_step), fmi2OK);
    CHECK_STATUS(setr(c, VR_KSLOW, p->k_slow), fmi2OK);
    CHECK_STATUS(setr(c, VR_KFAST, p->k_fast), fmi2OK);
    CHECK_STATUS(setr(c, VR_W, p->w), fmi2OK);
    CHECK_STATUS(setr(c, VR_YLIM, p->y_lim), fmi2OK);
    CHECK_STATUS(setr(c, VR_TNAN, p->t_nan), fmi2OK);
    CHECK_STATUS(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    CHECK_STATUS(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK_STATUS(fmi2ExitInitializationMode(c), fmi2OK);
    log_solver_on(c);
    return c;
}

/* Communication points: a few inside the fast transient, then every H up to t_end.
 * Returns the largest error against the exact solution, relative to max(1, |y|). */
static double run(fmi2Component c, const params *p, double H, double t_end, counts *n) {
    static const double early[] = {1e-6, 1e-5, 3e-5, 1e-4};
    double t = 0.0, err = 0.0, y[2];
    long allocs = h_total;
    size_t i;
    int k;
    for (i = 0; i <= sizeof(early) / sizeof(early[0]); i++) {
        const double t1 = i < sizeof(early) / sizeof(early[0]) ? early[i] : H;
        const double h = t1 - t;
        CHECK_STATUS(counted_step(c, t, h, n), fmi2OK);
        t = t + h; /* the FMU's time: lands exactly on currentCommunicationPoint + h */
        CHECK(last_time(c) == t);
        exact(p, t, y);
        for (k = 0; k < 2; k++) {
            double e = fabs(getr(c, (fmi2ValueReference)(VR_Y1 + k)) - y[k]) /
                       (fabs(y[k]) > 1.0 ? fabs(y[k]) : 1.0);
            if (!(e <= err)) err = e;
        }
    }
    for (k = 2; t < t_end - 1e-9; k++) {
        const double h = k * H - t;
        CHECK_STATUS(counted_step(c, t, h, n), fmi2OK);
        t = t + h;
        CHECK(last_time(c) == t); /* lands exactly on every communication point */
        exact(p, t, y);
        for (i = 0; i < 2; i++) {
            double e = fabs(getr(c, (fmi2ValueReference)(VR_Y1 + i)) - y[i]) /
                       (fabs(y[i]) > 1.0 ? fabs(y[i]) : 1.0);
            if (!(e <= err)) err = e;
        }
    }
    CHECK(h_total == allocs); /* fmi2DoStep never allocates */
    return err;
}

/* Rosenbrock reaches the requested accuracy; the error falls with the tolerance. */
static void test_accuracy(void) {
    const double tols[] = {1e-3, 1e-5, 1e-7, 1e-9};
    double errs[4];
    int i, w;
    for (w = 0; w < 2; w++) {
        params p = DEFAULTS;
        p.w = w ? 3.0 : 0.0; /* with forcing: non-autonomous, needs d f / d t */
        for (i = 0; i < 4; i++) {
            counts n = {0};
            fmi2Component c = start("acc", ROSENBROCK, tols[i], tols[i] * 1e-2, 10.0, &p);
            errs[i] = run(c, &p, 0.5, 10.0, &n);
            fprintf(stderr, "ROSENBROCK w=%g rtol=%g: max error %.3g, ", p.w, tols[i], errs[i]);
            counts_print("", &n);
            CHECK(errs[i] < 30.0 * tols[i]);
            CHECK(n.analytic_jacobian && !n.fd_jacobian);
            CHECK(n.jac <= n.accepted + n.dosteps); /* one Jacobian per step */
            CHECK(n.jac >= n.accepted);
            CHECK(n.lu >= n.jac && n.lu <= n.jac + n.rejected);
            if (i > 0) CHECK(errs[i] < 0.2 * errs[i - 1]);
            fmi2FreeInstance(c);
        }
    }
}

/* On the stiff problem Rosenbrock needs a tiny fraction of DOPRI5's work. */
static void test_stiff_work(void) {
    const params p = DEFAULTS;
    counts nr = {0}, nd = {0}, n8 = {0};
    double er, ed, e8;
    fmi2Component c = start("ros", ROSENBROCK, 1e-6, 1e-8, 10.0, &p);
    er = run(c, &p, 0.5, 2.0, &nr);
    fmi2FreeInstance(c);
    c = start("dopri5", DOPRI5, 1e-6, 1e-8, 10.0, &p);
    ed = run(c, &p, 0.5, 2.0, &nd);
    fmi2FreeInstance(c);
    c = start("dop853", DOP853, 1e-6, 1e-8, 10.0, &p);
    e8 = run(c, &p, 0.5, 2.0, &n8);
    fmi2FreeInstance(c);
    fprintf(stderr, "STIFF [0, 2] rtol=1e-6 errors: rosenbrock %.3g dopri5 %.3g dop853 %.3g\n", er, ed,
            e8);
    counts_print("stiff rosenbrock", &nr);
    counts_print("stiff dopri5", &nd);
    counts_print("stiff dop853", &n8);
    CHECK(er < 3e-5);
    CHECK(ed < 3e-5);
    CHECK(e8 < 3e-5);
    CHECK(100 * (nr.accepted + nr.rejected) < nd.accepted + nd.rejected);
    CHECK(50 * (nr.rhs + nr.jac) < nd.rhs);
}

/* Fixed steps (huge tolerances, max_step = h): the global error of RODAS4 falls like
 * h^4 on the non-stiff, non-autonomous variant (exercises the d f / d t terms). */
static void test_order(void) {
    params p = DEFAULTS;
    double err[2];
    int i;
    p.k_fast = 3.0;
    p.w = 2.0;
    for (i = 0; i < 2; i++) {
        const double h = i ? 0.1 : 0.2;
        fmi2Component c = start("order", ROSENBROCK, 1.0, 1.0, h, &p);
        err[i] = run(c, &p, 0.4, 8.0, NULL);
        fmi2FreeInstance(c);
    }
    fprintf(stderr, "ROSENBROCK fixed h=0.2: %.3g, h=0.1: %.3g, ratio %.2f (4th order: 16)\n",
            err[0], err[1], err[0] / err[1]);
    CHECK(err[0] / err[1] > 11.0 && err[0] / err[1] < 24.0);
}

/* TERMINATE event: y1 = e^-t + e^-k_fast t crosses y_lim = 0.5 at t = ln 2. */
static void test_event(int solver, double rtol, double H, double tol) {
    params p = DEFAULTS;
    fmi2Component c;
    double t = 0.0;
    fmi2Status st = fmi2OK;
    fmi2Boolean term = fmi2False;
    fmi2ValueReference vr = VR_LOW;
    int i;
    p.y_lim = 0.5;
    c = start("event", solver, rtol, rtol * 1e-2, 10.0, &p);
    for (i = 0; i < 1000; i++) {
        st = fmi2DoStep(c, t, H, fmi2True);
        if (st != fmi2OK) break;
        t += H;
    }
    CHECK(st == fmi2Discard);
    CHECK_STATUS(fmi2GetBooleanStatus(c, fmi2Terminated, &term), fmi2OK);
    CHECK(term == fmi2True);
    CHECK_STATUS(fmi2GetBoolean(c, &vr, 1, &term), fmi2OK);
    CHECK(term == fmi2True);
    fprintf(stderr, "EVENT solver %d rtol %g H %g: t_event - ln 2 = %.3g\n", solver, rtol, H,
            last_time(c) - log(2.0));
    CHECK_NEAR(last_time(c), log(2.0), tol);
    CHECK_NEAR(getr(c, VR_Y1), 0.5, tol);
    CHECK(getr(c, VR_Y1) <= 0.5);
    fmi2FreeInstance(c);
}

/* fmi2Get/SetFMUstate: stepping on from a restored state is bitwise the same. */
static void test_state(int solver) {
    const params p = DEFAULTS;
    fmi2Component c = start("state", solver, 1e-6, 1e-8, 10.0, &p);
    fmi2FMUstate s = NULL;
    double y1, y2;
    int i;
    for (i = 0; i < 5; i++) CHECK_STATUS(fmi2DoStep(c, i * 1e-4, 1e-4, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2GetFMUstate(c, &s), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 5e-4, 0.3, fmi2True), fmi2OK);
    y1 = getr(c, VR_Y1);
    y2 = getr(c, VR_Y2);
    CHECK_STATUS(fmi2DoStep(c, 5e-4 + 0.3, 0.3, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2SetFMUstate(c, s), fmi2OK);
    CHECK(last_time(c) == 5e-4);
    CHECK_STATUS(fmi2DoStep(c, 5e-4, 0.3, fmi2True), fmi2OK);
    CHECK(getr(c, VR_Y1) == y1);
    CHECK(getr(c, VR_Y2) == y2);
    CHECK_STATUS(fmi2FreeFMUstate(c, &s), fmi2OK);
    fmi2FreeInstance(c);
}

/* max_step bounds the internal steps; the step size is carried between fmi2DoStep
 * calls (many small communication steps cost few extra internal steps). */
static void test_max_step_and_carry(void) {
    const params p = DEFAULTS;
    counts a = {0}, b = {0}, m = {0};
    fmi2Component c = start("carry", ROSENBROCK, 1e-6, 1e-8, 10.0, &p);
    int i;
    CHECK_STATUS(counted_step(c, 0.0, 10.0, &a), fmi2OK);
    CHECK(last_time(c) == 10.0);
    fmi2FreeInstance(c);
    c = start("carry", ROSENBROCK, 1e-6, 1e-8, 10.0, &p);
    for (i = 0; i < 100; i++) CHECK_STATUS(counted_step(c, i * 0.1, 0.1, &b), fmi2OK);
    fmi2FreeInstance(c);
    c = start("max_step", ROSENBROCK, 1e-6, 1e-8, 0.01, &p);
    CHECK_STATUS(counted_step(c, 0.0, 2.0, &m), fmi2OK);
    CHECK(last_time(c) == 2.0);
    fmi2FreeInstance(c);
    fprintf(stderr, "CARRY one step: %llu accepted, 100 steps: %llu; max_step 0.01 over 2: %llu\n",
            a.accepted, b.accepted, m.accepted);
    CHECK(b.accepted <= a.accepted + 100);
    CHECK(m.accepted >= 200);
}

/* a right-hand side that turns NaN: rejected steps shrink to the underflow error */
static void test_underflow(int solver) {
    params p = DEFAULTS;
    fmi2Component c;
    p.t_nan = 1.0;
    c = start("nan", solver, 1e-6, 1e-8, 10.0, &p);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.5, fmi2True), fmi2OK);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.5, 1.0, fmi2True), fmi2Error);
    CHECK_LOG("step size underflow at t=");
    CHECK_NEAR(getr(c, VR_Y1), exp(-0.5), 1e-4); /* back at the start of the step */
    fmi2FreeInstance(c);
}

/* Euler and RK4 at their stability limits on the real axis (|1 + h lambda| <= 1: h |lambda| <= 2;
 * RK4's polynomial: <= 2.785), lambda = -k_fast = -100 the fastest mode: a step inside runs to the
 * end; a step beyond is refused at once with fmi2Error and the reason, its h |lambda| named */
static void test_fixed_step_stability(int solver, double h_lambda, int stable) {
    params p = DEFAULTS;
    fmi2Component c;
    p.k_fast = 100.0;
    c = start("limit", solver, 1e-6, 1e-8, h_lambda / p.k_fast, &p);
    log_clear();
    if (stable) {
        double y[2];
        CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2OK);
        exact(&p, 1.0, y);
        CHECK(isfinite(getr(c, VR_Y1)) && fabs(getr(c, VR_Y1) - y[0]) < 0.05);
        CHECK_NO_LOG("unstable");
    } else {
        char said[80];
        CHECK_STATUS(fmi2DoStep(c, 0.0, 1.0, fmi2True), fmi2Error);
        snprintf(said, sizeof said, "%s is unstable at t=0 ", solver == EULER ? "euler" : "rk4");
        CHECK_LOG(said);
        /* the estimate along the step, h (k_slow^2 + k_fast^2) / (k_slow + k_fast) for Euler:
         * the step is max_step or a little shorter (the grid), so the units digit is checked */
        snprintf(said, sizeof said, "h |lambda| ~ %d.", (int)h_lambda);
        CHECK_LOG(said);
        CHECK_LOG(solver == EULER ? "(stable up to 2)" : "(stable up to 2.8)");
        /* the grid's step (1 s in equal steps of at most max_step) and max_step as set, apart */
        snprintf(said, sizeof said, "with steps of h=%g (max_step=%g)", 1.0 / ceil(p.k_fast / h_lambda),
                 h_lambda / p.k_fast);
        CHECK_LOG(said);
        CHECK_NEAR(getr(c, VR_Y1), 2.0, 0.0); /* back at the start */
    }
    fmi2FreeInstance(c);
}

/* the instance (with the Rosenbrock work arrays) survives every allocation failure */
static void test_out_of_memory(void) {
    fmi2Component c;
    int k, ok = 0;
    for (k = 0; k < 300; k++) {
        h_fail_after = k;
        c = fmi2Instantiate("oom", fmi2CoSimulation, TOKEN, "", &h_callbacks, 0, 0);
        h_fail_after = -1;
        if (c) {
            ok = 1;
            fmi2FreeInstance(c);
            break;
        }
        CHECK(h_live == 0);
    }
    CHECK(ok);
}

int main(void) {
    test_accuracy();
    test_stiff_work();
    test_order();
    test_event(ROSENBROCK, 1e-10, 0.1, 1e-8);
    test_event(ROSENBROCK, 1e-10, 5.0, 1e-8);
    test_event(DOP853, 1e-12, 0.1, 1e-10);
    test_state(ROSENBROCK);
    test_state(DOP853);
    test_max_step_and_carry();
    test_underflow(ROSENBROCK);
    test_underflow(DOP853);
    test_fixed_step_stability(EULER, 1.9, 1);
    test_fixed_step_stability(EULER, 2.5, 0);
    test_fixed_step_stability(RK4, 2.7, 1);
    test_fixed_step_stability(RK4, 3.2, 0);
    test_out_of_memory();
    return h_finish("test_stiff");
}
