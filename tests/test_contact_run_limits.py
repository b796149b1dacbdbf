"""Runs of the contact modes at their limits, as a user meets them (docs/effects.md, "Flight";
docs/runtime.md, "Contact modes with each solver"; docs/fmi.md, "Bounded calls").

- a start value the FMU refuses (`--set restitution=1.5`): one line naming it and its range,
  exit 2 (bad input), however many checks it fails;
- a wheel tumbling through flat in flight: the run stops with its own reason
  (flight_attitude_limit, flag flat_in_flight) at the time of the torque-free rotation, not as
  "fallen";
- slip_long, slip_lat in flight: the lowest rim point's horizontal velocity, so a wheel started in
  flight reads its start values, and the centre's velocity differs from the rolling one by them;
- euler and rk4 with the contact modes: a warning, logged whatever the logging categories and
  printed by `gyrowheel simulate` (deserved: euler at the default step never rests the drop and
  creates energy); the FMI 3.0 FMU refuses and warns alike;
- DOPRI5 at the stiff slip onset of euler_disk_end with 1 ms steps: the run's budget stops it
  after about one budget of steps in all (counted from the FMU's solver log), not one per step;
- `gyrowheel info` lists an Enumeration's items.
Every FMU is the run's shared build of an example scene (conftest.example_build).
"""
from __future__ import annotations

import math
import re
import subprocess
import sys
import warnings

import pytest

import gyrowheel
from fmi_helpers import Slave, simulate_logged
from gyrowheel.simulation import FmuWarning


@pytest.fixture(scope="module")
def drop(example_build):
    return str(example_build("drop_bounce").fmu)


def test_set_out_of_range_is_one_line_naming_the_field_exit_2(drop, tmp_path):
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "simulate", drop, "--set", "restitution=1.5",
                        "--stop-time", "0.01", "-o", str(tmp_path / "out.csv")], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr == "gyrowheel: error: --set: the FMU refused the start values: restitution must be <= 1\n"
    assert not (tmp_path / "out.csv").exists()


@pytest.mark.parametrize("start, reason", [
    ({"height": -0.1}, "height must be >= 0 (the lowest rim point cannot start below the ground)"),
    # a combination names each value and its source
    ({"height": 0.0, "vz": 1.0}, "vz (1, given) must be 0 unless height (0, given) > 0 (in contact the centre's "
                                 "vertical velocity follows the lean rate)"),
    ({"M": -1.0}, "M (mass) must be > 0"),
    ({"k_axial": 0.9}, "k_axial (0.9, given) must be <= 2 k_diam (0.25, the FMU's start value) (I_axial <= 2 "
                       "I_diam for any rigid body)"),
    # one value, one reason: the combined checks hold back where a value fails its own range
    ({"k_diam": -1.0}, "k_diam must be > 0"),
    ({"beta": -1.0}, "beta (initial lean) must be > 0"),
    ({"beta": 4.0}, "beta (initial lean) must be < pi"),
    ({"mu": -1.0}, "mu must be >= 0"),
])
def test_start_values_the_fmu_refuses_are_bad_input(drop, start, reason):
    with pytest.raises(gyrowheel.ArgumentError) as exc:
        gyrowheel.simulate(drop, stop_time=0.01, start_values=start)
    assert str(exc.value) == f"start_values: the FMU refused the start values: {reason}"
    assert exc.value.argument == "start_values"


def test_fmi3_refuses_and_warns_alike(example_build):
    """The FMI 3.0 FMU of the same scene: the refusal at fmi3ExitInitializationMode is bad input
    with the same one reason, the fixed-step warning names fmi3ExitInitializationMode."""
    fmu = example_build("drop_bounce", fmi=3).fmu
    with pytest.raises(gyrowheel.ArgumentError) as exc:
        gyrowheel.simulate(fmu, stop_time=0.01, start_values={"restitution": 1.5})
    assert str(exc.value) == "start_values: the FMU refused the start values: restitution must be <= 1"
    with pytest.warns(FmuWarning, match=r"^fmi3ExitInitializationMode: solver rk4: the contact modes "):
        gyrowheel.simulate(fmu, stop_time=0.01, start_values={"solver": "rk4"})


def test_wheel_tumbling_through_flat_in_flight_stops_with_its_reason(drop):
    """Thrown at lean 1.2 rad with beta_dot = -20 rad/s and no other rate: torque-free rotation
    about a diameter (a principal axis) at a constant rate, so beta reaches beta_min = 1e-3 rad at
    (1.2 - 1e-3) / 20 s, in flight (the rim is 0.5 m up and falls less than 2 cm by then)."""
    r, events = simulate_logged(drop, 0.2, 0.001, ["beta", "contact_mode", "fallen", "flat_in_flight"],
                                {"height": 0.5, "beta": 1.2, "beta_dot": -20.0, "gamma_dot": 0.0})
    assert events[-1][0] == "flight_attitude_limit"
    assert events[-1][1] == pytest.approx((1.2 - 1e-3) / 20.0, abs=1e-9)
    assert r["time"][-1] == pytest.approx((1.2 - 1e-3) / 20.0, abs=1e-9)
    assert r["flat_in_flight"][-1] and not r["fallen"][-1] and r["contact_mode"][-1] == 2
    assert not any(name == "fall" for name, _ in events)


def test_a_fall_in_contact_is_still_fallen(drop):
    """The contact modes keep the fall event: a wheel standing with no spin falls over."""
    r, events = simulate_logged(drop, 5.0, 0.01, ["fallen", "flat_in_flight", "contact_mode"],
                                {"height": 0.0, "beta": 1.4, "gamma_dot": 0.0})
    assert r["fallen"][-1] and not r["flat_in_flight"][-1] and events[-1][0] == "fall"


def test_slip_in_flight_is_the_rim_point_velocity(drop):
    """Upright, spinning, thrown with a start slip: slip_long, slip_lat read the start values at
    t = 0 and through the flight (torque-free: the centre's horizontal velocity and the spin are
    constant), and the centre's velocity is the slip-free run's plus the slip, along the heading
    (alpha = 0: x) and across it (y)."""
    out = ["vx", "vy", "slip_long", "slip_lat", "contact_mode"]
    start = {"height": 0.1, "beta": math.pi / 2, "gamma_dot": 5.0}
    slid, _ = simulate_logged(drop, 0.1, 0.01, out, {**start, "slip_long": 0.3, "slip_lat": -0.2})
    plain, _ = simulate_logged(drop, 0.1, 0.01, out, start)
    flying = slid["contact_mode"] == 2
    assert flying[0] and flying.sum() >= 10
    assert slid["slip_long"][0] == pytest.approx(0.3, abs=1e-15)
    assert slid["slip_lat"][0] == pytest.approx(-0.2, abs=1e-15)
    assert max(abs(slid["slip_long"][flying] - 0.3)) < 1e-12 and max(abs(slid["slip_lat"][flying] + 0.2)) < 1e-12
    assert max(abs(plain["slip_long"][flying])) < 1e-12
    assert max(abs(slid["vx"][flying] - plain["vx"][flying] - 0.3)) < 1e-12
    assert max(abs(slid["vy"][flying] - plain["vy"][flying] + 0.2)) < 1e-12


@pytest.mark.parametrize("solver", ["euler", "rk4"])
def test_fixed_step_solvers_warn_for_the_contact_modes(drop, solver):
    with pytest.warns(FmuWarning, match=rf"^fmi2ExitInitializationMode: solver {solver}: the contact modes .* "
                                        r"use dopri5, dop853, rosenbrock or taylor"):
        gyrowheel.simulate(drop, stop_time=0.01, start_values={"solver": solver})


def test_the_warning_is_deserved_euler_never_rests_the_drop(drop):
    """The upright drop (h = 0.1 m, e = 0.5) at the default max_step 0.01 s, 3 s: DOPRI5 rests it
    after 11 switches at the series' time and keeps energy + dissipated_energy; euler bounces on
    to the end (hundreds of switches, still flying) and creates energy (more than 0.1 J of
    M g h = 1.96 J)."""
    out = ["contact_mode", "energy", "dissipated_energy"]
    runs = {s: simulate_logged(drop, 3.0, 0.001, out, {"solver": code}) for s, code in (("euler", 1), ("dopri5", 3))}
    balance = {s: r["energy"] + r["dissipated_energy"] for s, (r, _) in runs.items()}
    switches = {s: sum(name == "contact_flight" for name, _ in events) for s, (_, events) in runs.items()}
    assert switches["dopri5"] == 11 and runs["dopri5"][0]["contact_mode"][-1] == 0
    assert abs(balance["dopri5"][-1] - balance["dopri5"][0]) < 1e-12
    assert switches["euler"] > 100 and runs["euler"][0]["contact_mode"][-1] == 2
    assert balance["euler"][-1] - balance["euler"][0] > 0.1


def test_adaptive_solvers_do_not_warn(drop):
    with warnings.catch_warnings():
        warnings.simplefilter("error", FmuWarning)
        gyrowheel.simulate(drop, stop_time=0.01, start_values={"solver": "dopri5"})


def test_simulate_prints_the_fixed_step_warning(drop, tmp_path):
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "simulate", drop, "--set", "solver=euler",
                        "--stop-time", "0.01", "-o", str(tmp_path / "out.csv")], capture_output=True, text=True)
    assert r.returncode == 0
    assert re.fullmatch(r"gyrowheel: warning: fmi2ExitInitializationMode: solver euler: the contact modes [^\n]*\n",
                        r.stderr)


def _steps(log: str) -> int:
    """Internal steps (accepted + rejected) of every doStep the solver log reports."""
    return sum(int(a) + int(b) for a, b in re.findall(r"accepted=(\d+) rejected=(\d+)", log))


def test_run_budget_stops_a_stiff_onset_in_bounded_work(example_build):
    """euler_disk_end with DOPRI5, 1 ms communication steps, budget 1e5: the slip onset at 3.519 s
    takes DOPRI5's stability-bound steps of ~2e-9 s (~4.6e5 per communication step, within a
    per-call budget of 1e6, 8.5 s to go: 4e9 steps, benchmarks/run_budget.py); the run's budget
    refuses the rest once the run has taken one budget, so the whole run takes at most two
    budgets of steps; the wheel is sliding there (the onset was reached)."""
    budget = 100_000
    s = Slave(example_build("euler_disk_end").fmu)
    try:
        s.init(stop_time=12.0, solver=3, max_internal_steps=budget)
        s.slave.doStep(0.0, 3.518)
        t, refused = 3.518, None
        for _ in range(100):
            try:
                s.slave.doStep(t, 0.001)
            except Exception:
                refused = t
                break
            t += 0.001
        log = s.log_text()
        assert refused is not None and refused < 3.53
        assert "the run's budget refuses the rest" in log and "try solver rosenbrock" in log
        assert _steps(log) <= 2 * budget
        assert s.get("contact_mode") == 1  # sliding: the onset was reached
    finally:
        s.free()


def test_info_lists_the_items_of_enumerations(drop):
    text = str(gyrowheel.info(drop))
    assert "items of contact_mode (ContactMode): rolling = 0, sliding = 1, flight = 2" in text
    assert "items of solver (Solver): euler = 1, rk4 = 2, dopri5 = 3, rosenbrock = 4, dop853 = 5" in text
