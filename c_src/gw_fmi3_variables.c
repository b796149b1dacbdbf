/*
 * gw_fmi3_variables.c -- fmi3Get/Set of every variable type.  The value references are the
 * FMI 2.0 FMU's (GW_MODEL.vars) and 0, the independent variable time (Float64, read-only).
 * Types (FMI 3.0.2 section 2.4.7): Real -> Float64, Integer -> Int32, Enumeration -> Int64,
 * Boolean -> Boolean; the FMU has no variable of any other type, so the other typed functions
 * answer nValueReferences == 0 with fmi3OK and any value reference with fmi3Error and what
 * the variable is.  What may be set when is the FMI 2.0 layer's rule (gw_front_settable):
 * FMI 3.0.2's tables (sections 3.2.1 and 4.2.1) allow the same.  FMI 3.0 passes nValues
 * beside the value references: the number of serialized values, one per scalar and n per
 * array variable (section 2.2.7.2).  The array variables (GW_MODEL.arrays, section 2.4.7.2)
 * are read-only Float64 outputs whose elements are states or outputs; a model without any
 * takes the scalar path only.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu3.c */
#else

#include <math.h>
#include <string.h>

#include "gw_fmi3.h"
#include "gw_front.h"

/* value reference 0: time, the independent variable (a generated model's rows start at 1) */
#define GW3_VR_TIME 0u

/* legal states: getters in any (as the FMI 2.0 layer); setters where FMI 3.0.2 lets inputs
 * and tunable parameters be set; non-Float64 variables are discrete: not in Continuous-Time
 * Mode */
#define GW3_MASK_Get GW3_ST_ANY
#define GW3_MASK_Set                                                                            \
    (GW3_ST_INSTANTIATED | GW3_ST_INIT_MODE | GW3_ST_EVENT_MODE | GW3_ST_CONT_TIME_MODE |       \
     GW3_ST_STEP_MODE)
#define GW3_MASK_SetDiscrete (GW3_MASK_Set & ~GW3_ST_CONT_TIME_MODE)
#define GW3_IFACE_GetFloat64 GW3_IFACE_ANY
#define GW3_IFACE_GetInt32 GW3_IFACE_ANY
#define GW3_IFACE_GetInt64 GW3_IFACE_ANY
#define GW3_IFACE_GetBoolean GW3_IFACE_ANY
#define GW3_IFACE_SetFloat64 GW3_IFACE_ANY
#define GW3_IFACE_SetInt32 GW3_IFACE_ANY
#define GW3_IFACE_SetInt64 GW3_IFACE_ANY
#define GW3_IFACE_SetBoolean GW3_IFACE_ANY
#define GW3_MASK_GetFloat64 GW3_MASK_Get
#define GW3_MASK_GetInt32 GW3_MASK_Get
#define GW3_MASK_GetInt64 GW3_MASK_Get
#define GW3_MASK_GetBoolean GW3_MASK_Get
#define GW3_MASK_SetFloat64 GW3_MASK_Set
#define GW3_MASK_SetInt32 GW3_MASK_SetDiscrete
#define GW3_MASK_SetInt64 GW3_MASK_SetDiscrete
#define GW3_MASK_SetBoolean GW3_MASK_SetDiscrete

/* the FMI 3.0 type of a variable of base type `type` (gw_type), with its article */
static const char *gw_fmi3_type_name(int type) {
    switch (type) {
    case GW_REAL: return "a Float64";
    case GW_INTEGER: return "an Int32";
    case GW_BOOLEAN: return "a Boolean";
    case GW_ENUM: return "an Enumeration (Int64)";
    default: return "an unknown";
    }
}

GW_INTERNAL const gw_array *gw_fmi3_array_find(const gw_model *m, unsigned int vr) {
    int lo = 0, hi = m->n_arrays - 1;
    while (lo <= hi) {
        int mid = lo + (hi - lo) / 2;
        if (m->arrays[mid].vr == vr) return &m->arrays[mid];
        if (m->arrays[mid].vr < vr)
            lo = mid + 1;
        else
            hi = mid - 1;
    }
    return NULL;
}

/* element k of array a as the scalar variable it stands for: a state (read as a scalar state
 * is, x = init(s, p) while initialising) or an output */
static gw_variable gw_fmi3_element(const gw_array *a, int k) {
    gw_variable v;
    memset(&v, 0, sizeof(v));
    v.vr = a->vr;
    v.name = a->name;
    v.type = GW_REAL;
    v.kind = a->source == GW_ARRAY_X ? GW_VAR_STATE : GW_VAR_OUTPUT;
    v.index = a->index[k];
    v.out_index = -1;
    v.state_index = -1;
    return v;
}

/* the refusal of an array variable's reference where only a scalar of another type fits */
static void gw_fmi3_refuse_array(gw_instance *I, const char *fn, fmi3ValueReference vr,
                                 const gw_array *a) {
    GW_LOG_ERR(I, "%s: value reference %u (%s) is a Float64 array variable", fn, (unsigned)vr,
               a->name);
}

/* the variable vr if it is of base type `type` (-1: of a type this FMU has none of); else NULL
 * with the reason logged.  Time (vr 0) has no row: it answers *time = 1 and NULL. */
static const gw_variable *gw_fmi3_lookup(gw_instance *I, const char *fn, fmi3ValueReference vr,
                                         int type, int *time) {
    const gw_variable *v;
    *time = 0;
    if (vr == GW3_VR_TIME && !gw_variable_find(I->m, vr)) { /* (hand-written models may use 0) */
        if (type == GW_REAL) {
            *time = 1;
            return NULL;
        }
        GW_LOG_ERR(I, "%s: value reference 0 (time) is a Float64 variable", fn);
        return NULL;
    }
    v = gw_variable_find(I->m, vr);
    if (!v) {
        const gw_array *a = gw_fmi3_array_find(I->m, vr);
        if (a)
            gw_fmi3_refuse_array(I, fn, vr, a);
        else
            GW_LOG_ERR(I, "%s: unknown value reference %u", fn, (unsigned)vr);
        return NULL;
    }
    if ((int)v->type != type) {
        GW_LOG_ERR(I, "%s: value reference %u (%s) is %s variable", fn, (unsigned)vr, v->name,
                   gw_fmi3_type_name(v->type));
        return NULL;
    }
    return v;
}

/* the number of values of the references vr of a getter or setter of base type `type`
 * (section 2.2.7.1: the serialized variables concatenated): one per scalar, n per array (all
 * Float64); a reference of another type or unknown counts one (refused with its own reason) */
static size_t gw_fmi3_n_values(const gw_model *m, const fmi3ValueReference vr[], size_t nvr,
                               int type) {
    size_t k, n = nvr;
    if (m->n_arrays == 0 || !vr || type != GW_REAL) return nvr;
    for (k = 0; k < nvr; k++) {
        const gw_array *a = gw_fmi3_array_find(m, vr[k]);
        if (a) n += (size_t)a->n - 1;
    }
    return n;
}

/* the arrays of a call: present when there are values, nValues the sum of the sizes of the
 * referenced variables (section 2.2.7.2) */
static int gw_fmi3_arrays_ok(gw_instance *I, const char *fn, const fmi3ValueReference vr[],
                             size_t nvr, const void *values, size_t nValues, int type) {
    size_t want = gw_fmi3_n_values(I->m, vr, nvr, type), k;
    /* an array of another getter's type: named as such, before its size is counted wrongly */
    for (k = 0; type != GW_REAL && vr && k < nvr; k++) {
        const gw_array *a = gw_fmi3_array_find(I->m, vr[k]);
        if (a) {
            gw_fmi3_refuse_array(I, fn, vr[k], a);
            return 0;
        }
    }
    if (nValues != want && I->m->n_arrays == 0) {
        GW_LOG_ERR(I, "%s: nValues = %lu for %lu value references (every variable of this FMU "
                   "is a scalar)", fn, (unsigned long)nValues, (unsigned long)nvr);
        return 0;
    }
    if (nValues != want) {
        GW_LOG_ERR(I, "%s: nValues = %lu, but the referenced variables' sizes sum to %lu "
                   "(%lu value references; FMI 3.0.2 section 2.2.7.2)", fn,
                   (unsigned long)nValues, (unsigned long)want, (unsigned long)nvr);
        return 0;
    }
    if (nvr > 0 && (!vr || !values)) {
        GW_LOG_ERR(I, "%s: NULL array for %lu values", fn, (unsigned long)nvr);
        return 0;
    }
    return 1;
}

/* ---- getting values ------------------------------------------------------------------------ */

/* values[k] = variable vr[k] of base type `type`, stored as the C type of its fmi3Get
 * function.  Every reference and value is checked before anything is written: the caller's
 * array never receives a non-finite value, nor a partial answer. */
static fmi3Status gw_fmi3_get(gw_fmu3 *F, const char *fn, const fmi3ValueReference vr[],
                              size_t nvr, void *values, size_t nValues, int type) {
    gw_instance *I = F->I;
    fmi3Status status = fmi3OK;
    int need = 0, time, i;
    size_t k, j;
    if (!gw_fmi3_arrays_ok(I, fn, vr, nvr, values, nValues, type)) return fmi3Error;
    /* every reference first: a bad one is fmi3Error whatever the values of the others */
    for (k = 0; k < nvr; k++) {
        const gw_array *a = type == GW_REAL ? gw_fmi3_array_find(I->m, vr[k]) : NULL;
        const gw_variable *v;
        if (a) {
            gw_variable e = gw_fmi3_element(a, 0);
            need |= gw_front_needs(I, &e); /* every element is of the same source */
            continue;
        }
        v = gw_fmi3_lookup(I, fn, vr[k], type, &time);
        if (!v && !time) return fmi3Error;
        need |= gw_front_needs(I, v);
    }
    if (need & GW_NEED_OUTPUTS) GW3_TRY(gw_update_outputs(I, fn));
    if (need & GW_NEED_DERIVATIVES) GW3_TRY(gw_update_derivatives(I, fn));
    if (need & GW_NEED_INDICATORS) GW3_TRY(gw_front_indicators(I, fn));
    for (k = 0; k < nvr && type != GW_BOOLEAN; k++) { /* a Boolean is an event flag: 0 or 1 */
        const gw_array *a = gw_fmi3_array_find(I->m, vr[k]);
        const gw_variable *v = a ? NULL : gw_variable_find(I->m, vr[k]);
        double d;
        for (i = 0; a && i < a->n; i++) {
            gw_variable e = gw_fmi3_element(a, i);
            GW3_TRY(gw_front_get_finite(I, fn, &e, &d));
        }
        if (v) GW3_TRY(gw_front_get_finite(I, fn, v, &d));
    }
    for (k = 0, j = 0; k < nvr; k++, j++) {
        const gw_array *a = type == GW_REAL ? gw_fmi3_array_find(I->m, vr[k]) : NULL;
        const gw_variable *v;
        double d;
        if (a) { /* its elements, serialized in order (section 2.2.7.1) */
            for (i = 0; i < a->n; i++) {
                gw_variable e = gw_fmi3_element(a, i);
                ((fmi3Float64 *)values)[j + (size_t)i] = gw_value_get(I, &e);
            }
            j += (size_t)a->n - 1;
            continue;
        }
        v = gw_variable_find(I->m, vr[k]);
        d = v ? gw_value_get(I, v) : I->t;
        switch (type) {
        case GW_REAL: ((fmi3Float64 *)values)[j] = d; break;
        case GW_INTEGER: ((fmi3Int32 *)values)[j] = (fmi3Int32)floor(d + 0.5); break;
        case GW_ENUM: ((fmi3Int64 *)values)[j] = (fmi3Int64)floor(d + 0.5); break;
        default: ((fmi3Boolean *)values)[j] = d != 0.0; break;
        }
    }
END:
    return status;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    GW3_FRAME(GetFloat64);
    gw_fmi3_allow_discard(F);
    status = gw_fmi3_get(F, fn, valueReferences, nValueReferences, values, nValues, GW_REAL);
    GW3_FRAME_END();
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Int32 values[], size_t nValues) {
    GW3_FRAME(GetInt32);
    gw_fmi3_allow_discard(F);
    status = gw_fmi3_get(F, fn, valueReferences, nValueReferences, values, nValues, GW_INTEGER);
    GW3_FRAME_END();
}

fmi3Status fmi3GetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Int64 values[], size_t nValues) {
    GW3_FRAME(GetInt64);
    gw_fmi3_allow_discard(F);
    status = gw_fmi3_get(F, fn, valueReferences, nValueReferences, values, nValues, GW_ENUM);
    GW3_FRAME_END();
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues) {
    GW3_FRAME(GetBoolean);
    status = gw_fmi3_get(F, fn, valueReferences, nValueReferences, values, nValues, GW_BOOLEAN);
    GW3_FRAME_END();
}

/* ---- setting values ------------------------------------------------------------------------ */

/* variable vr[k] of base type `type` = values[k] (the C type of its fmi3Set function), each
 * checked (may it be set now, is the value valid) before it is stored */
static fmi3Status gw_fmi3_set(gw_fmu3 *F, const char *fn, const fmi3ValueReference vr[],
                              size_t nvr, const void *values, size_t nValues, int type) {
    gw_instance *I = F->I;
    fmi3Status status = fmi3OK;
    int time;
    size_t k;
    if (!gw_fmi3_arrays_ok(I, fn, vr, nvr, values, nValues, type)) return fmi3Error;
    for (k = 0; k < nvr; k++) {
        const gw_array *a = type == GW_REAL ? gw_fmi3_array_find(I->m, vr[k]) : NULL;
        const gw_variable *v;
        double d;
        if (a) { /* an output, as every array of this FMU */
            GW_LOG_ERR(I, "%s: variable %s (vr=%u) is read-only", fn, a->name, a->vr);
            return fmi3Error;
        }
        v = gw_fmi3_lookup(I, fn, vr[k], type, &time);
        if (time) {
            GW_LOG_ERR(I, "%s: value reference 0 (time) is the independent variable and "
                       "cannot be set%s", fn, gw_fmi3_is_me(F) ? " (use fmi3SetTime)" : "");
            return fmi3Error;
        }
        if (!v || !gw_front_settable(I, fn, v, (F->state & GW3_MASK_Set) != 0,
                                     (F->state & GW3_MASK_SetDiscrete) != 0,
                                     gw_fmi3_state_name(F->state),
                                     gw_fmi3_is_me(F) ? " (use fmi3SetContinuousStates)" : ""))
            return fmi3Error;
        switch (type) {
        case GW_REAL: d = ((const fmi3Float64 *)values)[k]; break;
        case GW_INTEGER: d = (double)((const fmi3Int32 *)values)[k]; break;
        case GW_ENUM: d = (double)((const fmi3Int64 *)values)[k]; break;
        default: d = ((const fmi3Boolean *)values)[k] ? 1.0 : 0.0; break;
        }
        GW3_TRY(gw_value_check(I, fn, v, d));
        gw_value_set(I, v, d);
    }
END:
    return status;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    GW3_FRAME(SetFloat64);
    status = gw_fmi3_set(F, fn, valueReferences, nValueReferences, values, nValues, GW_REAL);
    GW3_FRAME_END();
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Int32 values[], size_t nValues) {
    GW3_FRAME(SetInt32);
    status = gw_fmi3_set(F, fn, valueReferences, nValueReferences, values, nValues, GW_INTEGER);
    GW3_FRAME_END();
}

fmi3Status fmi3SetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Int64 values[], size_t nValues) {
    GW3_FRAME(SetInt64);
    status = gw_fmi3_set(F, fn, valueReferences, nValueReferences, values, nValues, GW_ENUM);
    GW3_FRAME_END();
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues) {
    GW3_FRAME(SetBoolean);
    status = gw_fmi3_set(F, fn, valueReferences, nValueReferences, values, nValues, GW_BOOLEAN);
    GW3_FRAME_END();
}

/* ---- the types this FMU has no variable of ---------------------------------------------------
 * nValueReferences == 0 is fmi3OK (nothing asked); any value reference is fmi3Error with what
 * the variable is ("value reference 7 (x) is a Float64 variable", "unknown value reference"). */
static fmi3Status gw_fmi3_no_such_type(fmi3Instance instance, const char *fn, int mask,
                                       const fmi3ValueReference vr[], size_t nvr) {
    gw_fmu3 *F = (gw_fmu3 *)instance;
    int time;
    if (!gw_fmi3_interface(F, fn, GW3_IFACE_ANY) || !gw_fmi3_begin(F, fn, mask))
        return fmi3Error;
    if (nvr == 0) return fmi3OK;
    if (!vr)
        GW_LOG_ERR(F->I, "%s: NULL array for %lu value references", fn, (unsigned long)nvr);
    else
        (void)gw_fmi3_lookup(F->I, fn, vr[0], -1, &time); /* logs what vr[0] is */
    return gw_fmi3_end(F, fmi3Error);
}

/* fmi3Get<T> and fmi3Set<T> of a type T (C type CT) without variables; SET_MASK: the states
 * of the setter (a Float32 may be continuous, settable in Continuous-Time Mode) */
#define GW3_NO_SUCH_TYPE(T, CT, SET_MASK)                                                      \
    fmi3Status fmi3Get##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],   \
                          size_t nValueReferences, CT values[], size_t nValues) {               \
        (void)values;                                                                           \
        (void)nValues;                                                                          \
        return gw_fmi3_no_such_type(instance, "fmi3Get" #T, GW3_MASK_Get, valueReferences,     \
                                    nValueReferences);                                          \
    }                                                                                           \
    fmi3Status fmi3Set##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],   \
                          size_t nValueReferences, const CT values[], size_t nValues) {         \
        (void)values;                                                                           \
        (void)nValues;                                                                          \
        return gw_fmi3_no_such_type(instance, "fmi3Set" #T, SET_MASK,                          \
                                    valueReferences, nValueReferences);                         \
    }

GW3_NO_SUCH_TYPE(Float32, fmi3Float32, GW3_MASK_Set)
GW3_NO_SUCH_TYPE(Int8, fmi3Int8, GW3_MASK_SetDiscrete)
GW3_NO_SUCH_TYPE(UInt8, fmi3UInt8, GW3_MASK_SetDiscrete)
GW3_NO_SUCH_TYPE(Int16, fmi3Int16, GW3_MASK_SetDiscrete)
GW3_NO_SUCH_TYPE(UInt16, fmi3UInt16, GW3_MASK_SetDiscrete)
GW3_NO_SUCH_TYPE(UInt32, fmi3UInt32, GW3_MASK_SetDiscrete)
GW3_NO_SUCH_TYPE(UInt64, fmi3UInt64, GW3_MASK_SetDiscrete)
GW3_NO_SUCH_TYPE(String, fmi3String, GW3_MASK_SetDiscrete)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, size_t valueSizes[], fmi3Binary values[],
                         size_t nValues) {
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return gw_fmi3_no_such_type(instance, "fmi3GetBinary", GW3_MASK_Get, valueReferences,
                                nValueReferences);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues) {
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return gw_fmi3_no_such_type(instance, "fmi3SetBinary", GW3_MASK_SetDiscrete,
                                valueReferences, nValueReferences);
}

#endif /* GW_UNITY_BUILD */
