"""The shared workspace effects write into while a wheel model is assembled.

Everything is expressed in placeholder symbols: q, q_dot, q_ddot of every
coordinate, the normal contact force Fn, inputs, parameters and effect states.
build.py binds them to the state and the solved accelerations at the end.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca

from model.spec import Check, Quantity


@dataclass
class Coordinate:
    """A generalised coordinate with its placeholders.

    free: an own equation of motion and an independent speed; driven: rate and
    acceleration prescribed by `rate` and `accel` (expressions of states, inputs,
    parameters), its own equation dropped.
    """

    name: str
    q: ca.SX
    qd: ca.SX
    qdd: ca.SX
    free: bool = True
    rate: ca.SX | None = None
    accel: ca.SX | None = None
    value: ca.SX | None = None  # driven: the state holding its value (None: cyclic, unused)
    start: Quantity | None = None  # free, beyond the wheel's: start value of the coordinate
    rate_start: Quantity | None = None  # ... and of its rate


@dataclass
class State:
    """A state an effect adds (a servo, an accumulated energy), with its derivative."""

    quantity: Quantity  # start value and metadata; exposed as an output when `output`
    sym: ca.SX
    derivative: ca.SX | None = None
    output: bool = True
    nominal: ca.SX | float = 1.0  # scale for the absolute tolerance


@dataclass
class Force:
    """A force F on a point moving with velocity v, or a torque on an angular velocity.

    Generalised force J^T F with J = d v / d q_dot; power F . v. kind is
    "dissipative" (counted in dissipated energy), "actuator" or "external".
    point: a force applied by the surroundings at a point (air drag), which the
    contact-force balance must subtract; couples and internal torques are not.
    """

    value: ca.SX
    velocity: ca.SX
    kind: str = "dissipative"
    point: bool = False


@dataclass
class Body:
    """A point mass for gravity: the potential is -mass g . position."""

    mass: ca.SX
    position: ca.SX


@dataclass
class WheelContext:
    """Placeholders of the base wheel plus everything effects contribute."""

    coords: list[Coordinate]
    par: dict[str, ca.SX] = field(default_factory=dict)
    parameters: list[Quantity] = field(default_factory=list)
    inputs: list[tuple[Quantity, ca.SX]] = field(default_factory=list)
    states: list[State] = field(default_factory=list)
    kinetic: list[ca.SX] = field(default_factory=list)
    potentials: list[ca.SX] = field(default_factory=list)
    bodies: list[Body] = field(default_factory=list)
    forces: list[Force] = field(default_factory=list)
    gravity: ca.SX | None = None  # ground-frame vector, set by the gravity effect
    outputs: list[tuple[Quantity, ca.SX]] = field(default_factory=list)
    events: list[tuple[str, ca.SX, str, Quantity]] = field(default_factory=list)
    checks: list[Check] = field(default_factory=list)
    Fn: ca.SX = field(default_factory=lambda: ca.SX.sym("Fn"))
    uses_Fn: bool = False
    kin: object = None  # model.kinematics.WheelKinematics of the wheel coordinates
    Fc: ca.SX = field(default_factory=lambda: ca.SX.sym("Fc", 3))  # contact force, bound late
    late: dict = field(default_factory=lambda: {n: ca.SX.sym(n + "_late") for n in ("T", "V", "P_diss", "P_act")})
    late_values: dict = field(default_factory=dict)

    def coordinate(self, name: str, free: bool = True, rate=None, accel=None, value=None,
                   start: Quantity | None = None, rate_start: Quantity | None = None) -> Coordinate:
        c = Coordinate(name, ca.SX.sym(name), ca.SX.sym(name + "_dot"), ca.SX.sym(name + "_ddot"),
                       free, rate, accel, value, start, rate_start)
        self.coords.append(c)
        return c

    def parameter(self, quantity: Quantity) -> ca.SX:
        """Declare a parameter and return its symbol."""
        if quantity.name in self.par:
            raise ValueError(f"parameter {quantity.name} declared twice")
        sym = ca.SX.sym(quantity.name)
        self.par[quantity.name] = sym
        self.parameters.append(quantity)
        return sym

    def input(self, quantity: Quantity) -> ca.SX:
        sym = ca.SX.sym(quantity.name)
        self.inputs.append((quantity, sym))
        return sym

    def gravity_magnitude(self) -> ca.SX:
        return ca.norm_2(self.gravity) if self.gravity is not None else ca.SX(0)

    def natural_rate(self) -> ca.SX:
        """sqrt(g / R), the wheel's own time scale, floored at g = 1e-3 m/s^2 (tolerance scaling)."""
        return ca.sqrt(ca.fmax(self.gravity_magnitude(), 1e-3) / self.par["R"])

    def energy_scale(self) -> ca.SX:
        """M g R, floored at g = 1e-3 m/s^2 (tolerance scaling of energy states)."""
        return self.par["M"] * self.par["R"] * ca.fmax(self.gravity_magnitude(), 1e-3)

    def state(self, quantity: Quantity, output: bool = True) -> State:
        st = State(quantity, ca.SX.sym(quantity.name), None, output)
        self.states.append(st)
        return st

    def output(self, quantity: Quantity, expr) -> None:
        self.outputs.append((quantity, expr))

    def force(self, value, velocity, kind: str = "dissipative", point: bool = False) -> None:
        """A generalised force from a force on a point velocity or a torque on an angular velocity."""
        if ca.depends_on(ca.vec(ca.SX(value)), self.Fn):
            self.uses_Fn = True
        self.forces.append(Force(ca.SX(value), ca.SX(velocity), kind, point))

    def check(self, expr: ca.SX, message: str) -> None:
        self.checks.append(Check(expr, message))

    def check_true(self, condition: ca.SX, message: str) -> None:
        """A non-strict condition (e.g. a >= b) as a check that must be > 0."""
        self.checks.append(Check(ca.if_else(condition, 1, -1), message))

    # placeholders of the wheel coordinates
    @property
    def q(self) -> ca.SX:
        return ca.vertcat(*[c.q for c in self.coords[:5]])

    @property
    def qd(self) -> ca.SX:
        return ca.vertcat(*[c.qd for c in self.coords[:5]])

    @property
    def qdd(self) -> ca.SX:
        return ca.vertcat(*[c.qdd for c in self.coords[:5]])

    def all_q(self) -> ca.SX:
        return ca.vertcat(*[c.q for c in self.coords])

    def all_qd(self) -> ca.SX:
        return ca.vertcat(*[c.qd for c in self.coords])

    def all_qdd(self) -> ca.SX:
        return ca.vertcat(*[c.qdd for c in self.coords])

    def acceleration(self, position: ca.SX) -> ca.SX:
        """Second time derivative of a position given in the coordinates' placeholders."""
        q, qd, qdd = self.all_q(), self.all_qd(), self.all_qdd()
        v = ca.jtimes(position, q, qd)
        return ca.jtimes(v, q, qd) + ca.jtimes(position, q, qdd)
