/*
 * gw_taylor.c -- the model's Taylor kernel for one trajectory (solver `taylor`): the
 * recurrences of gw_taylor_ops.h and the generated gw_taylor_model.h instantiated with one
 * lane, as gw_tl1_cst / gw_tl1_jet (the model's GW_MODEL.taylor points at them).  Part of the
 * unity build after gw_funcs.c, before model_desc.c.  The ensemble library instantiates the
 * same two templates with GW_ENSEMBLE_LANES lanes (gw_ensemble.c).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>
#include <stddef.h>

#include "gw_core.h"

/* gw_taylor_model.h includes the recurrences (gw_taylor_ops.h: plain static functions, inlined
 * as the compiler sees fit; forcing them inline makes the kernel ~25% faster but the build of a
 * large model minutes long).  A model built without a kernel (the default: only a scene with
 * solver = "taylor" or the build option asks for one) has a gw_taylor_model.h of one comment,
 * and this file compiles to nothing. */
#define GW_TL_W 1
#define GW_TL(name) gw_tl1_##name
#include "gw_taylor_model.h"
#undef GW_TL
#undef GW_TL_W
#undef GW_TL_INNER
#undef GW_TL_STATIC

#endif /* GW_UNITY_BUILD */
