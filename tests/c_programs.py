"""Build and run the C test programs of tests/c/: the runtime + a toy model + a driver.

Each program is built with the project's strict flags, with AddressSanitizer and
UndefinedBehaviorSanitizer, or for valgrind; `run` asserts a clean exit and the
harness's "0 failures" line (tests/c/harness.h).
"""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import fmpy

ROOT = Path(__file__).resolve().parent.parent
C_SRC = ROOT / "c_src"
TESTS_C = ROOT / "tests" / "c"
FMI_HEADERS = Path(fmpy.__file__).resolve().parent / "c-code"
VALGRIND = shutil.which("valgrind") or "/usr/bin/valgrind"

STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"]
MODES = ("strict", "sanitizers", "valgrind")
MODE_FLAGS = {
    "strict": ["-O2", "-g"],
    "sanitizers": ["-O1", "-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
                   "-fno-sanitize-recover=all"],
    "valgrind": ["-O1", "-g"],
}
SANITIZER_ENV = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0",
                 "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1"}


def compile_program(driver: str, toy: str, out: Path, extra: list[str]) -> Path:
    """tests/c/test_<driver>.c + tests/c/toy_<toy>.c + every c_src/*.c -> an executable."""
    exe = out / f"test_{driver}"
    cmd = ["gcc", *STRICT, *extra, f"-I{FMI_HEADERS}", f"-I{C_SRC}", "-fvisibility=hidden",
           *map(str, sorted(C_SRC.glob("*.c"))), str(TESTS_C / f"toy_{toy}.c"),
           str(TESTS_C / f"test_{driver}.c"), "-lm", "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"compile failed:\n{' '.join(cmd)}\n{r.stdout}{r.stderr}"
    return exe


def run(cmd: list[str], timeout: float = 900, env: dict | None = None) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert r.returncode == 0, f"{' '.join(cmd)} exited {r.returncode}\n{r.stdout}\n{r.stderr}"
    assert " 0 failures" in r.stderr, r.stderr
    return r


def run_program(driver: str, toy: str, out: Path, mode: str) -> subprocess.CompletedProcess:
    """Build in `mode` (strict | sanitizers | valgrind) and run; returns the finished process."""
    exe = compile_program(driver, toy, out, MODE_FLAGS[mode])
    if mode == "sanitizers":
        return run([str(exe)], env=dict(os.environ, **SANITIZER_ENV))
    if mode == "valgrind":
        assert os.path.exists(VALGRIND), "valgrind is required for this test"
        return run([VALGRIND, "-q", "--error-exitcode=1", "--leak-check=full", "--errors-for-leak-kinds=all",
                    str(exe)])
    return run([str(exe)])
