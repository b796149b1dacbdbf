"""True stiction of the Coulomb laws (docs/effects.md, "Stiction").

Against references the code did not produce: Newton-Euler of an upright disk on an incline
(solved here), the analytic stop time of a wheel rolling uphill or of a pivoting wheel, and an
independent sympy derivation of the planar Gyrover (tests/reference/planar_gyrover.py) for a
drive whose needed holding torque grows, exceeds the limit and falls back, again and again.
"""
from __future__ import annotations

import ctypes
import math
import re

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model

from fmi_helpers import Slave
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.fmu_build.scene import SceneError
from gyrowheel.studies.scipy_reference import solve_hybrid
from gyrowheel.model.build import build_model
from reference.hybrid_lift_off import to_lift_off
from reference.planar_gyrover import Planar
from paper_wheel import G, KA, KD, M, R
from paper_wheel import PAPER_WHEEL_TOML as WHEEL

C_RR = 0.02
TIGHT = {"rel_tol": 1e-10, "abs_tol": 1e-12}


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    root = tmp_path_factory.mktemp("stiction")
    cache: dict[str, str] = {}

    def _build(name: str, text: str) -> str:
        if name not in cache:
            scene = parse_scene(f'[model]\nname = "{name}"\n' + WHEEL + text, f"{name}.toml")
            cache[name] = str(build_fmu(scene, root / f"{name}.fmu", build_dir=root / name).fmu)
        return cache[name]
    return _build


@pytest.fixture(scope="module")
def slope_fmu(build):
    return build("slope_rr", "[effects.slope]\n[effects.rolling_resistance]\n[effects.energy]\n")


def run(fmu, stop, dt, fmi_type="CoSimulation", logs: list[str] | None = None, **start):
    """simulate_fmu with the FMU's logEvents messages: (result, [(event name, t)]); every message
    is appended to `logs` when given."""
    logs = [] if logs is None else logs

    def logger(*args):
        text = args[-1]
        logs.append(text.decode() if isinstance(text, bytes) else str(text))
    kw = {"solver": "CVode", "relative_tolerance": 1e-10} if fmi_type == "ModelExchange" else {}
    r = simulate_fmu(fmu, stop_time=stop, output_interval=dt, fmi_type=fmi_type, start_values={**TIGHT, **start},
                     debug_logging=True, logger=logger, output=_outputs(fmu), **kw)
    events = [(m.group(1), float(m.group(2))) for line in logs
              for m in [re.search(r"event (\w+) at t=(\S+?):? ", line + " ")] if m]
    return r, events


def _outputs(fmu):
    """Every output and the stiction modes (local states)."""
    return [v.name for v in read_model_description(fmu).modelVariables
            if v.causality == "output" or v.name.endswith("_mode")]


def incline_acceleration(theta: float, c_rr: float, direction: float) -> float:
    """Newton-Euler of an upright disk rolling straight on an incline, solved numerically.

    Unknowns: the centre's acceleration a downhill and the ground's friction force f (uphill on
    the wheel). M a = M g sin(th) - f; I_axial a / R = f R - c_rr R N direction (the resistance
    opposes the rolling direction, +1 downhill); N = M g cos(th).
    """
    N = M * G * math.cos(theta)
    A = np.array([[M, 1.0], [KA * M * R**2 / R, -R]])
    b = np.array([M * G * math.sin(theta), -c_rr * R * N * direction])
    return float(np.linalg.solve(A, b)[0])


# -- the model: sliding and stuck modes against the smoothed law and each other ------------------

def _spec_functions(law):
    spec = build_model(effects={"gravity": {}, "slope": {"slope_angle": 0.05},
                                "rolling_resistance": {"c_rr": C_RR, "law": law}, "contact_forces": {}})
    fns = spec.functions()
    p = np.array([q.start for q in spec.parameters])
    return spec, fns, p


def test_sliding_mode_is_the_coulomb_limit_of_the_smoothed_law():
    """Mode +1 at gamma_dot >> rr_omega_eps: the same accelerations as tanh (to 1e-12)."""
    spec, fns, p = _spec_functions("stiction")
    spec_s, fns_s, p_s = _spec_functions("smoothed")
    p_s[[q.name for q in spec_s.parameters].index("rr_omega_eps")] = 1e-9
    rng = np.random.default_rng(8)
    for _ in range(5):
        x = np.concatenate([rng.uniform(-1, 1, 3), [rng.uniform(1.2, 1.9)], rng.uniform(-1, 1, 3), [0]])
        x[7] = rng.uniform(0.5, 3.0) * rng.choice([-1, 1])
        mode = np.sign(x[7])
        xdot = np.array(fns["ode"](0, np.append(x, mode), [], p)).ravel()
        xdot_s = np.array(fns_s["ode"](0, x, [], p_s)).ravel()
        np.testing.assert_allclose(xdot[:8], xdot_s, rtol=1e-12, atol=1e-12)


def test_stuck_mode_holds_with_exactly_the_force_it_reports():
    """The holding torque H of mode 0, applied as a fixed Coulomb torque in a sliding mode
    (c_rr = |H| / (R F_n), direction -sign H), gives the same accelerations: gamma_ddot = 0."""
    spec, fns, p = _spec_functions("stiction")
    names = [q.name for q, _ in spec.outputs]
    rng = np.random.default_rng(6)
    for _ in range(5):
        # (x, y, alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot = 0, mode 0)
        x = np.concatenate([rng.uniform(-1, 1, 3), [rng.uniform(1.2, 1.9)], rng.uniform(-1, 1, 3), [0.0, 0.0]])
        xdot = np.array(fns["ode"](0, x, [], p)).ravel()
        assert xdot[7] == 0.0  # the stuck rate: exactly
        y = np.array(fns["out"](0, x, [], p)).ravel()
        H, F_n = y[names.index("rolling_resistance_torque")], y[names.index("F_n")]
        # the same wheel with the constant torque H replacing the law: c_rr such that c_rr R F_n = |H|
        p2 = p.copy()
        p2[[q.name for q in spec.parameters].index("c_rr")] = abs(H) / (R * F_n)
        xdot2 = np.array(fns["ode"](0, np.append(x[:8], -np.sign(H)), [], p2)).ravel()
        np.testing.assert_allclose(xdot2[:8], xdot[:8], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("mode", [0.0, 1.0, -1.0])
def test_formulations_agree_in_every_mode(mode):
    """Reduced (angle rates), reduced (body speeds) and multipliers: the same angle accelerations and
    the same update (both laws) at a state in each mode."""
    effects = {"gravity": {}, "slope": {"slope_angle": 0.05}, "rolling_resistance": {"c_rr": C_RR},
               "spin_friction": {"c_pivot": 0.01}}
    start = {"beta": 1.3, "alpha_dot": 0.4 if mode else 0.0, "beta_dot": -0.2, "gamma_dot": 0.0}
    results = []
    for kw in ({}, {"speeds": "body"}, {"formulation": "multipliers"}):
        spec = build_model(effects=effects, initial=start, **kw)
        fns = spec.functions()
        p = np.array([q.start for q in spec.parameters])
        x = np.array(fns["init"]([q.start for q in spec.starts], p)).ravel()
        x[-2] = mode  # rolling_mode (gamma_dot = 0: sliding into the mode's direction from rest)
        names = [q.name for q, _ in spec.outputs]

        def angles(xx):
            y = np.array(fns["out"](0, xx, [], p)).ravel()
            rates = [y[names.index(n)] for n in ("alpha_dot", "beta_dot", "gamma_dot")]
            h = 1e-6  # accelerations of the angle rates by a central difference of the exact flow
            yp = np.array(fns["out"](0, xx + h * np.array(fns["ode"](0, xx, [], p)).ravel(), [], p)).ravel()
            ym = np.array(fns["out"](0, xx - h * np.array(fns["ode"](0, xx, [], p)).ravel(), [], p)).ravel()
            acc = [(yp[names.index(n)] - ym[names.index(n)]) / (2 * h) for n in ("alpha_dot", "beta_dot", "gamma_dot")]
            return np.array(rates + acc + [y[names.index("rolling_resistance_torque")], y[names.index("pivot_torque")]])
        k = [e.name for e in spec.events].index("rolling_stiction")
        results.append((angles(x), angles(np.array(fns["upd"](0, x, [], p, k)).ravel())))
    for other in results[1:]:
        np.testing.assert_allclose(other[0], results[0][0], rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(other[1], results[0][1], rtol=1e-7, atol=1e-9)


def test_law_is_a_checked_scene_choice():
    with pytest.raises(SceneError, match="law: unknown choice 'sticky'; valid: stiction, smoothed"):
        parse_scene(WHEEL + '[effects.rolling_resistance]\nlaw = "sticky"\n', "bad.toml")
    # a smoothing parameter with the stiction law is refused, not silently ignored
    for effect, key in (("rolling_resistance", "rr_omega_eps"), ("spin_friction", "pivot_omega_eps")):
        with pytest.raises(SceneError, match=rf"\[effects.{effect}\] {key}: belongs to law = \"smoothed\""):
            parse_scene(WHEEL + f"[effects.{effect}]\n{key} = 0.1\n", "bad.toml")
        with pytest.raises(ValueError, match=key):
            build_model(effects={"gravity": {}, effect: {key: 0.1}})
        parse_scene(WHEEL + f'[effects.{effect}]\nlaw = "smoothed"\n{key} = 0.1\n', "good.toml")


# -- a wheel on a slope ------------------------------------------------------------------------

UPHILL_V0 = 0.4  # m/s: stops after 2.0 s on 0.5 deg, before the lean instability (below) matters


def upright(r, until: float) -> np.ndarray:
    """The samples before the lean instability matters: lean |beta - pi/2| < 1e-6 rad.

    A wheel started exactly upright (beta = fl(pi/2), cos(beta) = 6e-17) that does not spin fast
    is unstable: the lean grows as e^(lambda t) from that seed and tips it over sideways after
    about 4 s (test_wheel_on_a_gentle_slope_stands_still checks lambda against the analytic
    value). Up to a lean of 1e-6 the planar references (upright rolling on the incline) hold to
    O(lean^2) = 1e-12. Asserts these samples are the run's beginning and reach `until`.
    """
    mask = np.abs(r["beta"] - math.pi / 2) < 1e-6
    assert np.all(mask[:mask.sum()]) and r["time"][mask][-1] >= until
    return mask


def stuck_tip_over(theta: float) -> tuple[float, float]:
    """(lambda, |alpha| / lean): the lean instability of an upright wheel on an incline whose contact
    point is held (gamma_dot stuck at 0), linearised by hand (not by the model).

    A rigid body pivoting about the fixed contact point: lean phi about the heading (downhill)
    axis, heading alpha about the slope normal. T = 1/2 ((I_d + M R^2) phi_dot^2 + I_d alpha_dot^2),
    V = M g R (cos(th) cos(phi) + sin(th) sin(phi) sin(alpha)), so phi'' = a phi - b alpha,
    alpha'' = -c phi with a = g cos(th) / (R (1 + k_d)), b = g sin(th) / (R (1 + k_d)),
    c = g sin(th) / (k_d R): lambda^4 - a lambda^2 - b c = 0, and alpha = -c phi / lambda^2.
    """
    a = G * math.cos(theta) / (R * (1 + KD))
    bc = (G * math.sin(theta))**2 / (R**2 * (1 + KD) * KD)
    lam2 = (a + math.sqrt(a * a + 4 * bc)) / 2
    return math.sqrt(lam2), G * math.sin(theta) / (KD * R) / lam2


@pytest.mark.parametrize("theta", [math.radians(0.5), math.atan(0.999 * C_RR)], ids=["0.5deg", "just_below"])
def test_wheel_on_a_gentle_slope_stands_still(slope_fmu, theta):
    """tan(theta) < c_rr: held by the resistance, no creep at all; the contact point stays put
    even when the wheel's own lean instability tips it over sideways, at the analytic rate."""
    r, events = run(slope_fmu, 5.0, 0.05, slope_angle=theta, c_rr=C_RR, beta=math.pi / 2, gamma_dot=0.0)
    assert not events
    assert np.all(r["gamma_dot"] == 0.0) and np.all(r["rolling_mode"] == 0.0)
    contact = np.hypot(r["contact_x"] - r["contact_x"][0], r["contact_y"] - r["contact_y"][0])
    assert contact.max() < 1e-12  # no rolling, to the end (lean 0.013 rad at 5 s)
    stands = upright(r, 3.5)
    assert np.abs(r["x"][stands]).max() < 1e-12 and np.abs(r["vx"][stands]).max() < 1e-12  # no creep
    # the holding torque M g R sin(theta) exactly (it changes by O(lean^2) later: 1e-11 at 1e-6 rad)
    early = r["time"] <= 3.0
    np.testing.assert_allclose(r["rolling_resistance_torque"][early], -M * G * R * math.sin(theta), rtol=1e-12)
    E = r["energy"] + r["dissipated_energy"]
    assert np.ptp(E) < 1e-13 * E[0]
    # what ends the standing is the lean instability of a body pivoting about its held contact point
    lam, ratio = stuck_tip_over(theta)
    t = r["time"]
    i, j = np.searchsorted(t, 3.5), np.searchsorted(t, 4.5)  # lean 5e-7 .. 4e-4 rad: linear
    assert math.log(r["beta_dot"][j] / r["beta_dot"][i]) / (t[j] - t[i]) == pytest.approx(lam, rel=1e-7)
    assert abs(r["alpha"][j]) / abs(r["beta"][j] - math.pi / 2) == pytest.approx(ratio, rel=1e-5)


def test_smoothed_law_creeps_as_documented(build):
    """law = "smoothed" creeps, as docs/effects.md says: at R eps atanh(tan(theta) / c_rr)."""
    fmu = build("slope_smoothed", '[effects.slope]\n[effects.rolling_resistance]\nlaw = "smoothed"\n')
    theta, eps = math.radians(0.5), 0.01
    r = simulate_fmu(fmu, stop_time=2.0, output_interval=0.5,
                     start_values={**TIGHT, "slope_angle": theta, "c_rr": C_RR, "beta": math.pi / 2, "gamma_dot": 0.0})
    assert r["vx"][-1] == pytest.approx(R * eps * math.atanh(math.tan(theta) / C_RR), rel=1e-6)  # 7.95e-4 m/s


@pytest.mark.parametrize("ratio", [1.001, 2.0])
def test_above_the_limit_it_rolls_away_with_the_coulomb_acceleration(slope_fmu, ratio):
    """tan(theta) > c_rr: breaks away at the start and accelerates at Newton-Euler's a."""
    theta = math.atan(ratio * C_RR)
    r, events = run(slope_fmu, 3.5, 0.25, slope_angle=theta, c_rr=C_RR, beta=math.pi / 2, gamma_dot=0.0)
    a = incline_acceleration(theta, C_RR, +1.0)
    assert a == pytest.approx(G * (math.sin(theta) - C_RR * math.cos(theta)) / (1 + KA), rel=1e-12)
    assert events == [("rolling_stiction", 0.0)]  # breaks away at initialisation, before the first step
    assert np.all(r["rolling_mode"] == 1.0)
    upright(r, 3.5)
    np.testing.assert_allclose(r["vx"], a * r["time"], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(r["x"], 0.5 * a * r["time"]**2, rtol=1e-9, atol=1e-15)
    E = r["energy"] + r["dissipated_energy"]
    assert np.ptp(E) < 1e-12 * abs(E[0])


def test_rolling_uphill_stops_at_the_analytic_time_and_holds(slope_fmu):
    theta, v0 = math.radians(0.5), UPHILL_V0
    a_up = incline_acceleration(theta, C_RR, -1.0)  # > 0: decelerates the uphill motion (-x)
    t_stop = v0 / a_up
    r, events = run(slope_fmu, 3.5, 0.05, slope_angle=theta, c_rr=C_RR, beta=math.pi / 2, gamma_dot=-v0 / R)
    assert [name for name, _ in events] == ["rolling_stiction"]
    assert events[0][1] == pytest.approx(t_stop, abs=1e-9)
    after = r["time"] > t_stop
    assert np.all(r["gamma_dot"][after] == 0.0) and np.all(r["rolling_mode"][after] == 0.0)
    upright(r, 3.5)
    x_stop = -0.5 * v0 * t_stop
    assert r["x"][after][0] == pytest.approx(x_stop, abs=1e-12)
    assert np.ptp(r["x"][after]) < 1e-12  # no creep after the stop
    held = after & (r["time"] <= 3.0)  # the torque moves by O(lean^2) later (test above)
    np.testing.assert_allclose(r["rolling_resistance_torque"][held], -M * G * R * math.sin(theta), rtol=1e-12)
    E = r["energy"] + r["dissipated_energy"]
    assert np.ptp(E) < 1e-12 * abs(E[0])  # the stuck constraint does no work


def test_taylor_solver_stops_and_holds(build):
    """Solver taylor (its own dense output and event location, docs/taylor.md) with the update
    events of stiction: the same analytic stop, then held."""
    fmu = build("slope_taylor", '[effects.slope]\n[effects.rolling_resistance]\n[effects.energy]\n'
                '[experiment]\nsolver = "taylor"\n')
    theta, v0 = math.radians(0.5), UPHILL_V0
    t_stop = v0 / incline_acceleration(theta, C_RR, -1.0)
    r, events = run(fmu, 3.5, 0.05, slope_angle=theta, c_rr=C_RR, beta=math.pi / 2, gamma_dot=-v0 / R)
    assert [name for name, _ in events] == ["rolling_stiction"]
    assert events[0][1] == pytest.approx(t_stop, abs=1e-9)
    after = r["time"] > t_stop
    assert np.all(r["gamma_dot"][after] == 0.0) and np.all(r["rolling_mode"][after] == 0.0)
    assert np.ptp(r["x"][after & upright(r, 3.5)]) < 1e-12
    E = r["energy"] + r["dissipated_energy"]
    assert np.ptp(E) < 1e-12 * abs(E[0])


def test_rolling_uphill_on_a_steep_slope_turns_back(slope_fmu):
    theta, v0 = math.atan(2 * C_RR), UPHILL_V0
    t_stop = v0 / incline_acceleration(theta, C_RR, -1.0)
    a_down = incline_acceleration(theta, C_RR, +1.0)
    r, events = run(slope_fmu, 3.5, 0.05, slope_angle=theta, c_rr=C_RR, beta=math.pi / 2, gamma_dot=-v0 / R)
    assert [name for name, _ in events] == ["rolling_stiction"]
    assert events[0][1] == pytest.approx(t_stop, abs=1e-9)
    after = r["time"] > t_stop
    assert np.all(r["rolling_mode"][after] == 1.0)
    upright(r, 3.5)
    x_stop = -0.5 * v0 * t_stop
    np.testing.assert_allclose(r["x"][after], x_stop + 0.5 * a_down * (r["time"][after] - t_stop)**2, rtol=1e-9)
    E = r["energy"] + r["dissipated_energy"]
    assert np.ptp(E) < 1e-12 * abs(E[0])


def test_huge_rolling_resistance_brakes_at_once(slope_fmu):
    """c_rr = 1.001e6 (the fuzzer's stiff case of the smoothed law, tests/test_bounded_calls.py): with
    stiction it is a brake, not a stiff term. The rim stops at v0 / a_up (57 ns) and holds; a 1e-4 s
    step takes a few internal steps (a budget of 100 suffices)."""
    theta, c_rr, v0 = math.radians(0.5), 1.001e6, UPHILL_V0
    t_stop = v0 / incline_acceleration(theta, c_rr, -1.0)
    r, events = run(slope_fmu, 1e-4, 1e-4, slope_angle=theta, c_rr=c_rr, beta=math.pi / 2, gamma_dot=-v0 / R,
                    max_internal_steps=100)
    assert [name for name, _ in events] == ["rolling_stiction"]
    assert events[0][1] == pytest.approx(t_stop, rel=1e-9)
    assert r["gamma_dot"][-1] == 0.0 and r["rolling_mode"][-1] == 0.0
    assert r["x"][-1] == pytest.approx(-0.5 * v0 * t_stop, rel=1e-9)
    E = r["energy"] + r["dissipated_energy"]
    assert np.ptp(E) < 1e-12 * abs(E[0])


# -- pivot friction ------------------------------------------------------------------------------

def test_pivoting_wheel_stops_and_stays_stopped(build):
    """Upright, pivoting at 3 rad/s: I_diam alpha_ddot = -c_pivot M g stops it at
    t = 3 k_diam R^2 / (c_pivot g); then the pivot rate w_k stays 0 with a holding torque in the
    limit, also while the lean instability tips the wheel (alpha_dot = -gamma_dot cos(beta) then)."""
    fmu = build("pivot", "[effects.spin_friction]\nc_pivot = 0.002\n[effects.contact_forces]\n[effects.energy]\n")
    t_stop = 3.0 * KD * R**2 / (0.002 * G)
    r, events = run(fmu, 4.0, 0.01, beta=math.pi / 2, alpha_dot=3.0, gamma_dot=0.0)
    assert [name for name, _ in events] == ["pivot_stiction"]
    assert events[0][1] == pytest.approx(t_stop, abs=1e-9)
    after = r["time"] > t_stop
    w_k = r["alpha_dot"] + r["gamma_dot"] * np.cos(r["beta"])
    assert np.all(r["pivot_mode"][after] == 0.0) and np.abs(w_k[after]).max() < 1e-25
    assert np.ptp(r["alpha"][after & upright(r, 3.0)]) < 1e-15  # the heading stays put
    assert np.all(np.abs(r["pivot_torque"][after]) <= 0.002 * r["F_n"][after])
    E = r["energy"] + r["dissipated_energy"]
    assert np.ptp(E) < 1e-12 * abs(E[0])


# -- entering and leaving ------------------------------------------------------------------------

def test_gyrover_drive_sticks_and_slips_like_the_planar_reference():
    """From rest, a constant drive torque swings the pendulum; the holding torque needed rises
    above c_rr R F_n (break away), the wheel rolls, stops where the torque is within the limit
    (stick), again and again: the model's 11 switches in 3 s against an independent planar sympy
    derivation (tests/reference/planar_gyrover.py), both integrated by scipy with its own event
    location (studies/scipy_reference.py); the FMU's runtime agrees with them to 3e-10 s (measured,
    docs/effects.md; its location is tested below on a cheaper scene, a Gyrover FMU takes 20 s to
    compile)."""
    tau = 0.03
    spec = build_model(effects={"gravity": {}, "gyrover": {}, "rolling_resistance": {"c_rr": C_RR}, "energy": {}},
                       initial={"beta": math.pi / 2, "gamma_dot": 0.0})
    fns = spec.functions()
    p = np.array([q.start for q in spec.parameters])
    u = np.array([tau if q.name == "drive_torque" else 0.0 for q in spec.inputs])
    x0 = np.array(fns["init"]([q.start for q in spec.starts], p)).ravel()
    ref_events, sample = Planar(tau, C_RR).simulate(3.0)
    assert len(ref_events) == 11 and [m for _, m in ref_events[:2]] == [-1, 0]
    names = [q.name for q, _ in spec.outputs]
    out = lambda t, x: dict(zip(names, np.array(fns["out"](t, x, u, p)).ravel()))  # noqa: E731
    _, x_end, switches = solve_hybrid(spec, x0, p, 3.0, u=u, rtol=1e-11, atol=1e-13)
    assert [name for _, name in switches] == ["rolling_stiction"] * len(ref_events)
    np.testing.assert_allclose([t for t, _ in switches], [t for t, _ in ref_events], atol=1e-9)
    for t_end in (2.0, 3.0):  # sliding at 2.0 s (mode -1), stuck at 3.0 s
        x = x_end if t_end == 3.0 else solve_hybrid(spec, x0, p, t_end, u=u, rtol=1e-11, atol=1e-13)[1]
        gd, th, thd = sample(t_end)[0]
        y = out(t_end, x)
        assert y["gamma_dot"] == pytest.approx(gd, abs=1e-8) and y["theta_p"] == pytest.approx(th, abs=1e-8)
        assert y["theta_p_dot"] == pytest.approx(thd, abs=1e-7)
    y, y0 = out(3.0, x_end), out(0.0, x0)
    balance = lambda yy: yy["energy"] + yy["dissipated_energy"] - yy["actuator_work"]  # noqa: E731
    assert balance(y) == pytest.approx(balance(y0), abs=1e-9 * abs(balance(y0)))


def test_leaning_wheel_breaks_away_where_scipy_does(slope_fmu):
    """A wheel at rest on 0.5 deg, leaning 10 deg, held by the resistance, falls sideways about its
    contact point; the normal force drops, so the limit c_rr R F_n does, until the holding torque
    exceeds it (break away, 0.367 s) and the wheel lifts off (0.371 s). Both located by the runtime
    within 1e-9 s of scipy's DOP853 with its own event location on the same model."""
    start = dict(slope_angle=math.radians(0.5), c_rr=C_RR, beta=math.radians(80.0), gamma_dot=0.0)
    logs: list[str] = []
    r, events = run(slope_fmu, 1.0, 0.01, logs=logs, **start)
    t_lift, _, switches = to_lift_off({"gravity": {}, "slope": {}, "rolling_resistance": {}, "energy": {}},  # slope_fmu's
                                      start, 1.0)
    assert [name for name, _ in events] == ["rolling_stiction", "lift_off"]
    assert [name for _, name in switches] == ["rolling_stiction"]
    assert events[0][1] == pytest.approx(switches[0][0], abs=1e-9) and 0.3 < events[0][1] < 0.4
    assert events[1][1] == pytest.approx(t_lift, abs=1e-9)
    # the reason fmi2DoStep gives names the terminating event, not the earlier mode switch
    # (an update event's flag means "switched at least once", not "ended the run")
    assert [m for m in logs if "terminated inside the step" in m][0].startswith("fmi2DoStep: lift_off at t=")
    held = r["time"] < events[0][1]
    assert np.all(r["gamma_dot"][held] == 0.0) and np.all(r["rolling_mode"][held] == 0.0)
    # free, it rolls the way the holding torque had to prevent: the fall's coupling (the wheel
    # pivots as it falls) reverses that torque before the break away, so it rolls uphill
    mode_after, torque_before = r["rolling_mode"][~held][0], r["rolling_resistance_torque"][held][-1]
    assert mode_after == -np.sign(torque_before) == -1.0 and np.all(r["rolling_mode"][~held] == mode_after)
    E = r["energy"] + r["dissipated_energy"]
    assert np.ptp(E) < 1e-10 * abs(E[0])  # 4e-12 measured: the fast fall integrated at rel_tol 1e-10


# -- Model Exchange and saved states ---------------------------------------------------------------

def test_model_exchange_switches_in_new_discrete_states(slope_fmu):
    """fmpy's ME path with its own event location (CVode): the stop located, then held."""
    theta, v0 = math.radians(0.5), UPHILL_V0
    t_stop = v0 / incline_acceleration(theta, C_RR, -1.0)
    r, events = run(slope_fmu, 3.5, 0.05, "ModelExchange", slope_angle=theta, c_rr=C_RR, beta=math.pi / 2,
                    gamma_dot=-v0 / R)
    assert [name for name, _ in events] == ["rolling_stiction"]
    assert events[0][1] == pytest.approx(t_stop, abs=1e-6)
    after = r["time"] > events[0][1]
    assert np.all(r["gamma_dot"][after] == 0.0) and np.all(r["rolling_mode"][after] == 0.0)
    assert np.ptp(r["x"][after & upright(r, 3.0)]) < 1e-12


def test_model_exchange_reports_changed_states(slope_fmu):
    """FMI 2.0: fmi2NewDiscreteStates returns valuesOfContinuousStatesChanged at a switch (and
    not again in the same instant); the importer reads the new states."""
    md = read_model_description(slope_fmu)
    fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(slope_fmu), modelIdentifier=md.modelExchange.modelIdentifier,
                    instanceName="me")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    nx, nz = md.numberOfContinuousStates, md.numberOfEventIndicators
    names = [d.variable.derivative.name for d in md.derivatives]  # the states, in order
    assert nz == 3 and "rolling_mode" in names
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    for k, v in dict(slope_angle=math.radians(0.5), c_rr=C_RR, beta=math.pi / 2, gamma_dot=-5.0).items():
        fmu.setReal([vr[k]], [v])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    assert not fmu.newDiscreteStates()[3]  # nothing settled: it starts rolling (mode -1)
    fmu.enterContinuousTimeMode()
    x = np.zeros(nx)
    ptr = x.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
    fmu.getContinuousStates(ptr, nx)
    i_gd, i_mode = names.index("gamma_dot"), names.index("rolling_mode")
    assert x[i_mode] == -1.0
    fmu.setTime(4.0)
    x[i_gd] = 1e-14  # the importer's located point: just past the stop (gamma_dot was < 0)
    fmu.setContinuousStates(ptr, nx)
    z = np.zeros(nz)
    fmu.getEventIndicators(z.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), nz)
    fmu.enterEventMode()
    changed = fmu.newDiscreteStates()[3]
    assert changed
    fmu.getContinuousStates(ptr, nx)
    assert x[i_gd] == 0.0 and x[i_mode] == 0.0
    assert not fmu.newDiscreteStates()[3]
    fmu.enterContinuousTimeMode()
    fmu.terminate()
    fmu.freeInstance()


def test_fmu_state_restored_across_a_switch(slope_fmu):
    theta, v0 = math.radians(0.5), 0.85
    s = Slave(slope_fmu)
    s.init(slope_angle=theta, c_rr=C_RR, beta=math.pi / 2, gamma_dot=-v0 / R, **TIGHT)
    t = 0.0
    for _ in range(30):  # to t = 3 s, rolling uphill (the stop is at 4.22 s)
        s.slave.doStep(t, 0.1)
        t += 0.1
    state = s.slave.getFMUstate()
    blob = s.slave.serializeFMUstate(state)

    def finish():
        tt = t
        for _ in range(20):
            s.slave.doStep(tt, 0.1)
            tt += 0.1
        return s.get("x", "gamma_dot", "rolling_mode", "energy")
    first = finish()
    assert first[1:3] == [0.0, 0.0]
    s.slave.setFMUstate(state)
    assert s.get("rolling_mode") == -1.0
    assert finish() == first
    s.slave.setFMUstate(s.slave.deSerializeFMUstate(blob))
    assert finish() == first
    s.slave.freeFMUstate(state)
    s.free()
