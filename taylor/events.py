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
import re

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


def _instructions(evt: ca.Function):
    """(k, op name, inputs, outputs) of each instruction of evt, in its order."""
    for k in range(evt.n_instructions()):
        yield k, OP_NAMES.get(evt.instruction_id(k), "?"), evt.instruction_input(k), evt.instruction_output(k)


_INPUTS = {0: "t", 2: "u", 3: "p", 4: "c"}


def _input(arg: int, nz: int) -> tuple[tuple[str, int], str, str]:
    """An input instruction's element nz of evt's input arg: (what it is, ("x", i) / ("t", -1) /
    ("", 0), its C value (a state from the row of order 0), its C time derivative (a state's from
    the row of order 1; 1 for t; 0 for u, p and c))."""
    if arg == 1:
        return ("x", nz), f"w0[{nz} * GW_TL_W]", f"w1[{nz} * GW_TL_W]"
    if arg == 0:
        return ("t", -1), "t", "1.0"
    return ("", 0), f"{_INPUTS[arg]}[{nz}]", "0.0"


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
    src: dict[int, tuple[str, int]] = {}  # work slot -> ("x", i) / ("t", -1): an input as read
    expr: dict[int, str] = {}  # work slot -> its C value now
    lines, used = [], 0
    for k, op, i_in, i_out in _instructions(evt):
        if op == "input":
            src[i_out[0]], expr[i_out[0]], _ = _input(*i_in)
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
""" + _slope_source(evt, shared)


# d(op)/dt from the operands' values a, b, their derivatives da, db and the op's value g (first
# order forward differentiation; None: the op has no rule here, the runtime keeps its difference)
_DOT = {
    "add": "{da} + {db}", "sub": "{da} - {db}", "neg": "-{da}", "twice": "2.0 * {da}",
    "mul": "{da} * {b} + {a} * {db}", "div": "({da} - {g} * {db}) / {b}", "sq": "2.0 * {a} * {da}",
    "inv": "-{g} * {g} * {da}", "sqrt": "{da} / (2.0 * {g})",
    "sin": "gw_cos({a}) * {da}", "cos": "-gw_sin({a}) * {da}", "tan": "(1.0 + {g} * {g}) * {da}",
    "sinh": "cosh({a}) * {da}", "cosh": "sinh({a}) * {da}", "tanh": "(1.0 - {g} * {g}) * {da}",
    "exp": "{g} * {da}", "log": "{da} / {a}", "atan": "{da} / (1.0 + {a} * {a})",
    "asin": "{da} / sqrt(1.0 - {a} * {a})", "acos": "-{da} / sqrt(1.0 - {a} * {a})",
    "atan2": "({b} * {da} - {a} * {db}) / ({a} * {a} + {b} * {b})",
    "fabs": "({a} < 0.0 ? -{da} : {da})", "fmin": "({a} <= {b} ? {da} : {db})",
    "fmax": "({a} >= {b} ? {da} : {db})", "if_else_zero": "({a} != 0.0 ? {db} : 0.0)",
}
_PARTNER = {"sin": ("cos", ""), "cos": ("sin", "-"), "sinh": ("cosh", ""), "cosh": ("sinh", "")}
_PIECEWISE_CONSTANT = {"lt", "le", "eq", "ne", "not", "and", "or", "sign", "floor", "ceil"}


# the rules with a zero operand derivative left out (a constant operand: p, u, a literal)
_ONE_SIDED = {("add", "da"): "{db}", ("add", "db"): "{da}", ("sub", "da"): "-{db}",
              ("sub", "db"): "{da}", ("mul", "da"): "{a} * {db}", ("mul", "db"): "{da} * {b}",
              ("div", "db"): "{da} / {b}", ("atan2", "db"): "{b} * {da} / ({a} * {a} + {b} * {b})"}


def _derivative(op: str, rule: str, g: str, names: dict[str, str]) -> str:
    """C of d(op)/dt: the rule, "0.0" when every operand's derivative is zero, a one-sided rule
    when one of two is."""
    zero = [d for d in ("da", "db") if names.get(d) == "0.0"]
    if len(zero) == sum(d in names for d in ("da", "db")):
        return "0.0"
    if zero:
        rule = _ONE_SIDED.get((op, zero[0]), rule)
    return rule.format(g=g, **names)


def _drop_unread(lines: list[str]) -> list[str]:
    """The lines without the derivatives nothing reads (an operand of a comparison, say): a
    written-but-unread local is a warning, an error under -Werror."""
    kept = list(lines)
    for j in range(len(kept) - 1, -1, -1):
        m = re.match(r"    const double (d\d+) = ", kept[j])
        if m and not any(re.search(rf"\b{m[1]}\b", later) for later in kept[j + 1:]):
            del kept[j]
    return kept


def _slope_source(evt: ca.Function, shared: dict[tuple[str, int], int]) -> str:
    """GW_TL(evt_slope): the indicators e and their time derivatives d = de/dt at the point of a
    lane's series, from its rows of order 0 (w0) and 1 (w1: the states' derivatives there), both
    with node n at [n GW_TL_W] (d sin(beta)/dt = cos(beta) beta', both read): evt differentiated
    forward along the solution, instruction by instruction (the values are GW_TL(evt)'s, the
    same operations).  The indicators' slopes at a step's end then cost no evaluation of gw_evt
    at a nearby point (c_src/gw_events.c, crossings inside a step).  GW_TL_HAS_EVT_SLOPE 0 when
    an instruction has no rule here (pow with a varying exponent, erf, a call)."""
    off = "#define GW_TL_HAS_EVT_SLOPE 0\n"
    src: dict[int, tuple[str, int]] = {}
    val: dict[int, str] = {}
    dot: dict[int, str] = {}
    lines = []
    for k, op, i_in, i_out in _instructions(evt):
        if op == "input":
            src[i_out[0]], val[i_out[0]], dot[i_out[0]] = _input(*i_in)
            continue
        if op == "const":
            src.pop(i_out[0], None)
            val[i_out[0]], dot[i_out[0]] = _literal(evt.instruction_constant(k)), "0.0"
            continue
        if op == "output":
            lines.append(f"    e[{i_out[1]}] = {val[i_in[0]]};")
            lines.append(f"    d[{i_out[1]}] = {dot[i_in[0]]};")
            continue
        if op == "constpow":
            rule = "{b} * pow({a}, {b} - 1.0) * {da}"
        elif op in _PIECEWISE_CONSTANT:
            rule = "0.0"
        else:
            rule = _DOT.get(op)
        if op not in _C or rule is None:
            return off
        n_args = 1 if op in UNARY else 2
        names = dict(zip(("a", "b"), (val[a] for a in i_in[:n_args])))
        names.update(zip(("da", "db"), (dot[a] for a in i_in[:n_args])))
        s = src.get(i_in[0])
        if op in ("sin", "cos", "sinh", "cosh") and s and (op, s[1]) in shared and s[0]:
            # the kernel's order 0, and the pair's other node times the argument's rate (a
            # node's rows past order 0 are the kernel's locals: only the states' are stored)
            partner, sign = _PARTNER[op]
            value = f"w0[{shared[op, s[1]]} * GW_TL_W]"
            deriv = f"{sign}w0[{shared[partner, s[1]]} * GW_TL_W] * {names['da']}"
        else:
            value = _C[op].format(*(val[a] for a in i_in[:n_args]))
            deriv = _derivative(op, rule, f"g{k}", names)
        lines.append(f"    const double g{k} = {value};")
        lines.append(f"    const double d{k} = {deriv};")
        src.pop(i_out[0], None)
        val[i_out[0]], dot[i_out[0]] = f"g{k}", f"d{k}"
    lines = _drop_unread(lines)
    return f"""#define GW_TL_HAS_EVT_SLOPE 1
/* GW_TL(evt)'s indicators e and their time derivatives d from the series' rows of order 0 (w0)
 * and 1 (w1): evt differentiated forward along the solution (taylor/events.py) */
static GW_MAYBE_UNUSED void GW_TL(evt_slope)(const double *w0, const double *w1, double t,
                                             const double *u, const double *p, const double *c,
                                             double *e, double *d) {{
    (void)w0;
    (void)w1;
    (void)t;
    (void)u;
    (void)p;
    (void)c;
{chr(10).join(lines)}
}}
"""
