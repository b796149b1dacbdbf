"""The one-lane Taylor kernel's packed interior sums (GW_TL_PACK in c_src/gw_taylor_ops.h).

Packs lays out, behind each order's nodes, packed copies of the interior terms' operands so
that 4 terms are two 2-wide vector multiply-adds of contiguous loads; it writes the copies'
statements and phase 1 of order k for the one-lane kernel (the structure: the top of
taylor/kernel_c.py).
"""
from __future__ import annotations

import re

from gyrowheel.taylor.kernel_plan import Plan, oriented
from gyrowheel.taylor.kernel_recurrences import interior_loop

__all__ = ["Packs", "PACK_GROUP"]

PACK_GROUP = 8  # accumulators (pairs of 2-double vectors) of one packed interior loop (one lane: Packs)


class Packs:
    """The one-lane kernel's interior sums, 4 terms per two 2-wide vector operations (GW_TL_PACK).

    At W = 1 a term's multiply-add is one scalar operation with its own loads: the interior
    loops are load-bound.  Here every term has a slot in two packed rows kept behind each
    order's nodes (row j of the a-operands, sign and constant factor applied: -c A_j; row j of
    the b-operands: B_j), so that 4 terms are vector multiply-adds of contiguous loads:
    s += PA[j][4q .. 4q+3] PB[k-j][4q .. 4q+3].  Each target node has one lane of one
    accumulator vector; a target with m terms adds them in m consecutive vectors of slots (the
    same order as the lanes' kernel: bit for bit the same sums), padded with 0 x 0.  A node's
    coefficient is copied to its slots right where it is computed (rows 1 .. order - 1)."""

    def __init__(self, plan: Plan):
        targets, _ = oriented(plan)
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
            lines += interior_loop(str(self.base), str(self.base + self.slots), body, True)
            lines += [f"        GW_TLPST(gw_is + {4 * q}, {a});" for (q, _), a in zip(group, acc)]
            lines.append("    }")
        return lines
