"""A wheel that lands without slip and sticks, in the FMU (model/impact.py; docs/impact.md, rule 3).

Independent reference: the Delassus matrix of a rigid wheel (mass M, diametral inertia k_diam M R^2,
axial k_axial M R^2) at its lowest rim point by hand, as in tests/test_painleve.py: in the frame
(across the heading y, normal n) W_yy = (1 + sin^2 b / k_diam) / M, W_yn = -sin b cos b / (k_diam M),
W_nn = (1 + cos^2 b / k_diam) / M; the heading is decoupled from both. A wheel dropped rolling
(zero slip) from height h at lean b, spinning about its axle, reaches the ground with
u- = (0, 0, -sqrt(2 g h)) (the spin moves the lowest rim point along the heading, not down).
It sticks where |W_yn / W_yy| <= mu (0.433 at 60 degrees), and a stuck contact moves at
du_n/dP_n = W_nn - W_yn^2 / W_yy > 0 (the Schur complement): no jam, although a slip across the
heading would jam for mu >= W_nn / |W_yn| = 1.155. So the impulse is the same for every mu past the
stick ratio: P = W^-1 (u+ - u-), u+ = (0, 0, e' sqrt(2 g h)), e' the rebound of the spring-damper
of restitution e (calibrated to the mass 1 / W_nn) acting on the stuck contact's mass 1 / k:
damping ratio zeta sqrt(k / W_nn). The frictionless impulse would be (1 + e) sqrt(2 g h) / W_nn.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import gyrowheel
from reference.soft_contact import damping_for_restitution, restitution_of_damping

M, K_DIAM, G = 2.0, 0.25, 9.81  # examples/scenes/drop_bounce.toml
LANDING = {"height": 0.05, "beta_deg": 60.0, "gamma_dot": 10.0, "restitution": 0.3, "mu_k": 0.8}


@pytest.fixture(scope="module")
def drop(example_build):
    return str(example_build("drop_bounce").fmu)


def stuck_impulse(beta, h, e):
    """P (y, n) of the module docstring, N s."""
    s, c = math.sin(beta), math.cos(beta)
    W = np.array([[1 + s * s / K_DIAM, -s * c / K_DIAM], [-s * c / K_DIAM, 1 + c * c / K_DIAM]]) / M
    k = W[1, 1] - W[0, 1] ** 2 / W[0, 0]
    e_stuck = restitution_of_damping(damping_for_restitution(e) * math.sqrt(k / W[1, 1]))
    un = -math.sqrt(2 * G * h)
    return np.linalg.solve(W, np.array([0.0, -e_stuck * un]) - np.array([0.0, un])), W


@pytest.mark.parametrize("mu", [1.1, 1.2, 5.0])
def test_a_rolling_landing_sticks_whatever_the_friction_past_its_stick_ratio(drop, mu):
    out = gyrowheel.simulate(drop, stop_time=0.2, output_interval=1e-3, start_values={**LANDING, "mu": mu})
    landed = out["impact_impulse"] > 0
    P, W = stuck_impulse(math.radians(60.0), 0.05, 0.3)
    assert abs(W[0, 1] / W[0, 0]) < 1.1 < W[1, 1] / abs(W[0, 1]) < 1.2  # sticks; a slip could jam
    assert out["impact_impulse"][landed][0] == pytest.approx(P[1], rel=1e-7)
    frictionless = 1.3 * math.sqrt(2 * G * 0.05) / W[1, 1]
    assert abs(P[1] - frictionless) > 0.5  # 2.17 against 1.29 N s
    t_land = out["time"][landed][0]
    assert t_land == pytest.approx(math.sqrt(2 * 0.05 / G), abs=1.5e-3)  # the first row after it
