"""C code of the Taylor kernel of one model, from its decomposition (gyrowheel.taylor.graph).

Writes gw_taylor_model.h, a template over the lane count W that the runtime instantiates
(c_src/gw_taylor.c with W = 1 for solver `taylor`; the ensemble library with W lanes):

    GW_TL_STATIC void GW_TL(cst)(const double *u, const double *p, double *c);
        the nodes depending only on u and p, once per integration call
    GW_TL_STATIC void GW_TL(jet)(int order, const double *t, const double *x, const double *c,
                           double *w);
        the Taylor series of order `order` of the states at (t, x): state i's coefficient k
        of lane l at w[(i (order + 1) + k) W + l], the first nx (order + 1) W numbers of w
        (the solution's Taylor polynomials); w holds GW_TL_NVAR series of order `order`.
    GW_TL_STATIC void GW_TL(series)(int order, const double *t, const double *x, const double *c,
                           double *wi);
        the same series in the kernel's own layout (below): state i's coefficient k of lane l
        at wi[(k GW_TL_ROW + i) W + l]

Vectors are lane-innermost: x[i W + l], u[j W + l], p[j W + l], c[j W + l], t[l].

Structure of jet (the recurrences and their split: c_src/gw_taylor_ops.h).  Behind the states'
output the kernel keeps every node's series order-major, wi[(k NODES + n) W + l] (NODES = the
var nodes plus the weighted series j a_j some recurrences use), so that coefficient k of all
nodes is one block at a compile-time offset from one pointer.  Order 0 is the plain
right-hand side.  Each order k >= 1 then has two phases:
  1. interior sums: every recurrence's sum over j = 1 .. k-1 of products of coefficients known
     before order k (a_j b_{k-j}, ...), all nodes at once: one loop over j (j = 2 .. k-1, then
     j = 1) per group of GROUP accumulators, its body straight-line independent multiply-adds
     (one per term, a W-wide vector operation for W lanes); the sums land in slot k of their
     nodes;
  2. in program order, each node's boundary terms (j = 0 and j = k: they need coefficient k of
     the operands) and its finishing operation (divide by b_0, by k, ...); the states get
     x_i^[k+1] = f_i^[k] / (k + 1).  A node whose coefficients no interior sum reads is a local
     variable here (no store and reload).
The one-lane kernel (GW_TL_PACK: GCC and clang) sums 4 terms per two 2-wide vector operations in
phase 1, from packed copies of the terms' operands behind each order's nodes; the denominators'
reciprocals are computed once at order 0.
No function calls, and code size O(nodes), whatever the order.  That is series(), the nodes'
series in this order-major layout (solver taylor's one-lane steps read the states' coefficients
there: GW_TL_NODES apart from one order to the next, c_src/gw_solver_taylor.c); jet() calls it
and copies the states' series to the output layout above.

This module writes the template around the statements; the parts, one job each:
  taylor/kernel_plan.py          the internal nodes (var nodes, weighted series, reciprocals) and
                                 every recurrence's interior terms, in their summation order
  taylor/kernel_recurrences.py   the C statements: order 0, phase 1 for W lanes, phase 2
  taylor/kernel_packs.py         the one-lane kernel's packed phase 1
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from gyrowheel.taylor.events import event_source
from gyrowheel.taylor.graph import Decomposition, decompose
from gyrowheel.taylor.kernel_packs import PACK_GROUP, Packs
from gyrowheel.taylor.kernel_plan import Plan
from gyrowheel.taylor.kernel_recurrences import (GROUP, boundary, cst_lines, interior_lines, local_variables,
                                                 loops, next_items, order0_slices, zero_lines)

__all__ = ["TaylorKernel", "taylor_source", "write_taylor_kernel", "work_series", "KERNEL_FILE",
           "GROUP"]

KERNEL_FILE = "gw_taylor_model.h"


@dataclass
class TaylorKernel:
    """What model_desc.c needs to know of the generated kernel (n_var: series of work)."""

    n_var: int
    n_cst: int
    has_t: bool
    op_counts: dict[str, int]


def work_series(dec: Decomposition) -> int:
    """Series of order `order` the kernel's work array w holds (GW_TL_NVAR): the states'
    output, then every internal node (var nodes and weighted series)."""
    return dec.nx + Packs(Plan(dec)).stride + 1  # + 1: room to align the nodes' block


def taylor_source(dec: Decomposition, model: str, evt: ca.Function | None = None) -> str:
    """The template text of gw_taylor_model.h for a decomposition (evt: the model's event
    indicators, read from the kernel's order-0 row where they can be: taylor/events.py)."""
    plan = Plan(dec)
    packs = Packs(plan)
    ops = ", ".join(f"{k} {v}" for k, v in sorted(dec.op_counts.items()))
    t_init = [] if dec.t_node is None else [f"        GW_L0({dec.t_node}) = t[l];"]
    n_groups = -(-len({t.target for t in plan.terms}) // GROUP)
    return f"""/* Generated by gyrowheel (taylor/kernel_c.py) from the ode of model {model!r}; do not edit.
 * Taylor kernel template: instantiated by c_src/gw_taylor.c (1 lane) and the ensemble library
 * (W lanes) with GW_TL_W and GW_TL(name) defined.  {dec.n_var} var nodes ({dec.nx} states
 * first{', t at ' + str(dec.t_node) if dec.t_node is not None else ''}), {len(plan.weighted)} weighted series, {dec.n_cst} constants.
 * var ops: {ops}
 * interior sums: {len(plan.terms)} terms in {n_groups} loops of up to {GROUP} accumulators (one lane:
 * {packs.slots} packed slots, {len(packs.groups)} vectors of 4, loops of up to {PACK_GROUP}) */
#include "gw_taylor_ops.h" /* the lane vectors GW_TL(v), GW_TLZ, GW_TLFMA, ... for GW_TL_W lanes */
#include "gw_sincos.h" /* gw_sincos at order 0 (sin and cos of one argument, <= 1 ulp) */
#define GW_TL_NX {dec.nx}
/* GW_TL_ROW: the numbers of a row (one order's coefficients): the internal series (var
 * nodes, weighted series, reciprocals); with GW_TL_PACK (one lane) then the terms' packed
 * operands.  GW_TL_NODES: the one-lane kernel's row, whatever W (solver taylor reads its states
 * there; the same text in every instance of one translation unit) */
#if GW_TL_PACK1
#define GW_TL_NODES {packs.stride}
#else
#define GW_TL_NODES {plan.n_nodes}
#endif
#if GW_TL_PACK
#define GW_TL_ROW {packs.stride}
#else
#define GW_TL_ROW {plan.n_nodes}
#endif
/* series of w: the states' output, the rows (aligned to a lane slice: one series of room) */
#define GW_TL_NVAR (GW_TL_NX + {packs.stride} + 1)
#define GW_TL_NCST {dec.n_cst}
#define GW_TL_HAS_T {1 if dec.t_node is not None else 0}

/* the constants of a step: nodes depending on u and p only */
GW_TL_STATIC void GW_TL(cst)(const double *u, const double *p, double *c) {{
    int l;
    (void)u;
    (void)p;
#define GW_LC(j) c[(size_t)(j) * GW_TL_W + l]
    for (l = 0; l < GW_TL_W; l++) {{
{chr(10).join(cst_lines(dec)) or '        (void)c;'}
    }}
#undef GW_LC
}}

/* The Taylor series of order `order` (>= 1) of every node at (t, x), order-major: coefficient k
 * of node n of lane l at wi[(k GW_TL_ROW + n) W + l], the states first (n = 0 .. NX - 1); wi
 * aligned to a lane slice, room for GW_TL_ROW (order + 1) W numbers.  The structure: the top
 * of taylor/kernel_c.py.  Solver taylor's one-lane steps read the states' series here
 * (gw_solver_taylor.c): no copy to another layout. */
GW_TL_STATIC void GW_TL(series)(int order, const double *t, const double *x, const double *c,
                                double *wi) {{
    double *vk = wi, *vn = wi + GW_TL_ROW * GW_TL_W;
    double rk = 1.0, rk1 = 1.0, dk = 1.0;
    int j, k, l;
    (void)t;
    (void)c;
    (void)j;
#define GW_ORD(k) (wi + (size_t)(k) * (GW_TL_ROW * GW_TL_W))
/* coefficient 0, k, k + 1 of node n and constant j: slice l (GW_TLX), or lane l (GW_L*) */
#define GW_V0(n) GW_TLR(wi + (n) * GW_TL_W + l * GW_TL_VW)
#define GW_VK(n) GW_TLX(vk + (n) * GW_TL_W + l * GW_TL_VW)
#define GW_VN(n) GW_TLX(vn + (n) * GW_TL_W + l * GW_TL_VW)
#define GW_C(j) GW_TLR(c + (j) * GW_TL_W + l * GW_TL_VW)
#define GW_L0(n) wi[(n) * GW_TL_W + l]
#define GW_LK(n) vk[(n) * GW_TL_W + l]
#define GW_LN(n) vn[(n) * GW_TL_W + l]
#define GW_LC(j) c[(j) * GW_TL_W + l]
#if GW_TL_PACK /* slot o of the packed operands (row k, k + 1); interior sum i */
#define GW_VPK(o) vk[o]
#define GW_VPN(o) vn[o]
#define GW_LPK(o) vk[o]
#define GW_LPN(o) vn[o]
#define GW_IS(i) gw_is[i]
{f"    double gw_is[{4 * len(packs.groups)}];" if packs.groups else ""}
#endif
#if GW_TL_V0 /* order 0 in slices where its operations allow: gw_taylor_ops.h */
#define GW_X0(n) GW_TLX(wi + (n) * GW_TL_W + l * GW_TL_VW)
{chr(10).join(loops(order0_slices(plan)))}
#undef GW_X0
#else
    for (l = 0; l < GW_TL_W; l++) {{
{chr(10).join([f"        GW_L0({i}) = x[{i} * GW_TL_W + l];" for i in range(dec.nx)] + t_init)}
{chr(10).join(zero_lines(plan))}
{chr(10).join("        " + text for _, text in next_items(plan, True))}
#if GW_TL_PACK
{chr(10).join("        " + text for item in next_items(plan, True) for _, text in packs.copy(*item))}
#endif
    }}
#endif
    for (k = 1; k < order; k++) {{
    vk = GW_ORD(k);
    vn = GW_ORD(k + 1);
    dk = k;
    rk = 1.0 / dk;
    rk1 = 1.0 / (dk + 1.0);
#if GW_TL_PACK
{chr(10).join(packs.interior_lines())}
{chr(10).join(loops(local_variables(plan, packs.copies(boundary(plan, packs.isum) + next_items(plan, False)), True)))}
#else
{chr(10).join(interior_lines(plan))}
{chr(10).join(loops(local_variables(plan, boundary(plan) + next_items(plan, False))))}
#endif
    }}
    (void)vk; /* unread when no node has a series (every derivative constant: x' = p) */
    (void)vn;
    (void)rk;
    (void)rk1;
    (void)dk;
#undef GW_ORD
#undef GW_V0
#undef GW_VK
#undef GW_VN
#undef GW_C
#undef GW_L0
#undef GW_LK
#undef GW_LN
#undef GW_LC
#if GW_TL_PACK
#undef GW_VPK
#undef GW_VPN
#undef GW_LPK
#undef GW_LPN
#undef GW_IS
#endif
}}

/* The states' Taylor series of order `order` at (t, x): state i's coefficient k of lane l at
 * w[(i (order + 1) + k) W + l]; w holds GW_TL_NVAR series (the nodes' block of series() behind
 * the states', aligned to a lane slice: measured 1.4x slower for 4 lanes at malloc's 16 bytes,
 * 32-byte loads across cache lines). */
GW_TL_STATIC void GW_TL(jet)(int order, const double *t, const double *x, const double *c, double *w) {{
    double *const wi = GW_TL_ALIGN(w + (size_t)GW_TL_NX * (size_t)(order + 1) * GW_TL_W);
    int i, k, l;
    GW_TL(series)(order, t, x, c, wi);
    for (i = 0; i < GW_TL_NX; i++) /* the states' series, to the output layout */
        for (k = 0; k <= order; k++)
            for (l = 0; l < GW_TL_W; l++)
                w[((size_t)i * (size_t)(order + 1) + (size_t)k) * GW_TL_W + l] =
                    wi[((size_t)k * GW_TL_ROW + (size_t)i) * GW_TL_W + l];
}}
/* the row's length, for a caller of series() that reads its layout in place (gw_ensemble.c) */
enum {{ GW_TL(row) = GW_TL_ROW }};
{event_source(evt, dec)}#undef GW_TLZ
#undef GW_TLFMA
#undef GW_TLFMS
#undef GW_TLFMA3
#undef GW_TLFMS3
#undef GW_TLST
#undef GW_TL_VW
#undef GW_TL_BLK
#undef GW_TL_UNROLL
#undef GW_TL_ALIGN
#undef GW_TLX
#undef GW_TLR
#undef GW_TL_PACK
#undef GW_TL_PACK1
#undef GW_TL_ROW
#undef GW_TLPR
#undef GW_TLPZ
#undef GW_TLPFMA
#undef GW_TLPST
#undef GW_TL_V0
"""


def write_taylor_kernel(ode: ca.Function, model: str, out_dir: Path,
                        evt: ca.Function | None = None) -> TaylorKernel:
    """Decompose `ode` and write gw_taylor_model.h into out_dir (evt: the event indicators as
    code-generated, taylor/events.py, event_source).

    Raises gyrowheel.taylor.graph.TaylorUnsupportedError for an operation without a recurrence.
    """
    dec = decompose(ode)
    (out_dir / KERNEL_FILE).write_text(taylor_source(dec, model, evt))
    return TaylorKernel(n_var=work_series(dec), n_cst=dec.n_cst, has_t=dec.t_node is not None,
                        op_counts=dict(dec.op_counts))
