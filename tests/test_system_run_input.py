"""`gyrowheel system run --set` with values the system cannot take: each is bad input, exit 2
with one line naming COMPONENT.VARIABLE (and, for a value out of its range, the range the
component's FMU states), nothing written; gyrowheel.system_run raises ArgumentError naming
start_values. A value a component refuses at initialisation is told apart from a failure of the
run (a component failing while it steps stays exit 1, tests/test_system_files.py)."""
from __future__ import annotations

import subprocess
import sys

import pytest

import gyrowheel
from gyrowheel.errors import ArgumentError

RATE = ("gamma_dot must lie in [-1e+09, 1e+09] rad/s (the wheel's time scales, sqrt(R/g) >= 1 us and "
        "1/|rate| >= 1 ns, above the solvers' step-size floor)")
MASS = ("M (mass) must lie in [1e-30, 1e+30] kg (beyond, the contact's products of masses and squared speeds "
        "leave double precision)")


@pytest.mark.parametrize("value, message", [
    ("wheel.M=-1", "--set: wheel refused the start values: M (mass) must be > 0 (wheel.M = -1.0)"),
    ("wheel.M=1e150", f"--set: wheel refused the start values: {MASS} (wheel.M = 1e+150)"),
    ("wheel.gamma_dot=1e150", f"--set: wheel refused the start values: {RATE} (wheel.gamma_dot = 1e+150)"),
    ("nowheel.M=1", "--set 'nowheel.M=1': expected COMPONENT.VARIABLE=VALUE with a component of wheel, controller"),
    ("wheel.M=heavy", "--set, component wheel: value 'heavy' for 'M' is not a valid Real"),
    ("wheel.M", "--set 'wheel.M': expected NAME=VALUE"),
])
def test_bad_set_exits_2_in_one_line_naming_it(earth_loop, tmp_path, value, message):
    out = tmp_path / "run.csv"
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "system", "run", str(earth_loop.ssp), "--stop-time",
                        "0.02", "--set", value, "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert r.stderr == f"gyrowheel: error: {message}\n" and r.stdout == ""
    assert not out.exists()


def test_unknown_variable_exits_2_naming_component_and_variable(earth_loop, tmp_path):
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "system", "run", str(earth_loop.ssp), "--stop-time",
                        "0.02", "--set", "wheel.nosuch=1", "-o", str(tmp_path / "run.csv")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert r.stderr.startswith("gyrowheel: error: --set, component wheel: unknown variable 'nosuch'; settable: ")


def test_api_refusal_is_an_argument_error_naming_start_values(earth_loop):
    with pytest.raises(ArgumentError) as exc:
        gyrowheel.system_run(earth_loop.ssp, stop_time=0.02, start_values={"wheel.R": 1e-300})
    assert exc.value.argument == "start_values"
    # in Initialization Mode the master reads the wheel's outputs before fmi2ExitInitializationMode:
    # the FMU refuses the read, the output not finite, with the range its checks name
    text = str(exc.value)
    assert text.startswith("start_values: wheel refused the start values: ") and "\n" not in text
    assert "R must lie in [1e-06, 1e+06] m (" in text and text.endswith("(wheel.R = 1e-300)")
