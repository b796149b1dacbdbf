/*
 * realtime.c -- @model@ in a fixed-step real-time loop.  Each period the loop advances the
 * model by one step and reads its outputs, as a hardware-in-the-loop rig or a game loop does;
 * the cost of every such step is measured with CLOCK_MONOTONIC and reported as mean, median,
 * 99th and 99.9th percentile and worst case, beside the drift of the energy balance
 * energy + dissipated_energy - actuator_work (constant in an exact run, docs/effects.md) and the
 * error against a tight DOP853 reference (max over the states of |x - x_ref| / max(1, |x_ref|),
 * at 20 s and at the end).  Defaults: RK4 at 1 kHz, 10^6 steps (1000 s of simulated time).
 * docs/c_api.md has figures and their reading.
 *
 *   @model@_realtime [--steps N] [--rate HZ] [--solver euler|rk4|dopri5|dop853|rosenbrock]
 *                    [--compare] [--paced] [--mlock]
 *
 *   --steps    1 to 10^9 (the cost of every step is kept: 16 bytes a step)
 *   --compare  the same loop with euler, rk4, dopri5 and dop853 (the scene's tolerances for
 *              the adaptive ones): which solver is the cheapest that is accurate enough
 *   --paced    sleep to each period's start (clock_nanosleep, absolute time) as a real
 *              real-time loop does; reports wake-up latency and missed deadlines
 *   --mlock    lock the process's memory first (mlockall; may need privileges)
 *
 * Every run prints one line "RESULT key=value ..." for scripts.  Timings depend on the machine
 * and on what else runs on it: on a shared machine the tail (p99.9, max) measures the
 * neighbours as much as the model.
 */
#define _POSIX_C_SOURCE 200112L

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

#include "@model@.h"

static const char *prog = "@model@_realtime";

/* --steps at most: 16 GB of timings (two doubles a step) and 10^6 s of reference at 1 kHz */
#define MAX_STEPS 1000000000L

typedef struct {
    int solver;
    double rate;         /* Hz */
    long steps;
    int paced;
} loop_config;

typedef struct {
    double *cost_ns;     /* steps: advance + get_outputs, wall clock (CLOCK_MONOTONIC) */
    double *cpu_ns;      /* the same in this thread's CPU time: without the time the OS gave
                            to others (CLOCK_THREAD_CPUTIME_ID; includes the two wall-clock
                            reads, ~50 ns) */
    long done;           /* steps run (fewer if the run ended) */
    double energy_drift; /* max |B - B0| / |B0| of the energy balance B = energy +
                            dissipated_energy - actuator_work (the terms the scene has;
                            docs/effects.md): constant in an exact run (NaN when the model
                            lacks a term: see energy_balance_missing) */
    double violation;    /* max |constraint_violation| (the multipliers formulation; else NaN) */
    double err_20, err_end; /* max |x - x_ref| over the states at 20 s and at the end */
    double rhs_per_step;
    double max_late_ns;  /* paced: worst wake-up latency */
    long misses;         /* paced: steps finished after their period's end */
    int terminated;
} loop_result;

static double clock_ns(clockid_t clock) {
    struct timespec ts;
    clock_gettime(clock, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}
static double now_ns(void) { return clock_ns(CLOCK_MONOTONIC); }
static double cpu_ns(void) { return clock_ns(CLOCK_THREAD_CPUTIME_ID); }

static int solver_code(const char *name) {
    static const char *const names[] = {"euler", "rk4", "dopri5", "rosenbrock", "dop853"};
    int i;
    for (i = 0; i < 5; i++)
        if (strcmp(name, names[i]) == 0) return i + 1;
    return 0;
}
static const char *solver_label(int code) {
    static const char *const names[] = {"?", "euler", "rk4", "dopri5", "rosenbrock", "dop853"};
    return (code >= 1 && code <= 5) ? names[code] : "?";
}

static int fail(@model@ *w, const char *what) {
    fprintf(stderr, "%s: %s: %s\n", prog, what, @model@_last_error(w));
    @model@_free(w);
    return 1;
}

/* the scene's model with this solver; fixed-step solvers step exactly once per period */
static int make(@model@ **w, int solver, double period, double rel_tol, double abs_tol) {
    gyrowheel_settings s;
    @model@_default_settings(&s);
    s.solver = solver;
    if (solver == GYROWHEEL_SOLVER_EULER || solver == GYROWHEEL_SOLVER_RK4) s.max_step = period;
    if (rel_tol > 0.0) {
        s.rel_tol = rel_tol;
        s.abs_tol = abs_tol;
    }
    return @model@_create(NULL, NULL, &s, NULL, w) < 0 ? fail(*w, "create") : 0;
}

/* Reference states every second (ref[j * NX ...] at t0 + j), DOP853 at rel_tol `tol`;
 * *seconds is lowered to the last whole second before a terminating event.  0 on success. */
static int reference(double *ref, long *seconds, double tol) {
    @model@ *w = NULL;
    double t0;
    long j;
    if (make(&w, GYROWHEEL_SOLVER_DOP853, 0.0, tol, tol * 1e-2)) return 1;
    t0 = @model@_time(w);
    @model@_get_states(w, ref);
    for (j = 1; j <= *seconds; j++) {
        gyrowheel_status st = @model@_advance(w, t0 + (double)j);
        if (st < 0) return fail(w, "reference");
        if (st == GYROWHEEL_TERMINATED) {
            *seconds = j - 1;
            break;
        }
        @model@_get_states(w, ref + j * @MODEL@_NX);
    }
    @model@_free(w);
    return 0;
}

/* max over the states of |a - b| / max(1, |b|): absolute for small states, relative for the
 * ones that grow without bound (the spin angle gamma reaches 6000 rad in 1000 s) */
static double state_error(const double *a, const double *b) {
    double m = 0.0;
    int i;
    for (i = 0; i < @MODEL@_NX; i++) {
        const double e = fabs(a[i] - b[i]) / (fabs(b[i]) > 1.0 ? fabs(b[i]) : 1.0);
        if (e > m || e != e) m = e;
    }
    return m;
}

/* The kinds of non-conservative forces of the scene (written by gyrowheel export-c): a
 * dissipative scene loses energy by design, a driven one gains the actuators' work, so only the
 * balance with the terms of the energy effect is conserved. */
enum {
    DISSIPATIVE_FORCES = @dissipative_forces@,
    ACTUATOR_FORCES = @actuator_forces@,
    OTHER_FORCES = @other_forces@
};

/* why the energy balance cannot be measured from the model's outputs, or NULL if it can */
static const char *energy_balance_missing(void) {
    if (@model@_index(GYROWHEEL_KIND_OUTPUT, "energy") < 0) return "the model has no energy output";
    if (DISSIPATIVE_FORCES && @model@_index(GYROWHEEL_KIND_OUTPUT, "dissipated_energy") < 0)
        return "the scene dissipates energy but has no dissipated_energy output (add [effects.energy])";
    if (ACTUATOR_FORCES && @model@_index(GYROWHEEL_KIND_OUTPUT, "actuator_work") < 0)
        return "the scene's actuators do work but it has no actuator_work output (add [effects.energy])";
    if (OTHER_FORCES) return "the scene has forces whose work no output accounts for";
    return NULL;
}

/* the energy balance energy + dissipated_energy - actuator_work of outputs y (the terms the
 * model has) */
static double energy_balance(const double *y, int i_energy, int i_dissipated, int i_work) {
    return y[i_energy] + (i_dissipated >= 0 ? y[i_dissipated] : 0.0) - (i_work >= 0 ? y[i_work] : 0.0);
}

static int run_loop(const loop_config *c, const double *ref, long ref_seconds, loop_result *r) {
    const double period = 1.0 / c->rate;
    const int i_energy = @model@_index(GYROWHEEL_KIND_OUTPUT, "energy");
    const int i_dissipated = @model@_index(GYROWHEEL_KIND_OUTPUT, "dissipated_energy");
    const int i_work = @model@_index(GYROWHEEL_KIND_OUTPUT, "actuator_work");
    const int i_violation = @model@_index(GYROWHEEL_KIND_OUTPUT, "constraint_violation");
    const long per_second = (long)floor(c->rate + 0.5);
    double y[@MODEL@_NY + 1], x[@MODEL@_NX + 1], t0, e0 = 0.0, release = 0.0;
    gyrowheel_statistics stats;
    struct timespec wake;
    @model@ *w = NULL;
    long k;
    double *costs = r->cost_ns, *cpus = r->cpu_ns; /* the caller's */
    memset(r, 0, sizeof(*r));
    r->cost_ns = costs;
    r->cpu_ns = cpus;
    r->err_20 = r->err_end = NAN;
    r->energy_drift = NAN;
    r->violation = i_violation >= 0 ? 0.0 : NAN;
    if (make(&w, c->solver, period, 0.0, 0.0)) return 1;
    t0 = @model@_time(w);
    @model@_get_outputs(w, y);
    if (!energy_balance_missing()) {
        e0 = energy_balance(y, i_energy, i_dissipated, i_work);
        r->energy_drift = 0.0;
    }
    if (c->paced) release = now_ns();
    for (k = 1; k <= c->steps; k++) {
        double start, stop, cpu_start, cpu_stop;
        gyrowheel_status st;
        if (c->paced) { /* wait for this period's start */
            release += period * 1e9;
            wake.tv_sec = (time_t)(release / 1e9);
            wake.tv_nsec = (long)(release - (double)wake.tv_sec * 1e9);
            while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, NULL) != 0) {
            }
        }
        cpu_start = cpu_ns();
        start = now_ns();
        st = @model@_advance(w, t0 + (double)k * period);
        if (st >= 0) st = @model@_get_outputs(w, y) < 0 ? GYROWHEEL_ERR_SIMULATION : st;
        stop = now_ns();
        cpu_stop = cpu_ns();
        if (st < 0) return fail(w, solver_label(c->solver));
        r->cost_ns[k - 1] = stop - start;
        r->cpu_ns[k - 1] = cpu_stop - cpu_start;
        r->done = k;
        if (c->paced) {
            if (start - release > r->max_late_ns) r->max_late_ns = start - release;
            if (stop > release + period * 1e9) r->misses++;
        }
        if (!isnan(r->energy_drift)) {
            const double drift = fabs(energy_balance(y, i_energy, i_dissipated, i_work) - e0) /
                                 (e0 != 0.0 ? fabs(e0) : 1.0);
            if (drift > r->energy_drift || isnan(drift)) r->energy_drift = drift;
        }
        if (i_violation >= 0 && fabs(y[i_violation]) > r->violation)
            r->violation = fabs(y[i_violation]);
        if (k % per_second == 0 && k / per_second <= ref_seconds) { /* a whole second */
            const long j = k / per_second;
            @model@_get_states(w, x);
            r->err_end = state_error(x, ref + j * @MODEL@_NX);
            if (j == 20) r->err_20 = r->err_end;
        }
        if (st == GYROWHEEL_TERMINATED) {
            r->terminated = 1;
            break;
        }
    }
    @model@_get_statistics(w, &stats);
    r->rhs_per_step = r->done ? (double)stats.rhs_evaluations / (double)r->done : 0.0;
    @model@_free(w);
    return 0;
}

static int by_value(const void *a, const void *b) {
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* median cost of the measurement itself: the same brackets around nothing [ns] */
static void clock_overhead(double *wall, double *cpu) {
    enum { N = 20001 };
    static double w[N], c[N];
    int i;
    for (i = 0; i < N; i++) {
        const double c0 = cpu_ns(), w0 = now_ns(), w1 = now_ns(), c1 = cpu_ns();
        w[i] = w1 - w0;
        c[i] = c1 - c0;
    }
    qsort(w, N, sizeof(double), by_value);
    qsort(c, N, sizeof(double), by_value);
    *wall = w[N / 2];
    *cpu = c[N / 2];
}

/* the q-quantile (0..1) of sorted v[n], nearest rank */
static double quantile(const double *v, long n, double q) {
    long i = (long)ceil(q * (double)n) - 1;
    if (i < 0) i = 0;
    if (i >= n) i = n - 1;
    return v[i];
}

/* "mean p50 p99 p99.9 max" of v[n] in us (sorts v) */
typedef struct {
    double mean, p50, p99, p999, max;
} summary;
static summary summarise(double *v, long n) {
    summary s;
    double sum = 0.0;
    long i;
    for (i = 0; i < n; i++) sum += v[i];
    qsort(v, (size_t)n, sizeof(double), by_value);
    s.mean = sum / (double)n * 1e-3;
    s.p50 = quantile(v, n, 0.5) * 1e-3;
    s.p99 = quantile(v, n, 0.99) * 1e-3;
    s.p999 = quantile(v, n, 0.999) * 1e-3;
    s.max = v[n - 1] * 1e-3;
    return s;
}

static void report(const loop_config *c, loop_result *r) {
    const long n = r->done;
    summary wall, cpu;
    if (n == 0) return;
    wall = summarise(r->cost_ns, n);
    cpu = summarise(r->cpu_ns, n);
    printf("%-7s %6.0f Hz %8ld steps %5.2f rhs/step | energy drift %.2e | error 20 s %.2e, end "
           "%.2e%s\n",
           solver_label(c->solver), c->rate, n, r->rhs_per_step, r->energy_drift, r->err_20,
           r->err_end, r->terminated ? " (the run ended at an event)" : "");
    if (!isnan(r->violation))
        printf("   constraint violation |A q_dot| up to %.2e m/s\n", r->violation);
    printf("   cost per step [us]  wall: mean %.3f p50 %.3f p99 %.3f p99.9 %.3f max %.3f\n"
           "                        cpu: mean %.3f p50 %.3f p99 %.3f p99.9 %.3f max %.3f\n",
           wall.mean, wall.p50, wall.p99, wall.p999, wall.max, cpu.mean, cpu.p50, cpu.p99,
           cpu.p999, cpu.max);
    printf("RESULT solver=%s rate=%.17g steps=%ld rhs_per_step=%.17g energy_drift=%.6g "
           "err_20=%.6g err_end=%.6g terminated=%d violation=%.6g wall_mean_us=%.6g "
           "wall_p50_us=%.6g "
           "wall_p99_us=%.6g wall_p999_us=%.6g wall_max_us=%.6g cpu_mean_us=%.6g cpu_p50_us=%.6g "
           "cpu_p99_us=%.6g cpu_p999_us=%.6g cpu_max_us=%.6g",
           solver_label(c->solver), c->rate, n, r->rhs_per_step, r->energy_drift, r->err_20,
           r->err_end, r->terminated, r->violation, wall.mean, wall.p50, wall.p99, wall.p999,
           wall.max, cpu.mean, cpu.p50, cpu.p99, cpu.p999, cpu.max);
    if (c->paced) printf(" max_wake_late_us=%.6g misses=%ld", r->max_late_ns * 1e-3, r->misses);
    printf("\n");
}

static int usage(const char *arg, const char *why) {
    fprintf(stderr, "%s: %s: %s\n", prog, arg, why);
    fprintf(stderr,
            "usage: %s [--steps N] [--rate HZ] [--solver euler|rk4|dopri5|dop853|rosenbrock] "
            "[--compare] [--paced] [--mlock]\n",
            prog);
    return 2;
}

int main(int argc, char **argv) {
    loop_config c;
    loop_result r;
    int a, compare = 0, i, status = 0;
    const int compared[4] = {GYROWHEEL_SOLVER_EULER, GYROWHEEL_SOLVER_RK4,
                             GYROWHEEL_SOLVER_DOPRI5, GYROWHEEL_SOLVER_DOP853};
    long ref_seconds;
    double *ref, *ref_check, wall_overhead, cpu_overhead;
    c.solver = GYROWHEEL_SOLVER_RK4;
    c.rate = 1000.0;
    c.steps = 1000000;
    c.paced = 0;
    for (a = 1; a < argc; a++) {
        char *end = NULL;
        if (strcmp(argv[a], "--compare") == 0) {
            compare = 1;
        } else if (strcmp(argv[a], "--paced") == 0) {
            c.paced = 1;
        } else if (strcmp(argv[a], "--mlock") == 0) {
            if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
                fprintf(stderr, "%s: mlockall failed (not permitted here?); going on\n", prog);
        } else if (a + 1 < argc && strcmp(argv[a], "--steps") == 0) {
            c.steps = strtol(argv[++a], &end, 10);
            if (*end != '\0' || c.steps < 1 || c.steps > MAX_STEPS)
                return usage(argv[a], "--steps needs an integer in [1, 1e9]");
        } else if (a + 1 < argc && strcmp(argv[a], "--rate") == 0) {
            c.rate = strtod(argv[++a], &end);
            if (*end != '\0' || !(c.rate >= 1.0 && c.rate <= 1e7))
                return usage(argv[a], "--rate needs a number of Hz in [1, 1e7]");
        } else if (a + 1 < argc && strcmp(argv[a], "--solver") == 0) {
            c.solver = solver_code(argv[++a]);
            if (!c.solver) return usage(argv[a], "unknown solver");
        } else {
            return usage(argv[a], "unknown argument (or a missing value)");
        }
    }
    /* the timings of every step (16 bytes a step), before the reference takes its time */
    r.cost_ns = (double *)malloc((size_t)c.steps * sizeof(double));
    r.cpu_ns = (double *)malloc((size_t)c.steps * sizeof(double));
    /* reference: DOP853 at rel_tol 1e-13, its own error bounded by the difference to 1e-12 */
    ref_seconds = (long)floor((double)c.steps / c.rate);
    ref = (double *)calloc((size_t)(ref_seconds + 1) * @MODEL@_NX + 1, sizeof(double));
    ref_check = (double *)calloc((size_t)(ref_seconds + 1) * @MODEL@_NX + 1, sizeof(double));
    if (!r.cost_ns || !r.cpu_ns || !ref || !ref_check) {
        fprintf(stderr, "%s: out of memory for %ld steps (%.0f MB of timings and reference)\n", prog,
                c.steps, ((double)c.steps * 2.0 + (double)(ref_seconds + 1) * 2.0 * @MODEL@_NX) * 8e-6);
        status = 1;
        goto done;
    }
    if (reference(ref, &ref_seconds, 1e-13) || reference(ref_check, &ref_seconds, 1e-12)) {
        status = 1;
        goto done;
    }
    clock_overhead(&wall_overhead, &cpu_overhead);
    printf("%s: %ld steps at %g Hz (%g s simulated)%s; reference dop853 rel_tol 1e-13 (vs 1e-12: "
           "%.2e at the end); measuring costs %.0f ns (wall), %.0f ns (cpu) per step, included "
           "below\n",
           "@model@", c.steps, c.rate, (double)c.steps / c.rate,
           c.paced ? ", paced to the wall clock" : ", back to back",
           state_error(ref + ref_seconds * @MODEL@_NX, ref_check + ref_seconds * @MODEL@_NX),
           wall_overhead, cpu_overhead);
    if (energy_balance_missing())
        printf("energy drift not measured: %s\n", energy_balance_missing());
    printf("RESULT overhead wall_ns=%.6g cpu_ns=%.6g\n", wall_overhead, cpu_overhead);
    for (i = 0; i < (compare ? 4 : 1); i++) {
        if (compare) c.solver = compared[i];
        if (run_loop(&c, ref, ref_seconds, &r)) {
            status = 1;
            break;
        }
        report(&c, &r);
    }
done:
    free(r.cost_ns);
    free(r.cpu_ns);
    free(ref);
    free(ref_check);
    return status;
}
