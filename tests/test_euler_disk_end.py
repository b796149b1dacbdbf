"""Euler's disk run to its end with sliding and flight (examples/scenes/euler_disk_end.toml;
docs/hard_cases.md, family 11; docs/effects.md, "Sliding").

Against what the code did not produce: the slip starts where the rolling run's friction demand
|F_t| / F_n reaches mu (a run of the same FMU with mu = 10, which never slides), the normal force
obeys Newton's vertical law F_n = M (g + d^2/dt^2 R sin(beta)) (finite differences of the lean),
so it decides lift-off as the body's motion says, the friction in sliding lies on Coulomb's cone
against the slip, and energy + dissipated_energy stays constant through every switch.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime
from scipy.interpolate import CubicSpline

from fmi_helpers import Slave

SCENE = Path(__file__).parent.parent / "examples" / "scenes" / "euler_disk_end.toml"
OUT = ("beta", "contact_mode", "F_n", "F_long", "F_lat", "slip_long", "slip_lat", "friction_use", "energy",
       "dissipated_energy")
M, R, G, MU, BETA_MIN = 0.45, 0.0375, 9.81, 0.3, 1e-3  # the scene's wheel, g = "earth"
DT = 1e-3


@pytest.fixture(scope="module")
def fmu(example_build):
    """The scene's FMU, the test run's shared build (conftest.example_build)."""
    return str(example_build(SCENE.stem).fmu)


def run(fmu, **start):
    """Steps of DT to the end of the run: (time, {output: array}, [(event, t)], end time)."""
    s = Slave(fmu)
    s.init(**start)
    t, rows = 0.0, [(0.0, *s.get(*OUT))]
    try:
        while t < 12.0 - 1e-12:
            s.slave.doStep(t, DT)
            t += DT
            rows.append((t, *s.get(*OUT)))
    except FMICallException:
        t = s.slave.getRealStatus(fmi2LastSuccessfulTime)
    events = [(m.group(1), float(m.group(2))) for _, _, line in s.messages
              for m in [re.search(r"event (\w+) at t=(\S+?):? ", line + " ")] if m]
    a = np.array(rows)
    s.free()
    return a[:, 0], {name: a[:, i + 1] for i, name in enumerate(OUT)}, events, t


@pytest.fixture(scope="module")
def disk(fmu):
    return run(fmu)


def test_disk_slides_and_sticks_to_the_fall_without_chattering(disk):
    """The run reaches the fall at beta_min with stick and slip alternating on physical time scales:
    no two switches within 1 us, a bounded number of them, no NaN, no flight (F_n > 0)."""
    t, r, events, end = disk
    names = [name for name, _ in events]
    assert names[-1] == "fall" and "contact_flight" not in names
    assert r["beta"][-1] > BETA_MIN and end > t[-1] and end < t[-1] + DT
    for values in r.values():
        assert np.all(np.isfinite(values))
    switches = np.array([te for name, te in events if name == "contact_slip"])
    assert 50 <= len(switches) <= 400
    assert np.min(np.diff(switches)) > 1e-6
    assert set(r["contact_mode"]) == {0.0, 1.0} and np.min(r["F_n"]) > 0


def test_slip_starts_where_rolling_needs_mu(fmu, disk):
    """The first switch is where the rolling disk's friction demand |F_t| / F_n reaches mu, read from a
    run of the same disk with mu = 10 (it rolls until the final collapse): within 1e-7 s."""
    t_ref, r_ref, events_ref, _ = run(fmu, mu=10.0, mu_k=10.0)
    assert min(te for name, te in events_ref if name == "contact_slip") > 9.0  # only in the final collapse
    use = r_ref["friction_use"]
    k = int(np.argmax(use >= MU))
    window = slice(k - 4, k + 4)
    spline = CubicSpline(t_ref[window], use[window] - MU * (1 + 1e-9))
    t_star = [root for root in spline.roots(extrapolate=False) if t_ref[k - 1] <= root <= t_ref[k]]
    first = next(te for name, te in disk[2] if name == "contact_slip")
    assert len(t_star) == 1 and abs(first - t_star[0]) < 1e-7


def test_normal_force_follows_the_vertical_motion(disk):
    """F_n = M (g + z''), z = R sin(beta) the centre's height on the ground (Newton's vertical law),
    z'' by central differences of the lean at the output grid, away from switches."""
    t, r, events, _ = disk
    z = R * np.sin(r["beta"])
    z_dd = (z[2:] - 2 * z[1:-1] + z[:-2]) / DT ** 2
    expected = M * (G + z_dd)
    switch_times = np.array([te for _, te in events])
    near = np.min(np.abs(t[1:-1, None] - switch_times[None, :]), axis=1) < 2 * DT
    ok = ~near & (r["beta"][1:-1] > 0.02)  # the final collapse is faster than the grid resolves
    assert np.max(np.abs(r["F_n"][1:-1][ok] - expected[ok])) < 1e-3 * M * G


def test_friction_on_the_cone_against_the_slip(disk):
    """While sliding: |F_t| = mu F_n (1e-9), against the slip where the slip is far above the friction
    direction's seed 1e-8 v_scale (~7e-9 m/s here): |slip| > 1e-5 m/s, the direction within 1e-3 rad."""
    _, r, _, _ = disk
    s = r["contact_mode"] == 1.0
    f = np.hypot(r["F_long"][s], r["F_lat"][s])
    assert np.all(np.abs(f - MU * r["F_n"][s]) <= 1e-9 * MU * r["F_n"][s])
    slip = np.hypot(r["slip_long"][s], r["slip_lat"][s])
    resolved = slip > 1e-5
    cos = (r["F_long"][s] * r["slip_long"][s] + r["F_lat"][s] * r["slip_lat"][s])[resolved] / (f * slip)[resolved]
    assert resolved.sum() > 100 and np.max(cos) < -(1 - 5e-7)


def test_energy_balance_through_every_switch(disk):
    """energy + dissipated_energy constant to 1e-10 of the start energy at every output point."""
    _, r, _, _ = disk
    total = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(total - total[0])) < 1e-10 * r["energy"][0]


def test_explicit_solver_sees_one_slip_onset(fmu, disk):
    """dopri5 through the first 0.1 ms of the first slip (zero excess, mu_k = mu): the slip is at the
    round-off of v_slip for its first ~1e-7 s, and the sliding indicator's excess term keeps that
    noise from ending it: at most a few switches (d . v_slip alone as the indicator: the runtime's
    guard of 1000 events in one step), the first where the scene's run has it, the disk sliding."""
    first = next(te for name, te in disk[2] if name == "contact_slip")
    s = Slave(fmu)
    s.init(solver=3)  # dopri5
    s.slave.doStep(0.0, 3.5188)
    s.slave.doStep(3.5188, 1e-4)
    switches = [float(m.group(1)) for _, _, line in s.messages
                for m in [re.search(r"event contact_slip at t=(\S+?):? ", line + " ")] if m]
    assert 1 <= len(switches) <= 5 and abs(switches[0] - first) < 1e-7
    assert s.get("contact_mode") == 1.0 and np.isfinite(s.get("slip_lat"))
    s.free()
