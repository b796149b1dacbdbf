/*
 * gw_fmi2_variables.c -- fmi2Get/Set Real, Integer, Boolean, String: value references
 * looked up in GW_MODEL.vars, checked against the base type and against what FMI 2.0 allows
 * to be set in the current state; values read and stored by the core (gw_values.c).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>

#include "gw_fmi2.h"
#include "gw_front.h"

/* the frames of this file's functions (GW_FRAME, gw_fmi2.h): interface, legal states
 * (GW_MASK_Set, GW_MASK_SetDiscrete: gw_fmi2.h) */
#define GW_IFACE_GetReal GW_IFACE_BOTH
#define GW_IFACE_GetInteger GW_IFACE_BOTH
#define GW_IFACE_GetBoolean GW_IFACE_BOTH
#define GW_IFACE_GetString GW_IFACE_BOTH
#define GW_IFACE_SetReal GW_IFACE_BOTH
#define GW_IFACE_SetInteger GW_IFACE_BOTH
#define GW_IFACE_SetBoolean GW_IFACE_BOTH
#define GW_IFACE_SetString GW_IFACE_BOTH
#define GW_MASK_Get GW_ST_ANY
#define GW_MASK_GetReal GW_MASK_Get
#define GW_MASK_GetInteger GW_MASK_Get
#define GW_MASK_GetBoolean GW_MASK_Get
#define GW_MASK_GetString GW_MASK_Get
#define GW_MASK_SetReal GW_MASK_Set
#define GW_MASK_SetInteger GW_MASK_SetDiscrete
#define GW_MASK_SetBoolean GW_MASK_SetDiscrete
#define GW_MASK_SetString GW_MASK_SetDiscrete

static const char *gw_fmi2_type_name(int type) {
    switch (type) {
    case GW_REAL: return "Real";
    case GW_INTEGER: return "Integer";
    case GW_BOOLEAN: return "Boolean";
    case GW_ENUM: return "Enumeration";
    default: return "?";
    }
}

/* Look up vr and check that it is accessed through the right fmi2Get/SetXXX. */
static const gw_variable *gw_fmi2_lookup(gw_instance *I, const char *fn, fmi2ValueReference vr,
                                         int want_type) {
    const gw_variable *v = gw_variable_find(I->m, vr);
    int ok;
    if (!v) {
        GW_LOG_ERR(I, "%s: unknown value reference %u", fn, vr);
        return NULL;
    }
    ok = want_type == GW_INTEGER ? (v->type == GW_INTEGER || v->type == GW_ENUM)
                                 : (int)v->type == want_type;
    if (!ok) {
        GW_LOG_ERR(I, "%s: variable %s (vr=%u) is of type %s", fn, v->name, vr,
                   gw_fmi2_type_name(v->type));
        return NULL;
    }
    return v;
}

/* what reading the variables needs first (gw_front_needs: GW_NEED_*) */
static int gw_fmi2_needs(const gw_instance *I, const fmi2ValueReference vr[], size_t nvr) {
    int need = 0;
    size_t k;
    for (k = 0; k < nvr; k++) need |= gw_front_needs(I, gw_variable_find(I->m, vr[k]));
    return need;
}

/* Check that v may be set now; the value is already known to be valid. */
static int gw_fmi2_settable(gw_fmu *F, const char *fn, const gw_variable *v) {
    /* tunable parameters: in Model Exchange only in Event Mode, not in CT Mode */
    return gw_front_settable(F->I, fn, v, (F->state & GW_MASK_Set) != 0,
                             (F->state & GW_MASK_Set & ~GW_ST_CONT_TIME_MODE) != 0,
                             gw_fmi2_state_name(F->state),
                             gw_fmi2_is_me(F) ? " (use fmi2SetContinuousStates)" : "");
}

/* (in a frame: fn, I) */
#define GW_CHECK_ARRAYS(vr, nvr, value)                                                         \
    if ((nvr) > 0 && (!(vr) || !(value)))                                                       \
    GW_FAIL("%s: NULL array for %lu values", fn, (unsigned long)(nvr))

/* ---- getting values ------------------------------------------------------------------------ */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    size_t k;
    int need;
    GW_FRAME(GetReal);
    gw_fmi2_allow_discard(F);
    GW_CHECK_ARRAYS(vr, nvr, value);
    need = gw_fmi2_needs(I, vr, nvr);
    if (need & GW_NEED_OUTPUTS) GW_TRY(gw_update_outputs(I, fn));
    if (need & GW_NEED_DERIVATIVES) GW_TRY(gw_update_derivatives(I, fn));
    if (need & GW_NEED_INDICATORS) GW_TRY(gw_front_indicators(I, fn));
    /* every reference and value checked before anything is written: the caller's array
     * never receives a non-finite value, nor a partial answer */
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = gw_fmi2_lookup(I, fn, vr[k], GW_REAL);
        double d;
        if (!v) {
            status = fmi2Error;
            goto END;
        }
        GW_TRY(gw_front_get_finite(I, fn, v, &d));
    }
    for (k = 0; k < nvr; k++) value[k] = gw_value_get(I, gw_variable_find(I->m, vr[k]));
    GW_FRAME_END();
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    size_t k;
    GW_FRAME(GetInteger);
    gw_fmi2_allow_discard(F);
    GW_CHECK_ARRAYS(vr, nvr, value);
    if (gw_fmi2_needs(I, vr, nvr) & GW_NEED_OUTPUTS) GW_TRY(gw_update_outputs(I, fn));
    /* as fmi2GetReal: every reference and value checked before anything is written (an
     * Enumeration output, e.g. a contact mode, is computed from the state) */
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = gw_fmi2_lookup(I, fn, vr[k], GW_INTEGER);
        double d;
        if (!v) {
            status = fmi2Error;
            goto END;
        }
        GW_TRY(gw_front_get_finite(I, fn, v, &d));
    }
    for (k = 0; k < nvr; k++)
        value[k] = (fmi2Integer)floor(gw_value_get(I, gw_variable_find(I->m, vr[k])) + 0.5);
    GW_FRAME_END();
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    size_t k;
    GW_FRAME(GetBoolean);
    GW_CHECK_ARRAYS(vr, nvr, value);
    if (gw_fmi2_needs(I, vr, nvr) & GW_NEED_OUTPUTS) GW_TRY(gw_update_outputs(I, fn));
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = gw_fmi2_lookup(I, fn, vr[k], GW_BOOLEAN);
        if (!v) {
            status = fmi2Error;
            goto END;
        }
        value[k] = gw_value_get(I, v) != 0.0 ? fmi2True : fmi2False;
    }
    GW_FRAME_END();
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    GW_FRAME(GetString);
    (void)value;
    if (nvr > 0)
        GW_FAIL("%s: unknown value reference %u (the model has no String variables)", fn,
                vr ? vr[0] : 0u);
    GW_FRAME_END();
}

/* ---- setting values ------------------------------------------------------------------------ */

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    size_t k;
    GW_FRAME(SetReal);
    GW_CHECK_ARRAYS(vr, nvr, value);
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = gw_fmi2_lookup(I, fn, vr[k], GW_REAL);
        if (!v || !gw_fmi2_settable(F, fn, v)) {
            status = fmi2Error;
            goto END;
        }
        GW_TRY(gw_value_check(I, fn, v, value[k]));
        gw_value_set(I, v, value[k]);
    }
    GW_FRAME_END();
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    size_t k;
    GW_FRAME(SetInteger);
    GW_CHECK_ARRAYS(vr, nvr, value);
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = gw_fmi2_lookup(I, fn, vr[k], GW_INTEGER);
        if (!v || !gw_fmi2_settable(F, fn, v)) {
            status = fmi2Error;
            goto END;
        }
        GW_TRY(gw_value_check(I, fn, v, (double)value[k]));
        gw_value_set(I, v, (double)value[k]);
    }
    GW_FRAME_END();
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    size_t k;
    GW_FRAME(SetBoolean);
    GW_CHECK_ARRAYS(vr, nvr, value);
    for (k = 0; k < nvr; k++) {
        const gw_variable *v = gw_fmi2_lookup(I, fn, vr[k], GW_BOOLEAN);
        if (!v || !gw_fmi2_settable(F, fn, v)) {
            status = fmi2Error;
            goto END;
        }
        gw_value_set(I, v, value[k] ? 1.0 : 0.0);
    }
    GW_FRAME_END();
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    GW_FRAME(SetString);
    (void)value;
    if (nvr > 0)
        GW_FAIL("%s: unknown value reference %u (the model has no String variables)", fn,
                vr ? vr[0] : 0u);
    GW_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
