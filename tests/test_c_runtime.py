"""Tests of the generic C runtime (c_src/) with hand-written toy models (tests/c/).

Each C test program links the runtime with one toy model satisfying c_src/gw_model.h
(no CasADi, nothing loaded dynamically) and calls the fmi2* functions like an
importer, with counting allocators and a capturing logger.  Every program is built
with the strict flags of the project and, separately, with AddressSanitizer and
UndefinedBehaviorSanitizer, and run under valgrind.  Everything is built in tmp_path.
"""

from __future__ import annotations

import ctypes
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
PROGRAMS = ["oscillator", "warn", "decay"]


def runtime_sources() -> list[Path]:
    return sorted(C_SRC.glob("*.c"))


def compile_program(name: str, out: Path, extra: list[str]) -> Path:
    exe = out / f"test_{name}"
    cmd = [
        "gcc", *STRICT, *extra,
        f"-I{FMI_HEADERS}", f"-I{C_SRC}", "-fvisibility=hidden",
        *map(str, runtime_sources()),
        str(TESTS_C / f"toy_{name}.c"), str(TESTS_C / f"test_{name}.c"),
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


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    return tmp_path_factory.mktemp("c_runtime")


@pytest.mark.parametrize("name", PROGRAMS)
def test_strict_build_and_run(builds, name):
    exe = compile_program(name, builds, ["-O2", "-g"])
    run([str(exe)])


@pytest.mark.parametrize("name", PROGRAMS)
def test_sanitizers(builds, name, tmp_path):
    exe = compile_program(
        name, tmp_path,
        ["-O1", "-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
         "-fno-sanitize-recover=all"],
    )
    env = dict(os.environ, ASAN_OPTIONS="detect_leaks=1:abort_on_error=0",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1")
    run([str(exe)], env=env)


@pytest.mark.parametrize("name", PROGRAMS)
def test_valgrind(builds, name, tmp_path):
    assert os.path.exists(VALGRIND), "valgrind is required for this test"
    exe = compile_program(name, tmp_path, ["-O1", "-g"])
    run([VALGRIND, "-q", "--error-exitcode=1", "--leak-check=full",
         "--errors-for-leak-kinds=all", str(exe)])


def fmi2_function_names() -> set[str]:
    text = (FMI_HEADERS / "fmi2Functions.h").read_text()
    names = set(re.findall(r"FMI2_Export\s+fmi2\w+TYPE\s+(fmi2\w+)\s*;", text))
    assert len(names) >= 40
    return names


def build_shared(tmp_path: Path) -> Path:
    lib = tmp_path / "oscillator.so"
    cmd = ["gcc", *STRICT, "-O2", "-fPIC", "-shared", "-fvisibility=hidden",
           f"-I{FMI_HEADERS}", f"-I{C_SRC}", *map(str, runtime_sources()),
           str(TESTS_C / "toy_oscillator.c"), "-lm", "-o", str(lib)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return lib


def test_exports_exactly_the_fmi2_functions(tmp_path):
    lib = build_shared(tmp_path)
    r = subprocess.run(["nm", "-D", "--defined-only", str(lib)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    exported = {line.split()[-1] for line in r.stdout.splitlines()
                if line.split() and line.split()[-2] in "TDBRW"}
    assert exported == fmi2_function_names()
    # the plain names, callable through ctypes
    dll = ctypes.CDLL(str(lib))
    dll.fmi2GetVersion.restype = ctypes.c_char_p
    assert dll.fmi2GetVersion() == b"2.0"
    dll.fmi2GetTypesPlatform.restype = ctypes.c_char_p
    assert dll.fmi2GetTypesPlatform() == b"default"


def test_no_global_mutable_state(tmp_path):
    """The runtime's object files hold no writable data (no .data / .bss symbols)."""
    for src in runtime_sources():
        obj = tmp_path / (src.stem + ".o")
        r = subprocess.run(["gcc", *STRICT, "-O2", "-c", "-fvisibility=hidden",
                            f"-I{FMI_HEADERS}", f"-I{C_SRC}", str(src), "-o", str(obj)],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        r = subprocess.run(["nm", str(obj)], capture_output=True, text=True)
        writable = [line for line in r.stdout.splitlines()
                    if len(line.split()) == 3 and line.split()[1] in "BbDdCGgSs"]
        assert not writable, f"{src.name}: writable globals {writable}"
        # and the section sizes agree: nothing in .data or .bss
        r = subprocess.run(["size", "-A", str(obj)], capture_output=True, text=True)
        for line in r.stdout.splitlines():
            parts = line.split()
            if parts and parts[0] in (".data", ".bss"):
                assert int(parts[1]) == 0, f"{src.name}: {line}"


def test_sources_are_clean():
    """No function prefix, no copied FMI headers, gw_model.h is the contract."""
    for path in list(C_SRC.glob("*.[ch]")) + list(TESTS_C.glob("*.[ch]")):
        text = path.read_text()
        assert "#define FMI2_FUNCTION_PREFIX" not in text, path
    assert not list(C_SRC.glob("fmi2*.h")), "FMI headers must come from fmpy, not a copy"
    assert "extern const gw_model GW_MODEL;" in (C_SRC / "gw_model.h").read_text()
