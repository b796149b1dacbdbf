/*
 * test_capi.c -- the exported C API of paper_earth (`gyrowheel export-c`) from a plain C
 * program, the way a user embeds it: linked against the export's paper_earth.c, compiled
 * strictly, with ASan+UBSan and under valgrind (tests/test_export_c.py).  Checks
 *   names/units table and defaults; create by index and by name; bad input through every door
 *   (NaN / infinite / refused values, unknown names, advancing backwards, NULL pointers, indices
 *   out of range) with the right code and message; the instance after a failed create;
 *   save/restore bit for bit, and every corrupt state buffer refused (each single bit flip,
 *   truncation, a NaN or another model's guid with a valid checksum) with the instance
 *   unchanged; the fall as a
 *   terminating event with its time; the logger; a user allocator with a context pointer (no
 *   allocation while advancing, out of memory at every allocation); one RK4 step per 1 ms
 *   advance at t = 1000 s; the budget of internal steps of one advance; two threads with one instance each, bit-identical to one thread.
 */
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "paper_earth.h"

#include "checks.h"

#define PI 3.14159265358979323846

#define CHECK_MSG(w, text)                                                                    \
    do {                                                                                      \
        const char *msg_ = paper_earth_last_error(w);                                         \
        h_checks++;                                                                           \
        if (!strstr(msg_, (text))) {                                                          \
            h_failures++;                                                                     \
            fprintf(stderr, "%s:%d: last_error \"%s\" lacks \"%s\"\n", __FILE__, __LINE__,    \
                    msg_, (text));                                                            \
        }                                                                                     \
    } while (0)

static paper_earth *defaults(void) {
    paper_earth *w = NULL;
    CHECK(paper_earth_create(NULL, NULL, NULL, NULL, &w) == GYROWHEEL_OK);
    return w;
}

/* ---- the names/units table and the defaults ----------------------------------------------- */
static void table(void) {
    double p[PAPER_EARTH_NP], s[PAPER_EARTH_NI];
    gyrowheel_settings st;
    CHECK(paper_earth_count(GYROWHEEL_KIND_PARAMETER) == PAPER_EARTH_NP);
    CHECK(paper_earth_count(GYROWHEEL_KIND_OUTPUT) == PAPER_EARTH_NY && PAPER_EARTH_NY == 12);
    CHECK(paper_earth_count(GYROWHEEL_KIND_STATE) == 8 && PAPER_EARTH_NE == 1);
    CHECK(paper_earth_count((gyrowheel_kind)9) == -1);
    CHECK(strcmp(paper_earth_variable(GYROWHEEL_KIND_OUTPUT, PAPER_EARTH_Y_energy)->name, "energy") == 0);
    CHECK(strcmp(paper_earth_variable(GYROWHEEL_KIND_OUTPUT, PAPER_EARTH_Y_energy)->unit, "J") == 0);
    CHECK(strcmp(paper_earth_variable(GYROWHEEL_KIND_PARAMETER, PAPER_EARTH_P_M)->unit, "kg") == 0);
    CHECK(strcmp(paper_earth_variable(GYROWHEEL_KIND_STATE, PAPER_EARTH_X_beta_dot)->unit, "rad/s") == 0);
    CHECK(strcmp(paper_earth_variable(GYROWHEEL_KIND_EVENT, PAPER_EARTH_E_fallen)->name, "fallen") == 0);
    CHECK(paper_earth_variable(GYROWHEEL_KIND_OUTPUT, PAPER_EARTH_NY) == NULL);
    CHECK(paper_earth_variable(GYROWHEEL_KIND_OUTPUT, -1) == NULL);
    CHECK(paper_earth_index(GYROWHEEL_KIND_INITIAL, "gamma_dot") == PAPER_EARTH_I_gamma_dot);
    CHECK(paper_earth_index(GYROWHEEL_KIND_PARAMETER, "Mass") == -1);
    CHECK(paper_earth_index(GYROWHEEL_KIND_PARAMETER, NULL) == -1);
    paper_earth_default_parameters(p);
    paper_earth_default_initial(s);
    paper_earth_default_settings(&st);
    CHECK(p[PAPER_EARTH_P_M] == 2.0 && p[PAPER_EARTH_P_R] == 0.17 && p[PAPER_EARTH_P_g] == 9.81);
    CHECK(s[PAPER_EARTH_I_gamma_dot] == 6.0 && fabs(s[PAPER_EARTH_I_beta] - 80.0 * PI / 180.0) < 1e-15);
    /* the scene names no solver: auto, with max_step the run's length */
    CHECK(st.solver == GYROWHEEL_SOLVER_AUTO && st.rel_tol == 1e-8 && st.max_step == 20.0);
    CHECK(PAPER_EARTH_STOP_TIME == 20.0 && PAPER_EARTH_OUTPUT_INTERVAL == 0.01);
    CHECK(strcmp(paper_earth_status_string(GYROWHEEL_ERR_TIME),
                 paper_earth_status_string(GYROWHEEL_ERR_STATE)) != 0);
    CHECK(strcmp(paper_earth_status_string((gyrowheel_status)42), "unknown status") == 0);
}

/* ---- create by index and by name, reading ----------------------------------------------- */
static void create_and_read(void) {
    static const char *const names[] = {"gamma_dot", "g", "solver", "max_step"};
    const double values[] = {8.0, 1.62, 2.0, 1e-3};
    paper_earth *w = defaults(), *v = NULL;
    double x[PAPER_EARTH_NX], y[PAPER_EARTH_NY], value;
    gyrowheel_statistics stats;
    int fired = -1;
    double te = 0.0;
    CHECK(paper_earth_time(w) == 0.0 && !paper_earth_terminated(w));
    CHECK(paper_earth_get_states(w, x) == GYROWHEEL_OK && x[PAPER_EARTH_X_gamma_dot] == 6.0);
    CHECK(paper_earth_get_outputs(w, y) == GYROWHEEL_OK);
    CHECK_NEAR(y[PAPER_EARTH_Y_z], 0.17 * sin(80.0 * PI / 180.0), 1e-15);
    CHECK_NEAR(y[PAPER_EARTH_Y_vx], 0.17 * 6.0, 1e-15); /* rolling: vx = R gamma_dot */
    CHECK(paper_earth_get_event(w, PAPER_EARTH_E_fallen, &fired, &te) == GYROWHEEL_OK);
    CHECK(fired == 0 && isnan(te));
    CHECK(paper_earth_advance(w, 1.0) == GYROWHEEL_OK && paper_earth_time(w) == 1.0);
    CHECK(paper_earth_get_by_name(w, "energy", &value) == GYROWHEEL_OK);
    CHECK_NEAR(value, y[PAPER_EARTH_Y_energy], 1e-8 * fabs(value)); /* conservative */
    CHECK(paper_earth_get(w, GYROWHEEL_KIND_STATE, PAPER_EARTH_X_beta, &value) == GYROWHEEL_OK);
    CHECK(paper_earth_get_outputs(w, y) == GYROWHEEL_OK && value == y[PAPER_EARTH_Y_beta]);
    CHECK(paper_earth_get_statistics(w, &stats) == GYROWHEEL_OK);
    /* auto integrates with taylor here: one right-hand side per step for its defect check */
    CHECK(stats.steps_accepted > 0 && stats.rhs_evaluations >= stats.steps_accepted);
    paper_earth_free(w);

    CHECK(paper_earth_create_named(4, names, values, NULL, &v) == GYROWHEEL_OK);
    CHECK(paper_earth_get(v, GYROWHEEL_KIND_PARAMETER, PAPER_EARTH_P_g, &value) == GYROWHEEL_OK &&
          value == 1.62);
    CHECK(paper_earth_get_by_name(v, "gamma_dot", &value) == GYROWHEEL_OK && value == 8.0);
    CHECK(paper_earth_advance(v, 0.01) == GYROWHEEL_OK);
    CHECK(paper_earth_get_statistics(v, &stats) == GYROWHEEL_OK);
    /* rk4, h = 1 ms: 4 evaluations a step; the first k1 from the initialisation, and f at the
     * last step's end (the event indicators' slopes there, gw_events.c; the next step's k1) */
    CHECK(stats.steps_accepted == 10 && stats.rhs_evaluations == 40);
    CHECK(paper_earth_reset(v, NULL, NULL, NULL) == GYROWHEEL_OK); /* back to the scene */
    CHECK(paper_earth_get_by_name(v, "gamma_dot", &value) == GYROWHEEL_OK && value == 6.0);
    paper_earth_free(v);
}

/* ---- bad input: code and message ------------------------------------------------------------ */
static void bad_values(void) {
    double p[PAPER_EARTH_NP], s[PAPER_EARTH_NI];
    gyrowheel_settings st;
    paper_earth *w = NULL;
    const char *name[2];
    double value[2];

    paper_earth_default_parameters(p);
    p[PAPER_EARTH_P_M] = NAN;
    CHECK(paper_earth_create(p, NULL, NULL, NULL, &w) == GYROWHEEL_ERR_NOT_FINITE);
    CHECK(w != NULL);
    CHECK_MSG(w, "paper_earth_create: parameter M is not finite (nan)");
    CHECK(paper_earth_advance(w, 1.0) == GYROWHEEL_ERR_NOT_READY); /* only reset helps */
    CHECK_MSG(w, "paper_earth_advance: the instance is not initialised");
    p[PAPER_EARTH_P_M] = -1.0;
    CHECK(paper_earth_reset(w, p, NULL, NULL) == GYROWHEEL_ERR_INVALID);
    CHECK_MSG(w, "paper_earth_reset: M (mass) must be > 0");
    CHECK(paper_earth_reset(w, NULL, NULL, NULL) == GYROWHEEL_OK);
    CHECK(paper_earth_advance(w, 0.1) == GYROWHEEL_OK);

    paper_earth_default_parameters(p);
    paper_earth_default_initial(s);
    s[PAPER_EARTH_I_beta] = INFINITY;
    CHECK(paper_earth_reset(w, NULL, s, NULL) == GYROWHEEL_ERR_NOT_FINITE);
    CHECK_MSG(w, "initial value beta is not finite (inf)");
    s[PAPER_EARTH_I_beta] = 0.5 * p[PAPER_EARTH_P_beta_min]; /* below beta_min: already flat */
    CHECK(paper_earth_reset(w, NULL, s, NULL) == GYROWHEEL_ERR_INVALID);
    CHECK_MSG(w, "already flat");

    paper_earth_default_settings(&st);
    st.solver = 9;
    CHECK(paper_earth_reset(w, NULL, NULL, &st) == GYROWHEEL_ERR_INVALID);
    CHECK_MSG(w, "unknown solver 9; valid: 1 euler, 2 rk4, 3 dopri5");
    paper_earth_default_settings(&st);
    st.rel_tol = -1.0;
    CHECK(paper_earth_reset(w, NULL, NULL, &st) == GYROWHEEL_ERR_INVALID);
    CHECK_MSG(w, "rel_tol = -1 must be > 0");
    st.rel_tol = 2.0; /* > 0, but outside the core's range: refused by the initialisation */
    CHECK(paper_earth_reset(w, NULL, NULL, &st) == GYROWHEEL_ERR_INVALID);
    CHECK_MSG(w, "rel_tol = 2 is outside its valid range [2.2204460492503131e-15, 1]");
    st.rel_tol = 1e-8;
    st.abs_tol = 1e-40;
    CHECK(paper_earth_reset(w, NULL, NULL, &st) == GYROWHEEL_ERR_INVALID);
    CHECK_MSG(w, "abs_tol = 1e-40 is outside its valid range [1e-30, 1] or 0");
    st.abs_tol = 0.0; /* valid: follows rel_tol (rel_tol / 100) */
    CHECK(paper_earth_reset(w, NULL, NULL, &st) == GYROWHEEL_OK);
    st.max_step = NAN;
    CHECK(paper_earth_reset(w, NULL, NULL, &st) == GYROWHEEL_ERR_NOT_FINITE);
    CHECK_MSG(w, "max_step is not finite");

    name[0] = "Mass";
    value[0] = 2.0;
    CHECK(paper_earth_reset_named(w, 1, name, value) == GYROWHEEL_ERR_NAME);
    CHECK_MSG(w, "paper_earth_reset_named: unknown name \"Mass\"; parameters: M, R, k_diam");
    name[0] = "R";
    value[0] = NAN;
    CHECK(paper_earth_reset_named(w, 1, name, value) == GYROWHEEL_ERR_NOT_FINITE);
    CHECK_MSG(w, "parameter R is not finite");
    name[0] = name[1] = "g";
    value[0] = value[1] = 1.0;
    CHECK(paper_earth_reset_named(w, 2, name, value) == GYROWHEEL_ERR_ARGUMENT);
    CHECK_MSG(w, "\"g\" is given twice");
    name[0] = "solver";
    value[0] = 2.5;
    CHECK(paper_earth_reset_named(w, 1, name, value) == GYROWHEEL_ERR_INVALID);
    CHECK_MSG(w, "solver 2.5 is not a solver code");
    paper_earth_free(w);

    /* the same through create_named: a failed create still gives an instance to ask */
    name[0] = "Mass";
    w = NULL;
    CHECK(paper_earth_create_named(1, name, value, NULL, &w) == GYROWHEEL_ERR_NAME && w);
    CHECK_MSG(w, "unknown name \"Mass\"");
    paper_earth_free(w);
}

static void bad_calls(void) {
    paper_earth *w = defaults();
    double x[PAPER_EARTH_NX], v;
    gyrowheel_allocator broken = {NULL, NULL, NULL};
    paper_earth *none = NULL;
    CHECK(paper_earth_advance(w, 1.0) == GYROWHEEL_OK);
    CHECK(paper_earth_get_states(w, x) == GYROWHEEL_OK);
    CHECK(paper_earth_advance(w, 0.5) == GYROWHEEL_ERR_TIME);
    CHECK_MSG(w, "paper_earth_advance: cannot advance backwards, from t=1 to 0.5");
    CHECK(paper_earth_time(w) == 1.0);
    CHECK(paper_earth_advance(w, NAN) == GYROWHEEL_ERR_TIME);
    CHECK_MSG(w, "time nan is not finite");
    CHECK(paper_earth_advance(w, INFINITY) == GYROWHEEL_ERR_TIME);
    CHECK(paper_earth_advance(w, 1.0) == GYROWHEEL_OK); /* no time passes: nothing happens */
    CHECK(paper_earth_get_states(w, x) == GYROWHEEL_OK);
    /* inputs: this model has none */
    CHECK(paper_earth_set_input(w, 0, 1.0) == GYROWHEEL_ERR_ARGUMENT);
    CHECK_MSG(w, "input index 0 out of range");
    CHECK(paper_earth_set_input_by_name(w, "tilt_cmd", 0.1) == GYROWHEEL_ERR_NAME);
    CHECK_MSG(w, "no input \"tilt_cmd\"; inputs: none");
    CHECK(paper_earth_set_inputs(w, NULL) == GYROWHEEL_OK);
    /* reading */
    CHECK(paper_earth_get(w, GYROWHEEL_KIND_OUTPUT, PAPER_EARTH_NY, &v) == GYROWHEEL_ERR_ARGUMENT);
    CHECK(paper_earth_get(w, (gyrowheel_kind)7, 0, &v) == GYROWHEEL_ERR_ARGUMENT);
    CHECK(paper_earth_get(w, GYROWHEEL_KIND_OUTPUT, 0, NULL) == GYROWHEEL_ERR_ARGUMENT);
    CHECK(paper_earth_get_by_name(w, "omega", &v) == GYROWHEEL_ERR_NAME);
    CHECK_MSG(w, "no output, state, input, parameter or event \"omega\"");
    CHECK(paper_earth_get_event(w, 1, NULL, NULL) == GYROWHEEL_ERR_ARGUMENT);
    CHECK(paper_earth_get_states(w, NULL) == GYROWHEEL_ERR_ARGUMENT);
    /* NULL instances */
    CHECK(paper_earth_advance(NULL, 1.0) == GYROWHEEL_ERR_ARGUMENT);
    CHECK(isnan(paper_earth_time(NULL)) && paper_earth_terminated(NULL) == 0);
    CHECK(strstr(paper_earth_last_error(NULL), "no instance") != NULL);
    CHECK(paper_earth_create(NULL, NULL, NULL, NULL, NULL) == GYROWHEEL_ERR_ARGUMENT);
    CHECK(paper_earth_create(NULL, NULL, NULL, &broken, &none) == GYROWHEEL_ERR_ARGUMENT && !none);
    CHECK(paper_earth_state_size(NULL) == 0);
    paper_earth_free(NULL);
    paper_earth_free(w);
}

/* ---- saving and restoring ------------------------------------------------------------------ */
/* the core state's trailing CRC-32 (IEEE 802.3, as zlib's crc32) over every byte before it,
 * recomputed here so that a crafted buffer passes the checksum and meets the value checks */
static void seal(unsigned char *p, size_t n) {
    uint32_t crc = 0xFFFFFFFFu;
    size_t i;
    int k;
    for (i = 0; i + 4 < n; i++) {
        crc ^= p[i];
        for (k = 0; k < 8; k++) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    crc ^= 0xFFFFFFFFu;
    memcpy(p + n - 4, &crc, 4);
}

/* offset of the first 8 bytes equal to what (after the first 24), or size if none */
static size_t find8(const unsigned char *b, size_t size, const void *what) {
    size_t i;
    for (i = 24; i + 8 <= size; i++)
        if (memcmp(b + i, what, 8) == 0) return i;
    return size;
}

/* buf with the first 8 bytes equal to find replaced by value and the checksum made valid: the
 * value checks must refuse it with msg and leave the instance (at t = 3) as it was */
static void crafted_refused(paper_earth *w, const unsigned char *buf, unsigned char *bad,
                            size_t size, const void *find, double value, const char *msg) {
    size_t i;
    memcpy(bad, buf, size);
    i = find8(bad, size, find);
    CHECK(i < size);
    if (i >= size) return;
    memcpy(bad + i, &value, 8);
    seal(bad, size);
    CHECK(paper_earth_restore_state(w, bad, size) == GYROWHEEL_ERR_STATE);
    CHECK_MSG(w, msg);
    CHECK(paper_earth_time(w) == 3.0);
}

static void save_restore(void) {
    paper_earth *w = defaults();
    const size_t size = paper_earth_state_size(w);
    unsigned char *buf = (unsigned char *)malloc(size), *bad = (unsigned char *)malloc(size);
    double y3[PAPER_EARTH_NY], y[PAPER_EARTH_NY], x2[PAPER_EARTH_NX], x[PAPER_EARTH_NX], nan = NAN;
    size_t i, refused = 0;
    CHECK(size > 24 && buf && bad);
    if (!buf || !bad) return;
    CHECK(paper_earth_advance(w, 2.0) == GYROWHEEL_OK);
    CHECK(paper_earth_save_state(w, buf, size - 1) == GYROWHEEL_ERR_BUFFER);
    CHECK_MSG(w, "a state needs");
    CHECK(paper_earth_save_state(w, buf, size) == GYROWHEEL_OK);
    CHECK(paper_earth_get_states(w, x2) == GYROWHEEL_OK);
    CHECK(paper_earth_advance(w, 3.0) == GYROWHEEL_OK && paper_earth_get_outputs(w, y3) == 0);
    CHECK(paper_earth_restore_state(w, buf, size) == GYROWHEEL_OK && paper_earth_time(w) == 2.0);
    CHECK(paper_earth_advance(w, 3.0) == GYROWHEEL_OK && paper_earth_get_outputs(w, y) == 0);
    CHECK(memcmp(y, y3, sizeof(y)) == 0); /* bit for bit */
    /* every single bit flip is refused, the instance unchanged (at t = 3) */
    for (i = 0; i < size; i++) {
        memcpy(bad, buf, size);
        bad[i] ^= (unsigned char)(1u << (i % 8));
        if (paper_earth_restore_state(w, bad, size) == GYROWHEEL_ERR_STATE) refused++;
    }
    CHECK(refused == size);
    CHECK(paper_earth_time(w) == 3.0 && paper_earth_get_outputs(w, y) == 0);
    CHECK(memcmp(y, y3, sizeof(y)) == 0);
    CHECK(paper_earth_restore_state(w, buf, size - 1) == GYROWHEEL_ERR_STATE);
    CHECK_MSG(w, "header says");
    memcpy(bad, buf, size);
    bad[0] = 'X';
    CHECK(paper_earth_restore_state(w, bad, size) == GYROWHEEL_ERR_STATE);
    CHECK_MSG(w, "bad magic");
    /* a NaN state, a budget of internal steps no run can have (the default 1e6 made 0.5), each
     * with a valid checksum: refused by the value checks */
    crafted_refused(w, buf, bad, size, &x2[PAPER_EARTH_X_beta], nan, "FMU state holds an invalid x[");
    CHECK(paper_earth_get_states(w, x) == GYROWHEEL_OK && !isnan(x[PAPER_EARTH_X_beta]));
    /* the wheel past the fall (beta = -0.5 below beta_min, or 1e300: sin(beta) - sin(beta_min)
     * < 0) with the fall not fired and its stored indicator left positive: no step ends there */
    crafted_refused(w, buf, bad, size, &x2[PAPER_EARTH_X_beta], -0.5, "event fall has indicator");
    crafted_refused(w, buf, bad, size, &x2[PAPER_EARTH_X_beta], 1e300, "event fall has indicator");
    {
        const double budget = 1e6;
        crafted_refused(w, buf, bad, size, &budget, 0.5,
                        "max_internal_steps = 0.5 must be a whole number from 1 to 2147483647");
    }
    /* another model of the same sizes (another guid), with a valid checksum */
    memcpy(bad, buf, size);
    i = find8(bad, size, PAPER_EARTH_GUID);
    CHECK(i < size);
    if (i < size) {
        bad[i + 1] = bad[i + 1] == 'f' ? 'e' : 'f';
        seal(bad, size);
        CHECK(paper_earth_restore_state(w, bad, size) == GYROWHEEL_ERR_STATE);
        CHECK_MSG(w, "belongs to another model (token mismatch");
        CHECK(paper_earth_time(w) == 3.0);
    }
    CHECK(paper_earth_restore_state(w, NULL, size) == GYROWHEEL_ERR_ARGUMENT);
    /* a state brings a failed instance back */
    CHECK(paper_earth_reset(w, NULL, NULL, NULL) == GYROWHEEL_OK);
    {
        double p[PAPER_EARTH_NP];
        paper_earth_default_parameters(p);
        p[PAPER_EARTH_P_R] = -1.0;
        CHECK(paper_earth_reset(w, p, NULL, NULL) == GYROWHEEL_ERR_INVALID);
        CHECK(paper_earth_save_state(w, bad, size) == GYROWHEEL_ERR_NOT_READY);
    }
    CHECK(paper_earth_restore_state(w, buf, size) == GYROWHEEL_OK && paper_earth_time(w) == 2.0);
    CHECK(paper_earth_advance(w, 3.0) == GYROWHEEL_OK && paper_earth_get_outputs(w, y) == 0);
    CHECK(memcmp(y, y3, sizeof(y)) == 0);
    free(buf);
    free(bad);
    paper_earth_free(w);
}

/* ---- the fall: a terminating event and its time; the logger ------------------------------- */
static char log_text[8192];
static void logger(void *env, gyrowheel_log_level level, const char *message) {
    size_t len = strlen(log_text);
    CHECK(env == (void *)log_text);
    snprintf(log_text + len, sizeof(log_text) - len, "[%d] %s\n", (int)level, message);
}

static void fall(void) {
    static const char *const names[] = {"gamma_dot"};
    const double slow[] = {0.0}; /* no spin: it falls like a coin */
    paper_earth *w = NULL;
    double y[PAPER_EARTH_NY], te = 0.0, t, beta_min = 0.0;
    int fired = 0, k;
    gyrowheel_status st = GYROWHEEL_OK;
    CHECK(paper_earth_create_named(1, names, slow, NULL, &w) == GYROWHEEL_OK);
    CHECK(paper_earth_set_logger(w, logger, log_text) == GYROWHEEL_OK);
    for (k = 1; k <= 2000 && st == GYROWHEEL_OK; k++) st = paper_earth_advance(w, 0.01 * k);
    CHECK(st == GYROWHEEL_TERMINATED && paper_earth_terminated(w));
    t = paper_earth_time(w);
    CHECK(t > 0.0 && t < 20.0 && t < 0.01 * (k - 1) && t > 0.01 * (k - 2));
    CHECK(paper_earth_get_event(w, PAPER_EARTH_E_fallen, &fired, &te) == GYROWHEEL_OK);
    CHECK(fired == 1 && te == t);
    CHECK(paper_earth_get_outputs(w, y) == GYROWHEEL_OK);
    CHECK(paper_earth_get(w, GYROWHEEL_KIND_PARAMETER, PAPER_EARTH_P_beta_min, &beta_min) == 0);
    CHECK_NEAR(sin(y[PAPER_EARTH_Y_beta]), sin(beta_min), 1e-9); /* at beta_min */
    CHECK(strstr(log_text, "event fall at t=") != NULL);
    CHECK(paper_earth_advance(w, 30.0) == GYROWHEEL_ERR_TERMINATED);
    CHECK_MSG(w, "paper_earth_advance: the run ended at t=");
    CHECK_MSG(w, "(fallen); reset or restore a saved state");
    CHECK(strstr(log_text, "[0] event fall") != NULL);
    CHECK(paper_earth_reset(w, NULL, NULL, NULL) == GYROWHEEL_OK && !paper_earth_terminated(w));
    CHECK(paper_earth_get_event(w, 0, &fired, &te) == GYROWHEEL_OK && fired == 0 && isnan(te));
    CHECK(paper_earth_set_logger(w, NULL, NULL) == GYROWHEEL_OK);
    paper_earth_free(w);
}

/* ---- a user allocator with a context pointer ------------------------------------------------ */
typedef struct {
    long live, total, fail_at; /* fail_at: the allocation number that returns NULL (-1: none) */
} arena;
static void *arena_allocate(void *ctx, size_t size) {
    arena *a = (arena *)ctx;
    void *p;
    if (a->total == a->fail_at) {
        a->total++;
        return NULL;
    }
    p = malloc(size);
    if (p) {
        memset(p, 0xA5, size); /* not zeroed */
        a->live++;
        a->total++;
    }
    return p;
}
static void arena_free(void *ctx, void *p) {
    if (!p) return;
    ((arena *)ctx)->live--;
    free(p);
}

static void allocator(void) {
    arena a = {0, 0, -1};
    const gyrowheel_allocator alloc = {arena_allocate, arena_free, &a};
    paper_earth *w = NULL;
    long k, n_create, failures = 0;
    CHECK(paper_earth_create(NULL, NULL, NULL, &alloc, &w) == GYROWHEEL_OK);
    n_create = a.total;
    CHECK(n_create > 20 && a.live == n_create);
    for (k = 1; k <= 500; k++) CHECK(paper_earth_advance(w, 0.002 * k) >= 0);
    CHECK(a.total == n_create); /* nothing allocated while advancing */
    paper_earth_free(w);
    CHECK(a.live == 0);
    for (k = 0; k < n_create; k++) { /* out of memory at every allocation of create */
        arena b = {0, 0, 0};
        const gyrowheel_allocator balloc = {arena_allocate, arena_free, &b};
        paper_earth *v = (paper_earth *)&b; /* create must overwrite it */
        b.fail_at = k;
        if (paper_earth_create(NULL, NULL, NULL, &balloc, &v) == GYROWHEEL_ERR_MEMORY && v == NULL)
            failures++;
        CHECK(b.live == 0);
    }
    CHECK(failures == n_create);
}

/* ---- real time: one RK4 step per 1 ms advance, also at t = 1000 s -------------------------- */
static void fixed_step_late(void) {
    gyrowheel_settings st;
    gyrowheel_statistics stats;
    paper_earth *w = NULL;
    int k;
    paper_earth_default_settings(&st);
    st.solver = GYROWHEEL_SOLVER_RK4;
    st.max_step = 1e-3;
    st.start_time = 1000.0;
    CHECK(paper_earth_create(NULL, NULL, &st, NULL, &w) == GYROWHEEL_OK);
    for (k = 1; k <= 3000; k++) CHECK(paper_earth_advance(w, 1000.0 + 1e-3 * k) == GYROWHEEL_OK);
    CHECK(paper_earth_get_statistics(w, &stats) == GYROWHEEL_OK);
    CHECK(stats.steps_accepted == 3000 && stats.rhs_evaluations == 4 * 3000); /* as above */
    paper_earth_free(w);
}

/* ---- the budget of internal steps of one advance (settings.max_internal_steps) ---------- */
static void budget(void) {
    static const char *const name[] = {"max_internal_steps"};
    gyrowheel_settings st;
    paper_earth *w = NULL;
    double value;
    paper_earth_default_settings(&st);
    CHECK(st.max_internal_steps == 1000000); /* the scene's, docs/fmi.md */
    st.solver = GYROWHEEL_SOLVER_RK4;
    st.max_step = 1e-3;
    st.max_internal_steps = 10;
    CHECK(paper_earth_create(NULL, NULL, &st, NULL, &w) == GYROWHEEL_OK);
    CHECK(paper_earth_advance(w, 0.01) == GYROWHEEL_OK); /* exactly 10 steps of 1 ms */
    CHECK(paper_earth_advance(w, 0.021) == GYROWHEEL_ERR_SIMULATION); /* 11: refused at once */
    CHECK_MSG(w, "more than max_internal_steps = 10");
    CHECK(paper_earth_time(w) == 0.01);
    st.solver = GYROWHEEL_SOLVER_DOPRI5; /* adaptive: stopped when the budget runs out */
    st.max_internal_steps = 5;
    CHECK(paper_earth_reset(w, NULL, NULL, &st) == GYROWHEEL_OK);
    CHECK(paper_earth_advance(w, 1.0) == GYROWHEEL_ERR_SIMULATION); /* > 20 steps of max_step */
    CHECK(paper_earth_time(w) == 0.0);
    st.max_internal_steps = 0; /* 0: the scene's budget */
    CHECK(paper_earth_reset(w, NULL, NULL, &st) == GYROWHEEL_OK);
    CHECK(paper_earth_advance(w, 1.0) == GYROWHEEL_OK);
    st.max_internal_steps = -1;
    CHECK(paper_earth_reset(w, NULL, NULL, &st) == GYROWHEEL_ERR_INVALID);
    CHECK_MSG(w, "max_internal_steps = -1 must lie in [1, 2147483647]");
    value = 2.5;
    CHECK(paper_earth_reset_named(w, 1, name, &value) == GYROWHEEL_ERR_INVALID);
    CHECK_MSG(w, "max_internal_steps = 2.5 must be a whole number");
    value = 3.0;
    CHECK(paper_earth_reset_named(w, 1, name, &value) == GYROWHEEL_OK);
    CHECK(paper_earth_advance(w, 1.0) == GYROWHEEL_ERR_SIMULATION);
    paper_earth_free(w);
}

/* ---- two threads, one instance each --------------------------------------------------------- */
typedef struct {
    double gamma_dot, y[PAPER_EARTH_NY];
    int status;
} job;
static void *run_job(void *arg) {
    job *j = (job *)arg;
    static const char *const names[] = {"gamma_dot"};
    paper_earth *w = NULL;
    int k;
    j->status = paper_earth_create_named(1, names, &j->gamma_dot, NULL, &w);
    for (k = 1; k <= 300 && j->status >= 0; k++) j->status = paper_earth_advance(w, 0.01 * k);
    if (j->status >= 0) j->status = paper_earth_get_outputs(w, j->y);
    paper_earth_free(w);
    return NULL;
}
static void threads(void) {
    job a = {6.0, {0}, -1}, b = {9.0, {0}, -1}, a1 = {6.0, {0}, -1}, b1 = {9.0, {0}, -1};
    pthread_t ta, tb;
    run_job(&a1);
    run_job(&b1);
    CHECK(pthread_create(&ta, NULL, run_job, &a) == 0);
    CHECK(pthread_create(&tb, NULL, run_job, &b) == 0);
    pthread_join(ta, NULL);
    pthread_join(tb, NULL);
    CHECK(a.status == GYROWHEEL_OK && b.status == GYROWHEEL_OK);
    CHECK(memcmp(a.y, a1.y, sizeof(a.y)) == 0 && memcmp(b.y, b1.y, sizeof(b.y)) == 0);
    CHECK(a.y[PAPER_EARTH_Y_gamma] != b.y[PAPER_EARTH_Y_gamma]);
}

int main(void) {
    table();
    create_and_read();
    bad_values();
    bad_calls();
    save_restore();
    fall();
    allocator();
    fixed_step_late();
    budget();
    threads();
    fprintf(stderr, "test_capi: %d checks, %d failures\n", h_checks, h_failures);
    return h_failures == 0 ? 0 : 1;
}
