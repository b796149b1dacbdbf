"""The CasADi model against analytic results and first principles (not against itself)."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from conftest import PAPER, CasadiWheel, critical_spin, steady_precession
from gyrowheel.model.kinematics import WheelKinematics, angular_velocity

RNG = np.random.default_rng(20261122)


def _random_state():
    q = RNG.uniform([-1, -1, -3, 0.3, -3], [1, 1, 3, 2.8, 3])
    v = RNG.uniform(-4, 4, 3)
    return q, v


def test_angular_velocity_matches_eq12():
    """omega on {l, m, n} = (-alpha_dot sin beta, beta_dot, gamma_dot + alpha_dot cos beta), eq. (12)."""
    q, qd, R = ca.SX.sym("q", 5), ca.SX.sym("qd", 5), ca.SX.sym("R")
    kin = WheelKinematics(q, qd, R)
    f = ca.Function("w", [q, qd], [kin.omega_lmn, kin.omega - angular_velocity(kin.body, q, qd)])
    for _ in range(20):
        qv, vv = _random_state()
        qdv = np.r_[0.3, -0.2, vv]
        w, diff = (np.array(a).ravel() for a in f(qv, qdv))
        a_d, b_d, g_d = vv
        b = qv[3]
        np.testing.assert_allclose(w, [-a_d * math.sin(b), b_d, g_d + a_d * math.cos(b)], atol=1e-12)
        np.testing.assert_allclose(diff, 0, atol=1e-12)  # spin composed = derived from the full attitude


def test_rolling_constraint_matches_eqs_18_19(paper_model):
    """x_dot, y_dot of the null-space model equal eqs. (18)-(19) of the paper."""
    R = PAPER["R"]
    for _ in range(20):
        qv, vv = _random_state()
        x = np.r_[qv, vv]
        out = paper_model.out(x)
        a, b = qv[2], qv[3]
        ad, bd, gd = vv
        vx = R * (gd * math.cos(a) + ad * math.cos(a) * math.cos(b) - bd * math.sin(a) * math.sin(b))
        vy = R * (gd * math.sin(a) + ad * math.cos(b) * math.sin(a) + bd * math.cos(a) * math.sin(b))
        assert out["vx"] == pytest.approx(vx, abs=1e-12)
        assert out["vy"] == pytest.approx(vy, abs=1e-12)
        assert out["z"] == pytest.approx(R * math.sin(b), abs=1e-15)


def test_reduced_and_multiplier_forms_agree(paper_model):
    """Both formulations of the same Lagrangian give the same accelerations."""
    mult = CasadiWheel("multipliers", **PAPER)
    for _ in range(20):
        qv, vv = _random_state()
        xr = np.r_[qv, vv]
        xm = mult.x0(**dict(zip(["x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot"], xr)))
        dr = paper_model.rhs(0, xr)
        dm = mult.rhs(0, xm)
        np.testing.assert_allclose(dm[7:10], dr[5:8], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(dm[0:2], dr[0:2], rtol=1e-12, atol=1e-12)
        assert mult.out(xm)["constraint_violation"] < 1e-12


@pytest.mark.parametrize("k_diam,k_axial,g", [(0.25, 0.4, 9.81), (0.5, 1.0, 1.625), (0.3, 0.2, 3.721)])
def test_rhs_matches_independent_newton_euler(k_diam, k_axial, g):
    """CasADi's Lagrangian null-space RHS equals a sympy Newton-Euler derivation at random states."""
    from reference import newton_euler as ne
    params = dict(M=1.3, R=0.21, k_diam=k_diam, k_axial=k_axial, g=g)
    wheel = CasadiWheel(**params)
    for _ in range(20):
        qv, vv = _random_state()
        x = np.r_[qv, vv]
        np.testing.assert_allclose(wheel.rhs(0, x), ne.rhs(x, [params[k] for k in ne.PARAM_NAMES]),
                                   rtol=1e-10, atol=1e-10)


def test_multipliers_are_the_contact_force():
    """lambda of the multiplier form = horizontal contact force of the Newton-Euler derivation."""
    from reference import newton_euler as ne
    mult = CasadiWheel("multipliers", **PAPER)
    params = [PAPER[k] for k in ne.PARAM_NAMES]
    for _ in range(10):
        qv, vv = _random_state()
        x = np.r_[qv, vv]
        xm = mult.x0(**dict(zip(["x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot"], x)))
        out = mult.out(xm)
        F = ne.contact_force(x, params)
        assert out["lambda_x"] == pytest.approx(F[0], rel=1e-9, abs=1e-9)
        assert out["lambda_y"] == pytest.approx(F[1], rel=1e-9, abs=1e-9)


def test_energy_conserved_paper_scenario(paper_model):
    x0 = paper_model.x0()
    E0 = paper_model.out(x0)["energy"]
    sol = paper_model.integrate(x0, 5.0)
    E = np.array([paper_model.out(sol.y[:, i])["energy"] for i in range(sol.y.shape[1])])
    assert np.max(np.abs(E - E0)) / E0 < 1e-9


@pytest.mark.parametrize("k_diam,k_axial,beta_deg,rho", [
    (0.25, 0.4, 80.0, 1.0),    # the paper's wheel
    (0.25, 0.5, 60.0, 0.5),    # thin disc
    (0.5, 1.0, 75.0, 2.0),     # ring
    (0.3, 0.45, 70.0, 0.3),    # tight circle, strong lean
])
def test_steady_precession_eq52(k_diam, k_axial, beta_deg, rho):
    """Eq. (52), generalised to any inertia, with eq. (49) corrected: lean and radius stay constant."""
    params = dict(PAPER, k_diam=k_diam, k_axial=k_axial)
    wheel = CasadiWheel(**params)
    start = steady_precession(math.radians(beta_deg), rho, **params)
    x0 = wheel.x0(**start)
    sol = wheel.integrate(x0, 10.0, t_eval=np.linspace(0, 10, 201))
    beta = sol.y[3]
    assert np.max(np.abs(beta - beta[0])) < 1e-6
    xs, ys = sol.y[0], sol.y[1]
    # least-squares circle through the centre's path: x^2 + y^2 = 2 a x + 2 b y + c
    A = np.c_[2 * xs, 2 * ys, np.ones_like(xs)]
    a, b, c = np.linalg.lstsq(A, xs**2 + ys**2, rcond=None)[0]
    np.testing.assert_allclose(np.hypot(xs - a, ys - b), rho, rtol=1e-6)


def test_slow_steady_precession_is_unstable():
    """Eq. (52) also holds where steady precession is unstable (slow spin, 85 deg, rho = 0.2 m):
    the lean stays put at first, then the round-off grows and the wheel leaves the circle."""
    params = dict(PAPER, k_diam=0.3, k_axial=0.45)
    wheel = CasadiWheel(**params)
    start = steady_precession(math.radians(85.0), 0.2, **params)
    sol = wheel.integrate(wheel.x0(**start), 20.0, t_eval=np.linspace(0, 20, 401))
    dev = np.abs(sol.y[3] - start["beta"])
    assert dev[:40].max() < 1e-6  # first 2 s: on the equilibrium
    assert dev.max() > 0.1  # then it diverges


def test_steady_precession_fails_with_paper_printed_eq49():
    """With the printed eq. (49), gamma_dot = (-rho/R + cos beta) alpha_dot, the lean is not steady."""
    params = PAPER
    beta, rho = math.radians(80.0), 1.0
    start = steady_precession(beta, rho, **params)
    start["gamma_dot"] = (-rho / params["R"] + math.cos(beta)) * start["alpha_dot"]
    wheel = CasadiWheel(**params)
    sol = wheel.integrate(wheel.x0(**start), 3.0)
    assert np.max(np.abs(sol.y[3] - beta)) > 1e-3


@pytest.mark.parametrize("factor,stable", [(0.8, False), (1.25, True)])
def test_critical_spin_of_upright_rolling(factor, stable):
    """w_c^2 = M g R I_diam / (I_axial (I_axial + M R^2)) separates stable from unstable."""
    wheel = CasadiWheel(**PAPER)
    wc = critical_spin(**PAPER)
    x0 = wheel.x0(beta=math.pi / 2 - 1e-3, gamma_dot=factor * wc, alpha_dot=0.0)
    sol = wheel.integrate(x0, 15.0, rtol=1e-10, atol=1e-11, t_eval=np.linspace(0, 15, 1501))
    lean = np.abs(sol.y[3] - math.pi / 2)
    if stable:
        assert lean.max() < 2e-2
    else:
        assert lean.max() > 0.1
