"""The "limit" line of the work-precision tables (benchmarks/work_precision.py): what reaching an
error would cost if every operation of the cheapest right-hand side were computed once per
Taylor order of the fewest Taylor steps any method in the run needed.

For a target error e:

    L(e) = S(e) p(e) x n_ops x c_op

  S(e) p(e)  the smallest product of steps taken (accepted + rejected) and Taylor order over the
             Taylor runs of the same benchmark run that reach e: gyrowheel's solver taylor
             (steps from the FMU's logSolver record, order p0 + 4 with p0 = ceil(-ln(rel_tol)/2 + 1),
             c_src/gw_solver_taylor.c) and heyoka's taylor_adaptive (its propagate_until's step
             count and `order`).  A Taylor step of order p computes p coefficients of every
             elementary operation of the right-hand side.
  n_ops      the elementary operations of the minimal closed form of the wheel's right-hand side
             (benchmarks/minimal_wheel.h as heyoka expressions, peers._heyoka_system), counted in
             heyoka's decomposition of it (its u-variables: sin and cos of an angle, products,
             sums, differences, a quotient, multiplications by constants; 38 for the base wheel).
             Independent of gyrowheel's generator.
  c_op       the measured cost of one such operation: one evaluation of that closed form compiled
             as plain C (benchmarks/rhs_minimal.c timed by benchmarks/rhs_bench.c, the cheaper of
             libm's and gw_sincos2's sine and cosine, best of 5 runs, thread CPU time) over n_ops.

So L(e) = S p t_rhs: p evaluations of the cheapest right-hand side per step, at the fewest steps
any Taylor run needed.  It is a yardstick, not a proven bound: a Taylor coefficient of order k of a
product costs k multiply-adds, not one (a real step costs more than p evaluations), while a
vector unit can do several operations in the time of one (less); the per-call overhead of an FMU
or of heyoka's Python binding is outside it.  A method's distance from the limit is its time over
L(e): 1 is at the limit, 3 three times it.
"""
from __future__ import annotations

import math
from pathlib import Path

import peers

MAX_ORDER, EXTRA_ORDER = 30, 4  # GW_TAYLOR_MAX_ORDER, GW_TAYLOR_EXTRA_ORDER (c_src/gw_solver*.h/.c)


def taylor_order(rel_tol: float) -> int:
    """Solver taylor's order at rel_tol (c_src/gw_solver_taylor.c, gw_taylor_order)."""
    eps = max(rel_tol, 2.220446049250313e-16)
    p0 = min(max(math.ceil(-0.5 * math.log(eps) + 1.0), 3), MAX_ORDER)
    return min(p0 + EXTRA_ORDER, MAX_ORDER)


def operation_count(params) -> int:
    """Elementary operations of the minimal closed form (heyoka's decomposition: its entries less
    the 8 state variables at the front and the 8 outputs at the end).  params: (M, R, k_diam,
    k_axial, g)."""
    import heyoka as hy
    import numpy as np
    sys_ = peers._heyoka_system(params)
    ta = hy.taylor_adaptive(sys_, np.full(len(sys_), 0.5), tol=1e-8)
    return len(ta.decomposition) - 2 * len(sys_)


def rhs_seconds(sources: Path, work: Path, rounds: int = 5) -> float:
    """Seconds per evaluation of the minimal closed form in C: the cheaper of libm's and
    gw_sincos2's sin/cos (benchmarks/rhs_bench.c built against the FMU's `sources`)."""
    from paper_cost import rhs_ns
    _, libm_ns, fast_ns = rhs_ns(sources, work, rounds)
    return min(libm_ns, fast_ns) * 1e-9


def limits(points, targets, t_rhs: float) -> dict[float, tuple[float, int, int, str]]:
    """{target: (L seconds, steps, order, method)} from the Taylor points (those with steps and
    order) reaching each target; targets no Taylor run reached are left out."""
    out = {}
    for target in targets:
        work = [(p.steps * p.order, p.steps, p.order, p.method) for p in points
                if p.order > 0 and p.steps > 0 and p.error <= target]
        if work:
            w, steps, order, method = min(work)
            out[target] = (w * t_rhs, steps, order, method)
    return out


def limit_table(name: str, rows: dict[str, dict[float, float]], lim: dict, targets, n_ops: int,
                t_rhs: float) -> str:
    """Markdown: the limit per target, then each method's time over it ("-": not reached)."""
    cols = " | ".join(f"{t:.0e}" for t in targets)
    lines = [f"#### {name}: distance from the limit", "", f"| | {cols} |", "|---|" + "---|" * len(targets)]
    cells = [f"{lim[t][0] * 1e3:.3g} ms ({lim[t][1]} steps x order {lim[t][2]}, "
             f"{lim[t][3].split(' (')[0].removeprefix('gyrowheel/')})" if t in lim else "-"
             for t in targets]
    lines.append("| limit L | " + " | ".join(cells) + " |")
    for method, times in rows.items():
        cells = [f"{times[t] / lim[t][0]:.2g}" if t in times and t in lim else "-" for t in targets]
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    lines += ["", f"L = steps x order x {n_ops} operations (the minimal closed form's decomposition) x "
              f"{t_rhs / n_ops * 1e9:.3g} ns per operation (one evaluation of that form in C: "
              f"{t_rhs * 1e9:.3g} ns); a method's cell is its time over L (benchmarks/work_limit.py)."]
    return "\n".join(lines)
