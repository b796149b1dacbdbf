"""Kinematics of a rigid disc-like wheel on flat ground (paper section 2).

Coordinates q = (x, y, alpha, beta, gamma): centre position on the ground plane,
precession (heading), lean (pi/2 upright) and spin. The frame {l, m, n} of
eqs. (9)-(11) is built from elementary rotations, the wheel's attitude adds the
spin about n; angular velocity comes from R_dot R^T, not from eq. (12) (the
tests check that the two agree).
"""
from __future__ import annotations

import casadi as ca


def rot_x(a):
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


def rot_z(a):
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def frame_lmn(alpha, beta):
    """Columns l, m, n of eqs. (9)-(11) in ground coordinates.

    Upright with alpha = 0 the frame is l = -k (towards the contact point),
    m = -i, n = +j (the axle); lean turns it about m by pi/2 - beta, heading
    about k by alpha.
    """
    upright = ca.SX([[0, -1, 0], [0, 0, 1], [-1, 0, 0]])
    return ca.mtimes([rot_z(alpha), rot_x(ca.pi / 2 - beta), upright])


def angular_velocity(R_body, q, qd):
    """Angular velocity in ground coordinates from skew(w) = R_dot R^T."""
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
        self.lmn = frame_lmn(alpha, beta)
        self.l, self.m, self.n = self.lmn[:, 0], self.lmn[:, 1], self.lmn[:, 2]
        self.body = ca.mtimes(self.lmn, rot_z(gamma))
        # composition of rotations: frame {l,m,n} turns with omega_frame, the wheel spins
        # about n relative to it (the same as angular_velocity(self.body, ...) but free of
        # sin^2 + cos^2 terms in gamma that CasADi cannot cancel)
        self.omega_frame = angular_velocity(self.lmn, q, qd)
        self.omega = self.omega_frame + qd[4] * self.n
        self.omega_lmn = ca.mtimes(self.lmn.T, self.omega)
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
