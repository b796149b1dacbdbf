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

import os
import re
import shutil
import subprocess
from pathlib import Path

import fmpy
import pytest

ROOT = Path(__file__).resolve().parent.parent
C_SRC = ROOT / "c_src"
TESTS_C = ROOT / "tests" / "c"
FMI_HEADERS = Path(fmpy.__file__).resolve().parent / "c-code"
VALGRIND = shutil.which("valgrind") or "/usr/bin/valgrind"

STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"]
# test program -> toy model
PROGRAMS = {"stiff": "stiff", "solvers_osc": "oscillator"}


def compile_program(name: str, out: Path, extra: list[str]) -> Path:
    exe = out / f"test_{name}"
    cmd = [
        "gcc", *STRICT, *extra,
        f"-I{FMI_HEADERS}", f"-I{C_SRC}", "-fvisibility=hidden",
        *map(str, sorted(C_SRC.glob("*.c"))),
        str(TESTS_C / f"toy_{PROGRAMS[name]}.c"), str(TESTS_C / f"test_{name}.c"),
        "-lm", "-o", str(exe),
    ]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"compile failed:\n{' '.join(cmd)}\n{r.stdout}{r.stderr}"
    return exe


def run(cmd: list[str], timeout: float = 600, env: dict | None = None) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert r.returncode == 0, f"{' '.join(cmd)} exited {r.returncode}\n{r.stdout}\n{r.stderr}"
    assert " 0 failures" in r.stderr, r.stderr
    return r


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_strict_build_and_run(tmp_path, name):
    exe = compile_program(name, tmp_path, ["-O2", "-g"])
    r = run([str(exe)])
    print(r.stderr)


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_sanitizers(tmp_path, name):
    exe = compile_program(
        name, tmp_path,
        ["-O1", "-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
         "-fno-sanitize-recover=all"],
    )
    env = dict(os.environ, ASAN_OPTIONS="detect_leaks=1:abort_on_error=0",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1")
    run([str(exe)], env=env)


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_valgrind(tmp_path, name):
    assert os.path.exists(VALGRIND), "valgrind is required for this test"
    exe = compile_program(name, tmp_path, ["-O1", "-g"])
    run([VALGRIND, "-q", "--error-exitcode=1", "--leak-check=full",
         "--errors-for-leak-kinds=all", str(exe)])


def counts(stderr: str, what: str) -> dict[str, int]:
    m = re.search(rf"COUNTS {re.escape(what)}: (.*)", stderr)
    assert m, stderr
    return {k: int(v) for k, v in re.findall(r"(\w+)=(\d+)", m.group(1))}


def test_work_counts(tmp_path):
    """The headline numbers, checked once more from the programs' reports."""
    stiff = run([str(compile_program("stiff", tmp_path, ["-O2"]))]).stderr
    ros, dopri = counts(stiff, "stiff rosenbrock"), counts(stiff, "stiff dopri5")
    assert 100 * (ros["accepted"] + ros["rejected"]) < dopri["accepted"] + dopri["rejected"]
    assert 50 * (ros["rhs"] + ros["jacobians"]) < dopri["rhs"]
    osc = run([str(compile_program("solvers_osc", tmp_path, ["-O2"]))]).stderr
    d8, d5 = counts(osc, "tight dop853"), counts(osc, "tight dopri5")
    assert 3 * d8["accepted"] < d5["accepted"]
    assert 2 * d8["rhs"] < d5["rhs"]


def test_enumeration_values():
    """The solver enumeration is append-only: the Python side writes these numbers."""
    text = (C_SRC / "gw_model.h").read_text()
    values = dict(re.findall(r"GW_SOLVER_(\w+) = (\d+)", text))
    assert values == {"EULER": "1", "RK4": "2", "DOPRI5": "3", "ROSENBROCK": "4", "DOP853": "5"}
