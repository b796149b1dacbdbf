"""The FMU's binaries for other platforms, run here: the paper scene's FMU with binaries for
every platform of `all` (tests/conftest.py all_platforms_build), its x86_64-linux, aarch64-linux
and x86_64-windows libraries each loaded by tests/platform_driver/fmu_driver.c built for the
same platform, and run natively, under qemu-user (qemu-aarch64 with Debian's aarch64 C library)
and under Wine.

Two runs on each: the paper scenario (the scene's experiment, with the scene's solver and with
solver taylor: the FMU carries the Taylor kernel) and a fall.  The states at every
communication point equal the x86_64-linux binary's (the reference, natively) to 1e-12: absolute
for a value below 1 in magnitude, relative above (|a - b| <= 1e-12 max(1, |ref|): x, y in m and
beta in rad stay below 1, alpha and gamma grow past 100 rad, the rates reach a few rad/s).  Measured: aarch64's dopri5
differs by at most 1.5e-13 (its fused multiply-adds), its taylor run not at all; Windows' taylor
by at most 3e-14 (the portable copy of the kernel, the only one zig's binaries carry), its dopri5 not
at all.
"""
from __future__ import annotations

import math
import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

from gyrowheel.fmu_build import load_scene
from gyrowheel.fmu_build.platforms import PLATFORMS

from conftest import PAPER, SCENES, STATES, critical_spin
from platform_run import (AARCH64_ROOT, require, require_aarch64_libc, run_driver, run_quietly, wine_command,
                          windows_path)

TOL = 1e-12
# A fall: nearly upright (0.6 degrees of lean), spinning at 2 rad/s, below the critical spin
# of upright rolling (5.08 rad/s for the paper wheel, gyrowheel.model.steady.critical_spin), so
# the lean grows (about e^(6 t)); the wheel counts as fallen at beta_min = 0.6 rad, at 0.816 s.
FALL = {"beta": 1.56, "gamma_dot": 2.0, "beta_min": 0.6}
SOLVERS = ("scene", "taylor")
EMULATED = ("aarch64-linux", "x86_64-windows")


@pytest.fixture(scope="module")
def fmu(all_platforms_build, tmp_path_factory):
    """The unpacked FMU, its value references by name, its solver enumeration and experiment."""
    root = tmp_path_factory.mktemp("fmu")
    with zipfile.ZipFile(all_platforms_build.fmu) as z:
        z.extractall(root)
    md = read_model_description(str(all_platforms_build.fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    solvers = {i.name: int(i.value) for t in md.typeDefinitions if t.name == "Solver" for i in t.items}
    return dict(root=root, guid=md.guid, vr=vr, solvers=solvers, identifier=all_platforms_build.identifier,
                experiment=load_scene(SCENES / "paper_earth.toml").experiment)


@pytest.fixture(scope="module")
def wine_env(tmp_path_factory):
    """A private Wine prefix for this run (WINEDEBUG=-all; mscoree and mshtml off, so the first
    start installs neither Mono nor Gecko).  Slow once: the first start creates the prefix
    (measured 2 to 9 s, 6 s typical; about 700 MB, removed at the end with its wineserver
    stopped); each run after it takes 0.02-0.04 s."""
    wine = wine_command()
    prefix = tmp_path_factory.mktemp("wineprefix")
    env = {"WINEPREFIX": str(prefix), "WINEDEBUG": "-all", "WINEDLLOVERRIDES": "mscoree,mshtml="}
    server = shutil.which("wineserver") or "/usr/lib/wine/wineserver64"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "timeout": 60, "env": {**os.environ, **env}}
    # one wineserver for the module's runs (-p: until killed), so that Wine's services start once
    subprocess.run([server, "-p"], **quiet)
    status, _, stderr, first_start = run_quietly([wine, "cmd", "/c", "exit"], env, timeout=300)
    assert status == 0, f"Wine's first start in {prefix}: {stderr}"
    yield {"wine": wine, "env": env, "first_start_seconds": first_start}
    subprocess.run([server, "-k"], **quiet)
    shutil.rmtree(prefix, ignore_errors=True)


@pytest.fixture(scope="module")
def run(fmu, platform_drivers, request):
    """run(platform, case, solver, cpu=None): fmu_driver on `platform`'s binary of the FMU (for
    case 'paper' or 'fall', solver 'scene' or 'taylor'), memoised; cpu: qemu-x86_64's -cpu for
    the x86_64-linux binary."""
    memo: dict = {}
    ex = fmu["experiment"]
    vr = fmu["vr"]

    def _run(platform: str, case: str, solver: str, cpu: str | None = None):
        key = (platform, case, solver, cpu)
        if key in memo:
            return memo[key]
        p = PLATFORMS[platform]
        library = fmu["root"] / "binaries" / p.fmi2_dir / f"{fmu['identifier']}{p.extension}"
        resources = fmu["root"] / "resources"
        settings = [f"i:{vr['solver']}={fmu['solvers'][ex.solver if solver == 'scene' else solver]}"]
        if case == "fall":
            settings += [f"r:{vr[name]}={value!r}" for name, value in FALL.items()]
        tail = [repr(0.0), repr(ex.stop_time), repr(ex.output_interval), repr(ex.rel_tol),
                ",".join(str(vr[s]) for s in STATES), *settings]
        driver = platform_drivers[platform]
        env = None
        if platform == "x86_64-linux":
            head = [require("qemu-x86_64", "qemu-user"), "-cpu", cpu] if cpu else []
            command = [*head, str(driver), str(library), fmu["guid"], resources.as_uri(), *tail]
        elif platform == "aarch64-linux":
            qemu = require("qemu-aarch64", "qemu-user")
            require_aarch64_libc()
            command = [qemu, "-L", str(AARCH64_ROOT), str(driver), str(library), fmu["guid"], resources.as_uri(),
                       *tail]
        else:
            wine = request.getfixturevalue("wine_env")
            env = wine["env"]
            command = [wine["wine"], windows_path(driver), windows_path(library), fmu["guid"],
                       "file:///" + windows_path(resources).replace("\\", "/"), *tail]
        memo[key] = run_driver(command, env=env)
        return memo[key]
    return _run


def largest_difference(got, ref) -> float:
    """The largest |a - b| / max(1, |b|) over every state at every communication point; the
    rows' times must be the same (to TOL: the last row of a fall is at the fall)."""
    assert len(got.rows) == len(ref.rows), (len(got.rows), len(ref.rows))
    worst = 0.0
    for a, b in zip(got.rows, ref.rows):
        assert abs(a[0] - b[0]) <= TOL, (a[0], b[0])
        worst = max([worst, *(abs(x - y) / max(1.0, abs(y)) for x, y in zip(a[1:], b[1:]))])
    return worst


def test_fall_start_is_below_the_critical_spin():
    """The fall's start values fall for a reason the physics gives: upright rolling is unstable
    below the critical spin."""
    assert FALL["gamma_dot"] < critical_spin(*(PAPER[k] for k in ("M", "R", "k_diam", "k_axial", "g")))


@pytest.mark.parametrize("solver", SOLVERS)
def test_reference_runs(run, fmu, solver):
    """The x86_64-linux binary natively: the paper run reaches the stop time upright, the fall
    ends the run at the fall (fmi2Terminated) well inside the experiment."""
    paper = run("x86_64-linux", "paper", solver)
    ex = fmu["experiment"]
    assert paper.fall is None and paper.rows[-1][0] == ex.stop_time
    assert len(paper.rows) == round(ex.stop_time / ex.output_interval) + 1
    fall = run("x86_64-linux", "fall", solver)
    assert fall.terminated and 0.5 < fall.fall < 1.2, fall.fall
    beta = fall.rows[-1][1 + STATES.index("beta")]
    assert fall.rows[-1][0] == fall.fall and math.isclose(beta, FALL["beta_min"], abs_tol=1e-9), beta


@pytest.mark.parametrize("platform", EMULATED)
@pytest.mark.parametrize("case", ("paper", "fall"))
@pytest.mark.parametrize("solver", SOLVERS)
def test_platform_equals_reference(run, platform, case, solver):
    """aarch64-linux (qemu-user) and x86_64-windows (Wine): every state at every communication
    point equals the reference to TOL; a fall happens at the reference's time (to TOL, absolute)."""
    ref, got = run("x86_64-linux", case, solver), run(platform, case, solver)
    assert largest_difference(got, ref) <= TOL
    assert got.terminated == ref.terminated
    if case == "fall":
        assert abs(got.fall - ref.fall) <= TOL, (got.fall, ref.fall)


def test_qemu64_has_no_avx2_or_fma(platform_drivers):
    """The premise of the test below: qemu-x86_64 -cpu qemu64 shows a CPU without AVX2 and FMA to
    the compiler's runtime (libgcc's __builtin_cpu_supports, as the FMU's binary asks it)."""
    status, stdout, stderr, _ = run_quietly([require("qemu-x86_64", "qemu-user"), "-cpu", "qemu64",
                                             str(platform_drivers["x86_64-linux"]), "--cpu"])
    assert status == 0 and stdout.split() == ["avx2=0", "fma=0"], (stdout, stderr)


@pytest.mark.parametrize("case", ("paper", "fall"))
def test_x86_64_without_avx2_runs_the_portable_kernel(run, case):
    """The x86_64-linux binary on a CPU without AVX2 and FMA (qemu-x86_64 -cpu qemu64) runs
    solver taylor: the kernel's CPU check picks the portable copy (the copy for AVX2 with FMA
    would end the run with an illegal instruction), whose results equal the reference's (the
    fused copy on this machine's CPU; measured: 3e-14 apart at most) to TOL."""
    ref, got = run("x86_64-linux", case, "taylor"), run("x86_64-linux", case, "taylor", cpu="qemu64")
    assert largest_difference(got, ref) <= TOL
    if case == "fall":
        assert abs(got.fall - ref.fall) <= TOL


def test_windows_taylor_runs_under_wine(run, platform_drivers, wine_env):
    """The Windows DLL runs solver taylor under Wine to the reference's results (the paper run
    also in test_platform_equals_reference)."""
    ref, got = run("x86_64-linux", "fall", "taylor"), run("x86_64-windows", "fall", "taylor")
    assert largest_difference(got, ref) <= TOL and got.fall == pytest.approx(ref.fall, abs=TOL)


def test_zig_binaries_run_the_portable_kernel(run):
    """zig's binaries carry the portable copy of the Taylor kernel only (platforms.ZIG_DEFINES:
    zig's compiler-rt cannot tell the CPU's features): the Windows DLL's taylor runs give the
    bits of the gcc binary's portable copy (the linux64 binary on qemu64, a CPU without AVX2
    and FMA), not those of its copy for AVX2 with FMA (3e-14 apart on the paper run)."""
    for case in ("paper", "fall"):
        windows, portable = run("x86_64-windows", case, "taylor"), run("x86_64-linux", case, "taylor", cpu="qemu64")
        assert windows.rows == portable.rows and windows.fall == portable.fall, case
