"""Observer-based LQR for the Gyrover about one steady turn (an LQG compensator; the gain schedule
of controller/schedule.py designs one per grid point; rate 0, tilt 0 is straight upright rolling).

The plant model is the wheel FMU's own: model/linearise.py linearises the ModelSpec a scene
builds, at the steady turn (controller/operating_point.py), with the measurements the controller gets:

    lean = beta - pi/2, lean_rate = beta_dot, heading = alpha, heading_rate = alpha_dot,
    speed = vx cos(alpha) + vy sin(alpha), tilt

and keeps the states these see (alpha, beta, theta_p, the rates, tilt, tilt_rate). Design
(Franklin, Powell & Emami-Naeini, Feedback Control, ch. 7; Anderson & Moore, Optimal Control):
- Controllability: no internal actuator changes the yaw momentum of the whole Gyrover (the ground
  has no moment about the vertical through the centre, to first order), so the linear model
  conserves c = I_yaw alpha_dot - (H_w + H_f) lean - H_f tilt (H_w = I_axial gamma_dot the wheel's
  spin momentum, H_f = I_fly_axial flywheel_rate the flywheel's, I_yaw = I_diam + I_fly_diam):
  one direction of 9 is uncontrollable, everything else is (staircase of orthonormal bases).
  Since c depends only on measured quantities, it is not a limit on what the robot can do: for
  every c there is an equilibrium (straight rolling with the tilt -c / H_f), and a steady turn at
  any rate is an equilibrium with its own lean and tilt.
- References: the equilibrium x_ref = N_x r, u_ref = N_u r for r = (heading, heading rate,
  speed - v0, c): upright or steadily turning rolling with the commanded heading, turn rate and
  speed and the present yaw momentum c = w x_hat (w the conserved row, in N m s).
- Regulator: u = u_ref - K (x_hat - x_ref), K = R^-1 B^T P from the continuous algebraic Riccati
  equation on the controllable subspace, with Bryson's weights (Q_ii = 1 / max_i^2,
  R_jj = 1 / umax_j^2). x_hat - x_ref lies in that subspace (both have the same c).
- Observer: steady-state Kalman filter x_hat' = A x_hat + B sat(u) + L (y - y0 - C x_hat),
  L = S C^T V^-1 from the dual Riccati equation (process noise on the inputs, sensor noise V);
  the unmeasured tilt rate, pendulum swing and swing rate come from it. It is fed the
  saturated command, the one the plant receives (no observer windup).
- Saturation at the actuators' limits: |tilt_cmd| <= tilt_max (45 deg: the gimbal's stop assumed
  here; docs/effects.md gives the servo none; at 90 deg the spin axis would lie along the link),
  |drive_torque| <= drive_fraction m_fly g L_pend (docs/effects.md: the pendulum holds at most
  m_fly g L_pend statically, and a torque step from rest swings it over the top above
  DRIVE_STEP_LIMIT = 0.7246 m_fly g L_pend; 0.5 leaves room for a pendulum already swinging).
- Gains per world: design() is called with the scene's own g (earth, moon); the weights are the
  same, the gains and so the closed-loop poles differ.
- Communication step: sampled_closed_loop() gives the loop as co-simulated with a fixed step (a
  linear map per step), whose spectral radius predicts the longest step that works.

Separation principle: the closed-loop eigenvalues are eig(A - B K) on the controllable subspace
with eig(A - L C), plus the conserved direction at 0; closed_loop_matrix() gives the loop
[plant; observer] and tests/test_controller.py compares it with the co-simulated closed loop.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from gyrowheel.extras import require

require("system", "gyrowheel.controller")  # scipy comes with the optional part [system]
from scipy.linalg import expm, orth, solve_continuous_are  # noqa: E402

from gyrowheel.controller.operating_point import MEASUREMENTS, measurement_exprs, steady_turn
from gyrowheel.controller.operating_point import plant_model as _plant_model
from gyrowheel.model.linearise import LinearModel, parameter_values
from gyrowheel.model.spec import ModelSpec

COMMANDS = ("tilt_cmd", "drive_torque")
REFERENCES = ("heading", "heading_rate", "speed", "yaw_momentum")
# Bryson's rule: the largest acceptable deviation of each design state and command
MAX_DEVIATION = {"alpha": 0.05, "beta": 0.03, "theta_p": 0.5, "alpha_dot": 0.2, "beta_dot": 0.3,
                 "gamma_dot": 0.1 / 0.17, "theta_p_dot": 5.0, "tilt": 0.3, "tilt_rate": 1.0}
# Kalman filter: sensor noise (standard deviation) of each measurement, in its unit
SENSOR_NOISE = {"lean": 1e-3, "lean_rate": 1e-2, "heading": 1e-3, "heading_rate": 1e-1, "speed": 1e-2, "tilt": 1e-2}
YAW_MOMENTUM_NOISE = 0.03  # N m s / sqrt(s): process noise on c (its nonlinear drift)
TILT_MAX = math.radians(45.0)
TILT_WEIGHT = 0.05  # rad: Bryson's largest tilt_cmd deviation; keeps the servo's loop below ~35 rad/s
DRIVE_FRACTION = 0.5
DRIVE_STEP_LIMIT = 0.7246  # k(pi - asin k) = 1 + sqrt(1 - k^2): a step k m g L from rest just swings over


class DesignError(ValueError):
    """The model cannot be controlled as designed here (the message says why)."""


def plant_model(spec: ModelSpec, speed: float, values: dict[str, float] | None = None,
                tilt: float = 0.0, rate: float = 0.0) -> LinearModel:
    """The linear model at the steady turn (speed [m/s], rate [rad/s], tilt [rad]); rate 0: straight."""
    return _plant_model(spec, steady_turn(spec, speed, rate, tilt, values))


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


def yaw_momentum_row(lm: LinearModel, pv: dict[str, float]) -> np.ndarray:
    """The conserved row w (1 x n) of the linear model, scaled to c = w x in N m s.

    w x = I_yaw alpha_dot - (H_w + H_f) lean - H_f tilt up to scale; the scale makes the alpha_dot
    coefficient I_yaw = k_diam M R^2 + I_fly_diam. Raises DesignError unless exactly one
    direction is uncontrollable (e.g. a flywheel at rest cannot steer: more are).
    """
    W = uncontrollable_directions(lm.A, lm.B)
    if W.shape[0] != 1:
        raise DesignError(f"{W.shape[0]} uncontrollable directions (expected 1, the yaw momentum): "
                          "is the flywheel spinning (flywheel_rate != 0)?")
    w = W[0]
    i_ad = lm.index("alpha_dot")
    if abs(w[i_ad]) < 1e-9 * np.abs(w).max():
        raise DesignError("the uncontrollable direction is not the yaw momentum (no alpha_dot component)")
    I_yaw = pv["k_diam"] * pv["M"] * pv["R"] ** 2 + pv["I_fly_diam"]
    return w * (I_yaw / w[i_ad])


def reference_equilibria(lm: LinearModel, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """N_x (n x 4), N_u (m x 4): the equilibrium per unit of each reference (heading [rad],
    heading rate [rad/s], speed [m/s], yaw momentum c [N m s]), as deviations from lm's point.

    Solves A x + B u = e_alpha r_dot (every derivative unchanged except d alpha/dt, by the heading
    rate), heading = C_heading x, speed = C_speed x, c = w x, exactly (DesignError if inconsistent).
    """
    A, B = lm.A, lm.B
    n, m = B.shape
    ia = lm.index("alpha")
    c_heading, c_speed = lm.C[lm.y_names.index("heading")], lm.C[lm.y_names.index("speed")]
    M = np.block([[A, B], [c_heading[None, :], np.zeros((1, m))], [c_speed[None, :], np.zeros((1, m))],
                  [w[None, :], np.zeros((1, m))]])
    Nx, Nu = np.zeros((n, 4)), np.zeros((m, 4))
    for j in range(4):
        rhs = np.zeros(n + 3)
        if j == 1:
            rhs[ia] = 1.0  # d alpha / dt changes by 1
        else:
            rhs[n + {0: 0, 2: 1, 3: 2}[j]] = 1.0
        sol, *_ = np.linalg.lstsq(M, rhs, rcond=None)
        if np.abs(M @ sol - rhs).max() > 1e-8 * max(1.0, np.abs(sol).max()):
            raise DesignError(f"no equilibrium for the reference {REFERENCES[j]}")
        Nx[:, j], Nu[:, j] = sol[:n], sol[n:]
    return Nx, Nu


@dataclass
class Design:
    """Everything the controller FMU is built from, plus what the design found."""

    scene: str
    speed: float
    g: float
    rate: float  # operating point: heading rate [rad/s]
    tilt: float  # ... and flywheel tilt [rad]
    x0: list  # the operating point's state (plant-model order, absolute)
    u0: list  # ... and commands
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
    w: list  # the conserved row: c = w x [N m s]
    tilt_max: float
    drive_max: float
    max_deviation: dict = field(default_factory=dict)
    eig_plant: list = field(default_factory=list)
    eig_regulator: list = field(default_factory=list)
    eig_observer: list = field(default_factory=list)

    def matrices(self) -> dict[str, np.ndarray]:
        return {k: np.array(getattr(self, k), dtype=float)
                for k in ("A", "B", "C", "y0", "K", "L", "Nx", "Nu", "w", "x0", "u0")}

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(asdict(self), indent=1) + "\n")
        return path

    @classmethod
    def load(cls, path: str | Path) -> "Design":
        return cls(**json.loads(Path(path).read_text()))

    def feedback_gain(self, gain_scale: float = 1.0) -> np.ndarray:
        """K_eff (m x n) of u = -K_eff x_hat at zero heading, turn and speed references: the
        regulator plus the yaw-momentum equilibrium, u = N_u,c c - s K (x_hat - N_x,c c), c = w x_hat."""
        m = self.matrices()
        w = m["w"][None, :]
        return gain_scale * m["K"] @ (np.eye(len(self.x_names)) - m["Nx"][:, 3:4] @ w) - m["Nu"][:, 3:4] @ w


def _complex_list(ev) -> list:
    ev = np.asarray(ev)
    ev = ev[np.lexsort((ev.imag, ev.real))]
    return [[float(e.real), float(e.imag)] for e in ev]


def design(spec: ModelSpec, speed: float = 1.5, values: dict[str, float] | None = None,
           max_deviation: dict[str, float] | None = None, tilt_weight: float = TILT_WEIGHT,
           sensor_noise: dict[str, float] | None = None, yaw_momentum_noise: float = YAW_MOMENTUM_NOISE,
           tilt_max: float = TILT_MAX,
           drive_fraction: float = DRIVE_FRACTION, scene: str = "", tilt: float = 0.0,
           rate: float = 0.0) -> Design:
    """Design the compensator for the wheel `spec` (gravity + gyrover) at the steady turn of centre
    speed `speed` [m/s], heading rate `rate` [rad/s] and flywheel tilt `tilt` [rad] (default:
    straight upright rolling, flywheel untilted).

    values: parameter values by name (defaults: the spec's start values, with the scene's g);
    max_deviation, tilt_weight (the largest tilt_cmd wanted in normal use, rad; Bryson's R) and
    sensor_noise override MAX_DEVIATION, TILT_WEIGHT and SENSOR_NOISE; tilt_max and
    drive_fraction set the saturations.
    Returns a Design whose matrices are in the plant model's state order (Design.x_names).
    Raises DesignError if the model is not controllable as expected.
    """
    op = steady_turn(spec, speed, rate, tilt, values)
    lm = _plant_model(spec, op)
    A, B, C = lm.A, lm.B, lm.C
    pv = dict(zip([q.name for q in spec.parameters], parameter_values(spec, values)))
    drive_max = drive_fraction * pv["m_fly"] * pv["g"] * pv["L_pend"]
    dev = {**MAX_DEVIATION, **(max_deviation or {})}
    Q = np.diag([1.0 / dev[n] ** 2 for n in lm.x_names])
    R = np.diag([1.0 / tilt_weight**2, 1.0 / drive_max**2])
    w = yaw_momentum_row(lm, pv)
    T = controllable_basis(A, B)
    K = lqr(T.T @ A @ T, T.T @ B, T.T @ Q @ T, R) @ T.T
    # Kalman filter: process noise through the inputs (a tenth of their range) plus a floor
    # plus the nonlinear drift of the yaw momentum, which the linear model holds constant: without
    # it the filter would trust its initial c for ever (the initial lean's c is 0.035 N m s)
    v = w / (w @ w)
    W = (B @ np.diag([(0.1 * tilt_max) ** 2, (0.1 * drive_max) ** 2]) @ B.T + 1e-6 * np.eye(len(A))
         + yaw_momentum_noise**2 * np.outer(v, v))
    noise = {**SENSOR_NOISE, **(sensor_noise or {})}
    V = np.diag([noise[n] ** 2 for n in lm.y_names])
    S = solve_continuous_are(A.T, C.T, W, V)
    L = S @ C.T @ np.linalg.inv(V)
    Nx, Nu = reference_equilibria(lm, w)
    d = Design(
        scene=scene, speed=float(speed), g=float(pv["g"]), rate=float(rate), tilt=float(tilt),
        x0=lm.x0.tolist(), u0=op.u.tolist(), x_names=lm.x_names, y_names=lm.y_names,
        u_names=lm.u_names, A=A.tolist(), B=B.tolist(), C=C.tolist(), y0=lm.y0.tolist(), K=K.tolist(),
        L=L.tolist(), Nx=Nx.tolist(), Nu=Nu.tolist(), w=w.tolist(), tilt_max=float(tilt_max),
        drive_max=float(drive_max), max_deviation=dev, eig_plant=_complex_list(np.linalg.eigvals(A)),
        eig_observer=_complex_list(np.linalg.eigvals(A - L @ C)))
    d.eig_regulator = _complex_list(np.linalg.eigvals(A - B @ d.feedback_gain()))
    return d


def closed_loop_matrix(d: Design, plant: LinearModel | None = None, gain_scale: float = 1.0) -> np.ndarray:
    """The linear closed loop [x; x_hat] of the compensator with a plant model (default: the design's).

    x' = A_p x + B_p u,  x_hat' = A_p x_hat + B_p u + L (C_p x - C_p x_hat),  u = -K_eff x_hat
    (references zero, no saturation, continuous time: the loop the co-simulation approaches as
    its step -> 0). The observer runs the wheel's own equations (controller/compensator.py), so
    its linear model is the plant's wherever the plant is; K_eff: Design.feedback_gain.
    """
    m = d.matrices()
    A, B, C = (m["A"], m["B"], m["C"]) if plant is None else (plant.A, plant.B, plant.C)
    K, L = d.feedback_gain(gain_scale), m["L"]
    return np.block([[A, -B @ K], [L @ C, A - B @ K - L @ C]])


def sampled_closed_loop(d: Design, step: float, plant: LinearModel | None = None, gain_scale: float = 1.0) -> np.ndarray:
    """Phi: [x; x_hat](t + h) = Phi [x; x_hat](t) for the loop co-simulated with step h (Jacobi).

    Each FMU integrates exactly over [t, t + h] with its inputs held: the plant sees the command
    u(t) = -K_eff x_hat(t); the controller sees y(t) = C x(t), and its own command follows its
    state continuously. So Phi = [[e^(A h), -G_B(h) K_eff], [G_L(h), e^(A_c h)]] with
    A_c = A - B K_eff - L C, G_B(h) = int_0^h e^(A s) ds B, G_L(h) = int_0^h e^(A_c s) ds L C
    (A, B, C: the plant model's, as in closed_loop_matrix). Stable iff its spectral radius
    (without the conserved direction's 1) is < 1: the linear prediction of the longest step.
    """
    m = d.matrices()
    A, B, C = (m["A"], m["B"], m["C"]) if plant is None else (plant.A, plant.B, plant.C)
    K, L = d.feedback_gain(gain_scale), m["L"]
    n = len(A)

    def exp_and_integral(M: np.ndarray, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(e^(M h), int_0^h e^(M s) ds N) from one matrix exponential (Van Loan)."""
        k = N.shape[1]
        big = np.zeros((n + k, n + k))
        big[:n, :n], big[:n, n:] = M, N
        E = expm(big * step)
        return E[:n, :n], E[:n, n:]

    Pp, Gp = exp_and_integral(A, B)
    Pc, Gc = exp_and_integral(A - B @ K - L @ C, L @ C)
    return np.block([[Pp, -Gp @ K], [Gc, Pc]])


def sampled_spectral_radius(d: Design, step: float, plant: LinearModel | None = None, gain_scale: float = 1.0) -> float:
    """Spectral radius of sampled_closed_loop without the conserved direction (its eigenvalue 1,
    the one nearest to 1 is dropped): < 1 iff the co-simulated linear loop is stable at `step`."""
    z = np.linalg.eigvals(sampled_closed_loop(d, step, plant, gain_scale))
    return float(np.abs(np.delete(z, np.argmin(np.abs(z - 1.0)))).max())
