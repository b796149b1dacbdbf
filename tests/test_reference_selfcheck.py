"""Self-checks of the independent reference model (tests/reference/) against analytic facts.

These tests do not touch the project's model: they establish that the Newton-Euler
reference is right, so that the project's model can later be tested against it.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))  # tests/ (as pytest does for rootdir conftest)

from reference import lagrange_sympy as lg  # noqa: E402
from reference import newton_euler as ne  # noqa: E402

PAPER = ne.PAPER_PARAMS  # M=2, R=0.17, k_diam=1/4, k_axial=2/5, g=9.81
PAPER_STATE0 = [0.0, 0.0, 0.0, math.radians(80.0), 0.0, 0.0, 0.0, 6.0]


def _random_states(n, seed):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        st = np.concatenate([
            rng.uniform(-1, 1, 2),                 # x, y
            rng.uniform(-np.pi, np.pi, 1),          # alpha
            rng.uniform(0.2, np.pi - 0.2, 1),       # beta (away from lying flat)
            rng.uniform(-np.pi, np.pi, 1),          # gamma
            rng.uniform(-8, 8, 3),                  # rates
        ])
        params = (rng.uniform(0.3, 5), rng.uniform(0.05, 0.6), rng.uniform(0.1, 0.7),
                  rng.uniform(0.1, 1.0), rng.uniform(1.0, 12.0))
        out.append((st, params))
    return out


# ---------------------------------------------------------------- derivation itself

def test_derivation_kinematics_symbolic():
    d = ne.derive()
    s = d["symbols"]
    # centre velocity reproduces eqs (18)-(20)
    al, be = s["alpha"], s["beta"]
    ad, bd, gd = s["rates"]
    R = s["R"]
    sa, ca, sb, cb = sp.sin(al), sp.cos(al), sp.sin(be), sp.cos(be)
    expected = sp.Matrix([R * (gd * ca + ad * ca * cb - bd * sa * sb),
                          R * (gd * sa + ad * cb * sa + bd * ca * sb),
                          R * bd * cb])
    assert sp.simplify(d["v_A"] - expected) == sp.zeros(3, 1)


def test_euler_rotating_frame_equals_direct_derivative():
    """dH/dt computed in the rotating l,m,n frame equals the plain time derivative of H's
    ground components (checks the omega_frame = alpha_dot k + beta_dot m bookkeeping)."""
    d = ne.derive()
    s = d["symbols"]
    direct = d["H"].applyfunc(
        lambda e: sum(sp.diff(e, q) * qd for q, qd in zip(s["angles"], s["rates"]))
        + sum(sp.diff(e, qd) * qdd for qd, qdd in zip(s["rates"], s["accels"])))
    diff = d["dHdt"] - direct
    f = sp.lambdify((s["state"], s["accels"], s["params"]), list(diff), "numpy")
    rng = np.random.default_rng(7)
    for st, pa in _random_states(10, 11):
        acc = tuple(rng.uniform(-10, 10, 3))
        assert np.max(np.abs(f(tuple(st), acc, pa))) < 1e-12


def test_rhs_shape_and_constraint():
    st = np.array(PAPER_STATE0)
    f = ne.rhs(st, PAPER)
    assert f.shape == (8,)
    # x_dot = R gamma_dot cos(alpha) for beta_dot = alpha_dot = 0
    assert f[0] == pytest.approx(0.17 * 6.0, rel=1e-14)
    assert f[1] == pytest.approx(0.0, abs=1e-15)
    assert np.all(f[2:5] == st[5:8])


# ---------------------------------------------------------------- cross-check with Lagrange

def test_newton_euler_matches_lagrange_multipliers():
    for st, pa in _random_states(40, 1234):
        a = ne.rhs(st, pa)
        b = lg.rhs(st, pa)
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)
        # the multipliers are the horizontal contact force (eqs 40-41)
        _, lam = lg.accelerations(st, pa)
        F = ne.contact_force(st, pa)
        np.testing.assert_allclose(lam, F[:2], rtol=1e-10, atol=1e-10)
        assert ne.energy(st, pa) == pytest.approx(lg.energy(st, pa), rel=1e-12)


# ---------------------------------------------------------------- energy

def test_energy_conserved_paper_scenario():
    sol = ne.simulate(PAPER_STATE0, PAPER, 5.0, t_eval=np.linspace(0, 5, 501))
    assert sol.success
    E = ne.energy(sol.y, PAPER)
    assert np.max(np.abs(E - E[0])) / abs(E[0]) < 1e-9
    # the wheel really moves (wobbles) in that time, so the check is not vacuous
    assert np.ptp(sol.y[3]) > 0.1


def test_energy_definition():
    st = np.array([0.3, -0.2, 0.4, 1.1, 0.2, 0.7, -0.3, 5.0])
    M, R, kd, ka, g = PAPER
    be, ad, bd, gd = st[3], st[5], st[6], st[7]
    v = ne.centre_velocity(st, PAPER)
    T = 0.5 * M * v @ v + 0.5 * (kd * M * R**2 * ((ad * math.sin(be)) ** 2 + bd**2)
                                 + ka * M * R**2 * (gd + ad * math.cos(be)) ** 2)
    assert ne.energy(st, PAPER) == pytest.approx(T + M * g * R * math.sin(be), rel=1e-14)


# ---------------------------------------------------------------- steady precession

STEADY_CASES = [
    # (beta, rho, params)
    (1.2, 0.5, PAPER),
    (1.0, 2.0, (1.0, 0.3, 0.25, 0.5, 9.81)),     # thin uniform disc
    (1.4, 0.3, (3.0, 0.25, 0.5, 1.0, 3.71)),     # thin ring, Mars gravity
    (0.8, 1.0, (2.0, 0.17, 0.25, 0.4, 1.62)),    # paper wheel, moon gravity
]


def _steady_formula(beta, rho, params):
    M, R, kd, ka, g = params
    Id, Ia = kd * M * R**2, ka * M * R**2
    return math.sqrt(M * g * R**2 / math.tan(beta) / ((Ia + M * R**2) * rho + Id * R * math.cos(beta)))


@pytest.mark.parametrize("beta,rho,params", STEADY_CASES)
def test_steady_precession_held(beta, rho, params):
    ad = ne.steady_precession_rate(beta, rho, params)
    assert ad == pytest.approx(_steady_formula(beta, rho, params), rel=1e-13)
    st0 = ne.steady_precession_state(beta, rho, params)
    assert st0[7] == pytest.approx(-(rho / params[1] + math.cos(beta)) * ad, rel=1e-14)
    sol = ne.simulate(st0, params, 10.0, t_eval=np.linspace(0, 10, 201))
    assert sol.success
    assert np.max(np.abs(sol.y[3] - beta)) < 1e-6
    assert np.max(np.abs(sol.y[5] - ad)) < 1e-6
    # the centre stays on the circle of radius rho about the origin
    assert np.max(np.abs(np.hypot(sol.y[0], sol.y[1]) - rho)) < 1e-6
    # contact force: weight plus centripetal force M rho alpha_dot^2 towards the circle's centre
    M = params[0]
    F = ne.contact_force(st0, params)
    np.testing.assert_allclose(F, [0.0, -M * rho * ad**2, M * params[4]], atol=1e-10)


def test_steady_precession_eq52_paper_inertia():
    M, R, kd, ka, g = PAPER
    for beta, rho in [(1.2, 0.5), (0.9, 3.0), (1.5, 0.1)]:
        eq52 = 20 * g / math.tan(beta) / (5 * R * math.cos(beta) + 28 * rho)
        assert ne.steady_precession_rate(beta, rho, PAPER) ** 2 == pytest.approx(eq52, rel=1e-13)


def test_steady_precession_symbolic_result():
    d = ne.derive()
    s = d["symbols"]
    M, R, kd, ka, g = s["params"]
    be, rho = s["beta"], d["rho"]
    Id, Ia = kd * M * R**2, ka * M * R**2
    expected = M * g * R**2 * sp.cot(be) / ((Ia + M * R**2) * rho + Id * R * sp.cos(be))
    assert sp.simplify(d["steady_alpha_dot_sq"] - expected) == 0
    assert sp.simplify(d["steady_gamma_dot_factor"] + rho / R + sp.cos(be)) == 0


# ---------------------------------------------------------------- critical spin

def test_critical_spin_formula():
    d = ne.derive()
    s = d["symbols"]
    M, R, kd, ka, g = s["params"]
    Id, Ia = kd * M * R**2, ka * M * R**2
    assert sp.simplify(d["critical_spin_sq"] - M * g * R * Id / (Ia * (Ia + M * R**2))) == 0
    assert ne.critical_spin(PAPER) == pytest.approx(math.sqrt(25 * 9.81 / (56 * 0.17)), rel=1e-14)


def _upright(w, dbeta):
    return [0.0, 0.0, 0.0, math.pi / 2 + dbeta, 0.0, 0.0, 0.0, w]


@pytest.mark.parametrize("params", [PAPER, (1.0, 0.3, 0.25, 0.5, 9.81)])
def test_critical_spin_separates_stable_from_unstable(params):
    wc = ne.critical_spin(params)
    # below: the lean grows past 0.1 rad within a few seconds
    sol = ne.simulate(_upright(0.8 * wc, 1e-3), params, 6.0, rtol=1e-10, atol=1e-12,
                      t_eval=np.linspace(0, 6, 601))
    lean = np.abs(sol.y[3] - math.pi / 2)
    assert lean.max() > 0.1
    # above: stays within 1e-2 for 10 s
    sol = ne.simulate(_upright(1.3 * wc, 1e-3), params, 10.0, rtol=1e-10, atol=1e-12,
                      t_eval=np.linspace(0, 10, 1001))
    assert sol.success
    lean = np.abs(sol.y[3] - math.pi / 2)
    assert lean.max() < 1e-2
