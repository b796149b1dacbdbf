"""Kinematics of a rigid disc-like wheel on flat ground (paper section 2).

Coordinates q = (x, y, alpha, beta, gamma): centre position on the ground plane,
precession (heading), lean (pi/2 upright) and spin. The frame {l, m, n} of
eqs. (9)-(11) is a chain of elementary rotations; angular velocities follow from the
addition theorem for chained rotations (exact, and free of the sin^2 + cos^2 terms
that differentiating the attitude matrix leaves and a symbolic tool cannot cancel).
`angular_velocity` (skew(w) = R_dot R^T) is kept as the independent check the tests use.
"""
from __future__ import annotations

import casadi as ca

AXES = {"x": ca.SX([1, 0, 0]), "y": ca.SX([0, 1, 0]), "z": ca.SX([0, 0, 1])}



def norm(v) -> ca.SX:
    """|v| (shape (n, 1) -> scalar, v's unit) with a derivative at v = 0.

    Written (v . v) / sqrt(v . v + 1e-200): the value is |v| to rounding above 1e-100 and exactly 0
    at 0; the derivative is v / |v| away from 0 and 0 at 0 (CasADi's convention for fabs there,
    sign(0) = 0), where norm_2's v / |v| is 0/0. Magnitudes that are 0 at a start (a violation of
    the rolling constraint, the drag on a wheel at rest, the tangential force of a wheel standing
    still) would otherwise make the FMU's directional derivatives NaN (docs/fmi.md)."""
    vv = ca.dot(v, v)
    return vv / ca.sqrt(vv + 1e-200)

def rot_x(a, sign: int = 1):
    """Rotation about x by sign * a (sign = -1 reuses sin(a), cos(a) instead of new trig)."""
    c, s = ca.cos(a), sign * ca.sin(a)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


def rot_z(a, sign: int = 1):
    c, s = ca.cos(a), sign * ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


ROT = {"x": rot_x, "z": rot_z}
UPRIGHT = ca.SX([[0, -1, 0], [0, 0, 1], [-1, 0, 0]])  # l = -k, m = -i, n = +j at alpha = 0, upright


class RotationChain:
    """R = R_1(theta_1) ... R_k(theta_k) C, elementary rotations about their own frame's axes
    followed by a constant matrix C; a factor (axis, angle, sign) turns by sign * angle. Angular velocity by the addition theorem:
        w_world = sum_i R_1 ... R_(i-1) e_i theta_i_dot,
        w_body  = sum_i (R_(i+1) ... R_k C)^T e_i theta_i_dot.
    """

    def __init__(self, factors: list[tuple[str, ca.SX, int]], constant: ca.SX):
        self.factors, self.constant = factors, constant
        self.matrices = [ROT[axis](angle, sign) for axis, angle, sign in factors]

    def matrix(self) -> ca.SX:
        R = ca.SX.eye(3)
        for Ri in self.matrices:
            R = ca.mtimes(R, Ri)
        return ca.mtimes(R, self.constant)

    def column(self, j: int) -> ca.SX:
        """R e_j computed as matrix-vector products (compact expressions)."""
        v = self.constant[:, j]
        for Ri in reversed(self.matrices):
            v = ca.mtimes(Ri, v)
        return v

    def angular_velocity(self, q: ca.SX, qd: ca.SX) -> tuple[ca.SX, ca.SX]:
        """(w_world, w_body) of the chain at rates qd."""
        w_world, w_body = ca.SX.zeros(3), ca.SX.zeros(3)
        for i, (axis, angle, sign) in enumerate(self.factors):
            rate = sign * ca.jtimes(angle, q, qd)
            v = AXES[axis]
            for Rj in reversed(self.matrices[:i]):
                v = ca.mtimes(Rj, v)
            w_world = w_world + v * rate
            b = AXES[axis]
            for Rj in self.matrices[i + 1:]:
                b = ca.mtimes(Rj.T, b)
            w_body = w_body + ca.mtimes(self.constant.T, b) * rate
        return w_world, w_body


# Rx(pi/2 - beta) = Rx(pi/2) Rx(-beta): the lean factor then needs only sin(beta), cos(beta)
LEAN_BASE = ca.SX([[1, 0, 0], [0, 0, -1], [0, 1, 0]])  # Rx(pi/2)


def frame_chain(alpha, beta) -> RotationChain:
    """The frame {l, m, n}: heading alpha about k, lean pi/2 - beta about m, from upright."""
    return RotationChain([("z", alpha, 1), ("x", beta, -1)], ca.mtimes(LEAN_BASE, UPRIGHT))


def frame_lmn(alpha, beta):
    """Columns l, m, n of eqs. (9)-(11) in ground coordinates."""
    return frame_chain(alpha, beta).matrix()


def angular_velocity(R_body, q, qd):
    """Angular velocity in ground coordinates from skew(w) = R_dot R^T (reference derivation)."""
    R_dot = ca.reshape(ca.jtimes(ca.vec(R_body), q, qd), 3, 3)
    W = ca.mtimes(R_dot, R_body.T)
    return ca.vertcat(W[2, 1], W[0, 2], W[1, 0])


class WheelKinematics:
    """Positions, velocities and the rolling constraint of the wheel.

    R is the rolling radius; the centre height z = R sin(beta) is the holonomic
    constraint (21) eliminated from the start.
    """

    def __init__(self, q: ca.SX, qd: ca.SX, R: ca.SX):
        self.q, self.qd, self.R = q, qd, R
        x, y, alpha, beta, gamma = (q[i] for i in range(5))
        self.alpha, self.beta, self.gamma = alpha, beta, gamma
        chain = frame_chain(alpha, beta)
        self.lmn = chain.matrix()
        self.l, self.m, self.n = chain.column(0), chain.column(1), chain.column(2)
        self.body = ca.mtimes(self.lmn, rot_z(gamma))
        # the frame turns with omega_frame; the wheel spins about n relative to it
        self.omega_frame, omega_frame_lmn = chain.angular_velocity(q, qd)
        self.omega = self.omega_frame + qd[4] * self.n
        self.omega_lmn = omega_frame_lmn + ca.vertcat(0, 0, qd[4])
        self.centre = ca.vertcat(x, y, R * ca.sin(beta))
        self.centre_velocity = ca.jtimes(self.centre, q, qd)
        self.contact = self.centre + R * self.l

    def rolling_constraint(self) -> ca.SX:
        """A(q) with A q_dot = 0: the contact point's material velocity vanishes.

        v_A = omega x (A - C) with A - C = -R l (eq. 14); only the horizontal
        rows are constraints, the vertical one is the derivative of z = R sin(beta).
        """
        slip = self.centre_velocity - ca.cross(self.omega, -self.R * self.l)
        return ca.jacobian(slip[0:2], self.qd)
