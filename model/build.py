"""Assemble the wheel model of a scene: base wheel + chosen effects -> ModelSpec.

The base wheel is a rigid body of revolution (mass M, rolling radius R, inertias
I_diam = k_diam M R^2 about diameters and I_axial = k_axial M R^2 about the axle)
rolling without slip on flat ground (paper eqs. 18-22, general inertia). Effects
add energies, bodies, forces, coordinates, states, inputs, parameters, outputs,
events and checks (model/effects/). The formulation is the reduced Kane-Maggi
form (default) or the multiplier form with constraint stabilisation; both come
from the same T, V and A (model/lagrangian.py).
"""
from __future__ import annotations

import dataclasses
import math

import casadi as ca

from gyrowheel.model import contact_flight, contact_modes, painleve
from gyrowheel.model.context import Body, WheelContext
from gyrowheel.model.effects import CATALOGUE, lift_off_conflict
from gyrowheel.model.kinematics import WheelKinematics, norm
from gyrowheel.model.lagrangian import ConstrainedSystem
from gyrowheel.model.spec import (K_DIAM_MAX, MASS_RANGE, RADIUS_RANGE, RATE_RANGE, SPEED_OF_LIGHT, Event, ModelSpec,
                                  Quantity, range_refusal)
from gyrowheel.model.stiction import law_update, stuck_rate_rows

FORMULATIONS = ("reduced", "multipliers")
# what the contact outputs are in flight, added to their descriptions in a scene with flight
IN_FLIGHT = {"F_n": "; 0 in flight", "F_long": "; 0 in flight", "F_lat": "; 0 in flight",
             "friction_use": "; -1 in flight",
             "contact_x": "; in flight the lowest rim point's", "contact_y": "; in flight the lowest rim point's",
             "slip_long": "; in flight the lowest rim point's horizontal velocity along the heading",
             "slip_lat": "; in flight the lowest rim point's horizontal velocity across the heading"}
MASS_REFUSAL = (f"M (mass) must lie in [{MASS_RANGE[0]:g}, {MASS_RANGE[1]:g}] kg (beyond, the contact's products of "
                "masses and squared speeds leave double precision)")
SPEED_REFUSAL = "must lie in [-c, c], c = 299792458 m/s (Newtonian mechanics: below the speed of light)"
# each start rate times R, the speed its rate gives a rim point, below the speed of light
RIM_SPEED_REFUSAL = "R must be <= c = 299792458 m/s (Newtonian mechanics: a rim point below the speed of light)"
SPEED_CHOICES = ("body", "angle_rates")
BODY_SPEEDS = ("omega_l", "omega_m", "omega_n")

COORDINATES = ("x", "y", "alpha", "beta", "gamma")
SPEEDS = ("alpha_dot", "beta_dot", "gamma_dot")
DEPENDENT = [0, 1]  # x, y follow from the angle rates (rolling constraint)
WHEEL_ABOUT = (
    "A rigid wheel rolling without slip on flat ground (the Gyrover wheel of Nandy & Xu), equations "
    "derived by CasADi from the Lagrangian with the rolling constraints eliminated (formulation: {}). "
    "Angles: alpha precession (heading), beta lean (pi/2 upright), gamma spin; the centre velocity "
    "(vx, vy) follows from the angle rates, so only positions, angles and angle rates are initial values. "
    "When the wheel falls flat (beta reaches beta_min or pi - beta_min) the step stops at the located time.")


# Default fall lean (docs/model.md, "When the wheel has fallen"). The model's wheel touches the
# plane with its rim only, so it lies flat at beta = 0, and a rolling wheel can dip arbitrarily
# close to that and come back (the hoop of tests/test_fall_criterion.py dips to 0.0135 rad, and
# the dip shrinks in proportion to its spin). What ends first is the description in the paper's
# Euler angles, singular at
# beta = 0: the accelerations carry a round-off of about 10 eps / sin^2(beta) (measured against a
# 40-digit evaluation of the independent derivation). 1e-3 rad is the lowest decade at which it
# stays below a quarter of the default rel_tol (2.4e-9 < 1e-8 / 4); the centre is then 1e-3 R
# above the ground, less than the width of the rim of any real wheel.
BETA_MIN_DEFAULT = 1e-3
SLIDE_NEEDS_REDUCED = ('"slide" needs formulation = "reduced" (the sliding mode is derived in the '
                       'null-space form only)')

FLY_NEEDS_ANGLE_RATES = '"fly" needs speeds = "angle_rates" (the flight mode is derived in the angle rates)'


def state_units(x_names: list[str], free: list, states: list) -> list[str]:
    """The unit of every state of x_names (the wheel's continuous state): the coordinates x, y
    in m, the angles in rad (an effect's free coordinate its start value's unit), each speed
    NAME_dot its coordinate's unit per second, the body speeds omega_l, omega_m, omega_n rad/s,
    the effects' states (ctx.states) their quantity's unit."""
    coordinate = {c.name: ("m" if c.name in ("x", "y") else c.start.unit if c.start is not None else "rad")
                  for c in free}
    local = {st.quantity.name: st.quantity.unit for st in states}
    units = []
    for name in x_names:
        if name in local:
            units.append(local[name])
        elif name in coordinate:
            units.append(coordinate[name])
        elif name.endswith("_dot") and name[:-4] in coordinate:
            units.append(coordinate[name[:-4]] + "/s")
        elif name in BODY_SPEEDS:
            units.append("rad/s")
        else:
            raise ValueError(f"state {name!r}: no unit known")
    return units


def touchdown_lean(k_diam: float, k_axial: float) -> float:
    """Lean [rad] below which every wheel with these inertias touches the ground beside its rim.

    For a body of revolution symmetric about its mid-plane, with the rim (radius R, in the
    mid-plane) its outermost circle, a mass element at axle distance rho <= R and axial offset
    zeta on the lower side stays above the ground while |zeta| < (R - rho) tan(beta). Integrating
    zeta^2 over the lower half, with int zeta^2 dm = I_diam - I_axial / 2 and
    int (R - rho)^2 dm <= M R^2 - I_axial (since rho <= R), gives: nothing but the rim touches only if
        tan^2(beta) > (2 k_diam - k_axial) / (2 (1 - k_axial)).
    The bound is tight (a rim ring plus masses on the axle at +-h touch at tan(beta) = h / R).
    0 for thin wheels (2 k_diam = k_axial: disc, hoop). Raises ValueError when the inertias leave
    no lean at which such a body stands on its rim (k_axial = 1 with width: a drum), or describe
    no rigid body.
    """
    width, room = 2 * k_diam - k_axial, 2 * (1 - k_axial)
    if width < 0 or room < 0:
        raise ValueError(f"k_diam = {k_diam:g}, k_axial = {k_axial:g}: no rigid body of revolution "
                         "(k_axial must be <= 2 k_diam and <= 1)")
    if width == 0:
        return 0.0
    if room <= 0:
        raise ValueError(f"k_diam = {k_diam:g}, k_axial = {k_axial:g}: all mass at the rim but axial width "
                         "(a drum): such a wheel touches the ground with its edge at any lean")
    return math.atan(math.sqrt(width / room))


def wheel_parameters() -> list[Quantity]:
    """Parameters of the base wheel (docs/interface.md), with their defaults."""
    return [
        Quantity("M", "kg", f"wheel mass, in [{MASS_RANGE[0]:g}, {MASS_RANGE[1]:g}] kg", 2.0,
                 minimum=MASS_RANGE[0], maximum=MASS_RANGE[1]),
        Quantity("R", "m", f"wheel (rolling) radius, in [{RADIUS_RANGE[0]:g}, {RADIUS_RANGE[1]:g}] m", 0.17,
                 minimum=RADIUS_RANGE[0], maximum=RADIUS_RANGE[1], closed_range=True),
        Quantity("k_diam", "1", f"diametral inertia I_diam = k_diam M R^2, at most {K_DIAM_MAX:g}", 0.25,
                 maximum=K_DIAM_MAX),
        Quantity("k_axial", "1", "axial (spin-axis) inertia I_axial = k_axial M R^2", 0.4),
        Quantity("beta_min", "rad", "lean at which the wheel counts as fallen flat "
                 "(default: as near flat as the Euler angles keep their accuracy, docs/model.md)",
                 BETA_MIN_DEFAULT, display_unit="deg"),
    ]


def start_values() -> list[Quantity]:
    """User-facing initial values: positions, angles and angle rates (never x_dot, y_dot)."""
    return [
        Quantity("x", "m", "wheel-centre position x", 0.0),
        Quantity("y", "m", "wheel-centre position y", 0.0),
        Quantity("alpha", "rad", "precession (heading) angle", 0.0, display_unit="deg"),
        Quantity("beta", "rad", "lean angle, pi/2 upright", math.radians(80.0), display_unit="deg"),
        Quantity("gamma", "rad", "spin angle", 0.0, display_unit="deg"),
        Quantity("alpha_dot", "rad/s", "precession rate", 0.0, minimum=RATE_RANGE[0], maximum=RATE_RANGE[1],
                 closed_range=True),
        Quantity("beta_dot", "rad/s", "lean rate", 0.0, minimum=RATE_RANGE[0], maximum=RATE_RANGE[1],
                 closed_range=True),
        Quantity("gamma_dot", "rad/s", "spin rate", 6.0, minimum=RATE_RANGE[0], maximum=RATE_RANGE[1],
                 closed_range=True),
    ]


def _with_values(quantities: list[Quantity], values: dict[str, float]) -> list[Quantity]:
    for q in quantities:
        if q.name in values:
            q.start = float(values[q.name])
    return quantities


def base_context(wheel: dict[str, float]) -> WheelContext:
    """The wheel alone: coordinates, parameters, kinetic energy, its body, checks."""
    ctx = WheelContext(coords=[])
    for name in COORDINATES:
        ctx.coordinate(name)
    for quantity in _with_values(wheel_parameters(), wheel):
        ctx.parameter(quantity)
    P = ctx.par
    ctx.kin = kin = WheelKinematics(ctx.q, ctx.qd, P["R"])
    M, R = P["M"], P["R"]
    inertia = ca.diag(ca.vertcat(P["k_diam"], P["k_diam"], P["k_axial"])) * M * R**2
    w, v = kin.omega_lmn, kin.centre_velocity
    # eq. (22) with general inertia; z_dot is part of v (z = R sin beta)
    ctx.kinetic.append(0.5 * M * ca.dot(v, v) + 0.5 * ca.mtimes([w.T, inertia, w]))
    ctx.bodies.append(Body(M, kin.centre))
    ctx.check(M, "M (mass) must be > 0")
    # each refusal once: the range only where M > 0
    ctx.check_true(ca.logic_or(M <= 0, ca.logic_and(M >= MASS_RANGE[0], M <= MASS_RANGE[1])), MASS_REFUSAL)
    ctx.check(R, "R (radius) must be > 0")
    ctx.check_true(ca.logic_or(R <= 0, ca.logic_and(R >= RADIUS_RANGE[0], R <= RADIUS_RANGE[1])),
                   range_refusal("R", *RADIUS_RANGE, "m"))
    ctx.check(P["k_diam"], "k_diam must be > 0")
    ctx.check(P["k_axial"], "k_axial must be > 0")
    ctx.check_true(P["k_diam"] <= K_DIAM_MAX, f"k_diam must be <= {K_DIAM_MAX:g}")
    # each refusal once: the combined check only where k_diam itself passes its own
    ctx.check_true(ca.logic_or(P["k_diam"] <= 0, P["k_axial"] <= 2 * P["k_diam"]),
                   "k_axial must be <= 2 k_diam (I_axial <= 2 I_diam for any rigid body)")
    ctx.check_true(P["k_axial"] <= 1,
                   "k_axial must be <= 1 (a ring, all mass at radius R, is the limit)")
    ctx.check(P["beta_min"], "beta_min must be > 0")
    ctx.check(math.pi / 2 - P["beta_min"], "beta_min must be < pi/2")
    return ctx


def build_model(wheel: dict[str, float] | None = None,
                initial: dict[str, float] | None = None,
                effects: dict[str, dict] | None = None,
                formulation: str = "reduced",
                name: str = "wheel",
                description: str = "Gyrover wheel rolling without slip",
                speeds: str = "angle_rates") -> ModelSpec:
    """The ModelSpec of a wheel with the named effects.

    wheel: values of the base parameters (M, R, k_diam, k_axial, beta_min);
    initial: start values (x, y, alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot,
    and those effects add); effects: {effect name: {parameter: value}}, gravity
    alone by default. Effects are applied in catalogue order, whatever the scene's.
    speeds (reduced form): the wheel's independent speeds, "body" = the angular velocity on
    {l, m, n} (Kane's choice: diagonal reduced mass matrix, cheapest right-hand side) or
    "angle_rates" = (alpha_dot, beta_dot, gamma_dot).
    """
    if speeds not in SPEED_CHOICES:
        raise ValueError(f"speeds must be one of {', '.join(SPEED_CHOICES)}, not {speeds!r}")
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {', '.join(FORMULATIONS)}, not {formulation!r}")
    effects = {"gravity": {}} if effects is None else effects
    for effect_name in effects:
        if effect_name not in CATALOGUE:
            raise ValueError(f"unknown effect {effect_name!r}; valid: {', '.join(CATALOGUE)}")
    conflict = lift_off_conflict(effects)
    if conflict:
        raise ValueError(f"contact_forces on_lift_off: {conflict}")
    if effects.get("contact_forces", {}).get("on_slip") == "slide" and formulation != "reduced":
        raise ValueError(f"contact_forces on_slip: {SLIDE_NEEDS_REDUCED}")
    if effects.get("contact_forces", {}).get("on_lift_off") == "fly" and speeds != "angle_rates":
        raise ValueError(f"contact_forces on_lift_off: {FLY_NEEDS_ANGLE_RATES}")
    ctx = base_context(wheel or {})
    for effect_name, effect_cls in CATALOGUE.items():
        if effect_name in effects:
            effect_cls(effects[effect_name]).apply(ctx)
    return _Assembler(ctx, formulation, initial or {}, speeds).spec(name, description, list(effects))


class _Assembler:
    """Turns a filled WheelContext into state equations (one formulation)."""

    def __init__(self, ctx: WheelContext, formulation: str, initial: dict[str, float], speeds: str = "angle_rates"):
        self.ctx, self.formulation, self.initial, self.speeds = ctx, formulation, initial, speeds
        free = [c for c in ctx.coords if c.free]
        driven = [c for c in ctx.coords if not c.free]
        self.free, self.driven = free, driven
        ctx.coords[:] = free + driven  # free coordinates first (ConstrainedSystem's order)
        self.q, self.qd, self.qdd = ctx.all_q(), ctx.all_qd(), ctx.all_qdd()
        self.late = ctx.late

    # -- terms --------------------------------------------------------------
    def energies(self):
        ctx = self.ctx
        T = sum(ctx.kinetic, ca.SX(0))
        V = sum(ctx.potentials, ca.SX(0))
        if ctx.gravity is not None:
            for body in ctx.bodies:
                V = V - body.mass * ca.dot(ctx.gravity, body.position)
        return T, V

    def forces(self, mode: int = contact_modes.ROLLING):
        """The forces acting in the contact mode `mode` (every force but another mode's own)."""
        return [f for f in self.ctx.forces if f.mode is None or f.mode == mode]

    def generalised_forces(self, mode: int = contact_modes.ROLLING):
        if not self.forces(mode):
            return None
        Q = ca.SX.zeros(self.q.numel())
        for f in self.forces(mode):
            J = ca.jacobian(f.velocity, self.qd)
            Q = Q + ca.mtimes(J.T, f.value)
        return Q

    def powers(self, mode: int = contact_modes.ROLLING):
        diss, act = ca.SX(0), ca.SX(0)
        for f in self.forces(mode):
            p = ca.dot(ca.vec(f.value), ca.vec(f.velocity))
            if f.kind == "dissipative":
                diss = diss - p
            elif f.kind == "actuator":
                act = act + p
        return diss, act

    def contact_force(self):
        """Total ground force on the system, from Newton's law for all bodies (back-substitution)."""
        ctx = self.ctx
        F = ca.SX.zeros(3)
        for body in ctx.bodies:
            F = F + body.mass * ctx.acceleration(body.position)
            if ctx.gravity is not None:
                F = F - body.mass * ctx.gravity
        for f in self.forces():
            if f.point:
                F = F - f.value
        return F

    # -- state equations ----------------------------------------------------
    def spec(self, name: str, description: str, effect_names: list[str]) -> ModelSpec:
        ctx, P = self.ctx, self.ctx.par
        T, V = self.energies()
        Fc = self.contact_force()
        unknowns = [(ctx.Fn, Fc[2])] if ctx.uses_Fn else []
        # stiction laws: the holding force of each, from s r_dot + (1 - s) H = 0
        conditions = [(law.hold, law.condition(ctx.acceleration_of_rate(law.rate))) for law in ctx.stick_slip]
        nf = len(self.free)
        A = ca.horzcat(ctx.kin.rolling_constraint(), ca.SX.zeros(2, nf - 5))
        system = ConstrainedSystem(q=self.q, qd=self.qd, qdd=self.qdd, n_free=nf, T=T, V=V, A=A,
                                   Q_nc=self.generalised_forces(), unknowns=unknowns, conditions=conditions,
                                   parameters=list(ctx.par))
        qd_driven = ca.vertcat(*[c.rate for c in self.driven]) if self.driven else ca.SX(0, 1)
        qdd_driven = ca.vertcat(*[c.accel for c in self.driven]) if self.driven else ca.SX(0, 1)
        S = system.null_space(DEPENDENT)
        q_free = ca.vertcat(*[c.q for c in self.free])
        independent = [c for i, c in enumerate(self.free) if i not in DEPENDENT]
        v = ca.vertcat(*[c.qd for c in independent])

        starts = _with_values(start_values(), {})
        extra_starts = [c.start for c in self.free[5:]] + [c.rate_start for c in self.free[5:]]
        state_starts = [st.quantity for st in ctx.states if st.start_expr is None]
        state_starts += [qq for qq, _ in ctx.extra_starts]
        starts = _with_values(starts + extra_starts + state_starts, self.initial)
        s = ca.SX.sym("s", len(starts))
        s_by_name = {qq.name: s[i] for i, qq in enumerate(starts)}
        e_states = ca.vertcat(*[st.sym for st in ctx.states]) if ctx.states else ca.SX(0, 1)
        # states started from an expression (stiction modes) get their value once bind() exists
        e_start = ca.vertcat(*[s_by_name[st.quantity.name] if st.start_expr is None else ca.SX(0)
                               for st in ctx.states]) if ctx.states else ca.SX(0, 1)
        q0 = ca.vertcat(*[s_by_name[n] for n in COORDINATES], *[s_by_name[c.start.name] for c in self.free[5:]])
        v0 = ca.vertcat(*[s_by_name[n] for n in SPEEDS], *[s_by_name[c.rate_start.name] for c in self.free[5:]])

        extra_outputs: list[tuple[Quantity, ca.SX]] = []
        if self.formulation == "reduced":
            x_names = [c.name for c in self.free] + [c.name + "_dot" for c in independent]
            if self.speeds == "body":
                # u = Omega(q) (alpha_dot, beta_dot, gamma_dot) = omega on {l, m, n}: q_dot = S W u
                Omega = ca.jacobian(ctx.kin.omega_lmn, v[:3])
                W = ca.diagcat(ca.solve(Omega, ca.SX.eye(3)), ca.SX.eye(v.numel() - 3))
                S = ca.mtimes(S, W)
                u_body = ca.SX.sym("w", 3)
                v = ca.vertcat(u_body, v[3:])
                v0 = ca.vertcat(ca.mtimes(ca.substitute(Omega, q_free, q0), v0[:3]), v0[3:])
                x_names[nf:nf + 3] = list(BODY_SPEEDS)
            qd_all, qdd_all, v_dot, x_sol = system.reduced(S, v, ca.SX.sym("v_dot", v.numel()),
                                                           qd_driven, qdd_driven)
            x = ca.vertcat(q_free, v, e_states)
            ode_mech = ca.vertcat(qd_all[:nf], v_dot)
            init = ca.vertcat(q0, v0, e_start)
            nominal_rates = [1.0] * v.numel()
            speed_rows = list(range(nf, nf + v.numel()))
            speeds_now, to_state = v, (lambda vs: vs)
        else:
            k_stab = ctx.parameter(Quantity("k_stab", "1/s", "velocity-constraint stabilisation gain", 10.0))
            qd_free = ca.vertcat(*[c.qd for c in self.free])
            qdd_all, lam, x_sol, violation = system.multipliers(qd_free, qd_driven, qdd_driven, k_stab)
            qd_all = ca.vertcat(qd_free, qd_driven)
            x = ca.vertcat(q_free, qd_free, e_states)
            x_names = [c.name for c in self.free] + [c.name + "_dot" for c in self.free]
            ode_mech = ca.vertcat(qd_free, qdd_all[:nf])
            S0 = ca.substitute(S, q_free, q0)
            init = ca.vertcat(q0, ca.mtimes(S0, v0), e_start)
            speed_rows = list(range(nf, 2 * nf))
            speeds_now = qd_free[[i for i in range(nf) if i not in DEPENDENT]]
            to_state = (lambda vs: ca.mtimes(S, vs))  # consistent with A q_dot = 0
            nominal_rates = [P["R"], P["R"]] + [1.0] * (nf - 2)  # x_dot, y_dot scale like R sqrt(g/R)
            # kinematics.norm: its derivative is defined at 0, where every initial state lies
            # (norm_2's 0/0 there made every partial of Initialization Mode NaN)
            extra_outputs = [
                (Quantity("constraint_violation", "m/s", "|A(q) q_dot|, drift of the rolling constraint"),
                 norm(violation)),
                (Quantity("lambda_x", "N", "constraint multiplier: contact force along x"), lam[0]),
                (Quantity("lambda_y", "N", "constraint multiplier: contact force along y"), lam[1]),
            ]
        x_names += [st.quantity.name for st in ctx.states]
        x_units = state_units(x_names, self.free, ctx.states)

        P_diss, P_act = self.powers()
        tau_driven = system.driven_forces()
        P_act = P_act + ca.dot(tau_driven, qd_driven) if self.driven else P_act
        bind = self.binder(qd_all, qdd_all, T, V, P_diss, P_act, x_sol, len(unknowns), ctx.uses_Fn)
        sl, fl = ctx.sliding, ctx.flight
        if sl is None:
            ctx.late_values = {"Fc": bind(Fc)}
            ode_mech = bind(ode_mech)
        else:  # one state for both modes: ode, outputs and events per mode (model/contact_modes.py)
            bind_r = bind
            bind_s, ode_mech_s, tau_s = contact_modes.sliding_equations(self, T, V, Fc, conditions, S, v,
                                                                          qd_driven, qdd_driven)
            bind = contact_modes.merged(sl.mode.sym, bind_r, bind_s)
            ode_mech = ca.if_else(sl.mode.sym < 0.5, bind_r(ode_mech), bind_s(ode_mech_s))
            tau_driven = ca.if_else(sl.mode.sym < 0.5, bind_r(tau_driven), bind_s(tau_s)) if self.driven \
                else tau_driven
            ctx.late_values = {"Fc": Fc}  # bound per mode by bind
        if fl is not None:  # a third mode, flight (model/contact_flight.py): no contact force there
            flight = contact_flight.Flight(ctx, x)
            bind = contact_modes.merged(sl.mode.sym, bind, flight.bind, 1.5)  # flight above 1.5
            if self.driven:  # the motors' torques of the free system in flight
                tau_driven = ca.if_else(sl.mode.sym < 1.5, tau_driven, flight.tau_driven)
            ctx.late_values = {"Fc": ca.if_else(sl.mode.sym < 1.5, Fc, ca.SX.zeros(3))}
        self.bind = bind
        derivs = [bind(st.derivative) for st in ctx.states]
        ode = ca.vertcat(ode_mech, *derivs)
        if fl is not None:
            ode = ca.if_else(sl.mode.sym < 1.5, ode, flight.ode(x.numel() - len(ctx.states)))
        for row, stuck in stuck_rate_rows(ctx.stick_slip, x, bind).items():
            ode[row] = (1 - stuck) * ode[row]  # a stuck rate that is a state stays exactly 0
        init = self._started(init, x, bind)
        if sl is not None:
            init = contact_modes.contact_init(ctx, x, init, bind_r, s_by_name)
        if fl is not None:
            init = contact_flight.flight_init(ctx, x, init, s_by_name)

        by_name = {qq.name: qq for qq in starts}
        velocity_source = "from the rolling constraint" + (
            " while rolling, free (a state) while sliding" + (" and in flight" if fl else "") if sl else "")
        height = ("centre height: R sin(beta) in contact (rolling, sliding), free (the state z_centre) in flight"
                  if fl else "centre height R sin(beta)")
        outputs = [(by_name[n], self.q[i]) for i, n in enumerate(COORDINATES)]
        outputs += [(by_name[n], bind(self.qd[2 + i])) for i, n in enumerate(SPEEDS)]
        kin = ctx.kin
        outputs += [
            (Quantity("z", "m", height), kin.centre[2]),
            (Quantity("vx", "m/s", f"centre velocity x, {velocity_source}"), bind(kin.centre_velocity[0])),
            (Quantity("vy", "m/s", f"centre velocity y, {velocity_source}"), bind(kin.centre_velocity[1])),
            (Quantity("energy", "J", "total mechanical energy T + V"), bind(T + V)),
        ]
        for c in self.free[5:]:
            outputs += [(c.start, c.q), (c.rate_start, bind(c.qd))]
        outputs += [(st.quantity, st.sym) for st in ctx.states if st.output]
        outputs += [(Quantity(f"{c.name}_torque", "N.m", f"torque the motor of {c.name} supplies (generalised "
                              f"force on {c.name}, positive in the sense of increasing {c.name})"),
                     bind(tau_driven[i])) for i, c in enumerate(self.driven)]
        outputs += [(qq, bind(self._late(e))) for qq, e in ctx.outputs]
        outputs += [(qq, bind(e)) for qq, e in extra_outputs]  # lambda holds driven placeholders
        if sl is not None:
            outputs += contact_modes.contact_outputs(ctx, bind_s, by_name)
        if fl is not None:
            outputs += contact_flight.flight_outputs(ctx, flight, by_name)
            # z and the energy: the free body's in flight (z = R sin(beta) and its T, V are the contact's)
            flying = sl.mode.sym > 1.5
            for qq, _ in outputs:
                if qq.name == "contact_mode":
                    qq.description = "contact mode: 0 rolling, 1 sliding, 2 flight"
                    qq.items = contact_modes.MODE_NAMES
            outputs = [(dataclasses.replace(qq, description=qq.description + IN_FLIGHT[qq.name])
                        if qq.name in IN_FLIGHT else qq, e) for qq, e in outputs]
            in_flight = dict(zip(("slip_long", "slip_lat"), contact_flight.flight_slip(ctx, flight)))
            in_flight.update(z=fl.z.sym, energy=flight.T + flight.V)
            outputs = [(qq, ca.if_else(flying, in_flight[qq.name], e) if qq.name in in_flight else e)
                       for qq, e in outputs]

        fallen = Quantity("fallen", "", "true once the wheel has fallen flat (beta <= beta_min or >= pi - beta_min)")
        lean = ca.sin(self.q[3]) - ca.sin(P["beta_min"])
        if fl is not None:  # flat in flight is no fall: its own event (contact_flight.attitude_limit_event)
            lean = ca.if_else(sl.mode.sym > 1.5, 1, lean)
        events = [Event("fall", lean, "terminate", fallen)]
        events += [Event(n, bind(self._late(e)), a, f) for n, e, a, f in ctx.events]
        if sl is not None:
            events.append(contact_modes.contact_event(ctx, x, bind_r, bind_s, Fc, T, speed_rows))
        if fl is not None:
            events.append(contact_flight.flight_event(ctx, x, bind_r, bind_s, flight, Fc))
            events.append(contact_flight.attitude_limit_event(ctx))
            for ev in events:  # switches on the ground only; lift-off and landing are contact_flown's
                if ev.flag.name == "contact_switched":
                    ev.flag.description = contact_modes.SWITCHED + ", on the ground (lift-off and landing: contact_flown)"
        if sl is not None:  # sliding past its rigid solution: the Painleve stop (model/painleve.py)
            events.append(painleve.painleve_event(ctx, bind_s, contact_modes.friction_direction(ctx, sl)))
        n_mech = x.numel() - len(ctx.states)
        for law in ctx.stick_slip:
            mode_row = n_mech + next(i for i, st in enumerate(ctx.states) if st is law.mode)
            switched = Quantity(f"{law.name}_switched", "", f"true once the {law.what} has switched mode (stuck, "
                                "sliding again or turned back)")
            events.append(Event(f"{law.name}_stiction", bind(law.indicator()), "update", switched,
                                law_update(law, x, bind, mode_row, speed_rows, speeds_now, to_state)))
        if ctx.uses_Fn and fl is None and not any(ev.name == "lift_off" for ev in events):
            # load-proportional laws (rolling resistance, pivot friction) would push, not resist,
            # with F_n < 0: the model ends there, so stop and say so (lift_off_conflict refuses any
            # other on_lift_off policy for these laws)
            events.append(Event("lift_off", bind(self._late(ctx.Fc[2])), "terminate",
                                Quantity("lifted_off", "", "true once the normal force has reached zero")))

        beta0 = s_by_name["beta"]
        ctx.check(beta0, "beta (initial lean) must be > 0")
        ctx.check(math.pi - beta0, "beta (initial lean) must be < pi")
        # only where beta0 lies in (0, pi), so a lean outside is refused once, by the checks above
        ctx.check(ca.if_else(ca.logic_and(beta0 > 0, beta0 < math.pi), ca.sin(beta0) - ca.sin(P["beta_min"]), 1),
                  "initial lean beta must lie between beta_min and pi - beta_min (the wheel is already flat)")
        for speed in SPEEDS:  # the wheel's start rates (a closed range: spec.RATE_RANGE)
            rate0 = s_by_name[speed]
            in_range = ca.logic_and(rate0 >= RATE_RANGE[0], rate0 <= RATE_RANGE[1])
            ctx.check_true(in_range, range_refusal(speed, *RATE_RANGE, "rad/s"))
            # each refusal once: the rim speed only where the rate and R lie in their ranges
            radius_in_range = ca.logic_and(P["R"] >= RADIUS_RANGE[0], P["R"] <= RADIUS_RANGE[1])
            ctx.check_true(ca.logic_or(ca.logic_not(ca.logic_and(in_range, radius_in_range)),
                                       P["R"] * ca.fabs(rate0) <= SPEED_OF_LIGHT),
                           f"|{speed}| {RIM_SPEED_REFUSAL}")
        for qq, sym in ctx.extra_starts:  # the start velocities of the contact modes (slip, vz)
            if qq.unit == "m/s":
                ctx.check_true(ca.fabs(sym) <= SPEED_OF_LIGHT, f"{qq.name} {SPEED_REFUSAL}")
        if ctx.extra_starts:  # the start values' checks (contact_flight.declare_flight, speeds) in s
            syms = ca.vertcat(*[sym for _, sym in ctx.extra_starts])
            vals = ca.vertcat(*[s_by_name[qq.name] for qq, _ in ctx.extra_starts])
            for ch in ctx.checks:
                ch.expr = ca.substitute(ch.expr, syms, vals)
        p = ca.vertcat(*[P[qq.name] for qq in ctx.parameters])
        # absolute tolerances scale with the wheel: positions with R, rates with sqrt(g/R),
        # energies with M g R (angles and effect states of order 1 keep 1)
        rate = ctx.natural_rate()
        nominal = ca.vertcat(P["R"], P["R"], *([1.0] * (nf - 2)), *[rate * r for r in nominal_rates],
                             *[st.nominal for st in ctx.states])
        return ModelSpec(
            name=name, description=description, t=ca.SX.sym("t"), x=x, x_names=x_names, x_units=x_units,
            s=s, starts=starts, u=ca.vertcat(*[sym for _, sym in ctx.inputs]) if ctx.inputs else ca.SX(0, 1),
            inputs=[qq for qq, _ in ctx.inputs], p=p, parameters=ctx.parameters,
            init=init, ode=ode, outputs=outputs, events=events, checks=ctx.checks, nominal=nominal,
            effects=effect_names, force_kinds=sorted({f.kind for f in ctx.forces}), formulation=self.formulation,
            fixed_step_caveat=contact_modes.FIXED_STEP_CAVEAT if sl is not None else "",
            about=WHEEL_ABOUT.format(self.formulation) + (contact_modes.ABOUT if sl else "")
            + (contact_flight.ABOUT if fl else ""))

    def binder(self, qd_all, qdd_all, T, V, P_diss, P_act, x_sol, n_unknowns: int, uses_Fn: bool):
        """bind(expr): placeholders (rates, accelerations, late T, V, powers, driven values, F_n, holding
        forces) -> expressions of the state, for one mode's solution (x_sol: its extra unknowns,
        n_unknowns of them before the holding forces)."""
        ctx = self.ctx
        placeholders = ca.vertcat(self.qd, self.qdd, self.late["T"], self.late["V"], self.late["P_diss"],
                                  self.late["P_act"])
        values = ca.vertcat(qd_all, qdd_all, T, V, P_diss, P_act)
        for c in self.driven:
            if c.value is not None:
                placeholders = ca.vertcat(placeholders, c.q)
                values = ca.vertcat(values, c.value)
            elif ca.depends_on(T, c.q) or ca.depends_on(V, c.q):
                raise ValueError(f"driven coordinate {c.name} has no value state but the energies depend on it")
        if uses_Fn:
            placeholders = ca.vertcat(placeholders, ctx.Fn)
            values = ca.vertcat(values, x_sol[0])
        for i, law in enumerate(ctx.stick_slip):
            placeholders = ca.vertcat(placeholders, law.hold)
            values = ca.vertcat(values, x_sol[n_unknowns + i])

        keep = [i for i in range(placeholders.numel()) if not ca.is_equal(placeholders[i], values[i])]
        placeholders, values = placeholders[keep], values[keep]  # drop identities (independent speeds)

        def bind(expr):
            """Placeholders -> state expressions (repeated: the values contain placeholders too)."""
            expr = ca.SX(expr)
            for _ in range(6):
                if not ca.depends_on(ca.vec(expr), placeholders):
                    return expr
                expr = ca.substitute(expr, placeholders, values)
            raise RuntimeError("placeholders could not be bound (a cycle between late quantities)")
        return bind

    def _started(self, init: ca.SX, x: ca.SX, bind) -> ca.SX:
        """init with the states that start from an expression (stiction modes) filled in."""
        n_mech = x.numel() - len(self.ctx.states)
        init = ca.SX(init)
        for i, st in enumerate(self.ctx.states):
            if st.start_expr is not None:
                expr = bind(st.start_expr)
                if self.ctx.inputs and ca.depends_on(expr, ca.vertcat(*[sym for _, sym in self.ctx.inputs])):
                    raise ValueError(f"the start value of {st.quantity.name} must not depend on inputs")
                init[n_mech + i] = ca.substitute(expr, x, init)
        return init

    def _late(self, expr):
        """The contact-force placeholder -> the back-substituted contact force."""
        return ca.substitute(ca.SX(expr), self.ctx.Fc, self.ctx.late_values["Fc"])
