"""Equations of motion of a constrained mechanical system, derived by CasADi.

Given kinetic energy T(q, q_dot), potential V(q), Pfaffian constraints
A(q) q_dot = 0 and non-conservative generalised forces Q_nc, this module builds
the two formulations compared in Kelly's NASA report ("Dynamics Formulations for
the Real-Time Simulation of Constrained Motion", NASA/ASEE 1987):

* reduced (null-space / Kane-Maggi): q_dot = S(q) v with A S = 0 and
  S^T (M q_ddot + c - Q) = 0, q_ddot = S v_dot + S_dot v: a system in the
  independent speeds v only; the constraints hold by construction.
* multipliers (the paper's eq. 6 route): [M  -A^T; A  0] [q_ddot; lambda] =
  [Q - c; -A_dot q_dot - k A q_dot], the last term a velocity-level
  stabilisation of the drift of the nonholonomic constraints.

M = d2T/dq_dot2, c = d/dq(dT/dq_dot) q_dot - dT/dq (Coriolis and centrifugal
terms), Q = -dV/dq + Q_nc; every derivative is taken by CasADi.

Two extensions the effects need:
* driven coordinates (rheonomic): coordinates whose rate and acceleration are
  prescribed (a servo-held tilt, a flywheel at constant speed). They enter T and
  so the equations of the free coordinates; their own equations are dropped (the
  motor supplies whatever torque it takes).
* extra unknowns: Q_nc may depend on quantities that are themselves affine in the
  accelerations (the normal load on a rolling-resistance torque). Their defining
  equations are appended and everything is solved as one linear system.
* conditions: extra unknowns defined by a residual row instead of an explicit
  expression, e.g. the holding force H of a stiction law, s r_dot + (1 - s) H = 0
  (the multiplier of the constraint r_dot = 0 while stuck, zero while sliding).

All expressions are written in placeholder symbols (q, q_dot, q_ddot of every
coordinate); `formulate_*` return the accelerations as expressions of the state.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from gyrowheel.model.polynomial import simplify, solve_linear


def prune_identically_zero(A: ca.SX, trials: int = 6, seed: int = 20261122) -> ca.SX:
    """A with its identically-zero entries made structural zeros.

    Symbolic expressions such as R^2 (s_a c_a - c_a s_a) b_dot vanish for all arguments but
    CasADi cannot see it, so it would solve a dense system. An entry that evaluates to zero
    (to 1e-13 of the largest) at `trials` random points of its arguments is identically zero
    with probability 1 (Schwartz-Zippel: a nonzero analytic function vanishes only on a null
    set); every other entry is kept exactly as derived.
    """
    syms = ca.symvar(A)
    if not syms:
        return A
    f = ca.Function("prune", syms, [A])
    rng = np.random.default_rng(seed)
    zero = np.ones(A.shape, dtype=bool)
    for _ in range(trials):
        value = np.array(f(*rng.uniform(0.2, 1.3, len(syms))))
        zero &= np.abs(value) <= 1e-13 * max(np.abs(value).max(), 1e-300)
    pruned = ca.SX(A)
    for i, j in zip(*np.nonzero(zero)):
        pruned[int(i), int(j)] = 0
    return ca.sparsify(pruned)


def independent_of(expr: ca.SX, sym: ca.SX, trials: int = 6, seed: int = 20261129) -> bool:
    """True if expr does not depend on the scalar symbol sym (d expr / d sym vanishes, to 1e-12 of
    expr's size, at `trials` random points of all its arguments: an analytic derivative that is
    not identically zero vanishes only on a null set, as in prune_identically_zero)."""
    syms = ca.symvar(expr)
    if not any(ca.is_equal(sym, v) for v in syms):
        return True
    f = ca.Function("dependence", syms, [ca.jacobian(ca.vec(expr), sym), ca.vec(expr)])
    rng = np.random.default_rng(seed)
    for _ in range(trials):
        d, e = (np.array(v) for v in f(*rng.uniform(0.2, 1.3, len(syms))))
        if np.max(np.abs(d), initial=0.0) > 1e-12 * max(1.0, np.max(np.abs(e), initial=0.0)):
            return False
    return True


def evaluation_cost(expr: ca.SX) -> int:
    """Instructions of expr after common-subexpression elimination, a division counted as 8 (its
    latency against a multiplication's): how the candidate forms of the solve are compared."""
    expr = ca.cse(ca.SX(expr))
    f = ca.Function("cost", ca.symvar(expr), [ca.densify(ca.vec(expr))])
    ops = [f.instruction_id(k) for k in range(f.n_instructions())]
    return len(ops) + 7 * ops.count(ca.OP_DIV)


def _cramer(A: ca.SX, b: ca.SX) -> ca.SX:
    """x with A x = b for a small square A (one or two stiction laws) by Cramer's rule: one shared
    division by det(A) and no square roots (CasADi's symbolic solve is a QR factorisation)."""
    n = A.size1()
    inv_det = 1 / ca.det(A)
    x = ca.SX.zeros(n)
    for i in range(n):
        Ai = ca.SX(A)
        Ai[:, i] = b
        x[i] = ca.det(Ai) * inv_det
    return x


@dataclass
class ConstrainedSystem:
    """Placeholders and terms of a system with linear velocity constraints.

    q, qd, qdd: placeholders of all coordinates (free first, then driven);
    n_free: how many are free; T, V: energies in (q, qd); A: constraint matrix
    (m x n_free) in q; Q_nc: generalised forces (n, one per coordinate) in
    (q, qd, unknowns); unknowns: extra unknown symbols with their defining
    expressions (unknown = expr(q, qd, qdd)), e.g. the normal force; conditions: extra
    unknown symbols with a residual row (residual(q, qd, qdd, unknowns) = 0, affine), solved
    after the unknowns in the same system.
    """

    q: ca.SX
    qd: ca.SX
    qdd: ca.SX
    n_free: int
    T: ca.SX
    V: ca.SX
    A: ca.SX
    Q_nc: ca.SX | None = None
    unknowns: list[tuple[ca.SX, ca.SX]] = field(default_factory=list)
    conditions: list[tuple[ca.SX, ca.SX]] = field(default_factory=list)
    parameters: list[str] = field(default_factory=list)  # names of the parameter symbols (hoisting)

    @property
    def n(self) -> int:
        return self.q.numel()

    def terms(self):
        """Mass matrix, velocity terms c and generalised force Q (all in placeholders)."""
        p = ca.gradient(self.T, self.qd)
        M = ca.jacobian(p, self.qd)
        c = ca.mtimes(ca.jacobian(p, self.q), self.qd) - ca.gradient(self.T, self.q)
        Q = -ca.gradient(self.V, self.q)
        if self.Q_nc is not None:
            Q = Q + self.Q_nc
        return M, c, Q

    def driven_forces(self) -> ca.SX:
        """Generalised forces the motors of the driven coordinates must supply (placeholders)."""
        M, c, Q = self.terms()
        return (ca.mtimes(M, self.qdd) + c - Q)[self.n_free:]

    def null_space(self, dependent: list[int]) -> ca.SX:
        """S(q) (n_free x n_free - m) with A S = 0, from A = [A_d A_i].

        q_dot_d = -A_d^-1 A_i q_dot_i, so S stacks -A_d^-1 A_i over the identity
        (rows permuted back to the order of the free coordinates).
        """
        n, m = self.n_free, self.A.size1()
        if len(dependent) != m:
            raise ValueError(f"need {m} dependent coordinates, got {len(dependent)}")
        independent = [i for i in range(n) if i not in dependent]
        B = -ca.solve(self.A[:, dependent], self.A[:, independent])
        S = ca.SX.zeros(n, len(independent))
        for row, i in enumerate(dependent):
            S[i, :] = B[row, :]
        for col, i in enumerate(independent):
            S[i, col] = 1
        return ca.simplify(S)

    def _solve(self, residual: ca.SX, w: ca.SX) -> ca.SX:
        """w from the residual, affine in w; the last len(conditions) rows and entries of w are the
        conditions and their unknowns (the holding forces H of stiction laws).

        Those are eliminated last (a Schur complement): the other rows are solved for the other
        unknowns with H kept as a symbol (it enters their right-hand side only, linearly:
        w1 = c0 + C1 H), then the condition rows, affine in H, give H (k x k, k = 1 or 2). So the
        bulk of the system keeps the small block that _solve_affine's exact polynomial form handles
        (a 5 x 5 or 6 x 6 block would fall back to CasADi's QR solve, with square roots).
        """
        k = len(self.conditions)
        if k == 0:
            return self._solve_affine(residual, w)
        n = w.numel() - k
        w1, h = w[:n], w[n:]
        if ca.depends_on(ca.jacobian(residual[:n], w1), h):
            return self._solve_affine(residual, w)  # H in the coefficients: no elimination
        w1_h = self._solve_affine(residual[:n], w1)
        rows_h = ca.substitute(residual[n:], w1, w1_h)
        h_sol = _cramer(ca.jacobian(rows_h, h), -ca.substitute(rows_h, h, ca.DM.zeros(k)))
        return ca.vertcat(ca.substitute(w1_h, h, h_sol), h_sol)

    def _solve_affine(self, residual: ca.SX, w: ca.SX) -> ca.SX:
        """w from the residual, which is affine in w: A w + b = 0.

        Simplified before code generation, every step exact (docs/performance.md):
        identically-zero entries of A pruned; coordinates on which neither A nor b depends
        (cyclic: x, y, the heading alpha and the spin gamma of the wheel on flat ground) set to 0,
        which removes their sines and cosines from the accelerations; then A w = -b solved block
        by block by Cramer's rule in exact polynomial arithmetic (model/polynomial.py: equal terms
        merged, sin^2 + cos^2 = 1, common monomial factors cancelled, one division in all).  Of
        that, CasADi's solve of the same system and its solve of the original system, the
        cheapest to evaluate is kept (evaluation_cost): all three are the same function.
        """
        A = ca.jacobian(residual, w)
        if ca.depends_on(A, w):
            raise ValueError("the equations are not affine in the accelerations and extra unknowns; "
                             "generalised forces must be linear in the normal force")
        b = ca.substitute(residual, w, ca.DM.zeros(w.numel()))
        A = prune_identically_zero(A)
        candidates = [ca.solve(A, -b)]  # the plain symbolic solve, kept when it is the cheapest
        both = ca.veccat(A, b)
        cyclic = [self.q[i] for i in range(self.n_free) if independent_of(both, self.q[i])]
        if cyclic:
            zero = ca.DM.zeros(len(cyclic))
            A = ca.substitute(A, ca.vertcat(*cyclic), zero)
            b = ca.substitute(b, ca.vertcat(*cyclic), zero)
            candidates.append(ca.solve(A, -b))
        candidates.append(solve_linear(A, -b, max_block=4, params=self.parameters))
        return min(candidates, key=evaluation_cost)

    def _unknowns(self):
        """Symbols of the extra unknowns and their rows (unknowns, then conditions)."""
        rows = [s - e for s, e in self.unknowns] + [r for _, r in self.conditions]
        if not rows:
            return ca.SX(0, 1), ca.SX(0, 1)
        syms = ca.vertcat(*[s for s, _ in self.unknowns], *[s for s, _ in self.conditions])
        return syms, ca.vertcat(*rows)

    def reduced(self, S: ca.SX, v: ca.SX, v_dot: ca.SX, qd_driven: ca.SX, qdd_driven: ca.SX):
        """Kane-Maggi form. Returns (q_dot, q_ddot, v_dot solved, unknowns solved) as expressions.

        q_dot = [S v; qd_driven], q_ddot = [S v_dot + S_dot v; qdd_driven]; v_dot and the
        extra unknowns come from one linear solve.
        """
        nf = self.n_free
        qf = self.q[:nf]
        qd_free = ca.mtimes(S, v)
        simpler = simplify(qd_free, params=self.parameters)  # sin^2 + cos^2 = 1 in the kinematics
        if evaluation_cost(simpler) < evaluation_cost(qd_free):
            qd_free = simpler
        qd_all = ca.vertcat(qd_free, qd_driven)
        S_dot_v = ca.jtimes(qd_free, qf, qd_free)  # d(S v)/dq q_dot with v held fixed
        qdd_all = ca.vertcat(ca.mtimes(S, v_dot) + S_dot_v, qdd_driven)
        M, c, Q = self.terms()
        eq = ca.mtimes(S.T, (ca.mtimes(M, self.qdd) + c - Q)[:nf])
        x_syms, x_rows = self._unknowns()
        residual = ca.vertcat(eq, x_rows)
        residual = ca.substitute(residual, ca.vertcat(self.qd, self.qdd), ca.vertcat(qd_all, qdd_all))
        w = ca.vertcat(v_dot, x_syms)
        sol = self._solve(residual, w)
        v_dot_sol, x_sol = sol[: v.numel()], sol[v.numel():]
        qdd_sol = ca.substitute(qdd_all, v_dot, v_dot_sol)
        return qd_all, qdd_sol, v_dot_sol, x_sol

    def multipliers(self, qd_free: ca.SX, qd_driven: ca.SX, qdd_driven: ca.SX, k_stab):
        """KKT system of eq. (6) with velocity stabilisation.

        Returns (q_ddot of all coordinates, lambda, unknowns, constraint residual A q_dot).
        """
        nf = self.n_free
        qf = self.q[:nf]
        qdd_free = ca.SX.sym("qdd_free", nf)
        lam = ca.SX.sym("lambda", self.A.size1())
        qd_all = ca.vertcat(qd_free, qd_driven)
        qdd_all = ca.vertcat(qdd_free, qdd_driven)
        M, c, Q = self.terms()
        Aqd = ca.mtimes(self.A, qd_free)
        A_dot_qd = ca.jtimes(Aqd, qf, qd_free)
        dyn = (ca.mtimes(M, self.qdd) + c - Q)[:nf] - ca.mtimes(self.A.T, lam)
        con = ca.mtimes(self.A, qdd_free) + A_dot_qd + k_stab * Aqd
        x_syms, x_rows = self._unknowns()
        residual = ca.vertcat(dyn, con, x_rows)
        residual = ca.substitute(residual, ca.vertcat(self.qd, self.qdd), ca.vertcat(qd_all, qdd_all))
        w = ca.vertcat(qdd_free, lam, x_syms)
        sol = self._solve(residual, w)
        m = self.A.size1()
        qdd_sol = ca.vertcat(sol[:nf], qdd_driven)
        return qdd_sol, sol[nf: nf + m], sol[nf + m:], Aqd
