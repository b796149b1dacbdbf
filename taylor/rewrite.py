"""Cheaper Taylor decompositions: rewrites of gyrowheel.taylor.graph's graph, exact in real arithmetic.

Every var node of a decomposition costs its recurrence at every order of every step (interior
sum of a product: k - 1 multiply-adds at order k; a linear node: one operation, a store and its
packed copies).  CasADi's graph of a Lagrangian's equations carries constant factors through
chains of linear nodes (c*x, 2*x, -x), squares written x*(c*x), and reciprocals c/(2 c' sin b)
used only as factors of products.  This pass rewrites the graph, node by node in program order,
with each var node's value held as

    value = s * B   (or s / B: a reciprocal not yet computed)

s a constant (a cst node: computed once per integration call; None for 1), B a var node of the
new graph.  Constant factors ride on the node's consumers until something needs the value
itself:
  * c x, 2 x, -x, x / c: no node, the factor joins s;
  * (s1 B1) (s2 B2) = (s1 s2) (B1 B2); B1 = B2: (s1 s2) sq(B1) (recurrence with half the terms'
    boundary work);
  * s1 B1 / (s2 / B2) and (s1 B1) (s2 / B2) = (s1 / s2) div(B1, B2): a reciprocal used as a factor
    becomes a division (one interior sum, not the reciprocal's plus the product's);
  * sums of scaled terms: one `lin` node  sum_i +-[c_i] B_i [+- c0]  (a multiply-add per term),
    or s (B1 + B2) when both terms share the factor s; a sum read once (in CasADi's graph) is
    merged into the sum reading it;
  * x (c B + d), the sum read only here and the product only by a sum: c (x B) + d x (as many
    products, and x B may be shared below);
  * the state derivatives keep their factor: x_i^[k+1] = s_i B_i^[k] / (k + 1) (output_scales);
  * any other operation gets its operand's value (s B or s / B) as a node, made once.
No division by a factor is introduced (s2 / s1 with s1 a parameter that may be 0 would turn a
finite value into NaN): factors are only multiplied together, and divided where the original
graph divides.  Identical nodes are made once (products commutatively), nodes no output needs
are dropped, then products and quotients are shared modulo associativity (_Products).  Rounding
differs from the original graph's (products reassociated), values are equal in real arithmetic:
tests/test_taylor_rewrite.py checks them against CasADi's derivatives and the un-rewritten
kernel; docs/taylor.md has the counts, docs/performance.md the timings.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from gyrowheel.taylor.graph import Decomposition, Node, Operand

__all__ = ["rewrite", "lin_order0", "lin_order_k"]

Scale = Operand | None  # a cst operand, or None for 1
LINEAR = {"add", "sub", "neg", "twice"}


@dataclass(frozen=True)
class _Val:
    """value = s * base (recip: s / base); base a var operand of the new graph"""

    s: Scale
    base: Operand
    recip: bool = False


class _Rewriter:
    """CasADi's decomposition, node by node in program order, into values s B of a new graph"""

    def __init__(self, dec: Decomposition):
        self.dec = dec
        self.cst = list(dec.cst)
        self.cst_keys = {self._ckey(kind, payload): j for j, (kind, payload) in enumerate(self.cst)}
        self.nodes: dict[int, Node] = {}
        self.n_fixed = dec.nx + (dec.t_node is not None)  # the states and t: their own series
        self.n_var = self.n_fixed
        self.keys: dict[tuple, Operand] = {}
        self.val: dict[int, _Val] = {n: _Val(None, ("v", n)) for n in range(self.n_fixed)}
        # old nodes read once (by a node or an output): a sum among them is merged into its
        # reader (sum_of: its terms), a product with it distributed over its terms
        reads = [(a[1], nd.op) for nd in dec.nodes.values()
                 for a in nd.args + ([nd.zero[1]] if nd.zero else []) if a[0] == "v"]
        reads += [(o[1], "add") for o in dec.outputs if o is not None and o[0] == "v"]
        n_reads = Counter(m for m, _ in reads)
        self.once = {m for m in n_reads if n_reads[m] == 1}
        self.into_sum = {m for m, op in reads if m in self.once and op in ("add", "sub")}
        self.sum_of: dict[int, list[tuple[Scale, int, Operand]]] = {}

    # ---- constants ----
    @staticmethod
    def _ckey(kind: str, payload) -> tuple:
        return (kind, tuple(payload) if isinstance(payload, list) else payload)

    def constant(self, kind: str, payload) -> Operand:
        if kind == "mul":
            payload = sorted(payload)
        key = self._ckey(kind, payload)
        if key not in self.cst_keys:
            self.cst_keys[key] = len(self.cst)
            self.cst.append((kind, payload))
        return ("c", self.cst_keys[key])

    def smul(self, a: Scale, b: Scale) -> Scale:
        if a is None or b is None:
            return b if a is None else a
        return self.constant("mul", [a, b])

    def sdiv(self, a: Scale, b: Scale) -> Scale:
        if b is None:
            return a
        return self.constant("inv", [b]) if a is None else self.constant("div", [a, b])

    def sneg(self, a: Scale) -> Scale:
        return self.constant("k", -1.0) if a is None else self.constant("neg", [a])

    # ---- var nodes ----
    def var(self, op: str, args: list[Operand], **kw) -> Operand:
        key = (op, tuple(sorted(args) if op == "mul" else args), repr(sorted(kw.items())))
        if key not in self.keys:
            n = self.n_var
            self.n_var += 1
            self.nodes[n] = Node(op, list(args), **kw)
            self.keys[key] = ("v", n)
        return self.keys[key]

    def value(self, v: _Val) -> Operand:
        """the node holding v's value itself"""
        if v.recip:
            return self.var("div", [self.constant("k", 1.0) if v.s is None else v.s, v.base])
        return v.base if v.s is None else self.var("mul", [v.s, v.base])

    def arg(self, a: Operand) -> Operand:
        return a if a[0] == "c" else self.value(self.val[a[1]])

    def terms(self, a: Operand, sign: int) -> list[tuple[Scale, int, Operand]]:
        """a as linear terms (factor, sign, operand): a constant is one term with no factor; a
        sum read only here, its terms"""
        if a[0] == "c":
            return [(None, sign, a)]
        if a[1] in self.once and a[1] in self.sum_of:
            return [(c, g * sign, b) for c, g, b in self.sum_of[a[1]]]
        v = self.val[a[1]]
        if v.recip:
            return [(None, sign, self.value(v))]
        return [(v.s, sign, v.base)]

    # ---- the rules ----
    def product(self, x: _Val, y: _Val) -> _Val:
        s = self.smul(x.s, y.s)
        if x.recip and y.recip:
            return _Val(s, self.product(_Val(None, x.base), _Val(None, y.base)).base, True)
        if x.recip or y.recip:
            num, den = (y, x) if x.recip else (x, y)
            return _Val(s, self.var("div", [num.base, den.base]))
        if x.base == y.base:
            return _Val(s, self.var("sq", [x.base]))
        return _Val(s, self.var("mul", [x.base, y.base]))

    def linear(self, n: int, op: str, a: list[Operand]) -> _Val:
        if op in ("neg", "twice"):
            v = self.val[a[0][1]]
            s = self.sneg(v.s) if op == "neg" else self.smul(self.constant("k", 2.0), v.s)
            return _Val(s, v.base, v.recip)
        return self.sum(n, self.terms(a[0], 1) + self.terms(a[1], 1 if op == "add" else -1))

    def sum(self, n: int, terms: list[tuple[Scale, int, Operand]]) -> _Val:
        """old node n's value, the sum of terms (factor, sign, operand)"""
        self.sum_of[n] = terms
        if len(terms) == 2:
            (s1, g1, b1), (s2, g2, b2) = terms
            op = "add" if g1 * g2 > 0 else "sub"
            if g1 > 0 and s1 == s2 and b1[0] == b2[0] == "v":  # s (B1 +- B2): the factor rides on
                return _Val(s1, self.var(op, [b1, b2]))
            if g1 > 0 and s1 is None and s2 is None:
                return _Val(None, self.var(op, [b1, b2]))
        terms = sorted(terms, key=lambda x: x[2][0] == "c")  # the var terms lead
        return _Val(None, self.var("lin", [b for _, _, b in terms],
                                   coefs=tuple((s, g) for s, g, _ in terms)))

    def distributed(self, n: int, x: Operand, y: Operand) -> _Val | None:
        """x y with y = c B + d read only here, x y read only by a sum (or as an output):
        c (x B) + d x (one product as before; x B may be shared, and the sum merged into its
        reader), else None (a product read by a product or quotient stays one: its factors
        may be shared there)"""
        if (y[0] != "v" or y[1] not in self.once or n not in self.into_sum or x[0] != "v"
                or self.val[x[1]].recip):
            return None
        t = self.sum_of.get(y[1], [])
        var = [u for u in t if u[2][0] == "v"]
        if len(var) != 1 or len(t) != 2:
            return None
        (c, g, b), (cd, gd, d) = var[0], next(u for u in t if u[2][0] == "c")
        d = self.smul(cd, d)
        v = self.val[x[1]]
        p = self.product(_Val(None, v.base), _Val(None, b))
        return self.sum(n, [(self.smul(v.s, self.smul(c, p.s)), g, p.base), (self.smul(v.s, d), gd, v.base)])

    def node(self, n: int, nd: Node) -> None:
        op, a = nd.op, nd.args
        if op == "mul" and a[0][0] == "c" or op == "mul" and a[1][0] == "c":
            c, v = (a[0], self.val[a[1][1]]) if a[0][0] == "c" else (a[1], self.val[a[0][1]])
            self.val[n] = _Val(self.smul(c, v.s), v.base, v.recip)
        elif op == "mul" and (d := self.distributed(n, a[0], a[1]) or self.distributed(n, a[1], a[0])):
            self.val[n] = d
        elif op in ("mul", "sq"):
            x = self.val[a[0][1]]
            self.val[n] = self.product(x, self.val[a[-1][1]])
        elif op == "div" and a[0][0] == "c":
            y = self.val[a[1][1]]
            self.val[n] = _Val(self.sdiv(a[0], y.s), y.base, not y.recip)
        elif op == "div":
            x, y = self.val[a[0][1]], self.val[a[1][1]]
            inv = _Val(self.sdiv(None, y.s), y.base, not y.recip)
            self.val[n] = self.product(x, inv)
        elif op in LINEAR:
            self.val[n] = self.linear(n, op, a)
        else:  # every other operation: on its operands' values
            args = [self.arg(x) for x in a]
            zero = None if nd.zero is None else (nd.zero[0], self.arg(nd.zero[1]))
            first = self.n_var
            self.n_var += 1 + len(nd.extra)
            self.nodes[first] = Node(op, args, [first + 1 + i for i in range(len(nd.extra))], zero)
            self.val[n] = _Val(None, ("v", first))
            for i, e in enumerate(nd.extra):
                self.val[e] = _Val(None, ("v", first + 1 + i))


def _uses(nodes: dict[int, Node], roots: list[int]) -> dict[int, list[int]]:
    """var node -> the nodes reading it (an output: -1), with repeats"""
    users: dict[int, list[int]] = {m: [-1] for m in roots}
    owner = {e: n for n, nd in nodes.items() for e in nd.extra}
    for n, nd in nodes.items():
        read = [a[1] for a in nd.args if a[0] == "v"]
        read += [nd.zero[1][1]] if nd.zero is not None and nd.zero[1][0] == "v" else []
        for m in read:
            users.setdefault(owner.get(m, m), []).append(n)
    return users


class _Products:
    """Products and quotients of several factors, shared and re-paired.  Every maximal tree of
    var * var products and var / var quotients (inner ones read once) is one monomial: a
    multiset of factors x and inverse factors ~x (1 / x).  A pair of them common to several
    monomials (or already a node) becomes one node, x y or x / d, that they all use (CSE modulo
    associativity and commutativity: a x / d and b x / d share x / d).  Each monomial is then
    multiplied out in program order (measured as fast as earliest-ready-first pairing on the
    paper wheel), divided by the product of its inverse factors last."""

    def __init__(self, nodes: dict[int, Node], roots: list[int], fresh: int):
        self.nodes, self.fresh = nodes, fresh
        users = _uses(nodes, roots)
        self.absorbed = {m for m in nodes if self.product(m) and len(users.get(m, ())) == 1
                         and users[m][0] >= 0 and self.product(users[m][0])
                         and not (self.nodes[users[m][0]].op == "div"
                                  and self.nodes[users[m][0]].args[1] == ("v", m))}
        self.mono = {n: sorted(self.leaves(n)) for n in nodes
                     if self.product(n) and n not in self.absorbed}
        self.made = {tuple(m): n for n, m in self.mono.items() if len(m) == 2}
        self.defs: dict[int, Node] = {}
        self.share()

    def product(self, n: int) -> bool:
        nd = self.nodes.get(n)
        return nd is not None and nd.op in ("mul", "sq", "div") and all(a[0] == "v" for a in nd.args)

    def leaves(self, n: int) -> list[int]:
        nd = self.nodes[n]
        if nd.op == "div":
            return self.leaves_of(nd.args[0][1]) + [~nd.args[1][1]]
        return [x for a in nd.args * (2 if nd.op == "sq" else 1) for x in self.leaves_of(a[1])]

    def leaves_of(self, m: int) -> list[int]:
        return self.leaves(m) if m in self.absorbed else [m]

    def pair(self, p: tuple[int, int]) -> int:
        """the node of x y (x x: sq) or, p = (~d, x), x / d"""
        if p not in self.made:
            a, b = p
            self.made[p] = n = self.fresh
            self.defs[n] = (Node("div", [("v", b), ("v", ~a)]) if a < 0 else
                            Node("sq", [("v", a)]) if a == b else Node("mul", [("v", a), ("v", b)]))
            self.fresh += 1
        return self.made[p]

    def share(self) -> None:
        while True:
            count: dict[tuple[int, int], int] = {}
            for n, m in self.mono.items():
                if len(m) >= 3:
                    for p in {(m[i], m[j]) for i in range(len(m)) for j in range(i + 1, len(m))
                              if m[j] >= 0}:
                        count[p] = count.get(p, 0) + 1
            score = {p: c + (p in self.made) for p, c in count.items()}
            best = max(sorted(score), key=lambda p: score[p], default=None)
            if best is None or score[best] < 2:
                return
            pid = self.pair(best)
            for n, m in self.mono.items():
                rest = list(m)
                if len(m) >= 3 and n != pid and best[0] in rest and (rest.remove(best[0]) or best[1] in rest):
                    rest.remove(best[1])
                    m[:] = sorted(rest + [pid])

    def multiplied(self, xs: list[int]) -> int:
        """the product of factors xs (var nodes), in program order"""
        xs = sorted(xs)
        while len(xs) > 1:
            xs = [self.pair((xs[0], xs[1]))] + xs[2:]
        return xs[0]

    def result(self) -> dict[int, Node]:
        """the program: node -> definition, new nodes first where they are needed"""
        for n, m in self.mono.items():
            num = [x for x in m if x >= 0]
            den = [~x for x in m if x < 0]
            if den:
                self.defs[n] = Node("div", [("v", self.multiplied(num)), ("v", self.multiplied(den))])
                continue
            a, b = sorted([self.multiplied(num[:-1]), num[-1]] if len(num) > 2 else num)
            self.defs[n] = Node("sq", [("v", a)]) if a == b else Node("mul", [("v", a), ("v", b)])
        program: dict[int, Node] = {}
        owner = {e: n for n, nd in self.nodes.items() for e in nd.extra}

        def emit(n: int) -> None:
            n = owner.get(n, n)
            if n in program or n in self.absorbed or n not in self.defs and n not in self.nodes:
                return
            nd = self.defs.get(n, self.nodes.get(n))
            program[n] = nd  # (no cycle: a product reads only its factors)
            for a in nd.args + ([nd.zero[1]] if nd.zero is not None else []):
                if a[0] == "v":
                    emit(a[1])
            program[n] = program.pop(n)  # after its operands
        for n in self.nodes:
            emit(n)
        return program


def _needed(nodes: dict[int, Node], roots: list[int]) -> list[int]:
    """the program nodes the roots depend on, in program order"""
    owner = {e: n for n, nd in nodes.items() for e in nd.extra}
    need, stack = set(), list(roots)
    while stack:
        m = stack.pop()
        n = owner.get(m, m)
        if n not in nodes or n in need:  # a state or t, or done
            continue
        need.add(n)
        nd = nodes[n]
        stack += [x[1] for x in nd.args if x[0] == "v"]
        if nd.zero is not None and nd.zero[1][0] == "v":
            stack.append(nd.zero[1][1])
    return [n for n in nodes if n in need]


def rewrite(dec: Decomposition, share: bool = True) -> Decomposition:
    """The decomposition rewritten as in the module docstring: the same values in real
    arithmetic, fewer and cheaper nodes (share: products shared and re-paired, _Products).
    The states (and t) keep their node numbers."""
    r = _Rewriter(dec)
    for n, nd in dec.nodes.items():
        r.node(n, nd)
    outputs: list[Operand | None] = []
    scales: list[Scale] = []
    for o in dec.outputs:
        v = None if o is None or o[0] == "c" else r.val[o[1]]
        outputs.append(o if v is None else r.value(v) if v.recip else v.base)
        scales.append(None if v is None or v.recip else v.s)
    roots = [o[1] for o in outputs if o is not None and o[0] == "v"]
    program = {n: r.nodes[n] for n in _needed(r.nodes, roots)}  # (sums merged: unread nodes)
    if share:
        program = _Products(program, roots, r.n_var).result()
    need = _needed(program, roots)
    new = {m: m for m in range(r.n_fixed)}
    for n in need:  # renumbered in program order, each node's extras right after it
        new[n] = len(new)
        for e in program[n].extra:
            new[e] = len(new)

    def ren(a: Operand) -> Operand:
        return a if a[0] == "c" else ("v", new[a[1]])

    nodes: dict[int, Node] = {}
    counts: dict[str, int] = {}
    for n in need:
        nd = program[n]
        zero = None if nd.zero is None else (nd.zero[0], ren(nd.zero[1]))
        nodes[new[n]] = Node(nd.op, [ren(a) for a in nd.args], [new[e] for e in nd.extra], zero,
                             nd.coefs)
        counts[nd.op] = counts.get(nd.op, 0) + 1
    return Decomposition(nx=dec.nx, t_node=dec.t_node, nodes=nodes, n_var=len(new), cst=r.cst,
                         outputs=[None if o is None else ren(o) for o in outputs],
                         op_counts=counts, output_scales=scales)


def _factor(coef: Scale, sign: int, x: str, cst) -> str:
    term = x if coef is None else f"{cst(coef)} * {x}"
    return term if sign > 0 else f"-{term}" if coef is None else f"-({term})"


def lin_order0(nd: Node, order0, cst) -> str:
    """C of a lin node's value: sum_i +-[c_i] a_i (order0(a): an operand's value, cst(c): a
    constant's)"""
    return " + ".join(_factor(c, g, order0(a), cst) for (c, g), a in zip(nd.coefs, nd.args))


def lin_order_k(nd: Node, order_k, cst) -> str:
    """C of a lin node's coefficient k >= 1: its var terms' (a constant's coefficients are 0)"""
    return " + ".join(_factor(c, g, order_k(a), cst) for (c, g), a in zip(nd.coefs, nd.args)
                      if a[0] == "v")
