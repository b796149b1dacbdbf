"""The sliding part of an impact: the contact velocity integrated in the normal impulse while the
slip turns (Darboux-Keller; Stronge, "Impact Mechanics", 2000, ch. 4-5; Batlle, 1996).

Contact space (t1, t2, n), W = J M^-1 J^T constant during the impact, blocks A = W_tt (2 x 2),
b = W_tn (2,), W_nn. While the contact point slides with slip v = u_t != 0 (direction s = v / |v|),
Coulomb's law adds -mu s dP_n to the tangential impulse:

    du_t/dP_n = b - mu A s,     du_n/dP_n = W_nn - mu b.s,     dE_n/dP_n = u_n,

E_n = int u_n dP_n the normal force's work (J, negative while the body approaches). The field is
singular at v = 0. In tau, dP_n = |v| dtau (impulse per unit slip, 1/kg^-1 s^... : tau has units of
kg s / m... any positive scale), it is smooth and homogeneous of degree one in v:

    dv/dtau = |v| b - mu A v,   du_n/dtau = |v| W_nn - mu b.v,   dP_n/dtau = |v|,   dE_n/dtau = u_n |v|,

and v reaches 0 (the contact point sticks) only as tau -> infinity, exponentially, along an
invariant ray of the slip direction. `slide` integrates this system over a fixed tau span of
SPAN / L (L = |b| + mu |A|_F, the rate at which the slip direction turns) in STEPS steps of the
8th-order Runge-Kutta formula of Dormand and Prince (DOP853's, Hairer, Norsett & Wanner, Solving
ODEs I, 1993, II.5; the coefficients of c_src/gw_dop853_tableau.h), and locates the end of
compression (u_n = 0) and the end of restitution (E_n = a target) inside a step by Newton's
method on a re-taken step from the step's start. The step is one CasADi function called at
every step (a call node, `never_inline`): the generated C holds it once.

Shapes: the state y is (5,) = (v_1, v_2, u_n, P_n, E_n), m/s, m/s, m/s, N s, J.
"""
from __future__ import annotations

import re
from functools import lru_cache
from importlib import resources

import casadi as ca

SPAN = 96.0  # tau span in units of 1 / L: the slip direction's turn decays over many e-folds
STEPS = 192
P_STEP = 8.0  # a step takes at most p_0 / P_STEP of normal impulse (slide)
NEWTON = 6  # Newton iterations locating an event inside a step
STAGES = 12


def _tableau() -> tuple[list[list[float]], list[float]]:
    """(a (12 x 12), b (12,)) of DOP853's 8th-order solution, read from the runtime's header."""
    text = resources.files("gyrowheel.c_src").joinpath("gw_dop853_tableau.h").read_text()

    def table(name: str) -> str:
        start = text.index(name)
        return text[start:text.index(";", start)]

    a = [[0.0] * STAGES for _ in range(STAGES)]
    body = table("dop_a[16][16]")
    for row in re.finditer(r"\[(\d+)\] = \{([^{}]*)\}", body):
        i = int(row.group(1))
        if i < STAGES:
            for j, val in re.findall(r"\[(\d+)\] = ([-+0-9.eE]+)", row.group(2)):
                a[i][int(j)] = float(val)
    b = [0.0] * STAGES
    for j, val in re.findall(r"\[(\d+)\] = ([-+0-9.eE]+)", table("dop_b[12]")):
        b[int(j)] = float(val)
    return a, b


def field(y: ca.SX, W: ca.SX, mu: ca.SX) -> ca.SX:
    """dy/dtau (5,) of the sliding impact (module docstring)."""
    v = y[0:2]
    r = ca.sqrt(ca.dot(v, v))
    bt = W[0:2, 2]
    dv = r * bt - mu * ca.mtimes(W[0:2, 0:2], v)
    return ca.vertcat(dv, r * W[2, 2] - mu * ca.dot(bt, v), r, y[2] * r)


@lru_cache(maxsize=None)
def step_function() -> ca.Function:
    """impulse_step(y (5,), h, W (3 x 3), mu) -> y after one DOP853 step of size h in tau."""
    a, b = _tableau()
    y, h, W, mu = ca.SX.sym("y", 5), ca.SX.sym("h"), ca.SX.sym("W", 3, 3), ca.SX.sym("mu")
    k = []
    for i in range(STAGES):
        yi = y
        for j in range(i):
            if a[i][j] != 0.0:
                yi = yi + (h * a[i][j]) * k[j]
        k.append(field(yi, W, mu))
    out = y + h * sum(b[i] * k[i] for i in range(STAGES) if b[i] != 0.0)
    return ca.Function("gw_impulse_step", [y, h, W, mu], [out], ["y", "h", "W", "mu"], ["y_next"],
                       {"never_inline": True})


def _locate_function(row: int) -> ca.Function:
    """locate(start (5,), s0, s_max, W, mu, target) -> (y (5,), s): where y[row] (increasing)
    reaches target, by a DOP853 step of size s from start, s found by Newton's method from s0 and
    kept in [0, s_max]."""
    start, s0, s_max = ca.SX.sym("start", 5), ca.SX.sym("s0"), ca.SX.sym("s_max")
    W, mu, target = ca.SX.sym("W", 3, 3), ca.SX.sym("mu"), ca.SX.sym("target")
    step = step_function()
    s = s0
    for _ in range(NEWTON):
        ys = step(start, s, W, mu)
        rate = field(ys, W, mu)[row]
        s = s - ca.if_else(rate > 0, (ys[row] - target) / ca.if_else(rate > 0, rate, 1), 0)
        s = ca.fmin(ca.fmax(s, 0), s_max)
    return ca.Function(f"gw_impulse_locate{row}", [start, s0, s_max, W, mu, target],
                       [step(start, s, W, mu), s])


def _interp(lo, hi, target, span):
    """Linear interpolation of where target lies between lo and hi over span, in [0, span]."""
    frac = ca.if_else(hi > lo, (target - lo) / ca.if_else(hi > lo, hi - lo, 1), 0)
    return span * ca.fmin(ca.fmax(frac, 0), 1)


def _advance_function() -> ca.Function:
    """advance(y (5,), W, mu, h_max, p_step) -> (y after one grid step, the step h) (`grid`)."""
    y, W, mu = ca.SX.sym("y", 5), ca.SX.sym("W", 3, 3), ca.SX.sym("mu")
    h_max, p_step = ca.SX.sym("h_max"), ca.SX.sym("p_step")
    r = ca.sqrt(ca.dot(y[0:2], y[0:2]))
    h = ca.if_else(r * h_max > p_step, p_step / ca.if_else(r > 0, r, 1), h_max)
    return ca.Function("gw_impulse_advance", [y, W, mu, h_max, p_step], [step_function()(y, h, W, mu), h])


def _compression_scan() -> ca.Function:
    """scan(carry (8,), y_lo (5,), y_hi (5,), h) -> carry: (found, start (5,), s0, s_max) of the
    step in which u_n reaches 0 (u_n rises along the grid: one step at most)."""
    carry, y_lo, y_hi, h = ca.SX.sym("carry", 8), ca.SX.sym("y_lo", 5), ca.SX.sym("y_hi", 5), ca.SX.sym("h")
    here = ca.logic_and(y_lo[2] < 0, y_hi[2] >= 0)
    new = ca.vertcat(1, y_lo, _interp(y_lo[2], y_hi[2], 0, h), h)
    return ca.Function("gw_impulse_scan_c", [carry, y_lo, y_hi, h], [ca.if_else(here, new, carry)])


def _restitution_scan() -> ca.Function:
    """scan(carry (8,), y_lo, y_hi, h, y_c (5,), s_c, target, s_from_c) -> carry of the step in
    which E_n reaches target after the end of compression y_c (in the step that holds y_c the
    search starts there, s_c into it, Newton from s_from_c)."""
    carry, y_lo, y_hi, h = ca.SX.sym("carry", 8), ca.SX.sym("y_lo", 5), ca.SX.sym("y_hi", 5), ca.SX.sym("h")
    y_c, s_c, target, from_c = ca.SX.sym("y_c", 5), ca.SX.sym("s_c"), ca.SX.sym("target"), ca.SX.sym("from_c")
    split = y_lo[2] < 0  # the step that holds the end of compression: its part after it
    lo = ca.if_else(split, y_c, y_lo)
    span = ca.if_else(split, h - s_c, h)
    here = ca.logic_and(y_hi[2] >= 0, ca.logic_and(lo[4] < target, y_hi[4] >= target))
    s0 = ca.if_else(split, ca.fmin(from_c, span), _interp(lo[4], y_hi[4], target, span))
    new = ca.vertcat(1, lo, s0, span)
    return ca.Function("gw_impulse_scan_r", [carry, y_lo, y_hi, h, y_c, s_c, target, from_c],
                       [ca.if_else(here, new, carry)])


@lru_cache(maxsize=None)
def grid_function() -> ca.Function:
    """gw_impulse_grid(y0 (5,), W (3 x 3), mu, e) -> (y_end (5,), compression found, y_c (5,),
    restitution found, y_r (5,)): the sliding impact integrated over the tau grid from y0 (slip
    v != 0), its end of compression (u_n = 0) and end of restitution (E_n = (1 - e^2) E_n(y_c),
    Stronge's energetic rule) where they lie in it.

    Step k has h_k = min(SPAN / (STEPS L), p_0 / (P_STEP |v_k|)), p_0 = |u_n| / W_nn the normal
    impulse of a frictionless plastic impact: while the slip is fast at most a P_STEP-th of p_0
    per step, so that the grid covers the impact; while it is slow, the turn of the slip's direction
    over SPAN e-folds, so that it covers the approach to sticking. A loop in the generated C
    (casadi mapaccum), called from the impact's expression (`never_inline`)."""
    y0, W, mu, e = ca.MX.sym("y0", 5), ca.MX.sym("W", 3, 3), ca.MX.sym("mu"), ca.MX.sym("e")
    rate = ca.norm_2(W[0:2, 2]) + mu * ca.sqrt(ca.sumsqr(W[0:2, 0:2]))
    h_max = SPAN / (STEPS * (rate + 1e-9 * W[2, 2]))
    p_step = ca.fabs(y0[2]) / (P_STEP * W[2, 2])
    rep = lambda v: ca.repmat(v, 1, STEPS)  # noqa: E731
    Y, H = _advance_function().mapaccum("gw_impulse_advances", STEPS)(y0, rep(W), rep(mu), rep(h_max), rep(p_step))
    Y_lo = ca.horzcat(y0, Y[:, 0:STEPS - 1])
    carry = _compression_scan().mapaccum("gw_impulse_scans_c", STEPS)(ca.DM.zeros(8), Y_lo, Y, H)[:, -1]
    found_c = carry[0]
    y_c, s_c = _locate_function(2)(carry[1:6], carry[6], carry[7], W, mu, 0)
    target = (1 - e ** 2) * y_c[4]
    rates = _field_function()(y_c, W, mu)
    curvature = rates[2] * rates[3]  # from y_c (u_n = 0) E_n rises as (u_n' |v|) s^2 / 2
    from_c = ca.sqrt(2 * ca.fmax(target - y_c[4], 0) / ca.if_else(curvature > 0, curvature, 1))
    carry = _restitution_scan().mapaccum("gw_impulse_scans_r", STEPS)(
        ca.DM.zeros(8), Y_lo, Y, H, rep(y_c), rep(s_c), rep(target), rep(from_c))[:, -1]
    y_r, _ = _locate_function(4)(carry[1:6], carry[6], carry[7], W, mu, target)
    return ca.Function("gw_impulse_grid", [y0, W, mu, e],
                       [Y[:, -1], found_c, y_c, ca.logic_and(found_c, carry[0]), y_r],
                       ["y0", "W", "mu", "e"], ["y_end", "found_c", "y_c", "found_r", "y_r"],
                       {"never_inline": True})


def _field_function() -> ca.Function:
    """field(y (5,), W, mu) -> dy/dtau (5,) as a function (for MX callers)."""
    y, W, mu = ca.SX.sym("y", 5), ca.SX.sym("W", 3, 3), ca.SX.sym("mu")
    return ca.Function("gw_impulse_field", [y, W, mu], [field(y, W, mu)])
