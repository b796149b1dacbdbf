"""Symbolic simplification of CasADi expressions before code generation: exact polynomial normal form.

CasADi builds the equations by automatic differentiation of the Lagrangian; the result is correct but
redundant: pairs such as 0.5 a b + 0.5 b a, products re-associated in different orders, terms that
cancel only through sin^2 + cos^2 = 1. CasADi's `cse` merges identical nodes, not equal ones. This
module rewrites an expression into a canonical form that does:

* every scalar is expanded into a polynomial over *atoms* (the input symbols and every
  non-polynomial node: sin(u), cos(u), 1/d, sqrt(u), ... with canonical arguments) with exact
  rational coefficients (`fractions.Fraction` of the double constants), so equal terms merge and
  opposite terms cancel exactly;
* cos(u)^2 is rewritten as 1 - sin(u)^2 for every pair of atoms sin(u), cos(u) (one representative
  of each trigonometric polynomial modulo sin^2 + cos^2 - 1);
* the polynomial is emitted by a greedy multivariate Horner scheme (factor out the atom that occurs
  in most terms), shared atoms are one SX node each.

Expressions whose expansion grows past `max_terms` terms are returned unchanged (`simplify`), so the
rewrite can only shrink what it touches. The result equals the input as a function of the symbols
(up to rounding); tests/test_model_polynomial.py checks that at random points.
"""
from __future__ import annotations

from collections import Counter
from fractions import Fraction

import casadi as ca

Monomial = tuple  # sorted ((atom index, power), ...)
Poly = dict  # Monomial -> Fraction


class TooLarge(Exception):
    """An expansion grew past the term limit."""


def _mul_mono(a: Monomial, b: Monomial) -> Monomial:
    if not a:
        return b
    if not b:
        return a
    d = dict(a)
    for k, p in b:
        d[k] = d.get(k, 0) + p
    return tuple(sorted(d.items()))


class Normaliser:
    """Polynomial normal form over atoms; one instance shares atoms between the expressions it sees."""

    def __init__(self, max_terms: int = 300, params=()):
        self.max_terms = max_terms
        self.params = set(params)  # names of the symbols that are parameters (coefficients)
        self._param_atom: dict[int, bool] = {}
        self.atoms: list[ca.SX] = []  # the SX node of each atom
        self.keys: dict = {}  # canonical key -> atom index
        self.trig: dict[int, tuple[str, object]] = {}  # atom index -> ("sin"|"cos", argument key)

    # -- polynomial arithmetic -------------------------------------------------------------
    def _check(self, p: Poly) -> Poly:
        if len(p) > self.max_terms:
            raise TooLarge
        return p

    @staticmethod
    def _add(a: Poly, b: Poly, sign: int = 1) -> Poly:
        out = dict(a)
        for m, c in b.items():
            v = out.get(m, 0) + sign * c
            if v:
                out[m] = v
            else:
                out.pop(m, None)
        return out

    def _mul(self, a: Poly, b: Poly) -> Poly:
        out: Poly = {}
        for ma, ca_ in a.items():
            for mb, cb in b.items():
                m = _mul_mono(ma, mb)
                v = out.get(m, 0) + ca_ * cb
                if v:
                    out[m] = v
                else:
                    out.pop(m, None)
        return self._check(out)

    @staticmethod
    def _const(p: Poly):
        if not p:
            return Fraction(0)
        if len(p) == 1 and () in p:
            return p[()]
        return None

    @staticmethod
    def _key(p: Poly):
        return tuple(sorted(p.items()))

    def _atom(self, key, make) -> Poly:
        if key not in self.keys:
            self.keys[key] = len(self.atoms)
            self.atoms.append(make())
        return {((self.keys[key], 1),): Fraction(1)}

    # -- from CasADi -------------------------------------------------------------------------
    def polys(self, expr: ca.SX) -> list[Poly]:
        """The normal form of every element of expr (column-major)."""
        expr = ca.SX(expr)
        syms = ca.symvar(expr)
        f = ca.Function("normal_form", syms, [ca.densify(ca.vec(expr))])
        work: dict[int, Poly] = {}
        out: list[Poly] = [dict() for _ in range(expr.numel())]
        for k in range(f.n_instructions()):
            op = f.instruction_id(k)
            o = f.instruction_output(k)
            i = f.instruction_input(k)
            if op == ca.OP_INPUT:
                s = syms[i[0]]
                work[o[0]] = self._atom(("sym", s.name()), lambda s=s: s)
            elif op == ca.OP_OUTPUT:
                out[o[1]] = work[i[0]]
            elif op == ca.OP_CONST:
                c = float(f.instruction_constant(k))
                work[o[0]] = {(): Fraction(c)} if c else {}
            else:
                work[o[0]] = self._op(op, [work[j] for j in i[: self._arity(op)]])
        return [self._reduce_trig(p) for p in out]

    @staticmethod
    def _arity(op: int) -> int:
        return 2 if op in (ca.OP_ADD, ca.OP_SUB, ca.OP_MUL, ca.OP_DIV, ca.OP_POW, ca.OP_CONSTPOW, ca.OP_FMIN,
                           ca.OP_FMAX, ca.OP_ATAN2, ca.OP_IF_ELSE_ZERO, ca.OP_LT, ca.OP_LE, ca.OP_EQ, ca.OP_NE,
                           ca.OP_AND, ca.OP_OR, ca.OP_COPYSIGN, ca.OP_FMOD, ca.OP_HYPOT) else 1

    def _op(self, op: int, a: list[Poly]) -> Poly:
        if op == ca.OP_ADD:
            return self._check(self._add(a[0], a[1]))
        if op == ca.OP_SUB:
            return self._check(self._add(a[0], a[1], -1))
        if op == ca.OP_NEG:
            return {m: -c for m, c in a[0].items()}
        if op == ca.OP_MUL:
            return self._mul(a[0], a[1])
        if op == ca.OP_TWICE:
            return {m: 2 * c for m, c in a[0].items()}
        if op == ca.OP_SQ:
            return self._mul(a[0], a[0])
        if op == ca.OP_ASSIGN:
            return a[0]
        if op == ca.OP_DIV:
            c = self._const(a[1])
            if c:  # division by a constant: exact
                return {m: v / c for m, v in a[0].items()}
            inv = self._atom(("inv", self._key(a[1])), lambda d=a[1]: 1 / self.emit(d))
            return self._mul(a[0], inv)
        if op == ca.OP_INV:
            c = self._const(a[0])
            if c:
                return {(): 1 / c}
            return self._atom(("inv", self._key(a[0])), lambda d=a[0]: 1 / self.emit(d))
        if op in (ca.OP_POW, ca.OP_CONSTPOW):
            e = self._const(a[1])
            if e is not None and e.denominator == 1 and 0 <= e <= 8:
                p: Poly = {(): Fraction(1)}
                for _ in range(int(e)):
                    p = self._mul(p, a[0])
                return p
        consts = [self._const(x) for x in a]
        if all(c is not None for c in consts):  # a function of constants: fold it
            args = [ca.SX(float(c)) for c in consts]
            v = ca.SX.unary(op, args[0]) if len(a) == 1 else ca.SX.binary(op, *args)
            if v.is_constant():
                fv = float(ca.DM(v))
                return {(): Fraction(fv)} if fv else {}
        key = (op,) + tuple(self._key(x) for x in a)
        if len(a) == 1:
            atom = self._atom(key, lambda x=a[0]: ca.SX.unary(op, self.emit(x)))
        else:
            atom = self._atom(key, lambda x=a[0], y=a[1]: ca.SX.binary(op, self.emit(x), self.emit(y)))
        if op in (ca.OP_SIN, ca.OP_COS):
            self.trig[self.keys[key]] = ("sin" if op == ca.OP_SIN else "cos", self._key(a[0]))
        return atom

    def _reduce_trig(self, p: Poly) -> Poly:
        """cos(u)^2 -> 1 - sin(u)^2 where both atoms exist (repeated until no cos^2 is left)."""
        pairs = {}
        for idx, (kind, arg) in self.trig.items():
            pairs.setdefault(arg, {})[kind] = idx
        rules = [(d["cos"], d["sin"]) for d in pairs.values() if "cos" in d and "sin" in d]
        for cos_i, sin_i in rules:
            one_minus_s2 = {(): Fraction(1), ((sin_i, 2),): Fraction(-1)}
            while True:
                m = next((m for m in p if dict(m).get(cos_i, 0) >= 2), None)
                if m is None:
                    break
                p = dict(p)
                c = p.pop(m)
                d = dict(m)
                d[cos_i] -= 2
                rest = tuple(sorted((k, v) for k, v in d.items() if v))
                p = self._add(p, self._mul({rest: c}, one_minus_s2))
        return p

    # -- back to CasADi ----------------------------------------------------------------------
    def is_param_atom(self, k: int) -> bool:
        """Atom k depends on parameters alone (its value is fixed during a simulation)."""
        if k not in self._param_atom:
            self._param_atom[k] = bool(self.params) and all(
                v.name() in self.params for v in ca.symvar(self.atoms[k]))
        return self._param_atom[k]

    def emit(self, p: Poly) -> ca.SX:
        """p as an SX expression: a greedy multivariate Horner form.  With parameters declared, the
        monomials are grouped by their part in the other atoms and each group's coefficient, a
        polynomial of the parameters alone, is emitted as one subexpression (hoisted out of the
        right-hand side by model/hoist.py): k_a alpha_dot cos(beta) - 2 k_d alpha_dot cos(beta)
        becomes (k_a - 2 k_d) alpha_dot cos(beta)."""
        if not self.params:
            return self._horner({m: ca.SX(float(c)) for m, c in p.items()}, {m: c for m, c in p.items()})
        groups: dict[Monomial, Poly] = {}
        for m, c in p.items():
            var = tuple((k, v) for k, v in m if not self.is_param_atom(k))
            par = tuple((k, v) for k, v in m if self.is_param_atom(k))
            groups.setdefault(var, {})[par] = c
        coeffs = {}
        for var, poly in groups.items():
            const = Normaliser._const(poly)
            coeffs[var] = const if const is not None else self._horner(
                {m: ca.SX(float(c)) for m, c in poly.items()}, poly)
        return self._horner({m: (ca.SX(float(c)) if isinstance(c, Fraction) else c) for m, c in coeffs.items()},
                            {m: c for m, c in coeffs.items() if isinstance(c, Fraction)})

    def _horner(self, terms: dict, exact: dict) -> ca.SX:
        """sum of coefficient * monomial; terms: monomial -> SX coefficient, exact: the coefficients
        known as numbers (1 and -1 need no multiplication)."""
        if not terms:
            return ca.SX(0)
        const = terms.get(())
        rest = {m: c for m, c in terms.items() if m}
        if not rest:
            return const
        count = Counter(k for m in rest for k, _ in m)
        atom, n = count.most_common(1)[0]
        if n == 1 and len(rest) > 1:
            out = None
            for m, c in rest.items():
                t = self._emit_mono(m, exact.get(m), c)
                out = t if out is None else out + t
        else:
            with_a, without = {}, {}
            ex_a, ex_wo = {}, {}
            for m, c in rest.items():
                d = dict(m)
                if atom in d:
                    d[atom] -= 1
                    key = tuple(sorted((k, v) for k, v in d.items() if v))
                    with_a[key] = c
                    if m in exact:
                        ex_a[key] = exact[m]
                else:
                    without[m] = c
                    if m in exact:
                        ex_wo[m] = exact[m]
            out = self.atoms[atom] * self._horner(with_a, ex_a)
            if without:
                out = out + self._horner(without, ex_wo)
        if const is None or (() in exact and exact[()] == 0):
            return out
        return out + const

    def _emit_mono(self, m: Monomial, c, coeff: ca.SX) -> ca.SX:
        out = None
        for k, pw in m:
            f = self.atoms[k] if pw == 1 else (ca.SX.unary(ca.OP_SQ, self.atoms[k]) if pw == 2 else self.atoms[k] ** pw)
            out = f if out is None else out * f
        if c == 1:
            return out
        if c == -1:
            return -out
        return coeff * out


def simplify(expr: ca.SX, max_terms: int = 300, normaliser: Normaliser | None = None, params=()) -> ca.SX:
    """expr in the polynomial normal form, or unchanged if an expansion grows past max_terms.
    params: names of the parameter symbols (coefficients grouped, Normaliser.emit)."""
    expr = ca.SX(expr)
    if expr.numel() == 0:
        return expr
    norm = normaliser or Normaliser(max_terms, params)
    try:
        polys = norm.polys(expr)
    except TooLarge:
        return expr
    n1 = expr.size1()
    out = ca.SX.zeros(n1, expr.size2())
    for k, p in enumerate(polys):
        out[k % n1, k // n1] = norm.emit(p)
    return ca.sparsify(out)


def _content(polys: list[Poly]) -> Monomial:
    """The largest monomial dividing every term of every polynomial (their monomial gcd)."""
    common: dict | None = None
    for p in polys:
        for m in p:
            d = dict(m)
            common = d if common is None else {k: min(v, d[k]) for k, v in common.items() if k in d}
            if not common:
                return ()
    return tuple(sorted((common or {}).items()))


def _divide(p: Poly, m: Monomial) -> Poly:
    if not m:
        return p
    out = {}
    for mono, c in p.items():
        d = dict(mono)
        for k, v in m:
            d[k] -= v
        out[tuple(sorted((k, v) for k, v in d.items() if v))] = c
    return out


def _det(norm: Normaliser, A: list[list[Poly]]) -> Poly:
    n = len(A)
    if n == 1:
        return A[0][0]
    if n == 2:
        return norm._add(norm._mul(A[0][0], A[1][1]), norm._mul(A[0][1], A[1][0]), -1)
    out: Poly = {}
    for j in range(n):  # expansion along the first row
        minor = [[A[i][k] for k in range(n) if k != j] for i in range(1, n)]
        if A[0][j]:
            out = norm._add(out, norm._mul(A[0][j], _det(norm, minor)), -1 if j % 2 else 1)
    return norm._check(out)


def _blocks(A: ca.SX) -> list[list[int]]:
    """Index sets of the diagonal blocks of A (connected components of its sparsity graph)."""
    n = A.size1()
    adj: dict[int, set[int]] = {i: {i} for i in range(n)}
    rows, cols = A.sparsity().get_triplet()
    for i, j in zip(rows, cols):
        adj[i].add(j)
        adj[j].add(i)
    seen: set[int] = set()
    blocks = []
    for i in range(n):
        if i in seen:
            continue
        stack, comp = [i], []
        while stack:
            k = stack.pop()
            if k not in seen:
                seen.add(k)
                comp.append(k)
                stack.extend(adj[k] - seen)
        blocks.append(sorted(comp))
    return blocks


def solve_linear(A: ca.SX, b: ca.SX, max_block: int = 4, max_terms: int = 300, params=()) -> ca.SX:
    """x with A x = b, A square: block by block (the connected components of A's sparsity); a block
    of size <= max_block by Cramer's rule in exact polynomial arithmetic: each equation is first
    divided by the monomial common to all its terms (M R^2, ...), the numerators and the
    determinant by theirs (sin(beta), ...), both valid wherever A is regular.  One division for
    the whole system: with block determinants d_k and D = prod d_k, x = num (D / d_k) r with the
    shared reciprocal r = 1 / D, written 2 / (2 D) so that CasADi does not turn y * (1 / D) back
    into one division per use (exact: the factor 2 is a power of two).
    A determinant of the parameters alone gets its own reciprocal (hoisted by model/hoist.py).
    params: names of the parameter symbols (Normaliser.emit).
    Larger blocks, or expansions past max_terms, use CasADi's symbolic solve."""
    A, b = ca.SX(A), ca.SX(b)
    x = ca.SX.zeros(A.size1())
    norm = Normaliser(max_terms, params)
    solved = []  # (block, numerators, determinant) of the blocks done by Cramer
    for blk in _blocks(A):
        Ab, bb = A[blk, blk], b[blk]
        if len(blk) > max_block:
            x[blk] = ca.solve(Ab, bb)
            continue
        try:
            n = len(blk)
            pa, pb = norm.polys(Ab), norm.polys(bb)
            rows = []
            for i in range(n):
                row = [pa[i + j * n] for j in range(n)] + [pb[i]]
                g = _content(row)
                rows.append([_divide(p, g) for p in row])
            M = [r[:n] for r in rows]
            rhs = [r[n] for r in rows]
            det = norm._reduce_trig(_det(norm, M))
            nums = []
            for k in range(n):
                Mk = [[rhs[i] if j == k else M[i][j] for j in range(n)] for i in range(n)]
                nums.append(norm._reduce_trig(_det(norm, Mk)))
            g = _content([det] + nums)
            solved.append((blk, [_divide(p, g) for p in nums], _divide(det, g)))
        except TooLarge:
            x[blk] = ca.solve(Ab, bb)
    def fixed(det: Poly) -> bool:  # a determinant of the parameters alone
        return all(norm.is_param_atom(k) for m in det for k, _ in m)

    varying = [k for k, (_, _, det) in enumerate(solved) if Normaliser._const(det) is None and not fixed(det)]
    # r = 1 / D written 2 / (2 D): CasADi rewrites y * (1 / D) into y / D (a division per use)
    r = 2 / (2 * _product([norm.emit(solved[k][2]) for k in varying])) if varying else None
    for k, (blk, nums, det) in enumerate(solved):
        c = Normaliser._const(det)
        if c is not None:
            for i, num in zip(blk, nums):
                x[i] = norm.emit({m: v / c for m, v in num.items()})
            continue
        if fixed(det):
            inv_fixed = 2 / (2 * norm.emit(det))
            for i, num in zip(blk, nums):
                x[i] = norm.emit(num) * inv_fixed
            continue
        others = [norm.emit(solved[j][2]) for j in varying if j != k]
        inv = _product(others) * r if others else r  # 1 / d_k
        for i, num in zip(blk, nums):
            x[i] = norm.emit(num) * inv
    return x


def _product(factors: list[ca.SX]) -> ca.SX:
    out = factors[0]
    for f in factors[1:]:
        out = out * f
    return out
