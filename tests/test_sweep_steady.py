"""The maps' physics overlays: eqs. (52)/(53), the critical spin and the linearised stability,
against the paper's printed formula, the analytic w_c and the growth seen in simulation."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gyrowheel.model.steady import critical_spin, precession_rates, precession_speed
from gyrowheel.studies.steady import growth_rate, precession_growth_rate, upright_boundary

PAPER = dict(M=2.0, R=0.17, k_diam=0.25, k_axial=0.4, g=9.81)


@pytest.mark.parametrize("beta_deg, rho, g", [(80.0, 1.0, 9.81), (60.0, 0.3, 3.721), (88.0, 2.5, 1.625)])
def test_eq53_equals_the_paper_for_its_inertia(beta_deg, rho, g):
    beta = math.radians(beta_deg)
    printed = math.sqrt(20 * g / math.tan(beta) * rho**2 / (5 * 0.17 * math.cos(beta) + 28 * rho))
    assert precession_speed(beta, rho, **dict(PAPER, g=g)) == pytest.approx(printed, rel=1e-14)
    alpha_dot, _ = precession_rates(beta, rho, **dict(PAPER, g=g))
    assert alpha_dot**2 == pytest.approx(20 * g / math.tan(beta) / (5 * 0.17 * math.cos(beta) + 28 * rho), rel=1e-14)


@pytest.mark.parametrize("params", [PAPER, dict(PAPER, g=1.625), dict(M=0.45, R=0.0375, k_diam=0.25, k_axial=0.5, g=9.81),
                                    dict(PAPER, k_diam=0.5, k_axial=1.0)])
def test_eigenvalue_boundary_is_the_critical_spin(params):
    """Eigenvalues of CasADi's Jacobian of the model's ode alone find w_c^2 = M g R I_d / (I_a (I_a + M R^2))."""
    assert upright_boundary(**params) == pytest.approx(critical_spin(**params), rel=1e-6)
    wc = critical_spin(**params)
    assert growth_rate(math.pi / 2, 0.0, 0.9 * wc, **params) > 0.1 * math.sqrt(params["g"] / params["R"])
    assert growth_rate(math.pi / 2, 0.0, 1.1 * wc, **params) < 1e-12


def test_unstable_steady_precession_grows_as_the_eigenvalue_says(casadi_wheel):
    """k = 0.3/0.45, 85 deg, rho = 0.2 m (docs/model.md): the largest eigenvalue is real and positive,
    and a 1e-9 rad/s nudge of the lean rate grows at that rate in a scipy integration of the model."""
    params = dict(PAPER, k_diam=0.3, k_axial=0.45)
    beta = math.radians(85.0)
    lam = precession_growth_rate(beta, 0.2, **params)
    assert lam > 1.0
    alpha_dot, gamma_dot = precession_rates(beta, 0.2, **params)
    wheel = casadi_wheel(**params)
    x0 = wheel.x0(beta=beta, alpha_dot=alpha_dot, gamma_dot=gamma_dot, beta_dot=1e-9)
    t = np.linspace(0, 4, 801)
    dev = np.abs(wheel.integrate(x0, 4.0, rtol=1e-12, atol=1e-14, t_eval=t).y[3] - beta)
    window = (dev > 1e-8) & (dev < 1e-4)
    slope = np.polyfit(t[window], np.log(dev[window]), 1)[0]
    assert slope == pytest.approx(lam, rel=0.05)


@pytest.mark.parametrize("beta_deg, rho", [(80.0, 1.0), (60.0, 0.5), (70.0, 0.3)])
def test_stable_steady_precession_has_no_growth(beta_deg, rho):
    """The cases test_model_physics.py::test_steady_precession_eq52 simulates as steady."""
    assert precession_growth_rate(math.radians(beta_deg), rho, **PAPER) < 1e-9


def test_no_steady_precession_past_upright():
    with pytest.raises(ValueError, match="no steady precession"):
        precession_rates(math.radians(95.0), 1.0, **PAPER)
