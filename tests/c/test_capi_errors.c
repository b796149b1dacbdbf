/*
 * test_capi_errors.c -- errors of the exported C API of paper_earth, from a plain C program
 * (tests/test_export_c.py builds it strictly against the export and runs it):
 *   logger    every error reaches the logger exactly once, the API's own (backwards, NaN, not
 *             ready, index) as well as the core's; last_error(NULL) names the allocator case
 *   far_time  euler / rk4 far from t = 0, where doubles are coarser than max_step: the advance
 *             is refused with the reason and the instance unchanged, never taken as one step
 *             500x max_step long; at t = 1e9 s (a Unix time) still one step per 1 ms period
 *   horizon   an advance needing more internal steps than max_internal_steps (10^6) is
 *             refused at once by every adaptive solver (DOPRI5, the default, DOP853 and
 *             RODAS4), not run for hours; the instance goes on afterwards
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "paper_earth.h"

#include "checks.h"

/* ---- logger --------------------------------------------------------------------------------- */
static char log_text[16384];
static int log_errors;
static void logger(void *env, gyrowheel_log_level level, const char *message) {
    (void)env;
    if (level == GYROWHEEL_LOG_ERROR) log_errors++;
    if (strlen(log_text) + strlen(message) + 2 < sizeof(log_text)) {
        strcat(log_text, message);
        strcat(log_text, "\n");
    }
}
static int count(const char *text, const char *what) {
    int n = 0;
    for (text = strstr(text, what); text; text = strstr(text + 1, what)) n++;
    return n;
}
/* the call failed with `code`, its last_error went to the logger exactly once */
#define CHECK_LOGGED(w, call, code)                                                           \
    do {                                                                                      \
        int before_ = log_errors;                                                             \
        CHECK((call) == (code));                                                              \
        CHECK(log_errors == before_ + 1);                                                     \
        CHECK(count(log_text, paper_earth_last_error(w)) == 1);                               \
    } while (0)

static void logged_errors(void) {
    paper_earth *w = NULL;
    double p[PAPER_EARTH_NP], y[PAPER_EARTH_NY];
    const gyrowheel_allocator no_functions = {NULL, NULL, NULL};
    CHECK(paper_earth_create(NULL, NULL, NULL, &no_functions, &w) == GYROWHEEL_ERR_ARGUMENT);
    CHECK(w == NULL && strstr(paper_earth_last_error(NULL), "allocator") != NULL);

    CHECK(paper_earth_create(NULL, NULL, NULL, NULL, &w) == GYROWHEEL_OK);
    CHECK(paper_earth_set_logger(w, logger, NULL) == GYROWHEEL_OK);
    CHECK(paper_earth_advance(w, 0.5) == GYROWHEEL_OK);
    CHECK_LOGGED(w, paper_earth_advance(w, 0.25), GYROWHEEL_ERR_TIME); /* backwards */
    CHECK_LOGGED(w, paper_earth_advance(w, NAN), GYROWHEEL_ERR_TIME);
    CHECK_LOGGED(w, paper_earth_set_input(w, 3, 1.0), GYROWHEEL_ERR_ARGUMENT);
    CHECK_LOGGED(w, paper_earth_get_outputs(w, NULL), GYROWHEEL_ERR_ARGUMENT);
    paper_earth_default_parameters(p);
    p[PAPER_EARTH_P_M] = NAN;
    CHECK_LOGGED(w, paper_earth_reset(w, p, NULL, NULL), GYROWHEEL_ERR_NOT_FINITE);
    CHECK_LOGGED(w, paper_earth_get_outputs(w, y), GYROWHEEL_ERR_NOT_READY);
    /* the core's reason: logged once, not again as last_error */
    p[PAPER_EARTH_P_M] = -1.0;
    CHECK_LOGGED(w, paper_earth_reset(w, p, NULL, NULL), GYROWHEEL_ERR_INVALID);
    CHECK(count(log_text, "M (mass) must be > 0") == 1);
    paper_earth_free(w);
}

/* ---- fixed steps far from t = 0 ------------------------------------------------------------ */
static paper_earth *fixed(int solver, double start_time) {
    gyrowheel_settings st;
    paper_earth *w = NULL;
    paper_earth_default_settings(&st);
    st.solver = solver;
    st.max_step = 1e-3;
    st.start_time = start_time;
    CHECK(paper_earth_create(NULL, NULL, &st, NULL, &w) == GYROWHEEL_OK);
    return w;
}

static void far_time(void) {
    const int solvers[2] = {GYROWHEEL_SOLVER_EULER, GYROWHEEL_SOLVER_RK4};
    gyrowheel_statistics stats;
    int s, k;
    for (s = 0; s < 2; s++) {
        /* doubles at 1e15 are 0.125 s apart: steps of 1 ms cannot be taken */
        paper_earth *w = fixed(solvers[s], 1e15);
        double x0[PAPER_EARTH_NX], x1[PAPER_EARTH_NX];
        CHECK(paper_earth_get_states(w, x0) == GYROWHEEL_OK);
        CHECK(paper_earth_advance(w, 1e15 + 0.5) == GYROWHEEL_ERR_SIMULATION);
        CHECK(strstr(paper_earth_last_error(w), "cannot take steps of max_step=0.001") != NULL);
        CHECK(paper_earth_time(w) == 1e15);
        CHECK(paper_earth_get_states(w, x1) == GYROWHEEL_OK && memcmp(x0, x1, sizeof(x0)) == 0);
        paper_earth_free(w);
    }
    /* at t = 1e9 s (doubles 1.2e-7 s apart) a 1 ms period is still one step */
    {
        paper_earth *w = fixed(GYROWHEEL_SOLVER_RK4, 1e9);
        for (k = 1; k <= 1000; k++) CHECK(paper_earth_advance(w, 1e9 + 1e-3 * k) == GYROWHEEL_OK);
        CHECK(paper_earth_get_statistics(w, &stats) == GYROWHEEL_OK && stats.steps_accepted == 1000);
        paper_earth_free(w);
    }
}

/* ---- a horizon no solver can reach --------------------------------------------------------- */
static void horizon(void) {
    const int solvers[3] = {GYROWHEEL_SOLVER_DOPRI5, GYROWHEEL_SOLVER_DOP853,
                            GYROWHEEL_SOLVER_ROSENBROCK};
    gyrowheel_statistics stats;
    int s;
    for (s = 0; s < 3; s++) {
        /* max_step 0.05 s: 1e8 s are 2e9 steps, beyond the budget of 10^6 */
        static const char *const names[2] = {"solver", "max_step"};
        const double values[2] = {solvers[s], 0.05};
        paper_earth *w = NULL;
        CHECK(paper_earth_create_named(2, names, values, NULL, &w) == GYROWHEEL_OK);
        CHECK(paper_earth_advance(w, 1.0) == GYROWHEEL_OK);
        CHECK(paper_earth_advance(w, 1e8) == GYROWHEEL_ERR_SIMULATION);
        CHECK(strstr(paper_earth_last_error(w), "internal steps of max_step=0.05, more than "
                                                "max_internal_steps = 1000000") != NULL);
        CHECK(paper_earth_get_statistics(w, &stats) == GYROWHEEL_OK);
        CHECK(paper_earth_time(w) == 1.0 && stats.steps_accepted < 1000); /* refused at once */
        CHECK(paper_earth_advance(w, 1e299) == GYROWHEEL_ERR_SIMULATION);
        CHECK(paper_earth_advance(w, 1.5) == GYROWHEEL_OK); /* and goes on */
        paper_earth_free(w);
    }
}

int main(void) {
    logged_errors();
    far_time();
    horizon();
    fprintf(stderr, "test_capi_errors: %d checks, %d failures\n", h_checks, h_failures);
    return h_failures == 0 ? 0 : 1;
}
