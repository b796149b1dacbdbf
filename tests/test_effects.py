"""Effects against independent expectations: dissipation laws, slope, contact forces, Gyrover."""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from conftest import PAPER, SCENES, steady_precession
from fmi_helpers import Slave
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.studies.analysis import fit_circle
from paper_wheel import G, KA, KD, M, R
from paper_wheel import PAPER_WHEEL_TOML as BASE



@pytest.fixture(scope="module")
def build(tmp_path_factory):
    """Build (and cache) an FMU from scene text."""
    root = tmp_path_factory.mktemp("effects")
    cache: dict[str, str] = {}

    def _build(text: str, name: str) -> str:
        if text not in cache:
            scene = parse_scene(f'[model]\nname = "{name}"\n' + text, f"{name}.toml")
            cache[text] = str(build_fmu(scene, root / f"{name}.fmu", build_dir=root / f"{name}_build").fmu)
        return cache[text]
    return _build


@pytest.fixture(scope="module")
def euler_fmu(example_build):
    return str(example_build("euler_disk").fmu)


def _run(fmu, stop, dt, **start):
    return simulate_fmu(fmu, stop_time=stop, output_interval=dt,
                        start_values={"rel_tol": 1e-10, "abs_tol": 1e-12, **start})


# -- dissipation ------------------------------------------------------------------

def test_rolling_resistance_decelerates_at_c_rr_g_over_1_plus_k_axial(build):
    """Straight upright rolling: Q_gamma = -c_rr R M g gives v_dot = -c_rr g / (1 + k_axial)."""
    fmu = build(BASE + "[effects.rolling_resistance]\nc_rr = 0.02\n", "rr")
    r = _run(fmu, 1.0, 0.1, beta=math.pi / 2, gamma_dot=10.0)
    a = np.polyfit(r["time"], r["vx"], 1)[0]
    assert a == pytest.approx(-0.02 * G / (1 + KA), rel=1e-6)


def test_air_drag_law(build):
    """Drag on the centre: M (1 + k_axial) v_dot = -(c_lin v + rho cd_area v^2 / 2) at t = 0."""
    fmu = build(BASE + "[effects.air_drag]\nc_lin = 0.3\ncd_area = 0.05\ncm_spin = 0.0\n", "drag")
    v0, dt = 3.0, 1e-4
    r = _run(fmu, dt, dt, beta=math.pi / 2, gamma_dot=v0 / R)
    a = (r["vx"][-1] - r["vx"][0]) / dt
    expected = -(0.3 * v0 + 0.5 * 1.225 * 0.05 * v0**2) / (M * (1 + KA))
    assert a == pytest.approx(expected, rel=1e-3)


def test_spin_friction_decelerates_a_pivoting_wheel(build):
    """Upright, pivoting about the vertical (no rolling): I_diam alpha_ddot = -c_pivot M g."""
    fmu = build(BASE + "[effects.spin_friction]\nc_pivot = 0.002\n", "pivot")
    dt = 1e-3
    r = _run(fmu, dt, dt, beta=math.pi / 2, alpha_dot=3.0, gamma_dot=0.0)
    a = (r["alpha_dot"][-1] - r["alpha_dot"][0]) / dt
    assert a == pytest.approx(-0.002 * M * G / (KD * M * R**2), rel=1e-3)


@pytest.mark.parametrize("scene", ["euler_disk", "drag_and_resistance"])
def test_energy_lost_equals_work_of_dissipative_forces(build, euler_fmu, scene):
    """E(0) - E(t) = integral of dissipated_power dt (trapezoid over the outputs) and = dissipated_energy."""
    if scene == "euler_disk":
        r = simulate_fmu(euler_fmu, stop_time=5.0, output_interval=1e-3)
    else:
        fmu = build(BASE + "[effects.rolling_resistance]\n[effects.air_drag]\n[effects.spin_friction]\n"
                    "[effects.energy]\n", "dissipative")
        r = _run(fmu, 5.0, 1e-3, gamma_dot=12.0)
    lost = r["energy"][0] - r["energy"]
    work = np.concatenate([[0.0], np.cumsum(np.diff(r["time"]) * 0.5 * (r["dissipated_power"][1:] +
                                                                         r["dissipated_power"][:-1]))])
    assert lost[-1] > 0.01 * r["energy"][0]  # a real loss
    np.testing.assert_allclose(work, lost, atol=2e-4 * abs(r["energy"][0]))
    np.testing.assert_allclose(r["dissipated_energy"], lost, atol=1e-6 * abs(r["energy"][0]))
    assert np.all(r["dissipated_power"] >= -1e-12)


def test_dissipation_ends_in_a_clean_fall(euler_fmu):
    """Euler's disk: dissipation drives it flat; the FMU stops at the located fall."""
    r = simulate_fmu(euler_fmu, stop_time=60.0, output_interval=1e-2)
    assert r["fallen"][-1] and r["time"][-1] < 60.0
    assert math.sin(r["beta"][-1]) == pytest.approx(math.sin(0.05), abs=1e-9)
    assert np.all(np.isfinite(r["alpha_dot"]))
    assert abs(r["alpha_dot"][-1]) > 2 * abs(r["alpha_dot"][0])  # the precession speeds up as it falls


# -- slope ------------------------------------------------------------------------

@pytest.mark.parametrize("direction_deg", [0.0, 90.0])
def test_slope_accelerates_at_g_sin_over_1_plus_k_axial(build, direction_deg):
    th = math.radians(5.0)
    fmu = build(BASE + f"[effects.slope]\nslope_angle = {th!r}\nslope_direction = {math.radians(direction_deg)!r}\n",
                f"slope{int(direction_deg)}")
    r = _run(fmu, 1.0, 0.1, beta=math.pi / 2, alpha=math.radians(direction_deg), gamma_dot=2.0)
    v = np.hypot(r["vx"], r["vy"])
    a = np.polyfit(r["time"], v, 1)[0]
    assert a == pytest.approx(G * math.sin(th) / (1 + KA), rel=1e-8)
    heading = math.radians(direction_deg)
    assert r["vx"][-1] * math.cos(heading) + r["vy"][-1] * math.sin(heading) == pytest.approx(v[-1], rel=1e-9)


# -- contact forces ----------------------------------------------------------------

def test_contact_force_upright_rolling(build):
    fmu = build(BASE + "[effects.contact_forces]\n", "contact")
    r = _run(fmu, 1.0, 0.1, beta=math.pi / 2, gamma_dot=8.0)
    np.testing.assert_allclose(r["F_n"], M * G, rtol=1e-12)
    np.testing.assert_allclose(r["F_long"], 0.0, atol=1e-9)
    np.testing.assert_allclose(r["F_lat"], 0.0, atol=1e-9)
    np.testing.assert_allclose(r["friction_use"], 0.0, atol=1e-9)


@pytest.mark.parametrize("beta_deg,rho", [(80.0, 1.0), (70.0, 0.5)])
def test_contact_force_in_steady_precession_is_centripetal(build, beta_deg, rho):
    """F_n = M g; the horizontal force is M v^2 / rho, pointing to the centre of the circle."""
    fmu = build(BASE + "[effects.contact_forces]\n", "contact")
    start = steady_precession(math.radians(beta_deg), rho, **PAPER)
    r = _run(fmu, 4.0, 0.01, **start)
    cx, cy, radius = fit_circle(r["x"], r["y"])
    assert radius == pytest.approx(rho, rel=1e-6)
    v = rho * abs(start["alpha_dot"])
    a = r["alpha"]
    Fx = r["F_long"] * np.cos(a) - r["F_lat"] * np.sin(a)
    Fy = r["F_long"] * np.sin(a) + r["F_lat"] * np.cos(a)
    to_centre = np.c_[cx - r["x"], cy - r["y"]] / rho
    np.testing.assert_allclose(r["F_n"], M * G, rtol=1e-8)
    np.testing.assert_allclose(Fx * to_centre[:, 0] + Fy * to_centre[:, 1], M * v**2 / rho, rtol=1e-6)
    np.testing.assert_allclose(Fx * to_centre[:, 1] - Fy * to_centre[:, 0], 0.0, atol=1e-6 * M * v**2 / rho)


def test_slip_warning_when_friction_use_exceeds_mu(build):
    """Steady precession needs friction v^2 / (g rho) = 0.125; with mu = 0.13 and the motion
    perturbed by beta_dot = 0.1 rad/s the wobble crosses mu: a warning, the flag, the run goes on."""
    fmu = build(BASE + "[effects.contact_forces]\nmu = 0.13\non_slip = 'warn'\n", "slip")
    start = steady_precession(math.radians(80.0), 1.0, **PAPER)
    start["beta_dot"] = 0.1
    msgs = []
    r = simulate_fmu(fmu, stop_time=3.0, output_interval=0.01, debug_logging=True, start_values=start,
                     logger=lambda *a: msgs.append(a[-1].decode() if isinstance(a[-1], bytes) else str(a[-1])))
    assert not r["slipping"][0] and r["slipping"][-1]
    first = r["time"][np.argmax(r["slipping"])]
    assert np.all(r["friction_use"][r["time"] < first - 0.01] < 0.13)
    assert r["time"][-1] == pytest.approx(3.0)  # warn: no stop
    assert any("slip" in m for m in msgs)


def test_terminating_event_already_true_at_the_start_is_an_error(build):
    """A state that already violates a terminating condition (here: slip) is refused with a reason."""
    fmu = build(BASE + "[effects.contact_forces]\nmu = 0.01\non_slip = 'terminate'\n", "slip_stop")
    s = Slave(fmu)
    try:
        from fmpy.fmi1 import FMICallException
        with pytest.raises(FMICallException):
            s.init(beta=math.radians(70), gamma_dot=12.0)
        assert "already triggers event slip" in s.log_text()
    finally:
        s.free()


# -- Gyrover actuation ---------------------------------------------------------------

GYROVER = BASE + "[effects.gyrover]\n[effects.energy]\n"


def _initial_accelerations(fmu, flywheel_rate, tilt_rate, h=1e-4):
    """(alpha_ddot, beta_ddot) at t = 0 from q(h) = q0 + q_ddot h^2 / 2 (alpha_dot0 = beta_dot0 = 0)."""
    s = Slave(fmu)
    try:
        # servo at rest on a ramp: tilt_cmd = tilt + 2 zeta rate / omega gives zero servo acceleration
        s.init(flywheel_rate=flywheel_rate, tilt_rate=tilt_rate, beta=math.pi / 2, gamma_dot=10.0,
               rel_tol=1e-12, abs_tol=1e-14)
        s.set(tilt_cmd=2 * 1.0 * tilt_rate / 20.0)
        s.slave.doStep(0.0, h)
        return 2 * s.get("alpha") / h**2, 2 * (s.get("beta") - math.pi / 2) / h**2
    finally:
        s.free()


@pytest.mark.parametrize("flywheel_rate,tilt_rate", [(400.0, 0.5), (-400.0, 0.5), (800.0, -0.3)])
def test_tilting_a_spinning_flywheel_turns_the_wheel_about_the_vertical(build, flywheel_rate, tilt_rate):
    """Angular-momentum balance (Xu & Ou's tilt: the spin axis a = cos(tilt) n + sin(tilt) l_p turns
    about m_p, from the axle towards the link): a tilt rate turns the flywheel's momentum
    I_a Omega n towards l_p = -k at the rate I_a Omega tilt_rate, so the wheel and assembly receive
    the torque +I_a Omega tilt_rate k about the vertical, and nothing about the travel axis.
    Upright with alpha_dot = beta_dot = 0 (no gyroscopic terms yet), the yaw inertia about the
    vertical through the centre is the wheel's I_diam plus the flywheel's I_fly_diam (the
    assembly's mass hangs on that vertical): alpha_ddot = I_a Omega tilt_rate / (I_diam + I_fly_diam),
    beta_ddot = 0."""
    fmu = build(GYROVER, "gyrover")
    md = read_model_description(fmu)
    p = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter" and v.type == "Real"}
    I_yaw = KD * M * R**2 + p["I_fly_diam"]
    expected = tilt_rate * p["I_fly_axial"] * flywheel_rate / I_yaw
    yaw, lean = _initial_accelerations(fmu, flywheel_rate, tilt_rate)
    assert yaw == pytest.approx(expected, rel=2e-3)
    assert abs(lean) < 1e-3 * abs(expected)


def _held_tilt(fmu, flywheel_rate, tilt, seconds=6.0):
    """Run with tilt_cmd held at `tilt` from t = 0; returns fmpy's result."""
    signal = np.array([(0.0, tilt, 0.0), (seconds, tilt, 0.0)],
                      dtype=[("time", np.float64), ("tilt_cmd", np.float64), ("drive_torque", np.float64)])
    return simulate_fmu(fmu, stop_time=seconds, output_interval=0.01, input=signal,
                        start_values={"flywheel_rate": flywheel_rate, "beta": math.pi / 2, "gamma_dot": 10.0},
                        output=["alpha", "beta", "alpha_dot"])


def test_held_tilt_leans_the_wheel_into_a_steady_turn(build):
    """The Gyrover's steering: the yaw momentum stays (nearly) what it was, so tilting the flywheel's
    momentum H_f out of the horizontal leans the wheel the other way until the vertical components
    cancel, H_f sin(tilt) + (H_w + H_f) sin(lean) = 0 (H_w = I_axial gamma_dot); the lean then turns
    the wheel steadily. Mean lean over 2-6 s within 5 % of that; +tilt and -tilt mirror each other;
    a flywheel at rest does not steer."""
    fmu = build(GYROVER, "gyrover")
    left, right = _held_tilt(fmu, 400.0, -0.3), _held_tilt(fmu, 400.0, 0.3)
    late = left["time"] >= 2.0
    H_w, H_f = KA * M * R**2 * 10.0, 5e-4 * 400.0
    lean = math.asin(H_f * math.sin(0.3) / (H_w + H_f))  # for tilt = -0.3: leans left (beta > pi/2)
    assert np.mean(left["beta"][late] - math.pi / 2) == pytest.approx(lean, rel=0.05)
    rate = np.polyfit(left["time"][late], left["alpha"][late], 1)[0]
    assert rate > 0.3  # leaning left, it turns left (and keeps turning: > 1.2 rad in 4 s)
    np.testing.assert_allclose(right["alpha"], -left["alpha"], atol=1e-9)
    np.testing.assert_allclose(right["beta"] - math.pi / 2, -(left["beta"] - math.pi / 2), atol=1e-9)
    still = _held_tilt(fmu, 0.0, 0.3)
    assert np.abs(still["alpha"]).max() < 0.01 * np.abs(left["alpha"]).max()
    assert abs(_initial_accelerations(fmu, 0.0, 0.5)[0]) < 1e-3 * abs(_initial_accelerations(fmu, 400.0, 0.5)[0])


def test_gyrover_matches_an_independent_newton_euler_derivation():
    """The effect's right-hand side (CasADi, one Lagrangian) against tests/reference/gyrover_newton_euler.py
    (sympy rotation matrices, momentum balances) at random states, inputs and parameters: the
    accelerations of all coordinates, the tilt and flywheel motor torques, the centre velocity."""
    from gyrowheel.model.build import build_model
    from reference import gyrover_newton_euler as ne

    spec = build_model(wheel={"M": M, "R": R, "k_diam": KD, "k_axial": KA}, effects={"gravity": {}, "gyrover": {}})
    fns = spec.functions()
    out_names = [q.name for q, _ in spec.outputs]
    rng = np.random.default_rng(20261129)
    for _ in range(8):
        par = {q.name: q.start for q in spec.parameters}
        par.update(M=rng.uniform(1, 3), R=rng.uniform(0.1, 0.3), k_diam=rng.uniform(0.2, 0.5),
                   k_axial=rng.uniform(0.3, 0.9), g=rng.uniform(1, 10), m_fly=rng.uniform(0.1, 1),
                   L_pend=rng.uniform(0.01, 0.08), I_fly_axial=rng.uniform(1e-4, 1e-3),
                   I_fly_diam=rng.uniform(1e-4, 1e-3), flywheel_rate=rng.uniform(-600, 600),
                   tilt_omega=rng.uniform(5, 30), tilt_zeta=rng.uniform(0.3, 1.2))
        state = dict(alpha=rng.uniform(-3, 3), beta=rng.uniform(0.5, 2.6), gamma=rng.uniform(-3, 3),
                     theta_p=rng.uniform(-3, 3), alpha_dot=rng.normal(), beta_dot=rng.normal(),
                     gamma_dot=5 * rng.normal(), theta_p_dot=rng.normal(), tilt=rng.uniform(-1.2, 1.2),
                     tilt_rate=rng.normal())
        inputs = dict(tilt_cmd=rng.uniform(-1, 1), drive_torque=0.1 * rng.normal())
        p = np.array([par[q.name] for q in spec.parameters])
        x = np.array(fns["init"]([state.get(q.name, q.start) for q in spec.starts], p)).ravel()
        u = [inputs[q.name] for q in spec.inputs]
        xdot = dict(zip(spec.x_names, np.array(fns["ode"](0.0, x, u, p)).ravel()))
        y = dict(zip(out_names, np.array(fns["out"](0.0, x, u, p)).ravel()))
        got = dict(alpha_ddot=xdot["alpha_dot"], beta_ddot=xdot["beta_dot"], gamma_ddot=xdot["gamma_dot"],
                   theta_p_ddot=xdot["theta_p_dot"], tilt_ddot=xdot["tilt_rate"], tilt_torque=y["tilt_torque"],
                   flywheel_torque=y["flywheel_torque"], vx=y["vx"], vy=y["vy"])
        ref = ne.evaluate(state, inputs, par)
        for k, v in got.items():
            assert v == pytest.approx(ref[k], rel=1e-9, abs=1e-11 * (1 + abs(ref[k]))), k


def test_actuator_work_balances_energy(build):
    """No dissipation: energy(t) - energy(0) = actuator_work(t) (drive, tilt and spin motors)."""
    fmu = build(GYROVER, "gyrover")
    s = Slave(fmu)
    try:
        s.init(gamma_dot=10.0, beta=math.radians(85), rel_tol=1e-11, abs_tol=1e-13)
        e0 = s.get("energy")
        t = 0.0
        for i in range(200):
            s.set(tilt_cmd=0.3 * math.sin(3 * t), drive_torque=-0.2 if i < 100 else 0.1)
            s.slave.doStep(t, 5e-3)
            t += 5e-3
        e, w = s.get("energy", "actuator_work")
    finally:
        s.free()
    assert abs(w) > 0.05  # the motors did real work
    assert e - e0 == pytest.approx(w, abs=1e-7 * e0)


def test_tilt_torque_sign(build):
    """tilt_torque is the torque the tilt motor applies to the flywheel about +m_p (the tilt axis),
    positive in the sense of increasing tilt. Upright, at rest, flywheel not spinning, tilt_cmd =
    0.2 rad: the servo starts with tilt_ddot = tilt_omega^2 0.2 = 80 rad/s^2 about m_p = m, the
    horizontal roll axis; the reaction rolls the wheel the other way about the contact line (no
    moment of gravity or of the ground about it, upright), so the motor supplies
    I_f I_roll / (I_f + I_roll) tilt_ddot with I_f = I_fly_diam and the roll inertia about the
    contact line I_roll = k_diam M R^2 + M R^2 + m_fly (R - L_pend)^2, and the lean accelerates
    at beta_ddot = -I_f tilt_ddot / (I_f + I_roll)."""
    fmu = build(GYROVER, "gyrover")
    s = Slave(fmu)
    try:
        s.init(flywheel_rate=0.0, beta=math.pi / 2, gamma_dot=0.0, tilt_cmd=0.2, rel_tol=1e-12, abs_tol=1e-14)
        tau = s.get("tilt_torque")
        h = 1e-4
        s.slave.doStep(0.0, h)
        lean_acc = 2 * (s.get("beta") - math.pi / 2) / h**2
    finally:
        s.free()
    I_f, I_roll = 2.5e-4, KD * M * R**2 + M * R**2 + 0.4 * (R - 0.03) ** 2
    assert tau == pytest.approx(I_f * I_roll / (I_f + I_roll) * 20.0**2 * 0.2, rel=1e-9)
    assert tau > 0
    assert lean_acc == pytest.approx(-I_f * 80.0 / (I_f + I_roll), rel=2e-3)


def _max_swing(fmu, torque, ramp: float, seconds: float) -> float:
    """Largest |theta_p| while drive_torque rises linearly over `ramp` s (0: a step) to `torque`."""
    s = Slave(fmu)
    try:
        s.init(beta=math.pi / 2, gamma_dot=10.0)
        t, h, swing = 0.0, 5e-3, 0.0
        while t < seconds - 1e-9:
            s.set(drive_torque=torque * min(1.0, (t + h) / ramp) if ramp else torque)
            s.slave.doStep(t, h)
            t += h
            swing = max(swing, abs(s.get("theta_p")))
        return swing
    finally:
        s.free()


def test_pendulum_static_and_dynamic_limits(build):
    """docs/effects.md, gyrover: a drive torque applied slowly is held up to m_fly g L_pend
    (0.118 N.m: the assembly settles at asin(tau / (m g L))); a step from rest swings the assembly
    over the top already above 0.7246 m_fly g L_pend (0.0853 N.m), where the energy
    tau theta - m g L (1 - cos theta) stays positive up to the unstable equilibrium."""
    fmu = build(GYROVER, "gyrover")
    mgl = 0.4 * G * 0.03
    s_dyn = 0.7246113537767085  # s (pi - asin s) = 1 + sqrt(1 - s^2)
    assert s_dyn * (math.pi - math.asin(s_dyn)) == pytest.approx(1 + math.sqrt(1 - s_dyn**2), abs=1e-12)
    assert _max_swing(fmu, 0.98 * s_dyn * mgl, 0.0, 2.0) < math.pi - 0.8  # turns back below the top
    assert _max_swing(fmu, 1.02 * s_dyn * mgl, 0.0, 2.0) > math.pi      # over the top
    held = _max_swing(fmu, 0.97 * mgl, 4.0, 6.0)  # quasi-static ramp, then held for 2 s
    assert math.asin(0.97) - 0.2 < held < math.pi / 2 + 0.2
    assert _max_swing(fmu, 1.03 * mgl, 4.0, 6.0) > math.pi


# -- only what a scene asks for --------------------------------------------------------

@pytest.mark.parametrize("path", sorted(SCENES.glob("*.toml")), ids=lambda p: p.stem)
def test_every_example_scene_builds_validates_and_simulates(example_build, path):
    """One scene a test (xdist spreads them); the build is the run's shared one (example_build:
    the same build_fmu call, made once for every module that uses the scene)."""
    from fmpy.validation import validate_fmu
    fmu = example_build(path.stem).fmu
    assert validate_fmu(str(fmu)) == [], path.name
    r = simulate_fmu(str(fmu))
    names = r.dtype.names
    for n in names:
        if n != "time":
            assert np.all(np.isfinite(r[n].astype(float))), (path.name, n)
    assert r["time"][-1] > 0
