"""Equations of motion of a constrained mechanical system, derived by CasADi.

Given kinetic energy T(q, q_dot), potential V(q), Pfaffian constraints
A(q) q_dot = 0 and non-conservative generalised forces Q_nc(q, q_dot), this module
builds the two formulations compared in Kelly's NASA report
(seeds/kelly-nasa-constrained-motion.txt):

* reduced (null-space / Kane-Maggi): q_dot = S(q) v with A S = 0 and
  S^T (M S v_dot + M S_dot v + c - Q) = 0, a system in the independent speeds v
  only; the constraints hold by construction.
* multipliers (the paper's eq. 6 route): [M  -A^T; A  0] [q_ddot; lambda] =
  [Q - c; -A_dot q_dot - k A q_dot], the last term a velocity-level
  stabilisation of the drift of the nonholonomic constraints.

Here M = d2T/dq_dot2, c = d/dq(dT/dq_dot) q_dot - dT/dq (Coriolis and
centrifugal terms) and Q = -dV/dq + Q_nc. Every derivative is taken by CasADi.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import casadi as ca

EnergyFn = Callable[[ca.SX, ca.SX], ca.SX]


@dataclass
class ConstrainedSystem:
    """A Lagrangian system with linear velocity constraints A(q) q_dot = 0.

    T: kinetic energy as a function of (q, q_dot); V: potential energy of q;
    A: constraint matrix (m x n) of q; Q_nc: generalised non-conservative force
    as a function of (q, q_dot), or None.
    """

    q: ca.SX
    T: EnergyFn
    V: ca.SX
    A: ca.SX
    Q_nc: EnergyFn | None = None

    @property
    def n(self) -> int:
        return self.q.numel()

    def _terms(self, qd: ca.SX):
        """Mass matrix, velocity terms c and generalised force Q at (q, qd)."""
        T = self.T(self.q, qd)
        p = ca.gradient(T, qd)
        M = ca.jacobian(p, qd)
        c = ca.mtimes(ca.jacobian(p, self.q), qd) - ca.gradient(T, self.q)
        Q = -ca.gradient(self.V, self.q)
        if self.Q_nc is not None:
            Q = Q + self.Q_nc(self.q, qd)
        return M, c, Q

    def null_space(self, dependent: list[int]) -> ca.SX:
        """S(q) with A S = 0, from A = [A_d A_i] split by the dependent coordinates.

        q_dot_d = -A_d^-1 A_i q_dot_i, so S stacks -A_d^-1 A_i over the identity
        (rows permuted back to the order of q).
        """
        n, m = self.n, self.A.size1()
        if len(dependent) != m:
            raise ValueError(f"need {m} dependent coordinates, got {len(dependent)}")
        independent = [i for i in range(n) if i not in dependent]
        A_d = self.A[:, dependent]
        A_i = self.A[:, independent]
        B = -ca.solve(A_d, A_i)
        S = ca.SX.zeros(n, len(independent))
        for row, i in enumerate(dependent):
            S[i, :] = B[row, :]
        for col, i in enumerate(independent):
            S[i, col] = 1
        return ca.simplify(S)

    def reduced(self, S: ca.SX, v: ca.SX) -> "ReducedForm":
        """Kane-Maggi equations in the independent speeds v, q_dot = S(q) v."""
        qd_sym = ca.SX.sym("qd", self.n)
        M, c, Q = self._terms(qd_sym)
        qd = ca.mtimes(S, v)
        M, c, Q = ca.substitute([M, c, Q], [qd_sym], [qd])
        S_dot_v = ca.jtimes(qd, self.q, qd)  # d(S v)/dq q_dot with v held fixed
        M_r = ca.mtimes([S.T, M, S])
        f_r = ca.mtimes(S.T, Q - c - ca.mtimes(M, S_dot_v))
        return ReducedForm(S=S, v=v, q_dot=qd, M_r=M_r, f_r=f_r,
                           energy=self.T(self.q, qd) + self.V)

    def multipliers(self, qd: ca.SX, k_stab: ca.SX | float = 0.0) -> "MultiplierForm":
        """KKT system of eq. (6) with velocity-level constraint stabilisation."""
        M, c, Q = self._terms(qd)
        A = self.A
        m = A.size1()
        A_dot_qd = ca.jtimes(ca.mtimes(A, qd), self.q, qd)
        K = ca.vertcat(ca.horzcat(M, -A.T), ca.horzcat(A, ca.SX.zeros(m, m)))
        rhs = ca.vertcat(Q - c, -A_dot_qd - k_stab * ca.mtimes(A, qd))
        sol = ca.solve(K, rhs)
        return MultiplierForm(q_ddot=sol[: self.n], lam=sol[self.n:],
                              violation=ca.mtimes(A, qd),
                              energy=self.T(self.q, qd) + self.V)


@dataclass
class ReducedForm:
    """v_dot = M_r^-1 f_r; q_dot = S v."""

    S: ca.SX
    v: ca.SX
    q_dot: ca.SX
    M_r: ca.SX
    f_r: ca.SX
    energy: ca.SX

    def v_dot(self) -> ca.SX:
        return ca.solve(self.M_r, self.f_r)


@dataclass
class MultiplierForm:
    """q_ddot and the multipliers lambda (generalised constraint forces)."""

    q_ddot: ca.SX
    lam: ca.SX
    violation: ca.SX
    energy: ca.SX
