"""Spin (pivot) friction: a torque opposing rotation about the contact normal.

tau = -(c_pivot F_n sign(w_k) + d_pivot w_k), w_k = omega . k = alpha_dot + gamma_dot cos(beta).
c_pivot is the friction coefficient times the effective radius of the contact patch (m); d_pivot an
optional viscous part. The Coulomb part follows the scene key `law`:
- "stiction" (default): true stiction (model/stiction.py): when w_k reaches 0 and the torque
  needed to hold the pivot is within c_pivot F_n, the pivot sticks (w_k = 0, the holding torque
  solved with the accelerations) until that torque exceeds the limit;
- "smoothed": c_pivot F_n tanh(w_k / pivot_omega_eps), viscous below pivot_omega_eps (never sticks).
"""
from __future__ import annotations

from gyrowheel.model.context import WheelContext
from gyrowheel.model.effects.coulomb import CoulombLaw
from gyrowheel.model.spec import COEFFICIENT_MAX, Quantity


class SpinFriction(CoulombLaw):
    name = "spin_friction"
    uses_normal_load = True
    smoothing = "pivot_omega_eps"
    summary = "torque about the contact normal opposing the pivot rate alpha_dot + gamma_dot cos(beta), with stiction"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [
            Quantity("c_pivot", "m", "pivot friction: coefficient x contact-patch radius", 1e-3, minimum=0.0,
                     maximum=COEFFICIENT_MAX),
            Quantity("d_pivot", "N.m.s", "viscous pivot friction", 0.0, minimum=0.0, maximum=COEFFICIENT_MAX),
            Quantity("pivot_omega_eps", "rad/s", "law smoothed: pivot rate below which the Coulomb part fades (tanh)",
                     0.01, minimum=1e-9),
        ]

    def apply(self, ctx: WheelContext) -> None:
        p = self.declare(ctx)
        w_k = ctx.kin.omega[2]
        tau = self.coulomb(ctx, p, "pivot", w_k, p["c_pivot"] * ctx.Fn, "pivot friction") - p["d_pivot"] * w_k
        ctx.force(tau, w_k, "dissipative")
        ctx.output(Quantity("pivot_torque", "N.m",
                            "spin-friction torque about the contact normal (the holding torque while stuck)"), tau)
