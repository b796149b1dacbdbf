"""The FMU's binaries for other platforms, run here: the paper scene's FMU with binaries for
every platform of `all` (tests/conftest.py all_platforms_build), its x86_64-linux, aarch64-linux
and x86_64-windows libraries each loaded by tests/platform_driver/fmu_driver.c built for the
same platform, and run natively, under qemu-user (qemu-aarch64 with Debian's aarch64 C library)
and under Wine.  The same for the FMI 3.0 FMU of the scene (all_platforms_build_fmi3, its
platform-tuple folders) with tests/platform_driver/fmu3_driver.c, whose x86_64-linux run also
equals the FMI 2.0 binary's.

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
def fmus(request, tmp_path_factory):
    """fmus(fmi): the unpacked all-platforms FMU of FMI version `fmi` (2: all_platforms_build,
    3: all_platforms_build_fmi3, built when first asked for), its value references by name, its
    solver enumeration and experiment."""
    memo: dict = {}

    def _fmu(fmi: int) -> dict:
        if fmi not in memo:
            built = request.getfixturevalue("all_platforms_build" if fmi == 2 else "all_platforms_build_fmi3")
            root = tmp_path_factory.mktemp(f"fmu{fmi}")
            with zipfile.ZipFile(built.fmu) as z:
                z.extractall(root)
            md = read_model_description(str(built.fmu))
            vr = {v.name: v.valueReference for v in md.modelVariables}
            solvers = {i.name: int(i.value) for t in md.typeDefinitions if t.name == "Solver" for i in t.items}
            memo[fmi] = dict(root=root, guid=md.guid, vr=vr, solvers=solvers, identifier=built.identifier, fmi=fmi,
                             experiment=load_scene(SCENES / "paper_earth.toml").experiment)
        return memo[fmi]
    return _fmu


@pytest.fixture(scope="module")
def fmu(fmus):
    """The FMI 2.0 FMU (fmus(2))."""
    return fmus(2)


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
def run(fmus, request):
    """run(platform, case, solver, cpu=None, fmi=2): the driver of FMI version `fmi`
    (fmu_driver, fmu3_driver) on `platform`'s binary of that version's FMU (for case 'paper' or
    'fall', solver 'scene' or 'taylor'), memoised; cpu: qemu-x86_64's -cpu for the x86_64-linux
    binary.  Both drivers print the same states; FMI 2's resources are a file: URI, FMI 3's
    a path ending in the separator (FMI 3.0.2, section 2.3.1), its solver an Int64 (e:)."""
    memo: dict = {}

    def _run(platform: str, case: str, solver: str, cpu: str | None = None, fmi: int = 2):
        key = (platform, case, solver, cpu, fmi)
        if key in memo:
            return memo[key]
        fmu = fmus(fmi)
        ex, vr = fmu["experiment"], fmu["vr"]
        p = PLATFORMS[platform]
        library = fmu["root"] / "binaries" / (p.fmi2_dir if fmi == 2 else p.fmi3_dir) / \
            f"{fmu['identifier']}{p.extension}"
        resources = fmu["root"] / "resources"
        kind = "i" if fmi == 2 else "e"
        settings = [f"{kind}:{vr['solver']}={fmu['solvers'][ex.solver if solver == 'scene' else solver]}"]
        if case == "fall":
            settings += [f"r:{vr[name]}={value!r}" for name, value in FALL.items()]
        tail = [repr(0.0), repr(ex.stop_time), repr(ex.output_interval), repr(ex.rel_tol),
                ",".join(str(vr[s]) for s in STATES), *settings]
        driver = request.getfixturevalue("platform_drivers" if fmi == 2 else "platform_drivers_fmi3")[platform]
        env = None
        if platform == "x86_64-linux":
            head = [require("qemu-x86_64", "qemu-user"), "-cpu", cpu] if cpu else []
            where = resources.as_uri() if fmi == 2 else f"{resources}/"
            command = [*head, str(driver), str(library), fmu["guid"], where, *tail]
        elif platform == "aarch64-linux":
            qemu = require("qemu-aarch64", "qemu-user")
            require_aarch64_libc()
            where = resources.as_uri() if fmi == 2 else f"{resources}/"
            command = [qemu, "-L", str(AARCH64_ROOT), str(driver), str(library), fmu["guid"], where, *tail]
        else:
            wine = request.getfixturevalue("wine_env")
            env = wine["env"]
            where = "file:///" + windows_path(resources).replace("\\", "/") if fmi == 2 else \
                windows_path(resources) + "\\"
            command = [wine["wine"], windows_path(driver), windows_path(library), fmu["guid"], where, *tail]
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


@pytest.mark.parametrize("case", ("paper", "fall"))
@pytest.mark.parametrize("solver", SOLVERS)
def test_fmi3_reference_equals_fmi2(run, case, solver):
    """The FMI 3.0 FMU's x86_64-linux binary natively gives the FMI 2.0 binary's states at every
    communication point, bit for bit (the same core, solvers and compiler behind another
    layer); the fall ends the run at FMI 2's fmi2LastSuccessfulTime, with terminateSimulation
    and, as the driver allows it, earlyReturn (FMI 3.0.2, section 4.2.1)."""
    ref, got = run("x86_64-linux", case, solver), run("x86_64-linux", case, solver, fmi=3)
    assert got.rows == ref.rows and len(got.rows) > 80
    assert (got.terminated, got.fall) == (ref.terminated, ref.fall)
    assert got.early == (case == "fall")


@pytest.mark.parametrize("platform", EMULATED)
@pytest.mark.parametrize("case", ("paper", "fall"))
@pytest.mark.parametrize("solver", SOLVERS)
def test_fmi3_platform_equals_reference(run, platform, case, solver):
    """The FMI 3.0 FMU's aarch64-linux (qemu-user) and x86_64-windows (Wine) binaries, in their
    platform-tuple folders: every state at every communication point equals its x86_64-linux
    binary's to TOL; a fall ends the run (terminateSimulation, earlyReturn) at the reference's
    time (to TOL, absolute).  Measured: as FMI 2's (aarch64's dopri5 1.5e-13 apart at most,
    its taylor not at all)."""
    ref, got = run("x86_64-linux", case, solver, fmi=3), run(platform, case, solver, fmi=3)
    assert largest_difference(got, ref) <= TOL
    assert (got.terminated, got.early) == (ref.terminated, ref.early)
    if case == "fall":
        assert got.terminated and abs(got.fall - ref.fall) <= TOL, (got.fall, ref.fall)
