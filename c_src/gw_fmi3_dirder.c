/*
 * gw_fmi3_dirder.c -- fmi3GetDirectionalDerivative (sensitivity = J seed) and
 * fmi3GetAdjointDerivative (sensitivity^T = seed^T J), Co-Simulation and Model Exchange:
 * exact partial derivatives from the model's generated Jacobians, the same knowns and unknowns
 * as fmi2GetDirectionalDerivative (gw_partials.c), in every state where FMI 3.0.2 allows the
 * calls (section 2.3: Initialization, Event, Continuous-Time, Step Mode, Terminated; and after
 * an error, as the FMI 2.0 layer).  An array variable (x_state, contact_force) among the
 * knowns or unknowns stands for its elements, each a state or an output with a scalar
 * variable of its own: the lists are expanded into those scalars here, and nSeed and
 * nSensitivity count the serialized values, n per array (section 2.2.12).  Time (value
 * reference 0) is neither a known nor an unknown, nor is an event indicator.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu3.c */
#else

#include <stdlib.h>

#include "gw_fmi3.h"

/* the frames (GW3_FRAME_OPEN, gw_fmi3.h): interface, legal states */
#define GW3_IFACE_GetDirectionalDerivative GW3_IFACE_ANY
#define GW3_MASK_GetDirectionalDerivative                                                       \
    (GW3_ST_INIT_MODE | GW3_ST_EVENT_MODE | GW3_ST_CONT_TIME_MODE | GW3_ST_STEP_MODE |          \
     GW3_ST_TERMINATED | GW3_ST_ERROR)
#define GW3_IFACE_GetAdjointDerivative GW3_IFACE_ANY
#define GW3_MASK_GetAdjointDerivative GW3_MASK_GetDirectionalDerivative

/* the words of FMI 3.0.2 in gw_partials' messages */
static const gw_pd_words gw_fmi3_pd_words = {
    "unknowns", "knowns", "seed",
    "of Initialization Mode (a Float64 InitialUnknown, FMI 3.0.2 section 2.2.12)",
    "(a Float64 output, continuous state or state derivative; not an event indicator, FMI 3.0.2 "
    "section 2.2.12)",
    "a known of Initialization Mode (a Float64 parameter, start value or input)",
    "a continuous state or a Float64 input (parameters are knowns only in Initialization Mode, "
    "FMI 3.0.2 section 2.2.12)",
    1};

/* a model without `dir`: the function fails alike in every state (1: provided) */
static int gw_fmi3_pd_provided(gw_fmu3 *F, const char *fn, const char *flag) {
    if (F->I->f_dir.eval || F->state == GW3_ST_FATAL) return 1;
    GW_LOG_ERR(F->I, "%s: not provided by this FMU (%s=false)", fn, flag);
    gw_fmi3_set_state(F, GW3_ST_ERROR);
    return 0;
}

/* the scalar variable element k of array a stands for (gw_model.h: the state x[i] is one
 * variable, a start value or a state; the output y[j] an output, or a start value that is
 * output j); 0 if the FMU has none */
static unsigned int gw_fmi3_pd_element(const gw_model *m, const gw_array *a, int k) {
    int i, want = a->index[k];
    for (i = 0; i < m->n_vars; i++) {
        const gw_variable *v = &m->vars[i];
        int state = v->kind == GW_VAR_STATE || v->kind == GW_VAR_START;
        if (v->type != GW_REAL) continue;
        if (a->source == GW_ARRAY_X && state &&
            (v->state_index >= 0 ? v->state_index : v->kind == GW_VAR_STATE ? v->index : -1) == want)
            return v->vr;
        if (a->source == GW_ARRAY_Y &&
            ((v->kind == GW_VAR_OUTPUT && v->index == want) ||
             (v->kind == GW_VAR_START && v->out_index == want)))
            return v->vr;
    }
    return 0;
}

/* The references with every array variable replaced by its elements' scalar variables, in
 * order: the seed and the sensitivity are serialized element by element (FMI 3.0.2 section
 * 2.2.12, the serialization of section 2.2.7.1), so value l of either goes with scalar l.
 * *out is refs itself when none is an array, else a list the caller frees (*owned).
 * GW_OK, or GW_ERROR with the reason logged. */
static gw_status gw_fmi3_pd_expand(gw_instance *I, const char *fn, const char *what,
                                   const fmi3ValueReference refs[], size_t n,
                                   const fmi3ValueReference **out, size_t *n_out,
                                   fmi3ValueReference **owned) {
    const gw_model *m = I->m;
    size_t k, l, arrays = 0;
    int e;
    *out = refs;
    *n_out = n;
    *owned = NULL;
    if (m->n_arrays == 0 || !refs) return GW_OK;
    for (k = 0; k < n; k++) {
        const gw_array *a = gw_fmi3_array_find(m, refs[k]);
        if (a) *n_out += (size_t)a->n - 1, arrays++;
    }
    if (arrays == 0) return GW_OK;
    *owned = (fmi3ValueReference *)calloc(*n_out, sizeof(fmi3ValueReference));
    if (!*owned) {
        GW_LOG_ERR(I, "%s: out of memory for the %lu scalars of the %s", fn,
                   (unsigned long)*n_out, what);
        return GW_ERROR;
    }
    for (k = 0, l = 0; k < n; k++) {
        const gw_array *a = gw_fmi3_array_find(m, refs[k]);
        if (!a) {
            (*owned)[l++] = refs[k];
            continue;
        }
        for (e = 0; e < a->n; e++) {
            unsigned int vr = gw_fmi3_pd_element(m, a, e);
            if (vr == 0) { /* (_arrays of fmu_build/variables.py makes none such) */
                GW_LOG_ERR(I, "%s: %s[%lu]: element %d of %s (vr=%u) is no variable of this "
                           "FMU", fn, what, (unsigned long)k, e, a->name, a->vr);
                free(*owned);
                *owned = NULL;
                return GW_ERROR;
            }
            (*owned)[l++] = vr;
        }
    }
    *out = *owned;
    return GW_OK;
}

/* the sizes of the serialized seed and sensitivity (one value per scalar, n per array of n
 * elements), then the derivatives of the current mode for the scalars */
static gw_status gw_fmi3_pd(gw_fmu3 *F, const char *fn, int adjoint,
                            const fmi3ValueReference unknowns[], size_t nUnknowns,
                            const fmi3ValueReference knowns[], size_t nKnowns,
                            const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                            size_t nSensitivity) {
    gw_instance *I = F->I;
    const char *seed_of = adjoint ? "unknowns" : "knowns";
    const char *sens_of = adjoint ? "knowns" : "unknowns";
    /* Initialization Mode has its own knowns (section 2.2.12: the InitialUnknowns and their
     * dependencies) when the model generated their derivatives */
    /* Initialization Mode's knowns, also in the Error state of an instance that never ended
     * its initialisation (in_setup: its values are still the start values) */
    int init_mode = I->in_setup && I->f_dini.eval != NULL;
    const fmi3ValueReference *unk = NULL, *kno = NULL;
    fmi3ValueReference *unk_owned, *kno_owned = NULL;
    size_t n_unk = 0, n_kno = 0, n_seed, n_sens;
    gw_status st = gw_fmi3_pd_expand(I, fn, "unknowns", unknowns, nUnknowns, &unk, &n_unk,
                                     &unk_owned);
    if (st == GW_OK)
        st = gw_fmi3_pd_expand(I, fn, "knowns", knowns, nKnowns, &kno, &n_kno, &kno_owned);
    n_seed = adjoint ? n_unk : n_kno;
    n_sens = adjoint ? n_kno : n_unk;
    if (st == GW_OK && nSeed != n_seed) {
        GW_LOG_ERR(I, "%s: nSeed = %lu, but the %s have %lu values (one per scalar, n per "
                   "array variable)", fn, (unsigned long)nSeed, seed_of, (unsigned long)n_seed);
        st = GW_ERROR;
    }
    if (st == GW_OK && nSensitivity != n_sens) {
        GW_LOG_ERR(I, "%s: nSensitivity = %lu, but the %s have %lu values (one per scalar, n "
                   "per array variable)", fn, (unsigned long)nSensitivity, sens_of,
                   (unsigned long)n_sens);
        st = GW_ERROR;
    }
    if (st == GW_OK)
        st = gw_partials(I, fn, init_mode, adjoint, &gw_fmi3_pd_words, unk, n_unk, kno, n_kno,
                         seed, sensitivity);
    free(unk_owned);
    free(kno_owned);
    return st;
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance,
                                        const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns,
                                        const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity) {
    GW3_FRAME_OPEN(GetDirectionalDerivative);
    if (!gw_fmi3_pd_provided(F, fn, "providesDirectionalDerivatives")) return fmi3Error;
    GW3_FRAME_CHECK_STATE();
    GW3_TRY(gw_fmi3_pd(F, fn, 0, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity,
                       nSensitivity));
    GW3_FRAME_END();
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity) {
    GW3_FRAME_OPEN(GetAdjointDerivative);
    if (!gw_fmi3_pd_provided(F, fn, "providesAdjointDerivatives")) return fmi3Error;
    GW3_FRAME_CHECK_STATE();
    GW3_TRY(gw_fmi3_pd(F, fn, 1, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity,
                       nSensitivity));
    GW3_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
