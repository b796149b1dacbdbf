"""The runtime's layering (docs/runtime.md): a simulation core without FMI, the FMI 2.0 layer on
top, everything in one translation unit.

  test_core_without_fmi         tests/c/test_core.c: the core from a plain C program with a user
                                allocator and logger, no FMI header on the include path (the
                                export-c use), strict / ASan+UBSan / valgrind
  test_only_the_fmi_layer_...   fmi2Functions.h is included by gw_fmi2.h alone, and only the
                                FMI layer includes gw_fmi2.h
  test_each_part_alone_is_empty every c_src/*.c compiled on its own, strictly, is an object
                                without a single symbol: only the unity file defines anything
  test_files_have_one_job       no runtime file past ~600 lines
"""
from __future__ import annotations

import re
import subprocess

import pytest

from c_programs import C_SRC, FMI_HEADERS, MODES, STRICT, run_program

FMI_LAYER = {"gw_fmi2.h", "gw_fmi2_common.c", "gw_fmi2_variables.c", "gw_fmi2_cs.c", "gw_fmi2_me.c",
             "gw_fmi2_dirder.c", "gw_fmi2_state.c", "gw_fmu.c"}


@pytest.mark.parametrize("mode", MODES)
def test_core_without_fmi(mode, tmp_path):
    r = run_program("core", None, tmp_path, mode)
    assert re.search(r"test_core: (\d+) checks, 0 failures", r.stderr), r.stderr


def _includes(path) -> set[str]:
    return set(re.findall(r'^\s*#\s*include\s+"([^"]+)"', path.read_text(), re.M))


def test_only_the_fmi_layer_includes_fmi_headers():
    files = sorted(C_SRC.glob("*.[ch]"))
    assert {p.name for p in files} >= FMI_LAYER
    for path in files:
        inc = _includes(path)
        if path.name == "gw_fmi2.h":
            assert "fmi2Functions.h" in inc
        else:
            assert not any(i.startswith("fmi2") for i in inc), path.name
        if path.name not in FMI_LAYER:  # the core: no FMI name in its code (comments aside)
            code = re.sub(r"/\*.*?\*/", "", path.read_text(), flags=re.S)
            assert "gw_fmi2.h" not in inc and not re.search(r"\bfmi2\w*", code), path.name


def test_each_part_alone_is_empty(tmp_path):
    parts = [p for p in sorted(C_SRC.glob("*.c")) if p.name not in ("gw_fmu.c", "gw_fmu3.c")]
    assert len(parts) >= 18
    for src in parts:
        obj = tmp_path / (src.stem + ".o")
        r = subprocess.run(["gcc", *STRICT, "-Wpedantic", "-c", f"-I{C_SRC}", f"-I{FMI_HEADERS}", str(src),
                            "-o", str(obj)], capture_output=True, text=True)
        assert r.returncode == 0, f"{src.name}:\n{r.stderr}"
        nm = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
        assert nm.strip() == "", f"{src.name} defines symbols on its own:\n{nm}"


def test_files_have_one_job():
    for path in sorted(C_SRC.glob("*.[ch]")):
        n = len(path.read_text().splitlines())
        assert n <= 620, f"{path.name}: {n} lines"
