"""Flight: the wheel leaves the ground where F_n reaches 0 and lands with an impact (mode 2 of
model/contact_modes.py; docs/effects.md, "Flight").

In flight the wheel is a free rigid body under gravity (tilted on a slope) and air drag, carrying
the effects' bodies and motors (the Gyrover's assembly), coordinates (x, y, z, alpha, beta, gamma)
and the effects' own, speeds (x_dot, y_dot, z_dot, alpha_dot, beta_dot, gamma_dot, the effects'
free rates), its equations those of model/flight_system.py (the same Lagrangian with the centre's
height free). The hybrid state gains three
local states: `z_centre`, `z_dot` (the centre's height and vertical velocity; in rolling and sliding
their derivatives are those of z = R sin(beta), so they follow the holonomic contact, and every
entry to a contact mode sets them from it exactly) and `last_impulse` (N s, the normal impulse of
the last touchdown, zero derivative).

One event, `contact_flight` (action "update"), switches both ways; its indicator is
    rolling:           F_n of the mode        (lift-off where it reaches 0)
    sliding:           F_n of the mode where D / W_nn > PAINLEVE_MARGIN (model/painleve.py), else 1
    flight:            h + TOUCH_SLACK R + sqrt(R/g) max(u_n, 0)  (touchdown where h = z - R sin(beta)
                         reaches -TOUCH_SLACK R moving down: u_n = dh/dt the contact point's vertical
                         velocity; positive while it rises; the slack, 1e-15 R, makes the indicator
                         > 0 on the ground, so a body that starts flight there and falls back,
                         rather than rising, still crosses it: an impact at once, never a sink)
The update:
- lift-off: velocities continuous (x_dot, y_dot the mode's centre velocity, z_dot = R cos(beta)
  beta_dot), z = R sin(beta); the flight indicator is then TOUCH_SLACK R > 0, rising (the free body's
  contact point accelerates away from the ground once the constraint would have to pull);
- touchdown: the impulse of model/impact.py (Coulomb friction integrated over the impulse, the
  normal impulse of a Kelvin-Voigt contact in its rigid limit) on the Delassus matrix W = J M^-1 J^T
  (M the flight speeds' mass matrix, the Hessian of T; J = d u / d w, u the contact point's
  velocity, rows x, y, z) with mu the static coefficient, e = restitution (a frictionless
  touchdown's) and v_rest = V_REST sqrt(g R): a slower
  rebound becomes a persistent contact, which ends a bouncing wheel's series of impacts. After it:
  flight again if the contact point leaves (u_n+ > 0); else rolling if it stopped tangentially
  and rolling holds there (the contact_slip indicator > 0 and F_n > 0), else sliding (d along the
  slip, or -F_t where it is 0) if F_n > 0 in sliding or sliding is past the Painleve limit (there
  the event painleve stops the run: F_n < 0 with D <= 0 is no lift-off), else flight from the
  ground (h = 0; the constraint would pull).
  z, z_dot are set from the constraint; the impact's energy loss -dT (>= 0) is added to
  dissipated_energy, the driven coordinates' motors' impulsive work T(w+) - T(w-) - dT to
  actuator_work; impact_impulse = P_n.
Stiction laws (rolling_resistance, spin_friction: limits c F_n) do nothing in flight (F_n = 0, their
holding forces 0); the lift-off leaves them sliding with their rate's sign (a stuck law would
freeze its rate, stiction.stuck_rate_rows), the touchdown sets m = sign(rate) as at the start.
After every update the indicator of the new mode is >= 0 (F_n > 0 is tested before a contact mode
is chosen; h = 0 after a lift-off or a bounce, and the bounce's u_n > 0).
Rolling reaches F_n = 0 with the friction it needs, |F_t|, still finite in general, so the friction
limit mu F_n is met first: a wheel leaves the ground from sliding (rolling -> sliding -> flight,
each switch located); rolling -> flight directly only where F_t vanishes with F_n.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import casadi as ca

from gyrowheel.model.contact_modes import friction_direction, state_rows, unit_vector
from gyrowheel.model.context import BREAKAWAY, State, WheelContext
from gyrowheel.model.flight_system import free_system
from gyrowheel.model.impact import generalised_impact
from gyrowheel.model.kinematics import norm
from gyrowheel.model.painleve import painleve_gap
from gyrowheel.model.spec import SPEED_OF_LIGHT, Event, Quantity

ROLLING, SLIDING, FLIGHT = 0, 1, 2
V_REST = 1e-3  # rebound speeds below V_REST sqrt(g R) end in a persistent contact
TOUCH_SLACK = 1e-15  # the touchdown indicator's offset, in R: > 0 on the ground, so a sink is a crossing;
# a landing that ends on the ground lifts the centre by it: M g TOUCH_SLACK R, 3e-15 J for the paper wheel
ABOUT = (" With on_lift_off = \"fly\" the wheel leaves the ground where the normal force reaches 0 and flies "
         "as a free rigid body under gravity; at touchdown an impact (a spring-damper contact's "
         "rigid limit with Coulomb friction, never creating energy) lands it rolling or sliding or bounces it (event contact_flight; outputs "
         "height, vz, impact_impulse; contact_mode 2 in flight).")


@dataclass
class FlightContact:
    """What contact_forces declares for on_lift_off = "fly": the restitution parameter, the local
    states z_centre (m), z_dot (m/s), impact_impulse (N s) and the start values' symbols."""

    e: ca.SX
    z: State
    vz: State
    impulse: State
    height0: ca.SX
    vz0: ca.SX

    @property
    def states(self) -> list[State]:
        return [self.z, self.vz, self.impulse]


def flight_starts() -> list[Quantity]:
    """The flight mode's start values: height (m, >= 0; > 0 starts the wheel in flight) and vz
    (m/s; 0 unless height > 0). The scene reader checks their limits (fmu_build/scene.py), the
    FMU again at initialisation (declare_flight)."""
    return [Quantity("height", "m", "height of the lowest rim point above the ground; > 0 at the start: "
                     "the wheel starts in flight", 0.0, minimum=0.0),
            Quantity("vz", "m/s", "vertical velocity of the centre (a start value in flight only: 0 unless "
                     "height > 0)", 0.0, minimum=-SPEED_OF_LIGHT, maximum=SPEED_OF_LIGHT)]


def declare_flight(ctx: WheelContext, restitution: ca.SX) -> FlightContact:
    """Add the flight mode's states and start values to ctx (after declare_sliding); return it
    (also as ctx.flight). restitution: the parameter symbol (1, 0..1)."""
    kin, R = ctx.kin, ctx.par["R"]
    rate = ctx.natural_rate()

    def local(name, unit, text, nominal):
        st = State(Quantity(name, unit, text), ca.SX.sym(name), ca.SX(0), output=False,
                   nominal=nominal, start_expr=ca.SX(0))  # init: set by flight_init
        ctx.states.append(st)
        return st

    z = local("z_centre", "m", "centre height (free in flight, R sin(beta) in contact)", R)
    vz = local("z_dot", "m/s", "centre vertical velocity (free in flight, from the contact in contact)", R * rate)
    imp = local("last_impulse", "N.s", "normal impulse of the last touchdown", ctx.par["M"] * R * rate)
    z.derivative = kin.centre_velocity[2]  # d/dt R sin(beta): follows the contact
    vz.derivative = ctx.acceleration(kin.centre)[2]
    starts = flight_starts()
    syms = [ca.SX.sym(q.name + "_0") for q in starts]
    ctx.extra_starts += list(zip(starts, syms))
    # restitution's range is checked with every parameter's (Effect.declare)
    ctx.check_true(syms[0] >= 0, "height must be >= 0 (the lowest rim point cannot start below the ground)")
    ctx.check_true(ca.logic_or(syms[0] > 0, syms[1] == 0),
                   "vz must be 0 unless height > 0 (in contact the centre's vertical velocity follows the lean rate)")
    fl = FlightContact(restitution, z, vz, imp, syms[0], syms[1])
    ctx.flight = fl
    return fl


class Flight:
    """The flight mode's equations in the hybrid state x (nx): speeds, binder, ode rows
    (model/flight_system.py: the free wheel and every body, coordinate and actuator of the effects)."""

    def __init__(self, ctx: WheelContext, x: ca.SX):
        sl, fl, P = ctx.sliding, ctx.flight, ctx.par
        self.ctx, self.x = ctx, x
        fs = free_system(ctx)
        c = ctx.coords
        self.free = [k for k in c if k.free]  # x, y, the angles, the effects' free coordinates
        self.driven = [k for k in c if not k.free]
        # placeholders -> the hybrid state's symbols (coordinates and independent speeds are states)
        ph = [c[0].qd, c[1].qd, fs.z, fs.z_dot] + [k.q for k in self.driven if k.value is not None]
        val = [sl.vx.sym, sl.vy.sym, fl.z.sym, fl.vz.sym] + [k.value for k in self.driven if k.value is not None]
        ph, val = ca.vertcat(*ph), ca.vertcat(*val)

        def to_state(e):
            return ca.substitute(ca.SX(e), ph, val)
        self.nf = fs.n_free  # x, y, z, the angles, the effects' free coordinates
        self.qf = to_state(fs.q[:self.nf])
        self.wf = to_state(fs.qd[:self.nf])  # x_dot, y_dot, z_dot, the angle rates, the effects' free rates
        self.qdd, self.T, self.V, self.P_diss, self.P_act, self.tau_driven = (
            to_state(e) for e in (fs.qdd, fs.T, fs.V, fs.P_diss, fs.P_act, fs.tau_driven))
        self.height = fl.z.sym - P["R"] * ca.sin(c[3].q)

    def rim_velocity(self) -> ca.SX:
        """The velocity (3, m/s, ground axes) of the wheel's lowest rim point, the material point
        that touches the ground in contact: the centre's free velocity plus omega x R l (eq. 14);
        omega in alpha, beta and the angle rates (state symbols)."""
        return self.wf[0:3] + ca.cross(self.ctx.kin.omega, self.ctx.par["R"] * self.ctx.kin.l)

    def speed_rows(self) -> list[int]:
        """Rows of x holding the flight speeds wf (x_dot, y_dot, z_dot and the independent speeds)."""
        sl, fl = self.ctx.sliding, self.ctx.flight
        r_vx, r_vy = state_rows(self.x, sl.states)[0:2]
        r_vz = state_rows(self.x, [fl.vz])[0]
        rest = [next(j for j in range(self.x.numel()) if ca.is_equal(self.x[j], self.wf[i]))
                for i in range(3, self.nf)]
        return [r_vx, r_vy, r_vz] + rest

    def bind(self, expr: ca.SX) -> ca.SX:
        """Placeholders -> the flight mode's expressions: rates (the driven ones prescribed),
        accelerations, driven values, T, V, the power the free body's laws dissipate (air drag),
        the actuators' power, F_n = 0 (the contact force is 0 in flight)."""
        ctx = self.ctx
        holds = [law.hold for law in ctx.stick_slip]  # the stiction laws' holding forces: 0 (their limit is)
        c = ctx.coords
        driven_q = [k for k in self.driven if k.value is not None]
        ph = ca.vertcat(c[0].qd, c[1].qd, *[k.qd for k in self.driven], ctx.all_qdd(), *[k.q for k in driven_q],
                        ctx.late["T"], ctx.late["V"], ctx.late["P_diss"], ctx.late["P_act"], ctx.Fn, ctx.Fc, *holds)
        val = ca.vertcat(self.wf[0:2], *[k.rate for k in self.driven], self.qdd[0:2], self.qdd[3:],
                         *[k.value for k in driven_q], self.T, self.V, self.P_diss, self.P_act, 0, ca.SX.zeros(3),
                         ca.SX.zeros(len(holds)))
        expr = ca.SX(expr)
        for _ in range(4):
            if not ca.depends_on(ca.vec(expr), ph):
                break
            expr = ca.substitute(expr, ph, val)
        return expr

    def ode(self, n_mech: int) -> ca.SX:
        """x_dot in flight (nx): the coordinates' rates, the free system's accelerations
        (model/flight_system.py: gravity, tilted on a slope, air drag, the Gyrover's assembly and
        motors), z_centre' = z_dot, every other state its own equation in flight (dissipated_energy:
        the drag's loss; actuator_work: the motors' power; the tilt servo; the contact's modes and
        directions constant)."""
        ctx, fl = self.ctx, self.ctx.flight
        nq = len(self.free)  # x, y and the angle coordinates (no z: its rows are local states)
        out = ca.SX.zeros(self.x.numel())
        out[0:nq] = ca.vertcat(self.wf[0:2], self.wf[3:])
        out[nq:n_mech] = self.qdd[3:self.nf]
        rows = {id(st): n_mech + i for i, st in enumerate(ctx.states)}
        for st in ctx.states:
            if st.derivative is not None:
                out[rows[id(st)]] = self.bind(st.derivative)
        r_vx, r_vy = state_rows(self.x, ctx.sliding.states)[0:2]  # x_dot, y_dot: a slope, drag
        out[r_vx], out[r_vy] = self.qdd[0], self.qdd[1]
        out[rows[id(fl.z)]] = fl.vz.sym
        out[rows[id(fl.vz)]] = self.qdd[2]
        return out


def flight_event(ctx: WheelContext, x: ca.SX, bind_r: Callable, bind_s: Callable, flight: Flight,
                 Fc: ca.SX) -> Event:
    """The event contact_flight (module docstring): indicator and update, expressions of (t, x, u, p).

    x: the hybrid state (nx); bind_r, bind_s: the rolling and sliding bindings; flight: the flight
    mode's equations; Fc: the contact force (3, N) in placeholders."""
    sl, fl, P = ctx.sliding, ctx.flight, ctx.par
    r_vx, r_vy, r_mode, r_dx, r_dy = state_rows(x, sl.states)
    r_z, r_vz, r_imp = state_rows(x, fl.states)
    mode = sl.mode.sym
    R, beta = P["R"], ctx.q[3]
    Fn_r, Fn_s = bind_r(Fc)[2], bind_s(Fc)[2]
    # flight: h + TOUCH_SLACK R + tau max(u_n, 0) (u_n = dh/dt, the contact point's vertical velocity;
    # tau = sqrt(R/g)): h + slack where the wheel comes down, positive on the ground and once it rises
    # (after a bounce, and at once after a lift-off, where h = 0 and u_n = 0 to rounding), so only a
    # descent reaches 0, whether it starts above the ground or on it
    u = flight.rim_velocity()
    tau = 1 / ctx.natural_rate()
    # sliding past the Painleve limit (gap <= 0) has F_n = -N / D < 0 where the contact point is
    # driven into the ground: no lift-off (the event painleve stops the run there)
    gap = painleve_gap(ctx, bind_s, friction_direction(ctx, sl))
    lifts = ca.if_else(gap > 0, Fn_s, 1)
    indicator = ca.if_else(mode < 0.5, Fn_r, ca.if_else(mode < 1.5, lifts,
                                                        flight.height + TOUCH_SLACK * R + tau * ca.fmax(u[2], 0)))
    z_c, vz_c = R * ca.sin(beta), R * ca.cos(beta) * ctx.qd[3]  # the contact's z, z_dot (beta_dot a state)

    # lift-off: velocities continuous, z on the constraint
    x_l = ca.SX(x)
    vc_r = bind_r(ctx.qd[0:2])
    x_l[r_vx] = ca.if_else(mode < 0.5, vc_r[0], x[r_vx])
    x_l[r_vy] = ca.if_else(mode < 0.5, vc_r[1], x[r_vy])
    x_l[r_z], x_l[r_vz], x_l[r_mode] = z_c, vz_c, FLIGHT

    # touchdown: the impact in the flight speeds w
    rows_w = flight.speed_rows()  # (x_dot, y_dot, z_dot, alpha_dot, beta_dot, gamma_dot, the effects' free rates)
    w = flight.wf
    M_w = ca.hessian(flight.T, w)[0]
    J = ca.jacobian(u, w)
    v_rest = V_REST * R * ctx.natural_rate()
    w_plus, res = generalised_impact(M_w, J, w, fl.e, sl.mu, v_rest)
    x_b = ca.SX(x)  # the state just after the impulse, still flying
    x_b[rows_w] = w_plus
    x_b[r_imp] = res.P[2]
    lost = [j for j, st in enumerate(ctx.states) if st.quantity.name == "dissipated_energy"]
    if lost:
        row = x.numel() - len(ctx.states) + lost[0]
        x_b[row] = x[row] - res.dT
    work = [j for j, st in enumerate(ctx.states) if st.quantity.name == "actuator_work"]
    if work:  # driven coordinates (the Gyrover's flywheel, tilt) keep their rates through the impact:
        # their motors' impulsive torques work on them, T(w+) - T(w-) - dT (dT the contact's loss)
        row = x.numel() - len(ctx.states) + work[0]
        x_b[row] = x[row] + ca.substitute(flight.T, x, x_b) - flight.T - res.dT
    on = ca.SX(x_b)  # on the constraint
    on[r_z], on[r_vz] = z_c, ca.substitute(vz_c, x, x_b)
    x_roll = ca.SX(on)
    x_roll[r_mode] = ROLLING
    vc = ca.substitute(vc_r, x, x_roll)
    x_roll[r_vx], x_roll[r_vy] = vc[0], vc[1]
    F_t = bind_r(Fc)[0:2]
    g_roll = sl.mu * Fn_r * (1 + BREAKAWAY) - norm(F_t)
    rolls = ca.logic_and(res.sticking, ca.logic_and(ca.substitute(g_roll, x, x_roll) > 0,
                                                      ca.substitute(Fn_r, x, x_roll) > 0))
    x_slide = ca.SX(on)
    x_slide[r_mode] = SLIDING
    v_slip = ca.substitute(u[0:2], x, x_b)
    d = ca.if_else(ca.dot(v_slip, v_slip) > 0, unit_vector(v_slip), ca.substitute(-unit_vector(F_t), x, x_roll))
    x_slide[r_dx], x_slide[r_dy] = d[0], d[1]
    # past the Painleve limit it lands sliding whatever F_n's sign, and the event painleve stops it
    slides = ca.logic_or(ca.substitute(Fn_s, x, x_slide) > 0, ca.substitute(gap, x, x_slide) <= 0)
    # a persistent contact (rebound below v_rest: target u_n+ = 0) never bounces, whatever the
    # rounding of u_n+ (a rounded +1e-17 would fly on at h = 0 and sink before the next touchdown)
    bounces = ca.logic_and(res.u_plus[2] > 0, ca.logic_not(res.persistent))
    # flight on from the ground (the constraint would pull): h = 0, so the indicator starts at
    # TOUCH_SLACK R > 0 and a fall back is a touchdown
    x_t = ca.if_else(bounces, x_b, ca.if_else(rolls, x_roll, ca.if_else(slides, x_slide, on)))
    # stiction laws (rolling_resistance, spin_friction; limits c F_n): sliding with the rate's sign
    # in flight, where the limit is 0 (a stuck law would freeze its rate: stiction.stuck_rate_rows);
    # on landing m = sign(r), as at the start, 0 (stuck) for a rate of exactly 0
    n_mech = x.numel() - len(ctx.states)
    for law in ctx.stick_slip:
        row = n_mech + next(i for i, st in enumerate(ctx.states) if st is law.mode)
        r_l = ca.substitute(flight.bind(law.rate), x, x_l)
        x_l[row] = ca.if_else(r_l >= 0, 1, -1)
        r_t = ca.substitute(flight.bind(law.rate), x, x_t)
        x_t[row] = ca.if_else(x_t[r_mode] > 1.5, ca.if_else(r_t >= 0, 1, -1), ca.sign(r_t))
    update = ca.if_else(mode < 1.5, x_l, x_t)
    flag = Quantity("contact_flown", "", "true once the wheel has left the ground or landed")
    return Event("contact_flight", indicator, "update", flag, update)


def flight_init(ctx: WheelContext, x: ca.SX, init: ca.SX, s_by_name: dict) -> ca.SX:
    """init (nx) with z_centre, z_dot filled in: on the contact (z = R sin(beta), z_dot = R cos(beta)
    beta_dot) at height 0, else z = R sin(beta) + height, z_dot = vz and the mode flight."""
    sl, fl, R = ctx.sliding, ctx.flight, ctx.par["R"]
    r_mode = state_rows(x, [sl.mode])[0]
    r_z, r_vz, _ = state_rows(x, fl.states)
    init = ca.SX(init)
    beta, beta_dot = init[3], init[6]
    height, vz = s_by_name["height"], s_by_name["vz"]
    flying = height > 0
    init[r_z] = R * ca.sin(beta) + height
    init[r_vz] = ca.if_else(flying, vz, R * ca.cos(beta) * beta_dot)
    init[r_mode] = ca.if_else(flying, FLIGHT, init[r_mode])
    return init


def flight_outputs(ctx: WheelContext, flight: Flight, by_name: dict) -> list[tuple[Quantity, ca.SX]]:
    """height (m, 0 in contact), vz (m/s; R cos(beta) beta_dot in contact, exactly) and impact_impulse (N s), height and vz being the start
    values' variables."""
    fl, mode = ctx.flight, ctx.sliding.mode.sym
    return [(by_name["height"], ca.if_else(mode > 1.5, flight.height, 0)),
            (by_name["vz"], ca.if_else(mode > 1.5, fl.vz.sym, ctx.par["R"] * ca.cos(ctx.q[3]) * ctx.qd[3])),
            (Quantity("impact_impulse", "N.s", "normal impulse of the last touchdown (0 before any)"), fl.impulse.sym)]


def flight_slip(ctx: WheelContext, flight: Flight) -> tuple[ca.SX, ca.SX]:
    """slip_long, slip_lat in flight (m/s): the lowest rim point's horizontal velocity along the
    heading (cos alpha, sin alpha) and across it, to the left; the sliding mode's slip velocity
    continued into the air, so a wheel started in flight reads its start values slip_long, slip_lat
    (the centre's horizontal velocity is the rolling one plus that slip, contact_init)."""
    u, a = flight.rim_velocity(), ctx.q[2]
    return u[0] * ca.cos(a) + u[1] * ca.sin(a), -u[0] * ca.sin(a) + u[1] * ca.cos(a)


def attitude_limit_event(ctx: WheelContext) -> Event:
    """The event flight_attitude_limit (terminate): in flight, the lean reaching beta_min (or pi -
    beta_min), where the Euler angles (alpha, beta, gamma) become singular (a wheel tumbling
    through flat in the air); the fall event is the contact modes' only. Indicator sin(beta) -
    sin(beta_min) in flight, 1 in contact."""
    flying = ctx.sliding.mode.sym > 1.5
    indicator = ca.if_else(flying, ca.sin(ctx.q[3]) - ca.sin(ctx.par["beta_min"]), 1)
    flag = Quantity("flat_in_flight", "", "true once the wheel lies flat in flight (beta <= beta_min or >= pi - "
                    "beta_min): its Euler angles are singular there, so the run stops (flight_attitude_limit)")
    return Event("flight_attitude_limit", indicator, "terminate", flag)
