/*
 * gw_capi_state.c -- saving and restoring a run: the caller owns the buffer.  Layout, native
 * byte order (same machine type and export only):
 *
 *   offset  size   field
 *   0       4      magic "GWCA"
 *   4       4      uint32 layout version (GWC_STATE_VERSION)
 *   8       4      uint32 total size in bytes
 *   12      4      uint32 ne (number of events)
 *   16      8      uint64 FNV-1a 64 of bytes [24, total): any change of a single byte (every
 *                  1-8 bit flip in one byte) is detected for certain, others with
 *                  probability 1 - 2^-64
 *   24      8*ne   double time of each event's last firing
 *   then           the core's state (gw_state.c: its own magic, version, model sizes and token)
 *
 * Restoring checks, in order: size, magic, version, the total size, the checksum, the number
 * of events, the core's header (sizes, model token); then it applies the state and checks its
 * values (finite time, states, parameters, inputs; valid solver and tolerances); if one is
 * bad the previous state is put back.  Every refusal is GYROWHEEL_ERR_STATE with the reason.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see <model>.c */
#else

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "gw_capi.h"

#define GWC_STATE_MAGIC "GWCA"
#define GWC_STATE_VERSION 1u
#define GWC_STATE_HEADER 24u

static uint64_t gwc_fnv1a(const unsigned char *p, size_t n) {
    uint64_t h = 14695981039346656037ull; /* FNV-1a 64 offset basis */
    size_t i;
    for (i = 0; i < n; i++) {
        h ^= (uint64_t)p[i];
        h *= 1099511628211ull; /* FNV prime */
    }
    return h;
}

static size_t gwc_events_bytes(const GWC_T *w) { return (size_t)w->I->m->ne * sizeof(double); }

GYROWHEEL_EXPORT size_t GWC(state_size)(const GWC_T *w) {
    if (!w) return 0;
    return GWC_STATE_HEADER + gwc_events_bytes(w) + w->core_state_size;
}

static void gwc_put_u32(unsigned char *p, uint32_t v) { memcpy(p, &v, 4); }
static uint32_t gwc_get_u32(const unsigned char *p) {
    uint32_t v;
    memcpy(&v, p, 4);
    return v;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(save_state)(const GWC_T *w, void *buffer, size_t size) {
    const int front[2] = {0, 0};
    unsigned char *b = (unsigned char *)buffer;
    size_t need;
    uint64_t sum;
    GWC_REQUIRE_READY(w, GWC_FN(save_state));
    need = GWC(state_size)(w);
    if (!buffer) return gwc_null(w, GWC_FN(save_state), "buffer");
    if (size < need)
        return gwc_fail(w, GYROWHEEL_ERR_BUFFER, "%s: buffer of %lu bytes, a state needs %lu (%s)",
                        GWC_FN(save_state), (unsigned long)size, (unsigned long)need,
                        GWC_FN(state_size));
    memcpy(b, GWC_STATE_MAGIC, 4);
    gwc_put_u32(b + 4, GWC_STATE_VERSION);
    gwc_put_u32(b + 8, (uint32_t)need);
    gwc_put_u32(b + 12, (uint32_t)w->I->m->ne);
    if (w->I->m->ne > 0) memcpy(b + GWC_STATE_HEADER, w->I->t_events, gwc_events_bytes(w));
    gw_state_write(w->I, front, b + GWC_STATE_HEADER + gwc_events_bytes(w));
    sum = gwc_fnv1a(b + GWC_STATE_HEADER, need - GWC_STATE_HEADER);
    memcpy(b + 16, &sum, 8);
    return GYROWHEEL_OK;
}

static int gwc_all_finite(const double *v, int n) {
    int i;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

static int gwc_positive(double v) { return v > 0.0 && isfinite(v); }

/* the values of a state just applied: NULL if usable, else what is wrong */
static const char *gwc_state_values_bad(const gw_instance *I) {
    const gw_model *m = I->m;
    if (!isfinite(I->t)) return "time is not finite";
    if (!gwc_all_finite(I->x, m->nx)) return "a state is not finite";
    if (!gwc_all_finite(I->p, m->np)) return "a parameter is not finite";
    if (!gwc_all_finite(I->s, m->ns)) return "an initial value is not finite";
    if (!gwc_all_finite(I->u, m->nu)) return "an input is not finite";
    if (!gwc_all_finite(I->t_events, m->ne)) return "an event time is not finite";
    if (!gw_solver_available(I->solver)) return "unknown solver";
    if (!gwc_positive(I->rel_tol) || !gwc_positive(I->abs_tol) || !gwc_positive(I->max_step))
        return "a tolerance or max_step is not finite and > 0";
    if (!(I->h_adapt >= 0.0 && isfinite(I->h_adapt))) return "the step size is not finite";
    return NULL;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(restore_state)(GWC_T *w, const void *buffer, size_t size) {
    const char *fn = GWC_FN(restore_state), *bad;
    const unsigned char *b = (const unsigned char *)buffer;
    gw_instance *I;
    size_t need, ev_bytes;
    uint32_t version, total, ne;
    uint64_t sum;
    int front[2] = {0, 0}, was_ready, was_setup;
    if (!w) return GYROWHEEL_ERR_ARGUMENT;
    gwc_begin(w);
    I = w->I;
    if (!buffer) return gwc_null(w, fn, "buffer");
    need = GWC(state_size)(w);
    ev_bytes = gwc_events_bytes(w);
    if (size < GWC_STATE_HEADER)
        return gwc_fail(w, GYROWHEEL_ERR_STATE, "%s: %lu bytes are too few for a saved state (%lu)",
                        fn, (unsigned long)size, (unsigned long)need);
    if (memcmp(b, GWC_STATE_MAGIC, 4) != 0)
        return gwc_fail(w, GYROWHEEL_ERR_STATE,
                        "%s: not a state saved by a gyrowheel C API (bad magic)", fn);
    version = gwc_get_u32(b + 4);
    total = gwc_get_u32(b + 8);
    ne = gwc_get_u32(b + 12);
    if (version != GWC_STATE_VERSION)
        return gwc_fail(w, GYROWHEEL_ERR_STATE, "%s: state layout version %u, this export reads %u",
                        fn, (unsigned)version, (unsigned)GWC_STATE_VERSION);
    if ((size_t)total != size)
        return gwc_fail(w, GYROWHEEL_ERR_STATE,
                        "%s: the buffer has %lu bytes, its header says %lu (truncated?)", fn,
                        (unsigned long)size, (unsigned long)total);
    memcpy(&sum, b + 16, 8);
    if (sum != gwc_fnv1a(b + GWC_STATE_HEADER, size - GWC_STATE_HEADER))
        return gwc_fail(w, GYROWHEEL_ERR_STATE, "%s: the state is corrupt (checksum mismatch)", fn);
    if ((int)ne != I->m->ne || size != need ||
        !gw_state_check(I, fn, b + GWC_STATE_HEADER + ev_bytes, size - GWC_STATE_HEADER - ev_bytes))
        return w->pending_len ? gwc_fail_core(w, GYROWHEEL_ERR_STATE, "")
                              : gwc_fail(w, GYROWHEEL_ERR_STATE,
                                         "%s: a state of another model (%lu bytes, %u events; "
                                         "this model's has %lu bytes, %d events)",
                                         fn, (unsigned long)size, (unsigned)ne,
                                         (unsigned long)need, I->m->ne);
    /* apply, keeping the current state to fall back on */
    gw_state_write(I, front, w->state_backup);
    if (ev_bytes) memcpy(w->t_events_backup, I->t_events, ev_bytes);
    was_ready = w->ready;
    was_setup = I->in_setup;
    gw_state_apply(I, b + GWC_STATE_HEADER + ev_bytes);
    if (ev_bytes) memcpy(I->t_events, b + GWC_STATE_HEADER, ev_bytes);
    I->in_setup = 0;
    bad = gwc_state_values_bad(I);
    if (bad) {
        gw_state_apply(I, w->state_backup);
        if (ev_bytes) memcpy(I->t_events, w->t_events_backup, ev_bytes);
        I->in_setup = was_setup;
        w->ready = was_ready;
        return gwc_fail(w, GYROWHEEL_ERR_STATE, "%s: the state holds invalid values: %s", fn, bad);
    }
    w->ready = 1;
    return GYROWHEEL_OK;
}

#endif /* GW_UNITY_BUILD */
