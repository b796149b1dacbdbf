"""Ctrl-C in a sweep without Dask at work: gyrowheel.studies.interrupt's stop request, the guard that
keeps a Ctrl-C during the cluster's start-up for later, the plain loop's batches, and the command's
exit status 130 with the table at -o always this sweep's."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gyrowheel.cli import main
from gyrowheel.studies import read_table
from gyrowheel.studies.interrupt import deferred_sigint
from terminal import AS_FROM_A_TERMINAL


@pytest.fixture
def default_sigint():
    """Python's own SIGINT handler for the test, as in a terminal (make test may run with it ignored)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def _ctrl_c() -> None:
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.05)  # the handler runs here (the main thread)


def test_ctrl_c_is_recorded_not_raised_and_acted_on_at_check(default_sigint):
    with pytest.raises(KeyboardInterrupt), deferred_sigint() as interrupt:
        _ctrl_c()  # nothing raised here, in the middle of whatever ran
        assert interrupt.requested
        with deferred_sigint() as inner:  # a nested block shares the request
            assert inner is interrupt
        with pytest.raises(KeyboardInterrupt):
            interrupt.check()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_request_never_checked_raises_when_the_block_ends(default_sigint):
    with pytest.raises(KeyboardInterrupt):
        with deferred_sigint() as interrupt:
            _ctrl_c()
            assert interrupt.wait(1.0)
    with deferred_sigint() as interrupt:  # and none came: nothing raised
        assert not interrupt.wait(0.0)


def test_a_programs_own_handler_is_left_alone():
    seen = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: seen.append(signum))
    try:
        with deferred_sigint() as interrupt:
            _ctrl_c()
            assert seen == [signal.SIGINT] and not interrupt.requested
            interrupt.request()  # a Ctrl-C that came another way (LocalCluster start-up)
            assert interrupt.requested
    except KeyboardInterrupt:
        pass
    else:
        pytest.fail("a request not acted on in the block must raise KeyboardInterrupt at its end")
    finally:
        handler = signal.signal(signal.SIGINT, previous)
    assert handler is not signal.default_int_handler and handler is not signal.SIG_IGN


def test_ctrl_c_in_the_plain_loop_keeps_the_batches_done(earth_fmu, tmp_path, monkeypatch):
    """workers=0 (`--workers 0`): a KeyboardInterrupt in the second batch leaves the first one's
    rows in the table on disk. Were every point one batch, a Ctrl-C would keep 0 rows however long
    the sweep had run (gyrowheel sweep ... --workers 0, Ctrl-C after 8 s of 1200 points)."""
    from gyrowheel.studies import execute as ex

    calls = []
    real = ex.run_batch

    def run_batch(*args):
        calls.append(len(args[-1]))
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args)

    monkeypatch.setattr(ex, "run_batch", run_batch)
    from gyrowheel.studies import sweep
    out = tmp_path / "t.csv"
    with pytest.raises(KeyboardInterrupt):
        sweep(earth_fmu, grid={"beta_deg": "70:80:20", "gamma_dot": "5:6:10"}, stop_time=0.1, workers=0,
              output=out, metrics="survived")
    table = read_table(out)
    assert calls[0] == ex.LOOP_BATCH == 64 and len(table) == calls[0]
    assert (table["status"] == "ok").all()


def test_ctrl_c_while_the_command_starts_is_exit_130(monkeypatch, capsys):
    """Ctrl-C in the first ~0.5 s of `gyrowheel sweep`, while make_parser imports the subcommands
    (pandas, dask): exit 130 without a traceback, not Python's own traceback through
    studies/api.py's `import pandas` and death by SIGINT (status -2) before main's handler."""
    from gyrowheel import cli

    def make_parser():
        raise KeyboardInterrupt  # where the Ctrl-C lands: inside an import

    monkeypatch.setattr(cli, "make_parser", make_parser)
    assert cli.main(["sweep", "x.fmu"]) == 130
    assert "Traceback" not in capsys.readouterr().err


def test_after_a_ctrl_c_the_command_exits_130_whatever_ctrl_c_follows(monkeypatch, default_sigint):
    """`gyrowheel sweep --scheduler ...`, Ctrl-C twice 50 ms apart: 'interrupted: 280 of 1200 points
    written' and exit 130, not status -2 (killed by the second SIGINT while Python exits, joining
    Dask's threads; 3 times in 4 without this). Once the command returns 130 as the program (argv
    from sys.argv), further SIGINTs are ignored; called with argv (a library caller) nothing
    changes."""
    from gyrowheel import cli

    def make_parser():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "make_parser", make_parser)
    assert cli.main(["sweep", "x.fmu"]) == 130
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    monkeypatch.setattr("sys.argv", ["gyrowheel", "sweep", "x.fmu"])
    assert cli.main() == 130
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN  # default_sigint restores it


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


def test_ctrl_c_before_the_run_leaves_a_previous_table_untouched(earth_fmu, tmp_path, capsys, monkeypatch):
    """Ctrl-C after the command has printed its plan but before the first row: the file at -o is
    the previous sweep's table, byte for byte (no empty table over it), as the message says."""
    import gyrowheel.studies.api as api
    out = tmp_path / "t.csv"
    argv = ["sweep", str(earth_fmu), "--grid", "M=1.5,2", "--stop-time", "0.1", "--workers", "0", "--no-progress",
            "-o", str(out)]
    assert main(argv) == 0 and len(read_table(out)) == 2
    before = out.read_bytes()

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(api, "run_plan", interrupted)
    assert main(argv) == 130
    assert f"interrupted: 0 of 2 points finished, {out} left as it was" in capsys.readouterr().err
    assert out.read_bytes() == before
