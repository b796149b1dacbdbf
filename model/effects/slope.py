"""Inclined ground: the plane the wheel rolls on is tilted by slope_angle.

The model's frame stays attached to the ground plane (x, y in the plane, z along its
normal), so tilting the ground is tilting gravity: g = g (sin th cos psi, sin th sin psi,
-cos th), th = slope_angle, psi = slope_direction (the downhill direction in the plane,
0 = +x). Straight upright rolling downhill then accelerates at g sin th / (1 + k_axial).
"""
from __future__ import annotations

import casadi as ca

from gyrowheel.model.context import WheelContext
from gyrowheel.model.effects.base import Effect
from gyrowheel.model.spec import Quantity


class Slope(Effect):
    name = "slope"
    summary = "ground inclined by slope_angle, downhill along slope_direction"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [
            Quantity("slope_angle", "rad", "inclination of the ground", 0.1, display_unit="deg",
                     minimum=-1.5, maximum=1.5),
            Quantity("slope_direction", "rad", "downhill direction in the ground plane (0: +x)", 0.0,
                     display_unit="deg"),
        ]

    def apply(self, ctx: WheelContext) -> None:
        if ctx.gravity is None:
            raise ValueError("effect 'slope' needs effect 'gravity'")
        p = self.declare(ctx)
        th, psi = p["slope_angle"], p["slope_direction"]
        g = -ctx.gravity[2]
        ctx.gravity = g * ca.vertcat(ca.sin(th) * ca.cos(psi), ca.sin(th) * ca.sin(psi), -ca.cos(th))
