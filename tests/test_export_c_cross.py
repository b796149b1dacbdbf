"""`gyrowheel export-c` for other platforms, and the ensemble library's portability, with zig's C
compiler (PyPI ziglang, the extra gyrowheel[platforms]; zig keeps what it builds in its global
cache, ~/.cache/zig, shared with the FMUs' cross builds):

  test_readme_gives_every_platform    the export's README.md names, for every platform of
                                      gyrowheel.fmu_build.platforms.PLATFORMS, one CMake command
                                      (cmake/zig.cmake) and one zig cc command, and docs/c_api.md
                                      the same commands
  test_aarch64_example_under_qemu     the README's zig cc command for aarch64-linux, strict and
                                      silent; the example under qemu-aarch64 equals the host's gcc
                                      build (earth_gcc) to 1e-12; with -ffp-contract=off byte
                                      for byte
  test_aarch64_cmake_toolchain        the README's CMake command (cmake/zig.cmake) for
                                      aarch64-linux, strict and silent: its example under qemu
                                      equals the host's to 1e-12
  test_compiles_for[platform]         for every other platform the library (through
                                      cmake/zig.cmake) and the examples (zig cc) compile strictly
                                      and silently (compile only: linking Windows and macOS
                                      programs would build their C runtimes first)
  test_ensemble_library_portable      the ensemble library (gw_ensemble_lib.c) compiles strictly for
                                      aarch64-linux (linked) and x86_64-windows; preprocessed for
                                      aarch64 it holds no target_clones, no target attribute and
                                      no x86 intrinsic, for Windows on x86-64 no target_clones nor
                                      target attribute (its clones are x86-64 ELF's)
  test_ensemble_under_qemu            one ensemble of seven trajectories run on aarch64 under qemu
                                      (tests/c/ensemble_driver.c) equals the host's lanes
                                      (gyrowheel.Ensemble) to 1e-12, with the same steps

The qemu tests need Debian's qemu-user and libc6-arm64-cross (/usr/aarch64-linux-gnu): make test
installs them as root.  Cost (2 cores): the module takes 30 s with zig's cache warm, 55 s cold;
each zig compile of a unity file takes 2-5 s, and a cold cache adds zig's aarch64 C runtime and
glibc stubs (about 8 s, once; the FMUs' aarch64 build makes them too) and CMake's compiler checks
(about 10 s).
"""
from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from export_c_helpers import ROOT, STRICT
from gyrowheel.fmu_build.compiler import STANDARD, WARNINGS, optimisation_for
from gyrowheel.fmu_build.export_c import TOOLCHAIN, cross_commands
from gyrowheel.fmu_build.platforms import PLATFORMS, zig_command
from platform_run import AARCH64_ROOT, require, require_aarch64_libc
from gyrowheel.fmu_build.runtime import EXPORT_DIR, RUNTIME_DIR
from gyrowheel.taylor.ensemble import FLAGS, LIBRARY_SOURCE, Ensemble, library_source

ZIG = zig_command("tests/test_export_c_cross.py")  # ziglang, of the [test] extra (gyrowheel[platforms])
ARM_ROOT = AARCH64_ROOT  # Debian libc6-arm64-cross: the aarch64 C library


MODEL = "paper_earth"
# the ensemble run: seven trajectories (two batches of 4 lanes, one lane idle), 2 s of the paper
START, VALUES, T_END, REL_TOL = "gamma_dot", [6.0, 5.0, 4.0, 3.0, 2.0, 1.0, 0.5], 2.0, 1e-10
# what must never reach a compiler off x86: a function-multiversioning or target attribute,
# an x86 intrinsic's header, builtin or vector type
X86_ONLY = re.compile(r"target_clones|__attribute__\s*\(\(\s*target\s*\(|immintrin|[xep]mmintrin|"
                      r"__builtin_ia32|__builtin_cpu_supports|__m(128|256|512)")


def run(cmd, cwd=None, env=None) -> subprocess.CompletedProcess:
    """Run cmd; assert it succeeded (its output is the result's)."""
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, cwd=cwd, env=env)
    assert r.returncode == 0, f"{' '.join(map(str, cmd))}\n{r.stdout}{r.stderr}"
    return r


def on_aarch64(program: Path, *args) -> str:
    """program's stdout, run under qemu-aarch64 with the aarch64 C library (make test installs
    both: a missing one fails the test, naming its Debian package)."""
    require_aarch64_libc()
    return run([require("qemu-aarch64", "qemu-user"), "-L", ARM_ROOT, program, *args]).stdout


def command(text: str) -> list[str]:
    """A README command as argv, `python` being this interpreter."""
    argv = shlex.split(text)
    return [sys.executable, *argv[1:]] if argv[0] == "python" else argv


def with_python_on_path() -> dict:
    """The environment with this interpreter's directory first on PATH: cmake/zig.cmake finds
    zig through the first python3 there (this one has ziglang)."""
    return {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}


def csv(text: str) -> np.ndarray:
    lines = text.splitlines()
    return np.loadtxt(lines[1:], delimiter=",", ndmin=2)


@pytest.fixture(scope="module")
def host_csv(earth_gcc) -> str:
    """The host gcc build's example output (the scene's experiment as CSV)."""
    return run([earth_gcc["example"]]).stdout


@pytest.fixture
def copy(earth, tmp_path) -> Path:
    """A private copy of the export (a build writes into its directory)."""
    return Path(shutil.copytree(earth, tmp_path / MODEL))


def readme_commands(export: Path) -> dict[str, tuple[str, str]]:
    """{platform: (cmake command, zig cc command)} as the export's README.md gives them."""
    text = (export / "README.md").read_text()
    section = text[text.index("## Other platforms"):]
    found = re.findall(r"\(`([\w-]+)`\):\n\n```sh\n(.+)\n(.+)\n```", section)
    return {name: (cmake, cc) for name, cmake, cc in found}


def test_readme_gives_every_platform(earth):
    given = readme_commands(earth)
    assert list(given) == list(PLATFORMS)
    docs = (ROOT / "docs" / "c_api.md").read_text()
    for c in cross_commands(MODEL):
        assert given[c.platform.name] == (c.cmake, c.cc)
        assert f"-DZIG_TARGET={c.platform.zig_target} " in c.cmake and f"-target {c.platform.zig_target} " in c.cc
        assert c.cmake in docs and c.cc in docs, c.platform.name
    assert (earth / TOOLCHAIN).read_bytes() == (EXPORT_DIR / TOOLCHAIN).read_bytes()


# slow (5-10 s): two builds of the whole library for aarch64 (fused and unfused) and two runs under qemu
def test_aarch64_example_under_qemu(copy, host_csv):
    """The README's one command for aarch64-linux, with the strict warnings: silent, an aarch64
    executable whose CSV equals the host's to 1e-12 (measured 2.3e-13, most values differ in
    their last bits: clang fuses multiplies and adds on ARM, gcc's C99 build does not); with
    -ffp-contract=off too (the host runs the Taylor kernel's FMA copy where the CPU has FMA, so
    unfused ARM code need not give the host's bytes)."""
    cc = command(readme_commands(copy)["aarch64-linux"][1])
    out = cc[cc.index("-o") + 1]
    r = run([*cc, *STRICT], cwd=copy)
    assert r.stdout + r.stderr == ""
    assert (copy / out).read_bytes()[:4] == b"\x7fELF" and (copy / out).read_bytes()[18] == 183  # EM_AARCH64
    arm = on_aarch64(copy / out)
    a, h = csv(arm), csv(host_csv)
    assert arm.splitlines()[0] == host_csv.splitlines()[0] and a.shape == h.shape == (2001, 14)
    assert np.max(np.abs(a - h)) <= 1e-12, np.max(np.abs(a - h))

    run([*cc, *STRICT, "-ffp-contract=off", "-o", "unfused"], cwd=copy)
    unfused = csv(on_aarch64(copy / "unfused"))
    assert unfused.shape == h.shape and np.max(np.abs(unfused - h)) <= 1e-12, np.max(np.abs(unfused - h))


# slow (5 s, 20 s with a cold zig cache): CMake's compiler checks link aarch64 test programs, the
# library is built at -O3, then the two examples and a run under qemu
@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake is not installed (make test installs it)")
def test_aarch64_cmake_toolchain(copy, host_csv):
    """cmake/zig.cmake as the README says (zig found through this Python's ziglang), strict:
    the library and both examples for aarch64 without a warning, the example's CSV equal to the
    host's to 1e-12 (measured: the same bytes as the zig cc build's, 2.3e-13 from the host's)."""
    cmake = readme_commands(copy)["aarch64-linux"][0]
    configure, build = (command(part) for part in cmake.split(" && "))
    run([shutil.which("cmake"), *configure[1:], f"-D{MODEL.upper()}_STRICT=ON"], cwd=copy, env=with_python_on_path())
    r = run([shutil.which("cmake"), *build[1:]], cwd=copy)
    assert "warning" not in (r.stdout + r.stderr).lower(), r.stdout + r.stderr
    b = copy / "build-aarch64-linux"
    assert (b / f"{MODEL}_realtime").is_file()
    arm = on_aarch64(b / f"{MODEL}_example")
    a, h = csv(arm), csv(host_csv)
    assert a.shape == h.shape and np.max(np.abs(a - h)) <= 1e-12


@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake is not installed (make test installs it)")
@pytest.mark.parametrize("platform", [p for p in PLATFORMS if p != "aarch64-linux"])  # that one runs, above
def test_compiles_for(platform, copy, tmp_path):
    """For `platform`: the library target through cmake/zig.cmake (CMake's checks compiling
    without linking: a Windows or macOS program would need its C runtime built first) and the
    examples (the real-time one where there is clock_nanosleep: Linux) by zig cc, all with the
    strict warnings, and nothing printed but CMake's progress."""
    target = PLATFORMS[platform].zig_target
    b = tmp_path / "build"
    run([shutil.which("cmake"), "-S", copy, "-B", b, f"-DCMAKE_TOOLCHAIN_FILE={TOOLCHAIN}", f"-DZIG_TARGET={target}",
         "-DCMAKE_BUILD_TYPE=Release", f"-D{MODEL.upper()}_STRICT=ON",
         "-DCMAKE_TRY_COMPILE_TARGET_TYPE=STATIC_LIBRARY"], cwd=copy, env=with_python_on_path())
    r = run([shutil.which("cmake"), "--build", b, "--target", MODEL], cwd=copy)
    assert "warning" not in (r.stdout + r.stderr).lower() and any(b.glob(f"*{MODEL}.*")), r.stdout + r.stderr
    for src in ["examples/main.c", *(["examples/realtime.c"] if platform.endswith("linux") else [])]:
        r = run([*ZIG, "cc", "-target", target, *STRICT, "-O2", "-I.", "-c", src, "-o",
                 tmp_path / (Path(src).stem + ".o")], cwd=copy)
        assert r.stdout + r.stderr == "", f"{platform} {src}:\n{r.stdout}{r.stderr}"


@pytest.fixture(scope="module")
def ensemble_unity(example_build, tmp_path_factory):
    """The paper's FMU with the Taylor kernel (shared with the ensemble tests), and the ensemble
    library's unity file with its front end beside it (as Ensemble compiles them); returns
    (FMU, compiler flags, the unity file, include directories)."""
    built = example_build(MODEL, taylor=True)
    d = tmp_path_factory.mktemp("ensemble_unity")
    shutil.copyfile(RUNTIME_DIR / LIBRARY_SOURCE, d / LIBRARY_SOURCE)
    unity = d / f"{built.identifier}_ensemble.c"
    unity.write_text(library_source(built.identifier, 4))
    flags = [*STANDARD, *optimisation_for(built.sources), *WARNINGS, *FLAGS]  # Ensemble's (compile_shared)
    return built.fmu, flags, unity, [d, built.sources]


def test_ensemble_library_portable(ensemble_unity, tmp_path):
    """Strict and silent for aarch64-linux (linked: a shared library) and x86_64-windows (compiled);
    preprocessed, the aarch64 unit holds nothing x86-only and the Windows unit no target clones
    or target attribute, while the x86-64 Linux unit has its clones and SSE2 intrinsics (what the
    check looks for is there where it belongs)."""
    _, flags, unity, includes = ensemble_unity
    inc = [f"-I{d}" for d in includes]
    arm = PLATFORMS["aarch64-linux"].zig_target
    r = run([*ZIG, "cc", "-target", arm, "-shared", "-fPIC", *flags, *inc, unity, "-o", tmp_path / "lib.so", "-lm"])
    assert r.stdout + r.stderr == "" and (tmp_path / "lib.so").read_bytes()[18] == 183  # EM_AARCH64
    win = PLATFORMS["x86_64-windows"].zig_target
    r = run([*ZIG, "cc", "-target", win, "-c", *flags, *inc, unity, "-o", tmp_path / "lib.obj"])
    assert r.stdout + r.stderr == ""
    found = {}
    for platform in ("aarch64-linux", "x86_64-windows", "x86_64-linux"):
        text = run([*ZIG, "cc", "-target", PLATFORMS[platform].zig_target, "-E", *flags, *inc, unity]).stdout
        assert "ensemble_run_packed" in text
        found[platform] = {re.sub(r"\s", "", m.group(0)) for m in X86_ONLY.finditer(text)}
    assert found["aarch64-linux"] == set()
    # Windows on x86-64: SSE2 (every x86-64 CPU; gw_sincos.h's two lanes), no clones, no other target
    assert not {"target_clones", "__attribute__((target("} & found["x86_64-windows"]
    assert {"target_clones", "emmintrin"} <= found["x86_64-linux"]


# slow (5-10 s): the ensemble library compiled twice at -O3, for aarch64 (with the driver) and for
# the host (gyrowheel.Ensemble)
def test_ensemble_under_qemu(ensemble_unity, tmp_path):
    """Seven trajectories (a batch of 4 lanes, then 3) of the paper wheel, 2 s at rel_tol 1e-10,
    through the library's C entry point on aarch64 under qemu: the status, time, states and steps
    of each equal the host's Ensemble (x86-64, gcc; its x86-64-v3 clones on an AVX2/FMA machine)
    to 1e-12 (measured 2.1e-13; both sides fuse multiplies and adds, in different places)."""
    fmu, flags, unity, includes = ensemble_unity
    driver = tmp_path / "driver"
    run([*ZIG, "cc", "-target", PLATFORMS["aarch64-linux"].zig_target, *flags, *[f"-I{d}" for d in includes],
         f'-DENSEMBLE_UNITY="{unity.name}"', ROOT / "tests" / "c" / "ensemble_driver.c", "-o", driver, "-lm"])
    rows = np.loadtxt(on_aarch64(driver, T_END, REL_TOL, START, *VALUES).splitlines(), ndmin=2)
    host = Ensemble(fmu, cache=tmp_path / "cache").run(T_END, starts={START: VALUES}, rel_tol=REL_TOL)
    assert rows.shape == (len(VALUES), 3 + host.x_final.shape[1])
    np.testing.assert_array_equal(rows[:, 0], host.status)
    np.testing.assert_array_equal(rows[:, -1], host.steps)
    assert np.all(host.status == 0) and np.all(rows[:, 1] == T_END)
    assert np.max(np.abs(rows[:, 2:-1] - host.x_final)) <= 1e-12, np.max(np.abs(rows[:, 2:-1] - host.x_final))
