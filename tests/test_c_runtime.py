"""Tests of the generic C runtime (c_src/) with hand-written toy models (tests/c/).

Each C test program links the runtime with one toy model satisfying c_src/gw_model.h
(no CasADi, nothing loaded dynamically; both in the one translation unit c_src/gw_fmu.c)
and calls the fmi2* functions like an importer, with counting allocators and a capturing
logger.  Every program is built
with the strict flags of the project and, separately, with AddressSanitizer and
UndefinedBehaviorSanitizer, and run under valgrind.  Everything is built in tmp_path.
"""

from __future__ import annotations

import ctypes
import re
import subprocess
from pathlib import Path

import pytest

from c_programs import (C_SRC, FMI_HEADERS, MODES, STRICT, TESTS_C, UNITY, run_program, unity_flags,
                        writable_symbols)

PROGRAMS = {"oscillator": "oscillator", "oscillator_simulation": "oscillator",  # driver -> toy model
            "warn": "warn", "decay": "decay", "stickslip": "stickslip"}


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("driver", PROGRAMS)
def test_program(driver, mode, tmp_path):
    run_program(driver, PROGRAMS[driver], tmp_path, mode)


def fmi2_function_names() -> set[str]:
    text = (FMI_HEADERS / "fmi2Functions.h").read_text()
    names = set(re.findall(r"FMI2_Export\s+fmi2\w+TYPE\s+(fmi2\w+)\s*;", text))
    assert len(names) >= 40
    return names


def build_shared(tmp_path: Path) -> Path:
    """The toy oscillator FMU's library, default visibility (no -fvisibility flag)."""
    lib = tmp_path / "oscillator.so"
    cmd = ["gcc", *STRICT, "-O2", "-fPIC", "-shared", *unity_flags("oscillator"), str(UNITY),
           "-lm", "-o", str(lib)]
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
    """The runtime's object file holds no writable data (no .data / .bss symbols)."""
    for src in [UNITY]:  # the whole runtime (and a toy model) in its one translation unit
        obj = tmp_path / (src.stem + ".o")
        r = subprocess.run(["gcc", *STRICT, "-O2", "-c", *unity_flags("oscillator"), str(src),
                            "-o", str(obj)], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        writable = writable_symbols(obj)
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
    # the model defines GW_MODEL with internal linkage in the unit (no extern object anywhere)
    assert "static const gw_model GW_MODEL = { ... };" in (C_SRC / "gw_model.h").read_text()
    for path in list(C_SRC.glob("*.[ch]")):
        assert "extern const gw_model" not in path.read_text(), path
