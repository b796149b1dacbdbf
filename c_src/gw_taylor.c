/*
 * gw_taylor.c -- the model's Taylor kernel for one trajectory (solver `taylor`): the
 * generated gw_taylor_model.h (with gw_taylor_ops.h) instantiated with one
 * lane, as gw_tl1_cst / gw_tl1_jet (the model's GW_MODEL.taylor points at them) and
 * gw_tl1_series (the series in the kernel's order-major layout, which gw_integrate_taylor
 * reads as it is: GW_TL1_SERIES).  Part of the
 * unity build after gw_funcs.c, before model_desc.c.  The ensemble library instantiates the
 * cst and jet templates with GW_ENSEMBLE_LANES lanes (gw_ensemble.c).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>
#include <stddef.h>

#include "gw_core.h"

/* gw_taylor_model.h: the kernel, straight-line code per order with the lane macros of
 * gw_taylor_ops.h (no function calls).  A model built without a kernel (the default: only a
 * scene with solver = "taylor" or the build option asks for one) has a gw_taylor_model.h of one
 * comment, and this file compiles to nothing.
 * On x86-64 with glibc, GCC or clang, the kernel is also compiled for x86-64-v3 (AVX2, FMA) and
 * chosen at load time (target_clones, a portable default beside it), with multiply-adds fused
 * (GCC: fp-contract=fast for these two functions, as -std=c99 turns it off; clang fuses within
 * an expression by default): measured 0.69 -> 0.63 us per order-13 jet on the paper wheel
 * (benchmarks/taylor_kernel_bench.py).  GW_NO_CLONES turns it off. */
#if defined(__GNUC__) && defined(__x86_64__) && defined(__ELF__) && defined(__GLIBC__) &&          \
    !defined(GW_NO_CLONES) &&                                                                      \
    ((defined(__clang__) && __clang_major__ >= 14) || (!defined(__clang__) && __GNUC__ >= 8))
#if defined(__clang__)
#define GW_TL_CLONED __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define GW_TL_CLONED                                                                               \
    __attribute__((target_clones("arch=x86-64-v3", "default"), optimize("fp-contract=fast")))
#endif
#define GW_TL_STATIC static GW_TL_CLONED /* GW_TL_CLONED stays: gw_solver_taylor.c's increment */
#endif
#define GW_TL_W 1
#define GW_TL(name) gw_tl1_##name
#include "gw_taylor_model.h"
#ifdef GW_TL_NX /* a kernel: solver taylor's steps take its series in the nodes' own layout */
#define GW_TL1_SERIES 1
#endif
#undef GW_TL
#undef GW_TL_W
#undef GW_TL_INNER
#undef GW_TL_STATIC

#endif /* GW_UNITY_BUILD */
