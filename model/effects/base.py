"""The interface every effect implements."""
from __future__ import annotations

import casadi as ca

from gyrowheel.model.context import WheelContext
from gyrowheel.model.spec import Quantity, range_refusal


class Effect:
    """One physical effect: declares parameters and options, adds terms to the context.

    `options` holds the scene's values for this effect (validated by the scene
    reader against `parameters()` and `choices()`); numbers become the parameters'
    start values, strings select structural options (e.g. what an event does).
    """

    name: str = ""
    summary: str = ""
    uses_normal_load: bool = False  # a law proportional to F_n: meaningless past lift-off (F_n < 0)

    def __init__(self, options: dict | None = None):
        self.options = dict(options or {})

    @classmethod
    def parameters(cls) -> list[Quantity]:
        """FMI parameters of the effect, with defaults and limits."""
        return []

    @classmethod
    def starts(cls) -> list[Quantity]:
        """Initial values the effect adds (settable in a scene's [initial])."""
        return []

    def start_quantity(self, name: str) -> Quantity:
        return next(q for q in self.starts() if q.name == name)

    @classmethod
    def choices(cls) -> dict[str, tuple[str, ...]]:
        """Structural string options: name -> allowed values, the first is the default."""
        return {}

    @classmethod
    def presets(cls) -> dict[str, dict[str, float]]:
        """Named values a parameter may be given as (parameter -> {name: value})."""
        return {}

    @classmethod
    def option_conflict(cls, options: dict) -> tuple[str, str] | None:
        """(key, reason) when the scene's options contradict each other (a parameter that the
        chosen structure does not use), else None. The scene reader reports it naming the key;
        apply() raises ValueError with it."""
        return None

    def choice(self, key: str) -> str:
        return self.options.get(key, self.choices()[key][0])

    def declare(self, ctx: WheelContext) -> dict:
        """Declare every parameter with the scene's value as start; return the symbols by name."""
        conflict = self.option_conflict({k: v for k, v in self.options.items() if not k.startswith("_")})
        if conflict:
            raise ValueError(f"{self.name} {conflict[0]}: {conflict[1]}")
        syms = {}
        for q in self.parameters():
            if self.options.get("_no_" + q.name):
                continue
            if q.name in self.options:
                q.start = float(self.options[q.name])
            syms[q.name] = ctx.parameter(q)
            if q.closed_range:
                ctx.check_true(ca.logic_and(syms[q.name] >= q.minimum, syms[q.name] <= q.maximum),
                               range_refusal(q.name, q.minimum, q.maximum, q.unit))
                continue
            if q.minimum is not None:
                ctx.check_true(syms[q.name] >= q.minimum, f"{q.name} must be >= {q.minimum:g}")
            if q.maximum is not None:
                ctx.check_true(syms[q.name] <= q.maximum, f"{q.name} must be <= {q.maximum:g}")
        return syms

    def apply(self, ctx: WheelContext) -> None:
        raise NotImplementedError
