"""Spin (pivot) friction: a torque opposing rotation about the contact normal.

tau = -(c_pivot F_n tanh(w_k / omega_eps) + d_pivot w_k), w_k = omega . k =
alpha_dot + gamma_dot cos(beta). c_pivot is the friction coefficient times the
effective radius of the contact patch (m); d_pivot an optional viscous part.
"""
from __future__ import annotations

from model.context import WheelContext
from model.effects.base import Effect
from model.spec import Quantity


class SpinFriction(Effect):
    name = "spin_friction"
    uses_normal_load = True
    summary = "torque about the contact normal opposing the pivot rate alpha_dot + gamma_dot cos(beta)"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [
            Quantity("c_pivot", "m", "pivot friction: coefficient x contact-patch radius", 1e-3, minimum=0.0),
            Quantity("d_pivot", "N.m.s", "viscous pivot friction", 0.0, minimum=0.0),
            Quantity("pivot_omega_eps", "rad/s", "pivot rate below which the Coulomb part fades (tanh)", 0.01,
                     minimum=1e-9),
        ]

    def apply(self, ctx: WheelContext) -> None:
        import casadi as ca
        p = self.declare(ctx)
        w_k = ctx.kin.omega[2]
        tau = -(p["c_pivot"] * ctx.Fn * ca.tanh(w_k / p["pivot_omega_eps"]) + p["d_pivot"] * w_k)
        ctx.force(tau, w_k, "dissipative")
        ctx.output(Quantity("pivot_torque", "N.m", "spin-friction torque about the contact normal"), tau)
