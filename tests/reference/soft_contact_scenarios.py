"""The contact scenarios of the soft-contact reference (`reference.soft_contact`), each returning
the quantities its closed form (or the hybrid model) names.

All take the wheel (`Wheel`: M, R, k_diam, k_axial), the contact's stiffness kappa (N/m per kg),
regularisation eps (m/s), restitution, friction and g, and the solver's rtol/atol; they return a
dict of floats (SI units) with the `Run` under "run". A wheel that starts on the ground starts at
its static sag (d = g cos(slope) / kappa: the normal force is M g cos(slope) from t = 0, no
vertical oscillation). Angles and slips follow docs/model.md: heading (cos alpha, sin alpha),
forward rolling is gamma_dot > 0 with v = R gamma_dot, slip = the rim point's velocity.

- `sliding_launch(v0, gamma_dot0)`: upright on level ground, centre speed v0, spin gamma_dot0.
- `incline(theta)`: upright, from rest, heading downhill on a slope theta.
- `flight(...)`: a spinning, leaning wheel thrown up; no contact.
- `drop(h)`: upright, lowest rim point h above the ground, at rest.
- `leaning_drop(h, beta0, gamma_dot0)`: a leaning, spinning wheel dropped; its impacts.
- `extrapolate(coarse, fine)`: Richardson's extrapolation in the stiffness (drops).
"""
from __future__ import annotations

import math

import numpy as np

from .soft_contact import CONTACT, FLIGHT, Ground, SoftWheel, Wheel, initial_state, quat_matrix

TOL = dict(rtol=1e-8, atol=1e-10)


def _on_ground(ground: Ground) -> float:
    """The lowest rim point's height at static sag (m, negative)."""
    return -ground.g * math.cos(ground.slope_angle) / ground.stiffness


def sliding_launch(v0: float, gamma_dot0: float, wheel: Wheel = Wheel(), mu_k: float = 0.3,
                   stiffness: float = 1e6, eps: float = 1e-4, restitution: float = 0.5, g: float = 9.81,
                   rtol: float = TOL["rtol"], atol: float = TOL["atol"]) -> dict:
    """An upright wheel on level ground launched sliding: centre speed v0 (m/s) along the heading,
    spin gamma_dot0 (rad/s; backspin when R gamma_dot0 < v0 with gamma_dot0 < 0, topspin when
    R gamma_dot0 > v0). Returns slip0 = v0 - R gamma_dot0 (m/s); t_roll (s), the first time the
    slip speed falls to eps (rolling has started); v_roll (m/s), gamma_dot_roll (rad/s) then;
    slip_rate (m/s^2), d(slip)/dt fitted over the first 80 % of the sliding phase; F_n (N) at
    t_roll/2."""
    ground = Ground(stiffness=stiffness, restitution=restitution, mu_k=mu_k, eps=eps, g=g)
    model = SoftWheel(wheel, ground)
    slip0 = v0 - wheel.R * gamma_dot0
    y0 = initial_state(wheel, gamma_dot=gamma_dot0, slip_long=slip0, height=_on_ground(ground))
    t_star = abs(slip0) / (mu_k * g * (1 + 1 / wheel.k_axial))
    run = model.simulate(y0, 1.2 * t_star + 0.02, rtol=rtol, atol=atol)
    sticks = [t for t, _ in run.named("stick")]
    if not sticks:
        raise RuntimeError("the slip never fell to eps")
    t_roll = sticks[0]
    out = run.out(t_roll)
    ts = np.linspace(0.05 * t_roll, 0.85 * t_roll, 9)
    slip = [run.out(t)["slip_long"] for t in ts]
    return dict(slip0=slip0, t_roll=t_roll, v_roll=out["vx"], gamma_dot_roll=out["gamma_dot"],
                slip_rate=float(np.polyfit(ts, slip, 1)[0]), F_n=run.out(t_roll / 2)["F_n"], run=run)


def incline(theta: float, wheel: Wheel = Wheel(), mu_k: float = 0.3, mu_s: float | None = None,
            stiffness: float = 1e6, eps: float = 1e-4, restitution: float = 0.5, g: float = 9.81,
            window: tuple[float, float] = (0.2, 0.5), rtol: float = TOL["rtol"],
            atol: float = TOL["atol"]) -> dict:
    """An upright wheel released from rest on a slope theta (rad), heading downhill (x downhill,
    slope_direction 0). Returns, from the states at the window's ends t1, t2 (s): accel (m/s^2),
    the centre's acceleration downhill; gamma_ddot (rad/s^2); slip (m/s) at t2; sliding (bool:
    slip > 10 eps at t2: the wheel slides rather than creeps); F_n (N) at t2."""
    ground = Ground(stiffness=stiffness, restitution=restitution, mu_k=mu_k, mu_s=mu_s, eps=eps, g=g,
                    slope_angle=theta)
    model = SoftWheel(wheel, ground)
    run = model.simulate(initial_state(wheel, height=_on_ground(ground)), window[1], rtol=rtol, atol=atol)
    a, b = run.out(window[0]), run.out(window[1])
    dt = window[1] - window[0]
    return dict(accel=(b["vx"] - a["vx"]) / dt, gamma_ddot=(b["gamma_dot"] - a["gamma_dot"]) / dt,
                slip=b["slip_long"], sliding=bool(b["slip_long"] > 10 * eps), F_n=b["F_n"], run=run)


def flight(beta0: float = 1.2, gamma_dot0: float = 30.0, alpha_dot0: float = 2.0, beta_dot0: float = 1.0,
           vz0: float = 3.0, v_long0: float = 1.0, height0: float = 1.0, t_end: float = 0.6,
           wheel: Wheel = Wheel(), g: float = 9.81, samples: int = 61, rtol: float = 1e-11,
           atol: float = 1e-12) -> dict:
    """A wheel thrown up (no contact until t_end: checked): lean beta0, rates (rad/s), centre
    velocity v_long0 along the heading alpha = 0 plus vz0 up (m/s), lowest rim point height0 (m).
    Returns at `samples` times t (N,): centre r (N, 3), velocity v (N, 3); L (N, 3), the angular
    momentum about the centre (kg m^2/s, plane frame); axle n (N, 3); w_n (N,), the spin
    component w.n (rad/s); precession (rad/s), the rate of n about L fitted over the run;
    cone (rad), the angle between n and L at t = 0."""
    model = SoftWheel(wheel, Ground(g=g))
    y0 = initial_state(wheel, beta=beta0, alpha_dot=alpha_dot0, beta_dot=beta_dot0, gamma_dot=gamma_dot0,
                       height=height0, vz=vz0)
    y0[3] += v_long0  # heading alpha = 0: along x
    run = model.simulate(y0, t_end, rtol=rtol, atol=atol)
    if run.switches:
        raise RuntimeError(f"the wheel touched the ground at t = {run.switches[0][0]}")
    t = np.linspace(0.0, t_end, samples)
    ys = np.array([run.at(ti)[0] for ti in t])
    rots = [quat_matrix(y[6:10]) for y in ys]
    L = np.array([rot @ (model.inertia * y[10:13]) for rot, y in zip(rots, ys)])
    n = np.array([rot[:, 2] for rot in rots])
    u = L[0] / np.linalg.norm(L[0])
    e1 = n[0] - (n[0] @ u) * u
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    phase = np.unwrap(np.arctan2(n @ e2, n @ e1))
    return dict(t=t, r=ys[:, 0:3], v=ys[:, 3:6], L=L, n=n, w_n=ys[:, 12],
                precession=float(np.polyfit(t, phase, 1)[0]), cone=float(math.acos(n[0] @ u)), run=run)


def extrapolate(coarse: float, fine: float, factor: float = 10.0, rate: float = 0.5) -> float:
    """Richardson's extrapolation to kappa -> infinity of a quantity whose error falls as
    kappa^-rate, from its values at kappa (coarse) and factor kappa (fine): the drops' apex
    heights and rebound ratios (rate 1/2: gravity acts during a contact of ~ pi / sqrt(kappa))."""
    q = factor ** rate
    return (q * fine - coarse) / (q - 1)


def _apex_event(t, y):
    return y[5]  # the centre's vertical velocity (level ground)


def drop(h: float, restitution: float = 0.5, wheel: Wheel = Wheel(), stiffness: float = 1e6,
         mu_k: float = 0.3, eps: float = 1e-4, g: float = 9.81, t_end: float | None = None,
         rtol: float = TOL["rtol"], atol: float = TOL["atol"]) -> dict:
    """An upright wheel at rest, its lowest rim point h (m) above level ground, dropped. Returns
    apex (list, m), the lowest rim point's height at each apex in flight after an impact;
    touchdowns (list, s); t_rest (s), the last touchdown (the contact then holds to t_end,
    default 1.5 times the rigid bounce series' total plus 0.1 s); e_eff (list), each impact's
    rebound / impact speed of the centre."""
    ground = Ground(stiffness=stiffness, restitution=restitution, mu_k=mu_k, eps=eps, g=g)
    model = SoftWheel(wheel, ground)
    t0 = math.sqrt(2 * h / g)
    if t_end is None:
        t_end = 1.5 * t0 * (1 + restitution) / (1 - restitution) + 0.1
    run = model.simulate(initial_state(wheel, height=h), t_end, rtol=rtol, atol=atol,
                         extra_events=[("apex", _apex_event, -1.0)])
    apex = [model.outputs(y, FLIGHT)["height"] for t, y in run.named("apex")
            if t > 0 and run.at(t)[1] == FLIGHT]
    touch = [t for t, _ in run.named("touchdown")]
    lift = [y for _, y in run.named("lift_off")]
    e_eff = [y_l[5] / -y_t[5] for (_, y_t), y_l in zip(run.named("touchdown"), lift)]
    if run.mode[-1] != CONTACT:
        raise RuntimeError("still bouncing at t_end")
    return dict(apex=apex, touchdowns=touch, t_rest=touch[-1], e_eff=e_eff, run=run)


def leaning_drop(h: float = 0.05, beta0: float = 1.1, gamma_dot0: float = 15.0, alpha_dot0: float = 1.0,
                 slip_long0: float = 0.3, restitution: float = 0.5, wheel: Wheel = Wheel(),
                 stiffness: float = 1e6, mu_k: float = 0.3, eps: float = 1e-4, g: float = 9.81,
                 t_end: float = 0.4, rtol: float = TOL["rtol"], atol: float = TOL["atol"]) -> dict:
    """A leaning spinning wheel (lean beta0, spin gamma_dot0, precession alpha_dot0, the rim point
    moving at slip_long0 along the heading) dropped from height h (m) of its lowest rim point.
    Returns impacts: a list of dicts, one per contact that ends in flight or at t_end, with
    t_touch, t_lift (s), E_before, E_after (J: energy at touchdown, and after the contact without
    the spring's store), J_n, J_t (N s: normal and tangential impulse of the contact force);
    drift (J), the largest |E + W - E(0)| sampled over the run (the balance's own check)."""
    ground = Ground(stiffness=stiffness, restitution=restitution, mu_k=mu_k, eps=eps, g=g)
    model = SoftWheel(wheel, ground)
    run = model.simulate(initial_state(wheel, beta=beta0, gamma_dot=gamma_dot0, alpha_dot=alpha_dot0,
                                       slip_long=slip_long0, height=h), t_end, rtol=rtol, atol=atol)
    impacts = []
    switches = run.switches + [(t_end, "end", run.y[-1])]
    for (t_a, name, y_a), (t_b, _, y_b) in zip(switches, switches[1:]):
        if name != "touchdown":
            continue
        j = y_b[14:17] - y_a[14:17]
        after = model.energy(y_b, FLIGHT if t_b < t_end else CONTACT)
        impacts.append(dict(t_touch=t_a, t_lift=t_b, E_before=model.energy(y_a, FLIGHT), E_after=after,
                            J_n=float(j[2]), J_t=float(math.hypot(j[0], j[1]))))
    e0 = model.energy(run.y[0], run.mode[0])
    drift = max(abs(model.energy(y, m) + y[13] - e0) for y, m in zip(run.y, run.mode))
    return dict(impacts=impacts, drift=drift, run=run)
