"""The impact at touchdown: a spring-damper contact's rigid limit with Coulomb friction.

A rigid body touching the ground at one point receives the impulse P = (P_t1, P_t2, P_n) there
(ground frame: two tangential components, then the normal one, ground on body). In contact space
the impact is linear (Stronge, "Impact Mechanics", 2000, ch. 4-5):

    u+ = u- + W P,     W = J M^-1 J^T (3 x 3, the Delassus matrix),     v+ = v- + M^-1 J^T P,

with u = J v the contact point's velocity, M the generalised mass matrix, J the contact Jacobian.
The kinetic energy changes by dT = P . u- + P . W P / 2.

The law (Darboux-Keller: the impact resolved in the normal impulse P_n, W constant):
1. Sliding (slip v = u_t != 0): du/dP_n = W (-mu v/|v|, 1); the slip's direction turns during the
   impact. Sticking once the slip reaches 0 if |W_tt^-1 W_tn| <= mu (Stronge's stick ratio; P_t
   then grows by -W_tt^-1 W_tn dP_n, keeping u_t = 0); else sliding on along the one direction s on
   which the slip grows, W_tn - mu W_tt s = lam s, lam > 0 (`_reslip_direction`).
2. The normal impulse is that of a Kelvin-Voigt contact (a linear spring and damper along the
   normal that never pulls) in its rigid limit, the damping ratio zeta the one whose frictionless
   rebound is e (model/impulse_ode.py: the stiffness drops out). It ends where the contact force
   returns to 0. A rebound below v_rest ends at the end of compression instead (u_n+ = 0): a slow
   impact becomes a persistent contact, which ends a bouncing wheel's geometric series of impacts;
   e = 0 is that plastic end.
   Why this rule and not a fixed one: friction changes du_n/dP_n = W_nn - mu W_nt.s, the contact's
   effective stiffness, with the slip's direction, and with it the damping ratio that decides the
   rebound (zeta sqrt(m du_n/dP_n), m = 1 / W_nn). Newton's (u_n+ = -e u_n-), Poisson's
   (P_n = (1 + e) P_c) and Stronge's energetic rule (restitution gives back e^2 of compression's
   work) all keep e fixed; each differs from the compliant contact by up to 5-12 % of |u-| on
   random impacts (tests/test_impact_law.py). This rule meets the soft-contact reference's
   converged second touchdown of a leaning drop (tests/test_contact_soft_modes.py) to 2e-8 s.
   For e = 1 (no damper) it is the energetic rule, for an upright impact (W_nt = 0) Newton's.
3. Energy and jams: the spring-damper with Coulomb friction only dissipates. A jam is a slip
   direction s the impact slides in with du_n/dP_n = W_nn - mu W_nt.s <= 0 (sliding drives the
   contact point into the ground; no rigid solution: Stronge ch. 5, Batlle 1996): checked on the
   grid's points to the end of compression (plastic) or of the contact, the last sliding stretch
   and the re-slip ray s_r; a stuck contact's rate W_nn - W_nt.A^-1 b (the Schur complement of
   W) is > 0, so sticking never jams, and a converging slip below JAM_SLIP max|u-| is passed in no
   finite impulse. In a jam, and against rounding where the result would gain energy, the
   frictionless impulse P = (0, 0, c / W_nn), c the rebound (e |u_n-|, or 0 below v_rest) minus
   the approach speed, for which dT = -(1 - e^2) u_n-^2 / (2 W_nn) <= 0.
The end mode: rolling if the impact ended sticking (1), sliding otherwise.
Measured (.venv/bin/python -m pytest -q tests/test_impact_law.py -s): against scipy's integration
of the same contact in time 6e-11 of |u-| at most over 300 random impacts with mu in 0..1.5 and
300 with mu in 1..10 (77 jams on the path found by both), of the impulse ODE for
e = 1 3e-11 over 100; 3000 random impacts never gain energy (dT / T- <= -3e-4).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from gyrowheel.model.impulse_ode import JAM_SLIP, damping_ratio, grid_function

RESLIP_ITERATIONS = 12  # Newton steps of the secular equation of the re-slip direction
OSCILLATOR_NEWTON = 8  # Newton steps of the time at which u_n reaches a value (_Oscillator.reaching)


@dataclass
class ImpactResult:
    """Symbolic (or numeric, ca.DM) results of one impact, contact space (t1, t2, n)."""

    P: ca.SX  # (3,) impulse on the body, N s
    u_plus: ca.SX  # (3,) contact point velocity after, m/s
    dT: ca.SX  # kinetic energy change, J (<= 0)
    sticking: ca.SX  # 1 if the impact ended with the contact point stuck tangentially, else 0
    persistent: ca.SX  # 1 if the normal velocity after is 0 (a slow impact), else 0
    jam: ca.SX  # 1 if sliding along the slip's path drove the contact into the ground (frictionless P)


def _reslip_direction(A: ca.SX, bt: ca.SX, mu) -> ca.SX:
    """The slip direction s (2,) on which sliding resumes after the slip reached 0 where sticking
    cannot hold (|A^-1 b| > mu): b - mu A s = lam s with lam > 0 (the invariant ray along which the
    slip grows), i.e. s = (lam I + mu A)^-1 b with |s| = 1. |(lam I + mu A)^-1 b| falls from
    |A^-1 b| / mu > 1 at lam = 0 to 0, so lam is unique; Newton's method on 1 / |s(lam)| - 1 (concave)
    from lam_0 = max(|b| - mu a_max, 0) <= lam, a_max A's larger eigenvalue, converges from below."""
    half_tr, det = 0.5 * (A[0, 0] + A[1, 1]), A[0, 0] * A[1, 1] - A[0, 1] ** 2
    a_max = half_tr + ca.sqrt(ca.fmax(half_tr ** 2 - det, 0))
    lam = ca.fmax(ca.norm_2(bt) - mu * a_max, 0)
    for _ in range(RESLIP_ITERATIONS):
        K = lam * ca.SX.eye(2) + mu * A
        x = ca.solve(K, bt)
        xx = ca.dot(x, x)
        dxx = -2 * ca.dot(x, ca.solve(K, x))  # d|x|^2 / dlam
        # psi = 1/|x| - 1, dpsi = -dxx / (2 |x|^3)
        lam = lam + ca.if_else(dxx < 0, (1 / ca.sqrt(xx) - 1) * 2 * xx * ca.sqrt(xx) / dxx, 0)
    s = ca.solve(lam * ca.SX.eye(2) + mu * A, bt)
    return s / ca.sqrt(ca.dot(s, s))


def _advance(y: ca.SX, d: ca.SX, dp) -> ca.SX:
    """u and P_n of the impact state y (5,) = (u_t1, u_t2, u_n, P_n, psi) after dp more normal
    impulse at the constant rate du/dP_n = d (3,) (psi left as it is: for a compression's end only)."""
    return ca.vertcat(y[0:3] + d * dp, y[3] + dp, y[4])


class _Oscillator:
    """The Kelvin-Voigt contact from the impact state y (5,) at a constant du/dP_n = d (3,).

    In sigma (dsigma = dP_n / G, the time scaled by sqrt(kappa / m)) u_n' = k G (k = d_n) and
    G' = -m u_n - 2 zeta m k G: G'' + 2 a G' + w^2 G = 0 with a = zeta m k, w^2 = m k, a damped
    oscillator: G = e^(-a sigma) (G_0 C + Q S), Q = G'(0) + a G_0, C = cos(b sigma), S =
    sin(b sigma) / b, b^2 = w^2 - a^2 (cosh, sinh for b^2 < 0; 1, sigma at b = 0), and
    u_n = -(G' + 2 a G) / m."""

    def __init__(self, y: ca.SX, d: ca.SX, zeta, Wnn):
        self.y, self.d, self.zeta, self.m = y, d, zeta, 1 / Wnn
        m, k = self.m, d[2]
        self.G0 = y[4] - 2 * zeta * m * y[2]
        self.a, w2 = zeta * m * k, m * k
        self.Q = -m * y[2] - self.a * self.G0
        self.b2 = w2 - self.a ** 2
        self.tiny = 1e-14 * w2
        self.b = ca.sqrt(ca.fmax(ca.fabs(self.b2), self.tiny))

    def _cs(self, sig):
        """(C, S, C', S') at sig."""
        b, under, over = self.b, self.b2 > self.tiny, self.b2 < -self.tiny
        C = ca.if_else(under, ca.cos(b * sig), ca.if_else(over, ca.cosh(b * sig), 1))
        S = ca.if_else(under, ca.sin(b * sig) / b, ca.if_else(over, ca.sinh(b * sig) / b, sig))
        dC = ca.if_else(under, -b * ca.sin(b * sig), ca.if_else(over, b * ca.sinh(b * sig), 0))
        return C, S, dC, C

    def G(self, sig):
        C, S, _, _ = self._cs(sig)
        return ca.exp(-self.a * sig) * (self.G0 * C + self.Q * S)

    def un(self, sig):
        C, S, dC, dS = self._cs(sig)
        inner = self.G0 * C + self.Q * S
        dG = ca.exp(-self.a * sig) * (self.G0 * dC + self.Q * dS - self.a * inner)
        return -(dG + 2 * self.a * ca.exp(-self.a * sig) * inner) / self.m

    def end(self):
        """sigma of the contact's end, the first zero of G after 0 (the force's)."""
        G0, Q, b = self.G0, self.Q, self.b
        t_under = ca.atan2(G0 * b, -Q) / b
        x = ca.fmin(G0 * b / ca.fmax(-Q, 1e-300), 1 - 1e-16)
        t_over = ca.if_else(Q < 0, ca.atanh(x) / b, 1 / ca.sqrt(self.tiny))
        t_crit = G0 / ca.fmax(-Q, 1e-300)
        return ca.if_else(self.b2 > self.tiny, t_under, ca.if_else(self.b2 < -self.tiny, t_over, t_crit))

    def reaching(self, un_target, sig_max):
        """sigma in [0, sig_max] where u_n reaches un_target (u_n rises: u_n' = k G >= 0)."""
        sig = ca.fmin((un_target - self.y[2]) / (self.d[2] * ca.fmax(self.G0, 1e-300)), sig_max)
        for _ in range(OSCILLATOR_NEWTON):
            rate = self.d[2] * self.G(sig)
            sig = sig - ca.if_else(rate > 0, (self.un(sig) - un_target) / ca.if_else(rate > 0, rate, 1), 0)
            sig = ca.fmin(ca.fmax(sig, 0), sig_max)
        return sig

    def state(self, sig):
        """The impact state (5,) at sig."""
        un = self.un(sig)
        dp = (un - self.y[2]) / self.d[2]
        return ca.vertcat(self.y[0:2] + self.d[0:2] * dp, un, self.y[3] + dp,
                          self.G(sig) + 2 * self.zeta * self.m * un)


def impact(W, u_minus, e, mu, v_rest) -> ImpactResult:
    """The impulse of a touchdown in contact space (module docstring).

    W: (3, 3) Delassus matrix J M^-1 J^T, 1/kg, symmetric positive definite; u_minus: (3,) contact
    point velocity before, m/s, (t1, t2, n) with u_n < 0 approaching; e: the restitution of a
    frictionless impact, 0..1 (the Kelvin-Voigt contact's damping ratio is calibrated to it);
    mu: Coulomb's friction coefficient >= 0; v_rest: m/s, normal speeds after below it become 0.
    Works on CasADi SX (symbolic) or DM/float (numeric) arguments alike. Returns an ImpactResult.
    Sources: Stronge, "Impact Mechanics" (2000), ch. 2, 4-5; Batlle, "Rough balanced collisions"
    (1996); Hunt & Crossley (1975) for the spring-damper that never pulls."""
    W, u = ca.SX(W), ca.SX(u_minus)
    A, bt, Wnn = W[0:2, 0:2], W[0:2, 2], W[2, 2]
    un = u[2]
    v0 = u[0:2]
    r0 = ca.sqrt(ca.dot(v0, v0))
    sliding = r0 > 0
    zeta = damping_ratio(e)
    plastic = e <= 0

    # after the slip reaches 0: sticking (P_t grows by -A^-1 b dP_n) or re-slip on a fixed ray
    stick_rate = ca.solve(A, bt)
    holds = ca.dot(stick_rate, stick_rate) <= mu ** 2
    s_r = _reslip_direction(A, bt, mu)
    d_after = ca.mtimes(W, ca.vertcat(ca.if_else(holds, -stick_rate, -mu * s_r), 1))

    # sliding: the chi grid, then the slip's last bit on its final direction
    y0 = ca.vertcat(u, 0, 0)
    g_end, g_found_c, g_y_c, g_found_e, g_y_e, g_jam_c, g_jam_e = grid_function()(y0, W, mu, zeta)
    yN = ca.if_else(sliding, g_end, y0)
    rN = ca.sqrt(ca.dot(yN[0:2], yN[0:2]))
    sN = ca.if_else(rN > 0, yN[0:2] / ca.if_else(rN > 0, rN, 1), ca.vertcat(1, 0))
    fN = ca.dot(sN, bt - mu * ca.mtimes(A, sN))  # d|v|/dP_n on it
    converging = ca.logic_and(rN > 0, fN < 0)
    growing = ca.logic_and(rN > 0, ca.logic_not(converging))  # slides on to the end
    # a growing slip where sticking cannot hold turns onto the one ray on which it grows, s_r
    s_end = ca.if_else(holds, sN, s_r)
    d_slide = ca.mtimes(W, ca.vertcat(-mu * ca.if_else(converging, sN, s_end), 1))
    tail = ca.if_else(converging, rN / ca.if_else(converging, -fN, 1), 0)  # P_n to the stop
    osc_tail = _Oscillator(yN, d_slide, zeta, Wnn)
    sig_e_tail = osc_tail.end()
    un_stop = yN[2] + d_slide[2] * tail
    ends_in_tail = ca.logic_and(converging, osc_tail.un(sig_e_tail) <= un_stop)
    y_stop = osc_tail.state(osc_tail.reaching(un_stop, sig_e_tail))
    y_stop = ca.vertcat(0, 0, y_stop[2:5])
    y_a = ca.if_else(converging, y_stop, yN)  # the last part, at the constant rate d_a
    d_a = ca.if_else(growing, d_slide, d_after)
    osc_a = _Oscillator(y_a, d_a, zeta, Wnn)

    in_grid_c = ca.logic_and(sliding, g_found_c)
    in_tail_c = ca.logic_and(converging, ca.logic_and(yN[2] < 0, un_stop >= 0))
    y_tail_c = _advance(yN, d_slide, -yN[2] / d_slide[2])
    y_a_c = _advance(y_a, d_a, ca.fmax(-y_a[2] / d_a[2], 0))
    y_c = ca.if_else(in_grid_c, g_y_c, ca.if_else(in_tail_c, y_tail_c, y_a_c))
    in_grid_e = ca.logic_and(sliding, g_found_e)
    y_e = ca.if_else(in_grid_e, g_y_e, ca.if_else(ends_in_tail, osc_tail.state(sig_e_tail), osc_a.state(osc_a.end())))

    # a jam: du_n/dP_n = W_nn - mu W_nt . s <= 0 on a slip direction s the impact traverses (the grid's
    # points, the last sliding stretch d_slide, the re-slip after the stop d_after; sticking never
    # jams: its rate W_nn - W_nt . A^-1 b is the Schur complement of W, > 0); to the end of
    # compression for a plastic impact, to the end of the contact otherwise
    # (a converging slip's last stretch only if longer than JAM_SLIP max|u-|: impulse_ode._jams)
    long_tail = ca.logic_or(growing, rN > JAM_SLIP * ca.mmax(ca.fabs(u)))

    def jams(grid_jam, in_grid, in_tail):
        on_slide = ca.logic_and(ca.logic_and(sliding, long_tail), ca.logic_not(in_grid))
        on_after = ca.logic_and(ca.logic_not(ca.logic_or(in_grid, in_tail)), ca.logic_not(growing))
        return ca.logic_or(ca.logic_and(sliding, grid_jam),
                           ca.logic_or(ca.logic_and(on_slide, d_slide[2] <= 0),
                                       ca.logic_and(on_after, d_after[2] <= 0)))
    jam = ca.if_else(plastic, jams(g_jam_c, in_grid_c, in_tail_c), jams(g_jam_e, in_grid_e, ends_in_tail))

    persistent = ca.logic_or(plastic, y_e[2] <= v_rest)
    y_end = ca.if_else(persistent, y_c, y_e)
    ends_sliding = ca.if_else(persistent, ca.logic_or(in_grid_c, in_tail_c), ca.logic_or(in_grid_e, ends_in_tail))
    stuck = ca.logic_and(ca.logic_and(holds, ca.logic_not(growing)), ca.logic_not(ends_sliding))
    u_end = ca.vertcat(ca.if_else(stuck, 0, y_end[0]), ca.if_else(stuck, 0, y_end[1]),
                       ca.if_else(persistent, 0, y_end[2]))
    P = ca.solve(W, u_end - u)

    # a jam (above: the contact point driven into the ground by sliding, the rigid impact has no
    # solution) and, against rounding, any energy gain: the frictionless impulse, for which
    # dT = -(1 - e^2) u_n^2 / (2 W_nn)
    c = ca.if_else(-e * un <= v_rest, 0, -e * un) - un
    frictionless = ca.vertcat(0, 0, c / Wnn)
    a, b = ca.mtimes([P.T, W, P]), ca.dot(P, u)
    gains = b + 0.5 * a > 1e-12 * ca.fabs(b)  # beyond rounding
    fallback = ca.logic_or(jam, gains)
    P = ca.if_else(fallback, frictionless, P)
    u_plus = ca.if_else(fallback, u + ca.mtimes(W, P), u_end)
    dT = ca.dot(P, u) + 0.5 * ca.mtimes([P.T, W, P])
    return ImpactResult(P=P, u_plus=u_plus, dT=dT, jam=jam,
                        sticking=ca.logic_and(stuck, ca.logic_not(fallback)),
                        persistent=ca.if_else(fallback, -e * un <= v_rest, persistent))


def generalised_impact(M, J, v_minus, e, mu, v_rest):
    """The impact in generalised coordinates: (v_plus (n,), ImpactResult).

    M: (n, n) generalised mass matrix, SPD; J: (3, n) contact Jacobian, rows (t1, t2, n) of the
    contact point's velocity; v_minus: (n,) generalised velocity before. v+ = v- + M^-1 J^T P."""
    M, J, v = ca.SX(M), ca.SX(J), ca.SX(v_minus)
    MinvJt = ca.solve(M, J.T)
    W = ca.mtimes(J, MinvJt)
    W = 0.5 * (W + W.T)
    result = impact(W, ca.mtimes(J, v), e, mu, v_rest)
    return v + ca.mtimes(MinvJt, result.P), result
