"""Flight with slope and air drag (docs/effects.md, "Flight"): the free wheel under tilted gravity
and the drag law, against closed forms and an independent integration.

- Slope: the frame stays attached to the ground plane, so gravity is tilted and the height is
  measured normal to the plane; an upright spinning wheel thrown off the slope follows the tilted
  parabola r0 + v0 t + g t^2 / 2 and touches down where its z reaches R: at
  t* = (vz0 + sqrt(vz0^2 + 2 g cos(th) h0)) / (g cos(th)).
- Air drag, linear (c_lin) with the spin torque (cm_spin): v = v0 e^(-c t / M) plus the terminal
  fall, gamma_dot = w0 / (1 + k w0 t) with k = rho cm_spin R^5 / (2 I_axial).
- Air drag, quadratic (cd_area): scipy's DOP853 on M v' = M g - rho cd_area |v| v / 2 (a point
  mass, written here).
- energy + dissipated_energy constant through flight, drag and touchdown on a slope.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmi_helpers import simulate_logged
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.fmu_build.scene import SceneError
from paper_wheel import G, KA, M, R
from paper_wheel import PAPER_WHEEL_TOML as WHEEL

TIGHT = {"rel_tol": 1e-12, "abs_tol": 1e-14}
EFFECTS = """
[effects.slope]
slope_angle = 0.0
[effects.air_drag]
rho_air = 0.0
cm_spin = 0.0
cd_area = 0.0
c_lin = 0.0
[effects.contact_forces]
on_slip = "slide"
on_lift_off = "fly"
mu = 0.3
[effects.energy]
"""
OUT = ["x", "y", "z", "vx", "vy", "vz", "beta", "gamma_dot", "height", "contact_mode", "energy",
       "dissipated_energy"]


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    root = tmp_path_factory.mktemp("flight_effects")
    scene = parse_scene('[model]\nname = "flight_effects"\n' + WHEEL + EFFECTS, "flight_effects.toml")
    return str(build_fmu(scene, root / "flight_effects.fmu").fmu)


def run(fmu, stop, dt=0.001, **start):
    return simulate_logged(fmu, stop, dt, OUT, {**TIGHT, **start})


@pytest.mark.parametrize("th, psi", [(0.2, 0.3), (-0.35, 2.0)])
def test_wheel_thrown_on_a_slope_lands_where_the_tilted_parabola_meets_the_plane(fmu, th, psi):
    h0, vz0, w0 = 0.3, 1.0, 10.0
    r, events = run(fmu, 0.6, slope_angle=th, slope_direction=psi, height=h0, vz=vz0, alpha=0.7, beta=math.pi / 2,
                    gamma_dot=w0)
    g = G * np.array([math.sin(th) * math.cos(psi), math.sin(th) * math.sin(psi), -math.cos(th)])
    gn = G * math.cos(th)
    t_land = (vz0 + math.sqrt(vz0 ** 2 + 2 * gn * h0)) / gn
    touch = [te for name, te in events if name == "contact_flight"]
    assert touch and abs(touch[0] - t_land) < 1e-9
    t = r["time"]
    fly = t < t_land
    assert np.all(r["contact_mode"][fly] == 2) and r["contact_mode"][-1] < 2
    r0 = np.array([r["x"][0], r["y"][0], R + h0])
    v0 = np.array([r["vx"][0], r["vy"][0], vz0])
    assert abs(np.hypot(v0[0], v0[1]) - R * w0) < 1e-12  # the rolling wheel's velocity, thrown
    expected = r0 + np.outer(t[fly], v0) + 0.5 * np.outer(t[fly] ** 2, g)
    got = np.stack([r["x"], r["y"], r["z"]], axis=1)[fly]
    assert np.abs(got - expected).max() < 1e-9
    assert np.abs(r["beta"][fly] - math.pi / 2).max() < 1e-12  # torque-free: it stays upright
    land = r0 + v0 * t_land + 0.5 * g * t_land ** 2  # where it lands: z = R on the plane
    assert abs(land[2] - R) < 1e-12
    after = np.argmax(t >= t_land)  # the first sample after touchdown: the position is continuous there
    v_land = np.linalg.norm(v0 + g * t_land)
    assert np.linalg.norm([r["x"][after] - land[0], r["y"][after] - land[1]]) <= v_land * (t[after] - t_land) + 1e-9
    balance = r["energy"] + r["dissipated_energy"]
    assert np.abs(balance - balance[0]).max() < 1e-10 * M * G * R


def test_linear_drag_and_spin_drag_in_flight_follow_their_closed_forms(fmu):
    c, rho, cm, h0, vz0, w0 = 0.8, 1.225, 0.5, 1.0, 2.0, 40.0
    r, events = run(fmu, 0.4, c_lin=c, rho_air=rho, cm_spin=cm, height=h0, vz=vz0, beta=math.pi / 2, gamma_dot=w0)
    assert not [e for e in events if e[0] == "contact_flight"]
    t = r["time"]
    assert np.all(r["contact_mode"] == 2)
    e = np.exp(-c * t / M)
    vt = M * G / c  # terminal speed
    vx0, vy0 = r["vx"][0], r["vy"][0]
    assert np.abs(r["vx"] - vx0 * e).max() < 1e-9 and np.abs(r["vy"] - vy0 * e).max() < 1e-9
    assert np.abs(r["vz"] - ((vz0 + vt) * e - vt)).max() < 1e-9
    z = R + h0 + (vz0 + vt) * (M / c) * (1 - e) - vt * t
    assert np.abs(r["z"] - z).max() < 1e-9
    assert np.abs(r["x"] - (r["x"][0] + vx0 * (M / c) * (1 - e))).max() < 1e-9
    k = 0.5 * rho * cm * R ** 5 / (KA * M * R ** 2)
    assert np.abs(r["gamma_dot"] - w0 / (1 + k * w0 * t)).max() < 1e-9 * w0
    balance = r["energy"] + r["dissipated_energy"]
    assert np.abs(balance - balance[0]).max() < 1e-10 * M * G * R
    assert np.all(np.diff(r["dissipated_energy"]) > 0)


def test_quadratic_drag_in_flight_matches_an_independent_integration(fmu):
    rho, cd, h0, vz0, w0 = 1.225, 0.3, 1.5, 3.0, 20.0
    r, _ = run(fmu, 0.5, rho_air=rho, cd_area=cd, height=h0, vz=vz0, gamma_dot=w0, alpha=0.4, beta=math.pi / 2)
    assert np.all(r["contact_mode"] == 2)

    def f(t, y):  # a point mass under gravity and the drag law, with the law's smoothed speed
        v = y[3:]
        speed = math.sqrt(v @ v + 1e-12)
        return np.concatenate([v, [0, 0, -G] - 0.5 * rho * cd * speed * v / M])
    y0 = [r["x"][0], r["y"][0], R + h0, r["vx"][0], r["vy"][0], vz0]  # upright: z0 = R + h0
    ref = solve_ivp(f, (0, 0.5), y0, method="DOP853", rtol=1e-13, atol=1e-15, t_eval=r["time"]).y
    for i, name in enumerate(("x", "y", "z", "vx", "vy", "vz")):
        assert np.abs(r[name] - ref[i]).max() < 1e-9, name
    assert abs(r["vz"][-1] - (vz0 - G * 0.5)) > 0.01  # the drag is felt


def test_energy_balance_through_a_tumbling_flight_and_landing_on_a_slope(fmu):
    r, events = run(fmu, 0.8, slope_angle=0.15, slope_direction=1.0, rho_air=1.225, cd_area=0.3, c_lin=0.2,
                    cm_spin=0.5, height=0.1, vz=0.5, beta=1.2, gamma_dot=25.0, alpha_dot=2.0, beta_dot=1.0)
    assert any(name == "contact_flight" for name, _ in events)
    assert all(np.isfinite(r[n]).all() for n in OUT)
    balance = r["energy"] + r["dissipated_energy"]
    assert np.abs(balance - balance[0]).max() < 1e-10 * M * G * R
    assert np.all(np.diff(r["dissipated_energy"]) >= 0)


def test_fly_is_refused_with_gyrover_naming_the_reason():
    text = '[effects.gyrover]\n[effects.contact_forces]\non_slip = "slide"\non_lift_off = "fly"\n'
    with pytest.raises(SceneError, match=re.escape('on_lift_off: "fly" is not possible with gyrover: the flight '
                                                   "mode is the free wheel alone")):
        parse_scene(WHEEL + text, "s.toml")
