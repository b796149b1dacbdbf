/*
 * gw_capi_names.c -- what needs no instance: the names/units table (GWC_TABLE, written by
 * `gyrowheel export-c` into capi_desc.c), the scene's defaults (GW_MODEL), and a static string
 * per status code.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see <model>.c */
#else

#include <string.h>

#include "gw_capi.h"

GYROWHEEL_EXPORT int GWC(count)(gyrowheel_kind kind) {
    if ((int)kind < 0 || (int)kind >= GWC_N_KINDS) return -1;
    return GWC_TABLE.count[kind];
}

GYROWHEEL_EXPORT const gyrowheel_variable *GWC(variable)(gyrowheel_kind kind, int index) {
    const int n = GWC(count)(kind);
    if (index < 0 || index >= n) return NULL;
    return &GWC_TABLE.rows[kind][index];
}

GYROWHEEL_EXPORT int GWC(index)(gyrowheel_kind kind, const char *name) {
    const int n = GWC(count)(kind);
    int i;
    if (!name) return -1;
    for (i = 0; i < n; i++)
        if (strcmp(GWC_TABLE.rows[kind][i].name, name) == 0) return i;
    return -1;
}

static void gwc_copy_defaults(double *out, const double *start, int n) {
    int i;
    if (!out) return;
    for (i = 0; i < n; i++) out[i] = start ? start[i] : 0.0;
}

GYROWHEEL_EXPORT void GWC(default_parameters)(double *parameters) {
    gwc_copy_defaults(parameters, GW_MODEL.p_start, GW_MODEL.np);
}

GYROWHEEL_EXPORT void GWC(default_initial)(double *initial) {
    gwc_copy_defaults(initial, GW_MODEL.s_start, GW_MODEL.ns);
}

GYROWHEEL_EXPORT void GWC(default_inputs)(double *inputs) {
    gwc_copy_defaults(inputs, GW_MODEL.u_start, GW_MODEL.nu);
}

GYROWHEEL_EXPORT void GWC(default_settings)(gyrowheel_settings *settings) {
    if (!settings) return;
    settings->start_time = GWC_START_TIME;
    settings->solver = GW_MODEL.default_solver;
    settings->rel_tol = GW_MODEL.default_rel_tol;
    settings->abs_tol = GW_MODEL.default_abs_tol;
    settings->max_step = GW_MODEL.default_max_step;
    settings->max_internal_steps = (long)(GW_MODEL.default_max_internal_steps > 0.0
                                              ? GW_MODEL.default_max_internal_steps
                                              : GW_DEFAULT_MAX_INTERNAL_STEPS);
}

GYROWHEEL_EXPORT const char *GWC(status_string)(gyrowheel_status status) {
    switch (status) {
    case GYROWHEEL_OK: return "ok";
    case GYROWHEEL_FIRED: return "ok, an event fired";
    case GYROWHEEL_TERMINATED: return "the run ended at a terminating event";
    case GYROWHEEL_ERR_ARGUMENT: return "bad argument (NULL pointer, index or kind out of range)";
    case GYROWHEEL_ERR_NAME: return "unknown variable name";
    case GYROWHEEL_ERR_NOT_FINITE: return "value is not finite (NaN or infinite)";
    case GYROWHEEL_ERR_INVALID: return "value refused by the model or solver";
    case GYROWHEEL_ERR_TIME: return "time before the current time or not finite";
    case GYROWHEEL_ERR_TERMINATED: return "the run has ended (reset or restore a state)";
    case GYROWHEEL_ERR_NOT_READY: return "instance not initialised (its last create/reset failed)";
    case GYROWHEEL_ERR_SIMULATION: return "the simulation failed (instance back where it was)";
    case GYROWHEEL_ERR_STATE: return "saved state refused (corrupt, truncated or another model's)";
    case GYROWHEEL_ERR_BUFFER: return "buffer too small";
    case GYROWHEEL_ERR_MEMORY: return "out of memory";
    default: return "unknown status";
    }
}

#endif /* GW_UNITY_BUILD */
