"""Tests of the runtime's DOP853 and Rosenbrock (RODAS4) solvers with hand-written toys.

Two C programs, each linked with the runtime (c_src/) and one toy model:
  tests/c/test_stiff.c       + toy_stiff.c       stiff linear system, exact solution,
                                                  analytic Jacobian in the jac slot
  tests/c/test_solvers_osc.c + toy_oscillator.c  harmonic oscillator (no jac: the
                                                  Rosenbrock solver differentiates)
They check accuracy against the exact solutions, orders (fixed-step error ratios, the
growth of the step count with the tolerance), work counts against DOPRI5 (from the
logSolver messages), event location on the dense outputs, exact landing, max_step,
step size carry-over, FMU state restore and step size underflow.  Like
test_c_runtime.py, every program is built with the strict flags, with ASan/UBSan, and
run under valgrind; everything is built in tmp_path.
"""

from __future__ import annotations

import re

import pytest

from c_programs import C_SRC, MODES, compile_program, run, run_program

PROGRAMS = {"stiff": "stiff", "solvers_osc": "oscillator"}  # driver -> toy model


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("driver", sorted(PROGRAMS))
def test_program(driver, mode, tmp_path):
    run_program(driver, PROGRAMS[driver], tmp_path, mode)


def counts(stderr: str, what: str) -> dict[str, int]:
    m = re.search(rf"COUNTS {re.escape(what)}: (.*)", stderr)
    assert m, stderr
    return {k: int(v) for k, v in re.findall(r"(\w+)=(\d+)", m.group(1))}


def test_work_counts(tmp_path):
    """The headline numbers, checked once more from the programs' reports."""
    stiff = run([str(compile_program("stiff", "stiff", tmp_path, ["-O2"]))]).stderr
    ros, dopri = counts(stiff, "stiff rosenbrock"), counts(stiff, "stiff dopri5")
    assert 100 * (ros["accepted"] + ros["rejected"]) < dopri["accepted"] + dopri["rejected"]
    assert 50 * (ros["rhs"] + ros["jacobians"]) < dopri["rhs"]
    osc = run([str(compile_program("solvers_osc", "oscillator", tmp_path, ["-O2"]))]).stderr
    d8, d5 = counts(osc, "tight dop853"), counts(osc, "tight dopri5")
    assert 3 * d8["accepted"] < d5["accepted"]
    assert 2 * d8["rhs"] < d5["rhs"]


def test_enumeration_values():
    """The solver enumeration is append-only: the Python side writes these numbers."""
    text = (C_SRC / "gw_model.h").read_text()
    values = dict(re.findall(r"GW_SOLVER_(\w+) = (\d+)", text))
    assert values == {"EULER": "1", "RK4": "2", "DOPRI5": "3", "ROSENBROCK": "4", "DOP853": "5",
                      "TAYLOR": "6", "AUTO": "7"}
    from gyrowheel.fmu_build.scene import SOLVERS
    assert {name.upper(): str(code) for name, code in SOLVERS.items()} == values
