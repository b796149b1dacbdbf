"""The model's right-hand side as a Taylor decomposition: one node per elementary operation.

The Taylor method of solver `taylor` (c_src/gw_solver_taylor.c) needs, at a point (t, x), the
normalised derivatives x^[k] = x^(k)(t) / k!, k = 0..p, of the solution.  They follow from the
coefficients of every intermediate quantity of xdot = f(t, x, u, p), order by order: automatic
differentiation in Taylor arithmetic (Moore 1966; Jorba & Zou 2005, Exp. Math. 14, sect. 3;
Griewank & Walther, Evaluating Derivatives, 2nd ed. 2008, table 13.2).  This module walks the
SX algorithm of the model's `ode` casadi.Function (its instructions, after casadi.cse) and
turns it into such a decomposition:

  * var nodes: quantities depending on t or x; each has a Taylor series of order p.  Nodes
    0 .. nx-1 are the states, node nx is t (if the ode uses it).  Each var node has an op and
    operands, listed in evaluation order.
  * cst nodes: quantities depending only on u and p (constant during a communication step):
    one number each, computed once per integration call.
  * outputs: for each state, the operand of its derivative (x_i^[k+1] = f_i^[k] / (k + 1)).

decompose() then rewrites the graph (taylor/rewrite.py, exact in real arithmetic:
constant factors carried to the consumers, `lin` nodes for scaled sums, squares, reciprocal
factors as divisions, products shared modulo associativity): what every kernel is built from.

Operations (CasADi OP_* code -> recurrence; c_src/gw_taylor_ops.h has the formulas,
taylor/kernel_recurrences.py writes their C):
  add sub neg twice mul (linear when one factor is constant) div inv sq sqrt sin/cos (one
  pair per argument) sinh/cosh (pair) tan tanh exp log pow/constpow (constant exponent; a
  variable exponent is exp(b log a)) atan atan2 asin acos fabs fmin fmax if_else_zero, the
  comparisons and logic (lt le eq ne not and or), sign floor ceil (piecewise constant: order 0
  only).  Any other operation on a var node raises TaylorUnsupportedError naming it: the FMU
  is not built with a Taylor kernel that would silently be wrong.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca

__all__ = ["TaylorUnsupportedError", "Decomposition", "Node", "decompose", "OP_NAMES"]

OP_NAMES = {getattr(ca, n): n[3:].lower() for n in dir(ca) if n.startswith("OP_")}

# ops whose result is piecewise constant: order 0 only, zero derivatives
PIECEWISE = {"lt", "le", "eq", "ne", "not", "and", "or", "sign", "floor", "ceil"}
# sign(x) in C as CasADi defines it (its casadi_sign in the generated gw_ode and gw_evt, and its
# SX virtual machine): -1 where x < 0, 1 where x > 0, x itself otherwise, so NaN stays NaN and
# -0.0 stays -0.0.  Both uses need exactly that: the kernel's order 0 is the right-hand side
# gw_ode computes (a NaN there must reach the solver's finiteness checks, not become 0), and the
# event indicators read from the kernel's order-0 row must equal gw_evt's bit for bit
# (taylor/events.py).  Its derivatives are 0 wherever x != 0 (PIECEWISE).
SIGN_C = "({0} < 0.0 ? -1.0 : ({0} > 0.0 ? 1.0 : {0}))"
# C expressions of every op at order 0 (cst nodes, and the order-0 value of var nodes)
C_EXPR = {
    "add": "{0} + {1}", "sub": "{0} - {1}", "mul": "{0} * {1}", "div": "{0} / {1}",
    "neg": "-{0}", "twice": "2.0 * {0}", "sq": "{0} * {0}", "inv": "1.0 / {0}",
    "sqrt": "sqrt({0})", "sin": "sin({0})", "cos": "cos({0})", "tan": "tan({0})",
    "sinh": "sinh({0})", "cosh": "cosh({0})", "tanh": "tanh({0})", "exp": "exp({0})",
    "log": "log({0})", "pow": "pow({0}, {1})", "constpow": "pow({0}, {1})",
    "atan": "atan({0})", "asin": "asin({0})", "acos": "acos({0})", "atan2": "atan2({0}, {1})",
    "fabs": "fabs({0})", "fmin": "fmin({0}, {1})", "fmax": "fmax({0}, {1})",
    "if_else_zero": "({0} != 0.0 ? {1} : 0.0)",
    "lt": "({0} < {1} ? 1.0 : 0.0)", "le": "({0} <= {1} ? 1.0 : 0.0)",
    "eq": "({0} == {1} ? 1.0 : 0.0)", "ne": "({0} != {1} ? 1.0 : 0.0)",
    "not": "({0} == 0.0 ? 1.0 : 0.0)", "and": "({0} != 0.0 && {1} != 0.0 ? 1.0 : 0.0)",
    "or": "({0} != 0.0 || {1} != 0.0 ? 1.0 : 0.0)",
    "sign": SIGN_C, "floor": "floor({0})",
    "ceil": "ceil({0})",
}
UNARY = {"neg", "twice", "sq", "inv", "sqrt", "sin", "cos", "tan", "sinh", "cosh", "tanh", "exp",
         "log", "atan", "asin", "acos", "fabs", "not", "sign", "floor", "ceil"}


class TaylorUnsupportedError(ValueError):
    """The model uses an operation that has no Taylor recurrence here (named in the message)."""


Operand = tuple[str, int]  # ("v", var node) or ("c", cst node)


@dataclass
class Node:
    """A var node: op applied to operands; `out` holds extra nodes an op writes (pairs, aux)."""

    op: str
    args: list[Operand]
    extra: list[int] = field(default_factory=list)  # sincos: [cos node]; tan/tanh: [aux q]
    zero: tuple[str, Operand] | None = None  # dq: the op giving order 0 (atan, asin, acos)
    coefs: tuple = ()  # lin (taylor/rewrite.py): per operand (factor or None, sign)


@dataclass
class Decomposition:
    """var nodes (states first, then t if used, then the program), cst nodes, outputs."""

    nx: int
    t_node: int | None
    nodes: dict[int, Node]  # program: var node -> op, in evaluation order (dict keeps it)
    n_var: int
    cst: list[tuple[str, list]]  # ("p"|"u", index) | ("k", value) | (op, [Operand...])
    outputs: list[Operand | None]  # per state: derivative operand (None: structural zero)
    op_counts: dict[str, int] = field(default_factory=dict)
    output_scales: list[Operand | None] = field(default_factory=list)  # x_i' = s_i output_i

    @property
    def n_cst(self) -> int:
        return len(self.cst)


class _Builder:
    def __init__(self, nx: int):
        self.nx = nx
        self.n_var = nx
        self.nodes: dict[int, Node] = {}
        self.cst: list[tuple[str, list]] = []
        self.cst_keys: dict[tuple, int] = {}
        self.pairs: dict[tuple[str, Operand], tuple[int, int]] = {}
        self.t_node: int | None = None
        self.counts: dict[str, int] = {}

    def constant(self, kind: str, payload) -> Operand:
        key = (kind, tuple(payload) if isinstance(payload, list) else payload)
        if key not in self.cst_keys:
            self.cst_keys[key] = len(self.cst)
            self.cst.append((kind, payload))
        return ("c", self.cst_keys[key])

    def number(self, value: float) -> Operand:
        return self.constant("k", float(value))

    def var(self, op: str, args: list[Operand], **kw) -> Operand:
        n = self.n_var
        self.n_var += 1
        self.nodes[n] = Node(op, args, **kw)
        self.counts[op] = self.counts.get(op, 0) + 1
        return ("v", n)

    def series(self, a: Operand) -> Operand:
        """A var node for an operand (a constant becomes the series (c, 0, 0, ...))."""
        return a if a[0] == "v" else self.var("add", [a, self.number(0.0)])

    def pair(self, kind: str, a: Operand) -> tuple[int, int]:
        """The (sin, cos) or (sinh, cosh) nodes of argument a, made once."""
        key = (kind, a)
        if key not in self.pairs:
            first = self.var(kind, [a])[1]
            second = self.n_var
            self.n_var += 1
            self.nodes[first].extra = [second]
            self.pairs[key] = (first, second)
        return self.pairs[key]

    def apply(self, op: str, args: list[Operand]) -> Operand:
        if all(a[0] == "c" for a in args):  # constant during the step: computed once
            return self.constant(op, args)
        if op in PIECEWISE:
            return self.var(op, args)
        if op in ("add", "sub", "neg", "twice"):
            return self.var(op, args)
        if op == "mul":
            return self.var("mul", args)  # scaled when one factor is constant (taylor/kernel_recurrences.py)
        if op == "div":
            a, b = args
            if b[0] == "c":
                return self.var("mul", [a, self.constant("inv", [b])])
            return self.var("div", [a, b])
        if op == "inv":
            return self.var("div", [self.number(1.0), args[0]])
        if op in ("sq", "sqrt", "exp", "log", "fabs"):
            return self.var(op, args)
        if op in ("sin", "cos"):
            s, c = self.pair("sincos", args[0])
            return ("v", s if op == "sin" else c)
        if op in ("sinh", "cosh"):
            s, c = self.pair("sinhcosh", args[0])
            return ("v", s if op == "sinh" else c)
        if op in ("tan", "tanh"):
            v = self.var(op, args)
            q = self.n_var
            self.n_var += 1
            self.nodes[v[1]].extra = [q]
            return v
        if op in ("pow", "constpow"):
            a, b = args
            if b[0] == "c":
                return self.var("pow", [a, b])
            return self.apply("exp", [self.apply("mul", [b, self.apply("log", [self.series(a)])])])
        if op in ("atan", "asin", "acos"):
            # v' r = num': atan r = 1 + a^2, num = a; asin r = sqrt(1 - a^2), num = a; acos num = -a
            a = args[0]
            sq = self.apply("sq", [a])
            if op == "atan":
                r = self.apply("add", [sq, self.number(1.0)])
            else:
                r = self.apply("sqrt", [self.apply("sub", [self.number(1.0), sq])])
            num = self.apply("neg", [a]) if op == "acos" else a
            return self.var("dq", [num, r], zero=(op, a))
        if op == "atan2":
            a, b = (self.series(x) for x in args)
            r = self.apply("add", [self.apply("sq", [a]), self.apply("sq", [b])])
            return self.var("atan2", [a, b, r])
        if op in ("fmin", "fmax", "if_else_zero"):
            return self.var(op, args)
        raise TaylorUnsupportedError(
            f"operation {op!r} has no Taylor recurrence in gyrowheel (taylor/graph.py); "
            "supported: " + ", ".join(sorted(set(C_EXPR) - {"constpow"})))


def decompose(ode: ca.Function, rewrite: bool = True) -> Decomposition:
    """The Taylor decomposition of ode(t, x, u, p) -> xdot (an SX casadi.Function); rewrite:
    with the exact rewrites of taylor/rewrite.py (constant factors carried to the
    consumers, squares, reciprocals folded into divisions), as every kernel is built.

    Inputs must be, in order, t (1), x (nx), u (nu), p (np) dense vectors; the output xdot
    (nx).  Raises TaylorUnsupportedError for an operation without a recurrence, ValueError
    for a function of another shape.
    """
    if ode.n_in() != 4 or ode.n_out() != 1:
        raise ValueError(f"ode must be (t, x, u, p) -> xdot, got {ode}")
    nx = ode.nnz_in(1)
    if ode.nnz_in(0) != 1 or ode.numel_out(0) != nx:
        raise ValueError(f"ode must map t (1) and x ({nx}) to xdot ({nx}), got {ode}")
    rows = ode.sparsity_out(0).row()
    b = _Builder(nx)
    uses_t = any(ode.instruction_id(k) == ca.OP_INPUT and ode.instruction_input(k)[0] == 0
                 for k in range(ode.n_instructions()))
    if uses_t:  # t is node nx: the solver sets its series (t, 1, 0, ...)
        b.t_node = nx
        b.n_var += 1
    work: dict[int, Operand] = {}
    outputs: list[Operand | None] = [None] * nx
    for k in range(ode.n_instructions()):
        code = ode.instruction_id(k)
        op = OP_NAMES.get(code, str(code))
        ins, outs = ode.instruction_input(k), ode.instruction_output(k)
        if op == "input":
            i, nz = ins
            if i == 0:
                work[outs[0]] = ("v", b.t_node)
            elif i == 1:
                work[outs[0]] = ("v", nz)
            else:
                work[outs[0]] = b.constant("u" if i == 2 else "p", nz)
        elif op == "const":
            work[outs[0]] = b.number(ode.instruction_constant(k))
        elif op == "output":
            outputs[rows[outs[1]]] = work[ins[0]]
        else:
            if op not in C_EXPR:
                raise TaylorUnsupportedError(
                    f"operation {op!r} (CasADi OP code {code}) has no Taylor recurrence in "
                    "gyrowheel (taylor/graph.py)")
            n_args = 1 if op in UNARY else 2
            args = [work[i] for i in ins[:n_args]]
            work[outs[0]] = b.apply(op, args)
    dec = Decomposition(nx=nx, t_node=b.t_node, nodes=b.nodes, n_var=b.n_var, cst=b.cst,
                        outputs=outputs, op_counts=dict(b.counts))
    if not rewrite:
        return dec
    from gyrowheel.taylor.rewrite import rewrite as rewritten  # it builds on this module's types
    return rewritten(dec)

