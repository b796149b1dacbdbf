"""The W-lane Taylor kernel's series() at orders known at compile time (the ensemble library).

The kernel's loops over the orders k and over j in the interior sums have trip counts that
depend on the order p of a run; with p a constant every loop can be straight-line code, as a
JIT-compiled Taylor integrator has it (heyoka).  Measured on the paper kernel, 4 lanes, x86-64-v4
clone: order 8 1.10x, 10 1.18x, 12 1.2x faster; order 13 and above slower (0.77x at 13: the
straight-line code, 2.6 kB per order at 10, outgrows what unrolling saves), so only low orders
are specialised: those of rel_tol >= 1e-6 (p = ceil(-ln(rel_tol) / 2 + 1) + 4,
c_src/gw_solver_taylor.c).

GW_TL_FIXED_MAX (the ensemble's unity file, fmu_build/ensemble.py, defines it) enables it for
the W-lane instances (W > 1) under GCC: series() then dispatches orders 1 .. GW_TL_FIXED_MAX to
GW_TL(series_fixed), the same body inlined at a constant order with `#pragma GCC unroll` on its
loops.  The same operations in the same order: the same numbers bit for bit
(tests/test_taylor_kernel.py).  The one-lane kernel (solver taylor, the FMU) is unchanged.
"""
from __future__ import annotations

import re

__all__ = ["FIXED_ORDERS", "FIXED_DISPATCH", "fixed_series"]

FIXED_ORDERS = range(7, 17)  # the orders a library may specialise: the lowest a run takes is 7
# (p0 >= 3, gw_taylor_order), GW_TL_FIXED_MAX <= 16

FIXED_DISPATCH = """#if GW_TL_FIXED
    if (order >= 7 && order <= GW_TL_FIXED_MAX && __builtin_cpu_supports("x86-64-v4")) {
        GW_TL(series_at)(order, t, x, c, wi);
        return;
    }
#endif"""


def fixed_series(body: str) -> str:
    """GW_TL(series_fixed): the body of series() with its order and interior loops unrolled,
    and GW_TL(series_at), which runs it at orders 7 .. GW_TL_FIXED_MAX, compiled for
    x86-64-v4 (GCC's W-lane instances when GW_TL_FIXED_MAX is defined: GW_TL_FIXED 1, else 0)"""
    unrolled = re.sub(r"^(\s*)for \((k = 1; k < order|j = 2; j < k|j = 2; j <= k); ",
                      r"#pragma GCC unroll 32\n\1for (\2; ", body, flags=re.M)
    cases = "\n".join(f"#if GW_TL_FIXED_MAX >= {o}\n    case {o}: GW_TL(series_fixed)({o}, t, x, c, wi); return;\n#endif"
                      for o in FIXED_ORDERS)
    return (f"""#if defined(GW_TL_FIXED_MAX) && GW_TL_W > 1 && GW_TL_W <= 4 && defined(__GNUC__) && !defined(__clang__) && \\
    __GNUC__ >= 12 && defined(__x86_64__) && defined(__ELF__) && !defined(GW_NO_CLONES)
#define GW_TL_FIXED 1
/* series() at a compile-time order: every loop straight-line (fmu_build/taylor_fixed.py) */
static inline __attribute__((always_inline)) void GW_TL(series_fixed)(int order, const double *t,
        const double *x, const double *c, double *wi) {{
{unrolled}}}
/* series() at orders 7 .. GW_TL_FIXED_MAX for x86-64-v4 (its 32 vector registers: compiled for
 * AVX2's 16 the straight-line code spilled, 0.85x the loops), chosen at run time */
static __attribute__((target("arch=x86-64-v4"), noinline)) void GW_TL(series_at)(int order,
        const double *t, const double *x, const double *c, double *wi) {{
    switch (order) {{
{cases}
    default: break;
    }}
}}
#else
#define GW_TL_FIXED 0
#endif""")
