"""The animation's geometry: the drawn wheel is where the model says it is.

Checked against facts the drawing code does not compute: an upright wheel's rim is vertical, the
lowest point of any leaned rim is the ground point below the centre in the wheel's plane, the FMU's
own contact-point and centre-height outputs, the Gyrover FMU's flywheel momentum (which fixes the
flywheel's axis), and the direction a rolling wheel's marks turn.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy.util import write_csv

from animate_data import R, rolling_csv
from gyrowheel.animation import AnimationError, Options, build_timeline, read_result, resolve_parameters
from gyrowheel.animation.geometry import circle_points, wheel_poses
from gyrowheel.simulation import run

PHI = np.linspace(0.0, 2 * np.pi, 20001)
RNG = np.random.default_rng(7)


def test_upright_rim_is_vertical_and_along_the_heading():
    alpha, gamma = RNG.uniform(-7, 7, 12), RNG.uniform(-20, 20, 12)
    q = np.column_stack([RNG.normal(size=12), RNG.normal(size=12), alpha, np.full(12, np.pi / 2), gamma])
    p = wheel_poses(q, R)
    rim = circle_points(p.centre, p.body, R, PHI)
    d = rim - p.centre[:, None, :]
    np.testing.assert_allclose(p.centre[:, 2], R, atol=1e-15)
    np.testing.assert_allclose(p.body[:, 2, 2], 0.0, atol=1e-15)  # the axle is horizontal
    heading = np.column_stack([np.cos(alpha), np.sin(alpha)])
    across = np.column_stack([-np.sin(alpha), np.cos(alpha)])
    # every rim point lies in the vertical plane through the centre along the heading
    np.testing.assert_allclose(np.einsum("npi,ni->np", d[:, :, :2], across), 0.0, atol=1e-15)
    np.testing.assert_allclose(np.einsum("npi,ni->np", d[:, :, :2], heading) ** 2 + d[:, :, 2] ** 2, R**2,
                               rtol=1e-12)
    np.testing.assert_allclose(rim[:, :, 2].min(axis=1), 0.0, atol=R * 1e-7)
    np.testing.assert_allclose(rim[:, :, 2].max(axis=1), 2 * R, rtol=1e-7)


def test_leaned_rim_touches_the_ground_at_the_contact_point():
    n = 40
    beta = RNG.uniform(0.05, np.pi - 0.05, n)
    q = np.column_stack([RNG.normal(size=n), RNG.normal(size=n), RNG.uniform(-9, 9, n), beta,
                         RNG.uniform(-30, 30, n)])
    p = wheel_poses(q, R)
    np.testing.assert_allclose(p.centre[:, 2], R * np.sin(beta), rtol=1e-14)  # eq. (21)
    rim = circle_points(p.centre, p.body, R, PHI)
    low = rim[np.arange(n), rim[:, :, 2].argmin(axis=1)]
    assert rim[:, :, 2].min() > -1e-15  # nothing below the ground
    np.testing.assert_allclose(low[:, 2], 0.0, atol=R * (1 - math.cos(PHI[1])))
    np.testing.assert_allclose(p.contact[:, 2], 0.0, atol=1e-16)
    np.testing.assert_allclose(low, p.contact, atol=R * PHI[1])
    # independently: the lowest point of a circle is its centre minus R times the unit vector of
    # the up direction projected onto the circle's plane
    axle = p.body[:, :, 2]
    up = np.array([0.0, 0.0, 1.0]) - axle[:, 2:3] * axle
    lowest = p.centre - R * up / np.linalg.norm(up, axis=1, keepdims=True)
    np.testing.assert_allclose(p.contact, lowest, atol=1e-14)


def test_marks_turn_forward_over_the_top_as_the_wheel_rolls_forward():
    """Positive spin rolls the wheel along (cos alpha, sin alpha) (docs/interface.md: vx = R gamma_dot at
    alpha = 0, upright); a mark at the top then moves forward and one at the contact stays put."""
    alpha, d_gamma = 0.7, 1e-6
    q0 = np.array([[0, 0, alpha, np.pi / 2, 0.0]])
    q1 = q0 + [[0, 0, 0, 0, d_gamma]]
    p0, p1 = wheel_poses(q0, R), wheel_poses(q1, R)
    top = PHI[:-1][np.argmax(circle_points(p0.centre, p0.body, R, PHI[:-1])[0, :, 2])]
    move = (circle_points(p1.centre, p1.body, R, [top]) - circle_points(p0.centre, p0.body, R, [top]))[0, 0]
    np.testing.assert_allclose(move / d_gamma, R * np.array([np.cos(alpha), np.sin(alpha), 0]), atol=1e-5)
    np.testing.assert_allclose(p0.heading[0], [np.cos(alpha), np.sin(alpha), 0], atol=1e-15)


@pytest.fixture(scope="module")
def gyrover_run(tmp_path_factory, example_build):
    """The Gyrover scene's FMU steered by a tilt command from a leaned start, 3 s, as CSV."""
    d = tmp_path_factory.mktemp("animate_gyrover")
    fmu = example_build("gyrover_steering").fmu
    result = run(fmu, stop_time=3.0, output_interval=0.01,
                 start_values={"beta": 1.35, "gamma_dot": 9.0, "alpha_dot": 0.4, "tilt_cmd": 0.3, "theta_p": 0.2})
    write_csv(str(d / "gyrover.csv"), result)
    return fmu, d / "gyrover.csv", result


def test_poses_match_the_fmus_contact_point_and_height(gyrover_run):
    fmu, csv, r = gyrover_run
    table = read_result(csv)
    params = resolve_parameters(table, fmu=fmu)
    assert params.R == 0.17 and params.source["R"] == fmu.name and params.L_pend == 0.03
    q = np.column_stack([r[n] for n in ("x", "y", "alpha", "beta", "gamma")])
    p = wheel_poses(q, params.R, r["theta_p"], r["tilt"], params.L_pend)
    assert np.ptp(r["beta"]) > 0.1 and np.ptp(r["alpha"]) > 0.5  # the run leans and turns
    np.testing.assert_allclose(p.contact[:, 0], r["contact_x"], atol=1e-12)
    np.testing.assert_allclose(p.contact[:, 1], r["contact_y"], atol=1e-12)
    np.testing.assert_allclose(p.centre[:, 2], r["z"], atol=1e-12)
    # the drawn rim's lowest point is the FMU's contact point
    rim = circle_points(p.centre, p.body, params.R, PHI)
    low = rim[np.arange(len(r)), rim[:, :, 2].argmin(axis=1)]
    np.testing.assert_allclose(low[:, :2], np.column_stack([r["contact_x"], r["contact_y"]]), atol=R * PHI[1])


def test_flywheel_axis_matches_the_fmus_flywheel_momentum(gyrover_run):
    """flywheel_momentum = I_fly_axial (omega_frame . a + theta_p_dot cos(tilt) + flywheel_rate)
    (model/effects/gyrover.py: a = cos(tilt) n + sin(tilt) l_p, normal to m_p), with the frame's angular
    velocity omega_frame = alpha_dot k - beta_dot (cos alpha, sin alpha, 0) (heading about k, lean
    about the horizontal -m): the FMU's number fixes the component of the drawn axis along it."""
    fmu, _, r = gyrover_run
    I_axial, rate = 5e-4, 400.0  # examples/scenes/gyrover_steering.toml and the effect's default
    q = np.column_stack([r[n] for n in ("x", "y", "alpha", "beta", "gamma")])
    p = wheel_poses(q, 0.17, r["theta_p"], r["tilt"], 0.03)
    axis = p.fly_frame[:, :, 2]
    omega = np.column_stack([-r["beta_dot"] * np.cos(r["alpha"]), -r["beta_dot"] * np.sin(r["alpha"]),
                             r["alpha_dot"]])
    expected = r["flywheel_momentum"] / I_axial - rate - r["theta_p_dot"] * np.cos(r["tilt"])
    assert np.ptp(np.einsum("ni,ni->n", omega, axis)) > 0.1
    np.testing.assert_allclose(np.einsum("ni,ni->n", omega, axis), expected, atol=1e-9)
    # the flywheel hangs L_pend from the axle, in the wheel's plane, theta_p from l towards m
    lmn = wheel_poses(np.column_stack([q[:, :4], np.zeros(len(r))]), 0.17).body
    arm = p.fly_centre - p.centre
    np.testing.assert_allclose(np.linalg.norm(arm, axis=1), 0.03, rtol=1e-12)
    np.testing.assert_allclose(np.einsum("ni,ni->n", arm, lmn[:, :, 0]), 0.03 * np.cos(r["theta_p"]), atol=1e-15)
    np.testing.assert_allclose(np.einsum("ni,ni->n", arm, lmn[:, :, 1]), 0.03 * np.sin(r["theta_p"]), atol=1e-15)
    np.testing.assert_allclose(np.einsum("ni,ni->n", axis, lmn[:, :, 2]), np.cos(r["tilt"]), atol=1e-14)
    # tilted about m_p, from the axle towards the link l_p (Xu & Ou's beta_a)
    np.testing.assert_allclose(np.einsum("ni,ni->n", axis, arm / 0.03), np.sin(r["tilt"]), atol=1e-14)
    assert np.ptp(r["tilt"]) > 0.25


def test_timeline_checks_the_radius_against_the_csv(gyrover_run, tmp_path):
    fmu, csv, r = gyrover_run
    table = read_result(csv)
    params = resolve_parameters(table)  # no option: R from z / sin(beta), flywheel from the model
    assert params.R == pytest.approx(0.17, rel=1e-12) and params.source["R"] == "z / sin(beta)"
    assert params.source["L_pend"] == "model default"
    with pytest.raises(AnimationError, match=r"R = 0.2 m \(from --R\) contradicts .*gives R = 0.17 m"):
        resolve_parameters(table, R=0.2)
    # without z only the contact outputs can catch a wrong radius
    stripped = tmp_path / "no_z.csv"
    text = csv.read_text().splitlines()
    header = text[0].split(",")
    keep = [i for i, h in enumerate(header) if h != '"z"']
    stripped.write_text("\n".join(",".join(line.split(",")[i] for i in keep) for line in text) + "\n")
    table = read_result(stripped)
    with pytest.raises(AnimationError, match="wheel radius is unknown"):
        resolve_parameters(table)
    with pytest.raises(AnimationError, match="misses the CSV's contact_x/contact_y"):
        build_timeline(table, resolve_parameters(table, R=0.2), Options())
    tl = build_timeline(table, resolve_parameters(table, R=0.17), Options(fps=10))
    assert len(tl.time) == 31 and tl.gyrover


def test_frames_interpolate_the_rows(tmp_path):
    table = read_result(rolling_csv(tmp_path / "run.csv", stop=2.0))
    tl = build_timeline(table, resolve_parameters(table), Options(fps=8, speed=0.5, start=0.25, stop=1.0))
    np.testing.assert_allclose(tl.time, 0.25 + np.arange(13) / 16)
    q = np.column_stack([R * 7.5 * np.sin(0.8 * tl.time), R * 7.5 * (1 - np.cos(0.8 * tl.time)), 0.8 * tl.time,
                         np.full(13, math.radians(80)), 6 * tl.time])
    np.testing.assert_allclose(tl.poses.centre, wheel_poses(q, R).centre, atol=2e-5)
    assert tl.track_time[0] == 0.25 and tl.track_time[-1] == 1.0 and len(tl.track) == 2 + 74  # ends + rows 0.26 .. 0.99
    assert tl.readout[0].startswith("t =    0.25 s   beta =  80.0°   alpha =   11.5°   v = 1.02 m/s")


def test_an_fmu_given_must_give_what_the_drawing_needs(earth_fmu, tmp_path):
    """The paper wheel's FMU gives R to a plain run's drawing; for a Gyrover run (theta_p, tilt)
    it has no flywheel, so it is refused rather than passed over for the model's defaults."""
    plain = read_result(rolling_csv(tmp_path / "plain.csv"))
    params = resolve_parameters(plain, fmu=earth_fmu)
    assert params.R == 0.17 and params.source == {"R": earth_fmu.name}
    gyrover = read_result(rolling_csv(tmp_path / "gyrover.csv", gyrover=True))
    with pytest.raises(AnimationError, match=r"^--fmu .*paper_earth.fmu: no start value of L_pend, m_fly, "
                       r"I_fly_axial \(the Gyrover's flywheel\), which this result's theta_p and tilt columns need"):
        resolve_parameters(gyrover, fmu=earth_fmu)
    assert resolve_parameters(gyrover).source["L_pend"] == "model default"  # without an FMU: said by the command
