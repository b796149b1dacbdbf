"""The soft-contact reference (tests/reference/soft_contact.py) against closed forms it does not
produce, and its convergence to them as the contact stiffens and the friction's regularisation
narrows.

Closed forms (the paper wheel: M = 2 kg, R = 0.17 m, k_diam = 0.25, k_axial = 0.4; g = 9.81):

* Sliding launch, upright, level ground. While it slides the friction is -mu_k M g sgn(s) along
  the heading, s = v - R w the contact point's slip. Newton: dv/dt = -mu_k g sgn(s); Euler about
  the axle: k_axial M R^2 dw/dt = mu_k M g R sgn(s). So ds/dt = -mu_k g (1 + 1/k_axial) sgn(s):
  the slip decays at the constant rate a = mu_k g (1 + 1/k_axial) and rolling starts at
  t* = |s0| / a. Friction, normal force and gravity have no moment about the ground point under
  the centre, so M R v + k_axial M R^2 w is kept, and at rolling (v = R w)
  v* = (v0 + k_axial R w0) / (1 + k_axial). Regularised (F = mu F_n s / sqrt(s^2 + eps^2)):
  dt = -sqrt(s^2 + eps^2) / (a s) ds integrates to t(eps) = [G(s0) - G(eps)] / a with
  G(s) = sqrt(s^2 + eps^2) - eps ln((eps + sqrt(s^2 + eps^2)) / s), so
  t(eps) - t* -> -(sqrt 2 - ln(1 + sqrt 2)) eps / a and v(eps) - v* = k_axial eps / (1 + k_axial).
* Incline theta, upright from rest. Rolling needs the friction F = M g sin(theta) k_axial /
  (1 + k_axial) (Newton along the slope with I_axial dw/dt = F R, a = R dw/dt), which
  mu M g cos(theta) bounds exactly when tan(theta) <= mu (1 + k_axial) / k_axial. Below:
  a = g sin(theta) / (1 + k_axial) (the regularised wheel creeps at a constant slip: its
  acceleration is the rolling one). Above: a = g (sin(theta) - mu_k cos(theta)) and
  dw/dt = mu_k g cos(theta) / (k_axial R); the regularised law falls short of mu_k by
  ~ eps^2 / (2 s^2), s the slip.
* Flight: the centre moves on r0 + v0 t + g_vec t^2 / 2; torque-free, the angular momentum L
  about the centre is constant, w.n is constant (Euler's third equation, I_1 = I_2), and the
  axle precesses about L at Omega_p = |L| / I_diam (Goldstein, Classical Mechanics, 3rd ed.,
  sec. 5.6; Landau & Lifshitz, Mechanics, sec. 33).
* Drop from h, upright: Newton's restitution e per impact gives apex heights e^(2k) h after the
  k-th impact and rest at t0 (1 + e) / (1 - e), t0 = sqrt(2 h / g) (the geometric series of the
  flight times 2 e^k t0). The normal law's restitution is exact for an isolated impact (g = 0);
  with gravity the contact lasts ~ pi / sqrt(kappa), so apex heights and the rest time converge
  as kappa^(-1/2).
* A leaning spinning drop: E + W is constant (W the dissipated work, >= 0), so E never rises at
  an impact, and |F_t| <= mu_k F_n at every instant bounds the impulses: J_t <= mu_k J_n
  (Stronge, Impact Mechanics, ch. 4: the friction cone).

Convergence (numbers of this file's runs; the longer study: benchmarks/soft_contact_convergence.py):

  sliding launch, backspin v0 = 2 m/s, w0 = -5 rad/s (t* = 0.276686 s), kappa = 1e5 /s^2
    eps (m/s)   t_roll - t* (s)   v_roll - v* (m/s)
    1e-3        -5.17e-5          2.86e-4
    1e-4        -5.17e-6          2.86e-5
    1e-5        -5.17e-7          2.86e-6
  incline above the limit (tan = 1.1 x limit), a - g (sin - mu_k cos) (m/s^2)
    kappa 1e4, eps 1e-3: 2.0e-5;  1e5, 1e-4: 2.1e-7;  1e6, 1e-5: 2.1e-9
  drop from 0.2 m, e = 0.5: first apex / (e^2 h) - 1, rest time - t0 (1 + e) / (1 - e) (s)
    kappa 1e4: -1.56e-1, -1.8e-2;  1e5: -4.84e-2, -1.4e-2;  1e6: -1.52e-2, -2.2e-3
    first apex extrapolated (Richardson, kappa^-1/2) from 1e5 and 1e6: 1.3e-4
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from reference.soft_contact import (FLIGHT, Ground, SoftWheel, Wheel, damping_for_restitution, initial_state,
                                    lmn, restitution_of_damping)
from reference.soft_contact_scenarios import drop, extrapolate, flight, incline, leaning_drop, sliding_launch

WHEEL = Wheel()  # the paper's wheel
G, MU = 9.81, 0.3


@pytest.mark.parametrize("zeta", [0.0, 0.1, 0.45, 0.9, 1.0, 2.5])
def test_normal_law_restitution_matches_an_integration(zeta):
    """e(zeta) in closed form against the unilateral spring-damper integrated to its force zero."""
    def law(t, x):
        return [x[1], -(x[0] + 2 * zeta * x[1])]

    def released(t, x):
        return x[0] + 2 * zeta * x[1]
    released.terminal, released.direction = True, -1
    sol = solve_ivp(law, (0, 50), [0.0, 1.0], events=released, rtol=1e-12, atol=1e-14)
    assert restitution_of_damping(zeta) == pytest.approx(-sol.y_events[0][0][1], abs=1e-9)
    if zeta <= 2.5:
        assert damping_for_restitution(restitution_of_damping(zeta)) == pytest.approx(zeta, abs=1e-9)


@pytest.mark.parametrize("stiffness", [1e4, 1e6])
def test_isolated_impact_rebounds_with_the_restitution(stiffness):
    """Without gravity the upright wheel's impact (effective mass M) returns e v_in exactly."""
    model = SoftWheel(WHEEL, Ground(stiffness=stiffness, restitution=0.5, g=0.0))
    run = model.simulate(initial_state(WHEEL, height=1e-3, vz=-2.0), 0.1)
    (_, touch, y_in), (_, lift, y_out) = run.switches[:2]
    assert (touch, lift) == ("touchdown", "lift_off")
    assert y_out[5] / -y_in[5] == pytest.approx(0.5, abs=1e-8)


def test_leaning_frictionless_impact_converges_to_the_restitution():
    """A leaning wheel's contact point (effective mass below M) rebounds at e v_in as kappa grows
    (the wheel turns during the contact: an error ~ kappa^-1/2): e - 0.5 = 0.103, 0.0134 at
    kappa = 1e4, 1e6 /s^2 (0.0014 at 1e8)."""
    errors = []
    for stiffness in (1e4, 1e6):
        model = SoftWheel(WHEEL, Ground(stiffness=stiffness, restitution=0.5, mu_k=0.0, g=0.0))
        run = model.simulate(initial_state(WHEEL, beta=1.0, height=1e-3, vz=-2.0), 0.1)
        (_, _, y_in), (_, _, y_out) = run.switches[:2]
        errors.append(abs(model._push(y_out)[2] / -model._push(y_in)[2] - 0.5))
    assert errors[1] < errors[0] / 5 and errors[1] < 0.015


def test_start_values_come_back_in_the_project_conventions():
    """initial_state -> outputs returns the angles, rates, slips and height it was given; the
    frame is docs/model.md's (l.k = -sin beta, n.k = cos beta, upright alpha = 0: l = -k, n = j)."""
    rng = np.random.default_rng(7)
    model = SoftWheel(WHEEL, Ground())
    for _ in range(20):
        start = dict(alpha=rng.uniform(-3, 3), beta=rng.uniform(0.2, 2.9), gamma=rng.uniform(-3, 3),
                     alpha_dot=rng.normal(), beta_dot=rng.normal(), gamma_dot=rng.normal(scale=10),
                     slip_long=rng.normal(), slip_lat=rng.normal(), height=rng.uniform(0, 1))
        out = model.outputs(initial_state(WHEEL, **start), FLIGHT)
        for name, value in start.items():
            assert out[name] == pytest.approx(value, abs=1e-12), name
        f = lmn(start["alpha"], start["beta"])
        assert f[2, 0] == pytest.approx(-math.sin(start["beta"]), abs=1e-15)
        assert f[2, 2] == pytest.approx(math.cos(start["beta"]), abs=1e-15)
    np.testing.assert_allclose(lmn(0.0, math.pi / 2), [[0, -1, 0], [0, 0, 1], [-1, 0, 0]], atol=1e-15)
    rolling = model.outputs(initial_state(WHEEL, gamma_dot=10.0), FLIGHT)  # rolls forward at R w
    assert (rolling["vx"], rolling["vy"]) == pytest.approx((10.0 * WHEEL.R, 0.0), abs=1e-15)


def _rolling_start(v0, w0, eps):
    """(t*, v*, regularised t(eps)) of the sliding launch (module docstring)."""
    a = MU * G * (1 + 1 / WHEEL.k_axial)
    s0 = abs(v0 - WHEEL.R * w0)

    def G_(s):
        r = math.hypot(s, eps)
        return r - eps * math.log((eps + r) / s)
    return s0 / a, (v0 + WHEEL.k_axial * WHEEL.R * w0) / (1 + WHEEL.k_axial), (G_(s0) - G_(eps)) / a


@pytest.mark.parametrize("v0, w0", [(2.0, -5.0), (0.5, 20.0)], ids=["backspin", "topspin"])
def test_sliding_launch_rolls_at_the_coulomb_time_and_speed(v0, w0):
    """Slip decays at mu_k g (1 + 1/k_axial); rolling starts at t* with v* (angular momentum about
    the contact point); the errors fall tenfold with eps (kappa = 1e5: an upright wheel's normal
    force is M g whatever the stiffness)."""
    errors = []
    for eps in (1e-3, 1e-4, 1e-5):
        r = sliding_launch(v0, w0, WHEEL, mu_k=MU, stiffness=1e5, eps=eps)
        t_star, v_star, t_eps = _rolling_start(v0, w0, eps)
        assert r["t_roll"] == pytest.approx(t_eps, abs=1e-8)  # the regularised law's own closed form
        assert r["v_roll"] - v_star == pytest.approx(math.copysign(WHEEL.k_axial / (1 + WHEEL.k_axial) * eps,
                                                                   v0 - WHEEL.R * w0), rel=1e-4)
        assert r["slip_rate"] == pytest.approx(-math.copysign(MU * G * (1 + 1 / WHEEL.k_axial), r["slip0"]),
                                               rel=1e-5)
        assert r["F_n"] == pytest.approx(WHEEL.M * G, rel=1e-9)
        errors.append((abs(r["t_roll"] - t_star), abs(r["v_roll"] - v_star)))
    for coarse, fine in zip(errors, errors[1:]):
        assert fine[0] < coarse[0] / 9 and fine[1] < coarse[1] / 9
    assert errors[-1][0] < 1e-6 and errors[-1][1] < 1e-5


def test_incline_rolls_below_the_friction_limit_and_slides_above():
    """tan(theta) = 0.9 x the limit: rolling's acceleration to 1e-9; 1.1 x: sliding's, with the
    spin's acceleration from the friction torque; the sliding error falls as eps^2."""
    limit = MU * (1 + WHEEL.k_axial) / WHEEL.k_axial
    below = math.atan(0.9 * limit)
    r = incline(below, WHEEL, mu_k=MU, stiffness=1e5, eps=1e-4)
    assert not r["sliding"]
    assert r["accel"] == pytest.approx(G * math.sin(below) / (1 + WHEEL.k_axial), abs=1e-9)
    above = math.atan(1.1 * limit)
    a_slide = G * (math.sin(above) - MU * math.cos(above))
    spin = MU * G * math.cos(above) / (WHEEL.k_axial * WHEEL.R)
    errors = []
    for stiffness, eps in ((1e4, 1e-3), (1e5, 1e-4), (1e6, 1e-5)):
        r = incline(above, WHEEL, mu_k=MU, stiffness=stiffness, eps=eps)
        assert r["sliding"]
        assert r["F_n"] == pytest.approx(WHEEL.M * G * math.cos(above), rel=1e-8)
        errors.append((abs(r["accel"] - a_slide), abs(r["gamma_ddot"] - spin)))
    for coarse, fine in zip(errors, errors[1:]):
        assert fine[0] < coarse[0] / 50 and fine[1] < coarse[1] / 50
    assert errors[-1][0] < 1e-8 and errors[-1][1] < 1e-7


def test_static_friction_holds_the_wheel_between_the_kinetic_and_static_limits():
    """mu_s > mu_k: a slope past mu_k's rolling limit but within mu_s's holds (the wheel rolls)."""
    theta = math.atan(1.1 * MU * (1 + WHEEL.k_axial) / WHEEL.k_axial)
    r = incline(theta, WHEEL, mu_k=MU, mu_s=1.2 * MU, stiffness=1e5, eps=1e-4)
    assert not r["sliding"]
    assert r["accel"] == pytest.approx(G * math.sin(theta) / (1 + WHEEL.k_axial), abs=1e-9)


def test_flight_is_a_parabola_with_torque_free_precession():
    """Centre on r0 + v0 t + g t^2/2 to 1e-10; L, w.n and the energy constant; the axle turns
    about L at |L| / I_diam (a cone of 0.26 rad)."""
    r = flight(beta0=1.2, gamma_dot0=10.0, alpha_dot0=4.0, beta_dot0=3.0, wheel=WHEEL, g=G)
    t = r["t"][:, None]
    np.testing.assert_allclose(r["r"], r["r"][0] + r["v"][0] * t + 0.5 * np.array([0, 0, -G]) * t ** 2,
                               atol=1e-10)
    np.testing.assert_allclose(r["L"], np.broadcast_to(r["L"][0], r["L"].shape), atol=1e-9)
    np.testing.assert_allclose(r["w_n"], r["w_n"][0], atol=1e-9)
    i_diam = WHEEL.k_diam * WHEEL.M * WHEEL.R ** 2
    assert r["cone"] > 0.2
    assert r["precession"] == pytest.approx(np.linalg.norm(r["L"][0]) / i_diam, rel=1e-9)
    series = r["run"].series(r["t"])
    np.testing.assert_allclose(series["energy"], series["energy"][0], rtol=1e-10)
    assert (series["F_n"] == 0).all() and (series["height"] > 0.5).all()


def test_drop_bounces_converge_to_the_restitution_series():
    """Apex heights e^(2k) h and the rest time t0 (1 + e)/(1 - e): the errors fall with the
    stiffness as kappa^(-1/2) (gravity acts during a contact of ~ pi / sqrt(kappa)), and
    Richardson's extrapolation in kappa^(-1/2) takes the first apex to 2e-4."""
    h, e = 0.2, 0.5
    t_rest = math.sqrt(2 * h / G) * (1 + e) / (1 - e)
    first, second, rest, apex1 = [], [], [], []
    for stiffness in (1e4, 1e5, 1e6):
        r = drop(h, e, WHEEL, stiffness=stiffness, g=G)
        apex1.append(r["apex"][0])
        apex = np.array(r["apex"][:2])
        first.append(abs(apex[0] / (e ** 2 * h) - 1))
        second.append(abs(apex[1] / (e ** 4 * h) - 1))
        rest.append(abs(r["t_rest"] - t_rest))
        assert all(y < x for x, y in zip(r["apex"], r["apex"][1:]))
    for errors in (first, second):
        assert errors[1] < errors[0] / 2.8 and errors[2] < errors[1] / 2.8  # sqrt(10) = 3.16
    assert first[-1] < 0.02 and second[-1] < 0.05
    assert extrapolate(apex1[1], apex1[2]) == pytest.approx(e ** 2 * h, rel=2e-4)
    assert rest[-1] < rest[0] / 5 and rest[-1] < 0.005 * t_rest


def test_leaning_spinning_drop_never_gains_energy_and_keeps_to_the_friction_cone():
    """Every impact: E after <= E before, J_t <= mu_k J_n; E + W constant to 1e-7 J."""
    r = leaning_drop(h=0.05, beta0=1.1, gamma_dot0=15.0, alpha_dot0=1.0, slip_long0=0.3, wheel=WHEEL,
                     stiffness=1e6, mu_k=MU, g=G)
    assert len(r["impacts"]) >= 3
    for impact in r["impacts"]:
        assert impact["E_after"] < impact["E_before"]
        assert impact["J_t"] <= MU * impact["J_n"] * (1 + 1e-9)
    assert r["drift"] < 1e-7
