"""Soft-contact reference of the wheel on a plane: penalty normal force, regularised Coulomb friction.

An independent simulation for the contact modes (rolling, sliding, flight with impacts): nothing
here comes from the project's model; only its conventions (docs/model.md, docs/effects.md) are
shared, so that results compare one to one.

Body. A rigid body of revolution (mass M, radius R, I_diam = k_diam M R^2 about any diameter,
I_axial = k_axial M R^2 about the axle) that touches the plane with its rim only (a thin wheel).
Newton-Euler with the orientation as a unit quaternion q = (w, x, y, z) (no singularity at any
lean; renormalised in every evaluation and at every restart, with a drift term that pulls |q| to 1):

    M dv/dt = M g_vec + F,    I dw_b/dt = tau_b - w_b x I w_b    (Euler's equations, body frame)
    dq/dt = q (x) (0, w_b) / 2,   tau = (C - A) x F

Body axis 3 is the axle n. The project's attitude is [l m n] Rz(gamma) with
[l m n] = Rz(alpha) Rx(pi/2 - beta) [l m n]_upright, [l m n]_upright = [-k, -i, j]; so
n = (-sin a sin b, cos a sin b, cos b), w = alpha_dot k + beta_dot m + gamma_dot n, and the
rates come back as beta_dot = w.m, alpha_dot = (w.k - cos b w.n) / sin^2 b,
gamma_dot = (w.n - cos b w.k) / sin^2 b.

Plane. Positions are in the plane's frame (x, y in the plane, z along its normal), gravity
g_vec = g (sin th cos psi, sin th sin psi, -cos th) (th = slope_angle, psi = slope_direction, as
the project's `slope`). The rim's lowest point is C = A + R l, l = -(k - (k.n) n) / sin(beta);
its height h = A_z - R sin(beta); the penetration d = -h.

Normal law. A linear spring-damper, F_n = M (kappa d + c_eff d_dot), kappa the stiffness in N/m
per kg (1/s^2), c_eff = 2 zeta sqrt(kappa m_eff / M) with m_eff the contact point's effective
normal mass (M for an upright wheel). It acts while the wheel penetrates and the law pushes:
contact starts when min(d, kappa d + c_eff d_dot) turns positive and ends when that force falls
to 0 (the law never pulls). The contact point's normal motion is then the oscillator
d'' = -(M / m_eff)(kappa d + c_eff d_dot), of damping ratio zeta whatever m_eff, and its rebound
speed is e v_in with e(zeta) in closed form (`restitution_of_damping`): for a frictionless
impact without gravity the law's restitution is exact, independent of the impact speed, and the
damping is calibrated from the e asked for. Gravity during the contact (duration
~ pi / sqrt(kappa)), the turn of the wheel while it lasts and the static sag g / kappa are the
errors that vanish as kappa grows.

Friction. F_t = -mu(|v_t|) F_n v_t / sqrt(|v_t|^2 + eps^2) with v_t the velocity of the rim's
material point at C, in the plane; mu(s) = mu_k + (mu_s - mu_k) exp(-(s / v_s)^2) (v_s = 10 eps;
mu_s = mu_k by default: plain regularised Coulomb). |F_t| < mu F_n always.

Energy. E = T - M g_vec.r, plus the spring's store M kappa d^2 / 2 in contact, and an accumulator W
of what is dissipated (damper, friction; at lift off the store that the law, which stops pushing
at d > 0, leaves behind): E + W is constant to the solver's tolerance. A second accumulator J holds the
impulse of the contact force (N s, world), so an impact's impulse is J(lift off) - J(touchdown).

State (17,): centre r (m), velocity v (m/s), quaternion q, body rates w_b (rad/s), W (J), J (N s).
Integration: scipy solve_ivp by segments; a segment ends at each switch of the normal law
(touchdown, lift off), is restarted there (the damper's force jumps at touchdown) with DOP853 in
flight and Radau in contact; slip speed crossing eps (stick, slip) and apexes are located without
a restart.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

FLIGHT, CONTACT = 0, 1
N_STATE = 17


@dataclass(frozen=True)
class Wheel:
    """Mass M (kg), radius R (m), k_diam, k_axial (I = k M R^2); the defaults are the paper's wheel."""
    M: float = 2.0
    R: float = 0.17
    k_diam: float = 0.25
    k_axial: float = 0.4


@dataclass(frozen=True)
class Ground:
    """Contact and field parameters: stiffness kappa (N/m per kg), restitution e in (0, 1], kinetic
    and static friction, the regularisation speed eps (m/s), g (m/s^2), the plane's slope (rad)."""
    stiffness: float = 1e6
    restitution: float = 0.5
    mu_k: float = 0.3
    mu_s: float | None = None
    eps: float = 1e-4
    g: float = 9.81
    slope_angle: float = 0.0
    slope_direction: float = 0.0

    @property
    def damping(self) -> float:
        """c (1/s) of the normal law, from the restitution (`damping_for_restitution`)."""
        return 2.0 * damping_for_restitution(self.restitution) * math.sqrt(self.stiffness)

    @property
    def g_vec(self) -> np.ndarray:
        th, psi = self.slope_angle, self.slope_direction
        return self.g * np.array([math.sin(th) * math.cos(psi), math.sin(th) * math.sin(psi), -math.cos(th)])


def restitution_of_damping(zeta: float) -> float:
    """Restitution e of the unilateral linear spring-damper x'' = -w^2 x - 2 zeta w x' (x > 0 the
    penetration) entered at x = 0 with speed v: the contact ends where the force
    w^2 x + 2 zeta w x' first returns to 0, and e = -x'(end) / v. With s = sqrt(|1 - zeta^2|),
    x = v e^(-zeta w t) sin(s w t) / (s w) (sinh for zeta > 1); the force vanishes at
    tan(s w t) = 2 zeta s / (1 - 2 zeta^2) (tanh and 2 zeta s / (2 zeta^2 - 1) for zeta > 1), which
    gives e in closed form, independent of v and w (zeta = 0: e = 1; zeta = 1: e = e^-2).
    The force law that stops pushing (rather than pulling at the end) is the one of Hunt and
    Crossley's discussion (1975) of the Kelvin-Voigt contact; cf. Stronge, Impact Mechanics, ch. 1."""
    if zeta < 0:
        raise ValueError("zeta >= 0")
    if abs(zeta - 1.0) < 1e-9:
        return math.exp(-2.0)
    if zeta < 1.0:
        s = math.sqrt(1.0 - zeta * zeta)
        x = math.pi - math.atan2(2.0 * zeta * s, 1.0 - 2.0 * zeta * zeta)  # s w t at force zero
        return math.exp(-zeta * x / s) * (zeta / s * math.sin(x) - math.cos(x))
    s = math.sqrt(zeta * zeta - 1.0)
    x = math.atanh(2.0 * zeta * s / (2.0 * zeta * zeta - 1.0))
    return math.exp(-zeta * x / s) * (zeta / s * math.sinh(x) - math.cosh(x))


def damping_for_restitution(e: float) -> float:
    """The damping ratio zeta whose `restitution_of_damping` is e, for 1e-3 <= e <= 1."""
    if not 1e-3 <= e <= 1.0:
        raise ValueError(f"restitution {e} outside [1e-3, 1]")
    if e == 1.0:
        return 0.0
    return brentq(lambda z: restitution_of_damping(z) - e, 0.0, 60.0, xtol=1e-15, rtol=1e-15)


def _cross(a, b) -> np.ndarray:
    """a x b of two 3-vectors (np.cross costs ten times more on vectors this small)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


# ---- orientation ------------------------------------------------------------------------------

def quat_matrix(q) -> np.ndarray:
    """Rotation matrix (3, 3), body to plane frame, of a quaternion (w, x, y, z), normalised here."""
    w, x, y, z = np.asarray(q, dtype=float) / math.sqrt(float(np.dot(q, q)))
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def matrix_quat(m) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method: the largest pivot)."""
    m = np.asarray(m, dtype=float)
    tr = np.trace(m)
    i = int(np.argmax([tr, m[0, 0], m[1, 1], m[2, 2]]))
    if i == 0:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = [s / 4, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif i == 1:
        s = 2.0 * math.sqrt(1.0 + 2 * m[0, 0] - tr)
        q = [(m[2, 1] - m[1, 2]) / s, s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif i == 2:
        s = 2.0 * math.sqrt(1.0 + 2 * m[1, 1] - tr)
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + 2 * m[2, 2] - tr)
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4]
    q = np.array(q)
    return q / np.linalg.norm(q)


def lmn(alpha: float, beta: float) -> np.ndarray:
    """The frame [l m n] (3, 3) of docs/model.md: columns l (centre to contact), m, n (axle)."""
    ca, sa, cb, sb = math.cos(alpha), math.sin(alpha), math.cos(beta), math.sin(beta)
    return np.array([[-sa * cb, -ca, -sa * sb],
                     [ca * cb, -sa, ca * sb],
                     [-sb, 0.0, cb]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def angles(rot: np.ndarray, w_world: np.ndarray) -> tuple[float, ...]:
    """(alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot) of a wheel attitude (3, 3) and its
    angular velocity (3,) in the plane frame; alpha and gamma are undefined flat (beta = 0, pi)."""
    n = rot[:, 2]
    beta = math.atan2(math.hypot(n[0], n[1]), n[2])
    alpha = math.atan2(-n[0], n[1])
    f = lmn(alpha, beta)
    b1 = rot[:, 0]  # = cos(gamma) l + sin(gamma) m
    gamma = math.atan2(float(b1 @ f[:, 1]), float(b1 @ f[:, 0]))
    cb, s2 = math.cos(beta), math.sin(beta) ** 2
    wk, wn = w_world[2], float(w_world @ n)
    return alpha, beta, gamma, (wk - cb * wn) / s2, float(w_world @ f[:, 1]), (wn - cb * wk) / s2


def initial_state(wheel: Wheel, alpha: float = 0.0, beta: float = math.pi / 2, gamma: float = 0.0,
                  alpha_dot: float = 0.0, beta_dot: float = 0.0, gamma_dot: float = 0.0,
                  height: float = 0.0, slip_long: float = 0.0, slip_lat: float = 0.0,
                  vz: float = 0.0, x: float = 0.0, y: float = 0.0) -> np.ndarray:
    """State (17,) from the project's start values: angles (rad) and rates (rad/s); the lowest rim
    point's height (m; negative: penetrating); the centre velocity is the rolling one plus the
    contact point's slip (m/s) along the heading (cos alpha, sin alpha) and to its left, plus vz."""
    f = lmn(alpha, beta)
    l, m, n = f[:, 0], f[:, 1], f[:, 2]
    w = alpha_dot * np.array([0.0, 0.0, 1.0]) + beta_dot * m + gamma_dot * n
    rot = f @ _rz(gamma)
    heading = np.array([math.cos(alpha), math.sin(alpha), 0.0])
    lateral = np.array([-math.sin(alpha), math.cos(alpha), 0.0])
    v = -_cross(w, wheel.R * l) + slip_long * heading + slip_lat * lateral
    v[2] += vz
    r = np.array([x, y, height + wheel.R * math.sin(beta)])
    return np.concatenate([r, v, matrix_quat(rot), rot.T @ w, np.zeros(4)])


# ---- dynamics ---------------------------------------------------------------------------------

class SoftWheel:
    """The wheel on its plane: `rhs(t, y, mode)`, `outputs(y, mode)`, `simulate(y0, t_end)`."""

    def __init__(self, wheel: Wheel = Wheel(), ground: Ground = Ground()):
        self.wheel, self.ground = wheel, ground
        M, R = wheel.M, wheel.R
        self.inertia = np.array([wheel.k_diam, wheel.k_diam, wheel.k_axial]) * M * R * R
        self.kappa, self.c = ground.stiffness, ground.damping
        self.g_vec = ground.g_vec
        self.mu_s = ground.mu_k if ground.mu_s is None else ground.mu_s

    def _kinematics(self, y):
        """Attitude, world rates, l, contact-point velocity, penetration d and its rate."""
        rot = quat_matrix(y[6:10])
        w = rot @ y[10:13]
        n = rot[:, 2]
        s = np.array([-n[2] * n[0], -n[2] * n[1], 1.0 - n[2] * n[2]])
        l = -s / math.sqrt(s @ s)
        arm = self.wheel.R * l
        v_cp = y[3:6] + _cross(w, arm)
        return rot, w, arm, v_cp, -(y[2] + arm[2]), -v_cp[2]

    def _push(self, y) -> tuple[float, float, float]:
        """(kappa d + c_eff d_dot, d, d_dot): the normal law's force per unit mass. The damping is
        scaled to the contact point's effective normal mass m_eff (1/m_eff = 1/M + u.I^-1 u,
        u = (C - A) x k), c_eff = c sqrt(m_eff / M), so that the damping ratio, hence e, is the
        one asked for in any frictionless impact, not only the upright one (m_eff = M)."""
        rot, _, arm, _, d, dd = self._kinematics(y)
        u_b = rot.T @ _cross(arm, (0.0, 0.0, 1.0))
        m_ratio = 1.0 / (1.0 + self.wheel.M * float(u_b @ (u_b / self.inertia)))
        return self.kappa * d + self.c * math.sqrt(m_ratio) * dd, d, dd

    def _forces(self, y, mode):
        """Contact force (3,) on the wheel, the arm C - A, the contact point's velocity and d, d_dot."""
        rot, w, arm, v_cp, d, dd = self._kinematics(y)
        force = np.zeros(3)
        if mode == CONTACT:
            fn = self.wheel.M * self._push(y)[0]
            vt = np.array([v_cp[0], v_cp[1]])
            speed = math.hypot(vt[0], vt[1])
            eps, mu_k = self.ground.eps, self.ground.mu_k
            mu = mu_k + (self.mu_s - mu_k) * math.exp(-(speed / (10 * eps)) ** 2)
            ft = -mu * fn * vt / math.sqrt(speed * speed + eps * eps)
            force = np.array([ft[0], ft[1], fn])
        return rot, w, arm, v_cp, d, dd, force

    def rhs(self, t, y, mode):
        """dy/dt (17,) of the state y (17,) in mode FLIGHT (no contact force) or CONTACT."""
        rot, w, arm, v_cp, d, dd, force = self._forces(y, mode)
        M, I, wb, q = self.wheel.M, self.inertia, y[10:13], y[6:10]
        tau_b = rot.T @ _cross(arm, force)
        wb_dot = (tau_b - _cross(wb, I * wb)) / I
        qw, qx, qy, qz = q
        p, r_, s = wb
        q_dot = 0.5 * np.array([-qx * p - qy * r_ - qz * s, qw * p + qy * s - qz * r_,
                                qw * r_ + qz * p - qx * s, qw * s + qx * r_ - qy * p])
        q_dot += 10.0 * (1.0 - q @ q) * q  # pulls |q| back to 1 (drift only)
        # in contact the spring's store is part of E: what leaves E is the damper's and friction's work
        power = force @ v_cp + (self.wheel.M * self.kappa * d * dd if mode == CONTACT else 0.0)
        return np.concatenate([y[3:6], self.g_vec + force / M, q_dot, wb_dot, [-power], force])

    def energy(self, y, mode) -> float:
        """T + gravity + (in contact) the spring's store M kappa d^2 / 2 (J)."""
        M, I = self.wheel.M, self.inertia
        d = self._kinematics(y)[4]
        return (0.5 * M * y[3:6] @ y[3:6] + 0.5 * (I * y[10:13]) @ y[10:13] - M * self.g_vec @ y[0:3]
                + (0.5 * M * self.kappa * d * d if mode == CONTACT else 0.0))

    def outputs(self, y, mode) -> dict[str, float]:
        """The project's quantities at one state: centre x, y, z, vx, vy, vz (m, m/s); alpha, beta,
        gamma (rad) and rates (rad/s); slip_long, slip_lat (m/s, the rim point's velocity along the
        heading and to its left); F_n (N); height (m, lowest rim point); energy, dissipated (J)."""
        rot, w, arm, v_cp, d, dd, force = self._forces(y, mode)
        a, b, g, ad, bd, gd = angles(rot, w)
        ca, sa = math.cos(a), math.sin(a)
        return dict(x=y[0], y=y[1], z=y[2], vx=y[3], vy=y[4], vz=y[5], alpha=a, beta=b, gamma=g,
                    alpha_dot=ad, beta_dot=bd, gamma_dot=gd, slip_long=ca * v_cp[0] + sa * v_cp[1],
                    slip_lat=-sa * v_cp[0] + ca * v_cp[1], F_n=force[2], height=-d, energy=self.energy(y, mode),
                    dissipated=y[13], mode=mode)

    def _events(self, mode, extra):
        """Segment events: the law's switch (terminal), the slip speed falling to eps (stick) and
        rising through it (slip), then `extra`."""
        def law(t, y, *_):
            push, d, _ = self._push(y)
            return min(d, push) if mode == FLIGHT else push
        law.terminal, law.direction = True, (1.0 if mode == FLIGHT else -1.0)
        events = [law]
        for direction in (-1.0, 1.0):
            def slip(t, y, *_):
                v = self._kinematics(y)[3]
                return math.hypot(v[0], v[1]) - self.ground.eps
            slip.direction = direction
            events.append(slip)
        for fun, direction in extra:
            def event(t, y, *_, fun=fun):
                return fun(t, y)
            event.direction = direction
            events.append(event)
        return events

    def simulate(self, y0, t_end: float, rtol: float = 1e-10, atol: float = 1e-12,
                 extra_events=(), max_switches: int = 2000) -> Run:
        """Integrate from y0 to t_end by segments; the mode at the start follows from y0 (contact
        when penetrating with the law pushing). `extra_events`: (name, function(t, y), direction)
        located without a restart in every segment. Returns a `Run`."""
        y = np.array(y0, dtype=float)
        push, d, _ = self._push(y)
        mode = CONTACT if min(d, push) > 0 else FLIGHT
        names = ["stick", "slip"] + [e[0] for e in extra_events]
        extra = [(fun, direction) for _, fun, direction in extra_events]
        run = Run(self)
        t, max_step = 0.0, math.inf
        while t < t_end:
            if len(run.switches) > max_switches:
                raise RuntimeError(f"more than {max_switches} switches by t = {t}")
            y[6:10] /= np.linalg.norm(y[6:10])
            sol = solve_ivp(self.rhs, (t, t_end), y, method="DOP853" if mode == FLIGHT else "Radau",
                            rtol=rtol, atol=atol, events=self._events(mode, extra), args=(mode,),
                            dense_output=True, max_step=max_step)
            if not sol.success:
                raise RuntimeError(sol.message)
            run._add(sol, mode)
            for name, te_k, ye_k in zip(names, sol.t_events[1:], sol.y_events[1:]):
                if name in ("stick", "slip") and mode == FLIGHT:
                    continue  # a rim point in the air has no slip
                run.events.extend((float(te), name, ye) for te, ye in zip(te_k, ye_k))
            t, y = float(sol.t[-1]), sol.y[:, -1].copy()
            if sol.status == 1:  # the law switched
                d = self._kinematics(y)[4]
                name = ("touchdown" if abs(d) < 1e-9 else "re-engage") if mode == FLIGHT else "lift_off"
                max_step = math.inf
                if mode == CONTACT:  # the law stops pushing at d > 0: the spring's store is lost
                    y[13] += 0.5 * self.wheel.M * self.kappa * d * d
                    # free fall is a polynomial DOP853 steps over whole: a bounce that fits in one
                    # step would go unseen, so a step is at most a quarter of the ballistic flight
                    dd, g_n = self._kinematics(y)[5], -self.g_vec[2]
                    max_step = max(0.5 * -dd / g_n, 1e-7) if g_n > 0 and dd < 0 else math.inf
                run.switches.append((t, name, y.copy()))
                mode = 1 - mode
        run.events.sort(key=lambda e: e[0])
        return run


@dataclass
class Run:
    """A simulation: the accepted steps (t (N,), y (N, 17), mode (N,)), the law's switches and the
    other events as [(t, name, y)], and `at(t)`/`out(t)` on the segments' dense output."""
    model: SoftWheel
    t: list = field(default_factory=list)
    y: list = field(default_factory=list)
    mode: list = field(default_factory=list)
    segments: list = field(default_factory=list)
    switches: list = field(default_factory=list)
    events: list = field(default_factory=list)

    def _add(self, sol, mode):
        self.t.extend(sol.t)
        self.y.extend(sol.y.T)
        self.mode.extend([mode] * len(sol.t))
        self.segments.append((sol.t[0], sol.t[-1], mode, sol.sol))

    def at(self, t: float) -> tuple[np.ndarray, int]:
        """(state (17,), mode) at time t (the later segment at a switch)."""
        for t0, t1, mode, dense in reversed(self.segments):
            if t0 <= t <= t1:
                return dense(t), mode
        raise ValueError(f"t = {t} outside the run")

    def out(self, t: float) -> dict[str, float]:
        return self.model.outputs(*self.at(t))

    def series(self, times) -> dict[str, np.ndarray]:
        """`out` at each of `times` (N,): {name: (N,)}, the names of `SoftWheel.outputs`."""
        rows = [self.out(float(t)) for t in times]
        return {k: np.array([row[k] for row in rows]) for k in rows[0]}

    def named(self, name: str) -> list[tuple[float, np.ndarray]]:
        """[(t, state)] of the switches (touchdown, re-engage, lift_off) or events (stick, slip,
        the extra events' names) of that name, in time order."""
        return [(t, y) for t, n, y in self.switches + self.events if n == name]
