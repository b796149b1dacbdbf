"""Linearisation about upright rolling against the analytic modes and simulation."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import casadi as ca
from conftest import PAPER, critical_spin
from gyrowheel.model.build import build_model
from gyrowheel.model.linearise import (LinearisationError, initial_state, linearise, output_expr, parameter_values,
                                       upright_rolling)
from gyrowheel.model.steady import wheel_mode_eigenvalues


@pytest.fixture(scope="module")
def bare():
    spec = build_model(wheel={k: PAPER[k] for k in ("M", "R", "k_diam", "k_axial")}, effects={"gravity": {}})
    return spec, parameter_values(spec)


@pytest.mark.parametrize("ratio", [0.3, 0.8, 1.2, 3.0])
def test_unactuated_wheel_modes_match_the_analytic_roots(bare, ratio):
    """lambda^2 I_d (I_d + M R^2) = M g R I_d - w^2 I_a (I_a + M R^2), w = ratio * w_c."""
    spec, p = bare
    w = ratio * critical_spin(**PAPER)
    x0, u0 = upright_rolling(spec, w * PAPER["R"], p)
    lm = linearise(spec, x0, u0, p, {"lean": output_expr(spec, "beta")}).relevant()
    expected = wheel_mode_eigenvalues(**PAPER, spin=w)
    ev = lm.eigenvalues()
    assert np.min(np.abs(ev - expected)) < 1e-9 * max(1.0, abs(expected))
    assert (ev.real.max() > 1e-6) == (ratio < 1.0)  # one growing mode below the critical spin only


@pytest.mark.parametrize("ratio", [0.5, 2.0])
def test_growth_and_weave_rates_match_simulation(bare, ratio):
    """A 1e-6 rad lean perturbation grows at Re(lambda) (below w_c) or weaves at Im(lambda) (above)."""
    spec, p = bare
    w = ratio * critical_spin(**PAPER)
    lam = wheel_mode_eigenvalues(**PAPER, spin=w)
    x0 = initial_state(spec, p, {"beta": math.pi / 2 - 1e-6, "gamma_dot": w})
    f = ca.Function("f", [spec.x, spec.p], [spec.ode])
    t_end = 8.0 / abs(lam)  # lean stays below 2e-3 rad: linear
    sol = solve_ivp(lambda t, x: np.array(f(x, p)).ravel(), (0, t_end), x0, method="DOP853", rtol=1e-12,
                    atol=1e-15, dense_output=True)
    t = np.linspace(0, t_end, 4001)
    lean = math.pi / 2 - sol.sol(t)[3]
    if lam.real > 0:  # cosh growth: the log slope tends to lambda
        slope = np.polyfit(t[3000:], np.log(lean[3000:]), 1)[0]
        assert slope == pytest.approx(lam.real, rel=2e-3)
    else:  # lean rate ~ sin(omega t) (the lean itself weaves about an offset): crossings half a period apart
        rate = sol.sol(t)[spec.x_names.index("beta_dot")]
        crossings = t[1:][np.diff(np.sign(rate)) != 0]
        assert np.mean(np.diff(crossings)) == pytest.approx(math.pi / lam.imag, rel=1e-3)


def test_not_an_equilibrium_is_refused():
    spec = build_model(effects={"gravity": {}})
    p = parameter_values(spec)
    x0 = initial_state(spec, p, {"beta": 1.2, "gamma_dot": 5.0})
    from gyrowheel.model.linearise import check_equilibrium
    with pytest.raises(LinearisationError, match="not an equilibrium"):
        check_equilibrium(spec, x0, np.zeros(0), p, moving=("x", "y", "gamma"))
