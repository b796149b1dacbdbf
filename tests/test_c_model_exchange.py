"""Model Exchange and directional derivatives of the generic C runtime (c_src/).

The C programs in tests/c act as Model Exchange importers:
  test_me.c       + toy_me.c          RK4 outer loop with importer-side event location
                                      (WARN and TERMINATE events), state/derivative variables,
                                      lazy outputs, FMU states in ME, directional derivatives vs
                                      the analytic Jacobian and central differences (rel 1e-6),
                                      error paths with their logged reasons;
  test_me_nodir.c + toy_oscillator.c  a model without `dir`: ME works, directional
                                      derivatives are "not provided".
Each is built with the project's strict flags, with ASan/UBSan, and run under valgrind
(the pattern of tests/test_c_runtime.py).  Everything is built in tmp_path.
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
# program name -> toy model it links
PROGRAMS = {"me": "me", "me_nodir": "oscillator"}


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


def run(cmd: list[str], timeout: float = 900, env: dict | None = None) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert r.returncode == 0, f"{' '.join(cmd)} exited {r.returncode}\n{r.stdout}\n{r.stderr}"
    assert " 0 failures" in r.stderr, r.stderr
    return r


@pytest.mark.parametrize("name", PROGRAMS)
def test_strict_build_and_run(name, tmp_path):
    exe = compile_program(name, tmp_path, ["-O2", "-g"])
    r = run([str(exe)])
    if name == "me":
        m = re.search(r"central differences: worst relative (\S+)", r.stderr)
        assert m and float(m.group(1)) < 1e-6, r.stderr


@pytest.mark.parametrize("name", PROGRAMS)
def test_sanitizers(name, tmp_path):
    exe = compile_program(
        name, tmp_path,
        ["-O1", "-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
         "-fno-sanitize-recover=all"],
    )
    env = dict(os.environ, ASAN_OPTIONS="detect_leaks=1:abort_on_error=0",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1")
    run([str(exe)], env=env)


@pytest.mark.parametrize("name", PROGRAMS)
def test_valgrind(name, tmp_path):
    assert os.path.exists(VALGRIND), "valgrind is required for this test"
    exe = compile_program(name, tmp_path, ["-O1", "-g"])
    run([VALGRIND, "-q", "--error-exitcode=1", "--leak-check=full",
         "--errors-for-leak-kinds=all", str(exe)])
