"""The Dask paths for real: a `dask scheduler` and two `dask worker` processes on localhost (free
ports), a LocalCluster, and Ctrl-C on the command line. Results must equal the plain in-process
loop bit for bit; an interrupted sweep leaves a readable table of the points it finished; worker
processes that die do not end the sweep."""
from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pandas as pd
import pytest

from gyrowheel.studies import read_table, sweep
from terminal import AS_FROM_A_TERMINAL

# dask's own command line (`dask scheduler`, `dask worker`), from this interpreter's environment
DASK = [str(Path(sys.executable).with_name("dask"))] if Path(sys.executable).with_name("dask").exists() \
    else [sys.executable, "-m", "dask"]
# falls (gamma_dot = 0), survivors, and refused points (M < 0), in batches that do not divide evenly
POINTS = dict(grid={"beta_deg": "60:88:5", "gamma_dot": [0.0, 2.5, 7.0], "M": [2.0, -1.0]}, stop_time=1.5,
              output_interval=0.01)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    cols = [c for c in a.columns if c != "wall_time"]
    pd.testing.assert_frame_equal(a[cols], b[cols], check_exact=True)


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory):
    """tcp://127.0.0.1:PORT of a scheduler with two single-thread workers (subprocesses, ended after)."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = tmp_path_factory.mktemp("dask")
    procs = [subprocess.Popen([*DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--dashboard-address", f"127.0.0.1:{_free_port()}"],
                              stdout=subprocess.DEVNULL, stderr=open(logs / "scheduler.log", "w"))]
    for i in range(2):
        procs.append(subprocess.Popen([*DASK, "worker", address, "--nthreads", "1", "--no-nanny",
                                       "--host", "127.0.0.1", "--name", f"w{i}", "--no-dashboard"],
                                      stdout=subprocess.DEVNULL, stderr=open(logs / f"worker{i}.log", "w")))
    try:
        from distributed import Client
        deadline = time.monotonic() + 60
        while True:  # the scheduler needs a moment before it accepts connections
            try:
                with Client(address, timeout="5s") as client:
                    client.wait_for_workers(2, timeout=60)
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.3)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()


@pytest.fixture(scope="module")
def reference(earth_fmu):
    """The same points in a plain in-process loop, one batch."""
    return sweep(earth_fmu, workers=0, **POINTS)


def test_scheduler_address_equals_plain_loop(earth_fmu, scheduler, reference, tmp_path):
    """Through a scheduler address, batches of 4 spread over two worker processes: bit-identical
    metrics, failed points included, and the file holds the same table."""
    out = tmp_path / "cluster.parquet"
    table = sweep(earth_fmu, scheduler=scheduler, batch_size=4, output=out, **POINTS)
    _same(reference, table)
    _same(reference, read_table(out))
    assert (table["status"] == "error").sum() == len(table) // 2
    assert table.loc[table["status"] == "error", "reason"].str.contains("mass").all()
    assert not table.loc[table["gamma_dot"] == 0.0].query("status == 'ok'")["survived"].any()


def test_system_through_scheduler_equals_plain_loop(earth_loop, scheduler):
    """A system of two FMUs (.ssp: wheel + controller) travels to the workers and gives the same bits."""
    kw = dict(grid={"M": [1.8, 2.2], "k_axial": [0.35, 0.45], "controller.gain_scale": [1.0, 3.0]},
              fixed={"alpha_dot": -2.4}, stop_time=2.0, output_interval=0.01,
              metrics=["survived", "max_lean", "final:beta", "final:controller.tilt_cmd"])
    _same(sweep(earth_loop.ssp, workers=0, **kw), sweep(earth_loop.ssp, scheduler=scheduler, batch_size=3, **kw))


def test_local_cluster_equals_plain_loop(earth_fmu, reference):
    table = sweep(earth_fmu, workers=2, batch_size=7, **POINTS)
    _same(reference, table)


def test_cli_through_scheduler_with_user_metric(earth_fmu, scheduler, tmp_path):
    """The command line through the address; a metric function from a file the workers never saw."""
    metric = tmp_path / "lean.py"
    metric.write_text("def lowest(traj):\n    return float(traj['beta'].min())\n")
    out = tmp_path / "cli.csv"
    done = subprocess.run([sys.executable, "-m", "gyrowheel", "sweep", str(earth_fmu), "--grid", "beta_deg=70,80",
                           "--grid", "gamma_dot=3,6", "--stop-time", "1", "--scheduler", scheduler,
                           "--metric-function", f"{metric}:lowest", "--no-progress", "-o", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    table = read_table(out)
    assert len(table) == 4 and (table["status"] == "ok").all()
    assert (table["lowest"] == table["min_beta"]).all()


@pytest.mark.parametrize("where", ["scheduler", "local_cluster"])
def test_ctrl_c_leaves_a_readable_partial_table(earth_fmu, scheduler, tmp_path, where):
    """Ctrl-C during `gyrowheel sweep`: exit 130, the rows done so far on disk. Through an address
    SIGINT goes to the command; with its own LocalCluster to the whole process group, as a
    terminal sends it (the workers must not die with tracebacks before the table is written)."""
    out = tmp_path / "partial.parquet"
    total = 40 * 50
    execution = ["--scheduler", scheduler] if where == "scheduler" else ["--workers", "2"]
    proc = subprocess.Popen([sys.executable, "-m", "gyrowheel", "sweep", str(earth_fmu),
                             "--grid", "beta_deg=60:89:40", "--grid", "gamma_dot=0:15:50", "--stop-time", "20",
                             *execution, "--batch-size", "10", "--no-progress", "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **AS_FROM_A_TERMINAL)
    deadline = time.monotonic() + 60
    while not out.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    assert out.exists(), proc.stderr.read() if proc.poll() is not None else "no table written within 60 s"
    if where == "scheduler":
        proc.send_signal(signal.SIGINT)
    else:
        os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted:" in err and f"of {total} points written to {out}" in err
    assert "Traceback" not in err
    assert "CancelledError" not in err  # the workers closed under a running batch (worker_setup)
    table = read_table(out)
    assert 0 < len(table) < total
    assert (table["status"] == "ok").all() and table["point"].is_unique



@pytest.mark.parametrize("where", ["scheduler", "local_cluster"])
def test_ctrl_c_while_the_sweep_starts(earth_fmu, scheduler, tmp_path, where):
    """Ctrl-C as soon as the command says what it will run: the client connecting, the
    LocalCluster starting, the first batches going out. Exit 130, no table (none was there: the
    sweep writes one once a point has finished), no traceback, and no point run to its end first
    (the stop does not wait for the sweep)."""
    out = tmp_path / "early.parquet"
    execution = ["--scheduler", scheduler] if where == "scheduler" else ["--workers", "2"]
    proc = subprocess.Popen([sys.executable, "-m", "gyrowheel", "sweep", str(earth_fmu),
                             "--grid", "beta_deg=60:89:40", "--grid", "gamma_dot=0:15:50", "--stop-time", "20",
                             *execution, "--batch-size", "10", "--no-progress", "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **AS_FROM_A_TERMINAL)
    first = proc.stderr.readline()
    assert first.startswith("sweep: 2000 points"), first + proc.stderr.read()
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, first + err
    assert "Traceback" not in err and f"interrupted: 0 of 2000 points finished, {out} left as it was" in err, err
    assert not out.exists()


def test_ctrl_c_while_the_local_cluster_starts(earth_fmu, tmp_path):
    """Ctrl-C right after the command starts its LocalCluster is not lost: exit 130 at once, not
    after the whole sweep."""
    out = tmp_path / "t.parquet"
    proc = subprocess.Popen([sys.executable, "-m", "gyrowheel", "sweep", str(earth_fmu), "--grid", "beta_deg=60:89:40",
                             "--grid", "gamma_dot=0:15:50", "--stop-time", "20", "--workers", "2", "--batch-size", "10",
                             "--no-progress", "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **AS_FROM_A_TERMINAL)
    line = proc.stderr.readline()
    assert line.startswith("sweep:"), line + proc.stderr.read()
    os.killpg(proc.pid, signal.SIGINT)  # what a terminal does: the whole process group
    t0 = time.monotonic()
    try:
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert time.monotonic() - t0 < 30 and "interrupted:" in err and "Traceback" not in err


def test_both_workers_run_batches(earth_fmu, scheduler, tmp_path):
    """The FMU's bytes are one task's result that every batch depends on; a batch prefers a worker
    holding its inputs, so unless they are replicated every batch runs on the worker that has
    them and the second sits idle (1 -> 2 workers give 1.0-1.6x). Each worker's process id, as a
    user metric, must appear in the table. The metric takes 50 ms a trajectory, so that each batch
    lasts long enough for the scheduler to place the next on the idle worker also on a loaded machine
    (2 s runs of 5 ms each let one worker finish all 20 batches while the other had none)."""
    metric = tmp_path / "pid.py"
    metric.write_text("import os\nimport time\n\n\ndef pid(traj):\n    time.sleep(0.05)\n    return float(os.getpid())\n")
    out = tmp_path / "pids.csv"
    done = subprocess.run([sys.executable, "-m", "gyrowheel", "sweep", str(earth_fmu), "--grid", "beta_deg=60:89:40",
                           "--stop-time", "2", "--scheduler", scheduler, "--batch-size", "2",
                           "--metric-function", f"{metric}:pid", "--no-progress", "-o", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    table = read_table(out)
    assert len(table) == 40 and (table["status"] == "ok").all()
    assert table["pid"].nunique() == 2


@pytest.mark.parametrize("workers", ["0", "2"])
def test_no_unpacked_fmu_is_left_in_the_temporary_directory(earth_fmu, tmp_path, workers):
    """Each process unpacks the FMU once; the copy goes when the process does (in-process loop and
    the LocalCluster's workers alike), so thousands of sweeps do not fill /tmp."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    done = subprocess.run([sys.executable, "-m", "gyrowheel", "sweep", str(earth_fmu), "--grid", "beta_deg=70,80",
                           "--stop-time", "0.5", "--workers", workers, "--no-progress", "-o", str(tmp_path / "t.csv")],
                          capture_output=True, text=True, timeout=120, env={**os.environ, "TMPDIR": str(scratch)})
    assert done.returncode == 0, done.stderr
    assert len(read_table(tmp_path / "t.csv")) == 2
    assert sorted(p.name for p in scratch.glob("gyrowheel-*")) == []


CRASH = '''
import os, signal
from pathlib import Path
from distributed import get_worker

def crash(traj, point):
    """Kill this worker process: once per worker (its first point), and always at M = 3. The
    value: 1 if this (restarted) worker ignores SIGINT."""
    flag = Path(FLAGS) / f"died-{get_worker().name}"
    if point["M"] == 3.0 or not flag.exists():
        flag.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return float(signal.getsignal(signal.SIGINT) is signal.SIG_IGN)
'''


def test_dead_workers_do_not_cancel_the_sweep(earth_fmu, tmp_path):
    """Every worker process of a LocalCluster dies once (the nanny restarts it), and one point kills
    its worker every time: the sweep goes on, the FMU's bytes are not lost with the workers (were
    they only scattered to them, every waiting batch would be cancelled with them), the killing
    batch becomes error rows with a reason that says so, and the workers the nanny restarted
    ignore Ctrl-C too.
    Batches waiting on the same worker as the killing one may be given up with it (Dask counts
    a death against every task on the worker): which ones is timing, not asserted."""
    helper = tmp_path / "crash.py"
    helper.write_text(f"FLAGS = {str(tmp_path)!r}\n{CRASH}")
    table = sweep(earth_fmu, grid={"M": [1.5, 2.0, 2.5, 3.0], "gamma_dot": [2.0, 6.0]}, stop_time=0.2,
                  metric_functions=[f"{helper}:crash"], metrics="survived", workers=2, batch_size=2)
    assert len(table) == 8 and table["point"].is_unique
    failed = table[table["status"] != "ok"]
    assert 3.0 in set(failed["M"]) and (table.loc[table["M"] == 3.0, "status"] == "error").all()
    assert failed["reason"].str.contains("a worker process died on every try").all(), failed["reason"].tolist()
    # restarted workers ignore SIGINT (the preload; test_sweep_worker_setup.py tests it alone)
    if "crash" in table:
        assert (table.loc[table["status"] == "ok", "crash"] == 1.0).all(), table["crash"].tolist()


class _Records(logging.Handler):
    """The error records of Dask's and tornado's loggers (they do not propagate to the root)."""

    LOGGERS = ("tornado", "tornado.application", "asyncio", "distributed", "distributed.client")

    def __init__(self):
        super().__init__(logging.ERROR)
        self.records: list[logging.LogRecord] = []

    def emit(self, record):
        self.records.append(record)

    def __enter__(self):
        for name in self.LOGGERS:
            logging.getLogger(name).addHandler(self)
        return self

    def __exit__(self, *exc):
        for name in self.LOGGERS:
            logging.getLogger(name).removeHandler(self)


def _sigint_soon(delay: float) -> None:
    threading.Timer(delay, os.kill, (os.getpid(), signal.SIGINT)).start()


@pytest.mark.parametrize("landing", ["submit", "gather", "write"])
def test_ctrl_c_anywhere_in_a_dask_sweep_ends_cleanly(earth_fmu, scheduler, tmp_path, monkeypatch, landing):
    """SIGINT at a chosen point of a sweep through a scheduler address, the race window held open.

    gather: Ctrl-C while the main thread waits in Future.result (Dask's utils.sync) and the
    client's IO loop is busy (a loaded machine: here a callback holds it for 0.5 s): distributed's
    cancel callback can then read a future its coroutine has not made yet, and tornado logs
    'Traceback ... ioloop.py, in _run_callback ... NameError' on our stderr unless the sweep
    guards against it (an intermittent failure on a loaded machine otherwise).
    submit, write: Ctrl-C while batches go out, while the table is written. Each must end
    with KeyboardInterrupt, a readable table of the points done (none, when no batch had finished
    at a Ctrl-C during submission), no error logged, and nothing of the sweep's left on the
    scheduler."""
    from distributed import Client

    from gyrowheel.studies import plan_sweep, run_plan
    from gyrowheel.studies.output import TableWriter
    from gyrowheel.studies.target import FmuTarget

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a terminal (see terminal.py)
    out = tmp_path / "partial.parquet"
    plan = plan_sweep(FmuTarget(earth_fmu), grid={"beta_deg": "70:80:12"}, stop_time=0.5, output_interval=0.01)

    class Writer(TableWriter):
        calls, fired = 0, False

        def add(self, rows):
            Writer.calls += 1
            if landing == "gather" and Writer.calls == 1:
                deadline = time.monotonic() + 60  # every batch finished, as_completed holds them
                while any(st.status != "finished" for st in c.futures.values()) and time.monotonic() < deadline:
                    time.sleep(0.02)
                time.sleep(0.2)
                c.loop.add_callback(time.sleep, 0.5)  # the IO loop is busy...
                _sigint_soon(0.1)  # ... when Ctrl-C lands in the next Future.result
            super().add(rows)

        def flush(self, **kwargs):
            if landing == "write" and Writer.calls >= 2 and not Writer.fired:
                Writer.fired = True
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.05)  # the handler runs in the middle of the write
            return super().flush(**kwargs)

    writer = Writer(out, plan.inputs, interval=0.0)
    try:
        with Client(scheduler, timeout="20s") as c, _Records() as logged:
            if landing == "submit":
                submit = c.submit

                def submit_and_interrupt(*args, **kwargs):
                    if kwargs.get("key", "").endswith("-3"):
                        os.kill(os.getpid(), signal.SIGINT)
                        time.sleep(0.05)
                    return submit(*args, **kwargs)
                monkeypatch.setattr(c, "submit", submit_and_interrupt)
            with pytest.raises(KeyboardInterrupt):
                run_plan(plan, client=c, batch_size=1, writer=writer)
            time.sleep(1.0)  # the IO loop's callbacks have run: what they log is in `logged`
            left = c.run_on_scheduler(lambda dask_scheduler: [k for k in dask_scheduler.tasks
                                                              if "gyrowheel-sweep" in str(k)])
    finally:
        signal.signal(signal.SIGINT, previous)
    assert [r.getMessage() for r in logged.records] == []
    assert left == []
    if landing == "submit" and not writer.rows:  # no batch finished: no table (there was none before)
        assert not out.exists()
        return
    table = read_table(out)
    # the points written before Ctrl-C landed: every point when they had all finished by then (a
    # first batch that compiles the unit's ensemble library lets the others finish meanwhile)
    assert 0 < len(table) <= len(plan.values) and (table["status"] == "ok").all() and table["point"].is_unique
