"""Operating points of the Gyrover (steady rolling and steady turns) and its linear model there.

A Gyrover rolling at centre speed v and turning at the constant rate r (a circle of radius v / r)
with its flywheel held at the tilt t is an equilibrium of the wheel's equations when its lean,
pendulum swing and drive torque balance (beta_dot = theta_p_dot = tilt_rate = 0):

    d beta_dot / dt = d gamma_dot / dt = d theta_p_dot / dt = 0,  alpha_dot = r,
    v = R (gamma_dot + alpha_dot cos beta)                      (paper eqs. 18-19, beta_dot = 0)

For every (r, t) there is one (lean, theta_p, drive): the tilt is free because no internal torque
changes the yaw momentum (the fourth equation, d alpha_dot / dt = 0, then holds by itself; it is
checked). steady_turn() solves the three by Newton (scipy least_squares, residual <= 1e-10) from the
upright guess; r = 0 is straight upright rolling (gyrowheel.model.linearise.upright_rolling, exact).
plant_model() linearises the wheel's own expressions there (model/linearise.py) with the
controller's measurements.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from gyrowheel.extras import require

require("system", "gyrowheel.controller")  # scipy comes with the optional part [system]
from scipy.optimize import least_squares  # noqa: E402

from gyrowheel.model.linearise import (LinearisationError, LinearModel, initial_state, linearise, output_expr,
                             parameter_values, upright_rolling)
from gyrowheel.model.spec import ModelSpec

MEASUREMENTS = ("lean", "lean_rate", "heading", "heading_rate", "speed", "tilt")


def measurement_exprs(spec: ModelSpec) -> dict[str, ca.SX]:
    """The controller's measurements as expressions of the wheel's outputs (in spec.x, spec.u, spec.p)."""
    alpha, vx, vy = (output_expr(spec, n) for n in ("alpha", "vx", "vy"))
    return {"lean": output_expr(spec, "beta") - math.pi / 2, "lean_rate": output_expr(spec, "beta_dot"),
            "heading": alpha, "heading_rate": output_expr(spec, "alpha_dot"),
            "speed": vx * ca.cos(alpha) + vy * ca.sin(alpha), "tilt": output_expr(spec, "tilt")}


@dataclass
class OperatingPoint:
    """A steady turn (or straight rolling, rate 0): the wheel's full state x, inputs u, parameters p."""

    speed: float  # m/s, centre speed
    rate: float  # rad/s, heading rate
    tilt: float  # rad, flywheel tilt
    lean: float  # rad, beta - pi/2
    x: np.ndarray
    u: np.ndarray
    p: np.ndarray


def steady_turn(spec: ModelSpec, speed: float, rate: float = 0.0, tilt: float = 0.0,
                values: dict[str, float] | None = None) -> OperatingPoint:
    """The steady turn at centre speed `speed` [m/s], heading rate `rate` [rad/s], tilt `tilt` [rad].

    Raises LinearisationError if Newton does not find it (residual > 1e-10 rad/s2).
    """
    p = parameter_values(spec, values)
    if rate == 0.0:
        x, u = upright_rolling(spec, speed, p, tilt)
        return OperatingPoint(speed, 0.0, tilt, 0.0, x, u, p)
    names = [q.name for q in spec.parameters]
    R = p[names.index("R")]
    f = ca.Function("f", [spec.t, spec.x, spec.u, spec.p], [spec.ode])
    rows = [spec.x_names.index(n) for n in ("beta_dot", "gamma_dot", "theta_p_dot", "alpha_dot")]
    inputs = [q.name for q in spec.inputs]

    def point(z):
        lean, theta_p, drive = z
        beta = math.pi / 2 + lean
        starts = {q.name: 0.0 for q in spec.starts}
        starts.update(beta=beta, gamma_dot=speed / R - rate * math.cos(beta), alpha_dot=rate, theta_p=theta_p,
                      tilt=tilt)
        u = np.zeros(len(inputs))
        u[inputs.index("tilt_cmd")], u[inputs.index("drive_torque")] = tilt, drive
        return initial_state(spec, p, starts), u

    def residual(z):
        x, u = point(z)
        return np.array(f(0.0, x, u, p)).ravel()[rows[:3]]

    sol = least_squares(residual, np.zeros(3), xtol=1e-15, ftol=1e-15, gtol=1e-15)
    x, u = point(sol.x)
    worst = np.abs(np.array(f(0.0, x, u, p)).ravel()[rows]).max()
    if worst > 1e-10:
        raise LinearisationError(f"no steady turn at {speed:g} m/s, {rate:g} rad/s, tilt {tilt:g} rad "
                                 f"(residual {worst:.2g})")
    return OperatingPoint(speed, rate, tilt, float(sol.x[0]), x, u, p)


def plant_model(spec: ModelSpec, op: OperatingPoint) -> LinearModel:
    """The wheel's linear model at op with the controller's measurements, on the states they see."""
    return linearise(spec, op.x, op.u, op.p, measurement_exprs(spec)).relevant()
