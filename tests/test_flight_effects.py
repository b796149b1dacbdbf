"""Flight with slope, air drag and the Gyrover (docs/effects.md, "Flight"): the free wheel under
tilted gravity, the drag law and the Gyrover's internal bodies and motors, against closed forms, an
independent integration and the conservation laws.

- Slope: the frame stays attached to the ground plane, so gravity is tilted and the height is
  measured normal to the plane; an upright spinning wheel thrown off the slope follows the tilted
  parabola r0 + v0 t + g t^2 / 2 and touches down where its z reaches R: at
  t* = (vz0 + sqrt(vz0^2 + 2 g cos(th) h0)) / (g cos(th)).
- Air drag, linear (c_lin) with the spin torque (cm_spin): v = v0 e^(-c t / M) plus the terminal
  fall, gamma_dot = w0 / (1 + k w0 t) with k = rho cm_spin R^5 / (2 I_axial).
- Air drag, quadratic (cd_area): scipy's DOP853 on M v' = M g - rho cd_area |v| v / 2 (a point
  mass, written here).
- energy + dissipated_energy constant through flight, drag and touchdown on a slope.
- Gyrover: internal torques only, so the centre of mass flies the parabola and the angular momentum
  about it (wheel, assembly mass, flywheel; written here from the effect's geometry) is constant;
  energy + dissipated - actuator_work constant in flight and through a landing.
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


GYROVER = """
[effects.gyrover]
flywheel_rate = 400.0
[effects.contact_forces]
on_slip = "slide"
on_lift_off = "fly"
mu = 0.3
[effects.energy]
"""
GYRO_OUT = ["x", "y", "z", "vx", "vy", "vz", "alpha", "beta", "alpha_dot", "beta_dot", "gamma_dot", "theta_p",
            "theta_p_dot", "tilt", "tilt_rate", "contact_mode", "energy", "dissipated_energy", "actuator_work",
            "height"]
M_FLY, L_PEND, I_FA, I_FD, W_FLY = 0.4, 0.03, 5e-4, 2.5e-4, 400.0  # the gyrover effect's defaults, flywheel_rate


@pytest.fixture(scope="module")
def gyrover_fmu(tmp_path_factory):
    root = tmp_path_factory.mktemp("flight_gyrover")
    scene = parse_scene('[model]\nname = "flight_gyrover"\n' + WHEEL + GYROVER, "flight_gyrover.toml")
    return str(build_fmu(scene, root / "flight_gyrover.fmu").fmu)


def total_momentum(r):
    """Linear momentum / total mass (the centre of mass's velocity) and the angular momentum about
    the centre of mass (N m s, ground frame) of wheel and Gyrover assembly, from the outputs, written
    here from the effect's geometry: frame m = -(cos a, sin a, 0), n the axle, l = m x n (towards the
    contact); link l_p = cos(th) l + sin(th) m, tilt axis m_p = -sin(th) l + cos(th) m, flywheel
    axis a = cos(tilt) n + sin(tilt) l_p; the assembly's mass at L_pend l_p from the centre, turning
    with the frame plus the swing, the flywheel with its spin about a on top."""
    a, b, th, tl = r["alpha"], r["beta"], r["theta_p"], r["tilt"]
    k = np.array([0, 0, 1.0])
    m = np.stack([-np.cos(a), -np.sin(a), np.zeros_like(a)], axis=-1)
    n = np.stack([-np.sin(a) * np.sin(b), np.cos(a) * np.sin(b), np.cos(b)], axis=-1)
    lv = np.cross(m, n)
    lp = np.cos(th)[:, None] * lv + np.sin(th)[:, None] * m
    mp = -np.sin(th)[:, None] * lv + np.cos(th)[:, None] * m
    ax = np.cos(tl)[:, None] * n + np.sin(tl)[:, None] * lp
    w_frame = r["alpha_dot"][:, None] * k + r["beta_dot"][:, None] * m
    w_wheel = w_frame + r["gamma_dot"][:, None] * n
    w_link = w_frame + r["theta_p_dot"][:, None] * n
    w_fly = w_link + r["tilt_rate"][:, None] * mp + W_FLY * ax
    rc = np.stack([r["x"], r["y"], r["z"]], axis=1)
    vc = np.stack([r["vx"], r["vy"], r["vz"]], axis=1)
    rf, vf = rc + L_PEND * lp, vc + L_PEND * np.cross(w_link, lp)
    m_tot = M + M_FLY
    r_cm, v_cm = (M * rc + M_FLY * rf) / m_tot, (M * vc + M_FLY * vf) / m_tot
    I_d, I_a = 0.25 * M * R ** 2, KA * M * R ** 2

    def spin(w, axis, i_d, i_a):
        return i_d * w + (i_a - i_d) * np.sum(w * axis, axis=1)[:, None] * axis
    L = (spin(w_wheel, n, I_d, I_a) + M * np.cross(rc - r_cm, vc - v_cm)
         + spin(w_fly, ax, I_FD, I_FA) + M_FLY * np.cross(rf - r_cm, vf - v_cm))
    return v_cm, L


def test_gyrover_in_flight_keeps_its_momenta_and_energy_balance(gyrover_fmu):
    """Thrown with the assembly swinging, the flywheel tilting under its servo and the drive on:
    internal torques only, so the centre of mass flies the parabola and the angular momentum about
    it stays constant; energy + dissipated - actuator work constant."""
    start = dict(height=0.5, vz=1.0, beta=1.3, gamma_dot=15.0, alpha_dot=1.0, beta_dot=0.5, theta_p=0.3,
                 theta_p_dot=2.0, tilt=0.2, tilt_rate=1.0, tilt_cmd=0.6, drive_torque=0.02)
    r, events = simulate_logged(gyrover_fmu, 0.3, 0.001, GYRO_OUT, {**TIGHT, **start})
    assert not events and np.all(r["contact_mode"] == 2)
    t = r["time"]
    v_cm, L = total_momentum(r)
    assert np.abs(v_cm - v_cm[0] - np.outer(t, [0, 0, -G])).max() < 1e-9
    size = np.linalg.norm(L[0])
    assert np.abs(L - L[0]).max() < 1e-10 * size
    assert np.ptp(r["tilt"]) > 0.1 and np.ptp(r["theta_p"]) > 0.1  # the internal motion is there
    assert np.abs(np.ptp(r["actuator_work"])) > 1e-3  # and the motors work
    balance = r["energy"] + r["dissipated_energy"] - r["actuator_work"]
    assert np.abs(balance - balance[0]).max() < 1e-10 * M * G * R


def test_gyrover_thrown_lands_and_rolls_on(gyrover_fmu):
    start = dict(height=0.05, vz=0.5, beta=1.4, gamma_dot=15.0, theta_p=0.2, tilt_cmd=0.3)
    r, events = simulate_logged(gyrover_fmu, 0.6, 0.001, GYRO_OUT, {**TIGHT, **start})
    assert any(name == "contact_flight" for name, _ in events)
    assert r["contact_mode"][0] == 2 and r["contact_mode"][-1] < 2
    assert all(np.isfinite(r[n]).all() for n in GYRO_OUT)
    balance = r["energy"] + r["dissipated_energy"] - r["actuator_work"]
    assert np.abs(balance - balance[0]).max() < 1e-9 * M * G * R


def test_gyrover_lifts_off_flies_and_lands(gyrover_fmu):
    """A fast lean rate throws the Gyrover off the ground (rolling -> sliding -> flight, each
    located), the flight keeps the momenta of the state it left with, the landing ends it."""
    r, events = simulate_logged(gyrover_fmu, 0.5, 0.001, GYRO_OUT,
                                {**TIGHT, "beta": 1.0, "beta_dot": 6.0, "gamma_dot": 20.0})
    names = [name for name, _ in events]
    assert names[:3] == ["contact_slip", "contact_flight", "contact_flight"]  # slides, flies, lands
    fly = r["contact_mode"] == 2
    assert fly.sum() > 50 and r["contact_mode"][-1] < 2
    v_cm, L = total_momentum(r)
    t = r["time"][fly]
    assert np.abs(L[fly] - L[fly][0]).max() < 1e-10 * np.linalg.norm(L[fly][0])
    assert np.abs(v_cm[fly] - v_cm[fly][0] - np.outer(t - t[0], [0, 0, -G])).max() < 1e-9
    balance = r["energy"] + r["dissipated_energy"] - r["actuator_work"]
    assert np.abs(balance - balance[0]).max() < 1e-10 * M * G * R
