"""Parameter-only subexpressions of the right-hand side, computed once instead of at every call.

The accelerations contain subexpressions of the parameters alone: (1 + k_axial), R (1 + k_diam),
g / R, ... A hand-written right-hand side computes them once; a generated one recomputes them at
every evaluation. `split_parameters` finds every maximal parameter-only node that a node depending
on the state uses, and returns

    pre(p)          -> c                   the hoisted values (c_j = the j-th such node)
    f(t, x, u, p, c) = f(t, x, u, p)       the expression with those nodes replaced by c_j

The runtime evaluates `pre` when the parameters change (c_src/gw_eval.c, model function
`ode_pre`), so an evaluation of f costs only what depends on the state. The FMU splits the
right-hand side and the event indicators together (fmu_build/codegen.py `hoisted`: the fall
event sin(beta) - sin(beta_min) then costs one sine per evaluation). Constants and bare
parameter symbols are never hoisted (nothing to save).
"""
from __future__ import annotations

import casadi as ca


def _binary(op: int) -> bool:
    return op in (ca.OP_ADD, ca.OP_SUB, ca.OP_MUL, ca.OP_DIV, ca.OP_POW, ca.OP_CONSTPOW, ca.OP_FMIN, ca.OP_FMAX,
                  ca.OP_ATAN2, ca.OP_IF_ELSE_ZERO, ca.OP_LT, ca.OP_LE, ca.OP_EQ, ca.OP_NE, ca.OP_AND, ca.OP_OR,
                  ca.OP_COPYSIGN, ca.OP_FMOD, ca.OP_HYPOT)


def split_parameters(expr: ca.SX, inputs: list[ca.SX], p: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """(c, expr_c, c_sym): expr with its hoistable parameter-only nodes replaced by the symbols
    c_sym, whose values are c (an expression of p alone).  inputs: the other arguments of expr
    (t, x, u); p: the parameters.  Shapes: c and c_sym (n, 1), expr_c like expr."""
    expr = ca.SX(expr)
    f = ca.Function("hoist", [*inputs, p], [ca.densify(ca.vec(expr))])
    n_p_input = len(inputs)
    node: dict[int, ca.SX] = {}  # work index -> rebuilt node (in terms of inputs, p and c_sym)
    orig: dict[int, ca.SX] = {}  # work index -> node in terms of p (parameter-only nodes)
    kind: dict[int, str] = {}  # "const", "par" (a bare parameter), "pexpr" (parameter-only), "var"
    hoisted: list[ca.SX] = []
    c_syms: list[ca.SX] = []
    cache: dict[str, ca.SX] = {}  # the hoisted expression (printed) -> its symbol
    out = [ca.SX(0)] * expr.numel()

    def use(j: int) -> ca.SX:
        """The node j as an argument of a state-dependent node: hoisted if a parameter expression."""
        if kind[j] != "pexpr":
            return node[j]
        key = str(orig[j])  # equal parameter expressions share one hoisted value
        if key not in cache:
            sym = ca.SX.sym(f"c{len(c_syms)}")
            cache[key] = sym
            c_syms.append(sym)
            hoisted.append(orig[j])
        return cache[key]

    inputs_sx = [ca.SX(v) for v in inputs]
    for k in range(f.n_instructions()):
        op = f.instruction_id(k)
        o = f.instruction_output(k)
        i = f.instruction_input(k)
        if op == ca.OP_INPUT:
            which, nz = i[0], i[1]
            if which == n_p_input:
                node[o[0]] = orig[o[0]] = p[nz]
                kind[o[0]] = "par"
            else:
                node[o[0]] = inputs_sx[which].nz[nz]
                kind[o[0]] = "var"
        elif op == ca.OP_CONST:
            node[o[0]] = orig[o[0]] = ca.SX(float(f.instruction_constant(k)))
            kind[o[0]] = "const"
        elif op == ca.OP_OUTPUT:
            out[o[1]] = use(i[0]) if kind[i[0]] == "pexpr" else node[i[0]]
        else:
            args = list(i[:2]) if _binary(op) else [i[0]]
            if all(kind[j] != "var" for j in args):
                vals = [orig[j] for j in args]
                orig[o[0]] = ca.SX.binary(op, *vals) if len(vals) == 2 else ca.SX.unary(op, vals[0])
                node[o[0]] = orig[o[0]]
                kind[o[0]] = "pexpr"
            else:
                vals = [use(j) for j in args]
                node[o[0]] = ca.SX.binary(op, *vals) if len(vals) == 2 else ca.SX.unary(op, vals[0])
                kind[o[0]] = "var"
    expr_c = ca.SX.zeros(expr.size1(), expr.size2())
    for k, v in enumerate(out):
        expr_c[k % expr.size1(), k // expr.size1()] = v
    c = ca.vertcat(*hoisted) if hoisted else ca.SX(0, 1)
    c_sym = ca.vertcat(*c_syms) if c_syms else ca.SX(0, 1)
    return c, expr_c, c_sym
