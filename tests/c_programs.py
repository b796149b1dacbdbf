"""Build and run the C test programs of tests/c/: the runtime + a toy model + a driver.

The runtime and the toy model form one translation unit, exactly as in an FMU: c_src/gw_fmu.c
(FMI 2.0) or c_src/gw_fmu3.c (FMI 3.0, fmi=3) with GW_MODEL_SOURCE naming the toy
(docs/runtime.md); the driver is a second translation unit that sees only the fmi2* (fmi3*)
functions.  Each program is built with the project's strict flags
(no flag hiding symbols), with AddressSanitizer and UndefinedBehaviorSanitizer, or for
valgrind; `run` asserts a clean exit and the harness's "0 failures" line (tests/c/harness.h).
"""
from __future__ import annotations

import os
import re
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
UNITY = C_SRC / "gw_fmu.c"
UNITY3 = C_SRC / "gw_fmu3.c"  # the FMI 3.0 FMU's unity file
MODES = ("strict", "sanitizers", "valgrind")
MODE_FLAGS = {
    "strict": ["-O2", "-g"],
    "sanitizers": ["-O1", "-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
                   "-fno-sanitize-recover=all"],
    "valgrind": ["-O1", "-g"],
}
SANITIZER_ENV = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0",
                 "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1"}


def unity_flags(toy: str) -> list[str]:
    """Flags that make c_src/gw_fmu.c (gw_fmu3.c) the runtime with tests/c/toy_<toy>.c as its
    model."""
    return [f"-I{FMI_HEADERS}", f"-I{C_SRC}", f"-I{TESTS_C}", f'-DGW_MODEL_SOURCE="toy_{toy}.c"']


def compile_program(driver: str, toy: str | None, out: Path, extra: list[str],
                    fmi: int | tuple[int, ...] = 2) -> Path:
    """tests/c/test_<driver>.c + c_src/gw_fmu.c (fmi 3: gw_fmu3.c; (2, 3): both, an FMI 2.0
    and an FMI 3.0 FMU of the same toy in one program) with tests/c/toy_<toy>.c -> an
    executable.

    toy None: the driver is a whole program by itself (test_core.c includes its model and the
    core), built without the FMI headers on the include path."""
    exe = out / f"test_{driver}"
    if toy is None:
        sources, flags = [TESTS_C / f"test_{driver}.c"], [f"-I{C_SRC}", f"-I{TESTS_C}"]
    else:
        unities = [{2: UNITY, 3: UNITY3}[k] for k in (fmi if isinstance(fmi, tuple) else (fmi,))]
        sources, flags = [*unities, TESTS_C / f"test_{driver}.c"], unity_flags(toy)
    cmd = ["gcc", *STRICT, *extra, *flags, *map(str, sources), "-lm", "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"compile failed:\n{' '.join(cmd)}\n{r.stdout}{r.stderr}"
    return exe


def writable_symbols(obj: Path) -> list[str]:
    """Symbols of an object file in writable data sections (.data, .bss, common, TLS).

    Constant tables holding pointers sit in .data.rel.ro (read-only once relocated), which
    `nm` also reports as 'd': the section, not the letter, tells what is mutable."""
    r = subprocess.run(["objdump", "-t", str(obj)], capture_output=True, text=True, check=True)
    found = []
    for line in r.stdout.splitlines():
        m = re.match(r"^[0-9a-f]+\s.{7}\s(\S+)\s+[0-9a-f]+\s+(.*)$", line)
        if not m:
            continue
        section, name = m.groups()
        if section.startswith(".data.rel.ro"):
            continue
        if section in (".data", ".bss", "*COM*", ".tdata", ".tbss") or section.startswith((".data.", ".bss.")):
            found.append(f"{name} ({section})")
    return found


def run(cmd: list[str], timeout: float = 900, env: dict | None = None) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert r.returncode == 0, f"{' '.join(cmd)} exited {r.returncode}\n{r.stdout}\n{r.stderr}"
    assert " 0 failures" in r.stderr, r.stderr
    return r


def run_program(driver: str, toy: str | None, out: Path, mode: str,
                fmi: int | tuple[int, ...] = 2) -> subprocess.CompletedProcess:
    """Build in `mode` (strict | sanitizers | valgrind) over the FMI `fmi` unity file and run;
    returns the finished process."""
    return run_built(compile_program(driver, toy, out, MODE_FLAGS[mode], fmi=fmi), mode)


def run_built(exe: Path, mode: str, args: list[str] | None = None) -> subprocess.CompletedProcess:
    """Run a test program built with MODE_FLAGS[mode]: as is, with the sanitizers' options, or
    under valgrind (every error and leak fails); asserts exit 0 and "0 failures"."""
    cmd = [str(exe), *(args or [])]
    if mode == "sanitizers":
        return run(cmd, env=dict(os.environ, **SANITIZER_ENV))
    if mode == "valgrind":
        assert os.path.exists(VALGRIND), "valgrind is required for this test"
        return run([VALGRIND, "-q", "--error-exitcode=1", "--leak-check=full", "--errors-for-leak-kinds=all",
                    *cmd])
    return run(cmd)
