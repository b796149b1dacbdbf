"""Effects: independent physics a scene can switch on (DESIGN.md, "The model").

Each effect module defines an Effect with its parameters and an apply() that
adds terms to the shared WheelContext. The scene names the effects it wants;
nothing else enters the equations or the generated code.
"""
from __future__ import annotations

from model.effects.base import Effect
from model.effects.gravity import Gravity

CATALOGUE: dict[str, type[Effect]] = {
    Gravity.name: Gravity,
}

__all__ = ["CATALOGUE", "Effect"]
