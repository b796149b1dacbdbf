/*
 * test_solvers_osc.c -- DOP853 and Rosenbrock (finite-difference Jacobian: the toy
 * has no jac) on the harmonic oscillator toy (toy_oscillator.c): pos = cos t,
 * vel = -sin t; TERMINATE event "hit" at t = acos(pos_lim).
 */
#include "harness.h"
#include "oscillator_importer.h"
#include "solver_counts.h"

enum { EULER = 1, RK4 = 2, DOPRI5 = 3, ROSENBROCK = 4, DOP853 = 5 };

/* start(), with the logSolver category on: the work counts come from its messages */
static fmi2Component start_counted(const char *name, int solver, double rtol, double atol,
                                   double max_step, double pos_lim) {
    fmi2Component c = start(name, solver, rtol, atol, max_step, pos_lim);
    log_solver_on(c);
    return c;
}

/* [0, t_end] in communication steps H; largest error against cos / -sin */
static double run(fmi2Component c, double H, double t_end, counts *n) {
    double t = 0.0, err = 0.0;
    long allocs = h_total;
    while (t < t_end - 1e-9) {
        double e1, e2;
        CHECK_STATUS(counted_step(c, t, H, n), fmi2OK);
        t += H;
        CHECK(last_time(c) == t);
        e1 = fabs(getr(c, VR_POS) - cos(t));
        e2 = fabs(getr(c, VR_VEL) + sin(t));
        if (e1 > err) err = e1;
        if (e2 > err) err = e2;
    }
    CHECK(h_total == allocs); /* fmi2DoStep never allocates */
    return err;
}

static double solve(int solver, double rtol, double max_step, double H, double t_end,
                    counts *n) {
    fmi2Component c = start_counted("osc", solver, rtol, rtol * 1e-2, max_step, -2.0);
    double err = run(c, H, t_end, n);
    fmi2FreeInstance(c);
    return err;
}

/* DOP853 at tight tolerance: accurate, and far fewer steps than DOPRI5. */
static void test_tight_tolerance(void) {
    counts n8 = {0}, n5 = {0};
    double e8 = solve(DOP853, 1e-12, 1.0, 0.5, 20.0, &n8);
    double e5 = solve(DOPRI5, 1e-12, 1.0, 0.5, 20.0, &n5);
    fprintf(stderr, "TIGHT rtol=1e-12 over [0, 20]: error dop853 %.3g dopri5 %.3g\n", e8, e5);
    counts_print("tight dop853", &n8);
    counts_print("tight dopri5", &n5);
    CHECK(e8 < 1e-10);
    CHECK(e5 < 1e-10);
    CHECK(3 * n8.accepted < n5.accepted);
    CHECK(2 * n8.rhs < n5.rhs);
}

/* 8th order: from rtol 1e-6 to 1e-12 the number of steps grows by about
 * 1e6^(1/8) = 5.6 for DOP853 against 1e6^(1/5) = 16 for DOPRI5. */
static void test_step_growth(void) {
    counts a8 = {0}, b8 = {0}, a5 = {0}, b5 = {0};
    double g8, g5;
    solve(DOP853, 1e-6, 10.0, 10.0, 40.0, &a8);
    solve(DOP853, 1e-12, 10.0, 10.0, 40.0, &b8);
    solve(DOPRI5, 1e-6, 10.0, 10.0, 40.0, &a5);
    solve(DOPRI5, 1e-12, 10.0, 10.0, 40.0, &b5);
    g8 = (double)b8.accepted / (double)a8.accepted;
    g5 = (double)b5.accepted / (double)a5.accepted;
    fprintf(stderr, "GROWTH steps 1e-6 -> 1e-12: dop853 %llu -> %llu (x%.2f), dopri5 %llu -> "
            "%llu (x%.2f)\n", a8.accepted, b8.accepted, g8, a5.accepted, b5.accepted, g5);
    CHECK(g8 > 4.0 && g8 < 8.0);
    CHECK(g5 > 11.0);
}

/* [0, t_end] with every step accepted: the loosest tolerances (rel_tol = abs_tol = 1, the
 * top of their valid range) and max_step = h */
static double solve_fixed(int solver, double h, double H, double t_end) {
    fmi2Component c = start_counted("fixed", solver, 1.0, 1.0, h, -2.0);
    double err = run(c, H, t_end, NULL);
    fmi2FreeInstance(c);
    return err;
}

/* Fixed steps (loosest tolerances, max_step = h): global error ratio for h and h/2 is
 * 2^8 = 256 for DOP853 and 2^4 = 16 for RODAS4 (finite-difference Jacobian). */
static void test_fixed_step_order(void) {
    double e[2], r8, r4;
    e[0] = solve_fixed(DOP853, 1.0, 2.0, 20.0);
    e[1] = solve_fixed(DOP853, 0.5, 2.0, 20.0);
    r8 = e[0] / e[1];
    fprintf(stderr, "ORDER dop853 h=1: %.3g h=0.5: %.3g ratio %.1f (256)\n", e[0], e[1], r8);
    e[0] = solve_fixed(ROSENBROCK, 0.2, 2.0, 20.0);
    e[1] = solve_fixed(ROSENBROCK, 0.1, 2.0, 20.0);
    r4 = e[0] / e[1];
    fprintf(stderr, "ORDER rosenbrock h=0.2: %.3g h=0.1: %.3g ratio %.1f (16)\n", e[0], e[1], r4);
    CHECK(r8 > 150.0 && r8 < 400.0);
    CHECK(r4 > 11.0 && r4 < 24.0);
}

/* Dense output order: with fixed steps the located event time has the error of the
 * continuous extension: about h^7..h^8 for DOP853 (7th-order interpolant), h^4 for
 * RODAS4 (3rd-order interpolant). */
static double event_error(int solver, double h) {
    fmi2Component c = start_counted("dense", solver, 1.0, 1.0, h, 0.5);
    double err;
    CHECK_STATUS(fmi2DoStep(c, 0.0, 2.0, fmi2True), fmi2Discard);
    err = fabs(last_time(c) - PI / 3.0);
    fmi2FreeInstance(c);
    return err;
}

static void test_dense_order(void) {
    double a = event_error(DOP853, 0.8), b = event_error(DOP853, 0.4);
    double c = event_error(ROSENBROCK, 0.2), d = event_error(ROSENBROCK, 0.1);
    fprintf(stderr, "DENSE event time error dop853 h=0.8: %.3g h=0.4: %.3g ratio %.1f; "
            "rosenbrock h=0.2: %.3g h=0.1: %.3g ratio %.1f\n", a, b, a / b, c, d, c / d);
    CHECK(a / b > 60.0);
    CHECK(c / d > 6.0);
}

/* TERMINATE event with the adaptive solvers, at several communication step sizes */
static void run_terminate(int solver, double rtol, double H, double tol) {
    fmi2Component c = start_counted("term", solver, rtol, rtol * 1e-2, 1.0, 0.5);
    const double te = PI / 3.0;
    double t = 0.0;
    fmi2Boolean term = fmi2False;
    fmi2Status st = fmi2OK;
    fmi2ValueReference vr = VR_HIT;
    long allocs = h_total;
    int n = 0;
    while (n++ < 1000) {
        st = fmi2DoStep(c, t, H, fmi2True);
        if (st != fmi2OK) break;
        t += H;
    }
    CHECK(st == fmi2Discard);
    CHECK(h_total == allocs);
    CHECK(t < te && t + H > te);
    CHECK_STATUS(fmi2GetBooleanStatus(c, fmi2Terminated, &term), fmi2OK);
    CHECK(term == fmi2True);
    CHECK_STATUS(fmi2GetBoolean(c, &vr, 1, &term), fmi2OK);
    CHECK(term == fmi2True);
    fprintf(stderr, "EVENT solver %d rtol %g H %g: t_event - pi/3 = %.3g\n", solver, rtol, H,
            last_time(c) - te);
    CHECK_NEAR(last_time(c), te, tol);
    CHECK_NEAR(getr(c, VR_POS), 0.5, tol);
    CHECK(getr(c, VR_POS) <= 0.5);
    CHECK_NEAR(getr(c, VR_VEL), -sin(te), tol);
    fmi2FreeInstance(c);
}

/* the Rosenbrock solver falls back to a finite-difference Jacobian (and says so) */
static void test_fd_jacobian(void) {
    counts n = {0};
    double err = solve(ROSENBROCK, 1e-8, 1.0, 0.5, 10.0, &n);
    fprintf(stderr, "FD JACOBIAN rosenbrock rtol 1e-8: error %.3g, ", err);
    counts_print("", &n);
    CHECK(err < 1e-6);
    CHECK(n.fd_jacobian && !n.analytic_jacobian);
    CHECK(n.jac >= n.accepted && n.jac <= n.accepted + n.dosteps);
    CHECK(n.jac_rhs == 3 * n.jac); /* nx = 2 columns + d f / d t */
}

/* fmi2Get/SetFMUstate and serialisation: continuing from a restored (or deserialised)
 * state is bitwise identical (the solvers keep nothing beyond h_adapt between steps) */
static void test_state(int solver) {
    fmi2Component c = start_counted("state", solver, 1e-9, 1e-11, 1.0, -2.0), d;
    fmi2FMUstate s = NULL, s2 = NULL;
    fmi2Byte *bytes;
    size_t size = 0;
    double p1, v1;
    int i;
    for (i = 0; i < 5; i++) CHECK_STATUS(fmi2DoStep(c, i * 0.1, 0.1, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2GetFMUstate(c, &s), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.5, 0.7, fmi2True), fmi2OK);
    p1 = getr(c, VR_POS);
    v1 = getr(c, VR_VEL);
    CHECK_STATUS(fmi2DoStep(c, 1.2, 0.7, fmi2True), fmi2OK);
    CHECK_STATUS(fmi2SetFMUstate(c, s), fmi2OK);
    CHECK_STATUS(fmi2DoStep(c, 0.5, 0.7, fmi2True), fmi2OK);
    CHECK(getr(c, VR_POS) == p1);
    CHECK(getr(c, VR_VEL) == v1);
    CHECK_STATUS(fmi2SerializedFMUstateSize(c, s, &size), fmi2OK);
    CHECK(size > 44);
    bytes = (fmi2Byte *)malloc(size);
    CHECK_STATUS(fmi2SerializeFMUstate(c, s, bytes, size), fmi2OK);
    d = fmi2Instantiate("state2", fmi2CoSimulation, TOKEN, "", &h_callbacks, 0, 0);
    CHECK_STATUS(fmi2DeSerializeFMUstate(d, bytes, size, &s2), fmi2OK);
    CHECK_STATUS(fmi2SetFMUstate(d, s2), fmi2OK);
    CHECK_STATUS(fmi2DoStep(d, 0.5, 0.7, fmi2True), fmi2OK);
    CHECK(getr(d, VR_POS) == p1);
    CHECK(getr(d, VR_VEL) == v1);
    CHECK_STATUS(fmi2FreeFMUstate(d, &s2), fmi2OK);
    CHECK_STATUS(fmi2FreeFMUstate(c, &s), fmi2OK);
    free(bytes);
    fmi2FreeInstance(c);
    fmi2FreeInstance(d);
}

/* solver values, names in the log, and an unknown one */
static void test_solver_values(void) {
    fmi2Component c = start_counted("names", DOP853, 1e-6, 1e-8, 1.0, -2.0);
    fmi2ValueReference vr = VR_SOLVER;
    fmi2Integer v = 0;
    CHECK_STATUS(fmi2GetInteger(c, &vr, 1, &v), fmi2OK);
    CHECK(v == 5);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2OK);
    CHECK_LOG("solver=dop853 accepted=");
    fmi2FreeInstance(c);
    c = start_counted("names", ROSENBROCK, 1e-6, 1e-8, 1.0, -2.0);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2OK);
    CHECK_LOG("solver=rosenbrock accepted=");
    CHECK_LOG("|logSolver] rosenbrock t=0 -> t=0.10000000000000001 jacobians=");
    fmi2FreeInstance(c);
    c = fmi2Instantiate("names", fmi2CoSimulation, TOKEN, "", &h_callbacks, 0, 0);
    log_clear();
    CHECK_STATUS(seti(c, VR_SOLVER, 8), fmi2Error); /* refused at the call */
    CHECK_LOG("solver = 8 is not a solver");
    fmi2FreeInstance(c);
    c = start_counted("names", 7, 1e-6, 1e-8, 1.0, -2.0); /* auto: this toy has no kernel */
    CHECK_STATUS(fmi2GetInteger(c, &vr, 1, &v), fmi2OK);
    CHECK(v == 7);
    log_clear();
    CHECK_STATUS(fmi2DoStep(c, 0.0, 0.1, fmi2True), fmi2OK);
    CHECK_LOG("solver=dop853 accepted=");
    fmi2FreeInstance(c);
    c = fmi2Instantiate("names", fmi2CoSimulation, TOKEN, "", &h_callbacks, 0, 0);
    log_clear();
    CHECK_STATUS(seti(c, VR_SOLVER, 6), fmi2Error); /* taylor: this toy has no kernel */
    CHECK_LOG("solver = 6 (taylor) is not available in this model: a toy model without a Taylor kernel");
    fmi2FreeInstance(c);
}

int main(void) {
    test_tight_tolerance();
    test_step_growth();
    test_fixed_step_order();
    test_dense_order();
    run_terminate(DOP853, 1e-12, 0.1, 1e-10);
    run_terminate(DOP853, 1e-12, 100.0, 1e-10);
    run_terminate(DOP853, 1e-6, 0.25, 1e-6);
    run_terminate(ROSENBROCK, 1e-10, 0.1, 1e-8);
    run_terminate(ROSENBROCK, 1e-10, 100.0, 1e-8);
    test_fd_jacobian();
    test_state(DOP853);
    test_state(ROSENBROCK);
    test_solver_values();
    return h_finish("test_solvers_osc");
}
