"""Sweeps refused before anything runs, and a scheduler that is not one.

Through the API a bad sweep raises SweepSpecError naming the option or variable; the command line
prints one line `gyrowheel: error: ...`, exits 2 and writes nothing: unknown names, options that
exclude each other, values that are not finite or out of range, a variable given twice. An address
that answers but is no Dask scheduler ends the command with one line and exit 1, not a hang or a
traceback."""
from __future__ import annotations

import re
import socket
import threading
import time
from types import SimpleNamespace

import pytest

from gyrowheel.cli import main
from gyrowheel.studies import SweepSpecError, execute, sweep


@pytest.mark.parametrize("kwargs, message", [
    (dict(grid={"foo": [1.0]}), "unknown variable 'foo'"),
    (dict(grid={"z": [1.0]}), "calculated output"),
    (dict(grid={"beta": [1.0], "beta_deg": [60.0]}), "swept twice"),
    (dict(grid={"M": [1.0]}, fixed={"M": 2.0}), "both swept and fixed"),
    (dict(grid={"M": [1.0]}, metrics="lean"), "unknown metric"),
    (dict(grid={"M": [1.0]}, metrics="final:nope"), "no Real output 'nope'"),
    (dict(grid={"M": [1.0]}, solver="rk5"), "valid: euler, rk4"),
    (dict(grid={"M": [1.0]}, metric_functions=["no_such_module_xyz:f"]), "cannot load"),
    (dict(grid={"M": [1.0]}, output="table.xlsx"), "use .parquet or .csv"),
])
def test_bad_names_and_options_refused_before_running(earth_fmu, kwargs, message):
    with pytest.raises(SweepSpecError, match=message):
        sweep(earth_fmu, stop_time=0.1, workers=0, **kwargs)


@pytest.mark.parametrize("argv, message", [
    (["--grid", "beta_deg=60:89"], "--grid 'beta_deg=60:89': expected NAME=START:STOP:N"),
    (["--grid", "speed=1,2"], "unknown variable 'speed'; settable: M, R"),
    (["--random", "M=normal:2:0.1"], "--random needs --samples"),
    (["--grid", "M=1,2", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "exclude each other"),
    (["--grid", "M=1,2", "--samples", "3"], "--samples 3 without --random"),
    (["--grid", "M=1,2", "--set", "R=0.2", "--set", "R=0.3"], "--set R: given twice, as R=0.2 and R=0.3"),
    (["--grid", "beta_deg=60:89:1000000000"], "1000000000 values, more than the 10000000 points of one sweep"),
    (["--grid", "M=1", "--stop-time", "20", "--output-interval", "1e-12"],
     "--stop-time 20 s with --output-interval 1e-12 s: 2e+13 communication points of"),
    # the reported inputs: 1e9 s / 0.01 s (the FMU's step) + 1 and 20 s (its stop time) / 1e-9 s + 1 rows
    (["--grid", "M=1", "--stop-time", "1e9"],
     "--stop-time 1e+09 s with --output-interval 0.01 s: 100000000001 communication points of"),
    (["--grid", "M=1", "--output-interval", "1e-9"],
     "--stop-time 20 s with --output-interval 1e-09 s: 20000000001 communication points of"),
])
def test_cli_errors_are_one_line_exit_2(earth_fmu, tmp_path, capsys, argv, message):
    code = main(["sweep", str(earth_fmu), "-o", str(tmp_path / "t.parquet"), "--workers", "0", *argv]
                if "--scheduler" not in argv else ["sweep", str(earth_fmu), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("gyrowheel: error: ") and message in err and "\n" not in err


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
    # refused before running: every grid point would run 3 times alike / every row would fail
    (dict(grid={"M": [1.0]}, samples=3), "--samples 3 without --random: there is nothing to draw"),
    (dict(grid={"M": [1.0]}, rel_tol=-1.0), r"--rel-tol: the unit refuses -1.0 for every point: fmi2SetReal: "
                                            r"rel_tol = -1 is outside its valid range \[2.2204460492503131e-15, 1\]"),
    (dict(grid={"M": [1.0]}, fixed={"max_step": 0.0}), "--set max_step: the unit refuses 0.0 for every point"),
    (dict(grid={"M": [1.0]}, client=SimpleNamespace(submit=print, nthreads=dict, cancel=print)),
     "--workers and client exclude each other: give one of them"),
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


def test_an_address_that_refuses_fails_within_seconds(earth_fmu, tmp_path, capsys):
    """Nothing listens on the port: distributed's connect would try again for its whole timeout
    (20 s here); the sweep gives up after REFUSED_WAIT (2 s) with one line naming the address."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{s.getsockname()[1]}"  # bound, not listening: refused
        t0 = time.monotonic()
        code = main(["sweep", str(earth_fmu), "--grid", "M=1,2", "--stop-time", "0.1", "--scheduler", address,
                     "--no-progress", "-o", str(tmp_path / "t.csv")])
        took = time.monotonic() - t0
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and err[-1] == (f"gyrowheel: error: ConnectionError: no Dask scheduler at {address}: "
                                     "connection refused (tried for 2 s)"), err
    assert 2.0 <= took < 6.0, took


def test_workers_far_above_the_cores_refused_at_once(earth_fmu, tmp_path, capsys):
    """--workers 1000 on 2 cores was still starting its LocalCluster after 120 s: more than 4
    worker processes per core is refused in one line before anything runs."""
    cores = execute.cores()
    t0 = time.monotonic()
    code = main(["sweep", str(earth_fmu), "--grid", "M=1,2", "--stop-time", "0.1", "--workers", str(4 * cores + 1),
                 "--no-progress", "-o", str(tmp_path / "t.csv")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and time.monotonic() - t0 < 5 and "\n" not in err, err
    assert err == (f"gyrowheel: error: --workers {4 * cores + 1}: more than 4 worker processes per core ({cores} "
                   f"cores here: at most {4 * cores}); for more, start a Dask cluster and give --scheduler")
    with pytest.raises(SweepSpecError, match=f"workers {4 * cores + 1}: more than 4 worker processes per core"):
        sweep(earth_fmu, grid={"M": [1.0]}, stop_time=0.1, workers=4 * cores + 1)


CORES = execute.cores()


def test_the_cores_are_those_the_process_may_run_on(monkeypatch):
    """Under `taskset -c 0` a LocalCluster of one worker per core starts one worker, not one per
    core of the machine (its workers would share the one core they may use)."""
    monkeypatch.setattr(execute.os, "sched_getaffinity", lambda pid: {0}, raising=False)
    monkeypatch.setattr(execute.os, "cpu_count", lambda: 8)
    assert execute.cores() == 1 and execute.local_workers(None, 10)[0] == 1
    monkeypatch.delattr(execute.os, "sched_getaffinity")  # a system without affinity: the machine's
    assert execute.cores() == 8 and execute.local_workers(None, 10) == (8, "8 workers (one per core)")


@pytest.mark.parametrize("workers, points, used", [
    (3, 2, "2 workers (one per point; --workers 3)"), (2, 5, "2 workers"), (1, 1, "1 worker"),
    (None, 10**6, f"{CORES} worker{'s' * (CORES != 1)} (one per core)"),
    (None, 1, f"1 worker (one per point; {CORES} cores)" if CORES > 1 else "1 worker (one per core)")])
def test_a_local_cluster_has_no_more_processes_than_points(workers, points, used):
    from gyrowheel.studies.execute import local_workers
    assert local_workers(workers, points) == (int(used.split()[0]), used)


def test_the_command_says_how_many_workers_it_starts(earth_fmu, tmp_path, capsys, monkeypatch):
    import gyrowheel.studies.api as api

    def stop(*args, **kwargs):  # after the announcement, before any cluster starts
        raise KeyboardInterrupt

    monkeypatch.setattr(api, "run_plan", stop)
    code = main(["sweep", str(earth_fmu), "--grid", "M=1,2", "--stop-time", "0.1", "--workers", "3", "--no-progress",
                 "-o", str(tmp_path / "t.csv")])
    err = capsys.readouterr().err
    assert code == 130 and "on a LocalCluster of 2 workers (one per point; --workers 3)\n" in err, err


# a value every point shares that the FMU refuses only at initialisation (fmi2ExitInitializationMode
# checks the wheel's parameters, model/build.py): refused before any point runs, in the FMU's words
R_REFUSED = "fmi2ExitInitializationMode: R (radius) must be > 0"


def test_cli_a_fixed_value_refused_at_initialisation_exits_2(earth_fmu, tmp_path, capsys):
    out = tmp_path / "t.csv"
    code = main(["sweep", str(earth_fmu), "--grid", "beta_deg=60:85:6", "--set", "R=-1", "--workers", "0",
                 "--no-progress", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err == f"gyrowheel: error: --set R: the unit refuses -1.0 for every point: {R_REFUSED}\n"
    assert not out.exists()


@pytest.mark.parametrize("value, reason", [
    (-1, R_REFUSED),
    (2e6, "fmi2ExitInitializationMode: R must lie in [1e-06, 1e+06] m"),
])
def test_api_a_fixed_value_refused_at_initialisation(earth_fmu, value, reason):
    import gyrowheel
    with pytest.raises(SweepSpecError) as caught:
        gyrowheel.sweep(earth_fmu, grid={"beta_deg": "60:85:6"}, fixed={"R": value}, workers=0)
    assert caught.value.argument == "fixed"
    assert str(caught.value).startswith(f"fixed['R']: the unit refuses {float(value)!r} for every point: {reason}")


def test_a_refused_value_given_in_degrees_is_quoted_in_degrees(earth_fmu):
    """beta_min_deg = 89.99 leaves no lean between beta_min and pi - beta_min for any point: the
    refusal quotes 89.99 as given, not its 1.5706 rad."""
    with pytest.raises(SweepSpecError, match=r"^--set beta_min_deg: the unit refuses 89\.99 for every point: "):
        sweep(earth_fmu, grid={"beta_deg": [60.0, 85.0]}, fixed={"beta_min_deg": 89.99}, workers=0, stop_time=0.1)


def test_fixed_values_refused_only_together_are_named_together(earth_fmu):
    """Each alone takes the start lean (80 deg); together the lean lies below beta_min."""
    with pytest.raises(SweepSpecError, match=r"^--set beta_min, --set beta: the unit refuses these values together "
                                             r"for every point: .*initial lean beta must lie between beta_min"):
        sweep(earth_fmu, grid={"M": [1.0, 2.0]}, fixed={"beta_min": 1.2, "beta": 1.0}, workers=0, stop_time=0.1)


def test_a_grid_value_refused_at_initialisation_is_a_failed_point(earth_fmu):
    """Fine fixed values: the point the FMU refuses fails with its reason, the others run; a
    refused first point says nothing of the fixed values, which the next point then checks."""
    table = sweep(earth_fmu, grid={"M": [-1.0, 2.0]}, fixed={"R": 0.3}, workers=0, stop_time=0.1, ensemble=False)
    assert list(table["status"]) == ["error", "ok"]
    assert table["reason"][0] == "fmi2ExitInitializationMode: M (mass) must be > 0"
    with pytest.raises(SweepSpecError, match=re.escape(f"--set R: the unit refuses -1.0 for every point: {R_REFUSED}")):
        sweep(earth_fmu, grid={"M": [-1.0, 2.0]}, fixed={"R": -1.0}, workers=0, stop_time=0.1)


@pytest.mark.parametrize("leans", [[60.0, 85.0], [85.0, 60.0]])
def test_a_fixed_value_some_points_take_runs_those_points(earth_fmu, leans):
    """beta_min 80 deg refuses a start lean of 60 deg (below it) but takes 85 deg: no point of the
    sweep is refused for the fixed value alone, so the sweep runs, the 60 deg point failing with the
    FMU's reason, whichever point comes first."""
    table = sweep(earth_fmu, grid={"beta_deg": leans}, fixed={"beta_min_deg": 80.0}, workers=0, stop_time=0.1,
                  ensemble=False)
    status = dict(zip(table["beta_deg"], table["status"]))
    assert status == {60.0: "error", 85.0: "ok"}, table
    reason = dict(zip(table["beta_deg"], table["reason"]))[60.0]
    assert "initial lean beta must lie between beta_min and pi - beta_min" in reason


def test_the_check_of_fixed_values_is_one_initialisation(earth_fmu, monkeypatch):
    """Fixed values the FMU takes: one initialisation (no step) before the first point runs,
    then every point runs (one FMU run per point: ensemble=False)."""
    from gyrowheel.studies.target import FmuInstance
    calls = {"start": 0, "step": 0}
    for method in calls:
        def counted(self, *args, _method=method, _original=getattr(FmuInstance, method)):
            calls[_method] += 1
            return _original(self, *args)
        monkeypatch.setattr(FmuInstance, method, counted)
    before = []
    table = sweep(earth_fmu, grid={"beta_deg": "60:85:6"}, fixed={"R": 0.3}, workers=0, stop_time=0.1,
                  ensemble=False, on_start=lambda plan: before.append(dict(calls)))
    assert before == [{"start": 1, "step": 0}]
    assert list(table["status"]) == ["ok"] * 6 and calls["start"] == 7
