"""gyrowheel's Python API (gyrowheel/api.py): every verb from a path and from the parsed object,
its return values checked against independent readings (modelDescription.xml, fmpy, the CSV it
wrote), errors that name the function's own arguments, the version, and a light `import gyrowheel`."""
from __future__ import annotations

import csv
import importlib.metadata
import inspect
import json
import math
import os
import shutil
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

import gyrowheel
from conftest import ROOT, SCENES
from gyrowheel.cli import main

VERBS = ("build", "simulate", "info", "sweep", "export_c", "animate", "system_run")
HEAVY = ("pandas", "dask", "distributed", "matplotlib", "scipy", "PIL", "pyarrow", "tqdm", "imageio_ffmpeg",
         "pyssp_standard")


@pytest.fixture(scope="module")
def moon(tmp_path_factory):
    """paper_moon built by gyrowheel.build from the scene's path."""
    return gyrowheel.build(SCENES / "paper_moon.toml", tmp_path_factory.mktemp("api") / "moon.fmu")


@pytest.fixture(scope="module")
def moon_from_scene(tmp_path_factory):
    """paper_moon built from the parsed Scene, to the default output name in the working directory."""
    where = tmp_path_factory.mktemp("api_scene")
    cwd = os.getcwd()
    os.chdir(where)
    try:
        result = gyrowheel.build(gyrowheel.load_scene(SCENES / "paper_moon.toml"))
    finally:
        os.chdir(cwd)
    assert result.fmu == Path("paper_moon.fmu")  # the default: <scene name>.fmu, here
    return gyrowheel.BuildResult(where / result.fmu, result.spec, result.sources, result.identifier)


@pytest.fixture(scope="module")
def solo(moon, tmp_path_factory):
    """A system of one component (the moon wheel) as an .ssp."""
    from gyrowheel.cosim.system import Component, SystemDescription
    from gyrowheel.cosim.ssp import write_ssp
    path = tmp_path_factory.mktemp("api_system") / "solo.ssp"
    return write_ssp(SystemDescription("solo", [Component("wheel", moon.fmu)], [], 0.0, 1.0), path)


def _no_flags(message: str) -> None:
    """An API error names arguments, never the command line's flags."""
    assert "--" not in message and not message.startswith("-o "), message


# -- the package -----------------------------------------------------------------------------------

def test_version_is_the_installed_metadata_and_the_commands():
    assert gyrowheel.__version__ == importlib.metadata.version("gyrowheel")
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert pyproject["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "gyrowheel.__version__"}
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "--version"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout == f"gyrowheel {gyrowheel.__version__}\n" and r.stderr == ""


def test_import_gyrowheel_is_light():
    """`import gyrowheel` imports no third-party package; reaching the API functions (gyrowheel.api)
    none of the optional parts either; the command's parser and every --help neither."""
    code = f"""
import sys
heavy = {HEAVY!r} + ("casadi", "fmpy", "numpy")
import gyrowheel
print(sorted(m for m in heavy if m in sys.modules))
gyrowheel.build, gyrowheel.sweep, gyrowheel.animate, gyrowheel.GyrowheelError, gyrowheel.SweepSpecError
print(sorted(m for m in {HEAVY!r} if m in sys.modules))
import contextlib, io
from gyrowheel.cli import main
for argv in ([], ["build"], ["simulate"], ["system", "run"], ["export-c"], ["animate"], ["info"], ["sweep"]):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
        main([*argv, "--help"])
print(sorted(m for m in {HEAVY!r} if m in sys.modules))
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == ["[]", "[]", "[]"], r.stdout


def test_public_names():
    for name in gyrowheel.__all__:
        assert getattr(gyrowheel, name) is not None, name
    assert set(gyrowheel.__all__) <= set(dir(gyrowheel))
    with pytest.raises(AttributeError, match="module 'gyrowheel' has no attribute 'nope'"):
        gyrowheel.nope  # noqa: B018
    here = Path(gyrowheel.__file__).parent
    for name in (*VERBS, "Ensemble"):  # a submodule of that name would replace the function
        assert not (here / f"{name}.py").exists() and not (here / name).is_dir(), name
        assert callable(getattr(gyrowheel, name))
    for name in ("ArgumentError", "FmuError", "SceneError", "SweepSpecError", "SimulationError", "ExportError",
                 "AnimationError", "SystemFileError", "MasterError", "EnsembleError", "CompileError",
                 "MissingExtraError"):
        assert issubclass(getattr(gyrowheel, name), gyrowheel.GyrowheelError), name
    for name in ("ArgumentError", "FmuError", "SceneError", "SweepSpecError", "ExportError", "AnimationError",
                 "SystemFileError"):
        assert issubclass(getattr(gyrowheel, name), ValueError), name
    for name in ("SimulationError", "MasterError", "EnsembleError", "CompileError"):
        assert issubclass(getattr(gyrowheel, name), RuntimeError), name
    assert issubclass(gyrowheel.MissingExtraError, ImportError)
    # a wrong type: an ArgumentError (so a ValueError) and a TypeError, as Python's own
    assert issubclass(gyrowheel.ArgumentTypeError, gyrowheel.ArgumentError)
    assert issubclass(gyrowheel.ArgumentTypeError, TypeError)
    assert issubclass(gyrowheel.SweepInterrupted, KeyboardInterrupt)
    assert not issubclass(gyrowheel.SweepInterrupted, Exception)


@pytest.mark.parametrize("name", VERBS)
def test_every_verb_documents_its_arguments_return_and_errors(name):
    fn = getattr(gyrowheel, name)
    doc = inspect.getdoc(fn)
    assert "Returns" in doc and "Raises" in doc, name
    for parameter in inspect.signature(fn).parameters:
        assert parameter in doc, f"{name}: {parameter} undocumented"


# -- build ----------------------------------------------------------------------------------------

def test_build_from_a_path_and_from_a_scene(moon, moon_from_scene):
    assert isinstance(moon, gyrowheel.BuildResult) and moon.fmu.is_file() and moon.identifier == "paper_moon"
    assert os.fspath(moon) == str(moon.fmu)  # a BuildResult stands for its FMU
    assert moon_from_scene.fmu.is_file() and moon_from_scene.identifier == "paper_moon"
    a, b = gyrowheel.info(moon), gyrowheel.info(moon_from_scene)
    assert a.guid == b.guid and a.variables == b.variables  # the same model, the same FMU
    assert moon.spec.effects == moon_from_scene.spec.effects == ["gravity"]


@pytest.mark.parametrize("scene, output, error, message", [
    (SCENES / "missing.toml", None, "SceneError", "missing.toml: no such scene file"),
    ("[wheel]\nM = 2\n", None, "ArgumentError", "scene: got TOML text, not a path"),
    (42, None, TypeError, "scene must be a path to a scene file (.toml) or a gyrowheel.Scene, got int"),
    (SCENES / "paper_moon.toml", "{tmp}", "ArgumentError", "output {tmp}: is a directory; give a file name"),
    (SCENES / "paper_moon.toml", "{file}/x.fmu", "ArgumentError", "output {file}/x.fmu: cannot write: {file} is "
                                                                  "not a directory"),
])
def test_build_errors_name_the_argument(tmp_path, scene, output, error, message):
    (tmp_path / "file").write_text("")
    output = output and output.format(tmp=tmp_path, file=tmp_path / "file")
    cls = getattr(gyrowheel, error) if isinstance(error, str) else error
    with pytest.raises(cls) as exc:
        gyrowheel.build(scene, output)
    assert message.format(tmp=tmp_path, file=tmp_path / "file") in str(exc.value)
    _no_flags(str(exc.value))
    if "output" in message:
        assert exc.value.argument == "output"


def test_build_refusals_of_the_model_are_scene_errors(tmp_path):
    scene = gyrowheel.load_scene(SCENES / "paper_moon.toml")
    scene.outputs = ["nope"]
    with pytest.raises(gyrowheel.SceneError, match=r"^scene 'paper_moon': \[outputs\] keep: unknown output 'nope'"):
        gyrowheel.build(scene, tmp_path / "x.fmu")
    with pytest.raises(TypeError, match="taylor must be True or False, got str 'yes'"):
        gyrowheel.build(SCENES / "paper_moon.toml", tmp_path / "x.fmu", taylor="yes")
    assert not (tmp_path / "x.fmu").exists()


# -- simulate -------------------------------------------------------------------------------------

def test_simulate_from_a_path_and_from_the_build_result(moon, tmp_path):
    from fmpy import simulate_fmu
    kw = dict(stop_time=1.0, output_interval=0.25)
    a = gyrowheel.simulate(moon.fmu, start_values={"gamma_dot": 7, "solver": "rk4"}, **kw,
                           output=tmp_path / "run.csv", plot=tmp_path / "run.png")
    b = gyrowheel.simulate(moon, start_values=["gamma_dot=7", "solver=rk4"], **kw)
    assert a.dtype == b.dtype and np.array_equal(a, b)
    direct = simulate_fmu(str(moon.fmu), fmi_type="CoSimulation", start_values={"gamma_dot": 7.0, "solver": 2}, **kw)
    assert np.array_equal(a, direct)  # fmpy's own run, as fmpy returns it
    assert list(a["time"]) == [0.0, 0.25, 0.5, 0.75, 1.0] and a["gamma_dot"][0] == 7.0
    rows = list(csv.DictReader((tmp_path / "run.csv").open()))
    assert [float(r["beta"]) for r in rows] == list(a["beta"]) and rows[0]["fallen"] == "0"
    assert (tmp_path / "run.png").stat().st_size > 10_000
    default = gyrowheel.simulate(moon, stop_time=0.05)  # the DefaultExperiment's step size
    assert np.allclose(np.diff(default["time"]), 0.01)


def test_simulate_reports_the_fall(moon):
    run = gyrowheel.simulate(moon, start_values={"gamma_dot": 0.0, "beta_min": 0.1})
    assert run["fallen"][-1] and not run["fallen"][0] and 0.5 < run["time"][-1] < 20.0
    assert math.isclose(math.sin(run["beta"][-1]), math.sin(0.1), abs_tol=1e-6)


@pytest.mark.parametrize("fmu, kwargs, error, message, argument", [
    ("{moon}", dict(stop_time=-1), "ArgumentError", "stop_time must be > 0, got -1.0", "stop_time"),
    ("{moon}", dict(stop_time="x"), "ArgumentError", "stop_time must be a number of seconds, got str 'x'",
     "stop_time"),
    ("{moon}", dict(output_interval=float("inf")), "ArgumentError", "output_interval must be finite, got inf",
     "output_interval"),
    ("{moon}", dict(start_values={"colour": 3}), "UnknownArgumentNameError", "start_values: unknown variable 'colour'",
     "start_values"),
    ("{moon}", dict(start_values={"max_internal_steps": 1.5}), "ArgumentError",
     "start_values: value '1.5' for 'max_internal_steps' is not a valid Integer", "start_values"),
    ("{moon}", dict(start_values={"max_internal_steps": 10**12}), "ArgumentError",
     "start_values: value '1000000000000' for 'max_internal_steps' is out of range [1, 2147483647] (Integer)",
     "start_values"),
    ("{moon}", dict(start_values={"z": 1.0}), "ArgumentError",
     "start_values: variable 'z' is a calculated output and cannot be set", "start_values"),
    ("{moon}", dict(start_values=["M"]), "ArgumentError", "start_values 'M': expected NAME=VALUE", "start_values"),
    ("{moon}", dict(start_values="M=2"), "ArgumentError", "start_values: expected a mapping", "start_values"),
    ("{moon}", dict(output="{tmp}"), "ArgumentError", "output {tmp}: is a directory; give a file name", "output"),
    ("{moon}", dict(plot="{file}/p.png"), "ArgumentError", "plot {file}/p.png: cannot write: {file} is not a "
                                                          "directory", "plot"),
    ("{tmp}/missing.fmu", {}, "FmuError", "{tmp}/missing.fmu: no such FMU file", "fmu"),
    (str(SCENES / "paper_moon.toml"), {}, "FmuError", "paper_moon.toml: a scene, not an FMU; build its FMU first", "fmu"),
    ("{tmp}", {}, "FmuError", "{tmp}: is a directory, not an FMU file", "fmu"),
    ("{text}", {}, "FmuError", "{text}: not a readable FMU", "fmu"),
    ("{moon}", dict(start_values={"M": -2.0}, stop_time=0.1), "ArgumentError",
     "start_values: the FMU refused the start values: M (mass) must be > 0", "start_values"),
])
def test_simulate_errors_name_the_argument(moon, tmp_path, fmu, kwargs, error, message, argument):
    (tmp_path / "text.fmu").write_text("not a zip")
    (tmp_path / "file").write_text("")
    fill = dict(moon=moon.fmu, tmp=tmp_path, file=tmp_path / "file", text=tmp_path / "text.fmu")
    kwargs = {k: v.format(**fill) if isinstance(v, str) and "{" in v else v for k, v in kwargs.items()}
    with pytest.raises(getattr(gyrowheel, error)) as exc:
        gyrowheel.simulate(fmu.format(**fill), **kwargs)
    assert message.format(**fill) in str(exc.value), str(exc.value)
    assert exc.value.argument == argument
    _no_flags(str(exc.value))
    assert not any(tmp_path.glob("*.csv"))


def test_simulate_refuses_a_wrong_type():
    with pytest.raises(TypeError, match="fmu must be a path to an FMU"):
        gyrowheel.simulate(3.5)


# -- info -----------------------------------------------------------------------------------------

def _xml_variables(fmu: Path) -> tuple[ET.Element, list[dict]]:
    """modelDescription.xml read with ElementTree alone: the root and each ScalarVariable's facts."""
    with zipfile.ZipFile(fmu) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
    types = {t.get("name"): t for t in root.iter("SimpleType")}
    out = []
    for sv in root.find("ModelVariables"):
        kind = next(iter(sv))
        declared = kind.get("declaredType")
        unit = kind.get("unit") or (types[declared][0].get("unit") if declared else None)
        out.append(dict(name=sv.get("name"), type=kind.tag, causality=sv.get("causality", "local"),
                        variability=sv.get("variability", "continuous"), initial=sv.get("initial"),
                        value_reference=int(sv.get("valueReference")), description=sv.get("description"),
                        unit=unit, start=kind.get("start"), declared_type=declared))
    return root, out


def test_info_from_a_path_and_the_build_result_against_the_model_description(moon):
    info = gyrowheel.info(moon.fmu)
    assert gyrowheel.info(moon) == info
    root, variables = _xml_variables(moon.fmu)
    assert (info.model_name, info.fmi_version, info.guid, info.generation_tool, info.generation_date,
            info.description) == (root.get("modelName"), "2.0", root.get("guid"), "gyrowheel",
                                  root.get("generationDateAndTime"), root.get("description"))
    assert info.co_simulation == root.find("CoSimulation").get("modelIdentifier") == "paper_moon"
    assert info.model_exchange == root.find("ModelExchange").get("modelIdentifier")
    exp = root.find("DefaultExperiment")
    assert info.default_experiment == gyrowheel.DefaultExperiment(
        float(exp.get("startTime")), float(exp.get("stopTime")), float(exp.get("stepSize")),
        float(exp.get("tolerance")))
    assert [v.name for v in info.variables] == [v["name"] for v in variables]
    for got, want in zip(info.variables, variables):
        for key in ("type", "causality", "variability", "initial", "value_reference", "description", "unit",
                    "declared_type"):
            assert getattr(got, key) == want[key], (got.name, key)
        text = want["start"]
        typed = (None if text is None else float(text) if want["type"] == "Real" else
                 int(text) if want["type"] in ("Integer", "Enumeration") else text == "true")
        assert got.start == typed and type(got.start) is type(typed), got.name
    solver = info.variable("solver")
    items = [(i.get("name"), int(i.get("value"))) for i in root.iter("Item")]
    assert list(solver.items.items()) == items and info.solvers == tuple(n for n, _ in items)
    # the scene names no solver: auto, and the Taylor kernel it integrates with
    assert "taylor" in info.solvers and info.taylor and info.auto_solver == "taylor" and not info.modes
    assert info.variable("g").start == 1.625 and info.variable("g").unit == "m/s2"
    with zipfile.ZipFile(moon.fmu) as zf:
        platforms = {n.split("/")[1] for n in zf.namelist() if n.startswith("binaries/") and not n.endswith("/")}
    assert tuple(p.folder for p in info.platforms) == tuple(f"binaries/{f}" for f in sorted(platforms)) \
        == ("binaries/linux64",) and info.sources
    assert [(p.name, str(p)) for p in info.platforms] == [("x86_64-linux", "x86_64-linux (binaries/linux64)")]
    assert info.effects == tuple(moon.spec.effects) == ("gravity",)
    with pytest.raises(KeyError, match="no variable 'nope'; variables: M, R"):
        info.variable("nope")


def test_info_of_a_taylor_fmu_and_the_ensemble_from_a_build_result(example_build):
    built = example_build("paper_earth", taylor=True)
    info = gyrowheel.info(built)
    assert info.taylor and "taylor" in info.solvers
    a, b = gyrowheel.Ensemble(built), gyrowheel.Ensemble(built.fmu)
    kw = dict(starts={"gamma_dot": [6.0, 3.0]}, rel_tol=1e-10)
    ra, rb = a.run(2.0, **kw), b.run(2.0, **kw)
    assert isinstance(ra, gyrowheel.EnsembleResult)
    assert np.array_equal(ra.y_final, rb.y_final) and np.array_equal(ra.t_final, rb.t_final)


def test_info_text_and_json(moon, capsys):
    """`gyrowheel info` prints str(info): model, description, guid, experiment, interfaces,
    effects, solvers, platforms, sources, then the variable table, every column as wide as its
    longest entry (a long name or start value never runs into the next column), an Enumeration's
    start by its item's name, then each Enumeration's items; `--json` prints info.as_dict()."""
    from fmpy import read_model_description
    info = gyrowheel.info(moon)
    md = read_model_description(str(moon.fmu))
    e = md.defaultExperiment
    lines = str(info).splitlines()
    head = [f"model        {md.modelName}  (FMI {md.fmiVersion}, generated by {md.generationTool})",
            f"description  {md.description}", f"guid         {md.guid}",
            f"experiment   {e.startTime} .. {e.stopTime} s, step {e.stepSize}, tolerance {e.tolerance}",
            "interfaces   Co-Simulation (paper_moon), Model Exchange (paper_moon)",
            f"generated    {md.generationDateAndTime}", "effects      gravity",
            "solvers      euler, rk4, dopri5, rosenbrock, dop853, taylor, auto",
            "auto         taylor at the default tolerance 1e-08 (rule: taylor at every rel_tol where the FMU has "
            "the Taylor kernel and no mode switches, else dop853)",
            "platforms    x86_64-linux (binaries/linux64)",
            "sources      yes, with the Taylor kernel (solver taylor, the ensemble path)"]
    assert lines[:len(head)] == head
    table = lines[len(head):-1]
    assert lines[-1] == ("items of solver (Solver): euler = 1, rk4 = 2, dopri5 = 3, rosenbrock = 4, dop853 = 5, "
                         "taylor = 6, auto = 7")
    assert len(table) == 1 + len(md.modelVariables)
    header = table[0].split()
    assert header == ["name", "causality", "variability", "start", "unit", "description"]
    left = [table[0].index(h) for h in ("name", "causality", "variability")]
    start_end = table[0].index("start") + len("start")
    unit_col = table[0].index("unit")
    for line, v in zip(table[1:], md.modelVariables):
        assert line[:left[1]].rstrip() == v.name and line[left[1]:left[2]].rstrip() == v.causality
        start = "" if v.start is None else str(v.start)
        if v.name == "solver":
            start = f"auto ({v.start})"
        assert line[left[2]:start_end].split("  ")[0].rstrip() == v.variability, line
        assert line[:start_end].endswith(start), (line, start)
        assert line[unit_col:].startswith(v.unit or (v.declaredType.unit if v.declaredType else None) or " ")
        assert line.rstrip().endswith(v.description or "")
    assert max(len(v.name) for v in md.modelVariables) == len("max_internal_steps")  # the widest name fits
    assert main(["info", str(moon.fmu)]) == 0
    assert capsys.readouterr().out == str(info) + "\n"
    assert main(["info", "--json", str(moon.fmu)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data == json.loads(json.dumps(info.as_dict())) and data["variables"][0]["name"] == "M"
    assert data["default_experiment"]["stop_time"] == 20.0 and data["effects"] == ["gravity"]
    assert data["auto_solver"] == info.auto_solver == ("taylor" if info.taylor else "dop853")


def test_info_errors(tmp_path):
    with pytest.raises(gyrowheel.FmuError, match="missing.fmu: no such FMU file") as exc:
        gyrowheel.info(tmp_path / "missing.fmu")
    assert exc.value.argument == "fmu"
    (tmp_path / "bad.fmu").write_bytes(b"PK not really")
    with pytest.raises(gyrowheel.FmuError, match="bad.fmu: not a readable FMU"):
        gyrowheel.info(tmp_path / "bad.fmu")
    with pytest.raises(TypeError, match="fmu must be a path"):
        gyrowheel.info(None)


# -- sweep ----------------------------------------------------------------------------------------

SMALL = dict(grid={"gamma_dot": [5.0, 7.0]}, fixed={"beta_deg": 80.0}, stop_time=0.5, workers=0,
             metrics=["survived", "final:beta"])


def test_sweep_from_a_path_a_build_result_a_scene_and_a_system(moon, solo, tmp_path):
    calls = []
    a = gyrowheel.sweep(moon.fmu, **SMALL, output=tmp_path / "t.csv", on_start=lambda plan: calls.append(
        (len(plan.values), plan.settings.stop_time)))
    assert calls == [(2, 0.5)] and list(a["gamma_dot"]) == [5.0, 7.0] and (a["status"] == "ok").all()
    b = gyrowheel.sweep(moon, **SMALL)
    c = gyrowheel.sweep(gyrowheel.load_scene(SCENES / "paper_moon.toml"), **SMALL)
    d = gyrowheel.sweep(moon.fmu, **{**SMALL, "fixed": ["beta_deg=80"], "grid": ["gamma_dot=5,7"]})
    e = gyrowheel.sweep(solo, **SMALL)
    columns = ["point", "gamma_dot", "survived", "final_beta", "status", "reason"]
    for other in (b, c, d, e):
        assert other[columns].equals(a[columns])
    from gyrowheel.studies import read_table
    assert read_table(tmp_path / "t.csv")[columns[:-1]].equals(a[columns[:-1]])  # (CSV: an empty reason reads as NaN)
    direct = gyrowheel.simulate(moon, stop_time=0.5, start_values={"gamma_dot": 7.0, "beta": math.radians(80.0)})
    assert math.isclose(a["final_beta"].iloc[1], direct["beta"][-1], rel_tol=1e-13)


def test_sweep_interrupted_keeps_the_points_done(moon, tmp_path, monkeypatch):
    from gyrowheel.studies import execute
    real, calls = execute.run_batch, []

    def run_batch(*args):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args)
    monkeypatch.setattr(execute, "run_batch", run_batch)
    out = tmp_path / "t.csv"
    with pytest.raises(gyrowheel.SweepInterrupted) as stop:
        gyrowheel.sweep(moon, grid={"gamma_dot": [5.0, 6.0, 7.0]}, stop_time=0.2, workers=0, batch_size=1,
                        output=out, metrics="survived")
    assert (stop.value.written, stop.value.total, stop.value.output) == (1, 3, out)
    assert list(stop.value.table["gamma_dot"]) == [5.0] and len(out.read_text().splitlines()) == 2
    assert isinstance(stop.value, KeyboardInterrupt)


@pytest.mark.parametrize("kwargs, message, argument, flags", [
    (dict(grid={"beta_deg": "60:89"}), "grid['beta_deg'] = '60:89': expected START:STOP:N, START:STOP:N:log "
                                       "or V1,V2,...", "grid", "--grid 'beta_deg=60:89': expected NAME=START"),
    (dict(grid=["beta_deg=60:89"]), "grid 'beta_deg=60:89': expected NAME=START:STOP:N", "grid", "--grid"),
    (dict(grid={"M": float("inf")}), "grid['M']: inf is not finite", "grid", "grid 'M'"),
    (dict(random={"M": "normal:2"}, samples=2), "random['M'] = 'normal:2': expected normal:MU:SIGMA or "
                                                "uniform:A:B", "random", "--random 'M=normal:2'"),
    (dict(random={"M": "normal:2:0.1"}), "random needs samples N (N >= 1)", "random", "--random needs --samples"),
    (dict(grid={"M": [1.0]}, fixed={"R": float("nan")}), "fixed['R']: value nan for 'R' is not finite", "fixed",
     "--set R: value nan"),
    (dict(grid={"M": [1.0]}, fixed=["R"]), "fixed 'R': expected NAME=SPEC", "fixed", "--set 'R'"),
    (dict(grid={"M": [1.0]}, fixed={"M": 2.0}), "'M' is both swept and given in fixed", None, "fixed with --set"),
    (dict(grid={"M": [1.0]}, fixed={"solver": "rk4"}, solver="dopri5"),
     "'solver' given twice (solver and fixed['solver'])", None, "(--solver and --set solver)"),
    (dict(grid={"M": [1.0]}, stop_time=float("inf")), "stop_time must be finite", "stop_time", "--stop-time"),
    (dict(grid={"M": [1.0]}, output_interval=0.0), "output_interval must be > 0", "output_interval",
     "--output-interval"),
    (dict(random={"M": "normal:2:0.1"}, samples=2, seed=-1), "seed must be a whole number >= 0", "seed", "--seed"),
    (dict(random={"M": "normal:2:0.1"}, samples=2.5), "samples must be a whole number", "samples", "--samples"),
    (dict(grid={"M": [1.0]}, output="t.xlsx"), "output t.xlsx: unknown format '.xlsx'", "output", "-o t.xlsx"),
    (dict(grid={"M": [1.0]}, plot="x.xyz"), "plot x.xyz: unknown image format", "plot", "--plot x.xyz"),
    (dict(grid={"M": [1.0]}, workers=-1), "workers must be >= 0, got -1", "workers", "--workers"),
    (dict(grid={"M": [1.0]}, batch_size=0), "batch_size must be >= 1, got 0", "batch_size", "--batch-size"),
    (dict(grid={"M": [1.0]}, metrics="lean"), "metrics 'lean': unknown metric", "metrics", "--metrics 'lean'"),
    (dict(grid={"M": [1.0]}, metric_functions=["no_such_module_xyz:f"]),
     "metric_functions 'no_such_module_xyz:f': cannot load", "metric_functions", "--metric-function"),
    (dict(grid={"M": [1.0]}, derive="no_such_module_xyz:f"), "derive 'no_such_module_xyz:f': cannot load",
     "derive", "--derive"),
    (dict(grid={"speed": [1.0]}), "input 'speed': unknown variable 'speed'; settable: M, R", None, "input 'speed'"),
])
def test_sweep_errors_name_the_argument(moon, kwargs, message, argument, flags):
    """gyrowheel.sweep words the engine's errors in its argument names; the engine's own words (the
    command's flags, which `gyrowheel sweep` prints) stay on the error as engine_text."""
    kwargs = {"stop_time": 0.1, "workers": 0, **kwargs}
    with pytest.raises(gyrowheel.SweepSpecError) as exc:
        gyrowheel.sweep(moon, **kwargs)
    assert message in str(exc.value), str(exc.value)
    assert exc.value.argument == argument
    _no_flags(str(exc.value))
    assert flags in exc.value.engine_text, exc.value.engine_text


def _flags_in_strings(path: Path) -> set[str]:
    """The command-line flags in a module's strings (its docstrings aside): what its errors can name."""
    import ast
    from gyrowheel.wording import FLAG
    tree = ast.parse(path.read_text())
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef)) and node.body
                  and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    return {flag for node in ast.walk(tree) if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in docstrings for flag in FLAG.findall(node.value)}


@pytest.mark.parametrize("package, table, verb", [("studies", "SWEEP", "sweep"), ("animation", "ANIMATE", "animate")])
def test_the_api_rewords_every_flag_its_engine_names(package, table, verb):
    """A flag the engine's messages name and gyrowheel.wording does not know would reach an API user
    as a flag: every one it can name must have its argument (the command's own parsers aside)."""
    import gyrowheel.wording
    known = getattr(gyrowheel.wording, table)
    engine = [p for p in (ROOT / package).glob("*.py") if p.name not in ("cli.py", "command.py")]
    named = set().union(*(_flags_in_strings(p) for p in engine))
    assert named and named <= set(known), sorted(named - set(known))
    assert set(known.values()) <= set(inspect.signature(getattr(gyrowheel, verb)).parameters)  # real arguments


def test_sweep_plot_metric_is_checked_against_the_table(moon, tmp_path):
    with pytest.raises(gyrowheel.SweepSpecError, match="^plot_metric 'nope': no such column; columns: point"):
        gyrowheel.sweep(moon, grid={"gamma_dot": [5.0]}, stop_time=0.1, workers=0, plot=tmp_path / "p.png",
                        plot_metric="nope")
    with pytest.raises(TypeError, match="source must be a path .*, got int"):
        gyrowheel.sweep(42, grid={"gamma_dot": [5.0]}, workers=0)


# -- export_c -------------------------------------------------------------------------------------

def test_export_c_from_a_path_and_from_a_scene(tmp_path, monkeypatch):
    a = gyrowheel.export_c(SCENES / "paper_moon.toml", tmp_path / "a", check=False)
    monkeypatch.chdir(tmp_path)
    b = gyrowheel.export_c(gyrowheel.load_scene(SCENES / "paper_moon.toml"), check=False)
    assert b.directory == Path("paper_moon_c") and isinstance(a, gyrowheel.ExportResult)
    assert a.identifier == b.identifier == "paper_moon" and a.files == b.files
    for name in a.files:
        if name.startswith("src/"):
            assert (tmp_path / "a" / name).read_bytes() == (tmp_path / b.directory / name).read_bytes(), name
    assert "paper_moon.toml" in (tmp_path / "a" / "paper_moon.h").read_text()  # the scene file it came from


def test_export_c_errors(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(gyrowheel.ExportError, match="file: exists and is not a directory"):
        gyrowheel.export_c(SCENES / "paper_moon.toml", tmp_path / "file", check=False)
    with pytest.raises(gyrowheel.SceneError, match="missing.toml: no such scene file"):
        gyrowheel.export_c(tmp_path / "missing.toml", tmp_path / "out")
    with pytest.raises(TypeError, match="check must be True or False"):
        gyrowheel.export_c(SCENES / "paper_moon.toml", tmp_path / "out", check="no")
    with pytest.raises(TypeError, match="output must be a directory path, got int"):
        gyrowheel.export_c(SCENES / "paper_moon.toml", 3)


# -- animate --------------------------------------------------------------------------------------

def test_animate_from_a_csv_and_from_the_result_array(moon, tmp_path):
    run = gyrowheel.simulate(moon, stop_time=1.0, output=tmp_path / "run.csv")
    a = gyrowheel.animate(tmp_path / "run.csv", tmp_path / "a.html", fmu=moon, fps=10)
    b = gyrowheel.animate(run, tmp_path / "b.html", fmu=moon.fmu, fps=10)
    assert isinstance(a, gyrowheel.Timeline) and len(a.time) == 11
    assert np.array_equal(a.time, b.time) and np.array_equal(a.track, b.track)
    assert a.parameters == b.parameters and a.parameters.R == 0.17
    html_a, html_b = (tmp_path / "a.html").read_text(), (tmp_path / "b.html").read_text()
    assert "gyrowheel: run.csv" in html_a and "gyrowheel: result" in html_b
    assert html_a.replace("gyrowheel: run.csv", "gyrowheel: result") == html_b
    c = gyrowheel.animate(run, tmp_path / "c.gif", R=0.17, fps=5, size="96x64")
    assert c.parameters.source["R"] == "R" and c.options.size == (96, 64)
    from PIL import Image
    with Image.open(tmp_path / "c.gif") as im:
        assert im.n_frames == 6 and im.size == (96, 64)


@pytest.mark.parametrize("kwargs, message, argument", [
    (dict(fps=0), "fps must be in (0, 120], got 0", "fps"),
    (dict(speed=-1), "speed must be > 0, got -1", "speed"),
    (dict(size="wide"), "size: expected WIDTHxHEIGHT in pixels", "size"),
    (dict(size=(10,)), "size: expected (WIDTH, HEIGHT) in pixels or 'WIDTHxHEIGHT', got (10,)", "size"),
    (dict(size=(20, 20)), "size must be between 64x64 and 4096x4096 pixels", "size"),
    (dict(start=5.0), "start 5 is outside the run's time 0 .. 1 s", "start"),
    (dict(R=0.3), "R = 0.3 m (given as R) contradicts result: z = R sin(beta) gives R = 0.17 m", None),
    (dict(fmu="{tmp}/none.fmu"), "none.fmu: no such FMU file", None),
])
def test_animate_errors_name_the_argument(moon, tmp_path, kwargs, message, argument):
    run = gyrowheel.simulate(moon, stop_time=1.0)
    kwargs = {k: v.format(tmp=tmp_path) if isinstance(v, str) else v for k, v in kwargs.items()}
    with pytest.raises(gyrowheel.AnimationError) as exc:
        gyrowheel.animate(run, tmp_path / "out.gif", **kwargs)
    assert message in str(exc.value), str(exc.value)
    assert exc.value.argument == argument
    _no_flags(str(exc.value))
    assert not (tmp_path / "out.gif").exists()


def test_animate_bad_results(moon, tmp_path):
    run = gyrowheel.simulate(moon, stop_time=0.1)
    with pytest.raises(gyrowheel.AnimationError, match=r"^result: missing column beta \(needs time, x, y"):
        gyrowheel.animate(run[["time", "x", "y", "alpha", "gamma"]], tmp_path / "x.gif")
    with pytest.raises(gyrowheel.AnimationError, match="^result: no rows"):
        gyrowheel.animate(run[:0], tmp_path / "x.gif")
    with pytest.raises(TypeError, match="result must be a result CSV .* got int"):
        gyrowheel.animate(42, tmp_path / "x.gif")


# -- system_run -----------------------------------------------------------------------------------

def test_system_run_from_an_ssp_and_from_its_description(moon, solo, tmp_path):
    from gyrowheel.cosim.ssp import read_ssp
    a = gyrowheel.system_run(solo, stop_time=0.5, start_values={"wheel.gamma_dot": 7.0}, output=tmp_path / "s.csv")
    b = gyrowheel.system_run(read_ssp(solo, tmp_path / "unpacked"), stop_time=0.5,
                             start_values={"wheel": {"gamma_dot": 7.0}})
    c = gyrowheel.system_run(solo, stop_time=0.5, start_values=["wheel.gamma_dot=7"])
    assert isinstance(a, gyrowheel.RunResult) and a.stopped_by is None and len(a.data) == 51
    assert np.array_equal(a.data, b.data) and np.array_equal(a.data, c.data)
    back = np.genfromtxt(tmp_path / "s.csv", delimiter=",", names=True)
    assert np.array_equal(back["wheelbeta"], a.data["wheel.beta"])
    alone = gyrowheel.simulate(moon, stop_time=0.5, output_interval=0.01, start_values={"gamma_dot": 7.0})
    assert np.allclose(alone["beta"], a.data["wheel.beta"], rtol=1e-14, atol=0)  # one FMU, one grid
    timeline = gyrowheel.animate(a, tmp_path / "s.html", fmu=solo, fps=10)  # a system's result, as data
    assert len(timeline.time) == 6 and timeline.parameters.R == 0.17 and timeline.parameters.source["R"] == "solo.ssp"


@pytest.mark.parametrize("system, kwargs, error, message, argument", [
    ("{solo}", dict(step=0), "ArgumentError", "step must be > 0, got 0.0", "step"),
    ("{solo}", dict(stop_time=-1), "ArgumentError", "stop_time must be > 0, got -1.0", "stop_time"),
    ("{solo}", dict(stop_time=0.333), "ArgumentError", "stop time 0.333 is not a whole number (>= 1) of steps 0.01",
     "stop_time"),
    ("{solo}", dict(start_values={"M": 2}), "ArgumentError",
     "start_values['M']: expected COMPONENT.VARIABLE with a component of wheel", "start_values"),
    ("{solo}", dict(start_values=["M=2"]), "ArgumentError",
     "start_values 'M=2': expected COMPONENT.VARIABLE=VALUE with a component of wheel", "start_values"),
    ("{solo}", dict(start_values={"nope": {"M": 2}}), "ArgumentError",
     "start_values['nope']: no such component; expected a component of wheel", "start_values"),
    ("{solo}", dict(start_values={"wheel.colour": 3}), "ArgumentError",
     "start_values, component wheel: unknown variable 'colour'", "start_values"),
    ("{solo}", dict(output="{tmp}"), "ArgumentError", "output {tmp}: is a directory", "output"),
    ("{tmp}/missing.ssp", {}, "SystemFileError", "missing.ssp: no such SSP file", "system"),
    ("{solo}", dict(start_values={"wheel.M": -1.0}, stop_time=0.1), "ArgumentError",
     "start_values: wheel refused the start values: M (mass) must be > 0 (wheel.M = -1.0)", "start_values"),
])
def test_system_run_errors_name_the_argument(solo, tmp_path, system, kwargs, error, message, argument):
    fill = dict(solo=solo, tmp=tmp_path)
    kwargs = {k: v.format(**fill) if isinstance(v, str) else v for k, v in kwargs.items()}
    with pytest.raises(getattr(gyrowheel, error)) as exc:
        gyrowheel.system_run(system.format(**fill), **kwargs)
    assert message.format(**fill) in str(exc.value), str(exc.value)
    assert exc.value.argument == argument
    _no_flags(str(exc.value))
    with pytest.raises(TypeError, match="system must be a path to an .ssp or a SystemDescription, got int"):
        gyrowheel.system_run(3)


# -- the command calls the API --------------------------------------------------------------------

@pytest.mark.parametrize("argv, verb, expected", [
    (["build", "s.toml", "-o", "x.fmu", "--taylor", "--platforms", "all"], "build",
     (("s.toml", "x.fmu"), dict(build_dir=None, taylor=True, platforms="all", fmi=None, arrays=None))),
    (["build", "s.toml", "-o", "x.fmu", "--fmi", "3", "--no-arrays"], "build",
     (("s.toml", "x.fmu"), dict(build_dir=None, taylor=None, platforms=None, fmi=3, arrays=False))),
    (["build", "s.toml", "-o", "x.fmu", "--no-taylor"], "build",
     (("s.toml", "x.fmu"), dict(build_dir=None, taylor=False, platforms=None, fmi=None, arrays=None))),
    (["simulate", "m.fmu", "--stop-time", "2", "--set", "M=2", "-o", "o.csv"], "simulate",
     (("m.fmu",), dict(stop_time=2.0, output_interval=None, start_values=["M=2"], output="o.csv", plot=None,
                       events=[]))),
    (["info", "m.fmu"], "info", (("m.fmu",), {})),
    (["export-c", "s.toml", "-o", "d", "--no-compile"], "export_c", (("s.toml", "d"), dict(check=False))),
    (["system", "run", "l.ssp", "--step", "0.02", "--set", "wheel.M=2", "-o", "l.csv"], "system_run",
     (("l.ssp",), dict(step=0.02, stop_time=None, start_values=["wheel.M=2"], output="l.csv"))),
    (["animate", "r.csv", "-o", "r.gif", "--fps", "5", "--size", "96x64"], "animate",
     (("r.csv", Path("r.gif")), dict(R=None, fmu=None, component=None, fps=5.0, speed=1.0, size="96x64", trail=None,
                                     start=None, stop=None))),
])
def test_the_command_calls_the_api(monkeypatch, capsys, argv, verb, expected):
    """Each verb of `gyrowheel` is one call of the function of the same name in gyrowheel.api."""
    import gyrowheel.api
    seen = []

    def spy(*args, **kwargs):
        seen.append((args, kwargs))
        raise gyrowheel.ArgumentError("spy: called")
    monkeypatch.setattr(gyrowheel.api, verb, spy)
    assert main(argv) in (1, 2)
    assert seen == [expected]
    err = capsys.readouterr().err
    assert err.startswith("gyrowheel: error: ") and err.endswith("spy: called\n") and err.count("\n") == 1


def test_the_sweep_command_calls_the_api(monkeypatch, capsys, tmp_path):
    import gyrowheel.api
    seen = []

    def spy(source, **kwargs):
        seen.append((source, kwargs))
        raise gyrowheel.SweepSpecError("spy: called")
    monkeypatch.setattr(gyrowheel.api, "sweep", spy)
    assert main(["sweep", "m.fmu", "--grid", "M=1,2", "--set", "R=0.2", "--workers", "0", "-o", "t.csv"]) == 2
    (source, kwargs), = seen
    assert source == "m.fmu" and kwargs["grid"] == ["M=1,2"] and kwargs["fixed"] == ["R=0.2"]
    assert kwargs["workers"] == 0 and kwargs["output"] == "t.csv" and callable(kwargs["on_start"])
    assert capsys.readouterr().err == "gyrowheel: error: spy: called\n"


def test_the_readme_example_prints_what_it_says(tmp_path):
    """README.md's "Python API" example, run as written (from a directory holding its scene): each
    print gives the lines commented beneath it."""
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## Python API"):]
    code = section[section.index("```python\n") + 10:section.index("```\n", section.index("```python"))]
    expected, printing = [], False
    for line in code.splitlines():  # the comment lines right under a print are its output
        if printing and line.startswith("# "):
            expected.append(line[2:])
        else:
            printing = "print(" in line
    (tmp_path / "examples" / "scenes").mkdir(parents=True)
    shutil.copy(SCENES / "paper_moon.toml", tmp_path / "examples" / "scenes")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == expected
