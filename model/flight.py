"""The wheel in flight: a free rigid body of revolution under gravity, derived by CasADi.

The flight mode of the contact modes: no contact, six degrees of freedom. Coordinates
q = (x, y, z, alpha, beta, gamma): the centre, and the paper's Euler angles (heading alpha, lean
beta with pi/2 upright, spin gamma; docs/model.md). The kinetic energy is the rolling wheel's
(eq. 22, general inertia) with the centre's height z free instead of R sin(beta):

    T = M |r_dot|^2 / 2 + omega_lmn^T diag(I_diam, I_diam, I_axial) omega_lmn / 2,   V = -M g . r,

(g the ground-frame gravity vector: (0, 0, -g) on level ground, V = M g z; tilted on a slope, the
frame staying attached to the ground plane, so the height above the plane is still z),
and the equations of motion come from the same Lagrangian machinery as the rolling and sliding
modes (model/lagrangian.py, ConstrainedSystem with no constraint rows: the null space is the
identity), with the generalised forces of the surroundings' laws that act on a free body (air
drag: free_energies' laws). The lowest point of the rim lies R sin(beta) below the centre (the rim's circle tilted
by beta), so the height above the ground is h = z - R sin(beta): touchdown is h reaching 0 moving
down. The Euler angles are singular where the axle is vertical (sin(beta) = 0), as in rolling
(docs/model.md): a wheel turning flat in the air ends the description there.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from gyrowheel.model.kinematics import frame_chain
from gyrowheel.model.lagrangian import ConstrainedSystem

COORDINATES = ("x", "y", "z", "alpha", "beta", "gamma")


@dataclass
class FlightEquations:
    """Symbols and expressions of the free wheel (shapes: q, qd, qdd (6,); the rest 3-vectors or
    scalars). p = (M, R, k_diam, k_axial, g): kg, m, 1, 1, m/s^2."""

    q: ca.SX
    qd: ca.SX
    p: ca.SX
    qdd: ca.SX  # accelerations (m/s^2, rad/s^2), expressions of (q, qd, p)
    energy: ca.SX  # T + V, J
    momentum: ca.SX  # angular momentum about the centre, ground frame, kg m^2/s
    axle: ca.SX  # n, the unit axle vector, ground frame
    omega: ca.SX  # angular velocity, ground frame, rad/s
    height: ca.SX  # of the rim's lowest point above the ground, m

    def function(self) -> ca.Function:
        """f(q, qd, p) -> (qdd, energy, momentum, axle, omega, height)."""
        return ca.Function("flight", [self.q, self.qd, self.p],
                           [self.qdd, self.energy, self.momentum, self.axle, self.omega, self.height],
                           ["q", "qd", "p"], ["qdd", "energy", "L", "n", "omega", "height"])


@dataclass
class FreeEnergies:
    """The free wheel's energies and forces in given placeholders (see free_energies)."""

    T: ca.SX  # kinetic energy, J
    V: ca.SX  # potential energy, J
    Q: ca.SX  # generalised forces of the laws on (q, qd) (6,)
    power: ca.SX  # their power, W (negative for drag)
    momentum: ca.SX  # angular momentum about the centre, ground frame (3,)
    axle: ca.SX  # n (3,)
    omega: ca.SX  # angular velocity, ground frame (3,)
    height: ca.SX  # of the rim's lowest point above the plane z = 0, m


def free_energies(q: ca.SX, qd: ca.SX, M, R, k_diam, k_axial, gravity: ca.SX, laws=()) -> FreeEnergies:
    """The free wheel in the placeholders q = (x, y, z, alpha, beta, gamma), qd (6,): T as in the
    module docstring, V = -M gravity . (x, y, z) (gravity: the ground-frame vector (3,), m/s^2;
    (0, 0, -g) on level ground, tilted on a slope: the frame's z stays normal to the ground plane),
    and the generalised forces of `laws`: each a callable (v_centre (3,), omega (3,), n (3,)) ->
    [(value, velocity)], a force on the centre's velocity or a torque on an angular rate (both in
    the ground frame), Q = sum (d velocity / d qd)^T value, power sum value . velocity."""
    alpha, beta = q[3], q[4]
    chain = frame_chain(alpha, beta)
    lmn = chain.matrix()
    _, omega_frame_lmn = chain.angular_velocity(q, qd)
    omega_lmn = omega_frame_lmn + ca.vertcat(0, 0, qd[5])  # the spin about n relative to the frame
    inertia = ca.diag(ca.vertcat(k_diam, k_diam, k_axial)) * M * R ** 2
    r_dot = qd[0:3]
    T = 0.5 * M * ca.dot(r_dot, r_dot) + 0.5 * ca.mtimes([omega_lmn.T, inertia, omega_lmn])
    V = -M * ca.dot(gravity, q[0:3])
    omega, n = ca.mtimes(lmn, omega_lmn), lmn[:, 2]
    Q, power = ca.SX.zeros(qd.numel()), ca.SX(0)
    for law in laws:
        for value, velocity in law(r_dot, omega, n):
            Q = Q + ca.mtimes(ca.jacobian(velocity, qd).T, value)
            power = power + ca.dot(ca.vec(value), ca.vec(velocity))
    return FreeEnergies(T=T, V=V, Q=Q, power=power, momentum=ca.mtimes(lmn, ca.mtimes(inertia, omega_lmn)),
                        axle=n, omega=omega, height=q[2] - R * ca.sin(beta))


def flight_equations() -> FlightEquations:
    """The free wheel's equations of motion under vertical gravity (module docstring); derived,
    never typed in."""
    q = ca.SX.sym("q", 6)
    qd = ca.SX.sym("qd", 6)
    M, R, k_diam, k_axial, g = (ca.SX.sym(n) for n in ("M", "R", "k_diam", "k_axial", "g"))
    e = free_energies(q, qd, M, R, k_diam, k_axial, ca.vertcat(0, 0, -g))
    system = ConstrainedSystem(q=q, qd=qd, qdd=ca.SX.sym("qdd", 6), n_free=6, T=e.T, V=e.V, A=ca.SX(0, 6),
                               parameters=["M", "R", "k_diam", "k_axial", "g"])  # no constraint rows
    _, qdd, _, _ = system.reduced(ca.SX.eye(6), qd, ca.SX.sym("v_dot", 6), ca.SX(0, 1), ca.SX(0, 1))
    return FlightEquations(
        q=q, qd=qd, p=ca.vertcat(M, R, k_diam, k_axial, g), qdd=qdd, energy=e.T + e.V,
        momentum=e.momentum, axle=e.axle, omega=e.omega, height=e.height)
