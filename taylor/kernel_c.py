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
     j = 1: _interior_loop) per group of
     GROUP accumulators, its body straight-line independent multiply-adds (one per term, a
     W-wide vector operation for W lanes); the sums land in slot k of their nodes;
  2. in program order, each node's boundary terms (j = 0 and j = k: they need coefficient k of
     the operands) and its finishing operation (divide by b_0, by k, ...); the states get
     x_i^[k+1] = f_i^[k] / (k + 1).  A node whose coefficients no interior sum reads is a local
     variable here (no store and reload).
The one-lane kernel (GW_TL_PACK: GCC and clang) sums 4 terms per two 2-wide vector operations in phase 1,
from packed copies of the terms' operands behind each order's nodes (_Packs); the denominators'
reciprocals are computed once at order 0 (RECIPROCAL).
No function calls, and code size O(nodes), whatever the order.  That is series(), the nodes'
series in this order-major layout (solver taylor's one-lane steps read the states' coefficients
there: GW_TL_NODES apart from one order to the next, c_src/gw_solver_taylor.c); jet() calls it
and copies the states' series to the output layout above.
"""
from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from gyrowheel.taylor.graph import C_EXPR, PIECEWISE, Decomposition, Operand, decompose
from gyrowheel.taylor.events import event_source
from gyrowheel.taylor.rewrite import lin_order0, lin_order_k

__all__ = ["TaylorKernel", "taylor_source", "write_taylor_kernel", "work_series", "KERNEL_FILE",
           "GROUP"]

KERNEL_FILE = "gw_taylor_model.h"
GROUP = 12  # accumulators of one interior loop (registers: 16 vector registers on x86-64)
# ops whose order k divides by an order-0 value: the argument holding it (None: 2 v_0)
RECIPROCAL = {"div": 1, "sqrt": None, "log": 0, "dq": 1, "atan2": 2, "pow": 0}
PACK_GROUP = 8  # accumulators (pairs of 2-double vectors) of one packed interior loop (one lane: _Packs)

# ops whose order k >= 1 has an interior sum, and the weighted operands (j a_j) they need:
# "a", "b": the first, second argument; "v": the node's own series
WEIGHTED = {"sincos": "a", "sinhcosh": "a", "exp": "a", "tan": "a", "tanh": "a", "pow": "av",
            "log": "v", "dq": "v", "atan2": "abv"}


def _interior_loop(a: str, b: str, body: list[str], index: bool = False) -> list[str]:
    """the loop of interior terms: j = 2 .. k - 1, then j = 1, whose b_{k-1} is the newest
    coefficient (from the end of order k - 1): the other terms need not wait for it; pointers
    a, b at rows j, k - j plus offsets a, b.  index: one loop, j = 1 as its last iteration
    (measured best for the packed one-lane kernel), else the body again after the loop (best
    for W lanes)"""
    rows = "            const double *a = GW_ORD({0}) + {1}, *b = GW_ORD(k - {0}) + {2};"
    if index:
        return (["        for (j = 2; j <= k; j++) {", "            const int i = j < k ? j : 1;",
                 rows.format("i", a, b)] + body + ["        }"])
    return (["        for (j = 2; j < k; j++) {", rows.format("j", a, b)] + body
            + ["        }", "        if (k > 1) {", "            j = 1;", rows.format("j", a, b)]
            + body + ["        }"])


@dataclass
class TaylorKernel:
    """What model_desc.c needs to know of the generated kernel (n_var: series of work)."""

    n_var: int
    n_cst: int
    has_t: bool
    op_counts: dict[str, int]


@dataclass
class _Term:
    """acc[target] += sign [c[factor]] A_j B_{k-j} over j = 1 .. k-1 (A, B internal nodes)."""

    target: int
    sign: int
    a: int
    b: int
    factor: int | None = None


class _Plan:
    """Internal node numbering (var nodes, then weighted series) and the interior terms."""

    def __init__(self, dec: Decomposition):
        self.dec = dec
        self.weighted: dict[int, int] = {}  # var node -> its weighted series' internal node
        self.terms: list[_Term] = []
        for n, node in dec.nodes.items():
            self._terms(n, node)
        # node -> (internal node, its denominator at order 0): the reciprocal, computed once at
        # order 0, so that each order k multiplies (no division on the path from one order's
        # coefficients to the next)
        self.recip: dict[int, tuple[int, str]] = {}
        for n, node in dec.nodes.items():
            if node.op in RECIPROCAL:
                den = RECIPROCAL[node.op]
                den = f"2.0 * {_v0(n, True)}" if den is None else _order0(node.args[den], True)
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
            self.terms.append(_Term(target, sign, a, b, factor))

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


def work_series(dec: Decomposition) -> int:
    """Series of order `order` the kernel's work array w holds (GW_TL_NVAR): the states'
    output, then every internal node (var nodes and weighted series)."""
    return dec.nx + _Packs(_Plan(dec)).stride + 1  # + 1: room to align the nodes' block


def _v0(n: int, lane: bool = False) -> str:
    """coefficient 0 of node n: a W-lane vector (lane: one lane l's number)"""
    return f"GW_{'L' if lane else 'V'}0({n})"


def _vk(n: int, lane: bool = False) -> str:
    return f"GW_{'LK' if lane else 'VK'}({n})"


def _order0(a: Operand, lane: bool = False) -> str:
    return _v0(a[1], lane) if a[0] == "v" else f"GW_{'L' if lane else ''}C({a[1]})"


def _order_k(a: Operand, lane: bool = False) -> str:
    """coefficient k >= 1 of an operand (a constant has none)"""
    return _vk(a[1], lane) if a[0] == "v" else "0.0"


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
            expr = C_EXPR[kind].format(*[_order0(a, True) for a in payload])
        lines.append(f"        GW_LC({j}) = {expr};")
    return lines


# order-0 ops whose C (taylor_graph.C_EXPR) is arithmetic, valid on GW_TL(v) slices as written
SLICE0 = {"add", "sub", "mul", "div", "neg", "twice", "sq", "inv", "lin"}


def _zero_items(plan: _Plan, slices: bool = False) -> list[tuple[bool, str]]:
    """order 0: the right-hand side itself, in program order (and the reciprocals of the
    denominators of orders k >= 1), as (lane-wise, statement) items; slices: the arithmetic
    and sincos nodes as slice statements (GW_TL_V0: GW_X0 the slice lvalue, GW_TL(sincos)),
    the others lane by lane"""
    dec = plan.dec
    items: list[tuple[bool, str]] = []

    def ptr(a: Operand) -> str:
        return f"{'wi' if a[0] == 'v' else 'c'} + {a[1]} * GW_TL_W + l * GW_TL_VW"

    for n, node in dec.nodes.items():
        op = node.op
        vec = slices and (op in SLICE0 or op == "sincos")
        args = [_order0(a, not vec) for a in node.args]
        if op == "sincos" and vec:
            items.append((False, f"GW_TL(sincos)({ptr(node.args[0])}, {ptr(('v', n))}, "
                                 f"{ptr(('v', node.extra[0]))});"))
        elif op == "sincos":  # gw_sincos.h: inline, <= 1 ulp, one reduction for the pair
            items.append((True, f"gw_sincos({args[0]}, &{_v0(n, True)}, &{_v0(node.extra[0], True)});"))
        elif op == "sinhcosh":
            items.append((True, f"{_v0(n, True)} = sinh({args[0]});"))
            items.append((True, f"{_v0(node.extra[0], True)} = cosh({args[0]});"))
        elif op in ("tan", "tanh"):
            sign = "+" if op == "tan" else "-"
            items.append((True, f"{_v0(n, True)} = {op}({args[0]});"))
            items.append((True, f"{_v0(node.extra[0], True)} = 1.0 {sign} {_v0(n, True)} * {_v0(n, True)};"))
        elif op == "dq":
            zop, za = node.zero
            items.append((True, f"{_v0(n, True)} = {C_EXPR[zop].format(_order0(za, True))};"))
        elif op == "lin":
            val = lambda x: _order0(x, not vec)  # noqa: E731  (operands' and constants' values)
            items.append((not vec, f"{_x0(n, vec)} = {lin_order0(node, val, val)};"))
        else:
            items.append((not vec, f"{_x0(n, vec)} = {C_EXPR[op].format(*args)};"))
        if n in plan.recip:  # after the node itself (sqrt's is 1 / (2 v_0))
            r, den = plan.recip[n]
            if vec:
                den = _order0(node.args[RECIPROCAL[node.op]])
            items.append((not vec, f"{_x0(r, vec)} = 1.0 / ({den});"))
    return items


def _x0(n: int, vec: bool) -> str:
    """coefficient 0 of node n as an lvalue: slice l (GW_X0) or lane l"""
    return f"GW_X0({n})" if vec else _v0(n, True)


def _order0_slices(plan: _Plan) -> list[tuple[bool, str]]:
    """order 0 of W lanes under GW_TL_V0: the states and t, the right-hand side and the states'
    coefficient 1, slice statements where _zero_items and _next make them"""
    t = [] if plan.dec.t_node is None else [(False, f"GW_X0({plan.dec.t_node}) = GW_TLR(t + l * GW_TL_VW);")]
    x = [(False, f"GW_X0({i}) = GW_TLR(x + {i} * GW_TL_W + l * GW_TL_VW);") for i in range(plan.dec.nx)]
    return x + t + _zero_items(plan, True) + _next(plan, True, True)


def _zero_lines(plan: _Plan) -> list[str]:
    """order 0 lane by lane (the body of a loop over the lanes)"""
    return ["        " + text for _, text in _zero_items(plan)]


def _oriented(plan: _Plan) -> tuple[dict[int, list[_Term]], list[int]]:
    """the terms of each target node, each reading its more frequent operand at j (sum_j A_j
    B_{k-j} = sum_j B_j A_{k-j} over j = 1 .. k-1: both kernels sum in this one order, so the
    lanes and the packed one-lane kernel agree bit for bit), and the targets grouped by it"""
    uses = Counter(n for t in plan.terms for n in (t.a, t.b))
    targets: dict[int, list[_Term]] = {}
    for t in plan.terms:
        if (uses[t.b], -t.b) > (uses[t.a], -t.a):
            t = _Term(t.target, t.sign, t.b, t.a, t.factor)
        targets.setdefault(t.target, []).append(t)
    order = sorted(targets, key=lambda n: (-uses[targets[n][0].a], targets[n][0].a, n))
    return targets, order


def _interior_lines(plan: _Plan) -> list[str]:
    """phase 1 of order k (W lanes): the interior sums, GROUP accumulators per loop over j; the
    accumulators of a loop share operands (a group loads each shared coefficient once per j)"""
    targets, order = _oriented(plan)
    lines = []
    for g in range(0, len(order), GROUP):
        group = order[g:g + GROUP]
        acc = {n: f"s{i}" for i, n in enumerate(group)}
        lines.append("    GW_TL_UNROLL for (l = 0; l < GW_TL_BLK; l++) {")
        lines.append(f"        GW_TL(v) {', '.join(acc.values())};")
        lines += [f"        GW_TLZ({s});" for s in acc.values()]
        body = []
        for n in group:
            for t in targets[n]:
                op = "GW_TLFMA" if t.sign > 0 else "GW_TLFMS"
                if t.factor is None:
                    body.append(f"            {op}({acc[n]}, a + {t.a} * GW_TL_W, b + {t.b} * GW_TL_W);")
                else:
                    body.append(f"            {op}3({acc[n]}, c + {t.factor} * GW_TL_W + l * GW_TL_VW, "
                                f"a + {t.a} * GW_TL_W, b + {t.b} * GW_TL_W);")
        lines += _interior_loop("l * GW_TL_VW", "l * GW_TL_VW", body)
        lines += [f"        GW_TLST(vk + {n} * GW_TL_W + l * GW_TL_VW, {s});" for n, s in acc.items()]
        lines.append("    }")
    return lines


class _Packs:
    """The one-lane kernel's interior sums, 4 terms per two 2-wide vector operations (GW_TL_PACK).

    At W = 1 a term's multiply-add is one scalar operation with its own loads: the interior
    loops were load-bound.  Here every term has a slot in two packed rows kept behind each
    order's nodes (row j of the a-operands, sign and constant factor applied: -c A_j; row j of
    the b-operands: B_j), so that 4 terms are vector multiply-adds of contiguous loads:
    s += PA[j][4q .. 4q+3] PB[k-j][4q .. 4q+3].  Each target node has one lane of one
    accumulator vector; a target with m terms adds them in m consecutive vectors of slots (the
    same order as the lanes' kernel: bit for bit the same sums), padded with 0 x 0.  A node's
    coefficient is copied to its slots right where it is computed (rows 1 .. order - 1)."""

    def __init__(self, plan: _Plan):
        targets, _ = _oriented(plan)
        ranked = sorted(targets, key=lambda n: (-len(targets[n]), n))
        self.base = -(-plan.n_nodes // 4) * 4  # slots start on a 4-double boundary of a row
        self.groups: list[tuple[int, int]] = []  # per accumulator vector: (first slot, rows)
        self.isum: dict[int, str] = {}  # target -> where its interior sum lands
        self.writes: dict[int, list[tuple[int, str]]] = {}  # node -> (slot offset, scale)
        self.pads: list[int] = []
        slot = 0
        for g in range(0, len(ranked), 4):
            four = ranked[g:g + 4]
            rows = max(len(targets[n]) for n in four)
            self.groups.append((slot, rows))
            for i in range(4):
                n = four[i] if i < len(four) else None
                if n is not None:
                    self.isum[n] = f"GW_IS({g + i})"
                for r in range(rows):
                    at = slot + 4 * r + i
                    if n is None or r >= len(targets[n]):
                        self.pads.append(at)
                        continue
                    t = targets[n][r]
                    scale = ("" if t.factor is None else f"GW_C({t.factor}) * ") + "{}"
                    self.writes.setdefault(t.a, []).append((at, scale if t.sign > 0 else f"-({scale})"))
                    self.writes.setdefault(t.b, []).append((-1 - at, "{}"))
            slot += 4 * rows
        self.slots = slot
        self.stride = self.base + 2 * slot  # GW_TL_NODES of the packed kernel

    def _offset(self, at: int) -> int:
        return self.base + at if at >= 0 else self.base + self.slots + (-1 - at)

    def copy(self, lane: bool, text: str) -> list[tuple[bool, str]]:
        """the packed copies of the node a statement computes (GW_VK: row k, GW_VN: row k + 1)"""
        m = re.fullmatch(r"GW_([VL])([KN])\((\d+)\)", text.split(" = ", 1)[0])
        if m is None:
            return []
        n, row = int(m[3]), m[2]
        return [(lane, f"GW_{'L' if lane else 'V'}P{row}({self._offset(at)}) = "
                       f"{scale.format(f'GW_{m[1]}{row}({n})')};") for at, scale in self.writes.get(n, ())]

    def copies(self, items: list[tuple[bool, str]]) -> list[tuple[bool, str]]:
        """order k >= 1: items with each node's packed copies after its statement, and row k's
        padding (0 x 0)"""
        out: list[tuple[bool, str]] = []
        done = set()
        for lane, text in items:
            out += [(lane, text)] + self.copy(lane, text)
            done |= {int(m) for m in re.findall(r"^GW_[VL][KN]\((\d+)\) = ", text)}
        assert set(self.writes) <= done, sorted(set(self.writes) - done)  # every operand, every k
        for at in self.pads:
            out += [(False, f"GW_VPK({self._offset(at)}) = 0.0;"),
                    (False, f"GW_VPK({self._offset(-1 - at)}) = 0.0;")]
        return out

    def interior_lines(self) -> list[str]:
        """phase 1 of order k: PACK_GROUP accumulator vectors per loop over j"""
        lines = []
        for g0 in range(0, len(self.groups), PACK_GROUP):
            group = list(enumerate(self.groups))[g0:g0 + PACK_GROUP]
            acc = [f"s{q}" for q, _ in group]
            lines.append("    {")
            lines.append(f"        GW_TL(p) {', '.join(acc)};")
            lines += [f"        GW_TLPZ({a});" for a in acc]
            body = [f"            GW_TLPFMA({a}, a + {first + 4 * r}, b + {first + 4 * r});"
                    for (q, (first, rows)), a in zip(group, acc) for r in range(rows)]
            lines += _interior_loop(str(self.base), str(self.base + self.slots), body, True)
            lines += [f"        GW_TLPST(gw_is + {4 * q}, {a});" for (q, _), a in zip(group, acc)]
            lines.append("    }")
        return lines


def _boundary(plan: _Plan, isum: dict[int, str] | None = None) -> list[tuple[bool, str]]:
    """phase 2 of order k >= 1: boundary terms and finishing of every node, in program order
    (node n's interior sum I is isum[n], by default GW_VK(n), where phase 1 left it; rk = 1/k,
    dk = k), as (lane-wise, statement): whole W-lane vector statements, or one lane's
    (ternaries, constants)"""
    dec = plan.dec
    out: list[tuple[bool, str]] = []

    def interior(m: int) -> str:
        return (isum or {}).get(m, _vk(m))

    for n, node in dec.nodes.items():
        op, a = node.op, node.args
        target, I = _vk(n), interior(n)
        rec = _v0(plan.recip[n][0]) if n in plan.recip else None
        o0, ok = [_order0(x) for x in a], [_order_k(x) for x in a]
        lane = op in ("fabs", "fmin", "fmax", "if_else_zero") or op in PIECEWISE
        if lane:
            o0, ok, target = [_order0(x, True) for x in a], [_order_k(x, True) for x in a], _vk(n, True)
        if op in ("add", "sub"):
            first, second = ok
            sign = "+" if op == "add" else "-"
            if a[0][0] == a[1][0] == "v":
                expr = f"{first} {sign} {second}"
            else:
                expr = first if a[1][0] == "c" else (second if op == "add" else f"-{second}")
        elif op == "lin":
            expr = lin_order_k(node, _order_k, _order0)
        elif op == "neg":
            expr = f"-{ok[0]}"
        elif op == "twice":
            expr = f"2.0 * {ok[0]}"
        elif op == "mul":
            if a[0][0] == a[1][0] == "v":
                expr = f"{I} + {o0[0]} * {ok[1]} + {ok[0]} * {o0[1]}"
            else:
                c, v = (a[0], a[1]) if a[0][0] == "c" else (a[1], a[0])
                expr = f"{_order0(c)} * {_order_k(v)}"
        elif op == "sq":
            expr = f"{I} + 2.0 * {o0[0]} * {ok[0]}"
        elif op == "div":
            num = f"{ok[0]} - " if a[0][0] == "v" else "-"
            expr = f"({num}{I} - {ok[1]} * {_v0(n)}) * {rec}"
        elif op == "sqrt":
            expr = f"({ok[0]} - {I}) * {rec}"
        elif op in ("sincos", "sinhcosh"):
            c = node.extra[0]
            out.append((False, f"{target} = {I} * rk + {ok[0]} * {_v0(c)};"))
            sign = "-" if op == "sincos" else ""
            expr = f"{sign}({interior(c)} * rk + {ok[0]} * {_v0(n)})"
            target = _vk(c)
        elif op == "exp":
            expr = f"{I} * rk + {ok[0]} * {_v0(n)}"
        elif op in ("tan", "tanh"):
            q = node.extra[0]
            out.append((False, f"{target} = {I} * rk + {ok[0]} * {_v0(q)};"))
            sign = "" if op == "tan" else "-"
            expr = f"{sign}({interior(q)} + 2.0 * {_v0(n)} * {_vk(n)})"
            target = _vk(q)
        elif op == "log":
            expr = f"({ok[0]} - {I} * rk) * {rec}"
        elif op == "dq":
            expr = f"({ok[0]} - {I} * rk) * {rec}"
        elif op == "atan2":
            expr = f"({I} * rk + {ok[0]} * {o0[1]} - {ok[1]} * {o0[0]}) * {rec}"
        elif op == "pow":
            expr = f"({I} * rk + {o0[1]} * {ok[0]} * {_v0(n)}) * {rec}"
        elif op == "fabs":
            expr = f"{o0[0]} < 0.0 ? -{ok[0]} : {ok[0]}"
        elif op in ("fmin", "fmax"):
            cmp = "<=" if op == "fmin" else ">="
            expr = f"{o0[0]} {cmp} {o0[1]} ? {ok[0]} : {ok[1]}"
        elif op == "if_else_zero":
            expr = f"{o0[0]} != 0.0 ? {ok[1]} : 0.0"
        else:  # piecewise constant
            expr = "0.0"
        if "GW_V" not in expr:  # a number (the series of a constant: 0): one lane's statement
            lane, target = True, _vk(n, True)
        out.append((lane, f"{target} = {expr};"))
        for m in [n] + node.extra:
            if m in plan.weighted:
                out.append((False, f"{_vk(plan.weighted[m])} = dk * {_vk(m)};"))
    return out


def _next(plan: _Plan, order0: bool, slices: bool = False) -> list[tuple[bool, str]]:
    """coefficient k + 1 of the states (x_i^[k+1] = f_i^[k] / (k + 1)) and of t, and their
    weighted series (j x_j at j = k + 1 is f_i^[k]); order 0: one lane's statements (slices:
    slice statements where the value is not a number)"""
    dec = plan.dec
    out: list[tuple[bool, str]] = []

    def put(n: int, f: str | None, scale: str = "") -> None:
        if f is None or (order0 and not slices):
            out.append((True, f"GW_LN({n}) = {'0.0' if f is None else f};"))
        else:
            out.append((False, f"GW_VN({n}) = {f}{'' if order0 else scale};"))

    for i, o in enumerate(dec.outputs):
        s = dec.output_scales[i] if dec.output_scales else None  # x_i' = s output_i
        if order0:
            f = None if o is None else _order0(o, not slices)
            f = f if f is None or s is None else f"{_order0(s, not slices)} * {f}"
        else:
            f = None if o is None or o[0] == "c" else _vk(o[1])
        scaled = f is None or s is None or order0
        put(i, f, " * rk1" if scaled else f" * ({_order0(s)} * rk1)")
        if i in plan.weighted:
            put(plan.weighted[i], f if scaled else f"{_order0(s)} * {f}")
    if dec.t_node is not None:
        T = dec.t_node
        for n in [T] + ([plan.weighted[T]] if T in plan.weighted else []):
            out.append((True, f"GW_LN({n}) = {'1.0' if order0 else '0.0'};"))
    return out


def _locals(plan: _Plan, items: list[tuple[bool, str]], packed: bool = False) -> list[tuple[bool, str]]:
    """order k >= 1: a node whose coefficients no interior sum reads (and not a state or t)
    needs its coefficient k only in this order's statements: a local variable (a register, no
    store and reload) when its statement and all its uses are in one loop of whole statements
    (its slot k still holds its interior sum, if it has one).  packed: the interior sums read
    the packed copies (_Packs), so any node but the states and t may be local"""
    dec = plan.dec
    read = set(range(dec.nx)) | {dec.t_node}
    if not packed:
        read |= {n for t in plan.terms for n in (t.a, t.b)}
    run, r = [], 0
    for i, (lane, _) in enumerate(items):
        r += i > 0 and lane != items[i - 1][0]
        run.append(r)
    defs: dict[int, int] = {}
    uses: dict[int, set[int]] = {}
    for i, (lane, text) in enumerate(items):
        lhs, rhs = text.split(" = ", 1)
        m = re.fullmatch(r"GW_VK\((\d+)\)", lhs)
        if m and not lane:
            defs[int(m[1])] = i
        for u in re.findall(r"GW_[VL]K\((\d+)\)", rhs):
            uses.setdefault(int(u), set()).add(i)
    local = {n for n, i in defs.items() if n not in read
             and all(run[u] == run[i] and u >= i for u in uses.get(n, ()))}
    out = []
    for i, (lane, text) in enumerate(items):
        lhs, rhs = text.split(" = ", 1)
        for n in local:
            if defs[n] < i:
                rhs = rhs.replace(f"GW_VK({n})", f"v{n}")
        m = re.fullmatch(r"GW_VK\((\d+)\)", lhs)
        if m and int(m[1]) in local and defs[int(m[1])] == i:
            if not uses.get(int(m[1]), set()) - {i}:
                continue  # read by nothing at order k >= 1 (an operand of a piecewise op)
            lhs = f"const GW_TL(v) v{m[1]}"
        out.append((lane, f"{lhs} = {rhs}"))
    return out


def _loops(items: list[tuple[bool, str]]) -> list[str]:
    """statements in loops: runs of whole-vector statements over GW_TL_BLK, of lane-wise ones
    over the W lanes"""
    lines, i = [], 0
    while i < len(items):
        lane = items[i][0]
        j = i
        while j < len(items) and items[j][0] == lane:
            j += 1
        lines.append(f"    {'' if lane else 'GW_TL_UNROLL '}for (l = 0; l < {'GW_TL_W' if lane else 'GW_TL_BLK'}; l++) {{")
        lines += ["        " + text for _, text in items[i:j]]
        lines.append("    }")
        i = j
    return lines


def taylor_source(dec: Decomposition, model: str, evt: ca.Function | None = None) -> str:
    """The template text of gw_taylor_model.h for a decomposition (evt: the model's event
    indicators, read from the kernel's order-0 row where they can be: taylor_events.py)."""
    plan = _Plan(dec)
    packs = _Packs(plan)
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
{chr(10).join(_cst_lines(dec)) or '        (void)c;'}
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
{chr(10).join(_loops(_order0_slices(plan)))}
#undef GW_X0
#else
    for (l = 0; l < GW_TL_W; l++) {{
{chr(10).join([f"        GW_L0({i}) = x[{i} * GW_TL_W + l];" for i in range(dec.nx)] + t_init)}
{chr(10).join(_zero_lines(plan))}
{chr(10).join("        " + text for _, text in _next(plan, True))}
#if GW_TL_PACK
{chr(10).join("        " + text for item in _next(plan, True) for _, text in packs.copy(*item))}
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
{chr(10).join(_loops(_locals(plan, packs.copies(_boundary(plan, packs.isum) + _next(plan, False)), True)))}
#else
{chr(10).join(_interior_lines(plan))}
{chr(10).join(_loops(_locals(plan, _boundary(plan) + _next(plan, False))))}
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
    code-generated, taylor_events.event_source).

    Raises gyrowheel.taylor.graph.TaylorUnsupportedError for an operation without a recurrence.
    """
    dec = decompose(ode)
    (out_dir / KERNEL_FILE).write_text(taylor_source(dec, model, evt))
    return TaylorKernel(n_var=work_series(dec), n_cst=dec.n_cst, has_t=dec.t_node is not None,
                        op_counts=dict(dec.op_counts))
