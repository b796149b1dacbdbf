"""Rolling resistance: energy lost per metre of rim rolled over the ground, proportional to the load.

The rim advances over the ground at the rate gamma_dot (the spin relative to the
frame {l, m, n} whose l points at the contact): the contact point moves R gamma_dot
along the rim. The resistance dissipates c_rr F_n per metre rolled, so its power is
-c_rr F_n R |gamma_dot| and its generalised force acts on gamma:
    Q_gamma = -c_rr R F_n tanh(gamma_dot / rr_omega_eps).
In straight rolling this is the familiar force c_rr F_n at the contact (torque c_rr R F_n).
A couple about the axle would instead act on omega . n = gamma_dot + alpha_dot cos(beta),
which vanishes for a wheel spinning on a fixed centre (Euler's disk) although its rim rolls.
F_n is solved together with the accelerations (it depends on them); tanh regularises the
Coulomb-like sign below rr_omega_eps so a wheel at rest is not forced to chatter.
"""
from __future__ import annotations

import casadi as ca

from model.context import WheelContext
from model.effects.base import Effect
from model.spec import Quantity


class RollingResistance(Effect):
    name = "rolling_resistance"
    uses_normal_load = True
    summary = "resistance c_rr F_n to the rolling of the rim (power -c_rr F_n R |gamma_dot|)"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [
            Quantity("c_rr", "1", "rolling-resistance coefficient (force / normal load)", 0.01, minimum=0.0),
            Quantity("rr_omega_eps", "rad/s", "rolling rate below which the resistance fades (tanh)", 0.01,
                     minimum=1e-9),
        ]

    def apply(self, ctx: WheelContext) -> None:
        p = self.declare(ctx)
        gamma_dot = ctx.qd[4]
        tau = -p["c_rr"] * ctx.par["R"] * ctx.Fn * ca.tanh(gamma_dot / p["rr_omega_eps"])
        ctx.force(tau, gamma_dot, "dissipative")
        ctx.output(Quantity("rolling_resistance_torque", "N.m",
                            "generalised force on the spin coordinate gamma (N.m per rad), not a torque about an axis"),
                   tau)
