"""The flight mode's equations for everything the wheel model holds: the free wheel plus the bodies,
coordinates and internal forces effects add (the Gyrover's pendulum assembly, its flywheel, the
tilt servo and the drive), derived from one Lagrangian with the centre's height free.

The wheel shell is model/flight.py's free body (free_energies: T, V = -M g . r, the surroundings'
laws such as air drag). Every other body an effect registers (WheelContext.bodies[1:], with its
share of WheelContext.kinetic[1:]) is written in the contact's kinematics, where the centre is
(x, y, R sin(beta)). Its position is the centre plus an offset d that depends on the angles and
the effect's own coordinates only (the Gyrover's L_pend l_p), so its kinetic energy in flight is

    T_b(flight) = T_b(contact) - m_b |v_b(contact)|^2 / 2 + m_b |v_c + d_dot|^2 / 2,

v_c = (x_dot, y_dot, z_dot) the free centre's velocity (its rotational energy depends on angles
and rates only), and its potential -m_b g . (r_c + d). The coordinates: x, y, z, the wheel's
angles, the effects' free coordinates (theta_p) and their driven ones (tilt, flywheel: rate and
acceleration prescribed, their torques the motors' generalised forces). Forces: the actuators' own
(kind "actuator": the drive, between wheel and assembly; internal, so they change no total
momentum) and the free laws of the shell; the contact's laws (rolling resistance, pivot friction)
act through F_n = 0 in flight, nothing.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from gyrowheel.model.context import WheelContext
from gyrowheel.model.flight import free_energies
from gyrowheel.model.lagrangian import ConstrainedSystem


@dataclass
class FreeSystem:
    """The flight equations in placeholders: coordinates q (n,) = (x, y, z, alpha, beta, gamma,
    the effects' free coordinates, their driven ones), speeds qd (n,); n_free free ones first."""

    q: ca.SX
    qd: ca.SX
    n_free: int
    qdd: ca.SX  # accelerations of every coordinate (n,), in q, qd (the driven rates substituted)
    T: ca.SX
    V: ca.SX
    P_diss: ca.SX  # power the shell's laws take out (>= 0), W
    P_act: ca.SX  # power the actuators deliver (drive, and the driven coordinates' motors), W
    tau_driven: ca.SX  # the driven coordinates' motor torques (generalised forces)
    z: ca.SX  # the placeholders added for the centre's height and its rate
    z_dot: ca.SX


def free_system(ctx: WheelContext) -> FreeSystem:
    """The flight equations of everything in ctx (module docstring). Raises ValueError for an
    actuator force on the centre's velocity (it has no flight form)."""
    P, c = ctx.par, ctx.coords
    free = [k for k in c if k.free]
    driven = [k for k in c if not k.free]
    z, z_dot = ca.SX.sym("z_free"), ca.SX.sym("z_free_dot")
    z_ddot = ca.SX.sym("z_free_ddot")
    q6 = ca.vertcat(c[0].q, c[1].q, z, c[2].q, c[3].q, c[4].q)
    qd6 = ca.vertcat(c[0].qd, c[1].qd, z_dot, c[2].qd, c[3].qd, c[4].qd)
    gravity = ctx.gravity if ctx.gravity is not None else ca.SX.zeros(3)
    q = ca.vertcat(q6, *[k.q for k in free[5:]], *[k.q for k in driven])
    qd = ca.vertcat(qd6, *[k.qd for k in free[5:]], *[k.qd for k in driven])
    qdd = ca.vertcat(c[0].qdd, c[1].qdd, z_ddot, c[2].qdd, c[3].qdd, c[4].qdd, *[k.qdd for k in free[5:]],
                     *[k.qdd for k in driven])
    shell = free_energies(q6, qd6, P["M"], P["R"], P["k_diam"], P["k_axial"], gravity, ctx.free_laws)
    T, V = shell.T + sum(ctx.kinetic[1:], ca.SX(0)), shell.V
    q_ctx, qd_ctx = ctx.all_q(), ctx.all_qd()
    xy = ca.vertcat(c[0].q, c[1].q)
    for body in ctx.bodies[1:]:
        # the offset from the centre; rigid with the wheel's assembly, so x and y cancel in it: set
        # them to 0 to leave no rounding of (x + d_x) - x
        d = ca.substitute(body.position - ctx.kin.centre, xy, ca.SX.zeros(2))
        v_contact = ca.jtimes(body.position, q_ctx, qd_ctx)
        v_free = qd6[0:3] + ca.jtimes(d, q_ctx, qd_ctx)
        T = T + 0.5 * body.mass * (ca.dot(v_free, v_free) - ca.dot(v_contact, v_contact))
        V = V - body.mass * ca.dot(gravity, q6[0:3] + d)
    Q = ca.vertcat(shell.Q, ca.SX.zeros(qd.numel() - 6))
    act = ca.SX(0)
    for f in ctx.forces:
        if f.kind != "actuator":
            continue
        if ca.depends_on(ca.vec(f.velocity), ca.vertcat(c[0].qd, c[1].qd)):
            raise ValueError(f"an actuator force on the centre's velocity has no flight form: {f.velocity}")
        Q = Q + ca.mtimes(ca.jacobian(f.velocity, qd).T, f.value)
        act = act + ca.dot(ca.vec(f.value), ca.vec(f.velocity))
    nf = 6 + len(free) - 5
    system = ConstrainedSystem(q=q, qd=qd, qdd=qdd, n_free=nf, T=T, V=V, A=ca.SX(0, nf), Q_nc=Q,
                               parameters=list(P))
    qd_driven = ca.vertcat(*[k.rate for k in driven]) if driven else ca.SX(0, 1)
    qdd_driven = ca.vertcat(*[k.accel for k in driven]) if driven else ca.SX(0, 1)
    _, qdd_sol, _, _ = system.reduced(ca.SX.eye(nf), qd[:nf], ca.SX.sym("v_dot", nf), qd_driven, qdd_driven)
    tau = system.driven_forces() if driven else ca.SX(0, 1)
    tau = ca.substitute(ca.substitute(tau, qdd, qdd_sol), qd[nf:], qd_driven) if driven else tau
    P_act = act + (ca.dot(tau, qd[nf:]) if driven else 0)
    sub = (lambda e: ca.substitute(e, qd[nf:], qd_driven)) if driven else (lambda e: e)
    return FreeSystem(q=q, qd=qd, n_free=nf, qdd=qdd_sol, T=sub(T), V=V, P_diss=-shell.power, P_act=sub(P_act),
                      tau_driven=tau, z=z, z_dot=z_dot)
