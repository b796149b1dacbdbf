/*
 * gw_fmi3_dirder.c -- fmi3GetDirectionalDerivative (sensitivity = J seed) and
 * fmi3GetAdjointDerivative (sensitivity^T = seed^T J), Co-Simulation and Model Exchange:
 * exact partial derivatives from the model's generated Jacobians, the same knowns and unknowns
 * as fmi2GetDirectionalDerivative (gw_partials.c), in every state where FMI 3.0.2 allows the
 * calls (section 2.3: Initialization, Event, Continuous-Time, Step Mode, Terminated; and after
 * an error, as the FMI 2.0 layer).  Every variable is a scalar: nSeed and nSensitivity must
 * equal the numbers of knowns and unknowns (section 2.2.12).  Time (value reference 0) is
 * neither a known nor an unknown, nor is an event indicator.
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu3.c */
#else

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

/* the sizes of the serialized seed and sensitivity (every variable a scalar), then the
 * derivatives of the current mode */
static gw_status gw_fmi3_pd(gw_fmu3 *F, const char *fn, int adjoint,
                            const fmi3ValueReference unknowns[], size_t nUnknowns,
                            const fmi3ValueReference knowns[], size_t nKnowns,
                            const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                            size_t nSensitivity) {
    gw_instance *I = F->I;
    size_t n_seed = adjoint ? nUnknowns : nKnowns, n_sens = adjoint ? nKnowns : nUnknowns;
    const char *seed_of = adjoint ? "unknowns" : "knowns";
    const char *sens_of = adjoint ? "knowns" : "unknowns";
    /* Initialization Mode has its own knowns (section 2.2.12: the InitialUnknowns and their
     * dependencies) when the model generated their derivatives */
    int init_mode = F->state == GW3_ST_INIT_MODE && I->f_dini.eval != NULL;
    if (nSeed != n_seed) {
        GW_LOG_ERR(I, "%s: nSeed = %lu, but there are %lu %s (scalars: one seed value each)", fn,
                   (unsigned long)nSeed, (unsigned long)n_seed, seed_of);
        return GW_ERROR;
    }
    if (nSensitivity != n_sens) {
        GW_LOG_ERR(I, "%s: nSensitivity = %lu, but there are %lu %s (scalars: one value each)",
                   fn, (unsigned long)nSensitivity, (unsigned long)n_sens, sens_of);
        return GW_ERROR;
    }
    return gw_partials(I, fn, init_mode, adjoint, &gw_fmi3_pd_words, unknowns, nUnknowns, knowns,
                       nKnowns, seed, sensitivity);
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
