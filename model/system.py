"""A small CasADi system described by hand: states, inputs, outputs, parameters, events.

    x_dot = f(t, x, u, p),   y = h(t, x, u, p),   events e_i(t, x, u, p) crossing zero from above

System collects these as named scalars and produces the same ModelSpec the wheel's
assembler produces (model/build.py), so that fmu_build turns it into an FMI 2.0 FMU
with the same code generation, variable table, modelDescription writer and C runtime
(gyrowheel.fmu_build.builder.build_spec_fmu). A controller is one such system
(controller/compensator.py); the wheel is built by model/build.py into the same ModelSpec.

Every state is a settable start value; with output=True (default) it is also an output
(FMI causality output, initial exact), otherwise a local continuous state.
"""
from __future__ import annotations

import re

import casadi as ca

from gyrowheel.model.spec import Check, Event, ModelSpec, Quantity

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_ACTIONS = ("terminate", "warn")


class SystemDescriptionError(ValueError):
    """A system description that cannot be built; the message names the quantity."""


class System:
    """Builder of one ModelSpec from named scalar quantities (SX symbols)."""

    def __init__(self, name: str, description: str = "", about: str = ""):
        self._check_name(name, "system name")
        self.name, self.description, self.about = name, description, about
        self.t = ca.SX.sym("t")
        self._params: list[tuple[Quantity, ca.SX]] = []
        self._inputs: list[tuple[Quantity, ca.SX]] = []
        self._states: list[tuple[Quantity, ca.SX, bool, float]] = []
        self._derivs: dict[str, ca.SX] = {}
        self._outputs: list[tuple[Quantity, ca.SX]] = []
        self._events: list[Event] = []
        self._checks: list[Check] = []
        self._names: set[str] = set()

    # -- declarations -------------------------------------------------------
    def _check_name(self, name: str, what: str) -> None:
        if not isinstance(name, str) or not _NAME.match(name):
            raise SystemDescriptionError(f"{what} {name!r} is not a valid identifier ([A-Za-z_][A-Za-z0-9_]*)")

    def _declare(self, name: str, what: str) -> None:
        self._check_name(name, what)
        if name in self._names:
            raise SystemDescriptionError(f"{what} {name!r}: the name is already used")
        self._names.add(name)

    @staticmethod
    def _finite(name: str, value) -> float:
        v = float(value)
        if v != v or v in (float("inf"), float("-inf")):
            raise SystemDescriptionError(f"{name}: start value must be finite, got {value!r}")
        return v

    def parameter(self, name: str, start: float, unit: str = "1", description: str = "",
                  tunable: bool = False, minimum: float | None = None,
                  maximum: float | None = None) -> ca.SX:
        """A Real parameter; minimum/maximum (inclusive) become initialisation checks."""
        self._declare(name, "parameter")
        q = Quantity(name, unit, description, self._finite(name, start), tunable=tunable,
                     minimum=minimum, maximum=maximum)
        sym = ca.SX.sym(name)
        self._params.append((q, sym))
        if minimum is not None:
            self.check(ca.if_else(sym >= minimum, 1, -1), f"{name} must be >= {minimum:g}")
        if maximum is not None:
            self.check(ca.if_else(sym <= maximum, 1, -1), f"{name} must be <= {maximum:g}")
        return sym

    def input(self, name: str, start: float = 0.0, unit: str = "1", description: str = "") -> ca.SX:
        """A Real input, held constant by the runtime over each communication step."""
        self._declare(name, "input")
        sym = ca.SX.sym(name)
        self._inputs.append((Quantity(name, unit, description, self._finite(name, start)), sym))
        return sym

    def state(self, name: str, start: float = 0.0, unit: str = "1", description: str = "",
              output: bool = True, nominal: float = 1.0) -> ca.SX:
        """A continuous state; give its derivative with der(). nominal scales abs_tol."""
        self._declare(name, "state")
        if not nominal > 0:
            raise SystemDescriptionError(f"state {name!r}: nominal must be > 0, got {nominal!r}")
        sym = ca.SX.sym(name)
        self._states.append((Quantity(name, unit, description, self._finite(name, start)), sym, output,
                             float(nominal)))
        return sym

    def der(self, state: ca.SX, expr) -> None:
        """Set the time derivative of a state declared with state()."""
        name = self._state_name(state)
        if name in self._derivs:
            raise SystemDescriptionError(f"state {name!r}: derivative given twice")
        self._derivs[name] = self._scalar(expr, f"der({name})")

    def output(self, name: str, expr, unit: str = "1", description: str = "") -> None:
        """An output y = h(t, x, u, p)."""
        self._declare(name, "output")
        self._outputs.append((Quantity(name, unit, description), self._scalar(expr, name)))

    def event(self, name: str, expr, action: str = "terminate", flag: str | None = None,
              description: str = "") -> None:
        """An event when expr goes from > 0 to <= 0: stop the run or warn; a Boolean output flags it."""
        if action not in _ACTIONS:
            raise SystemDescriptionError(f"event {name!r}: action must be one of {', '.join(_ACTIONS)}, not {action!r}")
        flag = flag or name
        self._declare(flag, "event flag")
        self._events.append(Event(name, self._scalar(expr, f"event {name}"), action,
                                  Quantity(flag, "", description or f"true once event {name} has fired")))

    def check(self, expr, message: str) -> None:
        """A validity condition expr > 0 on parameters and start values, checked at initialisation."""
        self._checks.append(Check(self._scalar(expr, f"check {message!r}"), message))

    # -- assembly -----------------------------------------------------------
    def _state_name(self, state) -> str:
        for q, sym, _, _ in self._states:
            if ca.is_equal(sym, state):
                return q.name
        raise SystemDescriptionError("der(): the first argument must be a symbol returned by state()")

    @staticmethod
    def _scalar(expr, what: str) -> ca.SX:
        expr = ca.SX(expr)
        if expr.numel() != 1:
            raise SystemDescriptionError(f"{what}: expected a scalar expression, got shape {expr.shape}")
        return expr

    def spec(self) -> ModelSpec:
        """The ModelSpec (model/spec.py) of the system; raises SystemDescriptionError if incomplete."""
        missing = [q.name for q, _, _, _ in self._states if q.name not in self._derivs]
        if missing:
            raise SystemDescriptionError(f"state {missing[0]!r} has no derivative (call der())")
        x = ca.vertcat(*[s for _, s, _, _ in self._states]) if self._states else ca.SX(0, 1)
        u = ca.vertcat(*[s for _, s in self._inputs]) if self._inputs else ca.SX(0, 1)
        p = ca.vertcat(*[s for _, s in self._params]) if self._params else ca.SX(0, 1)
        starts = [q for q, _, _, _ in self._states]
        s = ca.SX.sym("s", len(starts))
        known = ca.vertcat(self.t, x, u, p)
        exprs = [(f"der({q.name})", self._derivs[q.name]) for q in starts]
        exprs += [(q.name, e) for q, e in self._outputs] + [(f"event {e.name}", e.expr) for e in self._events]
        for what, expr in exprs:
            self._only_declared(expr, known, what)
        checks = [Check(ca.substitute(c.expr, x, s), c.message) for c in self._checks]
        for c in checks:
            self._only_declared(c.expr, ca.vertcat(s, p), f"check {c.message!r}")
        outputs = [(q, sym) for q, sym, out, _ in self._states if out] + self._outputs
        ode = ca.vertcat(*[self._derivs[q.name] for q in starts]) if starts else ca.SX(0, 1)
        nominal = ca.DM([n for _, _, _, n in self._states]) if starts else None
        return ModelSpec(
            name=self.name, description=self.description, t=self.t, x=x,
            x_names=[q.name for q in starts], x_units=[q.unit for q in starts], s=s, starts=starts, u=u,
            inputs=[q for q, _ in self._inputs], p=p, parameters=[q for q, _ in self._params],
            init=s, ode=ode, outputs=outputs, events=self._events, checks=checks,
            nominal=ca.SX(nominal) if nominal is not None else None, effects=[], formulation="",
            about=self.about)

    @staticmethod
    def _only_declared(expr: ca.SX, known: ca.SX, what: str) -> None:
        free = [str(v) for v in ca.symvar(expr) if not any(ca.is_equal(v, k) for k in ca.vertsplit(known))]
        if free:
            raise SystemDescriptionError(f"{what} depends on {', '.join(free)}, which is not a declared state, "
                              "input, parameter or time of this system")
