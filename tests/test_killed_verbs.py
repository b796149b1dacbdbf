"""A verb killed with SIGKILL leaves nothing past the next verb (gyrowheel/scratch.py,
gyrowheel/output_files.py).

A killed process removes nothing itself: its temporary directory (the unpacked FMU of simulate,
a system's FMUs, a build's sources and the compiler's files) and the hidden sibling of the
output it was writing stay. Each test starts a verb in a process of its own with TMPDIR set to
an empty directory, kills it (SIGKILL) once it has made what it would leave, runs one more verb,
and asserts that TMPDIR is empty again and no `.NAME.part-PID.SUFFIX` is left: the directories
are named gyrowheel-<kind>-<pid>-<host>-..., and every verb removes those of processes gone
from this machine when it starts; a write removes the stale siblings of its own output.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import SCENES
from gyrowheel.fmu_build.build_cache import ENV as BUILD_CACHE

pytestmark = pytest.mark.skipif(os.name != "posix", reason="os.kill(pid, 0) answers whether a process exists")


def _start(tmpdir: Path, cwd: Path, *argv) -> subprocess.Popen:
    """The verb, without the run's build cache (GYROWHEEL_BUILD_CACHE): a build must still be
    compiling when it is killed, not copying a library built by an earlier test."""
    env = {**os.environ, "TMPDIR": str(tmpdir)}
    env.pop(BUILD_CACHE, None)
    return subprocess.Popen([sys.executable, "-m", "gyrowheel", *map(str, argv)], cwd=cwd, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def _run(tmpdir: Path, cwd: Path, *argv) -> subprocess.CompletedProcess:
    env = {**os.environ, "TMPDIR": str(tmpdir)}
    return subprocess.run([sys.executable, "-m", "gyrowheel", *map(str, argv)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def _kill_when(proc: subprocess.Popen, ready, timeout: float = 60.0) -> None:
    """SIGKILL `proc` as soon as ready() is true (what it would leave behind exists)."""
    end = time.monotonic() + timeout
    while not ready():
        assert proc.poll() is None, f"the verb ended before it was killed: {proc.stderr.read()}"
        assert time.monotonic() < end, "the verb made nothing to leave behind in time"
        time.sleep(0.02)
    time.sleep(0.1)
    proc.send_signal(signal.SIGKILL)
    assert proc.wait(timeout=30) == -signal.SIGKILL
    proc.stderr.close()


def _ours(tmpdir: Path) -> list[str]:
    return sorted(p.name for p in tmpdir.iterdir() if p.name.startswith("gyrowheel-"))


@pytest.fixture
def tmpdir_(tmp_path) -> Path:
    d = tmp_path / "tmp"
    d.mkdir()
    return d


def test_a_killed_simulate_leaves_nothing_past_the_next_verb(earth_fmu, tmp_path, tmpdir_):
    """simulate --stop-time 2000 killed mid-run: its unpacked FMU goes with the next verb (info)."""
    proc = _start(tmpdir_, tmp_path, "simulate", earth_fmu, "--stop-time", "2000", "-o", "run.csv")
    _kill_when(proc, lambda: _ours(tmpdir_))
    assert _ours(tmpdir_), "nothing was left to clean"
    assert _run(tmpdir_, tmp_path, "info", earth_fmu).returncode == 0
    assert sorted(os.listdir(tmpdir_)) == []
    assert sorted(os.listdir(tmp_path)) == ["tmp"]  # no CSV, no part of one


def test_a_killed_system_run_leaves_nothing_past_the_next_verb(earth_fmu, tmp_path, tmpdir_):
    """system run killed mid-run: the system's FMUs and each component's unpacked FMU (fmpy's
    extract goes into a directory of ours) go with the next verb."""
    from gyrowheel.cosim.system import Component, SystemDescription
    from gyrowheel.cosim.ssp import write_ssp
    ssp = write_ssp(SystemDescription("one", [Component("wheel", earth_fmu, {})], [], 0.0, 1.0), tmp_path / "one.ssp")
    proc = _start(tmpdir_, tmp_path, "system", "run", ssp, "--step", "0.001", "--stop-time", "2000", "-o", "run.csv")
    _kill_when(proc, lambda: any(n.startswith("gyrowheel-unit-") for n in _ours(tmpdir_)))
    assert _run(tmpdir_, tmp_path, "info", earth_fmu).returncode == 0
    assert sorted(os.listdir(tmpdir_)) == []
    assert sorted(os.listdir(tmp_path)) == ["one.ssp", "tmp"]


def test_a_killed_build_leaves_nothing_past_the_next_verb(earth_fmu, tmp_path, tmpdir_):
    """build killed while it generates or compiles: its build directory goes with the next verb."""
    proc = _start(tmpdir_, tmp_path, "build", SCENES / "paper_earth.toml", "-o", "e.fmu")
    _kill_when(proc, lambda: any(n.startswith("gyrowheel-build-") for n in _ours(tmpdir_)))
    time.sleep(0.5)  # the compiler, if it was running, is not killed with it: let it end
    assert _run(tmpdir_, tmp_path, "info", earth_fmu).returncode == 0
    assert sorted(os.listdir(tmpdir_)) == []
    assert sorted(os.listdir(tmp_path)) == ["tmp"]


def test_a_killed_animate_leaves_no_part_past_the_next_write(earth_fmu, tmp_path, tmpdir_):
    """animate killed while it writes its GIF: the hidden .a.part-PID.gif beside the output is
    removed by the next animate of the same output, which writes the GIF whole."""
    long_run = tmp_path / "long.csv"
    assert _run(tmpdir_, tmp_path, "simulate", earth_fmu, "--stop-time", "30", "-o", long_run).returncode == 0
    short_run = tmp_path / "short.csv"
    assert _run(tmpdir_, tmp_path, "simulate", earth_fmu, "--stop-time", "0.2", "-o", short_run).returncode == 0
    out = tmp_path / "out"
    out.mkdir()
    proc = _start(tmpdir_, tmp_path, "animate", long_run, "--fmu", earth_fmu, "-o", out / "a.gif",
                  "--size", "160x120")
    _kill_when(proc, lambda: any(p.name.startswith(".a.part-") for p in out.iterdir()))
    assert [p.name for p in out.iterdir()] == [f".a.part-{proc.pid}.gif"]
    done = _run(tmpdir_, tmp_path, "animate", short_run, "--fmu", earth_fmu, "-o", out / "a.gif", "--size", "160x120")
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in out.iterdir()) == ["a.gif"]
    assert sorted(os.listdir(tmpdir_)) == []
