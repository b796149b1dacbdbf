"""The FMI 3.0 layer (c_src/gw_fmi3_*.c, unity file c_src/gw_fmu3.c) over the toy models of
tests/c/, each program linking an FMI 3.0 and an FMI 2.0 FMU of the same toy (both unity files:
their runtimes are internal, only fmi2* and fmi3* are global), so that FMI 3.0's results are
checked against FMI 2.0's bit for bit.  The toys number their variables from 1
(GW_TOY_VR_BASE=1): value reference 0 is time in FMI 3.0.

  test_fmi3_program        tests/c/test_fmi3_<driver>.c, strict / ASan+UBSan / valgrind:
                           oscillator: state machine, typed getters and setters, steps equal to
                           fmi2DoStep, the terminating event (lastSuccessfulTime);
                           stickslip: update events with and without early return and Event Mode
  test_fmi3_unity_exports  gw_fmu3.c compiles -Werror with gcc and clang and exports fmi3* only
"""
from __future__ import annotations

import shutil
import subprocess

import pytest

from c_programs import C_SRC, MODE_FLAGS, MODES, STRICT, compile_program, run_built, unity_flags

PROGRAMS = {"fmi3_oscillator": "oscillator", "fmi3_stickslip": "stickslip"}  # driver -> toy


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("driver", PROGRAMS)
def test_fmi3_program(driver, mode, tmp_path):
    exe = compile_program(driver, PROGRAMS[driver], tmp_path, [*MODE_FLAGS[mode], "-DGW_TOY_VR_BASE=1"],
                          fmi=(2, 3))
    r = run_built(exe, mode)
    assert f"test_{driver}: " in r.stderr and " 0 failures" in r.stderr, r.stderr


@pytest.mark.parametrize("cc", ["gcc", "clang"])
def test_fmi3_unity_exports(cc, tmp_path):
    if shutil.which(cc) is None:
        pytest.fail(f"{cc} is required for this test")
    obj = tmp_path / "fmu3.o"
    cmd = [cc, *STRICT, "-Wpedantic", "-O2", *unity_flags("stickslip"), "-c", str(C_SRC / "gw_fmu3.c"),
           "-o", str(obj)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    nm = subprocess.run(["nm", "-g", "--defined-only", str(obj)], capture_output=True, text=True, check=True)
    names = [line.split()[-1] for line in nm.stdout.splitlines() if line.strip()]
    assert names and all(n.startswith("fmi3") for n in names), names
    assert {"fmi3DoStep", "fmi3GetFloat64", "fmi3InstantiateCoSimulation", "fmi3EnterStepMode"} <= set(names)
