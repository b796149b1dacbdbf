/*
 * gw_taylor.c -- the model's Taylor kernel for one trajectory (solver `taylor`): the generated
 * gw_taylor_model.h (with gw_taylor_ops.h) instantiated with one lane.  Part of the unity build
 * after gw_funcs.c, before model_desc.c.  The ensemble library instantiates the cst and jet
 * templates with GW_ENSEMBLE_LANES lanes (gw_ensemble.c).
 *
 * A model built without a kernel (a scene with contact modes, a named solver other than taylor,
 * or the build option --no-taylor) has a gw_taylor_model.h of one comment: this file then defines nothing
 * and leaves GW_TAYLOR_KERNEL undefined, so gw_solver_taylor.c compiles only the refusal of
 * solver taylor and the binary holds no Taylor code.  With a kernel it defines
 *   GW_TAYLOR_KERNEL          1: the unit has the kernel (gw_solver_taylor.c, gw_solver.h)
 *   gw_tl1_cst, gw_tl1_jet    the model's GW_MODEL.taylor points at them
 *   gw_tl1_series             the series in the kernel's order-major layout, which
 *                             gw_integrate_taylor reads as it is (node n, order k at
 *                             [k GW_TL_NODES + n])
 *   gw_tl1_evt                the event indicators from a series' order 0 (taylor/events.py),
 *                             where the model has them (GW_TL_HAS_EVT)
 *   gw_tl1_evt_slope          the same and their time derivatives from orders 0 and 1
 *                             (GW_TL_HAS_EVT_SLOPE)
 *
 * Two copies (GW_TAYLOR_FAST): on x86-64 with GCC >= 8 or clang >= 14 the kernel is compiled
 * twice, as portable code (gw_tl1d_*) and for x86-64-v3 (gw_tl1v3_*; GCC < 12 and clang, whose
 * __builtin_cpu_supports cannot ask for the level: for AVX2 and FMA, its floating point), with
 * multiply-adds fused (GCC: fp-contract=fast for both copies, as -std=c99 turns it off; clang
 * fuses within an expression by default).
 * Each entry point asks gw_taylor_fast() which copy this CPU runs: __builtin_cpu_supports reads
 * the features the compiler's runtime (libgcc, compiler-rt) detected when the program was
 * loaded, a load and a test per call; nothing is written, no state of the runtime's own.
 * Measured 0.69 -> 0.63 us per order-13 jet on the paper wheel (benchmarks/taylor_kernel_bench.py).
 * Not target_clones: its resolvers (IFUNCs) run while the program is being loaded, before a
 * sanitizer's runtime is set up (ThreadSanitizer: SIGSEGV before main), clang exports them as
 * global `<name>.resolver` symbols, and clang 14's resolver for arch=x86-64-v3 never chose the
 * fast clone on an Intel or AMD CPU.  GW_NO_CLONES: the portable copy only, whatever the CPU
 * (the same numbers on every x86-64 machine; docs/c_api.md).
 */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#include <math.h>
#include <stddef.h>

#include "gw_core.h"

/* (the ensemble library built by clang: none, as its passes, below) */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(GW_NO_CLONES) &&                         \
    ((defined(__clang__) && __clang_major__ >= 14 && !defined(GW_ENSEMBLE_LANES)) ||                \
     (!defined(__clang__) && __GNUC__ >= 8))
#define GW_TAYLOR_FAST 1
#if !defined(__clang__) && __GNUC__ >= 12
#define GW_TAYLOR_FAST_TARGET "arch=x86-64-v3"
#define GW_TAYLOR_FAST_CPU() __builtin_cpu_supports("x86-64-v3")
#else /* older GCC and clang do not name the level in __builtin_cpu_supports: what its floating
       * point adds (AVX2, FMA), each checked */
#define GW_TAYLOR_FAST_TARGET "avx2,fma"
#define GW_TAYLOR_FAST_CPU() (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
#endif
#if defined(__clang__)
#define GW_TAYLOR_BASE_ATTR
#define GW_TAYLOR_FAST_ATTR __attribute__((target(GW_TAYLOR_FAST_TARGET)))
#else
/* expensive-optimizations: GCC forms the fused multiply-adds in a pass that only that flag (on
 * from -O2) runs, so without it a build at -O1 (OPTIMISE_LARGE, GYROWHEEL_OPTIMISE) would have a
 * kernel without FMAs, slower and with other bits than at -O2; with it the kernel's results are
 * the same at -O1 and -O2 (tests/test_fmu_sources.py) */
#define GW_TAYLOR_OPT optimize("fp-contract=fast", "expensive-optimizations")
#define GW_TAYLOR_BASE_ATTR __attribute__((GW_TAYLOR_OPT))
#define GW_TAYLOR_FAST_ATTR __attribute__((target(GW_TAYLOR_FAST_TARGET), GW_TAYLOR_OPT))
#endif
#else
#define GW_TAYLOR_FAST 0
#define GW_TAYLOR_BASE_ATTR
#endif

/* The ensemble library only (not an FMU, not an export: gw_ensemble_lib.c defines
 * GW_ENSEMBLE_LANES): its increments pass (GW_ENS_PASS_FMA, gw_ensemble_passes.h) equals the
 * increments of gw_solver_taylor.c lane by lane, so it is compiled for the same two targets, as
 * target clones chosen by the same CPU check (GCC's resolver of arch=x86-64-v3).  Built by
 * clang the library has one portable copy here, as clang 14's resolvers choose the default
 * clone of its passes on Intel and AMD CPUs. */
#if defined(GW_ENSEMBLE_LANES) && GW_TAYLOR_FAST && defined(__ELF__) && defined(__GLIBC__)
#define GW_TL_CLONED                                                                               \
    __attribute__((target_clones("arch=x86-64-v3", "default"), GW_TAYLOR_OPT))
#endif

/* the portable copy (the only one without GW_TAYLOR_FAST) */
#define GW_TL_W 1
#define GW_TL_STATIC static GW_MAYBE_UNUSED GW_TAYLOR_BASE_ATTR
#define GW_TL(name) gw_tl1d_##name
#include "gw_taylor_model.h"
#undef GW_TL
#undef GW_TL_STATIC

#ifdef GW_TL_NX /* a kernel */
#define GW_TAYLOR_KERNEL 1

#if GW_TAYLOR_FAST
/* the copy for AVX2 with FMA */
#define GW_TL_STATIC static GW_MAYBE_UNUSED GW_TAYLOR_FAST_ATTR
#define GW_TL(name) gw_tl1v3_##name
#include "gw_taylor_model.h"
#undef GW_TL
#undef GW_TL_STATIC

/* 1: this CPU runs the copies for AVX2 with FMA (the kernel's, gw_solver_taylor.c's increments) */
static GW_MAYBE_UNUSED int gw_taylor_fast(void) { return GW_TAYLOR_FAST_CPU() != 0; }
#define GW_TAYLOR_PICK(fast, base) (gw_taylor_fast() ? (fast) : (base))
#else
#define GW_TAYLOR_PICK(fast, base) (base)
#endif

static GW_MAYBE_UNUSED void gw_tl1_cst(const double *u, const double *p, double *c) {
    GW_TAYLOR_PICK(gw_tl1v3_cst, gw_tl1d_cst)(u, p, c);
}

static GW_MAYBE_UNUSED void gw_tl1_series(int order, const double *t, const double *x,
                                          const double *c, double *w) {
    GW_TAYLOR_PICK(gw_tl1v3_series, gw_tl1d_series)(order, t, x, c, w);
}

static GW_MAYBE_UNUSED void gw_tl1_jet(int order, const double *t, const double *x,
                                       const double *c, double *w) {
    GW_TAYLOR_PICK(gw_tl1v3_jet, gw_tl1d_jet)(order, t, x, c, w);
}

#if GW_TL_HAS_EVT /* plain code in both copies (as gw_evt): the portable one */
static GW_MAYBE_UNUSED void gw_tl1_evt(const double *w0, double t, const double *u,
                                       const double *p, const double *c, double *e) {
    gw_tl1d_evt(w0, t, u, p, c, e);
}
#if GW_TL_HAS_EVT_SLOPE
static GW_MAYBE_UNUSED void gw_tl1_evt_slope(const double *w0, const double *w1, double t,
                                             const double *u, const double *p, const double *c,
                                             double *e, double *d) {
    gw_tl1d_evt_slope(w0, w1, t, u, p, c, e, d);
}
#endif
#endif
#endif /* GW_TL_NX */
#undef GW_TL_W

#endif /* GW_UNITY_BUILD */
