"""The generated wheel code and the runtime together, under ASan/UBSan and valgrind.

tests/c/test_wheel.c includes the FMU's unity file sources/gw_fmu.c (it reads GW_MODEL, which
has internal linkage), so the program is one translation unit built with the strict flags and
nothing that silences the generated code's warnings."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from c_programs import FMI_HEADERS, SANITIZER_ENV, STRICT, TESTS_C, VALGRIND, run


@pytest.fixture(scope="module")
def wheel_sources(earth_build) -> Path:
    return earth_build.sources


def _compile(sources: Path, out: Path, extra: list[str]) -> Path:
    exe = out / "test_wheel"
    cmd = ["gcc", *STRICT, *extra, f"-I{FMI_HEADERS}", f"-I{sources}", f"-I{TESTS_C}",
           str(TESTS_C / "test_wheel.c"), "-lm", "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"{' '.join(cmd)}\n{r.stdout}{r.stderr}"
    return exe


def test_wheel_under_sanitizers(wheel_sources, tmp_path):
    exe = _compile(wheel_sources, tmp_path, ["-O1", "-g", "-fno-omit-frame-pointer",
                                             "-fsanitize=address,undefined", "-fno-sanitize-recover=all"])
    run([str(exe)], env=dict(os.environ, **SANITIZER_ENV))


def test_wheel_under_valgrind(wheel_sources, tmp_path):
    exe = _compile(wheel_sources, tmp_path, ["-O1", "-g"])
    run([VALGRIND, "-q", "--error-exitcode=1", "--leak-check=full", "--errors-for-leak-kinds=all", str(exe)])
