"""When each node's coefficient k is ready in phase 2 of the Taylor kernel: a latency model.

Phase 2 of an order (fmu_build/taylor_c.py) evaluates the nodes' boundary terms in program
order; at the low orders of loose tolerances an order's time is its critical path (a chain of
dependent multiply-adds from the interior sums and the states' new coefficients to the next
coefficients of the states), not its operation count.  C evaluates a + b + c as (a + b) + c and
the compiler may not reassociate, so the generator orders each sum's terms by when their operands
are ready, the latest last: then it waits for the latest operand through one multiply-add only.
The model: interior sums and the states' (and t's) coefficients ready at 0, one multiply-add (or
multiply, add) LATENCY, constants and order-0 values always ready.
"""
from __future__ import annotations

from fmu_build.taylor_graph import Decomposition, Operand

__all__ = ["ready", "LATENCY"]

LATENCY = 1.0


def _chain(times: list[float], first: float = LATENCY) -> float:
    """a sum of terms, each a multiply-add onto the running sum, in ascending readiness"""
    ts = sorted(times)
    acc = ts[0] + first
    for t in ts[1:]:
        acc = max(acc, t) + LATENCY
    return acc


def ready(dec: Decomposition) -> dict[int, float]:
    """var node -> the time its coefficient k is ready in phase 2 (in multiply-add latencies)"""
    t = {n: 0.0 for n in range(dec.nx + (dec.t_node is not None))}

    def at(a: Operand) -> list[float]:
        return [t[a[1]]] if a[0] == "v" else []

    for n, nd in dec.nodes.items():
        ins = [x for a in nd.args for x in at(a)]
        if nd.op == "mul" and len(ins) == 2 or nd.op == "lin":
            r = _chain([0.0] + ins, 0.0) if nd.op == "mul" else _chain(ins)
        elif nd.op == "div":  # a_k rec - (I + b_k v_0) rec, or (a_k - I) rec - b_k (v_0 rec)
            r = _chain([0.0] + ins, 0.0)
        elif nd.op in ("add", "sub", "neg", "twice", "mul", "sq", "sincos", "sinhcosh", "exp"):
            r = max(ins) + LATENCY
        else:
            r = max(ins, default=0.0) + 2 * LATENCY
        t[n] = r
        for e in nd.extra:  # sincos: the pair at once; tan: q after v
            t[e] = r + (0.0 if nd.op in ("sincos", "sinhcosh") else LATENCY)
    return t
