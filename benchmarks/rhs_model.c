/* The generated model of a scene behind an opaque boundary: its own translation unit, so that
 * rhs_bench.c times real calls through GW_MODEL's function pointers, as the runtime makes
 * them, and the compiler cannot inline the right-hand side into the timing loop. */
#define GW_UNITY_BUILD 1
#include "gw_funcs.c"
#include "gw_taylor.c" /* the Taylor kernel, where the build has one: model_desc.c points at it */
#include "model_desc.c"

const gw_model *rhs_bench_model(void);
const gw_model *rhs_bench_model(void) { return &GW_MODEL; }
