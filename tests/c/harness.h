/*
 * harness.h -- tiny test harness for the C runtime tests: an importer's view of
 * the FMU (counting allocator, capturing logger) and check macros.
 * Test code only; linked statically with the runtime and one toy model.
 */
#ifndef GW_TEST_HARNESS_H
#define GW_TEST_HARNESS_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "checks.h"
#include "fmi2Functions.h"

#define CHECK_STATUS(call, expected)                                                         \
    do {                                                                                     \
        fmi2Status s_ = (call);                                                              \
        h_checks++;                                                                          \
        if (s_ != (expected)) {                                                              \
            h_failures++;                                                                    \
            fprintf(stderr, "%s:%d: %s returned %d, expected %d\n", __FILE__, __LINE__,     \
                    #call, (int)s_, (int)(expected));                                        \
        }                                                                                    \
    } while (0)
#define CHECK_LOG(substr)                                                                    \
    do {                                                                                     \
        h_checks++;                                                                          \
        if (!log_contains(substr)) {                                                         \
            h_failures++;                                                                    \
            fprintf(stderr, "%s:%d: log lacks \"%s\"; log:\n%s\n", __FILE__, __LINE__,       \
                    substr, h_log);                                                          \
        }                                                                                    \
    } while (0)
#define CHECK_NO_LOG(substr)                                                                 \
    do {                                                                                     \
        h_checks++;                                                                          \
        if (log_contains(substr)) {                                                          \
            h_failures++;                                                                    \
            fprintf(stderr, "%s:%d: log unexpectedly has \"%s\"\n", __FILE__, __LINE__,      \
                    substr);                                                                 \
        }                                                                                    \
    } while (0)

/* ---- counting allocator ----------------------------------------------------- */
#define H_MAGIC 0x47574d454dUL
typedef struct {
    unsigned long magic;
    size_t size;
    double align_; /* keep the payload aligned */
} h_header;

static long h_live = 0, h_total = 0, h_bad_free = 0;
static int h_fail_after = -1; /* >= 0: fail the n-th next allocation */

static void *h_alloc(size_t n, size_t size) {
    h_header *hd;
    if (h_fail_after == 0) {
        h_fail_after = -1;
        return NULL;
    }
    if (h_fail_after > 0) h_fail_after--;
    hd = (h_header *)malloc(sizeof(h_header) + n * size);
    if (!hd) return NULL;
    /* deliberately NOT zeroed: the runtime must zero memory itself */
    memset(hd + 1, 0xA5, n * size);
    hd->magic = H_MAGIC;
    hd->size = n * size;
    h_live++;
    h_total++;
    return hd + 1;
}

static void h_free(void *p) {
    h_header *hd;
    if (!p) return;
    hd = (h_header *)p - 1;
    if (hd->magic != H_MAGIC) {
        h_bad_free++;
        return;
    }
    hd->magic = 0;
    h_live--;
    free(hd);
}

/* ---- capturing logger --------------------------------------------------------- */
static char h_log[200000];
static size_t h_log_len = 0;
static int h_log_count = 0;
static int h_log_echo = 0;

static void h_logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                     fmi2String category, fmi2String message, ...) {
    char line[4096];
    int n;
    (void)env;
    n = snprintf(line, sizeof(line), "[%s|%d|%s] %s\n", name ? name : "?", (int)status,
                 category ? category : "?", message ? message : "");
    if (n < 0) return;
    if ((size_t)n >= sizeof(line)) n = (int)sizeof(line) - 1;
    if (h_log_len + (size_t)n + 1 < sizeof(h_log)) {
        memcpy(h_log + h_log_len, line, (size_t)n);
        h_log_len += (size_t)n;
        h_log[h_log_len] = '\0';
    }
    h_log_count++;
    if (h_log_echo || getenv("GW_TEST_ECHO")) fputs(line, stderr);
}

static inline void log_clear(void) {
    h_log_len = 0;
    h_log[0] = '\0';
    h_log_count = 0;
}
static inline int log_contains(const char *s) { return strstr(h_log, s) != NULL; }

static fmi2CallbackFunctions h_callbacks = {h_logger, h_alloc, h_free, NULL, NULL};

static int h_finish(const char *what) {
    CHECK(h_live == 0);
    CHECK(h_bad_free == 0);
    if (h_live != 0) fprintf(stderr, "%ld allocations leaked\n", h_live);
    fprintf(stderr, "%s: %d checks, %d failures, %ld allocations\n", what, h_checks,
            h_failures, h_total);
    return h_failures == 0 ? 0 : 1;
}


/* ---- one-variable get/set, as every driver needs them -------------------------- */
static inline double getr(fmi2Component c, fmi2ValueReference vr) {
    double v = NAN;
    fmi2GetReal(c, &vr, 1, &v);
    return v;
}
static inline fmi2Status setr(fmi2Component c, fmi2ValueReference vr, double v) {
    return fmi2SetReal(c, &vr, 1, &v);
}
static inline fmi2Status seti(fmi2Component c, fmi2ValueReference vr, int v) {
    fmi2Integer x = v;
    return fmi2SetInteger(c, &vr, 1, &x);
}
static inline int getb(fmi2Component c, fmi2ValueReference vr) {
    fmi2Boolean b = -1;
    fmi2GetBoolean(c, &vr, 1, &b);
    return b;
}

static inline fmi2Status gw_worst_test(fmi2Status a, fmi2Status b) { return a > b ? a : b; }

#endif
