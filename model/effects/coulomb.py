"""The Coulomb part of a friction-like effect, with the scene key `law` (docs/effects.md, "Stiction").

- "stiction" (default): true stiction (model/stiction.py, WheelContext.stiction): -L sign(r) while
  the rate r slides, a holding force within L while it is stuck.
- "smoothed": -L tanh(r / eps), eps the effect's smoothing parameter: no events, but it never
  sticks (it acts like a viscous term below eps).
"""
from __future__ import annotations

import casadi as ca

from gyrowheel.model.context import WheelContext
from gyrowheel.model.effects.base import Effect

LAWS = ("stiction", "smoothed")


class CoulombLaw(Effect):
    """An effect whose Coulomb part follows `law`; `smoothing` names the smoothed law's parameter."""

    smoothing: str = ""

    @classmethod
    def choices(cls) -> dict[str, tuple[str, ...]]:
        return {"law": LAWS}

    @classmethod
    def option_conflict(cls, options: dict) -> tuple[str, str] | None:
        """The smoothing parameter given with the stiction law: refused rather than ignored."""
        if options.get("law", LAWS[0]) == "stiction" and cls.smoothing in options:
            return cls.smoothing, ('belongs to law = "smoothed" (the tanh regularisation); law = "stiction" (the '
                                   'default) sticks exactly and has no such parameter: remove it or set law = "smoothed"')
        return None

    def declare(self, ctx: WheelContext) -> dict:
        """Effect.declare, without the smoothing parameter under the stiction law."""
        if self.choice("law") == "stiction":
            self.options["_no_" + self.smoothing] = True
        return super().declare(ctx)

    def coulomb(self, ctx: WheelContext, p: dict, name: str, rate: ca.SX, limit: ca.SX, what: str) -> ca.SX:
        """The Coulomb force on `rate` with the limit L = `limit` >= 0 under the chosen law; with
        stiction, `name` names the mode (`<name>_mode`) and the event (`<name>_stiction`)."""
        if self.choice("law") == "smoothed":
            return -limit * ca.tanh(rate / p[self.smoothing])
        return ctx.stiction(name, rate, limit, what).force
