"""The impact at touchdown: Newton's restitution with Coulomb's limit, never creating energy.

A rigid body touching the ground at one point receives the impulse P = (P_t1, P_t2, P_n) there
(ground frame: two tangential components, then the normal one, ground on body). In contact space
the impact is linear (Kelly's report, "temporary constraints"; Stronge, "Impact Mechanics", 2000,
ch. 5):

    u+ = u- + W P,     W = J M^-1 J^T (3 x 3, the Delassus matrix),     v+ = v- + M^-1 J^T P,

with u = J v the contact point's velocity, M the generalised mass matrix, J the contact Jacobian.
The kinetic energy changes by dT = P . u- + P . W P / 2.

The law (every step a fixed number of operations, so that it is one CasADi expression):
1. Normal target: u_n+ = -e u_n- (Newton), or 0 when that is below v_rest: a slow impact
   becomes a persistent contact, which ends a bouncing wheel's geometric series of impacts.
2. Sticking: the impulse P_s = W^-1 (u_target - u-) that stops the contact point tangentially and
   meets the normal target, if it lies in the friction cone |P_t| <= mu P_n.
3. Sliding otherwise: the impulse on the cone's boundary that meets the normal target and is
   nearest to P_s in W's metric (the largest dissipation Coulomb's law allows, the principle of
   maximal dissipation); with P_n eliminated by the normal target the boundary is a closed convex
   curve P_t = r(phi) (cos phi, sin phi), r = mu c / (W_nn + mu W_nt . d), c = u_n,target - u_n-,
   searched at SAMPLES angles and refined by Newton steps.
4. Energy: a kinematic restitution with friction can create energy (Stronge ch. 5.4: the normal
   target and the coupling W_nt together). If dT > 0 the impulse is scaled down to the largest
   s < 1 with dT(s P) = 0 (still in the cone, which is a cone), provided the contact point then no
   longer approaches the ground; else, and when the cone cannot be met at all
   (W_nn <= mu |W_nt|, a jam), the frictionless impulse P = (0, 0, c / W_nn), for which
   dT = -(1 - e^2) u_n-^2 / (2 W_nn) <= 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca

SAMPLES = 24  # boundary angles searched before the Newton refinement
NEWTON_STEPS = 6


@dataclass
class ImpactResult:
    """Symbolic (or numeric, ca.DM) results of one impact, contact space (t1, t2, n)."""

    P: ca.SX  # (3,) impulse on the body, N s
    u_plus: ca.SX  # (3,) contact point velocity after, m/s
    dT: ca.SX  # kinetic energy change, J (<= 0)
    sticking: ca.SX  # 1 if the contact point stopped tangentially (step 2), else 0
    persistent: ca.SX  # 1 if the normal velocity after is 0 (a slow impact), else 0


def _boundary_impulse(W: ca.SX, c: ca.SX, mu, phi):
    """The impulse on the cone's boundary at tangential angle phi meeting the normal target
    (W P)_n = c (step 3); shape (3,)."""
    d = ca.vertcat(ca.cos(phi), ca.sin(phi))
    w_nt = ca.vertcat(W[2, 0], W[2, 1])
    r = mu * c / (W[2, 2] + mu * ca.dot(w_nt, d))
    Pt = r * d
    Pn = (c - ca.dot(w_nt, Pt)) / W[2, 2]
    return ca.vertcat(Pt, Pn)


def _sliding_impulse(W: ca.SX, c: ca.SX, mu, P_s: ca.SX) -> ca.SX:
    """Step 3: the boundary impulse nearest to P_s in W's metric, shape (3,)."""
    phi = ca.SX.sym("phi")
    Wp, cp, mup, Psp = ca.SX.sym("W", 3, 3), ca.SX.sym("c"), ca.SX.sym("mu"), ca.SX.sym("Ps", 3)
    P = _boundary_impulse(Wp, cp, mup, phi)
    h = 0.5 * ca.mtimes([(P - Psp).T, Wp, P - Psp])
    dh = ca.jacobian(h, phi)
    d2h = ca.jacobian(dh, phi)
    fh = ca.Function("impact_h", [phi, Wp, cp, mup, Psp], [h, dh, d2h])
    best_phi, best_h = 0.0, None
    for k in range(SAMPLES):
        a = 2 * math.pi * k / SAMPLES
        hk = fh(a, W, c, mu, P_s)[0]
        if best_h is None:
            best_phi, best_h = ca.SX(a), hk
        else:
            better = hk < best_h
            best_phi, best_h = ca.if_else(better, a, best_phi), ca.if_else(better, hk, best_h)
    limit = math.pi / SAMPLES  # a Newton step stays within the sampled bracket
    for _ in range(NEWTON_STEPS):
        _, g, H = fh(best_phi, W, c, mu, P_s)
        step = ca.if_else(H > 0, -g / H, -ca.sign(g) * limit)
        best_phi = best_phi + ca.fmin(ca.fmax(step, -limit), limit)
    return _boundary_impulse(W, c, mu, best_phi)


def impact(W, u_minus, e, mu, v_rest) -> ImpactResult:
    """The impulse of a touchdown in contact space (module docstring, steps 1-4).

    W: (3, 3) Delassus matrix J M^-1 J^T, 1/kg, symmetric positive definite; u_minus: (3,) contact
    point velocity before, m/s, (t1, t2, n) with u_n < 0 approaching; e: Newton's coefficient of
    restitution, 0..1; mu: Coulomb's friction coefficient >= 0; v_rest: m/s, normal speeds after
    below it become 0. Works on CasADi SX (symbolic) or DM/float (numeric) arguments alike. Returns
    an ImpactResult. Sources: Stronge, "Impact Mechanics" (2000), ch. 5; the maximal dissipation
    principle of Moreau's frictional impact law."""
    W, u = ca.SX(W), ca.SX(u_minus)
    un = u[2]
    bounce = -e * un
    persistent = bounce <= v_rest
    un_target = ca.if_else(persistent, 0, bounce)
    c = un_target - un
    target = ca.vertcat(0, 0, un_target)
    P_s = ca.solve(W, target - u)
    inside = ca.logic_and(P_s[2] >= 0, ca.dot(P_s[:2], P_s[:2]) <= (mu * P_s[2]) ** 2)
    w_nt = ca.sqrt(W[2, 0] ** 2 + W[2, 1] ** 2)
    jam = W[2, 2] <= mu * w_nt
    frictionless = ca.vertcat(0, 0, c / W[2, 2])
    P = ca.if_else(inside, P_s, ca.if_else(jam, frictionless, _sliding_impulse(W, c, mu, P_s)))
    a, b = ca.mtimes([P.T, W, P]), ca.dot(P, u)
    gains = b + 0.5 * a > 0
    s_zero = -2 * b / a  # dT(s P) = s b + s^2 a / 2 = 0
    s_contact = -un / c  # (W s P)_n = s c: the contact point stops approaching at s >= s_contact
    scaled = ca.if_else(s_zero >= s_contact, s_zero * P, frictionless)
    P = ca.if_else(gains, scaled, P)
    u_plus = u + ca.mtimes(W, P)
    dT = ca.dot(P, u) + 0.5 * ca.mtimes([P.T, W, P])
    sticking = ca.logic_and(inside, ca.logic_not(gains))
    return ImpactResult(P=P, u_plus=u_plus, dT=dT, sticking=sticking,
                        persistent=ca.logic_and(persistent, ca.logic_not(gains)))


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
