"""Rolling resistance: a torque about the axle opposing rolling, proportional to the load.

tau = -c_rr R F_n tanh(w_z / omega_eps), w_z = omega . n = gamma_dot + alpha_dot cos(beta)
the rolling rate (centre speed / R). F_n is the normal contact force, solved together
with the accelerations (it depends on them). tanh regularises the sign of Coulomb-like
resistance below omega_eps, so a wheel at rest is not forced to chatter.
"""
from __future__ import annotations

import casadi as ca

from model.context import WheelContext
from model.effects.base import Effect
from model.spec import Quantity


class RollingResistance(Effect):
    name = "rolling_resistance"
    summary = "torque -c_rr R F_n sign(rolling rate) about the axle"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [
            Quantity("c_rr", "1", "rolling-resistance coefficient (force / normal load)", 0.01, minimum=0.0),
            Quantity("rr_omega_eps", "rad/s", "rolling rate below which the resistance fades (tanh)", 0.01,
                     minimum=1e-9),
        ]

    def apply(self, ctx: WheelContext) -> None:
        p = self.declare(ctx)
        w_z = ca.dot(ctx.kin.omega, ctx.kin.n)
        tau = -p["c_rr"] * ctx.par["R"] * ctx.Fn * ca.tanh(w_z / p["rr_omega_eps"])
        ctx.force(tau, w_z, "dissipative")
        ctx.output(Quantity("rolling_resistance_torque", "N.m", "rolling-resistance torque about the axle"), tau)
