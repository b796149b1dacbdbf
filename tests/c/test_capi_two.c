/*
 * test_capi_two.c -- two exported models in one program: paper_earth and lunar_rover, each
 * compiled on its own into an object file (their internal names are the same), linked together
 * with this driver (tests/test_export_c.py).  Both run their scene's experiment interleaved,
 * step by step, at fmpy's communication points, each writing CSV (time, outputs, event flags)
 * to the file named on the command line; the test compares them with the two FMUs.  Also: the
 * event time of lunar_rover's non-terminating slip event (GYROWHEEL_FIRED), and a state of one
 * model refused by the other.
 *
 *   test_capi_two paper_earth.csv lunar_rover.csv
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lunar_rover.h"
#include "paper_earth.h"

#include "checks.h"

/* One model's run at t0 + k * interval to its stop time (fmpy's points), a CSV row each. */
#define DEFINE_RUN(model, MODEL)                                                              \
    typedef struct {                                                                          \
        model *w;                                                                             \
        FILE *csv;                                                                            \
        long k;                                                                               \
        int done, fired_status;                                                               \
    } run_##model;                                                                            \
    static void row_##model(run_##model *r) {                                                 \
        double y[MODEL##_NY];                                                                 \
        int i, fired;                                                                         \
        CHECK(model##_get_outputs(r->w, y) == GYROWHEEL_OK);                                  \
        fprintf(r->csv, "%.17g", model##_time(r->w));                                         \
        for (i = 0; i < MODEL##_NY; i++) fprintf(r->csv, ",%.17g", y[i]);                     \
        for (i = 0; i < MODEL##_NE; i++) {                                                    \
            CHECK(model##_get_event(r->w, i, &fired, NULL) == GYROWHEEL_OK);                  \
            fprintf(r->csv, ",%d", fired);                                                    \
        }                                                                                     \
        fprintf(r->csv, "\n");                                                                \
    }                                                                                         \
    static void start_##model(run_##model *r, const char *path) {                             \
        int i;                                                                                \
        memset(r, 0, sizeof(*r));                                                             \
        CHECK(model##_create(NULL, NULL, NULL, NULL, &r->w) == GYROWHEEL_OK);                 \
        r->csv = fopen(path, "w");                                                            \
        CHECK(r->csv != NULL);                                                                \
        if (!r->csv) exit(1);                                                                 \
        fprintf(r->csv, "time");                                                              \
        for (i = 0; i < MODEL##_NY; i++)                                                      \
            fprintf(r->csv, ",%s", model##_variable(GYROWHEEL_KIND_OUTPUT, i)->name);         \
        for (i = 0; i < MODEL##_NE; i++)                                                      \
            fprintf(r->csv, ",%s", model##_variable(GYROWHEEL_KIND_EVENT, i)->name);          \
        fprintf(r->csv, "\n");                                                                \
        row_##model(r);                                                                       \
    }                                                                                         \
    static void step_##model(run_##model *r) {                                                \
        const double stop = MODEL##_STOP_TIME;                                                \
        double next;                                                                          \
        gyrowheel_status st;                                                                  \
        if (r->done) return;                                                                  \
        r->k++;                                                                               \
        next = MODEL##_START_TIME + (double)r->k * MODEL##_OUTPUT_INTERVAL;                   \
        if (next > stop && !close_to(next, stop)) next = stop;                                \
        st = model##_advance(r->w, next);                                                     \
        CHECK(st >= 0);                                                                       \
        if (st < 0) fprintf(stderr, "%s\n", model##_last_error(r->w));                       \
        if (st == GYROWHEEL_FIRED) r->fired_status++;                                         \
        row_##model(r);                                                                       \
        r->done = st < 0 || st == GYROWHEEL_TERMINATED || close_to(model##_time(r->w), stop); \
    }                                                                                         \
    static void finish_##model(run_##model *r) {                                              \
        fclose(r->csv);                                                                       \
        model##_free(r->w);                                                                   \
    }

static int close_to(double a, double b) { /* fmpy's isclose */
    return fabs(a - b) <= 1e-9 * (fabs(a) > fabs(b) ? fabs(a) : fabs(b));
}

DEFINE_RUN(paper_earth, PAPER_EARTH)
DEFINE_RUN(lunar_rover, LUNAR_ROVER)

int main(int argc, char **argv) {
    run_paper_earth a;
    run_lunar_rover b;
    int fired, slip;
    double t_slip;
    size_t size;
    unsigned char *buf;
    if (argc != 3) {
        fprintf(stderr, "usage: test_capi_two paper_earth.csv lunar_rover.csv\n");
        return 2;
    }
    start_paper_earth(&a, argv[1]);
    start_lunar_rover(&b, argv[2]);
    while (!a.done || !b.done) { /* interleaved: one instance of each, side by side */
        step_paper_earth(&a);
        step_lunar_rover(&b);
    }
    /* lunar_rover: slipping (does not end the run) fired before the fall; its time is the last firing */
    slip = lunar_rover_index(GYROWHEEL_KIND_EVENT, "slipping");
    CHECK(slip == LUNAR_ROVER_E_slipping && b.fired_status >= 1);
    CHECK(lunar_rover_get_event(b.w, slip, &fired, &t_slip) == GYROWHEEL_OK && fired == 1);
    CHECK(t_slip > 0.0 && t_slip < lunar_rover_time(b.w) && lunar_rover_terminated(b.w));
    printf("slip_time %.17g\nfall_time %.17g\n", t_slip, lunar_rover_time(b.w));
    /* a state of paper_earth is refused by lunar_rover, which stays as it was */
    size = paper_earth_state_size(a.w);
    buf = (unsigned char *)malloc(size);
    CHECK(buf && paper_earth_save_state(a.w, buf, size) == GYROWHEEL_OK);
    CHECK(lunar_rover_restore_state(b.w, buf, size) == GYROWHEEL_ERR_STATE);
    printf("cross_restore %s\n", lunar_rover_last_error(b.w));
    CHECK(lunar_rover_terminated(b.w));
    free(buf);
    finish_paper_earth(&a);
    finish_lunar_rover(&b);
    fprintf(stderr, "test_capi_two: %d checks, %d failures\n", h_checks, h_failures);
    return h_failures == 0 ? 0 : 1;
}
