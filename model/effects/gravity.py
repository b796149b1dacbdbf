"""Uniform gravity: potential -sum(m g . r) over all bodies (eq. 23 for the wheel alone).

The field is stored as a ground-frame vector (0, 0, -g) so the slope effect can tilt it.
"""
from __future__ import annotations

import casadi as ca

from gyrowheel.model.context import WheelContext
from gyrowheel.model.effects.base import Effect
from gyrowheel.model.spec import GRAVITY_RANGE, Quantity

PRESETS = {"earth": 9.81, "mars": 3.721, "moon": 1.625}


class Gravity(Effect):
    name = "gravity"
    summary = "uniform gravitational field g along -z (presets earth, mars, moon)"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [Quantity("g", "m/s2", "gravitational acceleration", 9.81,
                         minimum=GRAVITY_RANGE[0], maximum=GRAVITY_RANGE[1])]

    @classmethod
    def presets(cls) -> dict[str, dict[str, float]]:
        return {"g": dict(PRESETS)}

    def apply(self, ctx: WheelContext) -> None:
        g = self.declare(ctx)["g"]
        ctx.gravity = ca.vertcat(0, 0, -g)
