"""Uniform gravity along -z: potential M g z with z = R sin(beta) (eq. 23)."""
from __future__ import annotations

from model.context import WheelContext
from model.effects.base import Effect
from model.spec import Quantity

PRESETS = {"earth": 9.81, "mars": 3.721, "moon": 1.625}


class Gravity(Effect):
    name = "gravity"
    summary = "uniform gravitational field g along -z"

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return [Quantity("g", "m/s2", "gravitational acceleration", 9.81)]

    def apply(self, ctx: WheelContext) -> None:
        (g_q,) = (self.start(q) for q in self.parameters())
        g = ctx.parameter(g_q)
        ctx.potentials.append(ctx.par["M"] * g * ctx.kin.centre[2])
        ctx.check_true(g >= 0, "g must be >= 0")
