/*
 * gw_capi.h -- internals of the exported C API (gw_capi*.c): the model's names/units table
 * (written by `gyrowheel export-c` into capi_desc.c), the instance behind the opaque
 * <model> type, and the name-pasting macros that give every public function the model's
 * prefix.  Part of the export's single translation unit <model>.c, which defines
 * GW_CAPI_MODEL (the model's name) and includes <model>.h and gyrowheel_api.h first.
 */
#ifndef GW_CAPI_H
#define GW_CAPI_H

#ifndef GYROWHEEL_API_H
#error "gw_capi.h: include <model>.h (and with it gyrowheel_api.h) first: see <model>.c"
#endif

#include "gw_instance.h"

/* GWC(create) -> paper_earth_create; GWC_T -> paper_earth;
 * GWC_FN(create) -> "paper_earth_create" (for messages) */
#define GWC_CAT_(a, b) a##_##b
#define GWC_CAT(a, b) GWC_CAT_(a, b)
#define GWC(fn) GWC_CAT(GW_CAPI_MODEL, fn)
#define GWC_T GW_CAPI_MODEL
#define GWC_STR_(x) #x
#define GWC_STR(x) GWC_STR_(x)
#define GWC_FN(fn) GWC_STR(GW_CAPI_MODEL) "_" #fn

#define GWC_N_KINDS 6 /* gyrowheel_kind */
#define GWC_MSG 1024  /* bytes of a message */

/* The names/units table of one model (capi_desc.c): per gyrowheel_kind its rows and count. */
typedef struct {
    const gyrowheel_variable *rows[GWC_N_KINDS];
    int count[GWC_N_KINDS];
    const int *output_y; /* API output i is y[output_y[i]] (the outputs the scene exposes) */
} gwc_table;

struct GWC_T {
    gw_instance *I;
    gyrowheel_allocator alloc; /* the caller's, or malloc/free */
    int ready;                 /* 1: initialised (the last create/reset/restore succeeded) */
    gyrowheel_logger logger;
    void *logger_env;
    double *p_tmp, *s_tmp;       /* np, ns: values being assembled by *_named */
    size_t core_state_size;
    size_t pending_len;
    char pending[GWC_MSG];    /* error messages of the core during the call in progress */
    char last_error[GWC_MSG]; /* the message of the last failed call */
};

/* ---- gw_capi.c: shared by the API's files -------------------------------------------------- */
/* Set last_error (printf-style), hand it to the logger, return code; const instances too (the
 * one field written). */
static gyrowheel_status gwc_fail(const struct GWC_T *w, gyrowheel_status code, const char *fmt, ...)
    GW_PRINTF(3, 4);
/* GYROWHEEL_ERR_ARGUMENT, "fn: what is NULL" */
static gyrowheel_status gwc_null(const struct GWC_T *w, const char *fn, const char *what);
/* Start of a call: forget the core messages of the previous one. */
static void gwc_begin(struct GWC_T *w);
/* last_error from the core's messages of this call (or `fallback` if it logged none). */
static gyrowheel_status gwc_fail_core(struct GWC_T *w, gyrowheel_status code, const char *fallback);

/* NULL instance, or not initialised: the error of every call but reset, free, last_error */
#define GWC_REQUIRE_READY(w, fn)                                                              \
    do {                                                                                      \
        if (!(w)) return GYROWHEEL_ERR_ARGUMENT;                                              \
        if (!(w)->ready)                                                                      \
            return gwc_fail((w), GYROWHEEL_ERR_NOT_READY,                                     \
                            "%s: the instance is not initialised (its last create, reset or " \
                            "restore failed): reset it",                                      \
                            (fn));                                                            \
    } while (0)

#endif /* GW_CAPI_H */
