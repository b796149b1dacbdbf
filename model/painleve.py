"""The Painleve stop: where rigid Coulomb sliding has no solution, the run ends with its reason.

While the wheel slides (model/contact_modes.py), the normal force solves a_n = N + D F_n = 0 with

    D = W_nn - mu_k W_nt . e       (1/kg)

the contact's effective normal inverse mass under Coulomb friction: W = J M^-1 J^T the Delassus
matrix of the free wheel at the contact point (M the flight speeds' mass matrix, J = d u / d w, u
the lowest rim point's velocity, rows x, y, z; model/flight_system.py), W_nn its normal entry, W_nt
= (W_zx, W_zy), e the friction direction (the unit vector the Coulomb force -mu_k F_n e opposes).
F_n = -N / D diverges as D -> 0+; for D <= 0 the rigid model has no solution or more than one (the
Painleve paradox: Painleve 1895; Stewart, "Rigid-body dynamics with friction and impact", SIAM
Review 42, 2000; Genot & Brogliato, "New results on Painleve paradoxes", Eur. J. Mech. A 1999, the
dynamic jam). The same D limits an impact (model/impact.py, "jam").

The event `painleve` (action terminate, flag `painleve_paradox`) fires where, while sliding,

    D / W_nn - PAINLEVE_MARGIN

reaches 0; its indicator is 1 in every other mode, so a switch into sliding (rolling -> sliding, a
touchdown that lands sliding) at D / W_nn <= PAINLEVE_MARGIN takes it from > 0 to <= 0 in the
switch's instant and the run stops there (the runtime's event iteration), and a start sliding there
is refused at initialisation. D <= 0 is inside that range: there the sliding F_n = -N / D comes out
negative wherever the free contact point accelerates into the ground (N < 0), which is no lift-off;
so with flight (model/contact_flight.py) sliding never lifts off at D / W_nn <= PAINLEVE_MARGIN, and
a touchdown whose sliding end mode lies there lands sliding (and stops here) whatever F_n's sign. Why D / W_nn and not F_n: F_n = -N / D is large wherever the normal
load N is large (a fast wheel's centripetal terms), and where N < 0 the wheel lifts off (F_n <= 0)
whatever D is; D / W_nn is the dimensionless share of the frictionless normal compliance that
friction leaves, a property of the attitude and of mu_k alone, 1 without friction. At the margin
F_n is 1 / PAINLEVE_MARGIN times the frictionless normal force of the same state.
Rolling resistance and spin friction (limits c F_n) are left out of D: their moments' share is of
order c / R (<= 1e-2 for the scenes' values) of W_nn.
"""
from __future__ import annotations

from typing import Callable

import casadi as ca

from gyrowheel.model.context import WheelContext
from gyrowheel.model.flight_system import free_system
from gyrowheel.model.spec import Event, Quantity

PAINLEVE_MARGIN = 0.05  # D / W_nn below which sliding stops: F_n 20 times the frictionless one


def delassus(ctx: WheelContext) -> ca.SX:
    """W = J M^-1 J^T (3 x 3, 1/kg, symmetric positive definite) of the free wheel at its lowest rim
    point, rows and columns ground x, y, z: M the free system's mass matrix in its speeds (the
    centre's velocity, the angle rates, the effects' free rates; model/flight_system.py), J the
    rim point's velocity w[0:3] + omega x R l differentiated by them. An expression of the
    coordinates (state symbols) and parameters; the driven coordinates take their values."""
    fs = free_system(ctx)
    w = fs.qd[:fs.n_free]
    M = ca.hessian(fs.T, w)[0]
    u = w[0:3] + ca.cross(ctx.kin.omega, ctx.par["R"] * ctx.kin.l)
    J = ca.jacobian(u, w)
    W = ca.mtimes(J, ca.solve(M, J.T))
    driven = [k for k in ctx.coords if not k.free and k.value is not None]
    if driven:
        W = ca.substitute(W, ca.vertcat(*[k.q for k in driven]), ca.vertcat(*[k.value for k in driven]))
    return 0.5 * (W + W.T)


def normal_share(W: ca.SX, mu_k: ca.SX, e: ca.SX) -> ca.SX:
    """D / W_nn = 1 - mu_k W_nt . e / W_nn (1): W the Delassus matrix (3 x 3, rows x, y, z), mu_k
    the kinetic coefficient, e (2,) the friction direction (the slip's, unit)."""
    return 1 - mu_k * ca.dot(W[2, 0:2].T, e) / W[2, 2]


def painleve_gap(ctx: WheelContext, bind_s: Callable, direction: ca.SX) -> ca.SX:
    """D / W_nn - PAINLEVE_MARGIN (1) of the sliding mode, an expression of (t, x, u, p): <= 0 where
    sliding has no rigid solution (module docstring), whatever the sign of D. bind_s: the sliding
    mode's binding; direction: the friction direction e (2, placeholders) of the sliding force."""
    return normal_share(delassus(ctx), ctx.sliding.mu_k, bind_s(direction)) - PAINLEVE_MARGIN


def painleve_event(ctx: WheelContext, bind_s: Callable, direction: ca.SX) -> Event:
    """The event painleve (module docstring), an expression of (t, x, u, p). bind_s: the sliding
    mode's binding; direction: the friction direction e (2, placeholders) of the sliding force."""
    sl = ctx.sliding
    sliding = ca.logic_and(sl.mode.sym > 0.5, sl.mode.sym < 1.5)
    indicator = ca.if_else(sliding, painleve_gap(ctx, bind_s, direction), 1)
    flag = Quantity("painleve_paradox", "", f"true once sliding has reached D / W_nn <= {PAINLEVE_MARGIN} (D = W_nn - "
                    "mu_k W_nt . e, the effective normal inverse mass under Coulomb friction): the normal force "
                    "diverges there and the rigid Coulomb contact has no solution beyond (Painleve's paradox), "
                    "so the run stops (event painleve); lower mu_k")
    return Event("painleve", indicator, "terminate", flag)
