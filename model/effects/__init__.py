"""Effects: independent physics a scene can switch on (docs/effects.md, docs/architecture.md).

Each effect module defines an Effect with its parameters and an apply() that adds
terms to the shared WheelContext. The scene names the effects it wants; nothing
else enters the equations or the generated code. They are applied in the order of
CATALOGUE (gravity before slope, which tilts it; forces before the diagnostics that
sum their power), whatever the order in the scene.
"""
from __future__ import annotations

from gyrowheel.model.effects.air_drag import AirDrag
from gyrowheel.model.effects.base import Effect
from gyrowheel.model.effects.contact_forces import ContactForces
from gyrowheel.model.effects.energy import Energy
from gyrowheel.model.effects.gravity import Gravity
from gyrowheel.model.effects.gyrover import Gyrover
from gyrowheel.model.effects.rolling_resistance import RollingResistance
from gyrowheel.model.effects.slope import Slope
from gyrowheel.model.effects.spin_friction import SpinFriction

CATALOGUE: dict[str, type[Effect]] = {e.name: e for e in (
    Gravity, Slope, Gyrover, RollingResistance, SpinFriction, AirDrag, ContactForces, Energy)}


def lift_off_conflict(effects: dict[str, dict]) -> str | None:
    """Why contact_forces' on_lift_off cannot be honoured with these effects, or None.

    A law proportional to the normal load (rolling resistance, pivot friction) would push
    instead of resisting once F_n < 0, so it cannot go on past lift-off: a scene with such a
    law must stop there (on_lift_off = "terminate", also the default without contact_forces) or
    leave the ground ("fly": in flight F_n = 0 and the law does nothing). "fly" takes every effect:
    gravity (tilted by slope), air drag and the Gyrover's assembly act on the free system
    (model/flight_system.py; docs/effects.md, "Flight"), the load-proportional laws vanish with F_n = 0.
    """
    policy = effects.get("contact_forces", {}).get("on_lift_off", ContactForces.choices()["on_lift_off"][0])
    laws = [name for name, cls in CATALOGUE.items() if name in effects and cls.uses_normal_load]
    if policy in ("terminate", "fly") or not laws:
        return None
    return (f"{policy!r} is not possible with {' and '.join(laws)}: a law proportional to the normal "
            f"force would push instead of resisting once F_n < 0, so the run must stop at lift-off; "
            f"use \"terminate\" (the default) or leave out {' and '.join(laws)}")


__all__ = ["CATALOGUE", "Effect", "lift_off_conflict"]
