"""The C statements of a Taylor kernel's recurrences (W lanes): order 0, and order k's two phases.

Order 0 is the right-hand side itself (cst_lines: the constants; zero_items, order0_slices:
the var nodes, lane by lane or in W-lane slices).  Each order k >= 1 then has (the top of
taylor/kernel_c.py): phase 1, the interior sums (interior_lines, GROUP accumulators per loop
over j, interior_loop); phase 2, each node's boundary terms and finishing operation in program
order (boundary) and the states' next coefficient (next_items).  local_variables keeps a
coefficient no interior sum reads in a register; loops wraps the statements in loops over the
lanes.  Statements are (lane-wise, text) items: a whole W-lane vector statement, or one lane's.
The one-lane kernel's packed interior sums are taylor/kernel_packs.py's.
"""
from __future__ import annotations

import re

from gyrowheel.taylor.graph import C_EXPR, PIECEWISE, Decomposition, Operand
from gyrowheel.taylor.kernel_plan import RECIPROCAL, Plan, oriented, order0, order_k, v0, vk
from gyrowheel.taylor.rewrite import lin_order0, lin_order_k

__all__ = ["GROUP", "interior_loop", "cst_lines", "zero_items", "order0_slices", "zero_lines",
           "interior_lines", "boundary", "next_items", "local_variables", "loops"]

GROUP = 12  # accumulators of one interior loop (registers: 16 vector registers on x86-64)


def interior_loop(a: str, b: str, body: list[str], index: bool = False) -> list[str]:
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


def cst_lines(dec: Decomposition) -> list[str]:
    """the constants' statements, lane l's GW_LC(j): a parameter, an input, a number, or an op of
    other constants (C_EXPR), in the decomposition's order"""
    lines = []
    for j, (kind, payload) in enumerate(dec.cst):
        if kind in ("p", "u"):
            expr = f"{kind}[{payload} * GW_TL_W + l]"
        elif kind == "k":
            expr = repr(payload) if payload == payload else "(0.0 / 0.0)"
            if expr in ("inf", "-inf"):
                expr = ("-" if payload < 0 else "") + "HUGE_VAL"
        else:
            expr = C_EXPR[kind].format(*[order0(a, True) for a in payload])
        lines.append(f"        GW_LC({j}) = {expr};")
    return lines


# order-0 ops whose C (taylor/graph.py C_EXPR) is arithmetic, valid on GW_TL(v) slices as written
SLICE0 = {"add", "sub", "mul", "div", "neg", "twice", "sq", "inv", "lin"}


def zero_items(plan: Plan, slices: bool = False) -> list[tuple[bool, str]]:
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
        args = [order0(a, not vec) for a in node.args]
        if op == "sincos" and vec:
            items.append((False, f"GW_TL(sincos)({ptr(node.args[0])}, {ptr(('v', n))}, "
                                 f"{ptr(('v', node.extra[0]))});"))
        elif op == "sincos":  # gw_sincos.h: inline, <= 1 ulp, one reduction for the pair
            items.append((True, f"gw_sincos({args[0]}, &{v0(n, True)}, &{v0(node.extra[0], True)});"))
        elif op == "sinhcosh":
            items.append((True, f"{v0(n, True)} = sinh({args[0]});"))
            items.append((True, f"{v0(node.extra[0], True)} = cosh({args[0]});"))
        elif op in ("tan", "tanh"):
            sign = "+" if op == "tan" else "-"
            items.append((True, f"{v0(n, True)} = {op}({args[0]});"))
            items.append((True, f"{v0(node.extra[0], True)} = 1.0 {sign} {v0(n, True)} * {v0(n, True)};"))
        elif op == "dq":
            zop, za = node.zero
            items.append((True, f"{v0(n, True)} = {C_EXPR[zop].format(order0(za, True))};"))
        elif op == "lin":
            val = lambda x: order0(x, not vec)  # noqa: E731  (operands' and constants' values)
            items.append((not vec, f"{_x0(n, vec)} = {lin_order0(node, val, val)};"))
        else:
            items.append((not vec, f"{_x0(n, vec)} = {C_EXPR[op].format(*args)};"))
        if n in plan.recip:  # after the node itself (sqrt's is 1 / (2 v_0))
            r, den = plan.recip[n]
            if vec:
                den = order0(node.args[RECIPROCAL[node.op]])
            items.append((not vec, f"{_x0(r, vec)} = 1.0 / ({den});"))
    return items


def _x0(n: int, vec: bool) -> str:
    """coefficient 0 of node n as an lvalue: slice l (GW_X0) or lane l"""
    return f"GW_X0({n})" if vec else v0(n, True)


def order0_slices(plan: Plan) -> list[tuple[bool, str]]:
    """order 0 of W lanes under GW_TL_V0: the states and t, the right-hand side and the states'
    coefficient 1, slice statements where zero_items and next_items make them"""
    t = [] if plan.dec.t_node is None else [(False, f"GW_X0({plan.dec.t_node}) = GW_TLR(t + l * GW_TL_VW);")]
    x = [(False, f"GW_X0({i}) = GW_TLR(x + {i} * GW_TL_W + l * GW_TL_VW);") for i in range(plan.dec.nx)]
    return x + t + zero_items(plan, True) + next_items(plan, True, True)


def zero_lines(plan: Plan) -> list[str]:
    """order 0 lane by lane (the body of a loop over the lanes)"""
    return ["        " + text for _, text in zero_items(plan)]


def interior_lines(plan: Plan) -> list[str]:
    """phase 1 of order k (W lanes): the interior sums, GROUP accumulators per loop over j; the
    accumulators of a loop share operands (a group loads each shared coefficient once per j)"""
    targets, order = oriented(plan)
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
        lines += interior_loop("l * GW_TL_VW", "l * GW_TL_VW", body)
        lines += [f"        GW_TLST(vk + {n} * GW_TL_W + l * GW_TL_VW, {s});" for n, s in acc.items()]
        lines.append("    }")
    return lines


def boundary(plan: Plan, isum: dict[int, str] | None = None) -> list[tuple[bool, str]]:
    """phase 2 of order k >= 1: boundary terms and finishing of every node, in program order
    (node n's interior sum I is isum[n], by default GW_VK(n), where phase 1 left it; rk = 1/k,
    dk = k), as (lane-wise, statement): whole W-lane vector statements, or one lane's
    (ternaries, constants)"""
    dec = plan.dec
    out: list[tuple[bool, str]] = []

    def interior(m: int) -> str:
        return (isum or {}).get(m, vk(m))

    for n, node in dec.nodes.items():
        op, a = node.op, node.args
        target, I = vk(n), interior(n)
        rec = v0(plan.recip[n][0]) if n in plan.recip else None
        o0, ok = [order0(x) for x in a], [order_k(x) for x in a]
        lane = op in ("fabs", "fmin", "fmax", "if_else_zero") or op in PIECEWISE
        if lane:
            o0, ok, target = [order0(x, True) for x in a], [order_k(x, True) for x in a], vk(n, True)
        if op in ("add", "sub"):
            first, second = ok
            sign = "+" if op == "add" else "-"
            if a[0][0] == a[1][0] == "v":
                expr = f"{first} {sign} {second}"
            else:
                expr = first if a[1][0] == "c" else (second if op == "add" else f"-{second}")
        elif op == "lin":
            expr = lin_order_k(node, order_k, order0)
        elif op == "neg":
            expr = f"-{ok[0]}"
        elif op == "twice":
            expr = f"2.0 * {ok[0]}"
        elif op == "mul":
            if a[0][0] == a[1][0] == "v":
                expr = f"{I} + {o0[0]} * {ok[1]} + {ok[0]} * {o0[1]}"
            else:
                c, v = (a[0], a[1]) if a[0][0] == "c" else (a[1], a[0])
                expr = f"{order0(c)} * {order_k(v)}"
        elif op == "sq":
            expr = f"{I} + 2.0 * {o0[0]} * {ok[0]}"
        elif op == "div":
            num = f"{ok[0]} - " if a[0][0] == "v" else "-"
            expr = f"({num}{I} - {ok[1]} * {v0(n)}) * {rec}"
        elif op == "sqrt":
            expr = f"({ok[0]} - {I}) * {rec}"
        elif op in ("sincos", "sinhcosh"):
            c = node.extra[0]
            out.append((False, f"{target} = {I} * rk + {ok[0]} * {v0(c)};"))
            sign = "-" if op == "sincos" else ""
            expr = f"{sign}({interior(c)} * rk + {ok[0]} * {v0(n)})"
            target = vk(c)
        elif op == "exp":
            expr = f"{I} * rk + {ok[0]} * {v0(n)}"
        elif op in ("tan", "tanh"):
            q = node.extra[0]
            out.append((False, f"{target} = {I} * rk + {ok[0]} * {v0(q)};"))
            sign = "" if op == "tan" else "-"
            expr = f"{sign}({interior(q)} + 2.0 * {v0(n)} * {vk(n)})"
            target = vk(q)
        elif op in ("log", "dq"):
            expr = f"({ok[0]} - {I} * rk) * {rec}"
        elif op == "atan2":
            expr = f"({I} * rk + {ok[0]} * {o0[1]} - {ok[1]} * {o0[0]}) * {rec}"
        elif op == "pow":
            expr = f"({I} * rk + {o0[1]} * {ok[0]} * {v0(n)}) * {rec}"
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
            lane, target = True, vk(n, True)
        out.append((lane, f"{target} = {expr};"))
        for m in [n] + node.extra:
            if m in plan.weighted:
                out.append((False, f"{vk(plan.weighted[m])} = dk * {vk(m)};"))
    return out


def next_items(plan: Plan, at_order0: bool, slices: bool = False) -> list[tuple[bool, str]]:
    """coefficient k + 1 of the states (x_i^[k+1] = f_i^[k] / (k + 1)) and of t, and their
    weighted series (j x_j at j = k + 1 is f_i^[k]); order 0: one lane's statements (slices:
    slice statements where the value is not a number)"""
    dec = plan.dec
    out: list[tuple[bool, str]] = []

    def put(n: int, f: str | None, scale: str = "") -> None:
        if f is None or (at_order0 and not slices):
            out.append((True, f"GW_LN({n}) = {'0.0' if f is None else f};"))
        else:
            out.append((False, f"GW_VN({n}) = {f}{'' if at_order0 else scale};"))

    for i, o in enumerate(dec.outputs):
        s = dec.output_scales[i] if dec.output_scales else None  # x_i' = s output_i
        if at_order0:
            f = None if o is None else order0(o, not slices)
            f = f if f is None or s is None else f"{order0(s, not slices)} * {f}"
        else:
            f = None if o is None or o[0] == "c" else vk(o[1])
        scaled = f is None or s is None or at_order0
        put(i, f, " * rk1" if scaled else f" * ({order0(s)} * rk1)")
        if i in plan.weighted:
            put(plan.weighted[i], f if scaled else f"{order0(s)} * {f}")
    if dec.t_node is not None:
        T = dec.t_node
        for n in [T] + ([plan.weighted[T]] if T in plan.weighted else []):
            out.append((True, f"GW_LN({n}) = {'1.0' if at_order0 else '0.0'};"))
    return out


def local_variables(plan: Plan, items: list[tuple[bool, str]], packed: bool = False) -> list[tuple[bool, str]]:
    """order k >= 1: a node whose coefficients no interior sum reads (and not a state or t)
    needs its coefficient k only in this order's statements: a local variable (a register, no
    store and reload) when its statement and all its uses are in one loop of whole statements
    (its slot k still holds its interior sum, if it has one).  packed: the interior sums read
    the packed copies (Packs), so any node but the states and t may be local"""
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


def loops(items: list[tuple[bool, str]]) -> list[str]:
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
