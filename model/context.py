"""The shared workspace effects write into while a wheel model is assembled.

Everything is expressed in placeholder symbols: q, q_dot, q_ddot of every
coordinate, the normal contact force Fn, inputs, parameters and effect states.
build.py binds them to the state and the solved accelerations at the end.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca

from gyrowheel.model.spec import Check, Quantity


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
    # no start variable: the initial value is this expression of the placeholders (q, q_dot)
    # evaluated at the initial point (e.g. the mode of a stiction law, sign of its rate)
    start_expr: ca.SX | None = None


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
    mode: int | None = None  # None: in every contact mode; else only in that one (model/contact_modes.py)


# Breakaway margin of the stiction laws: a stuck mode holds while the holding force needed stays
# below (1 + BREAKAWAY) times the Coulomb limit and is left at or above it, so the motion after a
# breakaway always accelerates away from zero (never a zero-acceleration slide that chatters).
BREAKAWAY = 1e-9


@dataclass
class StickSlip:
    """A Coulomb law with true stiction on one rate (docs/effects.md, "Stiction").

    rate r(q, q_dot): the sliding rate, linear in q_dot (gamma_dot for rolling resistance, the
    pivot rate omega . k for spin friction); limit L >= 0: the Coulomb force (may contain F_n).
    The mode m (a state with zero derivative that only the law's update event changes) is +1 /
    -1 while r slides forwards / backwards and 0 while stuck; s = 1 - m^2 is 1 when stuck.
    The law's generalised force on r is  F = -L m + s H,  where H (`hold`, a placeholder solved
    with the accelerations) is the holding force: with s = 1 it is the multiplier of the extra
    constraint r_dot = 0, with s = 0 the row reads H = 0.  Arithmetic only: the right-hand side
    stays smooth within a mode and needs no if_else.
    """

    name: str
    rate: ca.SX
    limit: ca.SX
    mode: "State"
    hold: ca.SX
    what: str = "law"  # for descriptions: "rolling resistance", "pivot friction"

    @property
    def stuck(self) -> ca.SX:
        return 1 - self.mode.sym**2

    @property
    def force(self) -> ca.SX:
        """Generalised force of the law on its rate: Coulomb while sliding, holding when stuck."""
        return -self.limit * self.mode.sym + self.stuck * self.hold

    def condition(self, rate_dot: ca.SX) -> ca.SX:
        """The row solved for `hold`: s r_dot + (1 - s) H = 0 (affine in accelerations and H)."""
        return self.stuck * rate_dot + (1 - self.stuck) * self.hold

    def holding(self) -> ca.SX:
        """L |L| (1 + BREAKAWAY)^2 - H^2: > 0 exactly when the stuck mode holds, |H| < L (1 + BREAKAWAY).

        Signed in L, so that it changes sign once per physical crossing: a limit that drops to 0
        and below (F_n changing sign at lift-off) leaves it negative, where the square L^2 would
        turn it positive again and make a break-away followed by that drop look like no crossing
        at the ends of one step. Continuously differentiable (d(L |L|)/dL = 2 |L|).
        """
        return self.limit * ca.fabs(self.limit) * (1 + BREAKAWAY)**2 - self.hold**2

    def indicator(self) -> ca.SX:
        """Event indicator of the mode switches (fires going from > 0 to <= 0).

        Sliding (s = 0): m r, the rate in the mode's direction, reaches 0 (stick or reverse).
        Stuck (m = 0): `holding` reaches 0 (breakaway). Each sign change is one physical crossing.
        """
        return self.stuck * self.holding() + self.mode.sym * self.rate


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
    stick_slip: list[StickSlip] = field(default_factory=list)
    Fn: ca.SX = field(default_factory=lambda: ca.SX.sym("Fn"))
    uses_Fn: bool = False
    kin: object = None  # gyrowheel.model.kinematics.WheelKinematics of the wheel coordinates
    Fc: ca.SX = field(default_factory=lambda: ca.SX.sym("Fc", 3))  # contact force, bound late
    late: dict = field(default_factory=lambda: {n: ca.SX.sym(n + "_late") for n in ("T", "V", "P_diss", "P_act")})
    late_values: dict = field(default_factory=dict)
    sliding: object = None  # gyrowheel.model.contact_modes.SlidingContact when the wheel may slide
    flight: object = None  # gyrowheel.model.contact_flight.FlightContact when the wheel may fly
    extra_starts: list[tuple[Quantity, ca.SX]] = field(default_factory=list)  # start values used by init only
    # laws of the surroundings that act on the wheel as a free body too (flight, model/flight.py
    # free_energies): callables (v_centre (3,), omega (3,), n (3,)) -> [(value, velocity)]
    free_laws: list = field(default_factory=list)

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

    def stiction(self, name: str, rate: ca.SX, limit: ca.SX, what: str) -> StickSlip:
        """Declare a Coulomb law with true stiction on `rate` (see StickSlip); returns it.

        Adds the mode state `<name>_mode` (no start variable: it starts as sign(rate), and a
        law starting at rest is settled by the initial event iteration), the holding force
        placeholder, and (in model/build.py) the constraint row, the event and its update.
        """
        mode = State(Quantity(f"{name}_mode", "1", f"{what}: +1 / -1 sliding forwards / backwards, 0 stuck"),
                     ca.SX.sym(f"{name}_mode"), ca.SX(0), output=False, start_expr=ca.sign(rate))
        self.states.append(mode)
        law = StickSlip(name, ca.SX(rate), ca.SX(limit), mode, ca.SX.sym(f"{name}_hold"), what)
        self.stick_slip.append(law)
        return law

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

    def acceleration_of_rate(self, rate: ca.SX) -> ca.SX:
        """Time derivative of a rate r(q, q_dot) given in the coordinates' placeholders."""
        q, qd, qdd = self.all_q(), self.all_qd(), self.all_qdd()
        return ca.jtimes(rate, q, qd) + ca.jtimes(rate, qd, qdd)

    def acceleration(self, position: ca.SX) -> ca.SX:
        """Second time derivative of a position given in the coordinates' placeholders."""
        q, qd, qdd = self.all_q(), self.all_qd(), self.all_qdd()
        v = ca.jtimes(position, q, qd)
        return ca.jtimes(v, q, qd) + ca.jtimes(position, q, qdd)
