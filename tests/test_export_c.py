"""`gyrowheel export-c` and the C API it writes (docs/c_api.md).

  test_export_layout                      the files; no FMI layer or header; every part of src/
                                          alone compiles (strict) to an empty object
  test_strict_build_zero_warnings[cc]     library, example and real-time example with -std=c99
                                          -Wall -Wextra -Wpedantic -Werror, gcc and clang: no
                                          diagnostic at all
  test_only_prefixed_symbols              the object exports paper_earth_* only, nothing writable
  test_example_matches_fmu[cc|cmake]      examples/main.c built by plain cc and by the export's
                                          CMakeLists.txt (strict) runs the paper scenario; its CSV
                                          equals fmpy's simulation of the FMU of the same scene and
                                          settings to 1e-12 (measured: 0, bit for bit)
  test_capi[strict|sanitizers|valgrind]   tests/c/test_capi.c: table, create, bad input through
                                          the API with code and message, save/restore and corrupt
                                          buffers, the fall and its time, allocator, threads
  test_capi_errors                        tests/c/test_capi_errors.c: every error reaches the
                                          logger once; euler/rk4 refuse steps the time grid cannot
                                          resolve (t = 1e15), not one silent 0.5 s step, and still
                                          take one step per 1 ms period at t = 1e9 s; an advance
                                          beyond max_internal_steps refused at once by DOPRI5,
                                          DOP853 and RODAS4
  test_docs_quote_the_exports_figures     the state size and allocation count docs/c_api.md
                                          quotes are the export's (tests/c/capi_figures.c)
  test_two_models_side_by_side            paper_earth and lunar_rover objects linked into one
                                          program (tests/c/test_capi_two.c), run interleaved: both
                                          equal their FMUs bit for bit; the slip event's time; a
                                          state of one refused by the other
  test_fast_math_parent_project_keeps_nan_checks
                                          a parent CMake project with -ffast-math: the library
                                          keeps its NaN checks (advance(NaN) is refused, not an
                                          endless loop); plain cc with -ffast-math stops at a
                                          clear #error; the export's examples are not built
                                          inside the parent project
  test_cli_bad_input[...]                 one line `gyrowheel: error: ...`, exit 2
  test_output_errors_name_output[...]     a directory that cannot take the export is named as the
                                          `output` argument (export_c and gyrowheel.export_c)
  test_model_names_refused[...]           names that would break the user's program refused
                                          before anything is written: C23 / C++ keywords,
                                          reserved identifiers, standard header names (time.h on
                                          -I. hides <time.h>), names the C library declares
  test_reexport_replaces_previous         a previous export's files go, the user's stay
  test_reexport_never_adopts_users_files  the user's files (a build/ tree, notes, own sources)
                                          are never recorded as the export's, so no later
                                          re-export deletes them
  test_docs_worked_example                docs/c_api.md's worked example compiles strictly and
                                          prints what the page shows
  test_taylor_scene_exports_its_kernel    a taylor scene exports the Taylor kernel; its example
                                          equals the FMU

The real-time example (examples/realtime.c): tests/test_export_c_realtime.py.
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu

from c_programs import MODE_FLAGS, MODES, TESTS_C, run_built, writable_symbols
from conftest import ROOT, SCENES
from export_c_helpers import STRICT, cc, gyrowheel
from gyrowheel.fmu_build import build_fmu, load_scene
from gyrowheel.fmu_build.export_c import MARKER, ExportError, export_c


@pytest.fixture(scope="module")
def earth_reference(earth_fmu):
    """fmpy's run of the FMU of the same scene at the scene's output interval."""
    return simulate_fmu(str(earth_fmu), output_interval=0.01)


def _scene_named(tmp_path: Path, name: str, scene: str = "paper_earth") -> Path:
    text = (SCENES / f"{scene}.toml").read_text()
    path = tmp_path / f"{name}.toml"
    path.write_text(re.sub(r'(?m)^name = ".*"$', f'name = "{name}"', text, count=1))
    return path


def read_csv(path_or_text) -> np.ndarray:
    return np.genfromtxt(path_or_text, delimiter=",", names=True)


def max_difference(result, fmu_result) -> float:
    assert result.dtype.names == fmu_result.dtype.names and len(result) == len(fmu_result)
    return max(float(np.max(np.abs(result[n] - fmu_result[n].astype(float)))) for n in result.dtype.names)


def test_export_layout(earth, tmp_path):
    files = json.loads((earth / MARKER).read_text())["files"]
    for name in ("paper_earth.h", "paper_earth.c", "gyrowheel_api.h", "CMakeLists.txt", "README.md",
                 "examples/main.c", "examples/realtime.c", "src/gw_funcs.c", "src/model_desc.c",
                 "src/capi_desc.c", "src/gw_core.c", "src/gw_capi.c", "src/gw_solver_rodas4.c", "cmake/zig.cmake"):
        assert name in files and (earth / name).is_file(), name
    assert sorted(p.relative_to(earth).as_posix() for p in earth.rglob("*") if p.name != MARKER) \
        == sorted(files + ["cmake", "examples", "src"])
    for path in earth.rglob("*.[ch]"):  # no file of an FMI layer (2.0 or 3.0), no FMI header
        text = path.read_text()
        assert not re.search(r"fmi[23]|gw_fmu3?\.c", path.name) and not re.search(r'#\s*include\s+"fmi[23]', text), path
    parts = sorted((earth / "src").glob("*.c"))
    assert len(parts) >= 18
    for src in parts:  # the unity build's parts are empty on their own
        obj = tmp_path / (src.stem + ".o")
        cc("gcc", *STRICT, "-c", src, "-o", obj)
        nm = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
        assert nm.strip() == "", f"{src.name} defines symbols on its own:\n{nm}"


@pytest.mark.parametrize("compiler", ["gcc", "clang"])
def test_strict_build_zero_warnings(compiler, earth, earth_gcc, tmp_path):
    if shutil.which(compiler) is None:
        pytest.skip(f"{compiler} is not installed (make test installs it: Debian package {compiler})")
    if compiler == "gcc":  # the fixture's build
        diagnostics = earth_gcc["diagnostics"]
    else:
        obj = tmp_path / "paper_earth.o"
        diagnostics = cc(compiler, *STRICT, "-O2", "-c", earth / "paper_earth.c", "-o", obj).stderr
        for src in ("main.c", "realtime.c"):
            diagnostics += cc(compiler, *STRICT, "-O2", f"-I{earth}", earth / "examples" / src, obj, "-lm",
                              "-o", tmp_path / src[:-2]).stderr
    assert diagnostics == "", diagnostics  # zero warnings


def test_only_prefixed_symbols(earth_gcc):
    nm = subprocess.run(["nm", "--defined-only", "-g", str(earth_gcc["obj"])], capture_output=True, text=True,
                        check=True).stdout
    names = {line.split()[-1] for line in nm.splitlines() if line.strip()}
    assert len(names) >= 30 and all(n.startswith("paper_earth_") for n in names), sorted(names)
    assert {"paper_earth_create", "paper_earth_advance", "paper_earth_restore_state"} <= names
    assert writable_symbols(earth_gcc["obj"]) == []


@pytest.mark.parametrize("build", ["cc", "cmake"])
def test_example_matches_fmu(build, earth, earth_gcc, earth_reference, tmp_path):
    if build == "cc":
        example = earth_gcc["example"]
    else:
        if shutil.which("cmake") is None:
            pytest.skip("cmake is not installed (make test installs it: Debian package cmake)")
        b = tmp_path / "build"
        r = subprocess.run(["cmake", "-S", str(earth), "-B", str(b), "-DCMAKE_BUILD_TYPE=Release",
                            "-DPAPER_EARTH_STRICT=ON"], capture_output=True, text=True)
        assert r.returncode == 0, r.stdout + r.stderr
        r = subprocess.run(["cmake", "--build", str(b)], capture_output=True, text=True)
        assert r.returncode == 0 and "warning" not in r.stdout + r.stderr, r.stdout + r.stderr
        example = b / "paper_earth_example"
        assert (b / "paper_earth_realtime").is_file() and any(b.glob("libpaper_earth.*"))
    r = subprocess.run([str(example)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    result = read_csv(r.stdout.splitlines())
    assert len(result) == 2001 and result["time"][-1] == 20.0
    assert max_difference(result, earth_reference) <= 1e-12


@pytest.mark.parametrize("mode", MODES)
def test_capi(mode, earth, earth_gcc, tmp_path):
    exe = tmp_path / "test_capi"
    # the library as built for users (gcc -O2), except under the sanitizers (instrumented)
    library = earth / "paper_earth.c" if mode == "sanitizers" else earth_gcc["obj"]
    cc("gcc", *STRICT, *MODE_FLAGS[mode], f"-I{earth}", f"-I{TESTS_C}", TESTS_C / "test_capi.c",
       library, "-lm", "-pthread", "-o", exe)
    r = run_built(exe, mode)
    assert re.search(r"test_capi: (\d{4,}) checks, 0 failures", r.stderr), r.stderr


def _run_against_the_export(program: str, earth: Path, earth_gcc: dict, tmp_path: Path) -> str:
    """tests/c/<program>.c built strictly (no diagnostic at all) against the export's library
    object and run: exit 0 and "<program>: N checks, 0 failures" on stderr; returns its stdout."""
    exe = tmp_path / program
    diagnostics = cc("gcc", *STRICT, "-O2", f"-I{earth}", f"-I{TESTS_C}", TESTS_C / f"{program}.c",
                     earth_gcc["obj"], "-lm", "-o", exe).stderr
    assert diagnostics == ""
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and re.search(rf"{program}: \d+ checks, 0 failures", r.stderr), r.stderr
    return r.stdout


def test_capi_errors(earth, earth_gcc, tmp_path):
    """tests/c/test_capi_errors.c: every error reaches the logger once, advances the solver cannot
    take are refused (see the program's header)."""
    _run_against_the_export("test_capi_errors", earth, earth_gcc, tmp_path)


def test_docs_quote_the_exports_figures(earth, earth_gcc, tmp_path):
    """The state size and the allocations of create that docs/c_api.md quotes are the export's,
    as tests/c/capi_figures.c measures them (a user allocator counts the blocks)."""
    stdout = _run_against_the_export("capi_figures", earth, earth_gcc, tmp_path)
    figures = {k: int(v) for k, v in (line.split() for line in stdout.splitlines())}
    assert set(figures) == {"state_size", "blocks"}
    text = (ROOT / "docs" / "c_api.md").read_text()
    size, blocks = figures["state_size"], figures["blocks"]
    assert f"(`state_size` bytes: {size} for paper_earth)" in text
    assert f"buffer of {size - 1} bytes, a state needs {size} (paper_earth_state_size)" in text
    assert f"({blocks} blocks for paper_earth)" in text


@pytest.fixture(scope="module")
def lunar(tmp_path_factory, example_build) -> tuple[Path, Path]:
    """lunar_rover (slip: a warning event; lift-off and fall: terminating) as export and FMU."""
    out = tmp_path_factory.mktemp("lunar")
    export_c(load_scene(SCENES / "lunar_rover.toml"), out / "lunar_rover", check=False)
    return out / "lunar_rover", example_build("lunar_rover").fmu


def test_two_models_side_by_side(earth, earth_gcc, earth_reference, lunar, tmp_path):
    lunar_dir, lunar_fmu = lunar
    objs = [earth_gcc["obj"], tmp_path / "lunar_rover.o"]
    cc("gcc", *STRICT, "-O2", "-c", lunar_dir / "lunar_rover.c", "-o", objs[1])
    exe = tmp_path / "two"
    cc("gcc", *STRICT, "-O2", f"-I{earth}", f"-I{lunar_dir}", f"-I{TESTS_C}", TESTS_C / "test_capi_two.c",
       *objs, "-lm", "-o", exe)
    csvs = [tmp_path / "earth.csv", tmp_path / "lunar.csv"]
    r = run_built(exe, "strict", [str(c) for c in csvs])
    info = dict(line.split(" ", 1) for line in r.stdout.splitlines())
    assert max_difference(read_csv(csvs[0]), earth_reference) <= 1e-12
    lunar_reference = simulate_fmu(str(lunar_fmu), output_interval=0.02)
    lunar_result = read_csv(csvs[1])
    assert max_difference(lunar_result, lunar_reference) <= 1e-12
    # the fall ends both runs at the same time; slipping turned true at 13.94 s (its first firing),
    # and the event's last firing is the short second slip inside one output interval, which
    # Model Exchange (CVODE, tests/test_events_inside_step.py) places at 17.4667946 s
    t_fall, t_slip = float(info["fall_time"]), float(info["slip_time"])
    assert lunar_result["time"][-1] == t_fall and lunar_result["fallen"][-1] == 1
    first = int(np.argmax(lunar_reference["slipping"]))
    assert lunar_reference["time"][first] < t_slip < t_fall
    assert abs(t_slip - 17.4667946) < 1e-6
    assert "do not match this model" in info["cross_restore"]


FAST_MATH_PROGRAM = r"""
#include <math.h>
#include <stdio.h>
#include "paper_earth.h"
int main(void) {
    paper_earth *w = NULL;
    int st;
    if (paper_earth_create(NULL, NULL, NULL, NULL, &w) < 0) return 1;
    st = paper_earth_advance(w, NAN);
    printf("%d\n", st);
    paper_earth_free(w);
    return st == GYROWHEEL_ERR_TIME ? 0 : 1;
}
"""


def test_fast_math_parent_project_keeps_nan_checks(earth, tmp_path):
    """-ffast-math would let the compiler drop the library's NaN checks (advance(NaN) then loops
    for ever): plain cc stops at a clear #error; a parent CMake project built with -ffast-math
    gets a library that keeps them, and the export's examples are not built inside it."""
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed (make test installs it: Debian package cmake)")
    # plain cc: a clear stop, not a library without its checks
    r = subprocess.run(["gcc", *STRICT, "-O2", "-ffast-math", "-fsyntax-only", str(earth / "paper_earth.c")],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "compile it with -fno-finite-math-only" in r.stderr, r.stderr
    # a parent CMake project built with -ffast-math
    project = tmp_path / "rig"
    project.mkdir()
    (project / "main.c").write_text(FAST_MATH_PROGRAM)
    (project / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.13)\nproject(rig C)\n"
        f'add_subdirectory("{earth}" paper_earth)\n'
        "add_executable(rig main.c)\ntarget_link_libraries(rig PRIVATE paper_earth)\n")
    build = tmp_path / "build"
    r = subprocess.run(["cmake", "-S", str(project), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                        "-DCMAKE_C_FLAGS=-ffast-math", "-DPAPER_EARTH_STRICT=ON"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    r = subprocess.run(["cmake", "--build", str(build), "--target", "rig"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    r = subprocess.run([str(build / "rig")], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0 and r.stdout.strip() == str(-5), r.stdout + r.stderr
    targets = subprocess.run(["cmake", "--build", str(build), "--target", "help"], capture_output=True,
                             text=True).stdout
    assert "paper_earth_example" not in targets and "paper_earth_realtime" not in targets


@pytest.mark.parametrize("case,fragment", [
    ("missing", "missing.toml: no such scene file"),
    ("file", "exists and is not a directory"),
    ("not_empty", "not empty and not a gyrowheel export"),
    ("keyword", "model name 'double' is a C keyword"),
    ("reserved", "model name 'gw_wheel' starts with a prefix the runtime reserves"),
])
def test_cli_bad_input(case, fragment, tmp_path):
    scene, out = SCENES / "paper_earth.toml", tmp_path / "out"
    if case == "missing":
        scene = tmp_path / "missing.toml"
    elif case == "file":
        out.write_text("a file")
    elif case == "not_empty":
        out.mkdir()
        (out / "CMakeLists.txt").write_text("# the user's own\n")
    else:
        scene = _scene_named(tmp_path, "double" if case == "keyword" else "gw_wheel")
    r = gyrowheel("export-c", scene, "-o", out)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("gyrowheel: error: ") and fragment in r.stderr, r.stderr
    if case == "not_empty":
        assert (out / "CMakeLists.txt").read_text() == "# the user's own\n"


@pytest.mark.parametrize("case,fragment", [
    ("file", "exists and is not a directory; the export is a directory (choose a new or empty one)"),
    ("not_empty", "not empty and not a gyrowheel export; choose a new or empty directory"),
    ("marker", f"its {MARKER} is unreadable; remove the directory to export into it"),
])
def test_output_errors_name_output(case, fragment, tmp_path):
    import gyrowheel as api
    scene = load_scene(SCENES / "paper_moon.toml")
    out = tmp_path / "m.fmu"  # export_c(S, "m.fmu") with m.fmu an FMU beside it
    if case == "file":
        out.write_bytes(b"PK\x03\x04 an FMU")
    else:
        out.mkdir()
        (out / ("notes.txt" if case == "not_empty" else MARKER)).write_text("mine")
    for export in (export_c, api.export_c):
        with pytest.raises(ExportError) as err:
            export(scene, out, check=False)
        assert str(err.value) == f"output {out}: {fragment}" and err.value.argument == "output"


@pytest.mark.parametrize("name,fragment", [
    ("new", "'new' is a C++ keyword"),
    ("bool", "'bool' is a C keyword"),
    ("_wheel", "reserved identifier"),
    ("my__wheel", "reserved identifier"),
    ("time", "would make time.h hide the system header <time.h>"),
    ("Math", "would make Math.h hide the system header <math.h> (on a case-insensitive"),
    ("system", "declared by the C library's header <stdlib.h>"),
    ("log", "declared by the C library's header <math.h>"),
])
def test_model_names_refused(name, fragment, tmp_path):
    """Names that would break the user's program: C23 / C++ keywords, reserved identifiers,
    standard header names (time.h on -I. hides <time.h>), names the C library declares."""
    out = tmp_path / "out"
    with pytest.raises(ExportError, match=re.escape(fragment)):
        export_c(load_scene(_scene_named(tmp_path, name)), out)
    assert not out.exists()  # nothing written


def test_model_name_refused_on_the_command_line(tmp_path):
    r = gyrowheel("export-c", _scene_named(tmp_path, "clock"), "-o", tmp_path / "out")
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert r.stderr.startswith("gyrowheel: error: ") and "<time.h>" in r.stderr


def test_reexport_replaces_previous(earth, tmp_path):
    out = tmp_path / "export"
    shutil.copytree(earth, out)
    (out / "notes.txt").write_text("mine")
    result = export_c(load_scene(_scene_named(tmp_path, "other_wheel")), out, check=False)
    assert result.identifier == "other_wheel"
    assert not (out / "paper_earth.h").exists() and not (out / "paper_earth.c").exists()
    assert (out / "other_wheel.h").is_file() and (out / "notes.txt").read_text() == "mine"
    assert "other_wheel_create" in (out / "other_wheel.h").read_text()


def test_reexport_never_adopts_users_files(tmp_path):
    """The user's files in the export's directory (a build/ tree, notes, own sources) are never
    recorded as the export's, so no later re-export deletes them."""
    out = tmp_path / "export"
    first = export_c(load_scene(SCENES / "paper_earth.toml"), out, check=False)
    mine = {"notes.txt": "mine", "build/CMakeCache.txt": "# cmake", "mycode/app.c": "int app;\n",
            "src/my_extra.c": "int extra;\n"}
    for rel, text in mine.items():
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_text(text)
    second = export_c(load_scene(SCENES / "paper_earth.toml"), out, check=False)
    third = export_c(load_scene(_scene_named(tmp_path, "other_wheel")), out, check=False)
    for rel, text in mine.items():
        assert (out / rel).read_text() == text, rel
    recorded = json.loads((out / MARKER).read_text())["files"]
    assert recorded == third.files and not set(mine) & set(recorded)
    assert len(first.files) == len(second.files) == len(third.files)  # the first is a fresh export's
    assert not (out / "paper_earth.h").exists() and (out / "other_wheel.h").is_file()


def test_docs_worked_example(earth, earth_gcc, tmp_path):
    text = (ROOT / "docs" / "c_api.md").read_text()
    section = text[text.index("## Worked example"):]
    code = re.search(r"```c\n(.*?)```", section, re.S).group(1)
    shown = re.search(r"```text\n(.*?)```", section, re.S).group(1)
    (tmp_path / "coin.c").write_text(code)
    diagnostics = cc("gcc", *STRICT, "-O2", f"-I{earth}", tmp_path / "coin.c", earth_gcc["obj"], "-lm",
                     "-o", tmp_path / "coin").stderr
    assert diagnostics == ""
    r = subprocess.run([str(tmp_path / "coin")], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout == shown, r.stdout + r.stderr


def test_taylor_scene_exports_its_kernel(tmp_path):
    """A scene whose solver is taylor exports the Taylor kernel with the model (as its FMU
    carries it), strict-clean, and the example's run equals the FMU's (same C, same solver)."""
    text = (SCENES / "paper_earth.toml").read_text()
    assert "solver =" not in text  # auto
    scene_file = tmp_path / "paper_taylor.toml"
    scene_file.write_text(text.replace("[experiment]\n", '[experiment]\nsolver = "taylor"\n').replace(
        'name = "paper_earth"', 'name = "paper_taylor"'))
    scene = load_scene(scene_file)
    res = export_c(scene, tmp_path / "export", check=True)
    src = res.directory / "src"
    assert "GW_TL_NVAR" in (src / "gw_taylor_model.h").read_text()
    assert ".taylor = {gw_tl1_jet" in (src / "model_desc.c").read_text()
    exe = tmp_path / "example"
    cc("gcc", *STRICT, "-O2", f"-I{res.directory}", res.directory / "examples" / "main.c",
       res.directory / f"{res.identifier}.c", "-lm", "-o", exe)
    r = subprocess.run([str(exe)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    result = read_csv(r.stdout.splitlines())
    fmu = build_fmu(scene, tmp_path / "paper_taylor.fmu").fmu
    assert max_difference(result, simulate_fmu(str(fmu), output_interval=0.01)) <= 1e-12
