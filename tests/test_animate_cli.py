"""`gyrowheel animate`: what it writes and says; bad input is one line on stderr and exit 2."""
from __future__ import annotations

import subprocess
import sys

import pytest
from PIL import Image

from animate_data import rolling_csv
from conftest import ROOT
from fmu_build.cli import main


def test_animate_command_writes_a_gif(tmp_path):
    csv = rolling_csv(tmp_path / "run.csv", stop=1.0, gyrover=True)
    r = subprocess.run([sys.executable, "-m", "fmu_build", "animate", str(csv), "-o", str(tmp_path / "run.gif"),
                        "--fps", "10", "--size", "128x96", "--trail", "0.5"], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == ("wrote " + str(tmp_path / "run.gif") + ": 11 frames at 10 fps, 128x96, "
                                "t = 0 .. 1 s at ×1 (R = 0.17 m from z / sin(beta))")
    assert "flywheel geometry" in r.stderr and "model's defaults" in r.stderr  # no --fmu: said so
    with Image.open(tmp_path / "run.gif") as im:
        assert im.n_frames == 11 and im.size == (128, 96)


def test_default_output_name_and_aliasing_note(tmp_path, monkeypatch, capsys):
    csv = rolling_csv(tmp_path / "fast.csv", stop=1.0, spin=40.0)
    monkeypatch.chdir(tmp_path)
    assert main(["animate", str(csv), "--fps", "5", "--size", "96x64"]) == 0
    assert (tmp_path / "fast.gif").is_file()
    assert "turns up to 8.0 rad between frames" in capsys.readouterr().err


def _write(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize("make,extra,fragment", [
    (lambda d: d / "missing.csv", (), "missing.csv: no such result file"),
    (lambda d: _write(d / "empty.csv", ""), (), "empty.csv: empty file"),
    (lambda d: _write(d / "header.csv", '"time","x","y","alpha","beta","gamma"\n'), (), "a header but no rows"),
    (lambda d: _write(d / "cols.csv", '"time","x","y","alpha"\n0,0,0,0\n'), (),
     "cols.csv: missing columns beta, gamma (needs time, x, y, alpha, beta, gamma)"),
    (lambda d: _write(d / "text.csv", "time,x,y,alpha,beta,gamma\n0,0,0,0,up,0\n"), (),
     "row 2, column 'beta': 'up' is not a number"),
    (lambda d: _write(d / "nan.csv", "time,x,y,alpha,beta,gamma\n0,0,0,0,nan,0\n"), (),
     "column 'beta' is nan (not finite)"),
    (lambda d: _write(d / "ragged.csv", "time,x,y,alpha,beta,gamma\n0,0,0,0,1\n"), (), "row 2 has 5 fields"),
    (lambda d: _write(d / "back.csv", "time,x,y,alpha,beta,gamma\n0,0,0,0,1.5,0\n1,0,0,0,1.5,0\n0.5,0,0,0,1.5,0\n"),
     ("--R", "0.17"), "time decreases at row 4 (1 -> 0.5 s)"),
    (lambda d: _write(d / "noR.csv", "time,x,y,alpha,beta,gamma\n0,0,0,0,1.5,0\n"), (),
     "wheel radius is unknown (no z column): pass --R or --fmu"),
    (lambda d: _write(d / "half.csv", "time,x,y,alpha,beta,gamma,tilt\n0,0,0,0,1.5,0,0\n"), ("--R", "0.2"),
     "has 'tilt' but not 'theta_p'"),
    (lambda d: rolling_csv(d / "ok.csv"), ("-o", "{d}/run.avi"), "unknown output format '.avi'"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--R", "0.3"), "R = 0.3 m (from --R) contradicts"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--fmu", "{d}/none.fmu"), "none.fmu: no such FMU file"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--fmu", "{d}/ok.csv"), "ok.csv: not a readable FMU"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--fps", "0"), "--fps must be in (0, 120], got 0"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--speed", "-1"), "--speed must be > 0, got -1"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--size", "wide"), "--size: expected WIDTHxHEIGHT"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--size", "20x20"), "--size must be between 64x64 and 4096x4096"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--trail", "-2"), "--trail must be >= 0 seconds, got -2"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--start", "5"), "--start 5 is outside the run's time 0 .. 2 s"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--start", "1.5", "--stop", "1"), "--stop 1 is before --start 1.5"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--speed", "1e-5"), "frames is more than 20000: raise --speed"),
    (lambda d: rolling_csv(d / "ok.csv"), ("-o", "{d}/odd.mp4", "--size", "99x64"), "even width and height"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, make, extra, fragment):
    path = make(tmp_path)
    args = [a.format(d=tmp_path) for a in extra]
    if "-o" not in args:
        args += ["-o", str(tmp_path / "out.gif")]
    assert main(["animate", str(path), *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gyrowheel: error: ") and err.count("\n") == 1, err
    assert fragment in err, err
    assert not (tmp_path / "out.gif").exists()
