"""`gyrowheel export-c` built by a user with sanitizers, and the Taylor code of an export
(docs/c_api.md, "Building with sanitizers").

  test_example_under_sanitizer[export-compiler-sanitizer]
                              examples/main.c and <model>.c of a scene without the Taylor kernel
                              (paper_earth) and of one with it (the same scene, solver taylor),
                              built strictly (-std=c99 -Wall -Wextra -Wpedantic -Werror) with
                              -fsanitize=thread, address plus undefined (gcc and clang) and memory
                              (clang): exit 0, nothing on stderr, and the CSV byte for byte the one
                              of the same build without the sanitizer
  test_only_prefixed_symbols_with_each_compiler[...]
                              the export's object defines only <model>_* external symbols, gcc and
                              clang, with and without the kernel (no `<name>.resolver`)
  test_no_taylor_code_without_a_kernel
                              a scene without the Taylor kernel exports no file and compiles no
                              function of solver taylor's; the taylor scene's export has both
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from conftest import SCENES, shared_build
from export_c_helpers import STRICT, cc
from gyrowheel.fmu_build import load_scene
from gyrowheel.fmu_build.builder import TAYLOR_ONLY
from gyrowheel.fmu_build.export_c import export_c

# ASan and UBSan share one build; MSan only where the compiler has it (clang)
SANITIZERS = {"gcc": ["thread", "address,undefined"], "clang": ["thread", "address,undefined", "memory"]}
FLAGS = ["-O1", "-g", "-fno-omit-frame-pointer"]
SANITIZER_ENV = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0", "UBSAN_OPTIONS": "print_stacktrace=1",
                 "TSAN_OPTIONS": "halt_on_error=1", "MSAN_OPTIONS": "halt_on_error=1"}


@pytest.fixture(scope="session")
def exports(tmp_path_factory) -> dict[str, Path]:
    """paper_earth with solver dopri5 (no Taylor kernel) and with solver taylor (the kernel),
    exported once per test run."""
    def make(d: Path) -> dict[str, Path]:
        text = (SCENES / "paper_earth.toml").read_text()
        assert "solver =" not in text and "[experiment]\n" in text  # the default, auto
        scenes = {}
        for kind, solver in (("no_kernel", "dopri5"), ("kernel", "taylor")):
            scenes[kind] = d / f"paper_{kind}.toml"
            scenes[kind].write_text(text.replace("[experiment]\n", f'[experiment]\nsolver = "{solver}"\n').replace(
                'name = "paper_earth"', f'name = "paper_{kind}"'))
        return {kind: export_c(load_scene(path), d / kind, check=False).directory for kind, path in scenes.items()}
    return shared_build(tmp_path_factory, "export_c_sanitizers", make)


def _model(export: Path) -> str:
    return next(export.glob("*.c")).stem


def _example(compiler: str, export: Path, exe: Path, *flags: str) -> subprocess.CompletedProcess:
    """examples/main.c with <model>.c, strictly (no diagnostic at all), then run."""
    diagnostics = cc(compiler, *STRICT, *FLAGS, *flags, f"-I{export}", export / "examples" / "main.c",
                     export / f"{_model(export)}.c", "-lm", "-o", exe).stderr
    assert diagnostics == "", diagnostics
    return subprocess.run([str(exe)], capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, **SANITIZER_ENV))


@pytest.mark.parametrize("compiler,sanitizer", [(c, s) for c, ss in SANITIZERS.items() for s in ss])
@pytest.mark.parametrize("which", ["no_kernel", "kernel"])
def test_example_under_sanitizer(which, compiler, sanitizer, exports, tmp_path):
    # two builds of about 2 s each (compiler time): the instrumented one and its plain twin
    if shutil.which(compiler) is None:
        pytest.skip(f"{compiler} is not installed (make test installs it: Debian package {compiler})")
    export = exports[which]
    plain = _example(compiler, export, tmp_path / "plain")
    assert plain.returncode == 0 and plain.stderr == "", plain.stderr
    run = _example(compiler, export, tmp_path / "instrumented", f"-fsanitize={sanitizer}",
                   "-fno-sanitize-recover=all")
    assert run.returncode == 0, f"exit {run.returncode}\n{run.stderr[-3000:]}"
    assert run.stderr == ""  # no report, no warning
    assert run.stdout == plain.stdout  # bit for bit: 17 significant digits of every value
    assert len(run.stdout.splitlines()) == 2002  # header, t = 0 .. 20 s every 10 ms


@pytest.mark.parametrize("compiler", ["gcc", "clang"])
@pytest.mark.parametrize("which", ["no_kernel", "kernel"])
def test_only_prefixed_symbols_with_each_compiler(which, compiler, exports, tmp_path):
    if shutil.which(compiler) is None:
        pytest.skip(f"{compiler} is not installed (make test installs it: Debian package {compiler})")
    export = exports[which]
    model = _model(export)
    obj = tmp_path / f"{model}.o"
    cc(compiler, *STRICT, "-O2", "-c", export / f"{model}.c", "-o", obj)
    nm = subprocess.run(["nm", "--defined-only", "-g", str(obj)], capture_output=True, text=True,
                        check=True).stdout
    names = {line.split()[-1] for line in nm.splitlines() if line.strip()}
    assert {f"{model}_create", f"{model}_advance"} <= names
    assert all(n.startswith(f"{model}_") for n in names), sorted(n for n in names if not n.startswith(model))


def test_no_taylor_code_without_a_kernel(exports, tmp_path):
    symbols = {}
    for which, export in exports.items():
        model = _model(export)
        files = {p.name for p in (export / "src").iterdir()}
        assert not files & {n for n in TAYLOR_ONLY if n.startswith("gw_ensemble")}  # never the ensemble's
        if which == "no_kernel":
            assert not files & TAYLOR_ONLY
        else:
            assert {"gw_taylor_ops.h", "gw_solver_taylor_step.h"} <= files
        obj = tmp_path / f"{model}.o"
        cc("gcc", *STRICT, "-O2", "-c", export / f"{model}.c", "-o", obj)
        nm = subprocess.run(["nm", "--defined-only", str(obj)], capture_output=True, text=True, check=True).stdout
        symbols[which] = {line.split()[-1] for line in nm.splitlines() if line.strip()}
    taylor = re.compile(r"gw_tl\d|gw_taylor_")
    assert not {n for n in symbols["no_kernel"] if taylor.match(n)}
    assert {n for n in symbols["kernel"] if taylor.match(n)}
    assert not {n for names in symbols.values() for n in names if n.endswith(".resolver")}
