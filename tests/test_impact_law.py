"""The touchdown impact law (model/impact.py) against results it did not produce.

- An upright drop (W diagonal, contact point moving straight down): Newton's restitution exactly,
  no tangential impulse; below v_rest the contact persists (u_n+ = 0).
- 2000 random impacts (random SPD W from a random rigid body and contact Jacobian, random approach
  velocities, mu in 0..1.5, e in 0..1): the kinetic energy never rises (dT <= 1e-12 of the
  approach energy), the impulse stays in the friction cone and pushes (P_n >= 0), the contact point
  no longer approaches the ground, and whenever the law kept its target the normal velocity is
  -e u_n- (or 0) and, sticking, the tangential one 0.  Measured: largest dT / T- 7.3e-16, 958
  sticking, 10 of 2000 impacts scaled by the energy guard.
- Sliding impulses are the nearest boundary points in W's metric: equal to scipy's SLSQP solution
  of the same convex problem (written here from the problem's statement) to 1e-6 (measured 6.9e-8).
- A kinematic restitution with friction that would create energy exists among the samples (so the
  energy guard is exercised), and the law's answer there does not.
- In generalised coordinates (a free rigid disc, its mass matrix and contact Jacobian written here
  from the rigid-body equations): J v+ equals the contact space's u+, and the kinetic energy computed
  from v+ changes by dT.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import minimize

from gyrowheel.model.impact import generalised_impact, impact

_W, _u = ca.SX.sym("W", 3, 3), ca.SX.sym("u", 3)
_e, _mu, _vr = ca.SX.sym("e"), ca.SX.sym("mu"), ca.SX.sym("v_rest")
_r = impact(_W, _u, _e, _mu, _vr)
LAW = ca.Function("law", [_W, _u, _e, _mu, _vr], [_r.P, _r.u_plus, _r.dT, _r.sticking, _r.persistent])


def law(W, u, e, mu, v_rest=0.0):
    P, up, dT, st, pe = LAW(W, u, e, mu, v_rest)
    return np.array(P).ravel(), np.array(up).ravel(), float(dT), bool(st), bool(pe)


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


def test_upright_drop_is_newtons_restitution():
    W = np.diag([1 / 2.0 + 0.17 ** 2 / 0.0289, 1 / 2.0 + 0.17 ** 2 / 0.0578, 0.5])
    for e in (0.0, 0.3, 0.8, 1.0):
        P, up, dT, st, pe = law(W, [0, 0, -2.0], e, 0.5, 1e-3)
        assert np.allclose(P[:2], 0, atol=1e-15)
        assert up[2] == pytest.approx(2.0 * e, rel=1e-14, abs=1e-15)
        assert dT == pytest.approx(-0.5 * (1 - e * e) * 4.0 / 0.5, rel=1e-13, abs=1e-13)
    P, up, dT, st, pe = law(W, [0, 0, -1e-4], 0.5, 0.5, 1e-3)
    assert pe and up[2] == pytest.approx(0, abs=1e-18)


def test_random_impacts_never_create_energy_and_keep_the_cone():
    rng = np.random.default_rng(20261202)
    guarded = 0
    for _ in range(2000):
        W, u = random_case(rng)
        e, mu = rng.uniform(0, 1), rng.uniform(0, 1.5)
        P, up, dT, st, pe = law(W, u, e, mu, 1e-3)
        T0 = 0.5 * u @ np.linalg.solve(W, u)  # the approach energy in contact space
        assert dT <= 1e-12 * T0
        assert P[2] >= -1e-15
        assert np.hypot(P[0], P[1]) <= mu * P[2] * (1 + 1e-12) + 1e-15
        assert up[2] >= -1e-12 * abs(u[2])
        kept = abs(up[2] - (0.0 if pe else -e * u[2])) <= 1e-12 * abs(u[2])
        guarded += not kept
        if st:
            assert np.allclose(up[:2], 0, atol=1e-12 * np.abs(u).max())
    assert 0 < guarded < 400, guarded  # the energy guard acts, and only in the minority of cases


def _nearest_on_cone(W, u, e, mu):
    """min (P - P_s)' W (P - P_s) s.t. (u + W P)_n = -e u_n, mu P_n >= |P_t| (scipy SLSQP)."""
    target = np.array([0, 0, -e * u[2]])
    P_s = np.linalg.solve(W, target - u)
    cons = [{"type": "eq", "fun": lambda P: (u + W @ P)[2] - target[2]},
            {"type": "ineq", "fun": lambda P: mu * P[2] - np.sqrt(P[0] ** 2 + P[1] ** 2 + 1e-30)}]
    x0 = np.array([0, 0, (target[2] - u[2]) / W[2, 2]])
    res = minimize(lambda P: 0.5 * (P - P_s) @ W @ (P - P_s), x0, constraints=cons, method="SLSQP",
                   options={"ftol": 1e-14, "maxiter": 500})
    # SLSQP may stop with "Positive directional derivative" once at its precision: check the
    # constraints instead of its flag
    assert abs(cons[0]["fun"](res.x)) <= 1e-8 and cons[1]["fun"](res.x) >= -1e-8, res.message
    return res.x


def test_sliding_impulse_is_the_nearest_point_of_the_cone():
    rng = np.random.default_rng(7)
    checked = 0
    while checked < 40:
        W, u = random_case(rng)
        e, mu = rng.uniform(0, 1), rng.uniform(0.05, 0.6)
        P, up, dT, st, pe = law(W, u, e, mu, 0.0)
        kept = abs(up[2] + e * u[2]) <= 1e-12 * abs(u[2])
        if st or not kept or W[2, 2] <= mu * np.hypot(W[2, 0], W[2, 1]):
            continue
        ref = _nearest_on_cone(W, u, e, mu)
        assert np.allclose(P, ref, rtol=1e-6, atol=1e-6 * np.abs(ref).max()), (P, ref)
        checked += 1


def test_kinematic_restitution_with_friction_can_create_energy_and_the_law_does_not():
    """The naive law (normal target, then the nearest cone point, no energy guard) gains energy
    in some samples; the law's own dT stays <= 0 there."""
    rng = np.random.default_rng(3)
    for _ in range(5000):
        W, u = random_case(rng)
        e, mu = rng.uniform(0.8, 1.0), rng.uniform(0.5, 1.5)
        target = np.array([0, 0, -e * u[2]])
        P_s = np.linalg.solve(W, target - u)
        if np.hypot(P_s[0], P_s[1]) <= mu * P_s[2] and P_s @ u + 0.5 * P_s @ W @ P_s > 1e-9:
            P, up, dT, st, pe = law(W, u, e, mu, 0.0)
            T_minus = 0.5 * u @ np.linalg.solve(W, u)  # the contact's kinetic energy scale
            assert dT <= 1e-14 * T_minus  # no gain beyond rounding
            return
    pytest.fail("no energy-creating kinematic impact among the samples")


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
