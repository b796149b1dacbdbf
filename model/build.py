"""Assemble the wheel model of a scene: base wheel + chosen effects -> ModelSpec.

The base wheel is a rigid body of revolution (mass M, rolling radius R, inertias
I_diam = k_diam M R^2 about diameters and I_axial = k_axial M R^2 about the axle)
rolling without slip on flat ground (paper eqs. 18-22, general inertia). The
formulation is the reduced Kane-Maggi form (default) or the multiplier form with
constraint stabilisation; both come from the same T, V and A.
"""
from __future__ import annotations

import math

import casadi as ca

from model.context import WheelContext
from model.effects import CATALOGUE
from model.kinematics import WheelKinematics
from model.lagrangian import ConstrainedSystem
from model.spec import Event, ModelSpec, Quantity

FORMULATIONS = ("reduced", "multipliers")

COORDINATES = ("x", "y", "alpha", "beta", "gamma")
SPEEDS = ("alpha_dot", "beta_dot", "gamma_dot")
DEPENDENT = [0, 1]  # x, y follow from the angle rates (rolling constraint)


def wheel_parameters() -> list[Quantity]:
    """Parameters of the base wheel (INTERFACE.md), with their defaults."""
    return [
        Quantity("M", "kg", "wheel mass", 2.0),
        Quantity("R", "m", "wheel (rolling) radius", 0.17),
        Quantity("k_diam", "1", "diametral inertia I_diam = k_diam M R^2", 0.25),
        Quantity("k_axial", "1", "axial (spin-axis) inertia I_axial = k_axial M R^2", 0.4),
        Quantity("beta_min", "rad", "lean at which the wheel counts as fallen flat", 0.02,
                 display_unit="deg"),
    ]


def start_values() -> list[Quantity]:
    """User-facing initial values: positions, angles and angle rates (never x_dot, y_dot)."""
    return [
        Quantity("x", "m", "wheel-centre position x", 0.0),
        Quantity("y", "m", "wheel-centre position y", 0.0),
        Quantity("alpha", "rad", "precession (heading) angle", 0.0, display_unit="deg"),
        Quantity("beta", "rad", "lean angle, pi/2 upright", math.radians(80.0), display_unit="deg"),
        Quantity("gamma", "rad", "spin angle", 0.0, display_unit="deg"),
        Quantity("alpha_dot", "rad/s", "precession rate", 0.0),
        Quantity("beta_dot", "rad/s", "lean rate", 0.0),
        Quantity("gamma_dot", "rad/s", "spin rate", 6.0),
    ]


def _with_values(quantities: list[Quantity], values: dict[str, float]) -> list[Quantity]:
    for q in quantities:
        if q.name in values:
            q.start = float(values[q.name])
    return quantities


def _base_context(wheel: dict[str, float]) -> WheelContext:
    q = ca.SX.sym("q", 5)
    qd = ca.SX.sym("qd", 5)
    ctx = WheelContext(q=q, qd=qd, kin=None, par={})  # type: ignore[arg-type]
    for quantity in _with_values(wheel_parameters(), wheel):
        ctx.parameter(quantity)
    ctx.kin = WheelKinematics(q, qd, ctx.par["R"])
    P = ctx.par
    ctx.check(P["M"], "M (mass) must be > 0")
    ctx.check(P["R"], "R (radius) must be > 0")
    ctx.check(P["k_diam"], "k_diam must be > 0")
    ctx.check(P["k_axial"], "k_axial must be > 0")
    ctx.check_true(P["k_axial"] <= 2 * P["k_diam"],
                   "k_axial must be <= 2 k_diam (I_axial <= 2 I_diam for any rigid body)")
    ctx.check_true(P["k_axial"] <= 1,
                   "k_axial must be <= 1 (a ring, all mass at radius R, is the limit)")
    ctx.check(P["beta_min"], "beta_min must be > 0")
    ctx.check(math.pi / 2 - P["beta_min"], "beta_min must be < pi/2")
    return ctx


def kinetic_energy(ctx: WheelContext):
    """T(q, qd) of eq. (22) with general inertia (z_dot included, z = R sin beta)."""
    M, R = ctx.par["M"], ctx.par["R"]
    I = ca.diag(ca.vertcat(ctx.par["k_diam"], ctx.par["k_diam"], ctx.par["k_axial"])) * M * R**2

    def T(q, qd):
        kin = WheelKinematics(q, qd, R)
        v = kin.centre_velocity
        w = kin.omega_lmn
        return 0.5 * M * ca.dot(v, v) + 0.5 * ca.mtimes([w.T, I, w])

    return T


def build_model(wheel: dict[str, float] | None = None,
                initial: dict[str, float] | None = None,
                effects: dict[str, dict] | None = None,
                formulation: str = "reduced",
                name: str = "wheel",
                description: str = "Gyrover wheel rolling without slip") -> ModelSpec:
    """The ModelSpec of a wheel with the named effects.

    wheel: values of the base parameters (M, R, k_diam, k_axial, beta_min);
    initial: start values (x, y, alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot);
    effects: {effect name: {parameter: value}}; gravity alone by default.
    """
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {', '.join(FORMULATIONS)}, not {formulation!r}")
    effects = {"gravity": {}} if effects is None else effects
    ctx = _base_context(wheel or {})
    for effect_name, options in effects.items():
        if effect_name not in CATALOGUE:
            raise ValueError(f"unknown effect {effect_name!r}; valid: {', '.join(sorted(CATALOGUE))}")
        CATALOGUE[effect_name](options).apply(ctx)

    T = kinetic_energy(ctx)
    V = sum(ctx.potentials, ca.SX(0))

    def Q_nc(q, qd):
        Q = ca.SX.zeros(5)
        for force in ctx.forces:
            Q = Q + force(q, qd)
        return Q

    A = ctx.kin.rolling_constraint()
    system = ConstrainedSystem(q=ctx.q, T=T, V=V, A=A, Q_nc=Q_nc if ctx.forces else None)
    S = system.null_space(DEPENDENT)

    starts = _with_values(start_values(), initial or {})
    s = ca.SX.sym("s", len(starts))
    P = ctx.par
    p = ca.vertcat(*[P[q.name] for q in ctx.parameters])
    q0, v0 = s[0:5], s[5:8]
    beta0 = s[3]
    ctx.check(beta0, "beta (initial lean) must be > 0")
    ctx.check(math.pi - beta0, "beta (initial lean) must be < pi")
    ctx.check(ca.sin(beta0) - ca.sin(P["beta_min"]),
              "initial lean beta must lie between beta_min and pi - beta_min (the wheel is already flat)")

    t = ca.SX.sym("t")
    v = ca.SX.sym("v", 3)
    if formulation == "reduced":
        red = system.reduced(S, v)
        x = ca.vertcat(ctx.q, v)
        x_names = list(COORDINATES + SPEEDS)
        qd = red.q_dot
        ode = ca.vertcat(qd, red.v_dot())
        init = s
        energy = red.energy
        extra_outputs: list[tuple[Quantity, ca.SX]] = []
        nominal_rates = [1.0, 1.0, 1.0]
    else:
        qd = ca.SX.sym("qd", 5)
        k_stab = ctx.parameter(Quantity("k_stab", "1/s", "velocity-constraint stabilisation gain", 10.0))
        p = ca.vertcat(p, k_stab)
        mult = system.multipliers(qd, k_stab)
        x = ca.vertcat(ctx.q, qd)
        x_names = list(COORDINATES) + ["x_dot", "y_dot"] + list(SPEEDS)
        ode = ca.vertcat(qd, mult.q_ddot)
        S0 = ca.substitute(S, ctx.q, q0)
        init = ca.vertcat(q0, ca.mtimes(S0, v0))
        energy = mult.energy
        extra_outputs = [
            (Quantity("constraint_violation", "m/s", "|A(q) q_dot|, drift of the rolling constraint"),
             ca.norm_2(mult.violation)),
            (Quantity("lambda_x", "N", "constraint multiplier: contact force along x"), mult.lam[0]),
            (Quantity("lambda_y", "N", "constraint multiplier: contact force along y"), mult.lam[1]),
        ]
        nominal_rates = [1.0] * 5
        v = qd[2:5]

    # Expressions of the effects were written in the placeholder (q, qd); bind them to the state.
    def bind(expr):
        return ca.substitute(expr, ca.vertcat(ctx.q, ctx.qd), ca.vertcat(ctx.q, qd))

    kin = WheelKinematics(ctx.q, qd, P["R"])
    by_name = {qq.name: qq for qq in starts}
    outputs = [(by_name[n], ctx.q[i]) for i, n in enumerate(COORDINATES)]
    outputs += [(by_name[n], v[i]) for i, n in enumerate(SPEEDS)]
    outputs += [
        (Quantity("z", "m", "centre height R sin(beta)"), kin.centre[2]),
        (Quantity("vx", "m/s", "centre velocity x, from the rolling constraint"), kin.centre_velocity[0]),
        (Quantity("vy", "m/s", "centre velocity y, from the rolling constraint"), kin.centre_velocity[1]),
        (Quantity("energy", "J", "total mechanical energy T + V"), bind(energy)),
    ]
    outputs += [(qq, bind(e)) for qq, e in ctx.outputs] + extra_outputs

    fallen = Quantity("fallen", "", "true once the wheel has fallen flat (beta <= beta_min or >= pi - beta_min)")
    events = [Event("fall", ca.sin(ctx.q[3]) - ca.sin(P["beta_min"]), "terminate", fallen)]
    events += [Event(n, bind(e), a, f) for n, e, a, f in ctx.events]

    nominal = ca.vertcat(P["R"], P["R"], 1, 1, 1, *nominal_rates)
    return ModelSpec(
        name=name, description=description, t=t, x=x, x_names=x_names,
        s=s, starts=starts, u=ca.SX.sym("u", 0), inputs=[], p=p, parameters=ctx.parameters,
        init=init, ode=ode, outputs=outputs, events=events,
        checks=[ca_check for ca_check in _bind_checks(ctx, s)], nominal=nominal,
        effects=list(effects), formulation=formulation)


def _bind_checks(ctx: WheelContext, s: ca.SX):
    """Checks may use start values (beta0) and parameters only."""
    for check in ctx.checks:
        yield check
