"""The event indicators at a point where the Taylor kernel has just run, from its order-0 row.

Solver taylor and the ensemble compute the series at each attempt's end point (t1, P(h)) before
the step is accepted (its order 1 is the defect check's f(t1, P(h))); accepting the step then
evaluates the event indicators at that same point (c_src/gw_events.c).  The fall event sin(beta)
- sin(beta_min) costs one sine per step there, while the kernel's order-0 row already holds
sin(beta) (its sincos node of state beta).  This module writes `GW_TL(evt)`, the indicators
from that row: the model's own `evt` casadi.Function (the one CasADi generates as gw_evt, with
the hoisted parameter part c = ode_pre(p) as its fifth input when there is one), instruction by
instruction in its order, each operation the C one CasADi's code generator writes for it (so the
same IEEE operations on the same values: the same bits, fmu_build/casadi_c.py's gw_sin / gw_cos
for the sines left), except that a sin, cos, sinh or cosh of a state or of t reads the kernel's
node for it.  That value is the kernel's order 0 (gw_sincos in the kernel's clones, whose
polynomial the compiler may contract into FMAs): equal to gw_sin's to a rounding, usually bit for
bit; every other value is gw_evt's bit for bit.

No function (GW_TL_HAS_EVT 0: the runtime evaluates gw_evt as before) when the model has no
events, when nothing is read from the kernel (no gain), when the indicators are not a dense
vector, or when an instruction is not one of the operations below (e.g. erf, a call): gw_evt
stays the one definition then.
"""
from __future__ import annotations

import math

import casadi as ca

from gyrowheel.taylor.graph import C_EXPR, OP_NAMES, UNARY, Decomposition

__all__ = ["event_source", "kernel_nodes"]

# the C of each op as CasADi's generated code writes it: taylor/graph.py's C_EXPR (sign there is
# casadi_sign's), except sin and cos, which the generated C takes from gw_sincos.h
# (fmu_build/casadi_c.py)
_C = {**C_EXPR, "sin": "gw_sin({0})", "cos": "gw_cos({0})"}
_PAIRS = {"sincos": ("sin", "cos"), "sinhcosh": ("sinh", "cosh")}


def kernel_nodes(dec: Decomposition) -> dict[tuple[str, int], int]:
    """{(op, i): node}: the kernel's var node holding op(state i) (i = -1: op(t)) at order 0, for
    op in sin, cos, sinh, cosh (the pairs' two nodes)."""
    found = {}
    for n, nd in dec.nodes.items():
        if nd.op not in _PAIRS or len(nd.args) != 1 or nd.args[0][0] != "v":
            continue
        a = nd.args[0][1]
        i = a if a < dec.nx else -1 if a == dec.t_node else None
        if i is not None:
            first, second = _PAIRS[nd.op]
            found[first, i] = n
            found[second, i] = nd.extra[0]
    return found


def _literal(v: float) -> str:
    if math.isnan(v):
        return "NAN"
    if math.isinf(v):
        return "HUGE_VAL" if v > 0 else "(-HUGE_VAL)"
    return repr(float(v))


def event_source(evt: ca.Function | None, dec: Decomposition) -> str:
    """C text for the kernel template (gw_taylor_model.h): GW_TL_HAS_EVT and, when 1,

        static void GW_TL(evt)(const double *w0, double t, const double *u, const double *p,
                               const double *c, double *e)

    e (ne) = the indicators at the point whose series' order-0 row of one lane is w0 (node n at
    w0[n GW_TL_W]: gw_tl*_series's layout from that lane's number), t its time, u, p, c the
    lane's inputs, parameters and hoisted constants (c unused when evt takes 4 inputs).
    evt: the model's evt(t, x, u, p[, c]) -> e as code-generated (codegen.generate_functions)."""
    off = "#define GW_TL_HAS_EVT 0\n"
    if evt is None or evt.n_out() != 1 or evt.n_in() not in (4, 5) or evt.nnz_out(0) == 0:
        return off
    if not evt.sparsity_out(0).is_dense() or evt.nnz_in(1) != dec.nx:
        return off
    shared = kernel_nodes(dec)
    ins = {0: "t", 2: "u", 3: "p", 4: "c"}
    src: dict[int, tuple[str, int]] = {}  # work slot -> ("x", i) / ("t", -1): an input as read
    expr: dict[int, str] = {}  # work slot -> its C value now
    lines, used = [], 0
    for k in range(evt.n_instructions()):
        op = OP_NAMES.get(evt.instruction_id(k), "?")
        i_in, i_out = evt.instruction_input(k), evt.instruction_output(k)
        if op == "input":
            arg, nz = i_in
            src[i_out[0]] = ("x", nz) if arg == 1 else ("t", -1) if arg == 0 else ("", 0)
            expr[i_out[0]] = f"w0[{nz} * GW_TL_W]" if arg == 1 else "t" if arg == 0 else f"{ins[arg]}[{nz}]"
            continue
        if op == "const":
            src.pop(i_out[0], None)
            expr[i_out[0]] = _literal(evt.instruction_constant(k))
            continue
        if op == "output":
            lines.append(f"    e[{i_out[1]}] = {expr[i_in[0]]};")
            continue
        if op not in _C:
            return off  # no C of it here: gw_evt keeps the indicators
        args = [expr[a] for a in i_in[:1 if op in UNARY else 2]]
        s = src.get(i_in[0])
        if op in ("sin", "cos", "sinh", "cosh") and s and (op, s[1]) in shared and s[0]:
            value = f"w0[{shared[op, s[1]]} * GW_TL_W]"  # the kernel's order 0
            used += 1
        else:
            value = _C[op].format(*args)
        lines.append(f"    const double g{k} = {value};")
        src.pop(i_out[0], None)
        expr[i_out[0]] = f"g{k}"
    if not used:
        return off
    return f"""#define GW_TL_HAS_EVT 1
/* The event indicators e at the point of a lane's series, from its order-0 row w0 (node n at
 * w0[n GW_TL_W]): gw_evt's operations in its order, {used} sine(s) read from the kernel's nodes
 * (taylor/events.py).  Not a target clone: the FMU's default code, as gw_evt. */
static GW_MAYBE_UNUSED void GW_TL(evt)(const double *w0, double t, const double *u,
                                       const double *p, const double *c, double *e) {{
    (void)w0;
    (void)t;
    (void)u;
    (void)p;
    (void)c;
{chr(10).join(lines)}
}}
"""
