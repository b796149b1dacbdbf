/*
 * fmi3_me_importer.h -- one Model Exchange importer over either FMI version, for
 * test_fmi3_me.c: the same calls through the FMI 2.0 layer (gw_fmu.c) or the FMI 3.0 layer
 * (gw_fmu3.c) of one toy model (TOY_TOKEN), an explicit-Euler integration with event location
 * by bisection, and the record of a run (every step's states, every event) to compare runs
 * bit for bit.  Also the FMI 3.0 status checks and logger over harness.h.
 * Test code only (the driver includes it once).
 */
#ifndef GW_TEST_FMI3_ME_IMPORTER_H
#define GW_TEST_FMI3_ME_IMPORTER_H

#include <stdint.h>

#include "fmi3Functions.h"
#include "harness.h"

#ifndef TOY_TOKEN
#error "TOY_TOKEN: the toy model's token"
#endif

#define H_STEP 1e-3
#define T_END 10.0
#define MAX_NX 8
#define MAX_NE 8
#define MAX_STEPS 20000
#define MAX_EVENTS 64

#define CHECK3(call, expected)                                                               \
    do {                                                                                     \
        fmi3Status s3_ = (call);                                                             \
        h_checks++;                                                                          \
        if (s3_ != (expected)) {                                                             \
            h_failures++;                                                                    \
            fprintf(stderr, "%s:%d: %s returned %d, expected %d\n", __FILE__, __LINE__,     \
                    #call, (int)s3_, (int)(expected));                                       \
        }                                                                                    \
    } while (0)
/* fmi3Error with the reason logged */
#define EXPECT_ERROR3(call, msg)                                                             \
    do {                                                                                     \
        log_clear();                                                                         \
        CHECK3(call, fmi3Error);                                                             \
        CHECK_LOG(msg);                                                                      \
    } while (0)

/* the FMI 3.0 logger into the harness's log */
static void h3_logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                      fmi3String message) {
    h_logger(env, "fmi3", (fmi2Status)(int)status, category, message);
}

static fmi3String LOG_EVENTS[1] = {"logEvents"};

/* ---- one importer over either interface ------------------------------------------------ */

typedef struct {
    int fmi; /* 2 or 3 */
    fmi2Component c2;
    fmi3Instance c3;
} fmu;

static int st(int s) { return s; } /* fmi2Status and fmi3Status share their numbering */

static int set_time(fmu *u, double t) {
    return u->fmi == 2 ? st(fmi2SetTime(u->c2, t)) : st(fmi3SetTime(u->c3, t));
}
static int set_x(fmu *u, const double *x, size_t n) {
    return u->fmi == 2 ? st(fmi2SetContinuousStates(u->c2, x, n))
                       : st(fmi3SetContinuousStates(u->c3, x, n));
}
static int get_x(fmu *u, double *x, size_t n) {
    return u->fmi == 2 ? st(fmi2GetContinuousStates(u->c2, x, n))
                       : st(fmi3GetContinuousStates(u->c3, x, n));
}
static int get_dx(fmu *u, double *dx, size_t n) {
    return u->fmi == 2 ? st(fmi2GetDerivatives(u->c2, dx, n))
                       : st(fmi3GetContinuousStateDerivatives(u->c3, dx, n));
}
static int get_e(fmu *u, double *e, size_t n) {
    return u->fmi == 2 ? st(fmi2GetEventIndicators(u->c2, e, n))
                       : st(fmi3GetEventIndicators(u->c3, e, n));
}
static int enter_event(fmu *u) {
    return u->fmi == 2 ? st(fmi2EnterEventMode(u->c2)) : st(fmi3EnterEventMode(u->c3));
}
static int enter_ct(fmu *u) {
    return u->fmi == 2 ? st(fmi2EnterContinuousTimeMode(u->c2))
                       : st(fmi3EnterContinuousTimeMode(u->c3));
}
/* the event update: *terminate, *changed (valuesOfContinuousStatesChanged) */
static int update(fmu *u, int *terminate, int *changed) {
    int s;
    if (u->fmi == 2) {
        fmi2EventInfo ei;
        s = fmi2NewDiscreteStates(u->c2, &ei);
        CHECK(ei.newDiscreteStatesNeeded == fmi2False && ei.nextEventTimeDefined == fmi2False);
        *terminate = ei.terminateSimulation == fmi2True;
        *changed = ei.valuesOfContinuousStatesChanged == fmi2True;
    } else {
        fmi3Boolean need = true, term = true, nom = true, val = true, defined = true;
        fmi3Float64 next = -1.0;
        s = fmi3UpdateDiscreteStates(u->c3, &need, &term, &nom, &val, &defined, &next);
        CHECK(!need && !nom && !defined && next == 0.0);
        *terminate = term;
        *changed = val;
    }
    return s;
}
static int completed(fmu *u, int *terminate) {
    int s;
    if (u->fmi == 2) {
        fmi2Boolean enter = fmi2True, term = fmi2True;
        s = fmi2CompletedIntegratorStep(u->c2, fmi2True, &enter, &term);
        CHECK(enter == fmi2False);
        *terminate = term == fmi2True;
    } else {
        fmi3Boolean enter = true, term = true;
        s = fmi3CompletedIntegratorStep(u->c3, true, &enter, &term);
        CHECK(!enter);
        *terminate = term;
    }
    return s;
}

/* instantiated, initialised at t = 0, the initial event iteration done, in Continuous-Time
 * Mode */
static fmu start(int fmi) {
    fmu u = {fmi, NULL, NULL};
    int term = 0, changed = 0;
    if (fmi == 2) {
        fmi2String cats[1] = {"logEvents"};
        u.c2 = fmi2Instantiate("me2", fmi2ModelExchange, TOY_TOKEN, "", &h_callbacks, fmi2False,
                               fmi2False);
        CHECK(u.c2 != NULL);
        CHECK_STATUS(fmi2SetDebugLogging(u.c2, fmi2True, 1, cats), fmi2OK);
        CHECK_STATUS(fmi2SetupExperiment(u.c2, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
        CHECK_STATUS(fmi2EnterInitializationMode(u.c2), fmi2OK);
        CHECK_STATUS(fmi2ExitInitializationMode(u.c2), fmi2OK);
    } else {
        u.c3 = fmi3InstantiateModelExchange("me3", TOY_TOKEN, NULL, false, false, NULL,
                                            h3_logger);
        CHECK(u.c3 != NULL);
        CHECK3(fmi3SetDebugLogging(u.c3, true, 1, LOG_EVENTS), fmi3OK);
        CHECK3(fmi3EnterInitializationMode(u.c3, false, 0.0, 0.0, false, 0.0), fmi3OK);
        CHECK3(fmi3ExitInitializationMode(u.c3), fmi3OK);
    }
    CHECK(update(&u, &term, &changed) == 0);
    CHECK(!term);
    CHECK(enter_ct(&u) == 0);
    return u;
}

static void stop(fmu *u) {
    if (u->fmi == 2) {
        fmi2Terminate(u->c2);
        fmi2FreeInstance(u->c2);
    } else {
        fmi3Terminate(u->c3);
        fmi3FreeInstance(u->c3);
    }
}

/* what an importer's run produced */
typedef struct {
    double t;
    double x[MAX_NX], e[MAX_NE];
    int steps;
    double traj[MAX_STEPS][MAX_NX]; /* the states after each step or event */
    int n_events;
    double ev_t[MAX_EVENTS];
    int ev_flags[MAX_EVENTS]; /* 1: terminate, 2: states changed */
    int terminated;
} run;

static size_t NX, NE;

static void indicators_at(fmu *u, double t, const double *x, double *e) {
    CHECK(set_time(u, t) == 0);
    CHECK(set_x(u, x, NX) == 0);
    CHECK(get_e(u, e, NE) == 0);
}

/* the importer's own state from the FMU (after the start or a restore) at time t */
static void pick_up(fmu *u, run *r, double t) {
    r->t = t;
    CHECK(get_x(u, r->x, NX) == 0);
    indicators_at(u, t, r->x, r->e);
}

static void record(run *r) {
    if (r->steps < MAX_STEPS) memcpy(r->traj[r->steps], r->x, NX * sizeof(double));
    r->steps++;
}

/* Explicit Euler with step H_STEP until t_end, terminateSimulation or n more steps.  A crossing
 * (an indicator from > 0 to <= 0) is located by bisection on the step length to 1e-13; the
 * importer sets the point just past it and goes through Event Mode.  An Euler step is linear in
 * its length, so every trial point is x + s dx. */
static void integrate(fmu *u, run *r, double t_end, int n) {
    double dx[MAX_NX], xn[MAX_NX], en[MAX_NE];
    size_t i;
    while (!r->terminated && r->t < t_end - 1e-12 && n-- > 0) {
        int crossed = 0, term = 0, changed = 0;
        CHECK(set_time(u, r->t) == 0);
        CHECK(set_x(u, r->x, NX) == 0);
        CHECK(get_dx(u, dx, NX) == 0);
        for (i = 0; i < NX; i++) xn[i] = r->x[i] + H_STEP * dx[i];
        indicators_at(u, r->t + H_STEP, xn, en);
        for (i = 0; i < NE; i++) crossed |= r->e[i] > 0.0 && en[i] <= 0.0;
        if (!crossed) {
            r->t += H_STEP;
            memcpy(r->x, xn, sizeof(xn));
            memcpy(r->e, en, sizeof(en));
            CHECK(completed(u, &term) == 0);
            CHECK(!term);
            record(r);
            continue;
        }
        {
            double a = 0.0, b = H_STEP, xm[MAX_NX], em[MAX_NE];
            while (b - a > 1e-13) {
                double m = 0.5 * (a + b);
                int any = 0;
                for (i = 0; i < NX; i++) xm[i] = r->x[i] + m * dx[i];
                indicators_at(u, r->t + m, xm, em);
                for (i = 0; i < NE; i++) any |= r->e[i] > 0.0 && em[i] <= 0.0;
                if (any)
                    b = m;
                else
                    a = m;
            }
            for (i = 0; i < NX; i++) r->x[i] += b * dx[i];
            r->t += b;
        }
        CHECK(set_time(u, r->t) == 0);
        CHECK(set_x(u, r->x, NX) == 0);
        CHECK(enter_event(u) == 0);
        CHECK(update(u, &term, &changed) == 0);
        if (changed) CHECK(get_x(u, r->x, NX) == 0);
        if (r->n_events < MAX_EVENTS) {
            r->ev_t[r->n_events] = r->t;
            r->ev_flags[r->n_events] = term | (changed << 1);
        }
        r->n_events++;
        record(r);
        CHECK(enter_ct(u) == 0);
        if (term) {
            r->terminated = 1;
            break;
        }
        CHECK(get_e(u, r->e, NE) == 0);
    }
}

static run *new_run(void) {
    run *r = (run *)calloc(1, sizeof(run));
    CHECK(r != NULL);
    if (!r) exit(1);
    return r;
}

/* the same as b from step `from` of a on */
static int same_tail(const run *a, const run *b, int from) {
    int n = a->steps < MAX_STEPS ? a->steps : MAX_STEPS;
    return a->steps == b->steps && a->t == b->t && a->n_events == b->n_events &&
           a->terminated == b->terminated &&
           memcmp(a->traj[from], b->traj[from], (size_t)(n - from) * sizeof(a->traj[0])) == 0 &&
           memcmp(a->ev_t, b->ev_t, sizeof(a->ev_t)) == 0 &&
           memcmp(a->ev_flags, b->ev_flags, sizeof(a->ev_flags)) == 0;
}

#endif
