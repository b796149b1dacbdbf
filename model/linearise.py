"""Linear models of any ModelSpec about an operating point, by CasADi Jacobians.

    dx/dt = A dx + B du,   dy = C dx + D du,
    A = d f / d x, B = d f / d u, C = d h / d x, D = d h / d u at (x0, u0, p)

f and h are the very expressions code generation turns into the FMU's C (spec.ode, the output
expressions), so the linear model is the FMU's own, exact to rounding. Measurements may be any
expressions of the spec's symbols (e.g. the lean beta - pi/2).

upright_rolling() gives the operating point of a wheel rolling straight and upright at speed v
(beta = pi/2, gamma_dot = v / R, every other rate zero; actuators at rest), an equilibrium of the
wheel alone and of the wheel with the gyrover effect (no dissipation). The unactuated wheel's
lean-heading modes there have a closed form (gyrowheel.model.steady.wheel_mode_eigenvalues):
neutral above the critical spin, one growing below it; the linear model's eigenvalues match it
(tests/test_linearise.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from gyrowheel.model.spec import ModelSpec


class LinearisationError(ValueError):
    """The operating point is not an equilibrium, or a name is unknown."""


@dataclass
class LinearModel:
    """A, B, C, D (numpy) with the names of states, inputs and measurements, and the point."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    x_names: list[str]
    u_names: list[str]
    y_names: list[str]
    x0: np.ndarray
    u0: np.ndarray
    y0: np.ndarray

    def eigenvalues(self) -> np.ndarray:
        """Open-loop eigenvalues [1/s], sorted by real part then imaginary part."""
        ev = np.linalg.eigvals(self.A)
        return ev[np.lexsort((ev.imag, ev.real))]

    def index(self, name: str) -> int:
        try:
            return self.x_names.index(name)
        except ValueError:
            raise LinearisationError(f"no state {name!r}; states: {', '.join(self.x_names)}") from None

    def restrict(self, keep: list[str]) -> "LinearModel":
        """The model on a subset of states; refuses if a kept derivative or measurement reads a dropped state."""
        idx = [self.index(n) for n in keep]
        drop = [i for i in range(len(self.x_names)) if i not in idx]
        if drop and (np.any(self.A[np.ix_(idx, drop)] != 0) or np.any(self.C[:, drop] != 0)):
            bad = [self.x_names[j] for j in drop if np.any(self.A[idx, j] != 0) or np.any(self.C[:, j] != 0)]
            raise LinearisationError(f"cannot drop state(s) {', '.join(bad)}: the kept states or the "
                                     "measurements depend on them")
        return LinearModel(self.A[np.ix_(idx, idx)], self.B[idx], self.C[:, idx], self.D,
                           [self.x_names[i] for i in idx], self.u_names, self.y_names,
                           self.x0[idx], self.u0, self.y0)

    def relevant(self) -> "LinearModel":
        """Restricted to the states the measurements see, directly or through the dynamics.

        Starts from the states with a nonzero column in C and adds every state their
        derivatives depend on, until closed. Drops cyclic coordinates (for the wheel: x, y,
        gamma) and diagnostic states (energies) that nothing measured depends on.
        """
        keep = set(np.nonzero(np.any(self.C != 0, axis=0))[0])
        while True:
            more = set(np.nonzero(np.any(self.A[sorted(keep)] != 0, axis=0))[0]) - keep
            if not more:
                break
            keep |= more
        return self.restrict([self.x_names[i] for i in sorted(keep)])


def output_expr(spec: ModelSpec, name: str) -> ca.SX:
    """The expression of output `name` of the spec (in t, x, u, p)."""
    for q, e in spec.outputs:
        if q.name == name:
            return e
    raise LinearisationError(f"no output {name!r}; outputs: {', '.join(q.name for q, _ in spec.outputs)}")


def parameter_values(spec: ModelSpec, values: dict[str, float] | None = None) -> np.ndarray:
    """The parameter vector p: start values, overridden by name."""
    values = dict(values or {})
    names = [q.name for q in spec.parameters]
    unknown = [n for n in values if n not in names]
    if unknown:
        raise LinearisationError(f"unknown parameter {unknown[0]!r}; parameters: {', '.join(names)}")
    return np.array([values.get(q.name, q.start) for q in spec.parameters], dtype=float)


def initial_state(spec: ModelSpec, p: np.ndarray, starts: dict[str, float]) -> np.ndarray:
    """x0 = init(s, p) from start values by name (the FMU's own initialisation)."""
    names = [q.name for q in spec.starts]
    unknown = [n for n in starts if n not in names]
    if unknown:
        raise LinearisationError(f"unknown start value {unknown[0]!r}; start values: {', '.join(names)}")
    s = np.array([starts.get(q.name, q.start) for q in spec.starts], dtype=float)
    return np.array(ca.Function("init", [spec.s, spec.p], [spec.init])(s, p), dtype=float).ravel()


def upright_rolling(spec: ModelSpec, speed: float, p: np.ndarray, tilt: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(x0, u0): straight upright rolling at centre speed `speed` [m/s], inputs zero.

    beta = pi/2, gamma_dot = speed / R, every other start value zero (angles, rates, the gyrover's
    swing), the gyrover's flywheel held at `tilt` [rad] (state tilt and input tilt_cmd; a spinning
    flywheel at any fixed tilt leaves straight upright rolling an equilibrium). Raises
    LinearisationError if that is not an equilibrium of the spec.
    """
    R = p[[q.name for q in spec.parameters].index("R")]
    starts = {q.name: 0.0 for q in spec.starts}
    starts.update(beta=math.pi / 2, gamma_dot=speed / R)
    inputs = [q.name for q in spec.inputs]
    if tilt:
        if "tilt" not in starts or "tilt_cmd" not in inputs:
            raise LinearisationError("a tilt needs the gyrover effect (state tilt, input tilt_cmd)")
        starts["tilt"] = tilt
    x0 = initial_state(spec, p, starts)
    u0 = np.zeros(spec.u.numel())
    if tilt:
        u0[inputs.index("tilt_cmd")] = tilt
    check_equilibrium(spec, x0, u0, p, moving=("x", "y", "gamma"))
    return x0, u0


def check_equilibrium(spec: ModelSpec, x0, u0, p, moving=(), tol: float = 1e-9) -> None:
    """Every derivative is zero at (x0, u0, p), except those of the states named in `moving`."""
    f = np.array(ca.Function("f", [spec.t, spec.x, spec.u, spec.p], [spec.ode])(0.0, x0, u0, p)).ravel()
    scale = 1.0 + np.abs(x0)
    bad = [(n, f[i]) for i, n in enumerate(spec.x_names) if n not in moving and abs(f[i]) > tol * scale[i]]
    if bad:
        raise LinearisationError("not an equilibrium: " + ", ".join(f"d{n}/dt = {v:.3g}" for n, v in bad))


def linearise(spec: ModelSpec, x0, u0, p, measurements: dict[str, ca.SX] | list[str] | None = None,
              t: float = 0.0) -> LinearModel:
    """The Jacobians of spec.ode and of the measurements at (t, x0, u0, p).

    measurements: names of outputs, or {name: expression in spec.t, spec.x, spec.u, spec.p};
    None: every output. Returns a LinearModel over all states of the spec.
    """
    if measurements is None:
        measurements = [q.name for q, _ in spec.outputs]
    if not isinstance(measurements, dict):
        measurements = {n: output_expr(spec, n) for n in measurements}
    h = ca.vertcat(*measurements.values()) if measurements else ca.SX(0, 1)
    args = [spec.t, spec.x, spec.u, spec.p]
    jac = ca.Function("lin", args, [ca.jacobian(spec.ode, spec.x), ca.jacobian(spec.ode, spec.u),
                                    ca.jacobian(h, spec.x), ca.jacobian(h, spec.u), h])
    A, B, C, D, y0 = (np.array(ca.DM(m), dtype=float) for m in jac(t, x0, u0, p))
    return LinearModel(A, B.reshape(len(x0), -1), C.reshape(-1, len(x0)), D.reshape(len(measurements), -1),
                       list(spec.x_names), [q.name for q in spec.inputs], list(measurements),
                       np.asarray(x0, float), np.asarray(u0, float), y0.ravel())

