"""The shared workspace effects write into while a wheel model is assembled."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import casadi as ca

from model.kinematics import WheelKinematics
from model.spec import Check, Event, Quantity

ForceFn = Callable[[ca.SX, ca.SX], ca.SX]


@dataclass
class WheelContext:
    """Symbols of the base wheel plus the terms effects contribute.

    q, qd: generalised coordinates and their rates (symbolic placeholders);
    par: parameter symbols by name; kin: kinematics at (q, qd).
    Effects append potential energy terms, generalised forces Q_nc(q, qd),
    parameters, outputs (expressions of q, qd), events and checks.
    """

    q: ca.SX
    qd: ca.SX
    kin: WheelKinematics
    par: dict[str, ca.SX]
    parameters: list[Quantity] = field(default_factory=list)
    potentials: list[ca.SX] = field(default_factory=list)
    forces: list[ForceFn] = field(default_factory=list)
    outputs: list[tuple[Quantity, ca.SX]] = field(default_factory=list)
    events: list[tuple[str, ca.SX, str, Quantity]] = field(default_factory=list)
    checks: list[Check] = field(default_factory=list)

    def parameter(self, quantity: Quantity) -> ca.SX:
        """Declare a parameter and return its symbol."""
        if quantity.name in self.par:
            raise ValueError(f"parameter {quantity.name} declared twice")
        sym = ca.SX.sym(quantity.name)
        self.par[quantity.name] = sym
        self.parameters.append(quantity)
        return sym

    def check(self, expr: ca.SX, message: str) -> None:
        self.checks.append(Check(expr, message))

    def check_true(self, condition: ca.SX, message: str) -> None:
        """A non-strict condition (e.g. a >= b) as a check that must be > 0."""
        self.checks.append(Check(ca.if_else(condition, 1, -1), message))


def event(name: str, expr: ca.SX, action: str, flag: Quantity) -> Event:
    return Event(name, expr, action, flag)
