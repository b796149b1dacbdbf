"""The wheel in flight (model/flight.py) against the free rigid body's closed-form motion.

- Pointwise, at random states: the centre falls at g exactly; the angular momentum about the centre
  is constant (dL/dt = 0, Euler's equations of the torque-free body, to 1e-12); the axle turns as
  n_dot = (L / I_diam) x n, the torque-free precession of an axisymmetric body (Goldstein,
  "Classical Mechanics", section 5.6: omega = L / I_diam + (1 / I_axial - 1 / I_diam) (L . n) n).
- Integrated (scipy DOP853, rtol 1e-12): the centre on its parabola, the axle rotated about L by
  the angle |L| t / I_diam (Rodrigues' formula), the energy constant.
- Against the soft-contact reference's flight (tests/reference/soft_contact_scenarios.py: quaternion
  Newton-Euler, written independently): the same throw gives the same centre and axle (measured:
  1.3e-15 m and 2.0e-11 over 0.6 s).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gyrowheel.model.flight import flight_equations
from reference.soft_contact_scenarios import flight as reference_flight

M, R, K_DIAM, K_AXIAL, G = 2.0, 0.17, 0.25, 0.4, 9.81
P = [M, R, K_DIAM, K_AXIAL, G]
I_DIAM = K_DIAM * M * R * R


@pytest.fixture(scope="module")
def flight():
    return flight_equations().function()


def evaluate(flight, q, qd):
    return [np.array(v).ravel() for v in flight(q, qd, P)]


def rhs(flight):
    def f(t, y):
        return np.concatenate([y[6:], evaluate(flight, y[:6], y[6:])[0]])
    return f


def test_free_fall_and_torque_free_rotation_pointwise(flight):
    rng = np.random.default_rng(5)
    h = 1e-6
    for _ in range(50):
        q = np.concatenate([rng.normal(size=3), rng.uniform(-3, 3, 1), rng.uniform(0.3, 2.8, 1), rng.uniform(-3, 3, 1)])
        qd = rng.normal(size=6) * np.array([1, 1, 1, 3, 3, 30])
        qdd, E, L, n, w, _ = evaluate(flight, q, qd)
        np.testing.assert_allclose(qdd[:3], [0, 0, -G], atol=1e-15)
        # dL/dt along the motion by central differences of the exact acceleration: zero
        f = rhs(flight)
        y = np.concatenate([q, qd])
        yp, ym = y + h * f(0, y), y - h * f(0, y)
        Lp, Lm = evaluate(flight, yp[:6], yp[6:])[2], evaluate(flight, ym[:6], ym[6:])[2]
        assert np.abs((Lp - Lm) / (2 * h)).max() <= 1e-6 * max(1.0, np.abs(L).max())  # difference quotient: O(h^2)
        np_, nm = evaluate(flight, yp[:6], yp[6:])[3], evaluate(flight, ym[:6], ym[6:])[3]
        np.testing.assert_allclose((np_ - nm) / (2 * h), np.cross(L / I_DIAM, n), atol=1e-6 * np.abs(w).max())
        np.testing.assert_allclose(np.cross(w, n), np.cross(L / I_DIAM, n), atol=1e-12 * np.abs(w).max())


def rotate(v, axis, angle):
    """Rodrigues' rotation of v about the unit axis by angle."""
    return v * math.cos(angle) + np.cross(axis, v) * math.sin(angle) + axis * (axis @ v) * (1 - math.cos(angle))


def test_integrated_flight_is_a_parabola_and_a_steady_precession(flight):
    q0 = np.array([0.0, 0.0, 1.0, 0.0, 1.2, 0.0])
    qd0 = np.array([1.0, 0.0, 3.0, 2.0, 1.0, 30.0])
    t = np.linspace(0, 0.6, 31)
    sol = solve_ivp(rhs(flight), (0, 0.6), np.concatenate([q0, qd0]), method="DOP853", rtol=1e-12,
                    atol=1e-12, t_eval=t)
    assert sol.success
    _, E0, L0, n0, _, _ = evaluate(flight, q0, qd0)
    axis, rate = L0 / np.linalg.norm(L0), np.linalg.norm(L0) / I_DIAM
    for k, tk in enumerate(t):
        y = sol.y[:, k]
        np.testing.assert_allclose(y[:3], q0[:3] + qd0[:3] * tk + 0.5 * np.array([0, 0, -G]) * tk ** 2, atol=1e-11)
        _, E, L, n, _, _ = evaluate(flight, y[:6], y[6:])
        np.testing.assert_allclose(L, L0, atol=1e-9 * np.linalg.norm(L0))
        np.testing.assert_allclose(n, rotate(n0, axis, rate * tk), atol=1e-9)
        assert E == pytest.approx(E0, rel=1e-11)


def test_flight_agrees_with_the_soft_contact_reference(flight):
    """The reference's default throw: lean 1.2, rates (2, 1, 30) rad/s, 1 m/s along the heading and
    3 m/s up, lowest rim point 1 m up; its states are in the same conventions (docs/model.md)."""
    ref = reference_flight()
    beta0 = 1.2
    q0 = np.array([0.0, 0.0, 1.0 + R * math.sin(beta0), 0.0, beta0, 0.0])
    # the reference starts the centre with the rolling velocity of these rates plus (1, 0, 3)
    _, _, _, n0, w0, _ = evaluate(flight, q0, np.array([0, 0, 0, 2.0, 1.0, 30.0]))
    down = np.array([0.0, 0.0, -1.0]) + n0[2] * n0  # -k without its component along the axle
    l0 = down / np.linalg.norm(down)  # l: from the centre towards the lowest rim point
    v0 = -np.cross(w0, R * l0) + np.array([1.0, 0.0, 3.0])
    y0 = np.concatenate([q0, v0, [2.0, 1.0, 30.0]])
    sol = solve_ivp(rhs(flight), (0, ref["t"][-1]), y0, method="DOP853", rtol=1e-12, atol=1e-12, t_eval=ref["t"])
    assert sol.success
    np.testing.assert_allclose(sol.y[:3].T, ref["r"], atol=1e-8)
    axles = np.array([evaluate(flight, y[:6], y[6:])[3] for y in sol.y.T])
    np.testing.assert_allclose(axles, ref["n"], atol=1e-8)
