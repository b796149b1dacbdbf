"""The impact at touchdown: Coulomb friction integrated over the impulse, never creating energy.

A rigid body touching the ground at one point receives the impulse P = (P_t1, P_t2, P_n) there
(ground frame: two tangential components, then the normal one, ground on body). In contact space
the impact is linear (Stronge, "Impact Mechanics", 2000, ch. 4-5):

    u+ = u- + W P,     W = J M^-1 J^T (3 x 3, the Delassus matrix),     v+ = v- + M^-1 J^T P,

with u = J v the contact point's velocity, M the generalised mass matrix, J the contact Jacobian.
The kinetic energy changes by dT = P . u- + P . W P / 2.

The law (Darboux-Keller: the impact resolved in the normal impulse P_n, W constant):
1. Sliding (slip v = u_t != 0): du/dP_n = W (-mu v/|v|, 1). The slip's direction turns during the
   impact; model/impulse_ode.py integrates this to 1e-10 (tests/test_impact_law.py).
2. The slip reaching 0: sticking if |W_tt^-1 W_tn| <= mu (Stronge's stick ratio; P_t then grows by
   -W_tt^-1 W_tn dP_n, keeping u_t = 0); else sliding on along the one direction s on which the slip
   grows, W_tn - mu W_tt s = lam s, lam > 0 (`_reslip_direction`).
3. Compression ends at u_n = 0; restitution ends where the normal force's work int u_n dP_n has
   given back e^2 of what compression took (Stronge's energetic coefficient e). A rebound below
   v_rest ends at the end of compression instead (u_n+ = 0): a slow impact becomes a persistent
   contact, which ends a bouncing wheel's geometric series of impacts.
4. Energy: with Coulomb friction and the energetic rule the impact only dissipates (Stronge ch. 5);
   against rounding, and where the cone cannot be met at all (W_nn <= mu |W_nt|, a jam, sliding
   would drive the contact point into the ground), the frictionless impulse P = (0, 0, c / W_nn),
   c the rebound minus the approach speed, for which dT = -(1 - e^2) u_n-^2 / (2 W_nn) <= 0.
The end mode: rolling if the impact ended sticking (2), sliding otherwise.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from gyrowheel.model.impulse_ode import grid_function

RESLIP_ITERATIONS = 12  # Newton steps of the secular equation of the re-slip direction


@dataclass
class ImpactResult:
    """Symbolic (or numeric, ca.DM) results of one impact, contact space (t1, t2, n)."""

    P: ca.SX  # (3,) impulse on the body, N s
    u_plus: ca.SX  # (3,) contact point velocity after, m/s
    dT: ca.SX  # kinetic energy change, J (<= 0)
    sticking: ca.SX  # 1 if the impact ended with the contact point stuck tangentially, else 0
    persistent: ca.SX  # 1 if the normal velocity after is 0 (a slow impact), else 0


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
    """The impact state y (5,) = (u_t1, u_t2, u_n, P_n, E_n) after dp more normal impulse at the
    constant rate du/dP_n = d (3,)."""
    return ca.vertcat(y[0:3] + d * dp, y[3] + dp, y[4] + y[2] * dp + 0.5 * d[2] * dp ** 2)


@dataclass
class _Piece:
    """A part of the impact at a constant du/dP_n = d (3,), from y (5,) over length (N s) or,
    unbounded, to the end."""
    y: ca.SX
    d: ca.SX
    length: ca.SX
    unbounded: ca.SX


def _compression_in(pc: _Piece):
    """(found, state): where u_n reaches 0 in the piece."""
    un, dn = pc.y[2], pc.d[2]
    dp = -un / dn
    found = ca.logic_and(un < 0, ca.logic_or(pc.unbounded, dp <= pc.length))
    return found, _advance(pc.y, pc.d, dp)


def _restitution_in(pc: _Piece, target):
    """(found, state): where E_n reaches target with u_n >= 0 in the piece."""
    un, dn = pc.y[2], pc.d[2]
    dp_c = ca.fmax(-un / dn, 0)  # the piece's start, or its end of compression
    y = _advance(pc.y, pc.d, dp_c)
    room = ca.fmax(target - y[4], 0)
    dp = 2 * room / (y[2] + ca.sqrt(y[2] ** 2 + 2 * dn * room))  # the root on the rising branch
    dp = ca.if_else(room > 0, dp, 0)
    found = ca.logic_and(y[4] <= target, ca.logic_or(pc.unbounded, dp_c + dp <= pc.length))
    found = ca.logic_and(found, ca.logic_or(pc.unbounded, dp_c <= pc.length))
    return found, _advance(y, pc.d, dp)


def impact(W, u_minus, e, mu, v_rest) -> ImpactResult:
    """The impulse of a touchdown in contact space (module docstring).

    W: (3, 3) Delassus matrix J M^-1 J^T, 1/kg, symmetric positive definite; u_minus: (3,) contact
    point velocity before, m/s, (t1, t2, n) with u_n < 0 approaching; e: Stronge's energetic
    coefficient of restitution, 0..1; mu: Coulomb's friction coefficient >= 0; v_rest: m/s, normal
    speeds after below it become 0. Works on CasADi SX (symbolic) or DM/float (numeric) arguments
    alike. Returns an ImpactResult. Sources: Stronge, "Impact Mechanics" (2000), ch. 4-5; Batlle,
    "Rough balanced collisions" (1996); Glocker, "Set-valued force laws" (2001)."""
    W, u = ca.SX(W), ca.SX(u_minus)
    A, bt, Wnn = W[0:2, 0:2], W[0:2, 2], W[2, 2]
    un = u[2]
    v0 = u[0:2]
    r0 = ca.sqrt(ca.dot(v0, v0))
    sliding = r0 > 0
    jam = Wnn <= mu * ca.norm_2(bt)

    # after the slip reaches 0: sticking (P_t grows by -A^-1 b dP_n) or re-slip on a fixed ray
    stick_rate = ca.solve(A, bt)
    holds = ca.dot(stick_rate, stick_rate) <= mu ** 2
    s_r = _reslip_direction(A, bt, mu)
    Pt_rate = ca.if_else(holds, -stick_rate, -mu * s_r)
    d_after = ca.mtimes(W, ca.vertcat(Pt_rate, 1))

    # sliding: the tau grid, then the slip's last bit on its final direction
    y0 = ca.vertcat(u, 0, 0)
    g_end, g_found_c, g_y_c, g_found_r, g_y_r = grid_function()(y0, W, mu, e)
    yN = ca.if_else(sliding, g_end, y0)
    rN = ca.sqrt(ca.dot(yN[0:2], yN[0:2]))
    sN = ca.if_else(rN > 0, yN[0:2] / ca.if_else(rN > 0, rN, 1), ca.vertcat(1, 0))
    fN = ca.dot(sN, bt - mu * ca.mtimes(A, sN))  # d|v|/dP_n on it
    converging = ca.logic_and(rN > 0, fN < 0)
    # a growing slip where sticking cannot hold turns onto the one ray on which it grows, s_r
    sN = ca.if_else(ca.logic_or(converging, holds), sN, s_r)
    d_slide = ca.mtimes(W, ca.vertcat(-mu * sN, 1))
    tail = _Piece(yN, d_slide, ca.if_else(converging, rN / ca.if_else(converging, -fN, 1), 0),
                  ca.logic_and(rN > 0, ca.logic_not(converging)))
    y_stick = _advance(yN, d_slide, tail.length)
    y_stick = ca.vertcat(0, 0, y_stick[2:5])
    after = _Piece(y_stick, d_after, ca.SX(0), ca.SX(1))

    grid_c = ca.logic_and(sliding, g_found_c)
    tail_c, y_tail_c = _compression_in(tail)
    _, y_after_c = _compression_in(after)
    y_c = ca.if_else(grid_c, g_y_c, ca.if_else(tail_c, y_tail_c, y_after_c))
    y_c = ca.if_else(un < 0, y_c, y0)
    target = (1 - e ** 2) * y_c[4]  # Stronge: the restitution work is e^2 the compression's
    grid_r_found = ca.logic_and(grid_c, g_found_r)
    tail_r, y_tail_r = _restitution_in(tail, target)
    _, y_after_r = _restitution_in(after, target)
    y_f = ca.if_else(grid_r_found, g_y_r, ca.if_else(tail_r, y_tail_r, y_after_r))
    y_f = ca.if_else(un < 0, y_f, y0)
    in_after_f = ca.logic_not(ca.logic_or(ca.logic_and(sliding, ca.logic_or(grid_r_found, tail_r)),
                                          ca.logic_and(rN > 0, ca.logic_not(converging))))
    in_after_c = ca.logic_not(ca.logic_or(ca.logic_and(sliding, ca.logic_or(grid_c, tail_c)),
                                          ca.logic_and(rN > 0, ca.logic_not(converging))))

    persistent = y_f[2] <= v_rest
    y_end = ca.if_else(persistent, y_c, y_f)
    u_end = ca.vertcat(y_end[0:2], ca.if_else(persistent, 0, y_end[2]))
    stuck = ca.logic_and(holds, ca.if_else(persistent, in_after_c, in_after_f))
    u_end = ca.vertcat(ca.if_else(stuck, 0, u_end[0]), ca.if_else(stuck, 0, u_end[1]), u_end[2])
    P = ca.solve(W, u_end - u)

    # a jam (W_nn <= mu |W_nt|: sliding could drive the contact point into the ground) and, against
    # rounding, any energy gain: the frictionless impulse, for which dT = -(1 - e^2) u_n^2 / (2 W_nn)
    c = ca.if_else(-e * un <= v_rest, 0, -e * un) - un
    frictionless = ca.vertcat(0, 0, c / Wnn)
    a, b = ca.mtimes([P.T, W, P]), ca.dot(P, u)
    gains = b + 0.5 * a > 1e-12 * ca.fabs(b)  # beyond rounding
    fallback = ca.logic_or(jam, gains)
    P = ca.if_else(fallback, frictionless, P)
    u_plus = u + ca.mtimes(W, P)
    u_plus = ca.if_else(fallback, u_plus, u_end)
    dT = ca.dot(P, u) + 0.5 * ca.mtimes([P.T, W, P])
    return ImpactResult(P=P, u_plus=u_plus, dT=dT,
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
