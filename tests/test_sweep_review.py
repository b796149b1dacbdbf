"""Defects found by reviewing `gyrowheel sweep` as a user (issue 10): each test is an input that went
wrong, with the behaviour a user should get."""
from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pandas as pd
import pytest

from gyrowheel.cli import main
from gyrowheel.studies import SweepSpecError, read_table, sweep
from gyrowheel.studies.spec import parse_grid, point_table
from terminal import AS_FROM_A_TERMINAL

KEEP = ["point", "beta_deg", "survived", "fall_time", "max_lean", "final_x", "status", "reason"]


def _same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    cols = [c for c in a.columns if c != "wall_time"]
    pd.testing.assert_frame_equal(a[cols].reset_index(drop=True), b[cols].reset_index(drop=True), check_exact=True)


# --- points with different keys -------------------------------------------------------------------

def test_a_missing_key_means_the_units_start_value(earth_fmu):
    """Points that set different variables: a variable a point does not name keeps the unit's start
    value (every point starts from fmi2Reset), also after a point that set it (solver included)."""
    kw = dict(stop_time=1.0, output_interval=0.02, metrics=["survived", "max_lean", "final:x"], workers=0)
    mixed = sweep(earth_fmu, points=[{"beta_deg": 80.0, "gamma_dot": 9.0, "solver": "rk4"}, {"beta_deg": 75.0},
                                     {"beta_deg": 70.0, "gamma_dot": None}], **kw)
    assert (mixed["status"] == "ok").all(), mixed["reason"].tolist()
    alone = sweep(earth_fmu, points=[{"beta_deg": 75.0}, {"beta_deg": 70.0}], **kw)
    _same(mixed.drop(columns=["point", "gamma_dot", "solver"]).iloc[1:], alone.drop(columns="point"))
    assert mixed["gamma_dot"].isna().tolist() == [False, True, True]  # the table keeps what was given


def test_a_missing_enumeration_item_is_no_error(earth_fmu):
    table = sweep(earth_fmu, points=pd.DataFrame({"solver": ["rk4", None], "beta_deg": [80.0, 80.0]}),
                  stop_time=0.2, workers=0, metrics="final:beta")
    assert (table["status"] == "ok").all()


# --- values that are not numbers ----------------------------------------------------------------

@pytest.mark.parametrize("kwargs, message", [
    (dict(grid=["M=1,nan"]), "not finite"),
    (dict(grid=["M=1,inf"]), "not finite"),
    (dict(grid={"M": [1.0, float("nan")]}), "not finite"),
    (dict(grid={"M": float("inf")}), "not finite"),
    (dict(grid={"M": [1.0]}, fixed={"R": float("nan")}), "--set R: value nan"),
    (dict(grid={"M": [1.0]}, rel_tol=float("nan")), "not finite"),
    (dict(points=[{"M": float("inf")}]), "not finite"),
    (dict(grid={"M": [1.0]}, stop_time=float("inf")), "--stop-time"),
    (dict(grid={"M": [1.0]}, output_interval=0.0), "--output-interval must be > 0"),
    (dict(grid={"M": [1.0]}, output_interval=float("nan")), "--output-interval"),
    (dict(grid={"M": [1.0]}, fixed={"beta": 1.0, "beta_deg": 80.0}), "'beta' given twice"),
    (dict(grid={"M": [1.0]}, fixed={"solver": "rk4"}, solver="dopri5"), "'solver' given twice"),
    (dict(random={"M": "normal:2:0.1"}, samples=2, seed=-1), "--seed must be a whole number >= 0"),
    (dict(random={"M": "normal:2:0.1"}, samples=2, seed=1.5), "--seed must be a whole number >= 0"),
    (dict(random={"M": "normal:2:0.1"}, samples=2.5), "--samples must be a whole number"),
])
def test_bad_values_refused_before_running(earth_fmu, kwargs, message):
    kwargs.setdefault("stop_time", 0.1)
    with pytest.raises(SweepSpecError, match=message):
        sweep(earth_fmu, workers=0, **kwargs)


@pytest.mark.parametrize("argv, message", [
    (["--grid", "M=1", "--stop-time", "inf"], "--stop-time"),
    (["--grid", "M=1", "--output-interval", "0"], "--output-interval must be > 0"),
    (["--grid", "beta_deg=60,nan"], "not finite"),
    (["--grid", "M=1", "--plot", "NODIR/x.png"], "does not exist"),
    (["--grid", "M=1", "--plot", "x.xyz"], "format"),
    (["--grid", "M=1", "--workers", "-1"], "--workers"),
    (["--random", "M=normal:2:0.1", "--samples", "2", "--seed", "-1"], "--seed must be a whole number >= 0"),
])
def test_cli_bad_values_one_line_exit_2_nothing_run(earth_fmu, tmp_path, capsys, argv, message):
    out = tmp_path / "t.csv"
    argv = [a.replace("NODIR", str(tmp_path / "no_such_dir")) for a in argv]
    try:
        code = main(["sweep", str(earth_fmu), "--stop-time", "0.1", "--no-progress", "-o", str(out), *argv]
                    + ([] if "--workers" in argv else ["--workers", "0"]))
    except SystemExit as exc:  # refused by argparse itself (finite_float options)
        code = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].startswith(("gyrowheel: error: ", "gyrowheel sweep: error: ")), err
    assert message in err[-1], err
    assert not any(line.startswith("sweep:") for line in err)  # refused before it started
    assert not out.exists()


def test_huge_grids_refused_before_building_them():
    grid = [parse_grid("M=1:2:100000"), parse_grid("R=0.1:0.2:100000")]
    with pytest.raises(SweepSpecError, match="10000000000 points"):
        point_table(grid)


def test_upper_case_suffix_and_csv_booleans(earth_fmu, tmp_path):
    fmu = tmp_path / "EARTH.FMU"
    shutil.copy(earth_fmu, fmu)
    table = sweep(fmu, grid={"gamma_dot": [0.0, 6.0], "M": [2.0, -1.0]}, fixed={"beta_deg": 80.0}, stop_time=1.0,
                  workers=0, output=tmp_path / "t.csv", metrics="survived")
    back = read_table(tmp_path / "t.csv")
    assert back["survived"].dtype == table["survived"].dtype == "boolean"
    assert back["survived"].tolist() == table["survived"].tolist() == [False, pd.NA, True, pd.NA]


# --- a system's two names for one variable --------------------------------------------------------

@pytest.mark.parametrize("kwargs, message", [
    (dict(grid={"M": [1.8, 2.2]}, fixed={"wheel.M": 3.0}), "both swept and fixed"),
    (dict(grid={"M": [1.8], "wheel.M": [2.2]}), "swept twice"),
    (dict(grid={"beta_deg": [80.0], "wheel.beta": [1.0]}), "swept twice"),
    (dict(grid={"M": [1.8]}, fixed={"beta": 1.0, "wheel.beta_deg": 80.0}), "given twice"),
])
def test_system_aliases_are_one_variable(earth_loop, kwargs, message):
    """In an .ssp the wheel's M is also wheel.M: setting it under both names must not let one win silently."""
    with pytest.raises(SweepSpecError, match=message):
        sweep(earth_loop.ssp, stop_time=0.1, workers=0, **kwargs)


# --- a scheduler address that is not a Dask scheduler ---------------------------------------------

class _Server:
    """A TCP server on localhost that accepts and then says nothing, or answers like a web server."""

    def __init__(self, reply: bytes | None):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        self.reply, self.conns = reply, []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.reply is not None:
                conn.sendall(self.reply)
                conn.close()

    def close(self):
        self.sock.close()
        for c in self.conns:
            c.close()


@pytest.mark.parametrize("reply", [None, b"HTTP/1.0 426 Upgrade Required\r\ncontent-length: 0\r\n\r\n"],
                         ids=["silent", "web-server"])
def test_an_address_that_is_no_scheduler_fails_cleanly(earth_fmu, tmp_path, capsys, monkeypatch, reply):
    import gyrowheel.studies.execute as execute
    monkeypatch.setattr(execute, "CONNECT_TIMEOUT", 2.0)
    server = _Server(reply)
    try:
        t0 = time.monotonic()
        code = main(["sweep", str(earth_fmu), "--grid", "M=1,2", "--stop-time", "0.1", "--scheduler", server.address,
                     "--no-progress", "-o", str(tmp_path / "t.csv")])
        took = time.monotonic() - t0
    finally:
        server.close()
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and err[-1].startswith("gyrowheel: error: ") and server.address in err[-1], err
    assert "Traceback" not in "\n".join(err) and took < 30


# --- worker processes that die ----------------------------------------------------------------------

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
    its worker every time: the sweep goes on, the FMU's bytes are not lost with the workers (they
    were scattered: every waiting batch was cancelled with them), the killing batch becomes error
    rows with a reason that says so, and the workers the nanny restarted ignore Ctrl-C too.
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
    if "crash" in table:  # restarted workers ignore SIGINT (the preload): see also the next test
        assert (table.loc[table["status"] == "ok", "crash"] == 1.0).all(), table["crash"].tolist()


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
    terminal's Ctrl-C later killed them with tracebacks of their own."""
    script = tmp_path / "restart.py"
    script.write_text(RESTART)
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120,
                       cwd=Path(__file__).resolve().parent.parent)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["True", "[True]"], r.stdout + r.stderr[-2000:]


# --- Ctrl-C ---------------------------------------------------------------------------------------

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


GUARD = """
import signal, subprocess, sys, time
from gyrowheel.studies.execute import _children_ignore_sigint
with _children_ignore_sigint() as quiet:
    pass
print(quiet.interrupted, flush=True)
with _children_ignore_sigint() as startup:
    child = subprocess.run([sys.executable, "-c", "import signal; print(signal.getsignal(signal.SIGINT) is signal.SIG_IGN)"],
                           capture_output=True, text=True)
    print("ready", flush=True)
    time.sleep(float(sys.argv[1]))
print(startup.interrupted, child.stdout.strip(), signal.getsignal(signal.SIGINT) is signal.default_int_handler)
"""


@pytest.mark.parametrize("ctrl_c", [True, False])
def test_startup_guard_keeps_a_ctrl_c_for_later(tmp_path, ctrl_c):
    """The guard around the cluster's start-up: children started inside ignore SIGINT from their
    start; a Ctrl-C (SIGINT to the whole process group, as a terminal sends it) that arrives
    inside is not lost but reported when the guard ends, and the handler is restored."""
    script = tmp_path / "guard.py"
    script.write_text(GUARD)
    proc = subprocess.Popen([sys.executable, str(script), "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, **AS_FROM_A_TERMINAL, cwd=Path(__file__).resolve().parent.parent)
    try:
        assert proc.stdout.readline().strip() == "False"
        assert proc.stdout.readline().strip() == "ready"
        if ctrl_c:
            os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0, err
    assert out.split() == [str(ctrl_c), "True", "True"], out + err


def test_ctrl_c_before_the_run_replaces_a_previous_table(earth_fmu, tmp_path, capsys, monkeypatch):
    """Ctrl-C after the command has printed its plan but before the first row: the file at -o is
    this sweep's (empty) table, as the message says, not a previous sweep's rows left there."""
    import gyrowheel.studies.api as api
    out = tmp_path / "t.csv"
    argv = ["sweep", str(earth_fmu), "--grid", "M=1.5,2", "--stop-time", "0.1", "--workers", "0", "--no-progress",
            "-o", str(out)]
    assert main(argv) == 0 and len(read_table(out)) == 2

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(api, "run_plan", interrupted)
    assert main(argv) == 130
    assert "interrupted: 0 of 2 points written to" in capsys.readouterr().err
    assert len(read_table(out)) == 0
