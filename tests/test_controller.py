"""The Gyrover controller: what the actuators reach, the design across the schedule,
closed-loop eigenvalues against the co-simulated loop, the sampled loop's step limit, the mission."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.linalg import expm

from conftest import SCENES
from gyrowheel.controller.design import closed_loop_matrix, controllable_basis, plant_model, sampled_spectral_radius
from gyrowheel.controller.operating_point import steady_turn
from gyrowheel.cosim.master import run
from gyrowheel.fmu_build import load_scene
from gyrowheel.fmu_build.builder import model_spec

M, R, KD, KA = 2.0, 0.17, 0.25, 0.4
I_FA, I_FD, RATE = 5e-4, 2.5e-4, 400.0  # the gyrover effect's defaults (the mission scenes' flywheel)


@pytest.fixture(scope="module")
def moon_spec():
    return model_spec(load_scene(SCENES / "gyrover_mission_moon.toml"))


def test_only_the_yaw_momentum_is_uncontrollable(earth_design):
    """One direction of 9 is out of reach, and it is the linear yaw momentum
    c = I_yaw alpha_dot - (H_w + H_f) lean - H_f tilt (I_yaw = I_diam + I_fly_diam, H_w = I_axial v / R,
    H_f = I_fly_axial flywheel_rate), computed here from the parameters: no internal torque turns
    the whole Gyrover about the vertical."""
    d = earth_design
    m = d.matrices()
    T = controllable_basis(m["A"], m["B"])
    assert T.shape[1] == len(d.x_names) - 1
    w = m["w"]
    assert np.abs(w @ m["B"]).max() < 1e-12 and np.abs(w @ m["A"]).max() < 1e-9
    H_w, H_f = KA * M * R**2 * d.speed / R, I_FA * RATE
    expected = {"alpha_dot": KD * M * R**2 + I_FD, "beta": -(H_w + H_f), "tilt": -H_f}
    for i, name in enumerate(d.x_names):
        assert w[i] == pytest.approx(expected.get(name, 0.0), rel=1e-9, abs=1e-12), name


def test_steady_turns_are_equilibria_of_the_independent_reference(moon_spec):
    """controller/operating_point.py's steady turns (lean, swing, drive for a heading rate and tilt)
    give zero accelerations in tests/reference/gyrover_newton_euler.py, which shares nothing with
    the CasADi model; and a turn's lean does not depend on the tilt that holds it."""
    from reference import gyrover_newton_euler as ne
    par = {q.name: q.start for q in moon_spec.parameters}
    leans = []
    for rate, tilt in ((0.15, -0.5), (0.15, 0.3), (-0.1, 0.6)):
        op = steady_turn(moon_spec, 1.5, rate, tilt)
        x = dict(zip(moon_spec.x_names, op.x))
        state = {k: x[k] for k in ("alpha", "beta", "gamma", "theta_p", "alpha_dot", "beta_dot", "gamma_dot",
                                   "theta_p_dot", "tilt", "tilt_rate")}
        ref = ne.evaluate(state, {"tilt_cmd": op.u[0], "drive_torque": op.u[1]}, par)
        for k in ("alpha_ddot", "beta_ddot", "gamma_ddot", "theta_p_ddot", "tilt_ddot"):
            assert abs(ref[k]) < 1e-9, (rate, tilt, k, ref[k])
        assert math.hypot(ref["vx"], ref["vy"]) == pytest.approx(1.5, rel=1e-12)
        leans.append(op.lean)
    assert leans[0] > 0.1 and leans[2] < 0  # turning left leans left (beta > pi/2)
    assert leans[1] == pytest.approx(leans[0], rel=0.05)


def test_every_design_of_the_schedule_is_stable_and_so_are_the_gaps(earth_loop):
    """At every grid point (heading rate x tilt) the linear loop [plant; observer] is stable (the
    conserved direction at 0 apart); so is the interpolated controller at the centre of every grid
    cell (gains, equilibria and conserved row the mean of the cell's four designs, as the
    controller FMU's bilinear weights make them there), on the plant linearised at that centre."""
    sch = earth_loop.schedule
    spec = model_spec(load_scene(SCENES / "gyrover_mission_earth.toml"))
    for d in sch.designs:
        ev = np.linalg.eigvals(closed_loop_matrix(d))
        assert (np.abs(ev) < 1e-7).sum() == 1
        assert ev[np.abs(ev) > 1e-7].real.max() < -0.05, (d.rate, d.tilt)
    for i in range(len(sch.rates) - 1):
        for j in range(len(sch.tilts) - 1):
            cell = [sch.at(i, j), sch.at(i + 1, j), sch.at(i, j + 1), sch.at(i + 1, j + 1)]
            mean = {k: np.mean([np.array(getattr(d, k)) for d in cell], axis=0).tolist()
                    for k in ("K", "L", "Nx", "Nu", "w")}
            rate, tilt = np.mean([d.rate for d in cell]), np.mean([d.tilt for d in cell])
            plant = plant_model(spec, sch.speed, tilt=tilt, rate=rate)
            ev = np.linalg.eigvals(closed_loop_matrix(dataclasses.replace(cell[0], **mean), plant))
            assert ev[np.abs(ev) > 1e-7].real.max() < 0, (rate, tilt)


def test_closed_loop_follows_the_linear_closed_loop(earth_loop):
    """A 0.5 deg lean with zero heading rate (so a yaw momentum the tilt must hold) in the
    co-simulated loop at 1 ms against expm(A_cl t) of the centre design's linear loop
    [plant; observer]: lean and heading within 4 % of the start lean over 1.5 s."""
    d = earth_loop.design
    lean0 = math.radians(-0.5)
    r = run(earth_loop.system, 0.001, stop_time=1.5,
            start_values={"wheel": {"beta": math.pi / 2 + lean0, "alpha_dot": 0.0},
                          "controller": {f"mission_rate_{k}": 0.0 for k in range(12)}})
    assert r.stopped_by is None
    Acl = closed_loop_matrix(d)
    z0 = np.zeros(2 * len(d.x_names))
    z0[d.x_names.index("beta")] = lean0
    t = r.data["time"][::50]
    lin = np.array([expm(Acl * tk) @ z0 for tk in t])
    lean = r.data["wheel.beta"][::50] - math.pi / 2
    heading = r.data["wheel.alpha"][::50]
    assert np.abs(lean - lin[:, d.x_names.index("beta")]).max() < 0.04 * abs(lean0)
    assert np.abs(heading - lin[:, d.x_names.index("alpha")]).max() < 0.04 * abs(lean0)
    assert np.abs(lean[-1]) < 0.05 * abs(lean0)  # and it has settled


def test_the_sampled_linear_loop_predicts_the_step_that_fails(earth_loop):
    """The co-simulated loop at step h is linear map Phi(h) per step (controller/design.py,
    sampled_closed_loop): spectral radius < 1 at 20 ms, > 1 at 50 ms; the co-simulation agrees
    (up for 10 s at 20 ms, fallen or lost within 10 s at 50 ms: the `lost` event ends it)."""
    d = earth_loop.design
    assert sampled_spectral_radius(d, 0.02) < 1.0 < sampled_spectral_radius(d, 0.05)
    ok = run(earth_loop.system, 0.02, stop_time=10.0)
    assert ok.stopped_by is None
    bad = run(earth_loop.system, 0.05, stop_time=10.0)
    assert bad.stopped_by is not None


def test_mission_on_earth_turn_and_figure_eight(earth_loop):
    """The earth mission (gyrowheel.controller.mission): rolling upright at 1.5 m/s with a 5 deg lean
    and zero heading rate (the scene's start), a 90 deg turn and a figure eight on 3 m circles, 60 s
    at 10 ms: up, tracking within 5 deg after the first 5 s, actuators within their limits, and the
    course flown."""
    d = earth_loop.design
    r = run(earth_loop.system, 0.01)
    data = r.data
    assert r.stopped_by is None and data["time"][-1] == pytest.approx(60.0)
    late = data["time"] > 5.0
    lean = np.degrees(data["wheel.beta"] - math.pi / 2)
    assert lean[0] == pytest.approx(-5.0, abs=1e-9)
    assert np.abs(lean[late]).max() < 10.0
    err = np.degrees(data["controller.heading_error"][late])
    assert np.abs(err).max() < 5.0 and np.sqrt(np.mean(err**2)) < 1.5
    assert np.degrees(data["wheel.alpha"]).max() == pytest.approx(450.0, abs=5.0)  # 90 + a full circle
    assert np.degrees(data["wheel.alpha"][-1]) == pytest.approx(90.0, abs=1.0)  # ... and back
    assert np.abs(data["controller.tilt_cmd"]).max() <= d.tilt_max + 1e-12
    assert np.abs(data["controller.drive_torque"]).max() <= d.drive_max + 1e-12
