/*
 * gw_capi_state.c -- saving and restoring a run: the caller owns the buffer.  The buffer is
 * the core's own serialised state (c_src/gw_state.c: magic, layout version, model sizes and
 * token, every field of the run including each event's last firing time, a CRC-32 of all
 * of it), the same blob fmi2SerializeFMUstate writes, with both front-end words 0.  Native
 * byte order: the same machine type and export only.
 *
 * Restoring checks everything before it changes anything (gw_state_check: size, magic,
 * version, model sizes and token, checksum, and every value within the ranges the API
 * accepts; gw_state_check_run: the times in order, the events and their flags, the model's
 * validity checks), so a refused buffer leaves the instance as it was.  Every refusal is
 * GYROWHEEL_ERR_STATE with the core's reason.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see <model>.c */
#else

#include <string.h>

#include "gw_capi.h"

GYROWHEEL_EXPORT size_t GWC(state_size)(const GWC_T *w) { return w ? w->core_state_size : 0; }

GYROWHEEL_EXPORT gyrowheel_status GWC(save_state)(const GWC_T *w, void *buffer, size_t size) {
    static const int front[2] = {0, 0}; /* the C API keeps no front-end state of its own */
    GWC_REQUIRE_READY(w, GWC_FN(save_state));
    if (!buffer) return gwc_null(w, GWC_FN(save_state), "buffer");
    if (size < w->core_state_size)
        return gwc_fail(w, GYROWHEEL_ERR_BUFFER, "%s: buffer of %lu bytes, a state needs %lu (%s)",
                        GWC_FN(save_state), (unsigned long)size, (unsigned long)w->core_state_size,
                        GWC_FN(state_size));
    gw_state_write(w->I, front, (unsigned char *)buffer);
    return GYROWHEEL_OK;
}

GYROWHEEL_EXPORT gyrowheel_status GWC(restore_state)(GWC_T *w, const void *buffer, size_t size) {
    const char *fn = GWC_FN(restore_state);
    const unsigned char *b = (const unsigned char *)buffer;
    int front[2];
    if (!w) return GYROWHEEL_ERR_ARGUMENT;
    gwc_begin(w);
    if (!buffer) return gwc_null(w, fn, "buffer");
    if (!gw_state_check(w->I, fn, b, size))
        return gwc_fail_core(w, GYROWHEEL_ERR_STATE, "the state was refused");
    gw_state_front(w->I, b, front);
    if (front[0] != 0 || front[1] != 0)
        return gwc_fail(w, GYROWHEEL_ERR_STATE,
                        "%s: a state saved by an FMU, not by this C API (front-end words %d, %d)",
                        fn, front[0], front[1]);
    {
        const gw_state_facts facts = {1, 0, 0, 0}; /* saved after its initialisation; time only
                                                    advances through the API */
        if (!gw_state_check_run(w->I, fn, b, &facts))
            return gwc_fail_core(w, GYROWHEEL_ERR_STATE, "the state was refused");
    }
    w->I->in_setup = 0;
    gw_state_apply(w->I, b);
    w->ready = 1;
    return GYROWHEEL_OK;
}

#endif /* GW_UNITY_BUILD */
