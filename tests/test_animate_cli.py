"""`gyrowheel animate`: what it writes and says; bad input is one line on stderr and exit 2."""
from __future__ import annotations

import os
import subprocess
import sys
import zipfile

import pytest
from PIL import Image

from animate_data import rolling_csv
from conftest import ROOT
from gyrowheel.cli import main


def test_animate_command_writes_a_gif(tmp_path):
    csv = rolling_csv(tmp_path / "run.csv", stop=1.0, gyrover=True)
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "animate", str(csv), "-o", str(tmp_path / "run.gif"),
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


def _mkfifo(path):
    os.mkfifo(path)
    return path


def test_a_byte_order_mark_is_not_part_of_the_header(tmp_path):
    """A CSV saved by a spreadsheet starts with UTF-8's byte order mark: the same run."""
    import gyrowheel
    csv = rolling_csv(tmp_path / "run.csv", stop=0.5)
    marked = tmp_path / "marked.csv"
    marked.write_bytes(b"\xef\xbb\xbf" + csv.read_bytes())
    a = gyrowheel.animate(csv, tmp_path / "a.html")
    b = gyrowheel.animate(marked, tmp_path / "b.html")
    assert list(a.time) == list(b.time) and a.readout == b.readout


def _write(path, text):
    path.write_text(text)
    return path


def _write_bytes(path, data):
    path.write_bytes(data)
    return path


def _mkdir(path):
    path.mkdir()
    return path


FOREIGN_XML = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="spring" guid="{00000000-0000-0000-0000-000000000000}">
  <CoSimulation modelIdentifier="spring"/>
  <ModelVariables>
    <ScalarVariable name="k" valueReference="0" causality="parameter" variability="fixed">
      <Real start="1"/>
    </ScalarVariable>
  </ModelVariables>
  <ModelStructure/>
</fmiModelDescription>
"""


def _zip(path, xml=FOREIGN_XML):
    """A zip archive holding a modelDescription.xml: an FMU (of a model with no R) or an .ssp's stand-in."""
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("modelDescription.xml", xml)
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
    (lambda d: _zip(d / "moon.fmu"), (), "moon.fmu: an FMU, not a result CSV: animate draws a run; simulate the FMU "
                                         "first (gyrowheel simulate, gyrowheel.simulate) and give its result"),
    (lambda d: _zip(d / "loop.ssp"), (), "loop.ssp: an SSP system, not a result CSV: animate draws a run; run the "
                                         "system first"),
    (lambda d: _zip(d / "data.zip"), (), "data.zip: a zip archive, not a result CSV"),
    (lambda d: _write_bytes(d / "bin.csv", b"\xff\xfe\x00t"), (),
     "bin.csv: not a text file (a result CSV is UTF-8 text): invalid start byte at byte 0"),
    (lambda d: _write_bytes(d / "nul.csv", b"time\x00x"), (),
     "nul.csv: not a text file (a result CSV is UTF-8 text): a NUL byte at byte 4"),
    (lambda d: _mkdir(d / "dir.csv"), (), "dir.csv: is a directory, not a result CSV"),
    (lambda d: _mkfifo(d / "fifo.csv"), (),
     "fifo.csv: not a regular file (a device, FIFO or socket), not a result CSV"),
    (lambda d: d / "none.csv", (), "none.csv: no such result file"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--R", "-1"), "--R must be a finite number > 0 (the wheel radius in m), "
                                                         "got -1"),
    (lambda d: rolling_csv(d / "ok.csv"), ("--R", "0"), "--R must be a finite number > 0"),
    (lambda d: rolling_csv(d / "ok.csv") and _zip(d / "spring.fmu") and d / "ok.csv", ("--fmu", "{d}/spring.fmu"),
     "--fmu {d}/spring.fmu: no start value of R (the wheel radius): not a wheel FMU built by gyrowheel; give --R, "
     "or leave out --fmu (R from z / sin(beta))"),
    (lambda d: rolling_csv(d / "ok.csv") and _mkdir(d / "fmu_dir") and d / "ok.csv", ("--fmu", "{d}/fmu_dir"),
     "fmu_dir: is a directory, not an FMU"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, make, extra, fragment):
    path = make(tmp_path)
    args = [a.format(d=tmp_path) for a in extra]
    if "-o" not in args:
        args += ["-o", str(tmp_path / "out.gif")]
    assert main(["animate", str(path), *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gyrowheel: error: ") and err.count("\n") == 1, err
    assert fragment.format(d=tmp_path) in err, err
    assert not (tmp_path / "out.gif").exists()


def test_api_names_its_arguments_and_says_what_a_file_is(tmp_path):
    """gyrowheel.animate: a radius out of range is named as R (not a contradiction of the
    result), a foreign FMU as fmu, an FMU (its BuildResult) given as the result is said to be one."""
    import gyrowheel
    from gyrowheel.fmu_build.builder import BuildResult
    csv = rolling_csv(tmp_path / "ok.csv")
    for R, got in ((-1.0, "-1"), (0.0, "0"), (float("nan"), "nan"), ("0.17", "str '0.17'")):
        with pytest.raises(gyrowheel.AnimationError) as err:
            gyrowheel.animate(csv, tmp_path / "x.html", R=R)
        assert str(err.value) == f"R must be a finite number > 0 (the wheel radius in m), got {got}"
        assert err.value.argument == "R"
    with pytest.raises(gyrowheel.AnimationError) as err:
        gyrowheel.animate(csv, tmp_path / "x.html", fmu=_zip(tmp_path / "spring.fmu"))
    assert str(err.value).startswith(f"fmu {tmp_path / 'spring.fmu'}: no start value of R (the wheel radius): "
                                     "not a wheel FMU built by gyrowheel; give R, or leave out fmu")
    assert err.value.argument == "fmu"
    built = BuildResult(fmu=_zip(tmp_path / "moon.fmu"), spec=None, sources=None, identifier="moon")
    with pytest.raises(gyrowheel.AnimationError, match=r"^.*moon.fmu: an FMU, not a result CSV"):
        gyrowheel.animate(built, tmp_path / "a.html")
    assert not (tmp_path / "x.html").exists() and not (tmp_path / "a.html").exists()


def test_a_speed_beyond_the_run_shows_its_start_and_stop(tmp_path, capsys):
    """speed = 1e300 on a 2 s run: one frame step is longer than the run, so the animation is its
    first and last instant (2 frames, not the start alone), and the command says so."""
    import gyrowheel
    csv = rolling_csv(tmp_path / "ok.csv")
    tl = gyrowheel.animate(csv, tmp_path / "a.html", speed=1e300)
    assert list(tl.time) == [0.0, 2.0]
    tl = gyrowheel.animate(csv, tmp_path / "b.html", fps=1e-300)  # a step of inf s
    assert list(tl.time) == [0.0, 2.0]
    assert main(["animate", str(csv), "-o", str(tmp_path / "c.gif"), "--speed", "1e300", "--size", "96x64"]) == 0
    out, err = capsys.readouterr()
    assert "wrote " + str(tmp_path / "c.gif") + ": 2 frames at 25 fps" in out
    assert ("note: at ×1e+300 and 25 fps one frame is 4e+298 s of the run, more than the 2 s shown: the animation "
            "shows only its first and last instant; lower --speed") in err


def _as_system_result(csv, path, components=("wheel",)):
    """The columns of `csv` as `gyrowheel system run` writes them: "<component>.<variable>", plus a
    controller's columns (one component, or the wheel's columns under several names)."""
    lines = csv.read_text().splitlines()
    names = [n.strip('"') for n in lines[0].split(",")]
    header = ["time"] + [f"{c}.{n}" for c in components for n in names[1:]] + ["controller.tilt_cmd"]
    rows = [r.split(",") for r in lines[1:]]
    body = [",".join([r[0]] + [v for _ in components for v in r[1:]] + ["0.0"]) for r in rows]
    path.write_text(",".join(f'"{h}"' for h in header) + "\n" + "\n".join(body) + "\n")
    return path


def test_animate_reads_a_system_result(tmp_path, capsys):
    """`gyrowheel system run` writes "<component>.<variable>" columns; animate draws the component with
    the wheel's columns (here the only one), the same frames as from the wheel's own table."""
    plain = rolling_csv(tmp_path / "plain.csv", stop=1.0, gyrover=True)
    system = _as_system_result(plain, tmp_path / "loop.csv")
    assert main(["animate", str(system), "-o", str(tmp_path / "loop.gif"), "--fps", "10", "--size", "96x64"]) == 0
    assert main(["animate", str(plain), "-o", str(tmp_path / "plain.gif"), "--fps", "10", "--size", "96x64"]) == 0
    with Image.open(tmp_path / "loop.gif") as a, Image.open(tmp_path / "plain.gif") as b:
        assert a.n_frames == b.n_frames == 11
    assert (tmp_path / "loop.gif").read_bytes() == (tmp_path / "plain.gif").read_bytes()
    capsys.readouterr()
    two = _as_system_result(plain, tmp_path / "two.csv", components=("left", "right"))
    assert main(["animate", str(two), "-o", str(tmp_path / "two.gif")]) == 2
    assert "components left, right all have the wheel's columns: choose one with --component" in capsys.readouterr().err
    assert main(["animate", str(two), "-o", str(tmp_path / "two.gif"), "--component", "right", "--fps", "5",
                 "--size", "96x64"]) == 0
    capsys.readouterr()
    assert main(["animate", str(system), "-o", str(tmp_path / "x.gif"), "--component", "controller"]) == 2
    assert "no component 'controller' with the wheel's columns" in capsys.readouterr().err


@pytest.mark.parametrize("option,value", [("--R", "inf"), ("--fps", "nan"), ("--trail", "inf"), ("--start", "nan")])
def test_non_finite_numbers_are_refused(tmp_path, capsys, option, value):
    """inf and nan are not seconds, frames or metres: argparse refuses them (exit 2, no traceback)."""
    csv = rolling_csv(tmp_path / "ok.csv")
    with pytest.raises(SystemExit) as exc:
        main(["animate", str(csv), "-o", str(tmp_path / "out.gif"), option, value])
    assert exc.value.code == 2
    assert f"argument {option}: '{value}' is not a finite number" in capsys.readouterr().err


def test_a_missing_output_directory_and_a_directory_refused(tmp_path, capsys):
    """No verb makes the directory of its output (gyrowheel.output_files.check_output_file)."""
    csv = rolling_csv(tmp_path / "ok.csv", stop=0.5)
    missing = tmp_path / "new" / "dir"
    assert main(["animate", str(csv), "-o", str(missing / "run.html")]) == 2
    assert f"directory {missing} does not exist" in capsys.readouterr().err
    assert not (tmp_path / "new").exists()
    (tmp_path / "dir.gif").mkdir()
    assert main(["animate", str(csv), "-o", str(tmp_path / "dir.gif")]) == 2
    assert "dir.gif: is a directory; give a file name" in capsys.readouterr().err


def test_an_output_that_is_no_regular_file_is_refused(tmp_path, capsys):
    """A FIFO (or a device) under the output's name: refused before anything is drawn, left as it is."""
    import stat
    csv = rolling_csv(tmp_path / "ok.csv", stop=0.5)
    os.mkfifo(tmp_path / "fifo.gif")
    assert main(["animate", str(csv), "-o", str(tmp_path / "fifo.gif")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ("fifo.gif: exists and is not a regular file (a device, FIFO or socket); give a "
                                     "file name") in err, err
    assert stat.S_ISFIFO(os.stat(tmp_path / "fifo.gif").st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo.gif", "ok.csv"]
