/*
 * gw_fmu.c -- the whole FMU as ONE translation unit: the only file listed in
 * modelDescription.xml <SourceFiles>.  It includes the generated model, the simulation core
 * and the FMI 2.0 layer, so that every function but the fmi2* entry points has internal
 * linkage (the runtime's are `static`, the model's too: GW_MODEL and the CasADi functions).
 * Build it with any flags, e.g.
 *     cc -std=c99 -shared -fPIC gw_fmu.c -o <modelIdentifier>.so -lm
 * and only fmi2* symbols are exported; two FMUs load into one process side by side.
 * The other .c files of sources/ are parts of this one: compiled on their own they are
 * empty, so building every .c file gives the same library (docs/runtime.md).
 *
 * GW_MODEL_SOURCE: a hand-written model instead of the generated one (the C tests' toy
 * models, e.g. -DGW_MODEL_SOURCE='"toy_oscillator.c"').
 */
#define GW_UNITY_BUILD 1

/* the model: CasADi functions and the GW_MODEL table (gw_model.h) */
#ifdef GW_MODEL_SOURCE
#include GW_MODEL_SOURCE
#else
#include "gw_funcs.c"
#include "gw_taylor.c"
#include "model_desc.c"
#endif

/* the simulation core */
#include "gw_core.c"

/* what the FMI 2.0 and FMI 3.0 layers share */
#include "gw_front.c"
#include "gw_me.c"
#include "gw_state_blob.c"

/* the FMI 2.0 layer */
#include "gw_fmi2_common.c"
#include "gw_fmi2_variables.c"
#include "gw_fmi2_cs.c"
#include "gw_fmi2_me.c"
/* the partial derivatives of gw_fmi2_dirder.c, interface-neutral */
#include "gw_partials.c"
#include "gw_fmi2_dirder.c"
#include "gw_fmi2_state.c"
