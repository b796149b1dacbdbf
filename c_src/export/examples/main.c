/*
 * main.c -- the scene's experiment (for the paper scenes, the run of Nandy & Xu, section 4)
 * through the C API of @model@.h, as CSV on stdout: time, every output, every event flag; one
 * row per output interval from the start time, and a last row at the event time if a
 * terminating event (the fall) ends the run.  The communication points are those of fmpy's
 * simulate_fmu (t0 + k * interval, the last one clipped to the stop time), so the rows match
 * the FMU's built from the same scene.
 *
 *   @model@_example [--stop-time T] [--output-interval DT] [NAME=VALUE ...] > run.csv
 *
 * NAME=VALUE sets a parameter, an initial value or a setting before the run, e.g.
 * gamma_dot=8 beta=1.2 solver=2 max_step=0.001 (solver: 1 euler, 2 rk4, 3 dopri5,
 * 4 rosenbrock, 5 dop853, 6 taylor if the export carries the Taylor kernel: a scene with
 * solver = "taylor").  Exit status: 0 done, 1 the simulation failed, 2 bad arguments.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "@model@.h"

#define MAX_SETS 64
#define MAX_NAME 128

static const char *prog = "@model@_example";

static int bad_argument(const char *arg, const char *why) {
    fprintf(stderr, "%s: %s: %s\n", prog, arg, why);
    fprintf(stderr, "usage: %s [--stop-time T] [--output-interval DT] [NAME=VALUE ...]\n", prog);
    return 2;
}

/* a finite number filling the whole text, or 0 */
static int parse_number(const char *text, double *out) {
    char *end;
    *out = strtod(text, &end);
    return end != text && *end == '\0' && isfinite(*out);
}

/* fmpy's isclose (math.isclose, rel_tol 1e-9) */
static int close_to(double a, double b) {
    return fabs(a - b) <= 1e-9 * (fabs(a) > fabs(b) ? fabs(a) : fabs(b));
}

static void print_header(void) {
    int k, i;
    const gyrowheel_kind kinds[2] = {GYROWHEEL_KIND_OUTPUT, GYROWHEEL_KIND_EVENT};
    printf("time");
    for (k = 0; k < 2; k++)
        for (i = 0; i < @model@_count(kinds[k]); i++)
            printf(",%s", @model@_variable(kinds[k], i)->name);
    printf("\n");
}

static int print_row(@model@ *w) {
    double y[@MODEL@_NY + 1];
    int i, fired;
    if (@model@_get_outputs(w, y) < 0) return -1;
    printf("%.17g", @model@_time(w));
    for (i = 0; i < @MODEL@_NY; i++) printf(",%.17g", y[i]);
    for (i = 0; i < @MODEL@_NE; i++) {
        if (@model@_get_event(w, i, &fired, NULL) < 0) return -1;
        printf(",%d", fired);
    }
    printf("\n");
    return 0;
}

int main(int argc, char **argv) {
    static char name_text[MAX_SETS][MAX_NAME];
    const char *names[MAX_SETS];
    double values[MAX_SETS], stop = @MODEL@_STOP_TIME, interval = @MODEL@_OUTPUT_INTERVAL, t0;
    size_t n = 0;
    int a, k, status = 0;
    gyrowheel_status st;
    @model@ *w = NULL;

    for (a = 1; a < argc; a++) {
        const char *eq = strchr(argv[a], '=');
        const int is_stop = strcmp(argv[a], "--stop-time") == 0;
        if (is_stop || strcmp(argv[a], "--output-interval") == 0) {
            double v;
            if (a + 1 >= argc) return bad_argument(argv[a], "needs a value");
            if (!parse_number(argv[a + 1], &v))
                return bad_argument(argv[a], "needs a finite number");
            if (is_stop) {
                stop = v;
            } else {
                if (!(v > 0.0)) return bad_argument(argv[a], "must be > 0");
                interval = v;
            }
            a++;
        } else if (eq && eq != argv[a]) {
            size_t len = (size_t)(eq - argv[a]);
            if (n == MAX_SETS) return bad_argument(argv[a], "too many NAME=VALUE arguments");
            if (len >= MAX_NAME) return bad_argument(argv[a], "name too long");
            memcpy(name_text[n], argv[a], len);
            name_text[n][len] = '\0';
            if (!parse_number(eq + 1, &values[n]))
                return bad_argument(argv[a], "the value is not a finite number");
            names[n] = name_text[n];
            n++;
        } else {
            return bad_argument(argv[a],
                                "expected --stop-time T, --output-interval DT or NAME=VALUE");
        }
    }

    st = @model@_create_named(n, names, values, NULL, &w);
    if (st < 0) {
        fprintf(stderr, "%s: %s\n", prog, @model@_last_error(w));
        @model@_free(w);
        return st == GYROWHEEL_ERR_MEMORY ? 1 : 2;
    }
    t0 = @model@_time(w);
    if (!(stop >= t0)) {
        @model@_free(w);
        return bad_argument("--stop-time", "is before the start time");
    }
    print_header();
    if (print_row(w) < 0) status = 1;
    for (k = 1; status == 0 && !(@model@_time(w) > stop || close_to(@model@_time(w), stop)); k++) {
        double next = t0 + (double)k * interval;
        if (next > stop && !close_to(next, stop)) next = stop;
        st = @model@_advance(w, next);
        if (st < 0 || print_row(w) < 0) {
            status = 1;
            break;
        }
        if (st == GYROWHEEL_TERMINATED) {
            fprintf(stderr, "%s: the run ended at t = %.17g s (terminating event)\n", prog,
                    @model@_time(w));
            break;
        }
    }
    if (status != 0) fprintf(stderr, "%s: %s\n", prog, @model@_last_error(w));
    @model@_free(w);
    return status;
}
