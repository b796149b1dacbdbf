"""When has the wheel fallen? (docs/model.md, "When the wheel has fallen")

A thin hoop (M = 1, R = 1, g = 100, k_diam = 0.5, k_axial = 1, upright, beta_dot = 0.01,
gamma_dot = 0.1, no dissipation) dips to a lean of 0.0135 rad at t = 0.968 s and comes back up,
52 times in 100 s: a default beta_min of 0.02 would declare it fallen at the first dip. The
default is as near flat as the model's Euler angles keep their accuracy (1e-3 rad); the
physical fall lean of a wheel with width is the scene preset beta_min = "touchdown".
"""
from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
import sympy as sp
from fmpy import simulate_fmu

from conftest import SCENES, CasadiWheel
from fmi_helpers import Slave
from gyrowheel.fmu_build import parse_scene
from gyrowheel.model.build import BETA_MIN_DEFAULT, touchdown_lean

HOOP = dict(M=1.0, R=1.0, g=100.0, k_diam=0.5, k_axial=1.0)
HOOP_START = dict(beta=math.pi / 2, beta_dot=0.01, gamma_dot=0.1)
EPS = np.finfo(float).eps


def _dips(t, beta_dot_zero_states):
    """(times, leans from flat) of the states where beta_dot = 0 with the wheel near flat."""
    lean = np.minimum(beta_dot_zero_states[3], math.pi - beta_dot_zero_states[3])
    near = lean < 0.5
    return t[near], lean[near]


@pytest.fixture(scope="module")
def hoop_reference():
    """The independent Newton-Euler derivation (tests/reference) under scipy DOP853 at rtol 1e-12."""
    from reference import newton_euler as ne
    params = [HOOP[k] for k in ne.PARAM_NAMES]
    x0 = [0, 0, 0, HOOP_START["beta"], 0, 0, HOOP_START["beta_dot"], HOOP_START["gamma_dot"]]

    def turning(t, x):
        return x[6]
    sol = ne.simulate(x0, params, 100.0, rtol=1e-12, atol=1e-14, events=turning)
    assert sol.success
    return _dips(sol.t_events[0], sol.y_events[0].T)


def _hoop_run(fmu, fine=2e-5, coarse=1e-3):
    """The hoop, every parameter but the wheel's at the FMU's defaults; communication steps of
    `coarse`, or `fine` while the lean is below 0.1 rad (so that every dip is resolved).
    Returns times, sin^2(beta) and energy."""
    s = Slave(fmu)
    try:
        s.init(**HOOP, **HOOP_START)
        t, q, e = [0.0], [math.sin(s.get("beta")) ** 2], [s.get("energy")]
        while t[-1] < 100.0 - 1e-9:
            h = min(fine if q[-1] < 0.01 else coarse, 100.0 - t[-1])
            s.slave.doStep(t[-1], h)
            t.append(t[-1] + h)
            q.append(math.sin(s.get("beta")) ** 2)
            e.append(s.get("energy"))
        assert not s.get("fallen")
    finally:
        s.free()
    return np.array(t), np.array(q), np.array(e)


def test_default_hoop_recovers_52_times_in_100_s(earth_fmu, hoop_reference):
    """Each dip's time and lowest lean against the reference: near a dip the lean follows
    sin^2(lean) = sin^2(lean_min) + c (t - t_min)^2 (a straight pass near the flat configuration),
    so a parabola through three samples of sin^2(beta) 20 us apart locates it."""
    assert "beta_min" not in (SCENES / "paper_earth.toml").read_text()  # the FMU keeps the default
    ref_t, ref_lean = hoop_reference
    assert len(ref_t) == 52 and ref_lean.min() == pytest.approx(0.0135133, abs=1e-7)
    t, q, energy = _hoop_run(earth_fmu)
    i = np.flatnonzero((q[1:-1] < q[:-2]) & (q[1:-1] <= q[2:]) & (q[1:-1] < 0.25)) + 1
    a, b, c = q[i - 1], q[i], q[i + 1]
    assert len(i) == 52 and np.all(t[i + 1] - t[i] < 3e-5)
    np.testing.assert_allclose(np.arcsin(np.sqrt(b - (a - c) ** 2 / (8 * (a - 2 * b + c)))), ref_lean, rtol=2e-6)
    t_min = t[i] + (t[i + 1] - t[i]) * (a - c) / (2 * (a - 2 * b + c))
    np.testing.assert_allclose(t_min, ref_t, atol=1e-2)  # 3.5e-3 s at the last dip (rel_tol 1e-8)
    assert np.abs(energy / energy[0] - 1).max() < 1e-8  # measured 1.3e-9


def test_default_hoop_with_default_output(earth_fmu):
    """gyrowheel simulate's way (communication every 10 ms): no fall, drift within the tolerance.
    Coarse steps through the dips cost accuracy (docs/hard_cases.md): 4.9e-7 relative drift."""
    r = simulate_fmu(str(earth_fmu), stop_time=100.0, output_interval=0.01, start_values={**HOOP, **HOOP_START})
    assert r["time"][-1] == pytest.approx(100.0) and not r["fallen"][-1]
    assert np.abs(r["energy"] / r["energy"][0] - 1).max() < 1e-6
    assert np.abs(np.sin(r["beta"])).min() > math.sin(0.0135)


def test_old_default_stopped_the_hoop_at_its_first_dip(earth_fmu):
    r = simulate_fmu(str(earth_fmu), stop_time=2.0, output_interval=1e-3,
                     start_values={**HOOP, **HOOP_START, "beta_min": 0.02})
    assert r["fallen"][-1] and r["time"][-1] == pytest.approx(0.967, abs=1e-3)


@pytest.fixture(scope="module")
def exact_accelerations():
    """(alpha_ddot, beta_ddot, gamma_ddot) of the independent derivation, evaluated with 40 digits."""
    from reference import newton_euler as ne
    d = ne.derive()
    s = d["symbols"]
    f = sp.lambdify((s["state"], s["params"]), [d["accels"][a] for a in s["accels"]], modules="mpmath")

    def exact(state, params):
        with mpmath.workdps(40):
            return np.array([float(v) for v in f([mpmath.mpf(v) for v in state], [mpmath.mpf(v) for v in params])])
    return exact


@pytest.mark.parametrize("k_diam,k_axial", [(0.5, 1.0), (0.25, 0.4), (0.25, 0.5)])
def test_round_off_near_flat_is_below_the_default_tolerance(exact_accelerations, k_diam, k_axial):
    """The accelerations lose accuracy like eps / sin^2(beta) (the Euler angles are singular at 0);
    at the default beta_min that is still well below the default rel_tol = 1e-8."""
    params = dict(M=1.3, R=0.4, k_diam=k_diam, k_axial=k_axial, g=9.81)
    wheel = CasadiWheel(**params)
    rng = np.random.default_rng(7)
    worst = {}
    for lean in (1e-1, 1e-2, BETA_MIN_DEFAULT):
        errors = []
        for beta in (lean, math.pi - lean):
            for _ in range(10):  # rates of a dip: alpha_dot ~ 1 / lean, omega . n = O(1)
                ad = rng.uniform(-1, 1) * 0.3 / lean
                state = [0.0, 0.0, rng.uniform(0, 6), beta, rng.uniform(0, 6), ad, rng.uniform(-1, 1),
                         -ad * math.cos(beta) + rng.uniform(-1, 1)]
                exact = exact_accelerations(state, [params[k] for k in ("M", "R", "k_diam", "k_axial", "g")])
                got = wheel.rhs(0.0, np.array(state))[5:8]
                errors.append(np.abs(got - exact).max() / np.abs(exact).max())
        worst[lean] = max(errors)
        assert worst[lean] < 20 * EPS / math.sin(lean) ** 2, (lean, worst[lean])
    assert worst[BETA_MIN_DEFAULT] < 1e-8 / 2


@pytest.mark.parametrize("k_diam,k_axial,expected", [
    (0.5, 1.0, 0.0),                      # thin hoop: flat at 0
    (0.25, 0.5, 0.0),                     # thin uniform disc
    (0.25, 0.4, math.atan(math.sqrt(1 / 12))),  # the paper's wheel: 16.1 deg
])
def test_touchdown_lean(k_diam, k_axial, expected):
    assert touchdown_lean(k_diam, k_axial) == pytest.approx(expected, abs=1e-15)


def test_touchdown_lean_is_tight():
    """A rim ring plus two axle masses at +-h: the axle tips touch at tan(beta) = h / R."""
    M, R, m_rim, h = 1.0, 0.3, 0.7, 0.05
    m_axle = M - m_rim
    k_axial = m_rim / M
    k_diam = (m_rim * R**2 / 2 + m_axle * h**2) / (M * R**2)
    assert touchdown_lean(k_diam, k_axial) == pytest.approx(math.atan(h / R), rel=1e-12)


@pytest.mark.parametrize("text,beta_min", [
    ("", BETA_MIN_DEFAULT),
    ('beta_min = "touchdown"\n', math.atan(math.sqrt(1 / 12))),
    ('beta_min = "touchdown"\nk_diam = 0.5\nk_axial = 1.0\n', BETA_MIN_DEFAULT),  # never below the default
])
def test_scene_fall_lean(text, beta_min):
    scene = parse_scene("[wheel]\n" + text)
    assert scene.wheel.get("beta_min", BETA_MIN_DEFAULT) == pytest.approx(beta_min, rel=1e-15)
