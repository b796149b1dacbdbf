"""The touchdown impact law (model/impact.py) against results it did not produce.

Measured numbers below: `.venv/bin/python -m pytest -q tests/test_impact_law.py -s` prints them.

- An upright drop (no coupling, W_tn = 0): without slip Newton's restitution exactly, no tangential
  impulse, and below v_rest a persistent contact; with slip along a principal axis of W_tt the
  closed form of a straight slip that stops at P_n = |v| / (mu W_tt,ii) (before, during or after
  compression, or never), u_n+ = e |u_n-| (the contact's stiffness does not change), to 1e-10.
- The compliant limit: a Kelvin-Voigt contact (spring and damper along the normal that never
  pull, the damping ratio of restitution e for the frictionless effective mass, as
  tests/reference/soft_contact.py) with Coulomb friction, integrated in time by scipy's solve_ivp
  (DOP853, rtol 1e-12; its result does not depend on the stiffness, W being constant): sliding
  with the slip's direction turning, at v = 0 sticking if |W_tt^-1 W_tn| <= mu, else sliding on
  along the direction s with W_tn - mu W_tt s parallel to s (found here by scanning the angle),
  until the force returns to 0. 300 random impacts (random SPD W of a random rigid body and
  contact point, random approach, mu in 0..1.5, e in 0.001..1): the largest difference in u+ is
  6e-11 of |u-| (bound 1e-10).
- e = 1 (a spring: all compression's work given back): the impulse ODE du/dP_n = W (-mu v/|v|, 1)
  integrated in P_n by solve_ivp (rtol 1e-13) with compression ending at u_n = 0 and restitution
  where int u_n dP_n returns to 0 (Stronge's energetic rule): 100 impacts, 3e-11 at most.
- No fixed restitution rule is that limit: Newton's (u_n+ = -e u_n-), Poisson's (P_n = (1 + e) P_c)
  and the energetic rule differ from it by 12 %, 5 % and 6 % of |u-| at worst over 30 impacts.
- 3000 random impacts: the kinetic energy never rises (dT <= 1e-12 of the approach energy; the
  largest dT / T- is -3e-4, always a loss), the impulse pushes and stays in the friction cone,
  the contact point no longer approaches the ground, sticking means u_t+ = 0.
- In generalised coordinates (a free rigid disc, its mass matrix and contact Jacobian written here
  from the rigid-body equations): J v+ equals the contact space's u+, and the kinetic energy computed
  from v+ changes by dT.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from gyrowheel.model.impact import generalised_impact, impact
from reference.soft_contact import damping_for_restitution, restitution_of_damping

_W, _u = ca.SX.sym("W", 3, 3), ca.SX.sym("u", 3)
_e, _mu, _vr = ca.SX.sym("e"), ca.SX.sym("mu"), ca.SX.sym("v_rest")
_r = impact(_W, _u, _e, _mu, _vr)
LAW = ca.Function("law", [_W, _u, _e, _mu, _vr], [_r.P, _r.u_plus, _r.dT, _r.sticking, _r.persistent, _r.jam])


def law(W, u, e, mu, v_rest=0.0):
    P, up, dT, st, pe, _ = LAW(W, u, e, mu, v_rest)
    return np.array(P).ravel(), np.array(up).ravel(), float(dT), bool(st), bool(pe)


def law_jams(W, u, e, mu, v_rest=0.0):
    """Whether the law found a jam on the impact's path (and so gave the frictionless impulse)."""
    return bool(LAW(W, u, e, mu, v_rest)[5])


def random_case(rng):
    """A random rigid body's Delassus matrix at a random contact point, and an approach velocity."""
    m = rng.uniform(0.5, 3.0)
    I = np.diag(rng.uniform(0.05, 1.0, 3)) * m
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    Iinv = Q @ np.linalg.inv(I) @ Q.T
    r = rng.normal(size=3)
    r *= rng.uniform(0.05, 1.0) / np.linalg.norm(r)
    rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    W = np.eye(3) / m - rx @ Iinv @ rx  # J = [I, -r x] for (v_centre, omega)
    u = np.array([rng.normal(), rng.normal(), -rng.uniform(0.01, 3.0)])
    return 0.5 * (W + W.T), u


def jams(W, mu):
    """True where some slip direction could jam (W_nn <= mu |W_nt|): the cases the e = 1 and the
    fixed-rule comparisons leave out (their references do not follow a jam)."""
    return W[2, 2] <= mu * math.hypot(W[0, 2], W[1, 2])


# ---- the impulse ODE, integrated by scipy ---------------------------------------------------------

def _slip_rate(W, mu, s):
    """du_t/dP_n while sliding in direction s: W_tn - mu W_tt s."""
    return W[:2, 2] - mu * W[:2, :2] @ s


def _growing_direction(W, mu):
    """The unit s with W_tn - mu W_tt s = lam s, lam > 0: scanned over the angle, then brentq."""
    def cross(a):
        s = np.array([math.cos(a), math.sin(a)])
        d = _slip_rate(W, mu, s)
        return s[0] * d[1] - s[1] * d[0]
    grid = np.linspace(0, 2 * math.pi, 3601)
    found = []
    for a, b in zip(grid[:-1], grid[1:]):
        if cross(a) * cross(b) <= 0:
            a = brentq(cross, a, b, xtol=1e-15, rtol=1e-15)
            s = np.array([math.cos(a), math.sin(a)])
            if s @ _slip_rate(W, mu, s) > 0:
                found.append(s)
    assert found, "no growing slip direction"
    return found[0]


def integrate(W, u0, e, mu, rule="energetic"):
    """(u+ (3,), P_n, ended sticking): the impulse ODE integrated in P_n by scipy (module docstring).
    rule: "energetic" (Stronge), "newton" (u_n+ = -e u_n-) or "poisson" (P_n = (1 + e) P_c)."""
    state = {"P_c": None, "E_c": None}

    def rhs(p, y):  # y = (u (3), E_n)
        v = y[:2]
        dP = np.append(-mu * v / math.hypot(*v), 1.0)
        return np.append(W @ dP, y[2])

    def ended(p, y):
        if state["P_c"] is None:
            return y[2]
        if rule == "newton":
            return y[2] + e * u0[2]
        if rule == "poisson":
            return p - (1 + e) * state["P_c"]
        return y[3] - (1 - e * e) * state["E_c"]
    ended.terminal, ended.direction = True, 1
    scale = np.abs(u0).max()

    def stuck(p, y):
        return math.hypot(y[0], y[1]) - 1e-10 * scale
    stuck.terminal, stuck.direction = True, -1

    y, p = np.append(u0, 0.0), 0.0
    while math.hypot(y[0], y[1]) > 0:
        sol = solve_ivp(rhs, (p, p + 1e6), y, method="DOP853", rtol=1e-13, atol=1e-16 * scale,
                        events=[stuck, ended])
        y, p = sol.y[:, -1], sol.t[-1]
        if len(sol.t_events[0]):  # the last 1e-10 of the slip on its (converged) direction
            d = rhs(p, y)
            r = math.hypot(y[0], y[1])
            dp = -r / ((y[:2] @ d[:2]) / r)
            y, p = y + d * dp, p + dp
            y[:2] = 0.0
            break
        if state["P_c"] is None:
            state["P_c"], state["E_c"] = p, y[3]
            continue
        return y[:3], p, False
    # after the slip stopped: constant du/dP_n
    A, bt = W[:2, :2], W[:2, 2]
    holds = np.linalg.norm(np.linalg.solve(A, bt)) <= mu
    Pt_rate = -np.linalg.solve(A, bt) if holds else -mu * _growing_direction(W, mu)
    d = W @ np.append(Pt_rate, 1.0)

    def advance(y, p, dp):
        return np.append(y[:3] + d * dp, y[3] + y[2] * dp + 0.5 * d[2] * dp * dp), p + dp
    if state["P_c"] is None:
        y, p = advance(y, p, -y[2] / d[2])
        state["P_c"], state["E_c"] = p, y[3]
    if rule == "newton":
        dp = (-e * u0[2] - y[2]) / d[2]
    elif rule == "poisson":
        dp = (1 + e) * state["P_c"] - p
    else:
        room = (1 - e * e) * state["E_c"] - y[3]
        dp = (-y[2] + math.sqrt(y[2] ** 2 + 2 * d[2] * room)) / d[2]
    y, p = advance(y, p, dp)
    return y[:3], p, holds


# ---- tests ----------------------------------------------------------------------------------------

W_UPRIGHT = np.diag([1 / 2.0 + 0.17 ** 2 / 0.0289, 1 / 2.0 + 0.17 ** 2 / 0.0578, 0.5])


def test_upright_drop_is_newtons_restitution():
    W = W_UPRIGHT
    for e in (0.0, 0.3, 0.8, 1.0):
        P, up, dT, st, pe = law(W, [0, 0, -2.0], e, 0.5, 1e-3)
        assert np.allclose(P[:2], 0, atol=1e-15)
        assert up[2] == pytest.approx(2.0 * e, rel=1e-14, abs=1e-15)
        assert dT == pytest.approx(-0.5 * (1 - e * e) * 4.0 / 0.5, rel=1e-13, abs=1e-13)
        assert st
    P, up, dT, st, pe = law(W, [0, 0, -1e-4], 0.5, 0.5, 1e-3)
    assert pe and up[2] == 0.0


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("slip, e, mu", [(0.3, 0.5, 0.4), (2.0, 0.5, 0.4), (5.0, 0.8, 0.3),
                                         (40.0, 0.5, 0.2), (-1.0, 0.0, 0.6)])
def test_upright_slip_along_an_axis_is_the_closed_form(axis, slip, e, mu):
    """Slip v along a principal axis of a diagonal W: du_t/dP_n = -mu W_ii sign(v) until the slip
    stops at P_s = |v| / (mu W_ii); u_n = u_n- + W_nn P_n, so every restitution rule gives
    P_n = (1 + e) |u_n-| / W_nn and u_n+ = e |u_n-|."""
    W, un = W_UPRIGHT, -1.5
    u = np.zeros(3)
    u[axis], u[2] = slip, un
    P, up, dT, st, pe = law(W, u, e, mu, 0.0)
    Pn = (1 + e) * -un / W[2, 2]
    P_stop = abs(slip) / (mu * W[axis, axis])
    Pt = -math.copysign(mu * min(Pn, P_stop), slip)
    expected_P = np.zeros(3)
    expected_P[axis], expected_P[2] = Pt, Pn
    assert np.allclose(P, expected_P, rtol=1e-10, atol=1e-10 * Pn)  # the integration's accuracy
    assert up[axis] == pytest.approx(slip + W[axis, axis] * Pt, abs=1e-10 * abs(slip))
    assert up[2] == pytest.approx(e * -un, rel=1e-10, abs=1e-14)
    assert st == (P_stop < Pn)


def test_elastic_impacts_equal_scipys_integration_of_the_impulse_ode():
    """e = 1: the spring gives back all compression's work, the energetic rule (written here)."""
    rng = np.random.default_rng(20261203)
    worst, checked, stuck = 0.0, 0, 0
    while checked < 100:
        W, u = random_case(rng)
        mu = rng.uniform(0, 1.5)
        if jams(W, mu):
            continue
        P, up, dT, st, pe = law(W, u, 1.0, mu, 0.0)
        ref, Pn, holds = integrate(W, u, 1.0, mu)
        err = np.abs(up - ref).max() / np.abs(u).max()
        assert err <= 1e-10, (checked, err, up, ref)
        assert P[2] == pytest.approx(Pn, rel=1e-9)
        worst, checked, stuck = max(worst, err), checked + 1, stuck + st
    assert 10 < stuck < 90, stuck  # both ends, sticking and sliding, are sampled
    print(f"largest |u+ - scipy| / |u-|: {worst:.2e}")


@pytest.mark.parametrize("seed, mu_range, count", [(20261204, (0.0, 1.5), 300), (20261205, (1.0, 10.0), 300)])
def test_impacts_equal_the_kelvin_voigt_contacts_limit(seed, mu_range, count):
    """e in 0.001..1: the law against the compliant contact integrated in time (`kelvin_voigt`).
    Where the compliant contact meets a jam on its path (du_n/dP_n <= 0 on a slip direction it
    slides in) the law must report one (and give the frictionless impulse); everywhere else the
    same u+, jam or not in other slip directions it never takes."""
    rng = np.random.default_rng(seed)
    worst, checked, stuck, jammed, could_jam = 0.0, 0, 0, 0, 0
    while checked < count:
        W, u = random_case(rng)
        e, mu = rng.uniform(0.001, 1), rng.uniform(*mu_range)
        P, up, dT, st, pe = law(W, u, e, mu, 0.0)
        soft = kelvin_voigt(W, u, e, mu)
        assert law_jams(W, u, e, mu) == (soft is None), (checked, W, u, e, mu)
        if soft is None:
            assert np.allclose(P[:2], 0.0) and P[2] == pytest.approx((1 + e) * -u[2] / W[2, 2], rel=1e-12)
            jammed += 1
            continue
        err = np.abs(up - soft).max() / np.abs(u).max()
        assert err <= 1e-10, (checked, err, up, soft)
        worst, checked, stuck = max(worst, err), checked + 1, stuck + st
        could_jam += jams(W, mu)
    assert 0.1 * count < stuck < (0.9 if mu_range[1] < 5 else 0.99) * count, stuck  # both ends sampled
    if mu_range[1] > 5:  # high friction: most impacts have some slip direction that could jam, few take it
        assert could_jam > 0.2 * count and jammed > 20, (could_jam, jammed)
    print(f"mu in {mu_range}: largest |u+ - Kelvin-Voigt| / |u-|: {worst:.2e}; {jammed} jams on the path, "
          f"{could_jam} of {count} compared could jam in another direction")


@pytest.mark.parametrize("seed, mu_range", [(20261202, (0.0, 1.5)), (20261206, (1.0, 10.0))])
def test_random_impacts_never_create_energy_and_keep_the_cone(seed, mu_range):
    rng = np.random.default_rng(seed)
    worst, sticking = -np.inf, 0
    for _ in range(3000):
        W, u = random_case(rng)
        e, mu = rng.uniform(0, 1), rng.uniform(*mu_range)
        P, up, dT, st, pe = law(W, u, e, mu, 1e-3)
        T0 = 0.5 * u @ np.linalg.solve(W, u)  # the approach energy in contact space
        assert dT <= 1e-12 * T0
        worst = max(worst, dT / T0)
        assert P[2] >= 0
        assert np.hypot(P[0], P[1]) <= mu * P[2] * (1 + 1e-10) + 1e-15
        assert up[2] >= 0
        assert np.allclose(u + W @ P, up, atol=1e-12 * np.abs(u).max())
        if st:
            assert up[0] == 0.0 and up[1] == 0.0
        sticking += st
    assert 300 < sticking < 2700, sticking
    print(f"mu in {mu_range}: largest dT / T-: {worst:.2e}, {sticking} of 3000 stick")


def kelvin_voigt(W, u0, e, mu):
    """u+ (3,) of a compliant contact: normal force F = d + 2 zeta sqrt(m) d' (stiffness 1, m =
    1 / W_nn the frictionless effective mass, zeta the damping ratio of restitution e, d' = -u_n)
    until F returns to 0; tangential force -mu F v/|v| sliding; at v = 0 sticking if
    |W_tt^-1 W_tn| <= mu (the force that keeps v = 0), else sliding on along the growing direction.
    Integrated in time by scipy; W constant (so the stiffness only scales the time).
    None where the contact jams before F returns to 0: du_n/dP_n = W_nn - mu W_nt . s <= 0 on the
    slip direction s it slides in (the compression then grows without bound)."""
    zeta = damping_for_restitution(e) if e < 1 else 0.0
    c = 2 * zeta * math.sqrt(1 / W[2, 2])
    A, bt = W[:2, :2], W[:2, 2]
    scale = np.abs(u0).max()

    def force(y):
        return y[3] - c * y[2]

    def rhs(t, y, rate):  # y = (u (3), d)
        v = y[:2]
        Pt = -mu * v / math.hypot(*v) if rate is None else rate
        return np.append(W @ np.append(Pt, 1.0) * force(y), -y[2])

    def released(t, y, rate):
        return force(y) if t > 0 else 1.0
    released.terminal, released.direction = True, -1

    def stuck(t, y, rate):
        return math.hypot(y[0], y[1]) - 1e-10 * scale
    stuck.terminal, stuck.direction = True, -1

    def normal_rate(t, y, rate):
        return W[2, 2] - mu * bt @ y[:2] / math.hypot(*y[:2])
    normal_rate.terminal, normal_rate.direction = True, -1
    y, t = np.append(u0, 0.0), 0.0
    if math.hypot(*u0[:2]) > 0:
        if normal_rate(0, y, None) <= 0:
            return None
        sol = solve_ivp(rhs, (0, 1e3), y, method="DOP853", rtol=1e-12, atol=1e-15 * scale,
                        events=[stuck, released, normal_rate], args=(None,))
        y, t = sol.y[:, -1], sol.t[-1]
        if len(sol.t_events[2]):
            return None
        if len(sol.t_events[1]):
            return y[:3]
    holds = np.linalg.norm(np.linalg.solve(A, bt)) <= mu
    rate = -np.linalg.solve(A, bt) if holds else -mu * _growing_direction(W, mu)
    if (W @ np.append(rate, 1.0))[2] <= 0:
        return None
    y[:2] = 0.0
    sol = solve_ivp(rhs, (t, t + 1e3), y, method="DOP853", rtol=1e-12, atol=1e-15 * scale,
                    events=[released], args=(rate,))
    return sol.y[:3, -1]


def test_no_fixed_restitution_rule_is_the_kelvin_voigt_contacts_limit():
    """With friction the contact's effective stiffness du_n/dP_n (and so its damping ratio) changes
    with the slip, and none of Newton's (u_n+ = -e u_n-), Poisson's (P_n = (1 + e) P_c) or
    Stronge's energetic rule gives the compliant contact's rebound."""
    rng = np.random.default_rng(5)
    errors = {"energetic": [], "newton": [], "poisson": []}
    while len(errors["newton"]) < 30:
        W, u = random_case(rng)
        e, mu = rng.uniform(0.2, 0.9), rng.uniform(0.1, 1.2)
        if jams(W, mu):
            continue
        soft = kelvin_voigt(W, u, e, mu)
        for rule in errors:
            errors[rule].append(np.abs(integrate(W, u, e, mu, rule)[0] - soft).max() / np.abs(u).max())
    top = {rule: float(np.max(v)) for rule, v in errors.items()}
    print("largest |u+ - Kelvin-Voigt| / |u-| by rule:", top)
    assert min(top.values()) > 1e-2


def test_generalised_impact_of_a_free_disc():
    """A disc (mass 2 kg, radius 0.17 m, I_axial = 0.4 M R^2, I_diam = 0.25 M R^2) in free flight,
    generalised velocity (v_centre, omega) in the ground frame, touching down at the rim point r."""
    m, R = 2.0, 0.17
    rng = np.random.default_rng(11)
    beta = 1.1
    n = np.array([0.0, -np.cos(beta), np.sin(beta)])  # axle
    l = np.array([0.0, -np.sin(beta), -np.cos(beta)])  # centre to contact
    Ib = m * R ** 2 * (0.25 * (np.eye(3) - np.outer(n, n)) + 0.4 * np.outer(n, n))
    M = np.block([[m * np.eye(3), np.zeros((3, 3))], [np.zeros((3, 3)), Ib]])
    r = R * l
    rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    J = np.hstack([np.eye(3), -rx])  # u = v + omega x r
    v = np.concatenate([[0.4, 0.1, -1.5], rng.normal(size=3) * 3])
    v_plus, res = generalised_impact(M, J, v, 0.5, 0.4, 1e-3)
    v_plus = np.array(ca.evalf(v_plus)).ravel()
    u_plus, dT = np.array(ca.evalf(res.u_plus)).ravel(), float(ca.evalf(res.dT))
    assert np.allclose(J @ v_plus, u_plus, atol=1e-13)
    T = lambda w: 0.5 * w @ M @ w  # noqa: E731
    assert T(v_plus) - T(v) == pytest.approx(dT, abs=1e-12)
    assert dT < 0


# W with a stick ratio |W_tt^-1 W_tn| = 0.913 and W_nn / |W_nt| = 1.104: every mu >= 0.913 holds a
# zero-slip contact stuck, and a slip direction exists that would jam for mu >= 1.104
W_STICKS = np.array([[1.0, 0.2, 0.9], [0.2, 1.5, 0.1], [0.9, 0.1, 1.0]])


@pytest.mark.parametrize("e", [0.0, 0.3, 0.8])
@pytest.mark.parametrize("mu", [1.0, 1.1, 1.2, 5.0, 1e300])
def test_a_zero_slip_contact_that_sticks_never_jams(mu, e):
    """A contact that lands without slip and sticks moves along u_t = 0 at du_n/dP_n = W_nn -
    W_nt . W_tt^-1 W_tn (the Schur complement of the SPD W, > 0): no jam whatever mu, although
    W_nn <= mu |W_nt| for mu >= 1.104. The impulse is P = W^-1 (u+ - u-) with u+ = (0, 0, u_n+), the
    rebound u_n+ = e' |u_n-| of the spring-damper whose effective mass is the stuck contact's,
    1 / k: damping ratio zeta sqrt(k / W_nn) (zeta that of e for the mass 1 / W_nn)."""
    W, u = W_STICKS, np.array([0.0, 0.0, -1.3])
    A, bt = W[:2, :2], W[:2, 2]
    k = W[2, 2] - bt @ np.linalg.solve(A, bt)
    e_stuck = 0.0 if e == 0 else restitution_of_damping(damping_for_restitution(e) * math.sqrt(k / W[2, 2]))
    expected = np.linalg.solve(W, np.array([0.0, 0.0, -e_stuck * u[2]]) - u)
    P, up, dT, st, pe = law(W, u, e, mu, 1e-3)
    assert st and not law_jams(W, u, e, mu)
    assert np.allclose(P, expected, rtol=1e-9, atol=1e-12)
    assert up[0] == 0.0 and up[1] == 0.0
