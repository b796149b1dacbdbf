"""The gyrowheel command: build, simulate, info; bad input is one line and a non-zero exit."""
from __future__ import annotations

import csv
import subprocess
import sys

import pytest

from conftest import ROOT, SCENES


def gyrowheel(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "gyrowheel", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd or ROOT)


def test_build_simulate_info(tmp_path):
    fmu = tmp_path / "moon.fmu"
    r = gyrowheel("build", SCENES / "paper_moon.toml", "-o", fmu)
    assert r.returncode == 0, r.stderr
    assert fmu.is_file() and "built" in r.stdout
    out, png = tmp_path / "moon.csv", tmp_path / "moon.png"
    r = gyrowheel("simulate", fmu, "--stop-time", 2, "--output-interval", 0.5, "--set", "gamma_dot=7",
                  "--set", "solver=rk4", "--set", "max_step=0.05", "-o", out, "--plot", png)  # rk4's step
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(out.open()))
    assert [float(row["time"]) for row in rows] == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert float(rows[0]["gamma_dot"]) == 7.0
    assert png.stat().st_size > 10_000
    r = gyrowheel("info", fmu)
    assert r.returncode == 0
    assert "paper_moon" in r.stdout and "gamma_dot" in r.stdout and "1.625" in r.stdout
    assert "auto         taylor at the default tolerance 1e-08" in r.stdout  # the scene names no solver


@pytest.fixture(scope="module")
def built(earth_fmu):
    """The paper's earth FMU, the run's shared default build (conftest earth_fmu), read only;
    `gyrowheel build` itself is test_build_simulate_info's."""
    return earth_fmu


def _bad_scene(tmp_path, text):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("args,fragment", [
    (("build", "missing.toml"), "missing.toml: no such scene file"),
    (("simulate", "missing.fmu"), "missing.fmu: no such FMU file"),
    (("info", "missing.fmu"), "missing.fmu: no such FMU file"),
    (("simulate", "{fmu}", "--set", "colour=3"), "unknown variable 'colour'"),
    (("simulate", "{fmu}", "--set", "M=heavy"), "value 'heavy' for 'M' is not a valid Real"),
    (("simulate", "{fmu}", "--set", "solver=rk45"), "valid: euler, rk4, dopri5"),
    (("simulate", "{fmu}", "--set", "energy=3"), "'energy' is a calculated output"),
    (("simulate", "{fmu}", "--set", "M"), "expected NAME=VALUE"),
    # an fmi2Integer is 32 bits (fmpy would wrap 3000000000 to -1294967296): the variable's range is named
    (("simulate", "{fmu}", "--set", "max_internal_steps=3000000000"),
     "value '3000000000' for 'max_internal_steps' is out of range [1, 2147483647] (Integer)"),
    (("simulate", "{fmu}", "--stop-time", "-1"), "--stop-time must be > 0"),
    (("simulate", "{fmu}", "--set", "M=-2"), "M (mass) must be > 0"),
    (("build", "{bad}"), "bad.toml: [wheel] mass: unknown key"),
    # outputs that cannot be written are refused before the run, in one line
    (("simulate", "{fmu}", "-o", "{bad}/x.csv"), "bad.toml is not a directory"),
    (("simulate", "{fmu}", "--plot", "{bad}/p.png"), "bad.toml is not a directory"),
    (("simulate", "{fmu}", "-o", "."), "-o .: is a directory; give a file name"),
    (("export-c", str(SCENES / "paper_earth.toml"), "-o", "{bad}", "--no-compile"), "exists and is not a directory"),
    (("simulate", "{bad}"), "bad.toml: a scene, not an FMU; build its FMU first"),
    (("info", "{bad}"), "bad.toml: a scene, not an FMU"),
    (("simulate", "{fmu}", "--output-interval", "0"), "--output-interval must be > 0, got 0.0"),
    (("simulate", "{fmu}", "--plot", "."), "--plot .: is a directory; give a file name"),
])
def test_bad_input_is_one_line(built, tmp_path, args, fragment):
    bad = _bad_scene(tmp_path, "[wheel]\nmass = 2\n")
    args = [a.format(fmu=built, bad=bad) for a in args]
    r = gyrowheel(*args, cwd=tmp_path)
    assert r.returncode != 0
    assert "Traceback" not in r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("gyrowheel: error: ")
    assert fragment in lines[0]


def test_simulate_reports_the_fall(built, tmp_path):
    r = gyrowheel("simulate", built, "--set", "gamma_dot=1", "--set", "beta_min=0.1", "-o", tmp_path / "f.csv")
    assert r.returncode == 0, r.stderr
    assert "(events: fall at t = " in r.stdout
    rows = list(csv.DictReader((tmp_path / "f.csv").open()))
    assert rows[0]["fallen"] == "0" and rows[-1]["fallen"] == "1"


@pytest.mark.parametrize("args", [
    ("simulate", "x.fmu", "--stop-time", "inf"),
    ("simulate", "x.fmu", "--output-interval", "nan"),
    ("system", "run", "x.ssp", "--step", "inf"),
    ("system", "run", "x.ssp", "--stop-time", "inf"),
    ("sweep", "x.fmu", "--stop-time", "nan"),
    ("sweep", "x.fmu", "--max-step", "inf"),
    ("animate", "x.csv", "--R", "inf"),
])
def test_non_finite_numbers_are_refused(tmp_path, args):
    """Every number option is a finite float: inf and nan are refused by argparse (exit 2, one
    error line, no traceback) before anything runs. `simulate --output-interval inf` used to
    run and write 2 rows; `system run --stop-time inf` raised OverflowError."""
    r = gyrowheel(*args, cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert f"argument {args[-2]}: '{args[-1]}' is not a finite number" in r.stderr


@pytest.mark.parametrize("kwargs,message", [
    # before: int(1.5) = 1, silently, then "the budget of internal steps is spent" from the FMU
    (dict(start_values={"max_internal_steps": 1.5}), "value '1.5' for 'max_internal_steps' is not a valid Integer"),
    (dict(start_values={"max_internal_steps": 3e9}),
     "value '3000000000.0' for 'max_internal_steps' is out of range [1, 2147483647] (Integer)"),
    (dict(start_values={"solver": 2.7}), "value '2.7' for 'solver' is not a valid Enumeration"),  # before: rk4
    (dict(start_values={"M": "abc"}), "value 'abc' for 'M' is not a valid Real"),  # before: a bare ValueError
    (dict(start_values={"gamma_dot": True}), "value 'true' for 'gamma_dot' is not a valid Real"),
    (dict(start_values={"z": 1.0}), "variable 'z' is a calculated output and cannot be set"),
    (dict(stop_time="x"), "stop_time must be a number, got str 'x'"),
])
def test_python_run_checks_values_by_name_and_type(built, kwargs, message):
    """gyrowheel.simulation.run (the Python side of gyrowheel simulate) checks Python start values
    like --set does: nothing truncated, every error a SimulationError naming the value."""
    from gyrowheel.simulation import SimulationError, run
    with pytest.raises(SimulationError) as exc:
        run(built, **{"stop_time": 0.1, **kwargs})
    assert message in str(exc.value)
    r = run(built, stop_time=0.1, start_values={"gamma_dot": 0, "solver": "rk4", "max_internal_steps": 2000})
    assert r["time"][-1] == pytest.approx(0.1)


def test_version():
    from gyrowheel import __version__
    r = gyrowheel("--version")
    assert r.returncode == 0 and r.stdout == f"gyrowheel {__version__}\n"


def test_bench_is_no_verb():
    """The work-precision benchmark is a study of a checkout (make bench, benchmarks/work_precision.py),
    not a verb of the installed command."""
    r = gyrowheel("bench", "--quick")
    assert r.returncode == 2 and "invalid choice: 'bench'" in r.stderr
    assert "bench" not in gyrowheel("--help").stdout


def test_info_json(built):
    import json
    r = gyrowheel("info", "--json", built)
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["model_name"] == "paper_earth" and data["fmi_version"] == "2.0" and data["platforms"] == [
        {"name": "x86_64-linux", "folder": "binaries/linux64"}]
    g = next(v for v in data["variables"] if v["name"] == "g")
    assert (g["causality"], g["start"], g["unit"]) == ("parameter", 9.81, "m/s2")
    assert "solvers      euler, rk4, dopri5, rosenbrock, dop853" in gyrowheel("info", built).stdout


@pytest.mark.parametrize("args, line", [
    # an output that cannot be written is bad input (exit 2), for build as for simulate
    (("build", "{scene}", "-o", "{dir}"), "-o {dir}: is a directory; give a file name"),
    (("simulate", "{fmu}", "-o", "{dir}"), "-o {dir}: is a directory; give a file name"),
    (("build", "{scene}", "-o", "{csv}/x.fmu"), "-o {csv}/x.fmu: cannot write: {csv} is not a directory"),
    (("build", "{scene}", "-o", "{dir}/x.fmu", "--keep-build", "{csv}"), "--keep-build {csv}: exists and is not a "
                                                                          "directory"),
    # argparse's own errors are one line too, without the usage
    (("simulate", "{fmu}", "--stop-time", "nan"), "argument --stop-time: 'nan' is not a finite number (see "
                                                  "gyrowheel simulate --help)"),
    (("simulate",), "the following arguments are required: fmu (see gyrowheel simulate --help)"),
    # a run whose rows would not fit in the memory is refused before it starts
    (("simulate", "{fmu}", "--stop-time", "1e300"), "--stop-time 1e+300 s with --output-interval 0.01 s: 1e+302 "
                                                    "communication points of 14 columns would take "),
    # a directory, or a file of another kind, named as such
    (("simulate", "{dir}"), "{dir}: is a directory, not an FMU file"),
    (("info", "{dir}"), "{dir}: is a directory, not an FMU file"),
    (("animate", "{dir}", "-o", "{dir}/x.gif"), "{dir}: is a directory, not a result CSV"),
    (("system", "run", "{dir}"), "{dir}: is a directory, not an SSP file"),
    (("system", "run", "{fmu}"), "{fmu}: an FMU, not an SSP system; simulate it with gyrowheel.simulate "
                                 "(`gyrowheel simulate`)"),
    (("build", "{fmu}"), "{fmu}: an FMU (a zip archive), not a scene file: a scene is TOML text (docs/scenes.md)"),
    (("export-c", "{fmu}", "-o", "{dir}/c"), "{fmu}: an FMU (a zip archive), not a scene file"),
    # a value given twice: refused, not the last one taken
    (("simulate", "{fmu}", "--set", "gamma_dot=8", "--set", "gamma_dot=9"),
     "--set: 'gamma_dot' given twice (gamma_dot=8, gamma_dot=9)"),
    # a value every point of a sweep would fail with: refused, no table of failed rows
    (("sweep", "{fmu}", "--grid", "beta_deg=60:80:3", "--rel-tol", "-1", "--stop-time", "2", "--workers", "0",
      "-o", "{dir}/rt.csv"), "--rel-tol: the unit refuses -1.0 for every point: fmi2SetReal: rel_tol = -1 is outside "
                             "its valid range"),
])
def test_bad_input_exits_2_with_one_line(built, tmp_path, args, line):
    (tmp_path / "moon.csv").write_text("time\n0\n")
    fill = dict(scene=SCENES / "paper_earth.toml", fmu=built, dir=tmp_path, csv=tmp_path / "moon.csv")
    r = gyrowheel(*[a.format(**fill) for a in args], cwd=tmp_path)
    assert (r.returncode, r.stdout) == (2, ""), r.stderr
    assert r.stderr.startswith("gyrowheel: error: " + line.format(**fill)) and r.stderr.count("\n") == 1, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["moon.csv"]  # nothing written


def test_a_reader_that_goes_away_is_no_error(built):
    """`gyrowheel info moon.fmu --json | head -2`: a reader that has what it wants and goes away
    is no error (exit 0, nothing on stderr)."""
    for reader in ("head -2", "true"):  # true reads nothing: the pipe is closed before the first write
        r = subprocess.run(f"{sys.executable} -m gyrowheel info --json {built} | {reader}; exit ${{PIPESTATUS[0]}}",
                           shell=True, executable="/bin/bash", capture_output=True, text=True, cwd=ROOT)
        assert (r.returncode, r.stderr) == (0, ""), r.stderr
    assert r.stdout == ""


def test_the_sweep_says_where_it_runs(monkeypatch, capsys):
    """The sweep's first line says where it runs in words, with the number of workers."""
    from types import SimpleNamespace

    import gyrowheel.api
    from gyrowheel.cli import main
    plan = SimpleNamespace(values=[{}] * 4, settings=SimpleNamespace(start_time=0.0, stop_time=2.0,
                                                                     output_interval=0.5))

    def spy(source, **kwargs):
        kwargs["on_start"](plan)
        raise gyrowheel.SweepSpecError("spy")
    monkeypatch.setattr(gyrowheel.api, "sweep", spy)
    from gyrowheel.studies.execute import cores as machine_cores
    cores = machine_cores()
    for argv, where in ((["--workers", "2"], "a LocalCluster of 2 workers"),
                        (["--workers", "1"], "a LocalCluster of 1 worker"),
                        ([], f"a LocalCluster of {cores} worker{'s' * (cores != 1)} (one per core)"),
                        (["--workers", "0"], "an in-process loop"),
                        (["--scheduler", "tcp://10.0.0.5:8786"], "the Dask scheduler at tcp://10.0.0.5:8786")):
        assert main(["sweep", "m.fmu", "--grid", "M=1,2", *argv]) == 2
        assert capsys.readouterr().err.splitlines()[0] == f"sweep: 4 points, t = 0 .. 2 s every 0.5 s, on {where}"
