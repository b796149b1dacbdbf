"""Effects: independent physics a scene can switch on (DESIGN.md, "The model").

Each effect module defines an Effect with its parameters and an apply() that adds
terms to the shared WheelContext. The scene names the effects it wants; nothing
else enters the equations or the generated code. They are applied in the order of
CATALOGUE (gravity before slope, which tilts it; forces before the diagnostics that
sum their power), whatever the order in the scene.
"""
from __future__ import annotations

from model.effects.air_drag import AirDrag
from model.effects.base import Effect
from model.effects.contact_forces import ContactForces
from model.effects.energy import Energy
from model.effects.gravity import Gravity
from model.effects.gyrover import Gyrover
from model.effects.rolling_resistance import RollingResistance
from model.effects.slope import Slope
from model.effects.spin_friction import SpinFriction

CATALOGUE: dict[str, type[Effect]] = {e.name: e for e in (
    Gravity, Slope, Gyrover, RollingResistance, SpinFriction, AirDrag, ContactForces, Energy)}

__all__ = ["CATALOGUE", "Effect"]
