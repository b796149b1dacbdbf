"""The preload of the sweep's own workers: SIGINT ignored, also by the workers the nanny restarts,
and no traceback from a heartbeat that a closing worker cuts off (a race a Ctrl-C of a sweep can
hit, as test_sweep_cluster.py's test_ctrl_c_leaves_a_readable_partial_table does: "Failed to
communicate with scheduler during heartbeat", CommClosedError "Stream is closed")."""
from __future__ import annotations

import asyncio
import logging
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from distributed import Scheduler, Worker

from gyrowheel.studies import worker_setup
from gyrowheel.studies.worker_setup import HEARTBEAT_FAILURE, CancelledWhileClosing, HeartbeatWhileClosing


def _tracebacks_of_a_heartbeat_cut_by_close(preload: bool) -> list[str]:
    """A real scheduler and worker in this process: the scheduler holds the worker's heartbeat
    for 2 s, the worker closes meanwhile (what Nanny.close does when the sweep closes its cluster).
    Returns the messages distributed.worker logged with a traceback."""
    records: list[logging.LogRecord] = []
    handler = logging.Handler(logging.ERROR)
    handler.emit = records.append
    log = logging.getLogger("distributed.worker")

    async def scene():
        async with Scheduler(host="127.0.0.1", port=0, dashboard_address=":0") as scheduler:
            async def held_heartbeat(*_, **__):
                await asyncio.sleep(2)
                return {"status": "OK", "time": 0.0, "heartbeat-interval": 1.0}

            scheduler.handlers["heartbeat_worker"] = held_heartbeat
            worker = await Worker(scheduler.address, nthreads=1, host="127.0.0.1", dashboard=False)
            added = HeartbeatWhileClosing(worker) if preload else None
            if added:
                log.addFilter(added)
            try:
                beat = asyncio.create_task(worker.heartbeat())
                await asyncio.sleep(0.2)
                await worker.close()
                await beat
            finally:
                if added:
                    log.removeFilter(added)

    log.addHandler(handler)
    try:
        asyncio.run(scene())
    finally:
        log.removeHandler(handler)
    return [r.getMessage() for r in records if r.exc_info]


def test_without_the_filter_the_race_prints_a_traceback():
    """The race is real in the distributed we install (else the filter would guard nothing)."""
    assert _tracebacks_of_a_heartbeat_cut_by_close(preload=False) == [HEARTBEAT_FAILURE]


def test_the_preload_filter_drops_it():
    assert _tracebacks_of_a_heartbeat_cut_by_close(preload=True) == []


class _Status:
    def __init__(self, name: str):
        self.name = name


class _Worker:
    def __init__(self, status: str):
        self.status = _Status(status)


@pytest.mark.parametrize("status, kept", [("running", True), ("paused", True), ("closing", False), ("closed", False)])
def test_a_heartbeat_failure_of_a_running_worker_is_kept(status, kept):
    """Only a closing worker's record is dropped: losing the scheduler while running stays visible,
    and no other record is touched."""
    f = HeartbeatWhileClosing(_Worker(status))
    record = logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, HEARTBEAT_FAILURE, None, None)
    other = logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, "Compute Failed", None, None)
    assert f.filter(record) is kept
    assert f.filter(other) is True


def test_dask_setup_ignores_sigint_and_installs_the_filter():
    log = logging.getLogger("distributed.worker")
    machine = logging.getLogger("distributed.worker.state_machine")
    previous = signal.getsignal(signal.SIGINT)
    before, before_machine = list(log.filters), list(machine.filters)
    try:
        worker_setup.dask_setup(_Worker("running"))
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        assert [type(f) for f in log.filters if f not in before] == [HeartbeatWhileClosing]
        assert [type(f) for f in machine.filters if f not in before_machine] == [CancelledWhileClosing]
    finally:
        signal.signal(signal.SIGINT, previous)
        log.filters[:] = before
        machine.filters[:] = before_machine


@pytest.mark.parametrize("status, kept", [("running", True), ("closing", False), ("closed", False)])
def test_a_batch_cancelled_by_the_close_is_not_logged(status, kept):
    """After a Ctrl-C of `gyrowheel sweep --workers 2` mid-run, each worker closed under a running
    batch logs 'Async instruction for <Task cancelled ...> ended with CancelledError' (WARNING)
    on the user's terminal (3 of 3 tries without the filter). Dropped while the worker closes;
    kept while it runs."""
    f = CancelledWhileClosing(_Worker(status))
    msg = ("Async instruction for <Task cancelled name=\"execute('gyrowheel-sweep-95670ec4-0')\" coro=<Worker.execute() "
           "done, defined at worker_state_machine.py:3606>> ended with CancelledError")
    record = logging.LogRecord("distributed.worker.state_machine", logging.WARNING, __file__, 1, msg, None, None)
    other = logging.LogRecord("distributed.worker.state_machine", logging.WARNING, __file__, 1, "Compute Failed",
                              None, None)
    assert f.filter(record) is kept
    assert f.filter(other) is True


RESTART = """
import os, signal, time
import dask
from distributed import Client, LocalCluster
from gyrowheel.studies.execute import LOCAL_CONFIG, _children_ignore_sigint

def sigint():
    return signal.getsignal(signal.SIGINT) is signal.SIG_IGN

def die():
    os.kill(os.getpid(), signal.SIGKILL)

if __name__ == "__main__":
    with dask.config.set(LOCAL_CONFIG), _children_ignore_sigint():
        cluster = LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=":0")
    with cluster, Client(cluster) as c:
        first = c.run(os.getpid)
        c.submit(die, pure=False)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            time.sleep(0.2)
            try:
                now = c.run(os.getpid)
            except Exception:
                continue
            if now and set(now.values()) != set(first.values()):
                break
        print(set(now.values()) != set(first.values()), list(c.run(sigint).values()))
"""


def test_restarted_workers_ignore_ctrl_c(tmp_path):
    """The workers the nanny starts after one died ignore SIGINT too (the preload): else a
    terminal's Ctrl-C would kill them with tracebacks of their own."""
    script = tmp_path / "restart.py"
    script.write_text(RESTART)
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120,
                       cwd=Path(__file__).resolve().parent.parent)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["True", "[True]"], r.stdout + r.stderr[-2000:]
