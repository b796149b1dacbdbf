"""C code of the Taylor kernel of one model, from its decomposition (fmu_build.taylor_graph).

Writes gw_taylor_model.h, a template over the lane count W that the runtime instantiates
(c_src/gw_taylor.c with W = 1 for solver `taylor`; the ensemble library with W lanes):

    GW_TL_STATIC void GW_TL(cst)(const double *u, const double *p, double *c);
        the nodes depending only on u and p, once per integration call
    GW_TL_STATIC void GW_TL(jet)(int order, const double *t, const double *x, const double *c,
                           double *w);
        the Taylor series of order `order` of every var node at (t, x): node n's coefficient k
        of lane l at w[(n (order + 1) + k) W + l]; nodes 0 .. nx-1 are the states, so the
        first nx (order + 1) W numbers of w are the solution's Taylor polynomials.

Vectors are lane-innermost: x[i W + l], u[j W + l], p[j W + l], c[j W + l], t[l].
Order 0 is the plain right-hand side; order k >= 1 of each node uses the recurrences of
c_src/gw_taylor_ops.h; state i gets x_i^[k+1] = f_i^[k] / (k + 1).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from fmu_build.taylor_graph import C_EXPR, Decomposition, Operand, decompose

__all__ = ["TaylorKernel", "taylor_source", "write_taylor_kernel", "KERNEL_FILE"]

KERNEL_FILE = "gw_taylor_model.h"


@dataclass
class TaylorKernel:
    """What model_desc.c needs to know of the generated kernel."""

    n_var: int
    n_cst: int
    has_t: bool
    op_counts: dict[str, int]


def _v(n: int, k: str = "") -> str:
    return f"GW_V({n})[{k + ' + ' if k else ''}l]"


def _order0(a: Operand) -> str:
    return _v(a[1]) if a[0] == "v" else f"GW_C({a[1]})[l]"


def _order_k(a: Operand) -> str:
    """coefficient k >= 1 of an operand (a constant has none)"""
    return _v(a[1], "K") if a[0] == "v" else "0.0"


def _cst_lines(dec: Decomposition) -> list[str]:
    lines = []
    for j, (kind, payload) in enumerate(dec.cst):
        if kind in ("p", "u"):
            expr = f"{kind}[{payload} * GW_TL_W + l]"
        elif kind == "k":
            expr = repr(payload) if payload == payload else "(0.0 / 0.0)"
            if expr in ("inf", "-inf"):
                expr = ("-" if payload < 0 else "") + "HUGE_VAL"
        else:
            expr = C_EXPR[kind].format(*[_order0(a) for a in payload])
        lines.append(f"        GW_C({j})[l] = {expr};")
    return lines


def _zero_lines(dec: Decomposition) -> list[str]:
    """order 0: the right-hand side itself, in program order"""
    lines = []
    for n, node in dec.nodes.items():
        args = [_order0(a) for a in node.args]
        op = node.op
        if op in ("sincos", "sinhcosh"):
            f, g = ("sin", "cos") if op == "sincos" else ("sinh", "cosh")
            lines.append(f"        {_v(n)} = {f}({args[0]});")
            lines.append(f"        {_v(node.extra[0])} = {g}({args[0]});")
        elif op in ("tan", "tanh"):
            lines.append(f"        {_v(n)} = {op}({args[0]});")
            sign = "+" if op == "tan" else "-"
            lines.append(f"        {_v(node.extra[0])} = 1.0 {sign} {_v(n)} * {_v(n)};")
        elif op == "dq":
            zop, za = node.zero
            lines.append(f"        {_v(n)} = {C_EXPR[zop].format(_order0(za))};")
        else:
            lines.append(f"        {_v(n)} = {C_EXPR[op].format(*args)};")
    return lines


def _lanes(stmt: str) -> str:
    return f"    for (l = 0; l < GW_TL_W; l++) {stmt};"


def _k_lines(dec: Decomposition) -> list[str]:
    """order k >= 1 of every var node, in program order"""
    lines = []
    for n, node in dec.nodes.items():
        op, a = node.op, node.args
        out = _v(n, "K")
        vb = [f"GW_V({x[1]})" if x[0] == "v" else None for x in a]
        if op in ("add", "sub"):
            first, second = _order_k(a[0]), _order_k(a[1])
            sign = "+" if op == "add" else "-"
            expr = (f"{first} {sign} {second}" if a[0][0] == a[1][0] == "v"
                    else first if a[1][0] == "c" else (second if op == "add" else f"-{second}"))
            lines.append(_lanes(f"{out} = {expr}"))
        elif op == "neg":
            lines.append(_lanes(f"{out} = -{_order_k(a[0])}"))
        elif op == "twice":
            lines.append(_lanes(f"{out} = 2.0 * {_order_k(a[0])}"))
        elif op == "mul":
            if a[0][0] == a[1][0] == "v":
                lines.append(f"    GW_TL(mul)(GW_V({n}) + K, {vb[0]}, {vb[1]}, k);")
            else:
                c, v = (a[0], a[1]) if a[0][0] == "c" else (a[1], a[0])
                lines.append(_lanes(f"{out} = {_order0(c)} * {_order_k(v)}"))
        elif op == "sq":
            lines.append(f"    GW_TL(sq)(GW_V({n}) + K, {vb[0]}, k);")
        elif op == "div":
            num = f"{vb[0]} + K" if vb[0] else "NULL"
            lines.append(f"    GW_TL(div)(GW_V({n}), {num}, {vb[1]}, k);")
        elif op == "sqrt":
            lines.append(f"    GW_TL(sqrt)(GW_V({n}), {vb[0]} + K, k);")
        elif op in ("sincos", "sinhcosh"):
            sign = "-1.0" if op == "sincos" else "1.0"
            lines.append(f"    GW_TL(pair)(GW_V({n}), GW_V({node.extra[0]}), {vb[0]}, k, {sign});")
        elif op == "exp":
            lines.append(f"    GW_TL(dexp)(GW_V({n}), {vb[0]}, GW_V({n}), k);")
        elif op == "log":
            lines.append(f"    GW_TL(log)(GW_V({n}), {vb[0]}, k);")
        elif op in ("tan", "tanh"):
            sign = "1.0" if op == "tan" else "-1.0"
            lines.append(f"    GW_TL(tan)(GW_V({n}), GW_V({node.extra[0]}), {vb[0]}, k, {sign});")
        elif op == "dq":
            lines.append(f"    GW_TL(dq)(GW_V({n}), {vb[0]} + K, {vb[1]}, NULL, k);")
        elif op == "atan2":
            lines.append(f"    GW_TL(atan2)(GW_V({n}), {vb[0]}, {vb[1]}, {vb[2]}, k);")
        elif op == "pow":
            lines.append(f"    GW_TL(pow)(GW_V({n}), {vb[0]}, GW_C({a[1][1]}), k);")
        elif op == "fabs":
            lines.append(_lanes(f"{out} = {_order0(a[0])} < 0.0 ? -{_order_k(a[0])} : {_order_k(a[0])}"))
        elif op in ("fmin", "fmax"):
            cmp = "<=" if op == "fmin" else ">="
            lines.append(_lanes(f"{out} = {_order0(a[0])} {cmp} {_order0(a[1])} ? "
                                f"{_order_k(a[0])} : {_order_k(a[1])}"))
        elif op == "if_else_zero":
            lines.append(_lanes(f"{out} = {_order0(a[0])} != 0.0 ? {_order_k(a[1])} : 0.0"))
        else:  # piecewise constant
            lines.append(_lanes(f"{out} = 0.0"))
    return lines


def _state_lines(dec: Decomposition, order0: bool) -> list[str]:
    """x_i^[k+1] = f_i^[k] / (k + 1)"""
    lines = []
    for i, o in enumerate(dec.outputs):
        if order0:
            rhs = "0.0" if o is None else _order0(o)
            lines.append(f"        GW_V({i})[GW_TL_W + l] = {rhs};")
        else:
            rhs = "0.0" if o is None or o[0] == "c" else f"{_v(o[1], 'K')} * rk"
            lines.append(_lanes(f"GW_V({i})[K + GW_TL_W + l] = {rhs}"))
    return lines


def taylor_source(dec: Decomposition, model: str) -> str:
    """The template text of gw_taylor_model.h for a decomposition."""
    ops = ", ".join(f"{k} {v}" for k, v in sorted(dec.op_counts.items()))
    t_init = []
    if dec.t_node is not None:
        T = dec.t_node
        t_init = [f"        GW_V({T})[l] = t[l];", f"        GW_V({T})[GW_TL_W + l] = 1.0;"]
    body_t = ("    for (k = 2; k <= order; k++)\n"
              f"        for (l = 0; l < GW_TL_W; l++) GW_V({dec.t_node})[(size_t)k * GW_TL_W + l] = 0.0;\n"
              if dec.t_node is not None else "")
    return f"""/* Generated by gyrowheel (fmu_build/taylor_c.py) from the ode of model {model!r}; do not edit.
 * Taylor kernel template: instantiated by c_src/gw_taylor.c (1 lane) and the ensemble library
 * (W lanes) with GW_TL_W and GW_TL(name) defined.  {dec.n_var} var nodes ({dec.nx} states
 * first{', t at ' + str(dec.t_node) if dec.t_node is not None else ''}), {dec.n_cst} constants.
 * var ops: {ops} */
#include "gw_taylor_ops.h" /* the recurrences, instantiated for these GW_TL_W lanes */
#define GW_TL_NVAR {dec.n_var}
#define GW_TL_NCST {dec.n_cst}
#define GW_TL_HAS_T {1 if dec.t_node is not None else 0}

/* the constants of a step: nodes depending on u and p only */
GW_TL_STATIC void GW_TL(cst)(const double *u, const double *p, double *c) {{
    int l;
    (void)u;
    (void)p;
#define GW_C(j) (c + (size_t)(j) * GW_TL_W)
    for (l = 0; l < GW_TL_W; l++) {{
{chr(10).join(_cst_lines(dec)) or '        (void)c;'}
    }}
#undef GW_C
}}

/* Taylor series of order `order` (>= 1) of every var node at (t, x) */
GW_TL_STATIC void GW_TL(jet)(int order, const double *t, const double *x, const double *c, double *w) {{
    const size_t S = (size_t)(order + 1) * GW_TL_W;
    size_t K;
    double rk;
    int k, l;
    (void)t;
    (void)c;
#define GW_V(n) (w + (size_t)(n) * S)
#define GW_C(j) (c + (size_t)(j) * GW_TL_W)
    for (l = 0; l < GW_TL_W; l++) {{
{chr(10).join([f"        GW_V({i})[l] = x[{i} * GW_TL_W + l];" for i in range(dec.nx)] + t_init)}
{chr(10).join(_zero_lines(dec))}
{chr(10).join(_state_lines(dec, True))}
    }}
{body_t}    for (k = 1; k < order; k++) {{
    K = (size_t)k * GW_TL_W;
    rk = 1.0 / (k + 1);
{chr(10).join(_k_lines(dec))}
{chr(10).join(_state_lines(dec, False))}
    }}
    (void)K;
    (void)rk;
#undef GW_V
#undef GW_C
}}
"""


def write_taylor_kernel(ode: ca.Function, model: str, out_dir: Path) -> TaylorKernel:
    """Decompose `ode` and write gw_taylor_model.h into out_dir.

    Raises fmu_build.taylor_graph.TaylorUnsupportedError for an operation without a recurrence.
    """
    dec = decompose(ode)
    (out_dir / KERNEL_FILE).write_text(taylor_source(dec, model))
    return TaylorKernel(n_var=dec.n_var, n_cst=dec.n_cst, has_t=dec.t_node is not None,
                        op_counts=dict(dec.op_counts))
