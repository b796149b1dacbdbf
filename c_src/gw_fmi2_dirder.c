/*
 * gw_fmi2_dirder.c -- fmi2GetDirectionalDerivative (Co-Simulation and Model Exchange): exact
 * partial derivatives from the model's generated functions (gw_partials.c: the knowns and
 * unknowns of each mode, the checks of every reference and result), in every state where
 * FMI 2.0.4 allows the call (tables of sections 3.2.3 and 4.2.4).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include "gw_fmi2.h"

/* the frame of fmi2GetDirectionalDerivative (GW_FRAME_OPEN, gw_fmi2.h): interface, legal states */
#define GW_IFACE_GetDirectionalDerivative GW_IFACE_BOTH
#define GW_MASK_GetDirectionalDerivative                                                        \
    (GW_ST_INIT_MODE | GW_ST_STEP_COMPLETE | GW_ST_STEP_FAILED | GW_ST_TERMINATED |             \
     GW_ST_ERROR | GW_ST_ME)

/* the words of FMI 2.0.4 in gw_partials' messages */
static const gw_pd_words gw_fmi2_pd_words = {
    "vUnknown_ref", "vKnown_ref", "seed dvKnown",
    "of Initialization Mode (a Real InitialUnknown, FMI 2.0.4 section 2.2.8)",
    "(a Real output, continuous state or state derivative)",
    "a known of Initialization Mode (a Real parameter, start value or input)",
    "a continuous state or a Real input (parameters are knowns only in Initialization Mode, "
    "FMI 2.0.4 section 2.2.8)",
    0};

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    int init_mode;
    GW_FRAME_OPEN(GetDirectionalDerivative);
    /* a function the model does not provide fails alike in every state */
    if (!I->f_dir.eval && F->state != GW_ST_FATAL) {
        GW_LOG_ERR(I, "%s: not provided by this FMU (providesDirectionalDerivative=false)", fn);
        gw_fmi2_set_state(F, GW_ST_ERROR);
        return fmi2Error;
    }
    GW_FRAME_CHECK_STATE();
    /* Initialization Mode has its own knowns (FMI 2.0.4 section 2.2.8) when the model
     * generated their derivatives; a model without `dini` keeps the states as knowns there.
     * So has the Error state of an instance that never ended its initialisation (in_setup) */
    init_mode = I->in_setup && I->f_dini.eval != NULL;
    GW_TRY(gw_partials(I, fn, init_mode, 0, &gw_fmi2_pd_words, vUnknown_ref, nUnknown,
                       vKnown_ref, nKnown, dvKnown, dvUnknown));
    GW_FRAME_END();
}

#endif /* GW_UNITY_BUILD */
