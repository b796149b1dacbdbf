"""The controller FMU: the observer-based LQR of controller/design.py as a small CasADi system.

Inputs are the wheel FMU's outputs under their own names (alpha, alpha_dot, beta, beta_dot,
vx, vy, tilt), so a system file connects them name to name; outputs are the wheel's inputs
tilt_cmd and drive_torque. With r(t) = (heading_ref, speed_ref - v0) from the mission:

    y     = (beta - pi/2, beta_dot, alpha, alpha_dot, vx cos(alpha) + vy sin(alpha), tilt) - y0
    u     = sat(N_u r - gain_scale K (x_hat - N_x r))         (tilt_max, drive_max)
    x_hat' = A x_hat + B u + L (y - C x_hat)                  (states est_<plant state>)

The outputs depend on the states only (no direct feedthrough): no algebraic loop between the
two FMUs, whatever the master. K and L are parameters (K_<command>__<state>,
L_<state>__<measurement>); A, B, C, N_x, N_u, y0 are the design model, built in.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from controller.design import Design
from controller.mission import Mission, interpolate
from fmu_build.scene import Experiment
from model.spec import ModelSpec
from model.system import System

WHEEL_SIGNALS = (("alpha", 0.0, "rad", "heading (wheel output alpha)"),
                 ("alpha_dot", 0.0, "rad/s", "heading rate (wheel output alpha_dot)"),
                 ("beta", math.pi / 2, "rad", "lean angle, pi/2 upright (wheel output beta)"),
                 ("beta_dot", 0.0, "rad/s", "lean rate (wheel output beta_dot)"),
                 ("vx", 0.0, "m/s", "centre velocity x (wheel output vx)"),
                 ("vy", 0.0, "m/s", "centre velocity y (wheel output vy)"),
                 ("tilt", 0.0, "rad", "flywheel tilt (wheel output tilt)"))
STATE_UNITS = {"alpha": "rad", "beta": "rad", "theta_p": "rad", "tilt": "rad", "alpha_dot": "rad/s",
               "beta_dot": "rad/s", "gamma_dot": "rad/s", "theta_p_dot": "rad/s", "tilt_rate": "rad/s"}
EXPERIMENT = Experiment(stop_time=60.0, output_interval=0.01, solver="dopri5", rel_tol=1e-8,
                        abs_tol=1e-10, max_step=0.01)


def controller_system(d: Design, mission: Mission, name: str = "gyrover_controller") -> System:
    """The compensator as a System (model/system.py)."""
    m = d.matrices()
    sys = System(name, f"Gyrover balance and steering controller (LQR + Kalman observer, designed at "
                       f"{d.speed:g} m/s, g = {d.g:g} m/s2)",
                 about="Observer-based LQR from gyrowheel's controller/design.py: measurements in, "
                       "tilt_cmd and drive_torque out, saturated at the actuators' limits.")
    gain_scale = sys.parameter("gain_scale", 1.0, "1", "factor on the state-feedback gain K", minimum=0.0)
    tilt_max = sys.parameter("tilt_max", d.tilt_max, "rad", "saturation of tilt_cmd (gimbal stop)", minimum=0.0)
    drive_max = sys.parameter("drive_max", d.drive_max, "N.m", "saturation of drive_torque", minimum=0.0)
    v0 = sys.parameter("v0", d.speed, "m/s", "design speed (operating point of the linear model)")
    mt, mh, mv = [], [], []
    for k, (t, h, v) in enumerate(mission.points):
        mt.append(sys.parameter(f"mission_t_{k}", t, "s", f"time of mission point {k}"))
        mh.append(sys.parameter(f"mission_heading_{k}", h, "rad", f"heading reference at point {k}"))
        mv.append(sys.parameter(f"mission_speed_{k}", v, "m/s", f"speed reference at point {k}"))
    for k in range(len(mt) - 1):
        sys.check(mt[k + 1] - mt[k], f"mission_t_{k + 1} must be > mission_t_{k}")
    K = [[sys.parameter(f"K_{u}__{x}", m["K"][i, j], "1", f"state-feedback gain from est_{x} to {u}")
          for j, x in enumerate(d.x_names)] for i, u in enumerate(d.u_names)]
    L = [[sys.parameter(f"L_{x}__{y}", m["L"][i, j], "1", f"observer gain from the {y} residual to est_{x}")
          for j, y in enumerate(d.y_names)] for i, x in enumerate(d.x_names)]
    K, L = ca.blockcat(K), ca.blockcat(L)
    w = {n: sys.input(n, start, unit, desc) for n, start, unit, desc in WHEEL_SIGNALS}
    xhat = ca.vertcat(*[sys.state(f"est_{n}", 0.0, STATE_UNITS.get(n, "1"), f"observer estimate of the "
                                  f"deviation of {n} from the operating point") for n in d.x_names])
    y = ca.vertcat(w["beta"] - math.pi / 2, w["beta_dot"], w["alpha"], w["alpha_dot"],
                   w["vx"] * ca.cos(w["alpha"]) + w["vy"] * ca.sin(w["alpha"]), w["tilt"]) - ca.DM(m["y0"])
    heading_ref = interpolate(sys.t, mt, mh)
    speed_ref = interpolate(sys.t, mt, mv)
    # a heading error beyond what the tilt range can hold is clamped: balance keeps priority
    e_max = sys.parameter("heading_error_max", d.tilt_max / max(abs(m["Nx"][d.x_names.index("tilt"), 0]), 1e-9),
                          "rad", "largest heading error fed back (tilt_max / tilt per rad of heading)", minimum=0.0)
    i_alpha = d.x_names.index("alpha")
    heading_fb = xhat[i_alpha] - ca.fmin(ca.fmax(xhat[i_alpha] - heading_ref, -e_max), e_max)
    r = ca.vertcat(heading_fb, speed_ref - v0)
    u_raw = ca.mtimes(ca.DM(m["Nu"]), r) - gain_scale * ca.mtimes(K, xhat - ca.mtimes(ca.DM(m["Nx"]), r))
    u = ca.vertcat(ca.fmin(ca.fmax(u_raw[0], -tilt_max), tilt_max), ca.fmin(ca.fmax(u_raw[1], -drive_max), drive_max))
    xdot = ca.mtimes(ca.DM(m["A"]), xhat) + ca.mtimes(ca.DM(m["B"]), u) + ca.mtimes(L, y - ca.mtimes(ca.DM(m["C"]), xhat))
    for i in range(xhat.numel()):
        sys.der(xhat[i], xdot[i])
    sys.output("tilt_cmd", u[0], "rad", "commanded flywheel tilt (to the wheel's input tilt_cmd)")
    sys.output("drive_torque", u[1], "N.m", "drive-motor torque (to the wheel's input drive_torque)")
    sys.output("heading_error", w["alpha"] - heading_ref, "rad", "measured heading minus its reference")
    sys.output("heading_ref", heading_ref, "rad", "heading reference of the mission")
    sys.output("speed_ref", speed_ref, "m/s", "speed reference of the mission")
    sys.output("saturated", ca.if_else(ca.logic_or(ca.fabs(u_raw[0]) > tilt_max, ca.fabs(u_raw[1]) > drive_max), 1, 0),
               "1", "1 while a command is at its limit")
    return sys


def controller_spec(d: Design, mission: Mission, name: str = "gyrover_controller") -> ModelSpec:
    return controller_system(d, mission, name).spec()
