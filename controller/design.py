"""Observer-based LQR for the Gyrover about straight upright rolling (an LQG compensator).

The plant model is the wheel FMU's own: model/linearise.py linearises the ModelSpec a scene
builds, about upright rolling at the design speed, with the measurements the controller gets:

    lean = beta - pi/2, lean_rate = beta_dot, heading = alpha, heading_rate = alpha_dot,
    speed = vx cos(alpha) + vy sin(alpha), tilt

and keeps the states these see (alpha, beta, theta_p, the rates, tilt, tilt_rate). Design
(Franklin, Powell & Emami-Naeini, Feedback Control, ch. 7; Anderson & Moore, Optimal Control):
- Controllability: no internal actuator exerts a torque about the vertical through the contact
  point, so the linear model keeps the yaw momentum I_zz alpha_dot - H beta' - I tilt_rate (and
  with it a heading-tilt relation) whatever the inputs: the controllable subspace is found by a
  staircase of orthonormal bases and the regulator is designed on it (solve_continuous_are
  needs a stabilisable pair).
- Regulator: u = u_ref - K (x_hat - x_ref), K = R^-1 B^T P from the continuous algebraic Riccati
  equation with Bryson's weights (Q_ii = 1 / max_i^2, R_jj = 1 / umax_j^2).
- Observer: steady-state Kalman filter x_hat' = A x_hat + B sat(u) + L (y - y0 - C x_hat),
  L = S C^T V^-1 from the dual Riccati equation (process noise on the inputs, sensor noise V);
  the unmeasured tilt rate, pendulum swing and swing rate come from it. It is fed the
  saturated command, the one the plant receives (no observer windup).
- References: x_ref = N_x r, u_ref = N_u r for r = (heading, speed - v0), the least-squares
  equilibrium inside the controllable subspace (a heading offset needs a held tilt).
- Saturation at the actuators' limits: |tilt_cmd| <= tilt_max (45 deg, a gimbal stop: the roll
  torque of the tilt rate falls with cos(tilt)), |drive_torque| <= drive_fraction m_fly g L_pend
  (docs/effects.md: the pendulum holds at most m_fly g L_pend statically and swings over below it).

Separation principle: the closed-loop eigenvalues are eig(A - B K) with eig(A - L C); both are
reported and compared with the simulated closed loop (tests/test_controller.py).
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.linalg import orth, solve_continuous_are

from model.linearise import LinearModel, linearise, output_expr, parameter_values, upright_rolling
from model.spec import ModelSpec

MEASUREMENTS = ("lean", "lean_rate", "heading", "heading_rate", "speed", "tilt")
COMMANDS = ("tilt_cmd", "drive_torque")
REFERENCES = ("heading", "speed")
# Bryson's rule: the largest acceptable deviation of each design state and command
MAX_DEVIATION = {"alpha": 0.1, "beta": 0.03, "theta_p": 0.5, "alpha_dot": 0.5, "beta_dot": 0.3,
                 "gamma_dot": 0.1 / 0.17, "theta_p_dot": 5.0, "tilt": 0.5, "tilt_rate": 5.0}
TILT_MAX = math.radians(45.0)
DRIVE_FRACTION = 0.5


def measurement_exprs(spec: ModelSpec) -> dict[str, ca.SX]:
    """The controller's measurements as expressions of the wheel's outputs."""
    alpha, vx, vy = (output_expr(spec, n) for n in ("alpha", "vx", "vy"))
    return {"lean": output_expr(spec, "beta") - math.pi / 2, "lean_rate": output_expr(spec, "beta_dot"),
            "heading": alpha, "heading_rate": output_expr(spec, "alpha_dot"),
            "speed": vx * ca.cos(alpha) + vy * ca.sin(alpha), "tilt": output_expr(spec, "tilt")}


def plant_model(spec: ModelSpec, speed: float, values: dict[str, float] | None = None) -> LinearModel:
    """The linear model the controller is designed on: upright rolling at `speed` [m/s]."""
    p = parameter_values(spec, values)
    x0, u0 = upright_rolling(spec, speed, p)
    return linearise(spec, x0, u0, p, measurement_exprs(spec)).relevant()


def controllable_basis(A: np.ndarray, B: np.ndarray, rtol: float = 1e-8) -> np.ndarray:
    """Orthonormal basis (n x k) of the controllable subspace: span{B, AB, A^2 B, ...}.

    Built as a staircase (each step re-orthonormalised), robust where the plain controllability
    matrix [B AB ... A^(n-1) B] is too badly scaled for a rank decision.
    """
    basis = orth(B, rcond=rtol)
    while True:
        grown = orth(np.hstack([basis, A @ basis]), rcond=rtol)
        if grown.shape[1] == basis.shape[1]:
            return basis
        basis = grown


def uncontrollable_directions(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Rows w (k x n) orthogonal to the controllable subspace: w x is unaffected by the inputs."""
    T = controllable_basis(A, B)
    U, _, _ = np.linalg.svd(T, full_matrices=True)
    return U[:, T.shape[1]:].T


def lqr(A, B, Q, R) -> np.ndarray:
    """K = R^-1 B^T P, P from the continuous algebraic Riccati equation."""
    P = solve_continuous_are(A, B, Q, R)
    return np.linalg.solve(R, B.T @ P)


@dataclass
class Design:
    """Everything the controller FMU is built from, plus what the design found."""

    scene: str
    speed: float
    g: float
    x_names: list[str]
    y_names: list[str]
    u_names: list[str]
    A: list
    B: list
    C: list
    y0: list
    K: list
    L: list
    Nx: list
    Nu: list
    tilt_max: float
    drive_max: float
    max_deviation: dict = field(default_factory=dict)
    eig_plant: list = field(default_factory=list)
    eig_regulator: list = field(default_factory=list)
    eig_observer: list = field(default_factory=list)
    conserved: list = field(default_factory=list)  # rows w: w x unaffected by the inputs

    def matrices(self) -> dict[str, np.ndarray]:
        return {k: np.array(getattr(self, k), dtype=float) for k in ("A", "B", "C", "y0", "K", "L", "Nx", "Nu")}

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(asdict(self), indent=1) + "\n")
        return path

    @classmethod
    def load(cls, path: str | Path) -> "Design":
        return cls(**json.loads(Path(path).read_text()))


def _complex_list(ev) -> list:
    ev = np.asarray(ev)
    ev = ev[np.lexsort((ev.imag, ev.real))]
    return [[float(e.real), float(e.imag)] for e in ev]


def design(spec: ModelSpec, speed: float = 1.5, values: dict[str, float] | None = None,
           max_deviation: dict[str, float] | None = None, tilt_max: float = TILT_MAX,
           drive_fraction: float = DRIVE_FRACTION, scene: str = "") -> Design:
    """Design the compensator for the wheel `spec` (gravity + gyrover) at `speed` [m/s].

    values: parameter values by name (defaults: the spec's start values). Returns a Design
    whose matrices are in the plant model's state order (Design.x_names).
    """
    lm = plant_model(spec, speed, values)
    A, B, C = lm.A, lm.B, lm.C
    pv = dict(zip([q.name for q in spec.parameters], parameter_values(spec, values)))
    drive_max = drive_fraction * pv["m_fly"] * pv["g"] * pv["L_pend"]
    dev = {**MAX_DEVIATION, **(max_deviation or {})}
    Q = np.diag([1.0 / dev[n] ** 2 for n in lm.x_names])
    R = np.diag([1.0 / tilt_max**2, 1.0 / drive_max**2])
    T = controllable_basis(A, B)
    K = lqr(T.T @ A @ T, T.T @ B, T.T @ Q @ T, R) @ T.T
    # Kalman filter: process noise through the inputs (a tenth of their range) plus a floor
    W = B @ np.diag([(0.1 * tilt_max) ** 2, (0.1 * drive_max) ** 2]) @ B.T + 1e-6 * np.eye(len(A))
    V = np.diag([(1e-3) ** 2, (1e-2) ** 2, (1e-3) ** 2, (1e-2) ** 2, (1e-2) ** 2, (1e-3) ** 2])
    S = solve_continuous_are(A.T, C.T, W, V)
    L = S @ C.T @ np.linalg.inv(V)
    # reference equilibria inside the controllable subspace: A x + B u = 0, e_r x = 1
    n, m = B.shape
    Nx, Nu = np.zeros((n, 2)), np.zeros((m, 2))
    for j, (state, unit) in enumerate((("alpha", 1.0), ("gamma_dot", 1.0 / pv["R"]))):
        e = np.zeros(n)
        e[lm.index(state)] = 1.0
        M = np.block([[A @ T, B], [e @ T[:, None].squeeze(1) if False else (e @ T)[None, :], np.zeros((1, m))]])
        rhs = np.r_[np.zeros(n), unit]
        sol = np.linalg.lstsq(M, rhs, rcond=None)[0]
        Nx[:, j], Nu[:, j] = T @ sol[:T.shape[1]], sol[T.shape[1]:]
    return Design(
        scene=scene, speed=float(speed), g=float(pv["g"]), x_names=lm.x_names, y_names=lm.y_names,
        u_names=lm.u_names, A=A.tolist(), B=B.tolist(), C=C.tolist(), y0=lm.y0.tolist(), K=K.tolist(),
        L=L.tolist(), Nx=Nx.tolist(), Nu=Nu.tolist(), tilt_max=float(tilt_max), drive_max=float(drive_max),
        max_deviation=dev, eig_plant=_complex_list(np.linalg.eigvals(A)),
        eig_regulator=_complex_list(np.linalg.eigvals(A - B @ K)),
        eig_observer=_complex_list(np.linalg.eigvals(A - L @ C)),
        conserved=uncontrollable_directions(A, B).tolist())


def zero_yaw_momentum_rate(d: Design, lean: float) -> float:
    """The heading rate alpha_dot [rad/s] that gives a lean `lean` [rad] zero yaw momentum.

    The conserved direction of the linear model without a heading component (the yaw momentum
    I_zz alpha_dot - H lean - I tilt_rate, up to scale) is zero for alpha_dot = -w_beta lean / w_alpha_dot:
    the state a sideways push (no torque about the vertical) leaves at its largest lean.
    """
    W = np.array(d.conserved)
    ia, ib, ir = (d.x_names.index(n) for n in ("alpha", "beta", "alpha_dot"))
    w = np.linalg.svd(W[:, [ia]].T)[2][-1] @ W  # the combination with no alpha component
    return float(-w[ib] * lean / w[ir])


def closed_loop_matrix(d: Design, plant: LinearModel | None = None, gain_scale: float = 1.0) -> np.ndarray:
    """The linear closed loop [x; x_hat] of a plant model (default: the design's) with the compensator.

    x' = A_p x + B_p u,  x_hat' = A x_hat + B u + L (C_p x - C x_hat),  u = -gain_scale K x_hat
    (no saturation, continuous time: the reference the co-simulation approaches as its step -> 0).
    """
    m = d.matrices()
    A, B, C, K, L = m["A"], m["B"], m["C"], gain_scale * m["K"], m["L"]
    Ap, Bp, Cp = (A, B, C) if plant is None else (plant.A, plant.B, plant.C)
    return np.block([[Ap, -Bp @ K], [L @ Cp, A - B @ K - L @ C]])
