"""The interface every effect implements."""
from __future__ import annotations

from model.context import WheelContext
from model.spec import Quantity


class Effect:
    """One physical effect: declares parameters, adds terms to the context.

    `options` holds the scene's values for this effect (already validated against
    `parameters()`); they become the parameters' start values.
    """

    name: str = ""
    summary: str = ""

    def __init__(self, options: dict[str, float] | None = None):
        self.options = dict(options or {})

    @classmethod
    def parameters(cls) -> list[Quantity]:
        return []

    def start(self, quantity: Quantity) -> Quantity:
        """The parameter with the scene's value as its start value."""
        if quantity.name in self.options:
            quantity.start = float(self.options[quantity.name])
        return quantity

    def apply(self, ctx: WheelContext) -> None:
        raise NotImplementedError
