"""Contact modes: the wheel rolls (mode 0) or slides (mode 1) in one ModelSpec (docs/effects.md,
"Sliding"); mode 2 (flight) is reserved.

Both modes come from the same T, V and forces (model/lagrangian.py, ConstrainedSystem.reduced):
- rolling: the rolling constraint eliminates the centre's horizontal velocity (x_dot, y_dot
  follow from the angle rates); the model of model/build.py;
- sliding: the contact point stays on the ground (z = R sin(beta), holonomic, as in rolling) but
  the centre's horizontal velocity (vx, vy) is free, and Coulomb friction of magnitude mu_k F_n
  opposes the contact point's slip velocity v_slip = (vx, vy) + (omega x R l)_xy. F_n is solved
  with the accelerations (an extra unknown, as for rolling resistance).

The state holds what the larger mode needs: the rolling state, then (among the effect states)
`x_dot`, `y_dot` (the centre's horizontal velocity; in rolling their derivative is the time
derivative of the rolling constraint's expressions, so they follow it), `contact_state` (the mode,
zero derivative) and `slip_dir_x`, `slip_dir_y` (a unit vector d in the ground plane, reseeded
only by the switch). ode = the mode's equations (if_else on the mode).

One event, `contact_slip` (action "update"), switches both ways; its indicator is
    rolling:  g_roll = mu F_n (1 + BREAKAWAY) - |F_t|   (F_t the friction the rolling constraint needs)
    sliding:  d . v_slip + min(max(-g_roll, 0) / (M sqrt(g / R)), SLIP_SEED v_scale / 2)
    flight:   1
(d the stored direction). The sliding indicator's second term (excess_slip) is the slip the friction
demand's excess over the limit would build in one natural time sqrt(R / g), capped at half the
friction direction's seed; it is 0 wherever rolling can hold, so a slip that dies out there is
located at d . v_slip = 0.
One indicator for both switches, as a stiction law's (model/stiction.py): after each update the
indicator of the new mode is >= 0 (to rounding) while the fired one was <= 0, so no switch is seen
as a crossing of the other mode's indicator in the same instant. The update:
- rolling -> sliding (always, the friction needed has reached mu F_n (1 + BREAKAWAY)): the centre
  velocity is set from the rolling constraint (velocities continuous, v_slip = 0), d = -F_t / |F_t|,
  the direction the contact point starts to slip in (the friction needed exceeds the friction
  available, so the slip grows along K d, d . K d > 0 for the contact's inverse inertia K);
- sliding, d . v_slip reached 0: the wheel rolls if |v_slip| <= SLIP_ZERO v_scale
  (v_scale = sqrt(g R) + |v_centre|) and the friction the rolling constraint needs is within
  mu F_n (1 + BREAKAWAY) once the residual slip is removed by a tangential impulse at the contact
  (the plastic limit of the sliding friction: dv = -M^-1 J^T (J M^-1 J^T)^-1 v_slip, energy lost
  1/2 v_slip . (J M^-1 J^T)^-1 v_slip, second order in the residual, added to dissipated_energy).
  Otherwise it slides on, the state unchanged but d reseeded along the slip, v_slip / |v_slip| (at
  v_slip exactly 0: -F_t / |F_t|): the slip has turned by 90 degrees from d, or it dies out where
  rolling cannot hold; the indicator is |v_slip| >= 0 after. (Projecting to v_slip = 0 and restarting
  along -F_t there made a wheel whose friction need hovers at the limit with mu_k = mu stop and
  restart every 4e-8 s: -F_t is the slip's direction only in the limit, and the friction keeps the
  seeded direction while |v_slip| < SLIP_SEED v_scale.)
Friction direction while sliding: e = (v_slip + SLIP_SEED v_scale d) / |...|: v_slip / |v_slip| to
SLIP_SEED v_scale / |v_slip| (exactly when v_slip is along d, as in every straight slide), and d at
v_slip = 0, where the slip starts. Its power, mu_k F_n e . v_slip (dissipated_power), is negative only
where a slip of the seed's size points against d; the sliding indicator keeps d . v_slip >=
-SLIP_SEED v_scale / 2, and e . v_slip >= -a over the slips with d . v_slip = -a, so the power is
>= -mu_k F_n SLIP_SEED v_scale / 2 (docs/effects.md, "The friction's power at a slip onset").

Chattering: a switch back to rolling needs the slip velocity to reach 0 along d after it has been
seen > 0 (the runtime fires only on > 0 -> <= 0), and rolling needs the friction to reach the limit
from strictly inside it, so every stick and every slip lasts a finite time; a slip that dies out
where rolling cannot hold goes on along its own direction instead of being restarted from 0 (above);
each event fires at most once per instant (the runtime's guard); the step budget bounds every call.
While rolling cannot hold, the sliding indicator is d . v_slip plus the excess term, so a slip may
only end where the friction demand is within the limit: at a slip onset with mu_k = mu the excess
starts at 0 and the slip grows like (t - t_slip)^2, staying for ~1e-7 s at the round-off of
v_slip (1e-15 m/s, a difference of rim and centre speeds); d . v_slip alone would cross 0 there at
random, each failed hold reseeding d along that noise (Euler's disk on mu = 0.3 with dopri5: a
switch every 1e-8 to 1e-7 s from t = 3.5189 s until the runtime's guard of 1000 events in one
step). The excess term grows from the onset at the excess's own rate, above that noise within
~1e-13 s. What follows such an onset is stiff for explicit solvers (Coulomb's direction turns at
~mu_k F_n |K| / (|v_slip| + SLIP_SEED v_scale)): docs/effects.md, "Sliding".
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import casadi as ca

from gyrowheel.model.context import BREAKAWAY, Force, State, WheelContext
from gyrowheel.model.kinematics import norm
from gyrowheel.model.lagrangian import ConstrainedSystem
from gyrowheel.model.spec import Event, Quantity

ROLLING, SLIDING, FLIGHT = 0, 1, 2
MODE_NAMES = ("rolling", "sliding", "flight")  # the Enumeration contact_mode's items, by value
ABOUT = (" With on_slip = \"slide\" the wheel also slides: past the friction limit mu F_n the centre's horizontal "
         "velocity is free and Coulomb friction mu_k F_n opposes the contact point's slip (outputs contact_mode, "
         "slip_long, slip_lat); it rolls again when the slip has died out and the friction needed is within "
         "mu F_n. Both switches are located state events (contact_slip).")
SLIP_ZERO = 1e-6  # |v_slip| / v_scale below which a slip that reached 0 along d counts as stopped
SLIP_SEED = 1e-8  # weight of d in the friction direction (v_slip + SLIP_SEED v_scale d)


@dataclass
class SlidingContact:
    """What the contact_forces effect declares for on_slip = "slide" (placeholders and states)."""

    mu: ca.SX
    mu_k: ca.SX
    vx: State
    vy: State
    mode: State
    dx: State
    dy: State
    slip_long0: ca.SX  # start values (symbols of ctx.extra_starts)
    slip_lat0: ca.SX

    @property
    def direction(self) -> ca.SX:
        return ca.vertcat(self.dx.sym, self.dy.sym)

    @property
    def states(self) -> list[State]:
        return [self.vx, self.vy, self.mode, self.dx, self.dy]


def slip_velocity(ctx: WheelContext) -> ca.SX:
    """Horizontal velocity of the wheel's material point at the contact (2, m/s) in placeholders:
    v_A + omega x (C - A), C - A = R l (eq. 14); zero in rolling (the rolling constraint)."""
    kin = ctx.kin
    return (kin.centre_velocity + ca.cross(kin.omega, ctx.par["R"] * kin.l))[0:2]


def velocity_scale(ctx: WheelContext) -> ca.SX:
    """sqrt(g R) (g floored at 1e-3 m/s^2) + |v_centre| (m/s), placeholders: the slip thresholds' unit."""
    return ctx.par["R"] * ctx.natural_rate() + norm(ctx.kin.centre_velocity)


def unit_vector(v: ca.SX) -> ca.SX:
    """v / |v|, 0 at v = 0 (no NaN)."""
    return v / ca.sqrt(ca.dot(v, v) + 1e-300)


def excess_slip(ctx: WheelContext, g_roll: ca.SX, v_scale: ca.SX) -> ca.SX:
    """min(max(-g_roll, 0) / (M sqrt(g / R)), SLIP_SEED v_scale / 2) (m/s): the slip velocity the
    friction demand's excess over the limit (g_roll = mu F_n (1 + BREAKAWAY) - |F_t|, N, the rolling
    indicator) builds in one natural time sqrt(R / g), capped at half the friction direction's seed
    (v_scale in m/s, velocity_scale); 0 where rolling holds. Added to the sliding indicator
    d . v_slip, it keeps that indicator away from 0 while rolling cannot hold, and the cap keeps the
    indicator's zero short of the direction's singular point v_slip = -SLIP_SEED v_scale d (module
    docstring, "Chattering")."""
    return ca.fmin(ca.fmax(-g_roll, 0) / (ctx.par["M"] * ctx.natural_rate()), 0.5 * SLIP_SEED * v_scale)


def friction_direction(ctx: WheelContext, sl: "SlidingContact") -> ca.SX:
    """e = (v_slip + SLIP_SEED v_scale d) / |...| (2, unit, placeholders): the direction the sliding
    friction -mu_k F_n e opposes (module docstring), d the stored slip direction."""
    return unit_vector(slip_velocity(ctx) + SLIP_SEED * velocity_scale(ctx) * sl.direction)


# what the fixed-step solvers cannot do for the contact modes (docs/runtime.md, "Contact modes with
# each solver"): the FMU logs it as a warning when euler or rk4 initialises
FIXED_STEP_CAVEAT = ('the contact modes (on_slip = "slide", on_lift_off = "fly") get no error control from a fixed '
                     'step through the switches and impacts, so the energy drifts (euler at the default max_step: '
                     'a dropped wheel bounces on and never rests; rk4: a slip freezes near its end); use dopri5, '
                     'dop853, rosenbrock or taylor (docs/runtime.md, "Contact modes with each solver")')


def declare_sliding(ctx: WheelContext, mu: ca.SX, mu_k: ca.SX) -> SlidingContact:
    """Add the sliding mode to ctx and return it (also as ctx.sliding).

    mu, mu_k: the parameter symbols of the static and kinetic coefficients (1). Adds five local
    states (x_dot, y_dot in m/s, contact_state, slip_dir_x, slip_dir_y), the start values slip_long,
    slip_lat (m/s, ctx.extra_starts) and the Coulomb friction -mu_k F_n e (N, 2 components in the
    ground plane) on the slip velocity, a force of the sliding mode only: its generalised force
    J^T F (J = d v_slip / d q_dot), its power -mu_k F_n e . v_slip dissipated. e: the module
    docstring. Source: Coulomb's law at a point contact; docs/effects.md, "Sliding"."""
    def local(name, unit, text, nominal=1.0):
        st = State(Quantity(name, unit, text), ca.SX.sym(name), ca.SX(0), output=False,
                   nominal=nominal, start_expr=ca.SX(0))  # init: set by contact_init
        ctx.states.append(st)
        return st

    speed = ctx.par["R"] * ctx.natural_rate()
    kin = ctx.kin
    vx = local("x_dot", "m/s", "centre velocity x (free while sliding, from the rolling constraint while rolling)",
               speed)
    vy = local("y_dot", "m/s", "centre velocity y (free while sliding, from the rolling constraint while rolling)",
               speed)
    vx.derivative = ctx.acceleration(kin.centre)[0]
    vy.derivative = ctx.acceleration(kin.centre)[1]
    mode = local("contact_state", "1", "contact mode: 0 rolling, 1 sliding")
    dx = local("slip_dir_x", "1", "stored slip direction x (unit vector in the ground plane)")
    dy = local("slip_dir_y", "1", "stored slip direction y (unit vector in the ground plane)")
    starts = [Quantity("slip_long", "m/s", "slip velocity of the contact point along the heading "
                       "(cos alpha, sin alpha); non-zero at the start: the wheel starts sliding", 0.0),
              Quantity("slip_lat", "m/s", "slip velocity of the contact point across the heading, to the left; "
                       "non-zero at the start: the wheel starts sliding", 0.0)]
    syms = [ca.SX.sym(q.name + "_0") for q in starts]
    ctx.extra_starts += list(zip(starts, syms))
    sl = SlidingContact(mu, mu_k, vx, vy, mode, dx, dy, syms[0], syms[1])
    ctx.forces.append(Force(-mu_k * ctx.Fn * friction_direction(ctx, sl), slip_velocity(ctx), "dissipative", False,
                            SLIDING))
    ctx.sliding = sl
    return sl


def merged(mode: ca.SX, bind_r: Callable, bind_s: Callable, split: float = 0.5) -> Callable:
    """bind for both modes: each element bind_r's while mode < split, else bind_s's (one expression
    where both agree). split 0.5: rolling below, sliding above; model/contact_flight.py merges the
    contact modes with flight at 1.5."""
    def bind(expr):
        a, b = bind_r(expr), bind_s(expr)
        out = ca.SX(a)
        for i in range(a.numel()):
            if not ca.is_equal(a[i], b[i], 8):
                out[i] = ca.if_else(mode < split, a[i], b[i])
        return out
    return bind


def sliding_equations(asm, T: ca.SX, V: ca.SX, Fc: ca.SX, conditions, S: ca.SX, v: ca.SX,
                      qd_driven: ca.SX, qdd_driven: ca.SX):
    """The sliding mode's equations from the same T, V and forces (ConstrainedSystem.reduced).

    asm: the _Assembler of model/build.py (coordinates, forces, binder); T, V: the energies; Fc: the
    contact force (3, N) in placeholders; conditions: the stiction laws' rows; S: the rolling null
    space (nf x nf - 2, in the state's speeds v); qd_driven, qdd_driven: the driven rates. The
    sliding speeds are (vx, vy, v), q_dot = S_s (vx, vy, v) with S_s = diag(I_2, S[2:, :]); F_n is an
    extra unknown, solved with the accelerations (the friction is linear in it).
    Returns (bind_s, ode_mech_s, tau_driven_s): the sliding mode's binding of the placeholders to
    expressions of the state, the derivatives of the coordinates and of v (2 nf - 2 rows, the rolling
    state's mechanical rows), and the torques of the driven coordinates' motors."""
    ctx, sl = asm.ctx, asm.ctx.sliding
    nf = len(asm.free)
    S_s = ca.SX.zeros(nf, nf)
    S_s[0, 0], S_s[1, 1] = 1, 1
    S_s[2:, 2:] = S[2:, :]
    v_s = ca.vertcat(sl.vx.sym, sl.vy.sym, v)
    system = ConstrainedSystem(q=asm.q, qd=asm.qd, qdd=asm.qdd, n_free=nf, T=T, V=V, A=ca.SX(0, nf),
                               Q_nc=asm.generalised_forces(SLIDING), unknowns=[(ctx.Fn, Fc[2])],
                               conditions=conditions, parameters=list(ctx.par))
    qd_all, qdd_all, v_dot, x_sol = system.reduced(S_s, v_s, ca.SX.sym("v_dot_s", nf), qd_driven, qdd_driven)
    P_diss, P_act = asm.powers(SLIDING)
    tau = system.driven_forces()
    if asm.driven:
        P_act = P_act + ca.dot(tau, qd_driven)
    bind_s = asm.binder(qd_all, qdd_all, T, V, P_diss, P_act, x_sol, 1, True)
    return bind_s, ca.vertcat(qd_all[:nf], v_dot[2:]), tau


def state_rows(x: ca.SX, states: list[State]) -> list[int]:
    """The rows of x holding the given states' symbols."""
    return [next(j for j in range(x.numel()) if ca.is_equal(x[j], st.sym)) for st in states]


# the flag of contact_slip: set by every firing, a re-pointed slip direction too (contact_mode tells the mode)
SWITCHED = ("true once the event contact_slip has fired: a switch between rolling and sliding (either way), "
            "or a slip that kept sliding having its direction re-pointed (contact_mode unchanged)")


def contact_event(ctx: WheelContext, x: ca.SX, bind_r: Callable, bind_s: Callable, Fc: ca.SX, T: ca.SX,
                  speed_rows: list[int]) -> Event:
    """The event contact_slip (module docstring): indicator and update, expressions of (t, x, u, p).

    x: the state (nx); bind_r, bind_s: each mode's binding; Fc: the contact force (3, N) in
    placeholders; T: the kinetic energy in placeholders (for the stop impulse's mass matrix and its
    loss); speed_rows: the rows of x holding the rolling speeds v. The stop impulse is Newton's
    plastic tangential impact at the contact point, dv = -M^-1 J^T (J M^-1 J^T)^-1 v_slip (M the
    sliding speeds' mass matrix, J = d v_slip / d speeds)."""
    sl = ctx.sliding
    r_vx, r_vy, r_mode, r_dx, r_dy = state_rows(x, sl.states)
    mode, d = sl.mode.sym, sl.direction
    Fc_r = bind_r(Fc)
    F_t = Fc_r[0:2]
    g_roll = sl.mu * Fc_r[2] * (1 + BREAKAWAY) - norm(F_t)
    v_slip = bind_s(slip_velocity(ctx))
    v_scale = bind_s(velocity_scale(ctx))
    g_slide = ca.dot(d, v_slip) + excess_slip(ctx, g_roll, v_scale)
    indicator = ca.if_else(mode < 0.5, g_roll, ca.if_else(mode < 1.5, g_slide, 1))

    # rolling -> sliding: velocities continuous, slip along -F_t
    vc_r = bind_r(ctx.qd[0:2])
    x_r = ca.SX(x)
    x_r[r_vx], x_r[r_vy], x_r[r_mode] = vc_r[0], vc_r[1], SLIDING
    onset = -unit_vector(F_t)
    x_r[r_dx], x_r[r_dy] = onset[0], onset[1]

    # sliding, d . v_slip = 0: the impulse that stops the residual slip, in the sliding speeds
    rows_v = [r_vx, r_vy] + list(speed_rows)
    w = x[rows_v]
    T_s = bind_s(T)
    M_w = ca.hessian(T_s, w)[0]
    J = ca.jacobian(v_slip, w)
    Y = ca.solve(M_w, J.T)
    K = ca.mtimes(J, Y)
    K_inv = ca.vertcat(ca.horzcat(K[1, 1], -K[0, 1]), ca.horzcat(-K[1, 0], K[0, 0])) / ca.det(K)
    x_p = ca.SX(x)
    x_p[rows_v] = w - ca.mtimes(Y, ca.mtimes(K_inv, v_slip))
    x_p[r_mode] = ROLLING
    vc_p = ca.substitute(vc_r, x, x_p)  # exactly the rolling constraint's velocity
    x_p[r_vx], x_p[r_vy] = vc_p[0], vc_p[1]
    holds = ca.logic_and(ca.substitute(g_roll, x, x_p) > 0,
                         norm(v_slip) <= SLIP_ZERO * v_scale)
    # sliding on: d along the slip itself (no projection), or, at a slip of exactly 0, where it starts
    x_on = ca.SX(x)
    turned = ca.if_else(ca.dot(v_slip, v_slip) > 0, unit_vector(v_slip), ca.substitute(onset, x, x_p))
    x_on[r_dx], x_on[r_dy] = turned[0], turned[1]
    x_s = ca.if_else(holds, x_p, x_on)
    lost = [j for j, st in enumerate(ctx.states) if st.quantity.name == "dissipated_energy"]
    if lost:
        row = x.numel() - len(ctx.states) + lost[0]
        x_s[row] = x[row] + ca.if_else(holds, T_s - ca.substitute(T_s, x, x_p), 0)
    update = ca.if_else(mode < 0.5, x_r, ca.if_else(mode < 1.5, x_s, x))
    flag = Quantity("contact_switched", "", SWITCHED)
    return Event("contact_slip", indicator, "update", flag, update)


def contact_init(ctx: WheelContext, x: ca.SX, init: ca.SX, bind_r: Callable, s_by_name: dict) -> ca.SX:
    """init (nx, expressions of the start values s and parameters) with the contact states filled in:
    the centre velocity the rolling one plus the start slip (slip_long, slip_lat turned from heading
    to ground axes, m/s), sliding iff that slip is non-zero, d along it."""
    sl = ctx.sliding
    r_vx, r_vy, r_mode, r_dx, r_dy = state_rows(x, sl.states)
    init = ca.SX(init)
    vc = ca.substitute(bind_r(ctx.qd[0:2]), x, init)
    s_long, s_lat = s_by_name["slip_long"], s_by_name["slip_lat"]
    a = init[2]
    slip = ca.vertcat(s_long * ca.cos(a) - s_lat * ca.sin(a), s_long * ca.sin(a) + s_lat * ca.cos(a))
    init[r_vx], init[r_vy] = vc[0] + slip[0], vc[1] + slip[1]
    init[r_mode] = ca.if_else(ca.dot(slip, slip) > 0, SLIDING, ROLLING)
    d = unit_vector(slip)
    init[r_dx], init[r_dy] = d[0], d[1]
    return init


def contact_outputs(ctx: WheelContext, bind_s: Callable, by_name: dict) -> list[tuple[Quantity, ca.SX]]:
    """The outputs contact_mode (an Enumeration: 0 rolling, 1 sliding) and the slip velocity along / across the
    heading (m/s, 0 while rolling), slip_long and slip_lat being the start values' variables."""
    sl = ctx.sliding
    mode = sl.mode.sym
    v = bind_s(slip_velocity(ctx))
    a = ctx.q[2]
    along = v[0] * ca.cos(a) + v[1] * ca.sin(a)
    across = -v[0] * ca.sin(a) + v[1] * ca.cos(a)
    sliding = ca.logic_and(mode > 0.5, mode < 1.5)
    return [(Quantity("contact_mode", "", "contact mode: 0 rolling, 1 sliding", items=MODE_NAMES[:2]), mode),
            (by_name["slip_long"], ca.if_else(sliding, along, 0)),
            (by_name["slip_lat"], ca.if_else(sliding, across, 0))]
