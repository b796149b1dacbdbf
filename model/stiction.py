"""True stiction for Coulomb laws: the constraint row, the mode update, exact stuck rates.

A law declared with WheelContext.stiction (model/context.py, StickSlip) has a mode m in
{-1, 0, +1} carried as a state with zero derivative. While stuck (m = 0) its rate r is held by
the extra constraint r_dot = 0, whose multiplier H (the holding force) is solved in the same
linear system as the accelerations and the normal force (model/lagrangian.py, conditions);
while sliding the Coulomb force -L m opposes the motion. The event indicator (StickSlip.indicator)
fires when a sliding rate reaches zero or the holding force reaches the breakaway limit
L (1 + BREAKAWAY); its update (this module) gives the state after the switch:

    x_trial = x with m = 0 and the speeds projected so that r = 0 exactly
    m+      = 0                if m != 0 and L |L| (1 + BREAKAWAY)^2 - H^2 > 0 at x_trial   (holds: stick)
            = -sign(H(x_trial)) otherwise                                           (slide that way)
    x+      = x_trial with m = m+

The same rule serves sticking (a sliding rate reached zero and the holding force needed is
within the limit, L > 0: the law's `holding` form, the stuck indicator itself), reversing (it is
not: the wheel turns back) and breaking away (a stuck law fires only when its indicator has
reached 0, so it always leaves the stuck mode: it cannot re-stick at the located point, whose
indicator a rounding may leave a hair above 0, and fire again at once). After sticking the stuck
indicator is > 0; after sliding off, m+ r = 0: neither fires again until it has become > 0. The
projection changes one independent speed (the one with the largest coefficient in r) by the
residual rate the event location left, about 1e-12 of the motion, so the kinetic energy changes
only to second order in it; the stuck constraint itself does no work (H r = 0).
"""
from __future__ import annotations

from typing import Callable

import casadi as ca

from gyrowheel.model.context import BREAKAWAY, StickSlip


def stuck_rate_rows(laws: list[StickSlip], x: ca.SX, bind: Callable) -> dict[int, ca.SX]:
    """{row of x: stuck factor s} for laws whose rate is one state of x (e.g. gamma_dot).

    Their derivative is multiplied by s = m^2 (1 while sliding, 0 while stuck: StickSlip.stuck
    is 1 - m^2, the row's factor its complement), so that while stuck the rate stays exactly 0
    (the linear solve gives r_dot = 0 only to rounding); arithmetic, no branch.
    """
    rows = {}
    for law in laws:
        r = bind(law.rate)
        if r.is_symbolic():
            for j in range(x.numel()):
                if ca.is_equal(x[j], r):
                    rows[j] = law.stuck
    return rows


def _with_rows(x: ca.SX, rows: list[int], values: ca.SX) -> ca.SX:
    """x with the entries `rows` replaced by `values` (a copy)."""
    out = ca.SX(x)
    for i, row in enumerate(rows):
        out[row] = values[i]
    return out


def _projection(r_v: ca.SX, vs: ca.SX, v_now: ca.SX) -> ca.SX:
    """Speeds v close to v_now with r(v) = 0: one speed k solved for, the others kept.

    r is linear in the speeds, r = sum_j a_j v_j; k is the speed with the largest |a_k| (a
    nested if_else when several coefficients are structurally non-zero); v_k = -(r - a_k v_k)/a_k,
    so that r(v) is exactly 0 in floating point when a_k = 1.
    """
    a = ca.jacobian(r_v, vs)
    if ca.depends_on(a, vs):
        raise ValueError("a stiction law's rate must be linear in the speeds")
    candidates = [k for k in range(vs.numel()) if not a[k].is_zero()]
    if not candidates:
        raise ValueError("a stiction law's rate does not depend on the speeds")

    def solved(k):
        rest = ca.substitute(r_v, vs[k], ca.SX(0))
        vk = ca.SX(0) if rest.is_zero() else -ca.substitute(rest, vs, v_now) / ca.substitute(a[k], vs, v_now)
        v = ca.SX(v_now)
        v[k] = vk
        return v

    best, best_abs = solved(candidates[0]), ca.fabs(a[candidates[0]])
    for k in candidates[1:]:
        bigger = ca.fabs(a[k]) > best_abs
        best = ca.if_else(bigger, solved(k), best)
        best_abs = ca.fmax(ca.fabs(a[k]), best_abs)
    return best


def law_update(law: StickSlip, x: ca.SX, bind: Callable, mode_row: int, speed_rows: list[int],
               speeds_now: ca.SX, to_state: Callable[[ca.SX], ca.SX]) -> ca.SX:
    """The state after the mode switch of `law` at x (module docstring), an expression of (t, x, u, p).

    mode_row: the law's mode in x; speed_rows: the rows of x holding the speed part of the state;
    speeds_now: the independent speeds as expressions of x; to_state(v): the speed part of the
    state for independent speeds v (the identity in the reduced form, S(q) v with multipliers).
    """
    vs = ca.SX.sym("vs", speeds_now.numel())
    r_v = ca.substitute(bind(law.rate), x[speed_rows], to_state(vs))
    if ca.depends_on(r_v, x[speed_rows]):
        raise ValueError(f"stiction law {law.name}: its rate is not a function of the speeds")
    v_new = _projection(r_v, vs, speeds_now)
    x_trial = _with_rows(x, speed_rows, to_state(v_new))
    x_trial[mode_row] = 0
    hold = ca.substitute(bind(law.hold), x, x_trial)
    # a law that fires while stuck has reached its limit: it breaks away, whatever the holding
    # test gives at the located point (a rounding there must not re-stick it, to fire again)
    holds = ca.logic_and(x[mode_row] != 0, ca.substitute(bind(law.holding()), x, x_trial) > 0)
    x_new = ca.SX(x_trial)
    x_new[mode_row] = ca.if_else(holds, 0, ca.if_else(hold > 0, -1, 1))
    return x_new
