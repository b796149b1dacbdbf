"""Where a rolling wheel's contact force can vanish, and how the hybrid wheel leaves the ground there.

The reference is the rolling-only model (on_lift_off = "warn": its contact_forces outputs F_n,
F_long, F_lat from the rolling constraint), not the hybrid. Its states with zero contact force
(F_n = F_long = F_lat = 0, found by root search over the rates at a given lean) are all
time-symmetric points of the rolling motion: a turning point of the lean (beta_dot = 0, the
wheel precessing fast), where F_n has a maximum 0 (F_n < 0 on both sides: a rolling wheel cannot
get there), or the upright wheel falling through the vertical at beta_dot^2 = g / R (alpha_dot = 0,
any spin), where F_n has a minimum 0. At both F_n is even in the time from that point and the
friction F_long odd, so |F_t| / F_n grows like 1 / |t - t*|: for any finite mu the friction limit
comes first and a rolling wheel leaves the ground only through sliding (docs/effects.md, "Flight").
The hybrid wheel, run along such a path, switches to sliding where the rolling-only model's
friction demand reaches mu F_n, then lifts off, flies and lands keeping energy + dissipated_energy.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import simulate_fmu
from scipy.optimize import fsolve

from fmi_helpers import Slave, simulate_logged
from gyrowheel.fmu_build import build_fmu, parse_scene
from paper_wheel import G, M, R
from paper_wheel import PAPER_WHEEL_TOML as WHEEL

TIGHT = {"rel_tol": 1e-13, "abs_tol": 1e-15}
ROLLING = WHEEL + '[effects.contact_forces]\non_lift_off = "warn"\nmu = 100.0\n[effects.energy]\n'
HYBRID = WHEEL + ('[effects.contact_forces]\non_slip = "slide"\non_lift_off = "fly"\nmu = 100.0\n'
                  'restitution = 0.5\n[effects.energy]\n')
STATE = ("x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot")
RATES = ("alpha_dot", "beta_dot", "gamma_dot")
W_UP = math.sqrt(G / R)  # the upright wheel's lean rate where F_n = M (g - R beta_dot^2) = 0
T_STAR = 0.05  # the time the constructed rolling path passes the upright zero-force state
MU_10 = {"mu": 10.0, "mu_k": 10.0}  # the hybrid's friction for a landing lift-off (mu_k <= mu)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    root = tmp_path_factory.mktemp("lift_off")
    return {name: str(build_fmu(parse_scene(text, f"{name}.toml"), root / f"{name}.fmu").fmu)
            for name, text in (("rolling", ROLLING), ("hybrid", HYBRID))}


class Forces:
    """The rolling-only model's contact force (units of M g) at a start state, or tau seconds later."""

    def __init__(self, fmu: str):
        self.slave = Slave(fmu, logging_on=False)

    def __call__(self, tau: float = 0.0, **start) -> np.ndarray:
        self.slave.fmu2.reset()
        self.slave.init(**TIGHT, **start)
        if tau > 0:
            self.slave.fmu2.doStep(0.0, tau)
        return np.array(self.slave.get("F_n", "F_long", "F_lat")) / (M * G)

    def around(self, tau: float, **start) -> tuple[np.ndarray, np.ndarray]:
        """The force tau after and tau before the start state (before: the rates reversed, the
        rolling wheel being time-reversible)."""
        back = {**start, **{k: -start[k] for k in RATES}}
        return self(tau, **start), self(tau, **back)


def zero_force_states(forces: Forces, beta: float, tries: int = 60) -> list[np.ndarray]:
    """The rates (alpha_dot, beta_dot, gamma_dot) at lean beta where F = 0, from random starts."""
    rng = np.random.default_rng(7)
    roots = []
    for _ in range(tries):
        rates, _, ok, _ = fsolve(lambda v: forces(beta=beta, **dict(zip(RATES, v))), rng.normal(0, 15, 3),
                                 full_output=True)
        if ok == 1 and np.max(np.abs(forces(beta=beta, **dict(zip(RATES, rates))))) < 1e-10:
            roots.append(rates)
    return roots


@pytest.mark.parametrize("beta", [1.0, 1.2, 1.3])
def test_contact_force_vanishes_only_at_a_lean_turning_point_where_f_n_is_at_most_zero(fmus, beta):
    forces = Forces(fmus["rolling"])
    roots = zero_force_states(forces, beta)
    assert roots
    for rates in roots:
        start = {"beta": beta, **dict(zip(RATES, rates))}
        assert abs(start["beta_dot"]) < 1e-8  # a turning point of the lean
        ratios = []
        for tau in (1e-3, 2e-3):
            after, before = forces.around(tau, **start)
            assert after[0] < 0 and after[0] == pytest.approx(before[0], rel=1e-6)  # F_n: maximum 0, even
            assert after[1] == pytest.approx(-before[1], rel=1e-6) and after[1] != 0  # F_long: odd
            ratios.append(math.hypot(after[1], after[2]) / abs(after[0]))
        assert ratios[0] > 1.9 * ratios[1]  # |F_t| / |F_n| ~ 1 / tau


@pytest.mark.parametrize("spin, side", [(0.0, -1), (20.0, 1), (-35.0, 1)])
def test_upright_wheel_falling_at_sqrt_g_over_r_has_f_n_even_and_friction_linear(fmus, spin, side):
    """Through the vertical at beta_dot^2 = g / R: F = 0 there, F_n even beside it, a maximum 0
    without spin (negative beside it: unreachable while rolling), a minimum 0 with spin (the wheel
    is pressed on again); |F_t| / |F_n| ~ 1 / tau either way."""
    forces = Forces(fmus["rolling"])
    start = {"beta": math.pi / 2, "beta_dot": W_UP, "alpha_dot": 0.0, "gamma_dot": spin}
    assert np.max(np.abs(forces(**start))) < 1e-12
    ratios = []
    for tau in (1e-3, 2e-3):
        after, before = forces.around(tau, **start)
        assert side * after[0] > 0 and after[0] == pytest.approx(before[0], rel=1e-6)
        ratios.append(math.hypot(after[1], after[2]) / abs(after[0]))
    assert ratios[0] > 1.9 * ratios[1]


def test_falling_without_spin_has_the_pendulums_contact_force(fmus):
    """No spin, no precession: the wheel turns about the tangent at its contact point like a
    pendulum of inertia (k_diam + 1) M R^2, so (units of M g, with beta from the same run)
    F_n = 1 - cos^2(beta) / (1 + k_diam) - R sin(beta) beta_dot^2 / g and
    |F_t| = |cos(beta)| |sin(beta) / (1 + k_diam) - R beta_dot^2 / g|."""
    from paper_wheel import KD
    forces = Forces(fmus["rolling"])
    for tau in (1e-3, 0.03, 0.1):  # (flat at 0.2 s)
        f = forces(tau, beta=math.pi / 2, beta_dot=W_UP, alpha_dot=0.0, gamma_dot=0.0)
        beta, beta_dot = forces.slave.get("beta", "beta_dot")
        c, s = math.cos(beta), math.sin(beta)
        assert f[0] == pytest.approx(1 - c ** 2 / (1 + KD) - R * s * beta_dot ** 2 / G, abs=1e-12)
        assert math.hypot(f[1], f[2]) == pytest.approx(abs(c * (s / (1 + KD) - R * beta_dot ** 2 / G)), abs=1e-12)


@pytest.fixture(scope="module")
def approach(fmus):
    """A rolling start whose path passes the upright zero-force state (spin 20 rad/s) at T_STAR:
    the rolling-only model run backwards from it (rates reversed) for T_STAR, its end with the
    rates reversed again. Returns (start values, the rolling-only run from them)."""
    star = {"beta": math.pi / 2, "beta_dot": -W_UP, "alpha_dot": 0.0, "gamma_dot": -20.0}
    back, events = simulate_logged(fmus["rolling"], T_STAR, T_STAR / 50, list(STATE), {**TIGHT, **star})
    assert events == [] and back["time"][-1] == pytest.approx(T_STAR)
    start = {k: float(back[k][-1]) * (-1 if k in RATES else 1) for k in STATE}
    ahead, events = simulate_logged(fmus["rolling"], 0.07, 1e-4, list(STATE) + ["F_n", "F_long", "F_lat"],
                                    {**TIGHT, **start})
    return start, ahead, events


def test_the_constructed_rolling_path_reaches_f_n_zero_at_t_star(approach):
    _, r, _ = approach
    i = int(np.argmin(r["F_n"]))
    assert r["time"][i] == pytest.approx(T_STAR, abs=1e-12)
    assert abs(r["F_n"][i]) < 1e-9 * M * G and math.hypot(r["F_long"][i], r["F_lat"][i]) < 1e-9 * M * G
    assert r["beta"][i] == pytest.approx(math.pi / 2, abs=1e-9)
    assert np.all(r["F_n"] > 0)  # the rolling wheel touches F_n = 0 and is pressed on again


def test_hybrid_slides_where_the_friction_demand_reaches_mu_then_flies_and_lands(fmus, approach):
    """mu = 10: the slip where the rolling-only model's friction demand reaches mu F_n (its slip
    warning), then lift-off from sliding before t*, a flight, a touchdown that lands the wheel on
    the ground (sliding, then rolling), and the same again each time the wheel swings through the
    vertical (every 0.116 s); energy + dissipated_energy constant throughout."""
    start = approach[0]
    rolling, rolling_events = simulate_logged(fmus["rolling"], 0.07, 1e-4, list(STATE),
                                              {**TIGHT, **start, "mu": 10.0})
    slip = [t for name, t in rolling_events if name == "slip"]
    assert slip and slip[0] < T_STAR
    out = list(STATE) + ["contact_mode", "height", "energy", "dissipated_energy"]
    r, events = simulate_logged(fmus["hybrid"], 0.25, 1e-4, out, {**TIGHT, **start, **MU_10})
    names = [name for name, _ in events]
    assert names[:2] == ["contact_slip", "contact_flight"]
    assert events[0][1] == pytest.approx(slip[0], abs=1e-9)  # rolling until the same instant
    t_lift = events[1][1]
    assert events[0][1] < t_lift < T_STAR
    t = r["time"]
    n = int(np.sum(t < events[0][1]))  # the rows before the slip, on both runs' grid
    assert np.array_equal(t[:n], rolling["time"][:n])
    for name in ("beta", "alpha_dot", "gamma_dot"):
        assert np.max(np.abs(r[name][:n] - rolling[name][:n])) < 1e-9, name
    assert np.all(r["contact_mode"][:n] == 0)
    flight = [tt for name, tt in events if name == "contact_flight"]  # lift-off, touchdown, ...
    assert len(flight) >= 4
    for up, down in zip(flight[0::2], flight[1::2]):
        assert np.all(r["contact_mode"][(t > up) & (t < down)] == 2)
    assert np.all(r["contact_mode"][(t > flight[1] + 1e-3) & (t < flight[2])] < 2)
    assert np.all(r["height"] >= -1e-12 * R)
    balance = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(balance - balance[0])) < 1e-9 * M * G * R  # through the flights and touchdowns
    assert np.all(np.diff(r["dissipated_energy"]) >= -1e-12 * M * G * R)


def test_grazing_touchdown_keeps_the_wheel_above_the_ground(fmus, approach):
    """mu = 100: the slip 1e-4 s before t*, the lift-off from sliding 6.5e-5 s later, a touchdown
    at a grazing speed; the wheel must not go below the ground after it."""
    start = approach[0]
    r, events = simulate_logged(fmus["hybrid"], 0.1, 1e-4, ["height", "contact_mode"], {**TIGHT, **start})
    assert [name for name, _ in events][:3] == ["contact_slip", "contact_flight", "contact_flight"]
    assert np.all(r["height"] >= -1e-12 * R)


def test_lift_off_after_the_slip_keeps_the_velocities(fmus, approach):
    """Model Exchange (fmpy's CVode, the values before and after each event recorded): at the
    sliding -> flight switch every velocity is continuous and the rim point is on the ground."""
    start, _, _ = approach
    me = simulate_fmu(fmus["hybrid"], stop_time=T_STAR, output_interval=1e-3, fmi_type="ModelExchange",
                      record_events=True, solver="CVode", relative_tolerance=1e-10,
                      output=["contact_mode", "F_n", "height", "vx", "vy", "vz", "alpha_dot", "beta_dot",
                              "gamma_dot"], start_values={**TIGHT, **start, **MU_10})
    tm, mode = me["time"], me["contact_mode"]
    i = next(k for k in range(len(tm) - 1) if tm[k] == tm[k + 1] and mode[k] == 1 and mode[k + 1] == 2)
    assert abs(me["F_n"][i]) < 1e-6 * M * G and me["F_n"][i + 1] == 0 and me["height"][i + 1] == 0
    for name in ("vx", "vy", "vz", "alpha_dot", "beta_dot", "gamma_dot"):
        assert abs(me[name][i + 1] - me[name][i]) <= 1e-12 * max(1.0, abs(me[name][i])), name
