"""Flight, lift-off and touchdown with an impact (docs/effects.md, "Flight").

Against results the code did not produce: the free wheel's parabola and torque-free precession
(Goldstein, Classical Mechanics, sec. 5.6), the upright drop's apex heights e^(2k) h and its rest
at the truncated geometric series' time, the energy balance through impacts with the friction
cone, a lift-off with continuous velocities, and the soft-contact reference's drop.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from gyrowheel.fmu_build import build_fmu, parse_scene
from fmi_helpers import Slave, replayed, simulate_logged
from gyrowheel.fmu_build.scene import SceneError
from paper_wheel import G, KA, KD, M, R
from paper_wheel import PAPER_WHEEL_TOML as WHEEL

TIGHT = {"rel_tol": 1e-12, "abs_tol": 1e-14}
OUT = ["x", "y", "z", "vx", "vy", "vz", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot", "height",
       "contact_mode", "energy", "dissipated_energy", "impact_impulse", "F_n"]
V_REST = 1e-3 * math.sqrt(G * R)  # model/contact_flight.py V_REST sqrt(g R)


@pytest.fixture(scope="module")
def fmu(example_build):
    """examples/scenes/drop_bounce.toml's FMU: the run's one build of it (conftest example_build)."""
    return str(example_build("drop_bounce").fmu)


def run(fmu, stop, dt=0.001, **start):
    """simulate_fmu (Co-Simulation) with the FMU's event messages: (result, [(event name, t)])."""
    return simulate_logged(fmu, stop, dt, OUT, {**TIGHT, **start})


def axle(a, b):
    """n, the axle, ground frame (docs/model.md)."""
    return np.stack([-np.sin(a) * np.sin(b), np.cos(a) * np.sin(b), np.cos(b)], axis=-1)


def angular_momentum(r):
    """L about the centre (N m s, ground frame): w = alpha_dot k + beta_dot m + gamma_dot n with
    m = -(cos a, sin a, 0); L = I_d w + (I_a - I_d) (w . n) n."""
    a, b = r["alpha"], r["beta"]
    n = axle(a, b)
    m = np.stack([-np.cos(a), -np.sin(a), np.zeros_like(a)], axis=-1)
    w = r["alpha_dot"][:, None] * np.array([0, 0, 1.0]) + r["beta_dot"][:, None] * m + r["gamma_dot"][:, None] * n
    I_d, I_a = KD * M * R ** 2, KA * M * R ** 2
    return I_d * w + (I_a - I_d) * np.sum(w * n, axis=1)[:, None] * n


def test_thrown_wheel_flies_a_parabola_and_precesses_torque_free(fmu):
    """A spinning, leaning wheel thrown up: the centre on its parabola, L about the centre constant,
    the axle turning about L at |L| / I_diam on a fixed cone (Goldstein sec. 5.6)."""
    h0, vz0 = 0.5, 1.0
    r, events = run(fmu, 0.3, height=h0, vz=vz0, beta=1.2, gamma_dot=30.0, alpha_dot=2.0, beta_dot=1.0)
    assert events == []
    assert np.all(r["contact_mode"] == 2) and np.all(r["F_n"] == 0)
    t = r["time"]
    z0 = R * math.sin(1.2) + h0
    assert np.max(np.abs(r["z"] - (z0 + vz0 * t - G * t ** 2 / 2))) < 1e-9
    assert np.max(np.abs(r["vz"] - (vz0 - G * t))) < 1e-9
    for c, v in (("x", "vx"), ("y", "vy")):
        assert np.max(np.abs(r[c] - (r[c][0] + r[v][0] * t))) < 1e-9
    L = angular_momentum(r)
    size = np.linalg.norm(L[0])
    assert np.max(np.abs(L - L[0])) < 1e-9 * size
    k = L[0] / size
    rate = size / (KD * M * R ** 2)
    n = axle(r["alpha"], r["beta"])
    n0 = n[0]
    # Rodrigues: n0 turned about k by rate t
    c, s = np.cos(rate * t)[:, None], np.sin(rate * t)[:, None]
    expected = n0 * c + np.cross(k, n0) * s + k * np.dot(k, n0) * (1 - c)
    assert np.max(np.abs(n - expected)) < 1e-9


def drop_series(h, e):
    """The rigid bounce series: (N bounces before the rest, rest time, the infinite series' time,
    its truncation). Impact speeds e^k v0 (v0 = sqrt(2 g h)); the k-th impact bounces while its
    rebound e^(k+1) v0 > V_REST; the rest is the last impact, t0 + sum_{k=1..N} 2 e^k v0 / g."""
    v0 = math.sqrt(2 * G * h)
    n = 0
    while e ** (n + 1) * v0 > V_REST:
        n += 1
    t0 = v0 / G
    rest = t0 + sum(2 * e ** k * v0 / G for k in range(1, n + 1))
    return n, rest, t0 * (1 + 2 * e / (1 - e)), 2 * v0 * e ** (n + 1) / (G * (1 - e))


@pytest.mark.parametrize("h, e", [(0.1, 0.5), (0.05, 0.8)])
def test_upright_drop_bounces_to_rest_at_the_series_time(fmu, h, e):
    """Apex heights e^(2k) h after the k-th impact (the lowest rim point's, from any flight sample:
    h + vz^2 / (2 g)); the rest at the truncated series' time, then the wheel stands (rolling)."""
    n, rest, infinite, truncation = drop_series(h, e)
    r, events = run(fmu, rest + 0.1, height=h, restitution=e)
    times = [t for name, t in events if name == "contact_flight"]
    assert len(times) == n + 1
    assert times[-1] == pytest.approx(rest, abs=1e-9)
    assert infinite - times[-1] == pytest.approx(truncation, abs=1e-9)
    t = r["time"]
    for k in range(1, n):
        inside = (t > times[k - 1] + 1e-6) & (t < times[k] - 1e-6)
        if not inside.any():
            continue
        apex = r["height"][inside] + r["vz"][inside] ** 2 / (2 * G)
        assert np.max(np.abs(apex - e ** (2 * k) * h)) < 1e-9
    after = t > rest + 1e-6
    assert np.all(r["contact_mode"][after] == 0)
    assert np.max(np.abs(r["F_n"][after] - M * G)) < 1e-9
    balance = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(balance - balance[0])) < 1e-10 * M * G * R


@pytest.mark.parametrize("solver", ["dop853", "rosenbrock"])
def test_other_solvers_bounce_the_drop_to_rest_at_the_series_time(fmu, solver):
    n, rest, _, _ = drop_series(0.1, 0.5)
    r, events = run(fmu, rest + 0.05, height=0.1, restitution=0.5, solver={"dop853": 5, "rosenbrock": 4}[solver])
    times = [t for name, t in events if name == "contact_flight"]
    assert len(times) == n + 1
    assert times[-1] == pytest.approx(rest, abs=1e-9)
    assert r["contact_mode"][-1] == 0


def test_model_exchange_bounces_the_drop_to_rest(fmu):
    """Model Exchange: fmpy's CVode locates each touchdown, fmi2NewDiscreteStates applies the impact."""
    n, rest, _, _ = drop_series(0.1, 0.5)
    me = simulate_fmu(fmu, stop_time=rest + 0.05, output_interval=1e-3, fmi_type="ModelExchange", record_events=True,
                      solver="CVode", relative_tolerance=1e-10, output=OUT,
                      start_values={**TIGHT, "height": 0.1, "restitution": 0.5})
    t, mode, vz = me["time"], me["contact_mode"], me["vz"]
    jumps = [k for k in range(len(t) - 1) if t[k] == t[k + 1] and vz[k + 1] != vz[k]]
    assert len(jumps) == n + 1
    assert t[jumps[-1]] == pytest.approx(rest, abs=1e-6)
    assert mode[-1] == 0


def test_fmu_state_keeps_the_flight(fmu):
    """An FMU state saved in flight between bounces and restored reproduces the run, the later
    impacts and the rest included."""
    s = Slave(fmu, logging_on=False)
    s.init(**TIGHT, height=0.1, restitution=0.5)
    s.slave.doStep(0.0, 0.2)
    assert s.get("contact_mode") == 2.0
    first, second = replayed(s, 0.2, 0.03, 10, ("contact_mode", "vz", "height", "impact_impulse",
                                                 "dissipated_energy"))
    assert first[-1][0] == 0.0
    assert second == first
    s.free()


def test_leaning_spinning_drop_never_gains_energy_and_stays_in_the_cone(fmu):
    """Between impacts energy + dissipated is constant; at each impact dissipated_energy does not
    fall (no energy created); a bouncing impact's impulse, from the centre's velocity change between
    the flights around it (M dv = P + M g dt; the horizontal velocity is constant in flight), lies in
    the friction cone |P_t| <= mu P_n and matches impact_impulse."""
    mu = 0.3
    r, events = run(fmu, 0.4, dt=2e-4, height=0.05, beta=1.1, gamma_dot=15.0, alpha_dot=1.0, slip_long=0.3,
                    restitution=0.5)
    touch = [t for name, t in events if name == "contact_flight"]
    assert len(touch) >= 2
    balance = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(balance - balance[0])) < 1e-10 * M * G * R
    assert np.all(np.diff(r["dissipated_energy"]) >= -1e-12)
    t, mode = r["time"], r["contact_mode"]
    checked = 0
    bounds = [0.0] + touch + [t[-1] + 1]
    for k in range(len(touch)):
        before = (t > bounds[k] + 1e-6) & (t < touch[k] - 1e-6) & (mode == 2)
        after = (t > touch[k] + 1e-6) & (t < bounds[k + 2] - 1e-6) & (mode == 2)
        if not (before.any() and after.any()):
            continue
        i, j = np.nonzero(before)[0][-1], np.nonzero(after)[0][0]
        if np.any(mode[i:j + 1] != 2):
            continue  # not a bounce straight back into flight
        P = M * np.array([r["vx"][j] - r["vx"][i], r["vy"][j] - r["vy"][i],
                          r["vz"][j] - r["vz"][i] + G * (t[j] - t[i])])
        assert P[2] > 0
        assert P[2] == pytest.approx(r["impact_impulse"][j], rel=1e-9)
        assert math.hypot(P[0], P[1]) <= mu * P[2] * (1 + 1e-9)
        checked += 1
    assert checked >= 1


def test_lift_off_from_sliding_with_continuous_velocities(fmu):
    """A leaning wheel spinning at 20 rad/s thrown up in lean (beta_dot = 6 rad/s): the normal force
    falls, friction runs out first (sliding: rolling needs |F_t| > 0 as F_n -> 0), F_n reaches 0 and
    the wheel flies. Co-Simulation locates both switches; Model Exchange (fmpy's CVode, the values
    before and after each event recorded) shows the velocities continuous at the lift-off."""
    r, events = run(fmu, 0.02, dt=1e-5, height=0.0, beta=1.0, beta_dot=6.0, gamma_dot=20.0)
    assert [name for name, _ in events] == ["contact_slip", "contact_flight"]
    t_lift = events[1][1]
    t = r["time"]
    fly = t > t_lift
    assert np.all(r["contact_mode"][fly] == 2) and np.all(r["F_n"][fly] == 0)
    tf = t[fly]
    assert np.max(np.abs(r["vz"][fly] - (r["vz"][fly][0] - G * (tf - tf[0])))) < 1e-9  # free fall
    me = simulate_fmu(fmu, stop_time=0.02, output_interval=1e-3, fmi_type="ModelExchange", record_events=True,
                      solver="CVode", relative_tolerance=1e-10, output=OUT,
                      start_values={**TIGHT, "height": 0.0, "beta": 1.0, "beta_dot": 6.0,
                                    "gamma_dot": 20.0})
    tm, mode = me["time"], me["contact_mode"]
    i = next(k for k in range(len(tm) - 1) if tm[k] == tm[k + 1] and mode[k] == 1 and mode[k + 1] == 2)
    assert tm[i] == pytest.approx(t_lift, abs=1e-6)
    assert abs(me["F_n"][i]) < 1e-6 * M * G and me["F_n"][i + 1] == 0
    for name in ("vx", "vy", "vz", "alpha_dot", "beta_dot", "gamma_dot"):
        assert abs(me[name][i + 1] - me[name][i]) <= 1e-12 * max(1.0, abs(me[name][i])), name
    assert me["height"][i + 1] == 0


def test_upright_drop_agrees_with_the_soft_contact_reference(fmu):
    """The reference's first apex extrapolated in its stiffness (kappa 1e5, 1e6) agrees with the
    hybrid's e^2 h within the extrapolation's own convergence (docs/contact_reference.md: 1.3e-4
    relative at these stiffnesses), and the raw reference approaches it as kappa grows."""
    from reference.soft_contact_scenarios import drop, extrapolate
    h, e = 0.2, 0.5
    coarse, fine = drop(h, e, stiffness=1e5), drop(h, e, stiffness=1e6)
    n, rest, _, _ = drop_series(h, e)
    r, events = run(fmu, 0.7, height=h, restitution=e)
    t = r["time"]
    touch = [tt for name, tt in events if name == "contact_flight"]
    inside = (t > touch[0] + 1e-6) & (t < touch[1] - 1e-6)
    apex = float(np.mean(r["height"][inside] + r["vz"][inside] ** 2 / (2 * G)))
    assert abs(apex / (e ** 2 * h) - 1) < 1e-9
    assert abs(extrapolate(coarse["apex"][0], fine["apex"][0]) / apex - 1) < 3e-4
    assert abs(fine["apex"][0] - apex) < abs(coarse["apex"][0] - apex) / 2.5
    assert abs(touch[0] - fine["touchdowns"][0]) < 1e-3


LOADS = """
[effects.rolling_resistance]
c_rr = 0.02
[effects.spin_friction]
c_pivot = 0.001
[effects.contact_forces]
on_slip = "slide"
on_lift_off = "fly"
mu = 0.3
[effects.energy]
"""


@pytest.fixture(scope="module")
def loaded(tmp_path_factory):
    root = tmp_path_factory.mktemp("flight_loads")
    scene = parse_scene('[model]\nname = "flight_loads"\n' + WHEEL + LOADS, "flight_loads.toml")
    return str(build_fmu(scene, root / "flight_loads.fmu", build_dir=root / "build").fmu)


@pytest.mark.parametrize("start", [
    dict(height=0.05, beta=1.1, gamma_dot=15.0, alpha_dot=1.0, slip_long=0.3, restitution=0.5),
    dict(beta=1.0, beta_dot=6.0, gamma_dot=20.0),
    dict(height=0.1, beta=math.pi / 2, gamma_dot=0.0, restitution=0.5)], ids=["leaning_drop", "lift_off", "drop"])
def test_load_proportional_laws_vanish_in_flight(loaded, start):
    """rolling_resistance and spin_friction (stiction) act through F_n: in flight F_n = 0, so they do
    nothing (dissipated_energy constant there); the balance holds through every switch, and an
    upright drop lands at rest with both laws stuck."""
    r, events = simulate_logged(loaded, 0.6, 1e-3, OUT, {**TIGHT, **start})
    assert any(name == "contact_flight" for name, _ in events)
    balance = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(balance - balance[0])) < 1e-10 * M * G * R
    fly = r["contact_mode"] == 2
    t = r["time"]
    hit = np.zeros(len(t) - 1, bool)  # an event (an impact's loss) between two samples
    for _, te in events:
        hit |= (t[:-1] < te) & (te <= t[1:])
    runs = np.nonzero(fly[1:] & fly[:-1] & ~hit)[0]
    assert len(runs) > 10
    assert np.all(r["F_n"][fly] == 0)
    assert np.all(r["dissipated_energy"][runs + 1] == r["dissipated_energy"][runs])
    if "height" in start and start["beta"] == math.pi / 2:
        assert r["contact_mode"][-1] == 0 and r["gamma_dot"][-1] == 0


@pytest.mark.parametrize("text, message", [
    ('[effects.contact_forces]\non_lift_off = "fly"\n', 'on_lift_off: "fly" needs on_slip = "slide"'),
    ('[effects.contact_forces]\non_slip = "slide"\nrestitution = 0.5\n', "restitution: is the touchdown's"),
    ('[effects.contact_forces]\non_slip = "slide"\non_lift_off = "fly"\nrestitution = 1.5\n',
     "restitution: must be <= 1"),
    ('[effects.contact_forces]\non_slip = "slide"\n[initial]\nheight = 0.1\n', "height: is a start value of the flight"),
])
def test_scene_refuses_what_flight_cannot_honour(text, message):
    with pytest.raises(SceneError, match=re.escape(message)):
        parse_scene(WHEEL + text, "s.toml")


def test_fmu_refuses_a_restitution_above_one_and_vz_on_the_ground(fmu):
    from fmi_helpers import Slave, replayed, simulate_logged
    for start, text in (({"restitution": 1.5}, "restitution must be <= 1"),
                        ({"height": 0.0, "vz": 1.0}, "vz must be 0 unless height > 0")):
        s = Slave(fmu)
        with pytest.raises(Exception):
            s.init(**start)
        assert text in s.log_text()


def test_flight_adds_its_variables(fmu):
    variables = {v.name for v in read_model_description(fmu).modelVariables}
    for name in ("restitution", "height", "vz", "impact_impulse", "contact_flown", "z_centre", "z_dot",
                 "last_impulse", "contact_mode"):
        assert name in variables, name
    assert "lifted_off" not in variables


# GUIDs of example scenes' FMUs that do not ask for flight (the GUID hashes the generated C, the
# variable table, the experiment and the name): flight adds nothing to them. Change these only with
# a change meant for those scenes (ice_slide: the rolling and sliding modes, model/contact_modes.py,
# and the Painleve stop, model/painleve.py).
GROUND_GUIDS = {"paper_earth": "{507a1f5e-dce8-52db-bf2e-79fbb8822f46}",  # rolling, base wheel
                "ice_slide": "{25b2006a-62ab-591f-bea5-f6b61091b02d}"}  # rolling and sliding


@pytest.mark.parametrize("name", sorted(GROUND_GUIDS))
def test_scenes_without_flight_generate_what_they_did(name, example_build):
    fmu = example_build(name).fmu  # build_fmu(load_scene(<scene>)): the run's one build of the scene
    assert read_model_description(str(fmu)).guid == GROUND_GUIDS[name]
