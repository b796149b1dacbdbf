/*
 * gw_cpu_lanes.c -- the ensemble's lane count for the CPU this runs on (trajectories advanced
 * together, gyrowheel.taylor.lanes.cpu_lanes): a small shared library of its own, compiled once
 * and asked before an ensemble library of that width is built.
 *
 *     int gw_cpu_lanes(void)     8 with AVX-512F, 4 with AVX2, else GW_CPU_LANES_PORTABLE
 *     int gw_cpu_lanes_isa(void) 2: AVX-512F, 1: AVX2, 0: neither or not asked
 *
 * The features are read with __builtin_cpu_supports (GCC >= 4.8, clang), i.e. from what the
 * compiler's runtime (libgcc, compiler-rt) detected when the library was loaded: nothing is
 * written here, no state of our own.  Without that builtin (another compiler, another
 * architecture) the answer is GW_CPU_LANES_PORTABLE, a compile-time default.
 *
 * The widths (docs/performance.md, "The ensemble's lane count"): a lane slice of the Taylor
 * kernel is one vector register (gw_taylor_ops.h): 4 doubles with AVX2, 8 with AVX-512F (an
 * ensemble of 8 lanes there is built with 8-double slices, gyrowheel.taylor.lanes.slice_width;
 * per trajectory 0.63-0.78x the time of 4 lanes at N = 16 and 64 on one machine, 1.1-1.2x on
 * another of the same CPU model, so gyrowheel.taylor.lanes.ensemble_lanes times both kernels
 * there before it takes 8); without either (the portable build, SSE2 pairs on x86-64,
 * GW_NO_CLONES) 2 lanes measured fastest per trajectory, about half the time of 1 or 4 lanes at
 * N = 8, 16 and 64.
 *
 * gyrowheel.taylor.lanes compiles it from the installed runtime with -DGW_CPU_LANES_LIB; it is
 * no part of an FMU or an export (fmu_build/builder.py, HOST_ONLY), and compiled without that
 * macro it is empty, as every runtime file on its own.
 */
#ifndef GW_CPU_LANES_LIB
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see gw_fmu.c */
#else

#ifndef GW_CPU_LANES_PORTABLE
#define GW_CPU_LANES_PORTABLE 2
#endif

#if defined(__GNUC__)
#define GW_CPU_EXPORT __attribute__((visibility("default")))
#else
#define GW_CPU_EXPORT
#endif

#if (defined(__x86_64__) || defined(__i386__)) &&                                              \
    ((defined(__clang__) && __clang_major__ >= 6) ||                                            \
     (!defined(__clang__) && defined(__GNUC__) && (__GNUC__ > 4 || (__GNUC__ == 4 && __GNUC_MINOR__ >= 8))))
#define GW_CPU_ASK 1
#else
#define GW_CPU_ASK 0
#endif

GW_CPU_EXPORT int gw_cpu_lanes_isa(void);
GW_CPU_EXPORT int gw_cpu_lanes_isa(void) {
#if GW_CPU_ASK
    if (__builtin_cpu_supports("avx512f"))
        return 2;
    if (__builtin_cpu_supports("avx2"))
        return 1;
#endif
    return 0;
}

GW_CPU_EXPORT int gw_cpu_lanes(void);
GW_CPU_EXPORT int gw_cpu_lanes(void) {
    switch (gw_cpu_lanes_isa()) {
    case 2: /* AVX-512F: one 8-double slice */
        return 8;
    case 1: /* AVX2: one 4-double slice */
        return 4;
    default:
        return GW_CPU_LANES_PORTABLE;
    }
}

#endif /* GW_CPU_LANES_LIB */
