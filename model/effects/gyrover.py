"""Gyrover actuation: the internal pendulum-mounted flywheel, its tilt servo and the drive.

Bodies in the same Lagrangian as the wheel (Xu & Ou, "Control of Single Wheel Robots",
derived here from first principles):
- The internal assembly hangs from the axle and swings about it: coordinate theta_p (free),
  the angle in the wheel plane from l (towards the contact point) towards m. Its mass m_fly
  (flywheel plus gimbal) sits at distance L_pend from the centre along
  l_p = cos(theta_p) l + sin(theta_p) m.
- The flywheel is tilted relative to the assembly by the angle `tilt`, Xu & Ou's beta_a
  (Table 2.1: the angle between the link and the flywheel's spin axis is pi/2 - tilt): the tilt
  joint's axis m_p = -sin(theta_p) l + cos(theta_p) m is normal to the link l_p and to the axle
  n, and the spin axis a = cos(tilt) n + sin(tilt) l_p turns from the axle towards the link, so
  that at theta_p = 0 the flywheel leans by beta + tilt. The tilt is driven: a servo with
  natural frequency tilt_omega and damping tilt_zeta follows the FMI input tilt_cmd. The
  flywheel spins about a at the constant rate flywheel_rate (driven: the spin motor holds it).
  Its inertia: I_fly_axial about a, I_fly_diam about diameters. A tilt rate turns the
  flywheel's momentum out of the horizontal: its reaction on the wheel is a torque about the
  vertical, which is how the Gyrover steers (docs/effects.md).
- The drive motor applies drive_torque (FMI input) between wheel and assembly about the
  axle: power drive_torque (theta_p_dot - gamma_dot).
Driven coordinates give no equation of their own; the torques the tilt and spin motors
must supply to the flywheel (about +m_p and +a) come out as outputs (tilt_torque,
flywheel_torque) and count as actuator work.
M stays the mass of the wheel shell; the assembly adds m_fly.
"""
from __future__ import annotations

import casadi as ca

from gyrowheel.model.context import Body, WheelContext
from gyrowheel.model.effects.base import Effect
from gyrowheel.model.spec import Quantity


class Gyrover(Effect):
    name = "gyrover"
    summary = "internal flywheel with tilt servo (input tilt_cmd) and pendulum drive (input drive_torque)"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [
            Quantity("m_fly", "kg", "mass of the internal assembly (flywheel + gimbal)", 0.4, minimum=0.0),
            Quantity("L_pend", "m", "distance of the assembly's centre of mass below the axle", 0.03, minimum=0.0),
            Quantity("I_fly_axial", "kg.m2", "flywheel inertia about its spin axis", 5e-4, minimum=0.0),
            Quantity("I_fly_diam", "kg.m2", "flywheel inertia about a diameter", 2.5e-4, minimum=0.0),
            Quantity("flywheel_rate", "rad/s", "flywheel spin rate held by the spin motor", 400.0,
                     display_unit="rpm"),
            Quantity("tilt_omega", "rad/s", "natural frequency of the tilt servo", 20.0, minimum=1e-3),
            Quantity("tilt_zeta", "1", "damping ratio of the tilt servo", 1.0, minimum=0.0),
        ]

    @classmethod
    def starts(cls) -> list[Quantity]:
        return [
            Quantity("theta_p", "rad", "swing of the internal assembly about the axle", 0.0, display_unit="deg"),
            Quantity("theta_p_dot", "rad/s", "swing rate of the internal assembly", 0.0),
            Quantity("tilt", "rad", "flywheel tilt angle", 0.0, display_unit="deg"),
            Quantity("tilt_rate", "rad/s", "flywheel tilt rate", 0.0),
        ]

    def apply(self, ctx: WheelContext) -> None:
        p = self.declare(ctx)
        kin = ctx.kin
        l, m, n = kin.l, kin.m, kin.n
        tilt_cmd = ctx.input(Quantity("tilt_cmd", "rad", "commanded flywheel tilt angle", 0.0, display_unit="deg"))
        drive = ctx.input(Quantity("drive_torque", "N.m", "drive-motor torque on the wheel's assembly", 0.0))

        tilt = ctx.state(self.start_quantity("tilt"))
        tilt_rate = ctx.state(self.start_quantity("tilt_rate"))
        w, z = p["tilt_omega"], p["tilt_zeta"]
        tilt_acc = w**2 * (tilt_cmd - tilt.sym) - 2 * z * w * tilt_rate.sym
        tilt.derivative, tilt_rate.derivative = tilt_rate.sym, tilt_acc

        pend = ctx.coordinate("theta_p", free=True, start=self.start_quantity("theta_p"),
                              rate_start=self.start_quantity("theta_p_dot"))
        tc = ctx.coordinate("tilt", free=False, rate=tilt_rate.sym, accel=tilt_acc, value=tilt.sym)
        spin = ctx.coordinate("flywheel", free=False, rate=p["flywheel_rate"], accel=ca.SX(0))

        th = pend.q
        l_p = ca.cos(th) * l + ca.sin(th) * m
        m_p = -ca.sin(th) * l + ca.cos(th) * m
        # the tilt joint turns the spin axis about m_p (normal to the link l_p and to the axle n)
        # from the axle towards the link: at theta_p = 0 the flywheel leans by beta + tilt
        axis = ca.cos(tc.q) * n + ca.sin(tc.q) * l_p
        q_all, qd_all = ctx.all_q(), ctx.all_qd()
        omega_frame = kin.omega_frame  # the {l, m, n} frame (no spin)
        omega_fly = omega_frame + pend.qd * n + tc.qd * m_p + spin.qd * axis
        r_fly = kin.centre + p["L_pend"] * l_p
        v_fly = ca.jtimes(r_fly, q_all, qd_all)
        w_a = ca.dot(omega_fly, axis)
        ctx.kinetic.append(0.5 * p["m_fly"] * ca.dot(v_fly, v_fly)
                           + 0.5 * p["I_fly_diam"] * (ca.dot(omega_fly, omega_fly) - w_a**2)
                           + 0.5 * p["I_fly_axial"] * w_a**2)
        ctx.bodies.append(Body(p["m_fly"], r_fly))
        ctx.force(drive, pend.qd - ctx.coords[4].qd, "actuator")
        ctx.output(Quantity("flywheel_momentum", "N.m.s", "flywheel angular momentum about its axis"),
                   p["I_fly_axial"] * w_a)
