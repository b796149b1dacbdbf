"""The symbolic model handed to code generation: one table of named quantities.

A ModelSpec is everything fmu_build needs and nothing it must know about wheels (the
wheel's comes from model/build.py, any other system's from model/system.py):
symbol vectors (t, x, s, u, p), the expressions of the generated functions
(init, ode, out, evt, chk, nom, and upd when an event updates the state) and the metadata (names, units, defaults,
descriptions) of every FMI-visible quantity.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca


# Physical ranges the FMU and the scene reader hold values to (docs/scenes.md, "Rules"): Newtonian
# speeds stay below the speed of light; a mass between 1e-30 kg and 1e30 kg (any wheel, with room
# either way) keeps the products of masses, inertias and squared speeds in the contact's impulse
# arithmetic inside double precision (M = 1e150 kg overflows to NaN at a touchdown)
SPEED_OF_LIGHT = 299792458.0  # m/s
MASS_RANGE = (1e-30, 1e30)  # kg
# The wheel's time scales stay far above the adaptive solvers' step-size floor, 16 eps max(|t|, 1)
# (3.6e-15 s up to t = 1 s): sqrt(R / g) >= 1 microsecond, 1 / |rate| >= 1 ns (2.8e5 floors); and the
# energies stay inside double precision whatever M in MASS_RANGE (M g R <= 1e42 J, M R^2 rate^2 <=
# 1e60 J). Beyond, R = 1e-20 m, g = 1e20 m/s2, gamma_dot = 1e20 rad/s failed with "step size
# underflow", R = 1e-300 m, g = 1e300 m/s2 with NaN in the touchdown's update; at the ends every
# combination runs or stops with the budget's message (tests/test_input_ranges.py).
RADIUS_RANGE = (1e-6, 1e6)  # m
GRAVITY_RANGE = (0.0, 1e6)  # m/s2
RATE_RANGE = (-1e9, 1e9)  # rad/s, each of alpha_dot, beta_dot, gamma_dot
# the largest diametral inertia ratio k_diam (an axle 1000 R long) and the largest coefficient of
# air drag and pivot friction: at 1e300 their terms overflow to NaN, at 1e6 they stay finite (a law
# stiff for the wheel's inertia then stops with the solver's step-size floor or the step budget)
K_DIAM_MAX = 1e6
COEFFICIENT_MAX = 1e6
RANGE_NOTE = "(the wheel's time scales, sqrt(R/g) >= 1 us and 1/|rate| >= 1 ns, above the solvers' step-size floor)"


def range_refusal(name: str, low: float, high: float, unit: str, note: str = RANGE_NOTE) -> str:
    """The refusal of a value outside [low, high]: `R must lie in [1e-06, 1e+06] m (note)`; one
    text for the scene reader (fmu_build/scene.py) and the FMU's check at initialisation."""
    return f"{name} must lie in [{low:g}, {high:g}] {unit} {note}".replace("  ", " ")


@dataclass
class Quantity:
    """A named scalar of the model: a parameter, start value, input or output."""

    name: str
    unit: str = "1"
    description: str = ""
    start: float | None = None
    tunable: bool = False
    display_unit: str | None = None
    minimum: float | None = None  # inclusive limits a scene value is checked against
    maximum: float | None = None
    # an output that takes whole values 0, 1, ... naming states: the names, in value order (an
    # FMI Enumeration, type `<Name>` of the CamelCase name: fmu_build/variables.py); empty: a real
    items: tuple[str, ...] = ()
    # the closed range's refusal names it in one text (spec.range_refusal), not as >= and <= apart
    closed_range: bool = False


@dataclass
class Event:
    """An event indicator: fires when expr goes from > 0 to <= 0.

    action "terminate" (stop there) or "warn" (log, go on); "update": the state jumps to
    `update`, an expression of (t, x, u, p) (a discrete mode switch, e.g. a stiction law
    sticking), and the integration goes on. The Boolean output `flag` turns true when it
    first fires.
    """

    name: str
    expr: ca.SX
    action: str  # "terminate", "warn" or "update"
    flag: Quantity  # the Boolean output that turns true when it fires
    update: ca.SX | None = None  # "update": the new state x+(t, x, u, p)


@dataclass
class Check:
    """A validity condition expr > 0 checked at initialisation, with its message."""

    expr: ca.SX
    message: str


@dataclass
class ModelSpec:
    """Symbols, expressions and metadata of one generated model."""

    name: str
    description: str
    t: ca.SX
    x: ca.SX
    x_names: list[str]
    s: ca.SX
    starts: list[Quantity]
    u: ca.SX
    inputs: list[Quantity]
    p: ca.SX
    parameters: list[Quantity]
    init: ca.SX  # x0(s, p)
    ode: ca.SX  # x_dot(t, x, u, p)
    outputs: list[tuple[Quantity, ca.SX]]  # y(t, x, u, p)
    events: list[Event] = field(default_factory=list)
    checks: list[Check] = field(default_factory=list)
    nominal: ca.SX | None = None  # x scale(p) for absolute tolerances
    effects: list[str] = field(default_factory=list)
    x_units: list[str] = field(default_factory=list)  # the unit of each state of x_names (empty: unknown)
    # logged as a warning when a run initialises with a fixed-step solver (euler, rk4); "" none
    fixed_step_caveat: str = ""
    # kinds of the non-conservative forces ("dissipative", "actuator": model/context.py); empty:
    # energy is conserved, else energy + dissipated_energy - actuator_work is (the energy effect)
    force_kinds: list[str] = field(default_factory=list)
    formulation: str = "reduced"
    about: str = ""  # what the model is, one paragraph for the FMU's documentation/index.html

    def output_index(self, name: str) -> int:
        for i, (q, _) in enumerate(self.outputs):
            if q.name == name:
                return i
        raise KeyError(name)

    def functions(self) -> dict[str, ca.Function]:
        """The CasADi Functions that code generation turns into C (gw_<name>)."""
        t, x, s, u, p = self.t, self.x, self.s, self.u, self.p
        y = ca.vertcat(*[e for _, e in self.outputs])
        fns = {
            "init": ca.Function("gw_init", [s, p], [self.init], ["s", "p"], ["x0"]),
            "ode": ca.Function("gw_ode", [t, x, u, p], [self.ode], ["t", "x", "u", "p"], ["xdot"]),
            "out": ca.Function("gw_out", [t, x, u, p], [y], ["t", "x", "u", "p"], ["y"]),
        }
        if self.events:
            e = ca.vertcat(*[ev.expr for ev in self.events])
            fns["evt"] = ca.Function("gw_evt", [t, x, u, p], [e], ["t", "x", "u", "p"], ["e"])
        updates = [(k, ev.update) for k, ev in enumerate(self.events) if ev.action == "update"]
        if updates:
            # upd(t, x, u, p, k): the state after the update of event k (an index, as a double)
            k = ca.SX.sym("k")
            x_new = x
            for i, expr in reversed(updates):
                x_new = ca.if_else(k == i, expr, x_new)
            fns["upd"] = ca.Function("gw_upd", [t, x, u, p, k], [x_new], ["t", "x", "u", "p", "k"], ["x_new"])
        if self.checks:
            c = ca.vertcat(*[ch.expr for ch in self.checks])
            fns["chk"] = ca.Function("gw_chk", [s, p], [c], ["s", "p"], ["c"])
        if self.nominal is not None:
            fns["nom"] = ca.Function("gw_nom", [p], [self.nominal], ["p"], ["x_nominal"])
        fns["jac"] = ca.Function("gw_jac", [t, x, u, p], [ca.densify(ca.jacobian(self.ode, x))],
                                 ["t", "x", "u", "p"], ["J"])
        fns["dir"] = ca.Function("gw_dir", [t, x, u, p],
                                 [ca.densify(ca.jacobian(ca.vertcat(self.ode, y), ca.vertcat(x, u)))],
                                 ["t", "x", "u", "p"], ["D"])
        return fns
