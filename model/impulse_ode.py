"""The sliding part of an impact: the contact velocity integrated over the normal impulse while
the slip turns, the normal impulse given by a Kelvin-Voigt contact in its rigid limit (Darboux-
Keller; Stronge, "Impact Mechanics", 2000, ch. 2, 4-5; Batlle, 1996).

Contact space (t1, t2, n), W = J M^-1 J^T constant during the impact, blocks A = W_tt (2 x 2),
b = W_tn (2,), W_nn. While the contact point slides with slip v = u_t != 0, Coulomb's law adds
-mu v/|v| dP_n to the tangential impulse:

    du_t/dP_n = b - mu A v/|v|,     du_n/dP_n = W_nn - mu b.v/|v|.

The normal impulse: a spring and damper along the normal, F_n = kappa d + c d' (d the compression,
d' = -u_n), c = 2 zeta sqrt(kappa m), m = 1 / W_nn the frictionless effective mass, zeta the
damping ratio whose restitution is e (`damping_ratio`), ending where F_n returns to 0 (it never
pulls). With G = F_n / sqrt(kappa / m) = psi - 2 zeta m u_n, psi = sqrt(kappa m) d (N s), the
stiffness kappa drops out: dpsi = -m u_n dP_n / G, and the rigid limit is one impulse law.
Friction changes du_n/dP_n, hence the contact's effective stiffness and damping ratio during the
impact (zeta sqrt(m du_n/dP_n)): the rebound is not a fixed fraction of the approach.

In chi, with dP_n = |v| G dchi, everything is smooth (polynomial in v, |v| and G):

    dv/dchi = G (|v| b - mu A v),  du_n/dchi = G (|v| W_nn - mu b.v),  dP_n/dchi = |v| G,
    dpsi/dchi = -m u_n |v|,

the contact ends at G = 0 (G falling), and the slip v reaches 0 (the contact point sticks) only
as chi -> infinity, exponentially, along an invariant ray of its direction. `grid_function`
integrates this over STEPS steps of the 8th-order Runge-Kutta formula of Dormand and Prince
(DOP853's, Hairer, Norsett & Wanner, Solving ODEs I, 1993, II.5; the coefficients of
c_src/gw_dop853_tableau.h) and locates the end of compression (u_n = 0) and the end of the contact
(G = 0) inside a step by Newton's method on a re-taken step from the step's start. The grid is a
loop in the generated C (casadi mapaccum), called from the impact's expression (`never_inline`).

Shapes: the state y is (5,) = (v_1, v_2, u_n, P_n, psi), m/s, m/s, m/s, N s, N s.
"""
from __future__ import annotations

import math
import re
from functools import lru_cache
from importlib import resources

import casadi as ca

STEPS = 240
TURN = 0.4  # a step turns the slip's direction by at most about this (rad)
SWING = 0.08  # a step advances the normal oscillation by at most this phase (rad)
NEWTON = 6  # Newton iterations locating an event inside a step
STAGES = 12
JAM_SLIP = 1e-10  # slip / max|u-| below which a jamming direction is passed in no finite impulse
END = 5  # the `_quantity` row of -G (rising to 0 at the end of the contact)


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


def field(y: ca.SX, W: ca.SX, mu, zeta) -> ca.SX:
    """dy/dchi (5,) of the sliding impact (module docstring)."""
    v = y[0:2]
    r = ca.sqrt(ca.dot(v, v))
    bt = W[0:2, 2]
    G = y[4] - 2 * zeta * y[2] / W[2, 2]
    dv = G * (r * bt - mu * ca.mtimes(W[0:2, 0:2], v))
    return ca.vertcat(dv, G * (r * W[2, 2] - mu * ca.dot(bt, v)), r * G, -y[2] * r / W[2, 2])


def _quantity(y: ca.SX, zeta, W: ca.SX, row: int) -> ca.SX:
    """y[row], or for row END -G (the normal force's measure, negated: rising to 0 at the end)."""
    return -(y[4] - 2 * zeta * y[2] / W[2, 2]) if row == END else y[row]


@lru_cache(maxsize=None)
def step_function() -> ca.Function:
    """gw_impulse_step(y (5,), h, W (3 x 3), mu, zeta) -> y after one DOP853 step of size h in chi."""
    a, b = _tableau()
    y, h, W = ca.SX.sym("y", 5), ca.SX.sym("h"), ca.SX.sym("W", 3, 3)
    mu, zeta = ca.SX.sym("mu"), ca.SX.sym("zeta")
    k = []
    for i in range(STAGES):
        yi = y
        for j in range(i):
            if a[i][j] != 0.0:
                yi = yi + (h * a[i][j]) * k[j]
        k.append(field(yi, W, mu, zeta))
    out = y + h * sum(b[i] * k[i] for i in range(STAGES) if b[i] != 0.0)
    return ca.Function("gw_impulse_step", [y, h, W, mu, zeta], [out], ["y", "h", "W", "mu", "zeta"],
                       ["y_next"], {"never_inline": True})


def _locate_function(row: int) -> ca.Function:
    """locate(start (5,), s0, s_max, W, mu, zeta) -> (y (5,), s): where `_quantity` row (rising)
    reaches 0, by a DOP853 step of size s from start, s found by Newton's method from s0 and kept
    in [0, s_max]."""
    start, s0, s_max = ca.SX.sym("start", 5), ca.SX.sym("s0"), ca.SX.sym("s_max")
    W, mu, zeta = ca.SX.sym("W", 3, 3), ca.SX.sym("mu"), ca.SX.sym("zeta")
    step = step_function()
    ys_sym = ca.SX.sym("ys", 5)
    q = _quantity(ys_sym, zeta, W, row)
    dq = ca.Function("dq", [ys_sym, W, mu, zeta], [q, ca.dot(ca.gradient(q, ys_sym), field(ys_sym, W, mu, zeta))])
    s = s0
    for _ in range(NEWTON):
        value, rate = dq(step(start, s, W, mu, zeta), W, mu, zeta)
        s = s - ca.if_else(rate > 0, value / ca.if_else(rate > 0, rate, 1), 0)
        s = ca.fmin(ca.fmax(s, 0), s_max)
    return ca.Function(f"gw_impulse_locate{row}", [start, s0, s_max, W, mu, zeta],
                       [step(start, s, W, mu, zeta), s])


def _interp(lo, hi, span):
    """Linear interpolation of where a quantity rising from lo to hi over span reaches 0."""
    frac = ca.if_else(hi > lo, -lo / ca.if_else(hi > lo, hi - lo, 1), 0)
    return span * ca.fmin(ca.fmax(frac, 0), 1)


def _advance_function() -> ca.Function:
    """advance(y (5,), W, mu, zeta, L) -> (y after one grid step, the step h): h = min(h_turn,
    SWING / (|v| w)), h_turn from h rate (G + |dG/dchi| h) = TURN, rate the smaller of L = |b| +
    mu |A|_F and the sum of the local rates of the slip's direction and size (how fast the direction
    turns per unit G chi), and w = sqrt(m du_n/dP_n) max(1, 2 zeta sqrt(m du_n/dP_n)) (the normal oscillation's
    frequency and damping rate per unit time-like sigma, dsigma = |v| dchi)."""
    y, W, mu = ca.SX.sym("y", 5), ca.SX.sym("W", 3, 3), ca.SX.sym("mu")
    zeta, L = ca.SX.sym("zeta"), ca.SX.sym("L")
    r = ca.sqrt(ca.dot(y[0:2], y[0:2]))
    s = y[0:2] / ca.if_else(r > 0, r, 1)
    n = ca.vertcat(-s[1], s[0])
    A = W[0:2, 0:2]
    R = W[0:2, 2] - mu * ca.mtimes(A, s)
    f, g = ca.dot(s, R), ca.dot(n, R)
    # the direction's local rates: f = d ln|v|, g = dtheta, and their derivatives in theta
    dg, df = f + mu * ca.dot(n, ca.mtimes(A, n)), g - mu * ca.dot(s, ca.mtimes(A, n))  # -dg/dtheta, df/dtheta
    local = ca.fabs(f) + ca.fabs(g) + ca.fabs(dg) + ca.fabs(df)
    rate = ca.fmin(L, local)
    G = y[4] - 2 * zeta * y[2] / W[2, 2]
    k_n = W[2, 2] - mu * ca.dot(W[0:2, 2], y[0:2]) / ca.if_else(r > 0, r, 1)
    w = ca.sqrt(ca.fmax(k_n, 1e-6 * W[2, 2]) / W[2, 2])
    w = w * ca.fmax(1, 2 * zeta * w)
    # G changes over the step too (from 0 at the start of an elastic contact): h rate (G + |G'| h) <= TURN
    dG = ca.fabs(-y[2] * r / W[2, 2] - 2 * zeta / W[2, 2] * G * (r * W[2, 2] - mu * ca.dot(W[0:2, 2], y[0:2])))
    h_turn = 2 * TURN / ca.fmax(rate * G + ca.sqrt((rate * G) ** 2 + 4 * rate * dG * TURN), 1e-300)
    h_swing = SWING / ca.fmax(r * w, 1e-300)
    h = ca.fmin(h_turn, h_swing)
    return ca.Function("gw_impulse_advance", [y, W, mu, zeta, L],
                       [step_function()(y, h, W, mu, zeta), h])


def _scan(row: int) -> ca.Function:
    """scan(carry (8,), y_lo (5,), y_hi (5,), h, zeta, W) -> carry: (found, start (5,), s0, s_max)
    of the step in which `_quantity` row crosses 0 upwards (u_n: at most one step, as it rises
    along the grid; -G: the first, at the end of the contact)."""
    carry, y_lo, y_hi, h = ca.SX.sym("carry", 8), ca.SX.sym("y_lo", 5), ca.SX.sym("y_hi", 5), ca.SX.sym("h")
    zeta, W = ca.SX.sym("zeta"), ca.SX.sym("W", 3, 3)
    lo, hi = _quantity(y_lo, zeta, W, row), _quantity(y_hi, zeta, W, row)
    here = ca.logic_and(ca.logic_and(lo < 0, hi >= 0), carry[0] == 0)
    new = ca.vertcat(1, y_lo, _interp(lo, hi, h), h)
    return ca.Function(f"gw_impulse_scan{row}", [carry, y_lo, y_hi, h, zeta, W], [ca.if_else(here, new, carry)])


@lru_cache(maxsize=None)
def grid_function() -> ca.Function:
    """gw_impulse_grid(y0 (5,), W (3 x 3), mu, zeta) -> (y_end (5,), compression found, y_c (5,),
    contact end found, y_r (5,), jam before compression's end, jam before the contact's end): the
    sliding impact integrated over the chi grid from y0 (slip v != 0), where its compression
    (u_n = 0) and its contact (G = 0) end if they lie in it, and whether a grid point it passes
    before either end jams (`_jams`)."""
    y0, W, mu, zeta = ca.MX.sym("y0", 5), ca.MX.sym("W", 3, 3), ca.MX.sym("mu"), ca.MX.sym("zeta")
    rate = ca.norm_2(W[0:2, 2]) + mu * ca.sqrt(ca.sumsqr(W[0:2, 0:2]))
    rep = lambda v: ca.repmat(v, 1, STEPS)  # noqa: E731
    Y, H = _advance_function().mapaccum("gw_impulse_advances", STEPS)(y0, rep(W), rep(mu), rep(zeta), rep(rate))
    Y_lo = ca.horzcat(y0, Y[:, 0:STEPS - 1])
    found, ys = [], []
    for row in (2, END):
        scans = _scan(row).mapaccum(f"gw_impulse_scans{row}", STEPS)
        carry = scans(ca.DM.zeros(8), Y_lo, Y, H, rep(zeta), rep(W))[:, -1]
        found.append(carry[0])
        ys.append(_locate_function(row)(carry[1:6], carry[6], carry[7], W, mu, zeta)[0])
    jam_c, jam_r = _jams(ca.horzcat(y0, Y), W, mu, zeta)
    return ca.Function("gw_impulse_grid", [y0, W, mu, zeta],
                       [Y[:, -1], found[0], ys[0], found[1], ys[1], jam_c, jam_r],
                       ["y0", "W", "mu", "zeta"], ["y_end", "found_c", "y_c", "found_r", "y_r", "jam_c", "jam_r"],
                       {"never_inline": True})


def _jams(Y: ca.MX, W: ca.MX, mu, zeta) -> tuple[ca.MX, ca.MX]:
    """(jam before the end of compression, jam before the end of the contact): 1 where the normal
    rate du_n/dP_n = W_nn - mu W_nt . v/|v| is <= 0 at a grid point Y (5 x N, the slip v != 0) the
    impact passes before that end (u_n < 0, resp. G >= 0, at every grid point up to it), else 0.
    There sliding drives the contact point into the ground (a jam: Stronge, "Impact Mechanics",
    2000, ch. 5; Batlle, 1996); the rate on a slip direction the impact does not traverse is no jam,
    nor is it on a slip below JAM_SLIP max|u-| (Y[:, 0] the approach): a converging slip's
    direction keeps turning as it dies out, over a normal impulse of the order of the slip itself."""
    v = Y[0:2, :]
    r = ca.sqrt(ca.sum1(v * v))
    rate = W[2, 2] * r - mu * ca.mtimes(W[2, 0:2], v)  # |v| du_n/dP_n
    G = Y[4, :] - 2 * zeta * Y[2, :] / W[2, 2]
    before_c = ca.cumsum(Y[2, :] >= 0, 1) == 0
    before_r = ca.cumsum(G < 0, 1) == 0
    jammed = (rate <= 0) * (r > JAM_SLIP * ca.mmax(ca.fabs(Y[0:3, 0])))
    return ca.sum2(jammed * before_c) > 0, ca.sum2(jammed * before_r) > 0


def restitution(zeta):
    """e of the damping ratio zeta (SX or float): the rebound of the Kelvin-Voigt contact that
    stops pushing (tests/reference/soft_contact.py, restitution_of_damping, the same closed form):
    with s = sqrt(|1 - zeta^2|), x the phase s w t where the force returns to 0,
    e = exp(-zeta x / s) (zeta / s sin x - cos x) (sinh, cosh for zeta > 1)."""
    under = zeta < 1
    s = ca.sqrt(ca.fmax(ca.fabs(1 - zeta ** 2), 1e-30))
    x_u = math.pi - ca.atan2(2 * zeta * s, 1 - 2 * zeta ** 2)
    arg = ca.fmin(2 * zeta * s / ca.fmax(2 * zeta ** 2 - 1, 1e-300), 1 - 1e-16)
    x_o = ca.atanh(arg)
    e_u = ca.exp(-zeta * x_u / s) * (zeta / s * ca.sin(x_u) - ca.cos(x_u))
    e_o = ca.exp(-zeta * x_o / s) * (zeta / s * ca.sinh(x_o) - ca.cosh(x_o))
    return ca.if_else(under, e_u, e_o)


DAMPING_NEWTON = 30


def damping_ratio(e):
    """The damping ratio zeta >= 0 of restitution e in (0, 1] (`restitution` inverted by Newton's
    method in ln(zeta) from the estimate -ln(e) / sqrt(pi^2 + ln(e)^2) of the oscillator that may
    pull); 0 for e = 1. e = 0 has no finite zeta (the caller makes that impact plastic)."""
    z = ca.SX.sym("z")  # ln(zeta)
    f = ca.log(restitution(ca.exp(z)))
    fun = ca.Function("gw_restitution_log", [z], [f, ca.jacobian(f, z)])
    le = ca.log(ca.fmin(ca.fmax(e, 1e-12), 1))
    z = ca.log(ca.fmax(-le / ca.sqrt(math.pi ** 2 + le ** 2), 1e-300))
    for _ in range(DAMPING_NEWTON):
        value, slope = fun(z)
        z = z - ca.if_else(slope < 0, (value - le) / ca.if_else(slope < 0, slope, -1), 0)
    return ca.if_else(e >= 1, 0, ca.exp(z))
