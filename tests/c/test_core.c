/*
 * test_core.c -- the simulation core used from a plain C program, with no FMI at all: the
 * way `gyrowheel export-c` embeds a model.  One translation unit: the toy oscillator
 * (pos' = vel, vel' = -k pos, event "hit" when pos falls to pos_lim), the core (gw_core.c)
 * and this driver; built WITHOUT the FMI headers on the include path.  A user allocator
 * counts every allocation, a user logger keeps the messages.  Checks the core API of
 * docs/runtime.md: create, parameters and settings, initialise, advance (against the exact
 * solution), outputs, a terminating event, save/restore, errors, two instances, out of memory.
 */
#define GW_UNITY_BUILD 1
#include "toy_oscillator.c"
#include "gw_core.c"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "checks.h"

/* ---- the user's allocator: counts, never zeroes, fails on request ------------------------- */
typedef struct {
    size_t size;
    double align_;
} block;
static long live = 0, total = 0;
static int fail_after = -1;

static void *user_allocate(size_t n, size_t size) {
    block *b;
    if (fail_after == 0) {
        fail_after = -1;
        return NULL;
    }
    if (fail_after > 0) fail_after--;
    b = (block *)malloc(sizeof(block) + n * size);
    if (!b) return NULL;
    memset(b + 1, 0x5A, n * size); /* the core must zero what it needs */
    b->size = n * size;
    live++;
    total++;
    return b + 1;
}

static void user_free(void *p) {
    if (!p) return;
    live--;
    free((block *)p - 1);
}

/* ---- the user's logger -------------------------------------------------------------------- */
static char log_text[65536];
static int env_token = 42;

static void user_logger(void *env, const char *name, gw_status status, const char *category,
                        const char *message) {
    size_t len = strlen(log_text);
    CHECK(env == &env_token);
    snprintf(log_text + len, sizeof(log_text) - len, "[%s|%d|%s] %s\n", name, (int)status,
             category, message);
    if (getenv("GW_TEST_ECHO")) fprintf(stderr, "[%s|%d|%s] %s\n", name, (int)status, category,
                                        message);
}
static int logged(const char *s) { return strstr(log_text, s) != NULL; }

static const gw_callbacks callbacks = {user_logger, user_allocate, user_free, &env_token};

/* value references of toy_oscillator.c */
enum { VR_K = 0, VR_POS_LIM = 1, VR_POS = 10, VR_VEL = 11, VR_ENERGY = 20, VR_REL_TOL = 41,
       VR_ABS_TOL = 42, VR_HIT = 50 };

static void set(gw_instance *I, unsigned int vr, double value) {
    const gw_variable *v = gw_variable_find(I->m, vr);
    CHECK(v != NULL);
    if (v) gw_value_set(I, v, value);
}
static double get(gw_instance *I, unsigned int vr) {
    const gw_variable *v = gw_variable_find(I->m, vr);
    CHECK(v != NULL);
    CHECK(gw_update_outputs(I, "get") == GW_OK);
    return v ? gw_value_get(I, v) : NAN;
}

/* k, tight tolerances, initialised at t = 0 */
static gw_instance *start(double k, double pos_lim) {
    gw_instance *I = gw_instance_new(&GW_MODEL, "core", &callbacks, 0);
    CHECK(I != NULL);
    if (!I) return NULL;
    CHECK(I->in_setup);
    set(I, VR_K, k);
    set(I, VR_POS_LIM, pos_lim);
    set(I, VR_REL_TOL, 1e-11);
    set(I, VR_ABS_TOL, 1e-13);
    CHECK(gw_setup_experiment(I, "setup", 0, 0.0, 0.0, 0, 0.0) == GW_OK);
    CHECK(get(I, VR_POS) == 1.0); /* set-up phase: outputs from init(s, p) */
    CHECK(gw_initialize(I, "initialize") == GW_OK);
    CHECK(!I->in_setup);
    return I;
}

static void exact_solution(void) {
    gw_instance *I = start(4.0, -2.0);
    int i;
    for (i = 1; i <= 20; i++) {
        const double t = 0.1 * i;
        CHECK(gw_advance(I, "advance", t) == GW_OK);
        CHECK(I->t == t);
        CHECK_NEAR(get(I, VR_POS), cos(2.0 * t), 1e-9);
        CHECK_NEAR(get(I, VR_VEL), -2.0 * sin(2.0 * t), 2e-9);
        CHECK_NEAR(get(I, VR_ENERGY), 2.0, 1e-9);
    }
    CHECK(I->n_accepted > 0 && I->n_rhs > I->n_accepted);
    gw_instance_free(I);
}

static void save_and_restore(void) {
    gw_instance *I = start(4.0, -2.0);
    const int front[2] = {7, -3};
    int back[2] = {0, 0};
    unsigned char *buf;
    size_t size;
    double pos_a, pos_b;
    CHECK(gw_advance(I, "advance", 1.0) == GW_OK);
    size = gw_state_size(I);
    buf = (unsigned char *)malloc(size);
    gw_state_write(I, front, buf);
    CHECK(gw_advance(I, "advance", 1.5) == GW_OK);
    pos_a = get(I, VR_POS);
    CHECK(gw_state_check(I, "restore", buf, size) == 1);
    gw_state_front(I, buf, back);
    CHECK(back[0] == 7 && back[1] == -3);
    gw_state_apply(I, buf);
    CHECK(I->t == 1.0);
    CHECK(gw_advance(I, "advance", 1.5) == GW_OK);
    pos_b = get(I, VR_POS);
    CHECK(pos_a == pos_b); /* bit-identical: the step size is part of the state */
    log_text[0] = '\0';
    CHECK(gw_state_check(I, "restore", buf, size - 1) == 0);
    CHECK(logged("restore: FMU state has"));
    buf[0] = 'X';
    CHECK(gw_state_check(I, "restore", buf, size) == 0);
    CHECK(logged("not a gyrowheel FMU state"));
    free(buf);
    gw_instance_free(I);
}

static void terminating_event(void) {
    gw_instance *I = start(4.0, 0.5); /* cos(2t) = 0.5 at t = pi/6 */
    const double te = acos(0.5) / 2.0;
    CHECK(get(I, VR_HIT) == 0.0);
    CHECK(gw_set_logging(I, "logging", 1, 0, NULL) == GW_OK);
    log_text[0] = '\0';
    CHECK(gw_advance(I, "advance", 1.0) == GW_DISCARD);
    CHECK(I->terminated);
    CHECK_NEAR(I->t, te, 1e-9);
    CHECK_NEAR(I->last_successful_time, te, 1e-9);
    CHECK(get(I, VR_HIT) == 1.0);
    CHECK(I->flags[0] && I->t_events[0] == I->t); /* the event's time */
    CHECK_NEAR(get(I, VR_POS), 0.5, 1e-8);
    CHECK(logged("event hit at t="));
    gw_instance_free(I);
}

static void errors(void) {
    gw_instance *I = gw_instance_new(&GW_MODEL, "bad", &callbacks, 0);
    const char *cats[1] = {"logNothing"};
    log_text[0] = '\0';
    set(I, VR_K, -1.0);
    CHECK(gw_initialize(I, "initialize") == GW_ERROR);
    CHECK(logged("[bad|3|logStatusError] initialize: k must be > 0"));
    CHECK(I->in_setup); /* still configurable */
    set(I, VR_K, 1.0);
    CHECK(gw_setup_experiment(I, "setup", 1, -1.0, 0.0, 0, 0.0) == GW_ERROR);
    CHECK(logged("setup: tolerance -1 is outside the valid range of a relative tolerance"));
    CHECK(gw_set_logging(I, "logging", 1, 1, cats) == GW_ERROR);
    CHECK(logged("unknown log category \"logNothing\""));
    CHECK(gw_initialize(I, "initialize") == GW_OK);
    gw_instance_reset(I);
    CHECK(I->in_setup && I->t == 0.0 && I->p[0] == 1.0);
    gw_instance_free(I);
}

static void two_instances(void) {
    gw_instance *a = start(1.0, -2.0), *b = start(9.0, -2.0);
    int i;
    for (i = 1; i <= 10; i++) {
        CHECK(gw_advance(a, "advance", 0.2 * i) == GW_OK);
        CHECK(gw_advance(b, "advance", 0.2 * i) == GW_OK);
        CHECK_NEAR(get(a, VR_POS), cos(0.2 * i), 1e-9);
        CHECK_NEAR(get(b, VR_POS), cos(0.6 * i), 1e-8);
    }
    gw_instance_free(a);
    gw_instance_free(b);
}

static void out_of_memory(void) {
    int k, ok = 0;
    for (k = 0; k < 1000 && !ok; k++) {
        gw_instance *I;
        fail_after = k;
        I = gw_instance_new(&GW_MODEL, "oom", &callbacks, 0);
        fail_after = -1;
        CHECK(I != NULL || live == 0);
        if (I) {
            ok = 1;
            gw_instance_free(I);
        }
    }
    CHECK(ok && k > 10);
}

/* gw_instance_new_with: every allocation through an allocator with a context pointer */
typedef struct {
    long live, total;
} arena_counts;
static void *ctx_allocate(void *ctx, size_t n, size_t size) {
    ((arena_counts *)ctx)->live++;
    ((arena_counts *)ctx)->total++;
    return malloc(n * size);
}
static void ctx_free(void *ctx, void *p) {
    ((arena_counts *)ctx)->live--;
    free(p);
}
static void allocator_with_context(void) {
    arena_counts counts = {0, 0};
    const gw_allocator alloc = {ctx_allocate, ctx_free, &counts};
    const gw_callbacks no_alloc = {user_logger, NULL, NULL, &env_token};
    const long before = total;
    gw_instance *I = gw_instance_new_with(&GW_MODEL, "ctx", &no_alloc, &alloc, 0);
    CHECK(I != NULL);
    if (!I) return;
    CHECK(counts.total > 10 && counts.live == counts.total && total == before);
    CHECK(gw_initialize(I, "initialize") == GW_OK);
    CHECK(gw_advance(I, "advance", 0.5) == GW_OK);
    CHECK(counts.total == counts.live); /* nothing allocated while integrating */
    gw_instance_free(I);
    CHECK(counts.live == 0);
}

int main(void) {
    exact_solution();
    save_and_restore();
    terminating_event();
    errors();
    two_instances();
    out_of_memory();
    allocator_with_context();
    CHECK(live == 0);
    fprintf(stderr, "test_core: %d checks, %d failures, %ld allocations\n", h_checks, h_failures,
            total);
    return h_failures == 0 ? 0 : 1;
}
