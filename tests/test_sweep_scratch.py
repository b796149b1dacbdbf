"""Nothing a sweep puts in the temporary directory outlives it, however its processes end.

A killed process runs no atexit: a worker killed by a point (or the OOM killer) left its
unpacked FMU (gyrowheel-sweep-*, 2.2 MB) in the temporary directory forever. Our LocalCluster's
processes now keep their files in a directory of the sweep that the command removes, and every
sweep removes the directories of this machine's processes that are gone (gyrowheel/scratch.py)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from gyrowheel.studies import read_table
from gyrowheel.scratch import host_tag, owner, prefix, remove_stale

KILL = '''
import os, signal

def kill(traj, point):
    """Kill the process running this point (a worker, or the command itself with --workers 0)."""
    if point["M"] == 3.0:
        os.kill(os.getpid(), signal.SIGKILL)
    return 1.0
'''


def _sweep(fmu: Path, tmp_path: Path, scratch: Path, *args: str) -> subprocess.CompletedProcess:
    """`gyrowheel sweep` in a process of its own with TMPDIR=scratch; Dask gives a batch up after
    the first death of its worker (allowed-failures 0: one restart of a worker, not four)."""
    helper = tmp_path / "kill.py"
    helper.write_text(KILL)
    env = {**os.environ, "TMPDIR": str(scratch), "DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "0"}
    return subprocess.run([sys.executable, "-m", "gyrowheel", "sweep", str(fmu), "--stop-time", "0.2",
                           "--metrics", "survived", "--no-progress", "-o", str(tmp_path / "t.csv"), *args],
                          capture_output=True, text=True, timeout=180, env=env)


# ~13 s on 2 busy cores: a LocalCluster started in a process of its own, one worker killed and
# restarted by its nanny, the cluster closed: the case reported, end to end.
def test_a_worker_killed_mid_run_leaves_nothing(earth_fmu, tmp_path):
    """The point M = 3 kills its worker process (SIGKILL); the other points run. Afterwards the
    test's TMPDIR is empty: no unpacked FMU of the dead worker (one gyrowheel-sweep-* directory
    was left per death), no Dask scratch space."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    done = _sweep(earth_fmu, tmp_path, scratch, "--grid", "M=1.5,2,3", "--metric-function",
                  f"{tmp_path / 'kill.py'}:kill", "--workers", "1", "--batch-size", "1")
    assert done.returncode == 0, done.stderr
    table = read_table(tmp_path / "t.csv")
    # (points queued on the dying worker may be given up with it: Dask counts the death against them)
    assert list(table["M"]) == [1.5, 2.0, 3.0] and table["status"].iloc[-1] == "error", table
    assert sorted(p.name for p in scratch.iterdir()) == []


def test_a_killed_sweep_leaves_nothing_past_the_next_one(earth_fmu, tmp_path):
    """`gyrowheel sweep --workers 0` killed by its point leaves its unpacked FMU, named with its
    pid (run through the FMU: the ensemble path unpacks nothing that outlives the library's
    load); the next sweep on this machine finds that process gone and removes it."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    killed = _sweep(earth_fmu, tmp_path, scratch, "--grid", "M=3", "--metric-function",
                    f"{tmp_path / 'kill.py'}:kill", "--workers", "0", "--no-ensemble")
    assert killed.returncode == -9, killed.stderr
    left = [p.name for p in scratch.iterdir()]
    assert len(left) == 1 and left[0].startswith("gyrowheel-sweep-unit-"), left
    done = _sweep(earth_fmu, tmp_path, scratch, "--grid", "M=2", "--workers", "0")
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in scratch.iterdir()) == []


def test_only_directories_of_processes_gone_from_this_machine_are_removed(tmp_path):
    ended = subprocess.Popen([sys.executable, "-c", "pass"])
    ended.wait()  # its pid is free now (reused within the test only by a wrap-around of pids)
    host = host_tag()
    names = {
        "dead": f"gyrowheel-sweep-unit-{ended.pid}-{host}-abc",
        "mine": prefix("unit") + "abc",
        "parent": f"gyrowheel-sweep-run-{os.getppid()}-{host}-abc",
        "other host": f"gyrowheel-sweep-unit-{ended.pid}-{'0' * 8 if host != '0' * 8 else '1' * 8}-abc",
        "not ours": "gyrowheel-sweep-4f2a9c1e7b3d-abc",  # no pid in the name: left alone
    }
    for name in names.values():
        (tmp_path / name).mkdir()
        (tmp_path / name / "file").write_text("x")
    (tmp_path / f"gyrowheel-sweep-unit-{ended.pid}-{host}-file").write_text("a file, not a directory")
    assert remove_stale(tmp_path) == [tmp_path / names["dead"]]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [n for k, n in names.items() if k != "dead"] + [f"gyrowheel-sweep-unit-{ended.pid}-{host}-file"])
    assert owner(names["mine"]) == (os.getpid(), host) and owner(names["not ours"]) is None
