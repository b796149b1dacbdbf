/*
 * gw_fmu3.c -- the whole FMI 3.0 FMU as ONE translation unit: the only source file of an
 * FMI 3.0 FMU's buildDescription.xml (gw_fmu.c is the FMI 2.0 FMU's; an FMU carries one of
 * the two).  It includes the generated model, the simulation core and the FMI 3.0 layer, so
 * that every function but the fmi3* entry points has internal linkage.  Build it with any
 * flags, e.g.
 *     cc -std=c99 -shared -fPIC gw_fmu3.c -o <modelIdentifier>.so -lm
 * and only fmi3* symbols are exported.  The other .c files of sources/ are parts of this one:
 * compiled on their own they are empty (docs/runtime.md).
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

/* the FMI 3.0 layer */
#include "gw_fmi3_common.c"
#include "gw_fmi3_variables.c"
#include "gw_fmi3_cs.c"
#include "gw_fmi3_me.c"
/* the partial derivatives of gw_fmi3_dirder.c, interface-neutral */
#include "gw_partials.c"
#include "gw_fmi3_dirder.c"
#include "gw_fmi3_state.c"
#include "gw_fmi3_absent.c"
