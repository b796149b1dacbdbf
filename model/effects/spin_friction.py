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

import casadi as ca

from model.context import WheelContext
from model.effects.base import Effect
from model.effects.rolling_resistance import LAWS, smoothing_conflict
from model.spec import Quantity


class SpinFriction(Effect):
    name = "spin_friction"
    uses_normal_load = True
    summary = "torque about the contact normal opposing the pivot rate alpha_dot + gamma_dot cos(beta), with stiction"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [
            Quantity("c_pivot", "m", "pivot friction: coefficient x contact-patch radius", 1e-3, minimum=0.0),
            Quantity("d_pivot", "N.m.s", "viscous pivot friction", 0.0, minimum=0.0),
            Quantity("pivot_omega_eps", "rad/s", "law smoothed: pivot rate below which the Coulomb part fades (tanh)",
                     0.01, minimum=1e-9),
        ]

    @classmethod
    def choices(cls) -> dict[str, tuple[str, ...]]:
        return {"law": LAWS}

    @classmethod
    def option_conflict(cls, options: dict) -> tuple[str, str] | None:
        return smoothing_conflict(options, "pivot_omega_eps")

    def apply(self, ctx: WheelContext) -> None:
        law = self.choice("law")
        if law == "stiction":
            self.options["_no_pivot_omega_eps"] = True
        p = self.declare(ctx)
        w_k = ctx.kin.omega[2]
        limit = p["c_pivot"] * ctx.Fn
        if law == "smoothed":
            coulomb = -limit * ca.tanh(w_k / p["pivot_omega_eps"])
        else:
            coulomb = ctx.stiction("pivot", w_k, limit, "pivot friction").force
        tau = coulomb - p["d_pivot"] * w_k
        ctx.force(tau, w_k, "dissipative")
        ctx.output(Quantity("pivot_torque", "N.m",
                            "spin-friction torque about the contact normal (the holding torque while stuck)"), tau)
