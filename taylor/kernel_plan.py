"""The plan of a Taylor kernel: its internal nodes and the interior terms of every recurrence.

From a decomposition (gyrowheel.taylor.graph), Plan numbers the kernel's internal series (the var
nodes, then the weighted series j a_j some recurrences use, then the reciprocals of the
denominators computed once at order 0) and lists every recurrence's interior terms
acc[target] += sign [c[factor]] A_j B_{k-j}, j = 1 .. k-1 (the split of c_src/gw_taylor_ops.h).
oriented() fixes the one summation order both kernels use (the W-lane and the packed one-lane
kernel agree bit for bit).  v0, vk, order0, order_k name a node's or an operand's coefficients
in the kernel's C (the GW_V0 / GW_VK / GW_L* / GW_C macros of gw_taylor_model.h,
taylor/kernel_c.py).
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from gyrowheel.taylor.graph import Decomposition, Operand

__all__ = ["Plan", "Term", "oriented", "v0", "vk", "order0", "order_k", "RECIPROCAL", "WEIGHTED"]

# ops whose order k divides by an order-0 value: the argument holding it (None: 2 v_0)
RECIPROCAL = {"div": 1, "sqrt": None, "log": 0, "dq": 1, "atan2": 2, "pow": 0}

# ops whose order k >= 1 has an interior sum, and the weighted operands (j a_j) they need:
# "a", "b": the first, second argument; "v": the node's own series
WEIGHTED = {"sincos": "a", "sinhcosh": "a", "exp": "a", "tan": "a", "tanh": "a", "pow": "av",
            "log": "v", "dq": "v", "atan2": "abv"}


@dataclass
class Term:
    """acc[target] += sign [c[factor]] A_j B_{k-j} over j = 1 .. k-1 (A, B internal nodes)."""

    target: int
    sign: int
    a: int
    b: int
    factor: int | None = None


class Plan:
    """Internal node numbering (var nodes, then weighted series) and the interior terms."""

    def __init__(self, dec: Decomposition):
        self.dec = dec
        self.weighted: dict[int, int] = {}  # var node -> its weighted series' internal node
        self.terms: list[Term] = []
        for n, node in dec.nodes.items():
            self._terms(n, node)
        # node -> (internal node, its denominator at order 0): the reciprocal, computed once at
        # order 0, so that each order k multiplies (no division on the path from one order's
        # coefficients to the next)
        self.recip: dict[int, tuple[int, str]] = {}
        for n, node in dec.nodes.items():
            if node.op in RECIPROCAL:
                den = RECIPROCAL[node.op]
                den = f"2.0 * {v0(n, True)}" if den is None else order0(node.args[den], True)
                self.recip[n] = (dec.n_var + len(self.weighted) + len(self.recip), den)
        self.n_nodes = dec.n_var + len(self.weighted) + len(self.recip)

    def d(self, a: Operand) -> int | None:
        """the weighted series j a_j of a var operand (None for a constant: no terms)"""
        if a[0] != "v":
            return None
        if a[1] not in self.weighted:
            self.weighted[a[1]] = self.dec.n_var + len(self.weighted)
        return self.weighted[a[1]]

    def _add(self, target: int, a: Operand | int | None, b: Operand | int | None, sign: int = 1,
             factor: int | None = None) -> None:
        a = a[1] if isinstance(a, tuple) and a[0] == "v" else a
        b = b[1] if isinstance(b, tuple) and b[0] == "v" else b
        if isinstance(a, int) and isinstance(b, int):  # a constant operand's terms vanish
            self.terms.append(Term(target, sign, a, b, factor))

    def _terms(self, n: int, node) -> None:
        op, a = node.op, node.args
        v = ("v", n)
        if op == "mul" and a[0][0] == a[1][0] == "v":
            self._add(n, a[0], a[1])
        elif op == "sq":
            self._add(n, a[0], a[0])
        elif op == "div":
            self._add(n, a[1], v)
        elif op == "sqrt":
            self._add(n, v, v)
        elif op in ("sincos", "sinhcosh"):
            c = node.extra[0]
            self._add(n, self.d(a[0]), c)
            self._add(c, self.d(a[0]), n)
        elif op == "exp":
            self._add(n, self.d(a[0]), v)
        elif op in ("tan", "tanh"):
            q = node.extra[0]
            self._add(n, self.d(a[0]), q)
            self._add(q, v, v)
        elif op in ("log", "dq"):
            self._add(n, self.d(v), a[0] if op == "log" else a[1])
        elif op == "atan2":
            self._add(n, self.d(a[0]), a[1])
            self._add(n, self.d(a[1]), a[0], -1)
            self._add(n, self.d(v), a[2], -1)
        elif op == "pow":
            self._add(n, self.d(a[0]), v, 1, a[1][1])
            self._add(n, self.d(v), a[0], -1)


def v0(n: int, lane: bool = False) -> str:
    """coefficient 0 of node n: a W-lane vector (lane: one lane l's number)"""
    return f"GW_{'L' if lane else 'V'}0({n})"


def vk(n: int, lane: bool = False) -> str:
    """coefficient k of node n (the order being computed): a W-lane vector (lane: lane l's)"""
    return f"GW_{'LK' if lane else 'VK'}({n})"


def order0(a: Operand, lane: bool = False) -> str:
    """coefficient 0 of an operand: a var node's, or a constant's value"""
    return v0(a[1], lane) if a[0] == "v" else f"GW_{'L' if lane else ''}C({a[1]})"


def order_k(a: Operand, lane: bool = False) -> str:
    """coefficient k >= 1 of an operand (a constant has none)"""
    return vk(a[1], lane) if a[0] == "v" else "0.0"


def oriented(plan: Plan) -> tuple[dict[int, list[Term]], list[int]]:
    """the terms of each target node, each reading its more frequent operand at j (sum_j A_j
    B_{k-j} = sum_j B_j A_{k-j} over j = 1 .. k-1: both kernels sum in this one order, so the
    lanes and the packed one-lane kernel agree bit for bit), and the targets grouped by it"""
    uses = Counter(n for t in plan.terms for n in (t.a, t.b))
    targets: dict[int, list[Term]] = {}
    for t in plan.terms:
        if (uses[t.b], -t.b) > (uses[t.a], -t.a):
            t = Term(t.target, t.sign, t.b, t.a, t.factor)
        targets.setdefault(t.target, []).append(t)
    order = sorted(targets, key=lambda n: (-uses[targets[n][0].a], targets[n][0].a, n))
    return targets, order
