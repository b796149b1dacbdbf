"""The controller FMU: the gain-scheduled LQG of controller/schedule.py as a small CasADi system.

Inputs are the wheel FMU's outputs under their own names (alpha, alpha_dot, beta, beta_dot,
vx, vy, tilt), so a system file connects them name to name; outputs are the wheel's inputs
tilt_cmd and drive_torque. With the mission's references (controller/mission.py) heading_ref,
rate_ref (its turn rate) and speed_ref, and the scheduling variables s = (rate_ref, tilt_hat)
(clamped to the grid; bilinear weights over the grid points):

    y      = (beta - pi/2, beta_dot, alpha, alpha_dot, vx cos(alpha) + vy sin(alpha), tilt)
    x_hat' = f(x_hat, u) + L(s) (y - h(x_hat))      the wheel's own equations f, h (same CasADi
                                                     expressions as the wheel FMU), states est_<name>
    c      = w(s) (x_hat - x0(s))                   yaw momentum beyond the operating point's, N m s
    r      = (alpha_hat - clamp(alpha_hat - heading_ref), rate_ref - r0(s), speed_ref - v0, c)
    u      = sat(u0(s) + N_u(s) r - gain_scale K(s) (x_hat - x0(s) - N_x(s) r))   (tilt_max, drive_max)

x0(s), u0(s): the steady turn of the grid point (controller/operating_point.py); K, L, N_x, N_u, w:
its design (controller/design.py). The outputs depend on the states only (no direct
feedthrough): no algebraic loop between the two FMUs, whatever the master. The gains are built
in (the schedule has 45 designs); gain_scale, the saturations and the mission are parameters.
"""
from __future__ import annotations

import math

import casadi as ca

from gyrowheel.controller.mission import Mission, integrate, interpolate
from gyrowheel.controller.operating_point import measurement_exprs
from gyrowheel.controller.schedule import Schedule
from gyrowheel.fmu_build.scene import Experiment
from gyrowheel.model.linearise import parameter_values
from gyrowheel.model.spec import ModelSpec
from gyrowheel.model.system import System

WHEEL_SIGNALS = (("alpha", 0.0, "rad", "heading (wheel output alpha)"),
                 ("alpha_dot", 0.0, "rad/s", "heading rate (wheel output alpha_dot)"),
                 ("beta", math.pi / 2, "rad", "lean angle, pi/2 upright (wheel output beta)"),
                 ("beta_dot", 0.0, "rad/s", "lean rate (wheel output beta_dot)"),
                 ("vx", 0.0, "m/s", "centre velocity x (wheel output vx)"),
                 ("vy", 0.0, "m/s", "centre velocity y (wheel output vy)"),
                 ("tilt", 0.0, "rad", "flywheel tilt (wheel output tilt)"))
STATE_UNITS = {"alpha": "rad", "beta": "rad", "theta_p": "rad", "tilt": "rad", "alpha_dot": "rad/s",
               "beta_dot": "rad/s", "gamma_dot": "rad/s", "theta_p_dot": "rad/s", "tilt_rate": "rad/s"}
HEADING_ERROR_MAX = 0.3  # rad
LOST_MARGIN = math.radians(10.0)  # rad from flat
LOST_RATES = {"alpha_dot": 20.0, "theta_p_dot": 60.0, "tilt_rate": 60.0}  # rad/s
EXPERIMENT = Experiment(stop_time=60.0, output_interval=0.01, solver="dopri5", rel_tol=1e-8,
                        abs_tol=1e-10, max_step=0.01)


def hat_weights(s: ca.SX, grid: list[float]) -> list[ca.SX]:
    """Linear-interpolation weights of a uniform grid at s (clamped to it): they sum to 1."""
    step = grid[1] - grid[0]
    s = ca.fmin(ca.fmax(s, grid[0]), grid[-1])
    return [ca.fmax(0.0, 1.0 - ca.fabs(s - g) / step) for g in grid]


def wheel_model(wheel: ModelSpec, values: dict[str, float] | None, x_names: list[str]) -> ca.Function:
    """(x_hat, u) -> (f, h): the wheel's derivatives of the states x_names and its measurements,
    with the other states (x, y, gamma, energies: cyclic or diagnostic) at 0 and the parameters at
    their values."""
    x_hat, u = ca.SX.sym("x_hat", len(x_names)), ca.SX.sym("u", wheel.u.numel())
    full = [x_hat[x_names.index(n)] if n in x_names else ca.SX(0) for n in wheel.x_names]
    rows = [wheel.x_names.index(n) for n in x_names]
    h = ca.vertcat(*measurement_exprs(wheel).values())
    f = ca.Function("wheel", [wheel.x, wheel.u, wheel.p], [wheel.ode[rows], h])
    ode, y = f(ca.vertcat(*full), u, ca.DM(parameter_values(wheel, values)))
    return ca.Function("wheel_model", [x_hat, u], [ode, y])


def controller_system(schedule: Schedule, mission: Mission, wheel: ModelSpec,
                      wheel_values: dict[str, float] | None = None, name: str = "gyrover_controller") -> System:
    """The compensator as a System (model/system.py); wheel: the wheel's ModelSpec (its equations
    are the observer's model), wheel_values: its parameter values (default: the spec's)."""
    d0 = schedule.centre
    x_names = d0.x_names
    if d0.u_names != ["tilt_cmd", "drive_torque"] or list(d0.y_names) != list(measurement_exprs(wheel)):
        raise ValueError(f"the schedule's commands {d0.u_names} / measurements {d0.y_names} are not this controller's")
    sys = System(name, f"Gyrover balance and steering controller (gain-scheduled LQR + Kalman observer on the "
                       f"wheel's equations, {len(schedule.designs)} designs at {schedule.speed:g} m/s, "
                       f"g = {schedule.g:g} m/s2)",
                 about="Gain-scheduled LQG from gyrowheel's controller/schedule.py: measurements in, "
                       "tilt_cmd and drive_torque out, saturated at the actuators' limits.")
    gain_scale = sys.parameter("gain_scale", 1.0, "1", "factor on the state-feedback gain K", minimum=0.0)
    # at a tilt of pi/2 the flywheel's spin axis lies along the link (docs/system.md): no gimbal goes past it
    tilt_max = sys.parameter("tilt_max", d0.tilt_max, "rad", "saturation of tilt_cmd (gimbal stop), at most pi/2",
                             minimum=0.0, maximum=math.pi / 2)
    drive_max = sys.parameter("drive_max", d0.drive_max, "N.m", "saturation of drive_torque", minimum=0.0)
    v0 = schedule.speed
    mt, mr, mv = [], [], []
    for k, (t, rate, v) in enumerate(mission.points):
        mt.append(sys.parameter(f"mission_t_{k}", t, "s", f"time of mission point {k}"))
        mr.append(sys.parameter(f"mission_rate_{k}", rate, "rad/s", f"heading-rate reference at point {k}"))
        mv.append(sys.parameter(f"mission_speed_{k}", v, "m/s", f"speed reference at point {k}"))
    for k in range(len(mt) - 1):
        sys.check(mt[k + 1] - mt[k], f"mission_t_{k + 1} must be > mission_t_{k}")
    e_max = sys.parameter("heading_error_max", HEADING_ERROR_MAX, "rad", "largest heading error fed back",
                          minimum=0.0)

    sig = {n: sys.input(n, start, unit, desc) for n, start, unit, desc in WHEEL_SIGNALS}
    x0_centre = d0.matrices()["x0"]
    xhat = ca.vertcat(*[sys.state(f"est_{n}", float(x0_centre[i]), STATE_UNITS.get(n, "1"),
                                  f"observer estimate of {n}") for i, n in enumerate(x_names)])
    heading_ref = integrate(sys.t, mt, mr)
    rate_ref = interpolate(sys.t, mt, mr)
    speed_ref = interpolate(sys.t, mt, mv)

    # scheduling: bilinear weights over (rate_ref, estimated tilt)
    tilt_hat = xhat[x_names.index("tilt")]
    wr, wt = hat_weights(rate_ref, schedule.rates), hat_weights(tilt_hat, schedule.tilts)

    def scheduled(key: str) -> ca.SX:
        table = schedule.table(key)
        total = ca.SX.zeros(*table.shape[2:]) if table.ndim > 3 else ca.SX.zeros(table.shape[2], 1)
        for i in range(len(schedule.rates)):
            for j in range(len(schedule.tilts)):
                total = total + wr[i] * wt[j] * ca.DM(table[i, j])
        return total

    K, L, Nx, Nu = (scheduled(k) for k in ("K", "L", "Nx", "Nu"))
    x0, u0, w = scheduled("x0"), scheduled("u0"), scheduled("w")
    c = ca.dot(w, xhat - x0)
    i_alpha = x_names.index("alpha")
    heading_fb = xhat[i_alpha] - ca.fmin(ca.fmax(xhat[i_alpha] - heading_ref, -e_max), e_max)
    r = ca.vertcat(heading_fb - x0[i_alpha], rate_ref - x0[x_names.index("alpha_dot")], speed_ref - v0, c)
    u_raw = u0 + ca.mtimes(Nu, r) - gain_scale * ca.mtimes(K, xhat - x0 - ca.mtimes(Nx, r))
    u = ca.vertcat(ca.fmin(ca.fmax(u_raw[0], -tilt_max), tilt_max), ca.fmin(ca.fmax(u_raw[1], -drive_max), drive_max))

    y = ca.vertcat(sig["beta"] - math.pi / 2, sig["beta_dot"], sig["alpha"], sig["alpha_dot"],
                   sig["vx"] * ca.cos(sig["alpha"]) + sig["vy"] * ca.sin(sig["alpha"]), sig["tilt"])
    f, h = wheel_model(wheel, wheel_values, x_names)(xhat, u)
    xdot = f + ca.mtimes(L, y - h)
    for i in range(xhat.numel()):
        sys.der(xhat[i], xdot[i])
    sys.output("tilt_cmd", u[0], "rad", "commanded flywheel tilt (to the wheel's input tilt_cmd)")
    sys.output("drive_torque", u[1], "N.m", "drive-motor torque (to the wheel's input drive_torque)")
    sys.output("heading_error", sig["alpha"] - heading_ref, "rad", "measured heading minus its reference")
    sys.output("heading_ref", heading_ref, "rad", "heading reference of the mission (integral of rate_ref)")
    sys.output("rate_ref", rate_ref, "rad/s", "heading-rate reference of the mission")
    sys.output("speed_ref", speed_ref, "m/s", "speed reference of the mission")
    sys.output("yaw_momentum", c, "N.m.s", "yaw momentum c beyond the scheduled operating point's")
    # the estimated lean within LOST_MARGIN of flat: the wheel is down (or the estimate is lost) and
    # the observer's model nears its singular flat pose: stop the run cleanly, as the wheel's fall does
    # ... or a rate has run away (a diverging loop spins the pendulum or the tilt: the observer's
    # equations would get stiff long before the lean is flat)
    rates = [(x_names.index(n), limit) for n, limit in LOST_RATES.items()]
    margin = ca.sin(xhat[x_names.index("beta")]) - math.sin(LOST_MARGIN)
    for i, limit in rates:
        margin = ca.fmin(margin, 1.0 - ca.fabs(xhat[i]) / limit)
    sys.event("lost", margin, "terminate", "lost",
              "true once the estimated lean is within 10 deg of flat or a rate beyond LOST_RATES "
              "(the controller has lost the wheel)")
    sys.output("saturated", ca.if_else(ca.logic_or(ca.fabs(u_raw[0]) > tilt_max, ca.fabs(u_raw[1]) > drive_max), 1, 0),
               "1", "1 while a command is at its limit")
    return sys


def controller_spec(schedule: Schedule, mission: Mission, wheel: ModelSpec,
                    wheel_values: dict[str, float] | None = None, name: str = "gyrover_controller") -> ModelSpec:
    return controller_system(schedule, mission, wheel, wheel_values, name).spec()
