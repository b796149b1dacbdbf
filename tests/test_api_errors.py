"""What the front door does with the inputs a new user tries: every error of a gyrowheel function
is a GyrowheelError naming the function's own argument (an ArgumentTypeError, also a TypeError,
for a value of the wrong type), or the file it was given (a directory, a scene where an FMU goes,
an FMU of FMI 3.0 or without a binary for this platform), or the size of the run it would have
been (one memory rule for every run that collects rows); nothing it cannot use is accepted
silently. The command's side (one line, exit status 2) is in tests/test_cli.py."""
from __future__ import annotations

import math
import re
import time
import zipfile

import pytest

import gyrowheel
from conftest import SCENES
from gyrowheel.errors import ArgumentTypeError


@pytest.fixture(scope="module")
def moon(example_build):
    """The moon wheel without the Taylor kernel (the refusals of solver taylor below)."""
    return example_build("paper_moon", taylor=False)


@pytest.fixture(scope="module")
def solo(moon, tmp_path_factory):
    """A system of one component (the moon wheel) as an .ssp."""
    from gyrowheel.cosim.system import Component, SystemDescription
    from gyrowheel.cosim.ssp import write_ssp
    path = tmp_path_factory.mktemp("errors_system") / "solo.ssp"
    return write_ssp(SystemDescription("solo", [Component("wheel", moon.fmu)], [], 0.0, 1.0), path)


@pytest.fixture(scope="module")
def foreign(moon, tmp_path_factory):
    """FMUs gyrowheel did not build as they come: FMI 1.0, FMI 2.0 with a win64 binary only, a
    modelDescription.xml that breaks the FMI 2.0 schema, and one without a description."""
    where = tmp_path_factory.mktemp("foreign")
    with zipfile.ZipFile(moon.fmu) as zf:
        files = {name: zf.read(name) for name in zf.namelist()}
    xml = files["modelDescription.xml"].decode()

    def write(name, content):
        with zipfile.ZipFile(where / name, "w") as zf:
            for member, data in content.items():
                zf.writestr(member, data)
        return where / name
    fmi1 = ('<?xml version="1.0" encoding="UTF-8"?>\n<fmiModelDescription fmiVersion="1.0" modelName="x" '
            'modelIdentifier="x" guid="{1}" numberOfContinuousStates="0" numberOfEventIndicators="0">'
            '<ModelVariables/></fmiModelDescription>')
    return dict(
        fmi1=write("fmi1.fmu", {"modelDescription.xml": fmi1, "binaries/linux64/x.so": b""}),
        win=write("win.fmu", {n.replace("linux64/paper_moon.so", "win64/paper_moon.dll"): d for n, d in files.items()}),
        schema=write("bad3.fmu", {**files, "modelDescription.xml": xml.replace('causality="parameter"',
                                                                               'causality="nonsense"', 1)}),
        undescribed=write("nodesc.fmu", {**files, "modelDescription.xml": re.sub(r' description="[^"]*"', "", xml,
                                                                                 count=1)}))


def _names(exc: pytest.ExceptionInfo, argument: str | None, *fragments: str) -> None:
    """The error is a GyrowheelError with this argument, its message holding every fragment."""
    assert isinstance(exc.value, gyrowheel.GyrowheelError), type(exc.value)
    assert exc.value.argument == argument, (exc.value.argument, str(exc.value))
    for fragment in fragments:
        assert fragment in str(exc.value), str(exc.value)


# -- one memory rule for every run that collects rows -----------------------------------------------

def test_a_run_too_large_for_the_memory_is_refused_before_it_starts(moon, solo, tmp_path):
    """A result that cannot fit is refused at once, not collected until the machine runs out of
    memory; a count too large to read in digits is given as 1e+302."""
    outputs = sum(v.causality == "output" for v in gyrowheel.info(moon).variables)
    t0 = time.monotonic()
    with pytest.raises(gyrowheel.ArgumentError) as exc:
        gyrowheel.simulate(moon, stop_time=1e300, output=tmp_path / "run.csv")
    _names(exc, "stop_time", f"stop_time 1e+300 s with output_interval 0.01 s: 1e+302 communication points of "
                             f"{outputs + 1} columns would take ", "more than half of this machine's ",
           "GiB: choose a shorter stop_time or a longer output_interval")
    assert not (tmp_path / "run.csv").exists()
    with pytest.raises(gyrowheel.ArgumentError) as exc:
        gyrowheel.system_run(solo, stop_time=1e300)
    _names(exc, "stop_time", f"stop_time 1e+300 s with step 0.01 s: 1e+302 communication points of {outputs + 1} "
                             "columns would take ", "choose a shorter stop_time or a longer step")
    assert not re.search(r"\d{13}", str(exc.value))  # a count is 3 digits and an exponent, not 303 digits
    with pytest.raises(gyrowheel.SweepSpecError) as exc:
        gyrowheel.sweep(moon, grid={"M": [2.0]}, stop_time=20.0, output_interval=1e-12, workers=0)
    _names(exc, "stop_time", "stop_time 20 s with output_interval 1e-12 s: 2e+13 communication points of ",
           "choose a shorter stop_time or a longer output_interval")
    assert time.monotonic() - t0 < 30  # refused, not run


def test_one_memory_rule_for_simulate_system_run_and_sweep(moon, solo, monkeypatch):
    """The same rule and the same numbers for every run: on a machine of 4 KiB each of these small
    runs would take more than half of it and is refused naming its size; with the machine's real
    memory the same calls run."""
    import gyrowheel.arguments
    monkeypatch.setattr(gyrowheel.arguments, "physical_memory", lambda: 4096)
    calls = {"simulate": lambda: gyrowheel.simulate(moon, stop_time=1.0),
             "system_run": lambda: gyrowheel.system_run(solo, stop_time=1.0),
             "sweep": lambda: gyrowheel.sweep(moon, grid={"M": [2.0]}, stop_time=1.0, workers=0)}
    for name, call in calls.items():
        with pytest.raises(gyrowheel.GyrowheelError) as exc:
            call()
        assert isinstance(exc.value, ValueError), name
        _names(exc, "stop_time", "communication points of ", f"more than half of this machine's {4096 / 2**30:.3g} GiB: "
                                                             "choose a shorter stop_time or a longer ")
    monkeypatch.undo()
    assert len(calls["simulate"]()) == 101 and len(calls["system_run"]().data) == 101
    assert list(calls["sweep"]()["status"]) == ["ok"]


# -- an FMU: the one place that opens it, for simulate, info and sweep ------------------------------

@pytest.mark.parametrize("kind, message", [
    ("fmi1", "fmi1.fmu: FMI 1.0 is not supported: gyrowheel runs FMI 2.0 and 3.0 FMUs"),
    ("win", "win.fmu: no binary for linux64 (binaries/linux64/paper_moon.so); the FMU has binaries for "
            "x86_64-windows (binaries/win64)"),
    ("schema", "bad3.fmu: not a readable FMU: modelDescription.xml breaks the FMI 2.0 schema: "),
])
def test_an_fmu_that_cannot_run_here_says_why(foreign, capsys, kind, message):
    """FMI 1.0, a binary for another platform only, a modelDescription.xml breaking the schema:
    an FmuError saying which, in one line (fmpy's own words are a plain Exception or several
    lines of validation); the command exits 2 with that line."""
    from gyrowheel.cli import main
    fmu = foreign[kind]
    for verb in ("simulate", "info")[:1 if kind == "win" else 2]:
        assert main([verb, str(fmu)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"gyrowheel: error: {fmu.parent}/{message}") and err.count("\n") == 1, err
    for call, argument in ((lambda: gyrowheel.simulate(fmu), "fmu"),
                           (lambda: gyrowheel.sweep(fmu, grid={"M": [2.0]}, workers=0), "source")):
        with pytest.raises(gyrowheel.FmuError) as exc:
            call()
        _names(exc, argument, message)
        assert "\n" not in str(exc.value)
    if kind == "win":  # described all the same: what it is, for which platforms
        assert [str(p) for p in gyrowheel.info(fmu).platforms] == ["x86_64-windows (binaries/win64)"]
    else:
        with pytest.raises(gyrowheel.FmuError) as exc:
            gyrowheel.info(fmu)
        _names(exc, "fmu", message)


def test_the_docstrings_say_which_fmi_versions_each_function_takes(fmi3_earth_fmu):
    """simulate and info take the FMI versions open_fmu reads (FMI_VERSIONS), FMI 2.0 and 3.0,
    and their docstrings say so (FMI 1.0 refused: above; an FMI 3.0 FMU run and described:
    below and tests/test_fmi3_events.py); sweep's says it refuses FMI 3.0
    (tests/test_fmi3_build.py); FmuError's says what it is for."""
    from gyrowheel.description import FMI_VERSIONS
    assert FMI_VERSIONS == ("2.0", "3.0")
    for function in (gyrowheel.simulate, gyrowheel.info):
        doc = " ".join(function.__doc__.split())
        assert "an FMI 2.0 or 3.0 FMU" in doc and "another FMI version than 2.0 and 3.0" in doc, function
        assert "not an FMI 2.0 FMU" not in doc
    assert "is an FMI 3.0 FMU (a sweep runs FMI 2.0 FMUs)" in " ".join(gyrowheel.sweep.__doc__.split())
    assert "another FMI version than 2.0 and 3.0" in " ".join(gyrowheel.FmuError.__doc__.split())
    assert gyrowheel.info(fmi3_earth_fmu).fmi_version == "3.0"


def test_info_of_an_fmu_without_a_description(foreign):
    assert "description  none" in str(gyrowheel.info(foreign["undescribed"])).splitlines()[1]


# -- a file of another kind, a directory -----------------------------------------------------------

def test_a_directory_or_a_file_of_another_kind_is_named_as_such(moon, tmp_path):
    """A directory is named a directory (not 'no such FMU / result / SSP file'), an FMU given as
    a scene an FMU (not a text file that is no UTF-8), a Scene given as an FMU a Scene: what the
    user gave, so they see what to give instead. (Scene and result files: their readers say it,
    tests/test_scene.py, tests/test_animate_cli.py; here, that every verb gets there.)"""
    run = tmp_path / "run"
    run.mkdir()
    cases = [(lambda: gyrowheel.simulate(run), gyrowheel.FmuError, "fmu", "is a directory, not an FMU file"),
             (lambda: gyrowheel.info(run), gyrowheel.FmuError, "fmu", "is a directory, not an FMU file"),
             (lambda: gyrowheel.system_run(run), gyrowheel.SystemFileError, "system",
              "is a directory, not an SSP file"),
             (lambda: gyrowheel.animate(run, tmp_path / "x.gif"), gyrowheel.AnimationError, None,
              "is a directory, not a result CSV"),
             (lambda: gyrowheel.sweep(run, grid={"M": [2.0]}, workers=0), gyrowheel.SweepSpecError, "source",
              "is a directory, not a scene, FMU or system file"),
             (lambda: gyrowheel.build(moon.fmu, tmp_path / "x.fmu"), gyrowheel.SceneError, "scene",
              "paper_moon.fmu: an FMU (a zip archive), not a scene file: a scene is TOML text (docs/scenes.md)"),
             (lambda: gyrowheel.export_c(moon, tmp_path / "x_c", check=False), gyrowheel.SceneError, "scene",
              "paper_moon.fmu: an FMU (a zip archive), not a scene file"),
             (lambda: gyrowheel.simulate(gyrowheel.load_scene(SCENES / "paper_moon.toml")), gyrowheel.FmuError, "fmu",
              "fmu: a gyrowheel.Scene, not an FMU; build its FMU first: gyrowheel.build(scene)")]
    for call, error, argument, message in cases:
        with pytest.raises(error) as exc:
            call()
        _names(exc, argument, message)
        assert str(exc.value).startswith((str(run) + ":", str(moon.fmu) + ":", "fmu:")), str(exc.value)
    assert not (tmp_path / "x.fmu").exists() and not (tmp_path / "x_c").exists()


# -- wrong types: GyrowheelErrors (and TypeErrors) naming the argument ------------------------------

def test_an_argument_of_the_wrong_type_is_named(moon, tmp_path):
    """A GyrowheelError naming the argument, a TypeError too for a wrong type: never Python's,
    numpy's, pandas' or distributed's own error ('DataFrame constructor not properly called!',
    "'<' not supported ..."), which names no argument."""
    scene = gyrowheel.load_scene(SCENES / "paper_moon.toml")
    run = gyrowheel.simulate(moon, stop_time=0.2)
    sweep = dict(grid={"M": [2.0]}, stop_time=0.1)
    cases = [
        (lambda: gyrowheel.build(123), ArgumentTypeError, "scene",
         "scene must be a path to a scene file (.toml) or a gyrowheel.Scene, got int"),
        (lambda: gyrowheel.build(scene, tmp_path / "x.fmu", taylor="yes"), ArgumentTypeError, "taylor",
         "taylor must be True or False, got str 'yes'"),
        (lambda: gyrowheel.export_c(scene, tmp_path / "x_c", check="no"), ArgumentTypeError, "check",
         "check must be True or False, got str 'no'"),
        (lambda: gyrowheel.export_c(scene, "/proc/x", check=False), gyrowheel.ExportError, "output",
         "output /proc/x: cannot write: "),
        (lambda: gyrowheel.sweep(moon, **{**sweep, "stop_time": "5"}, workers=0), ArgumentTypeError, "stop_time",
         "stop_time must be a number of seconds, got str '5'"),
        (lambda: gyrowheel.sweep(moon, **sweep, workers=1.5), gyrowheel.SweepSpecError, "workers",
         "workers must be a whole number >= 0, got 1.5"),
        (lambda: gyrowheel.sweep(moon, **sweep, workers="2"), ArgumentTypeError, "workers",
         "workers must be a whole number >= 0, got str '2'"),
        (lambda: gyrowheel.sweep(moon, **sweep, client=object()), ArgumentTypeError, "client",
         "client must be a distributed.Client, got object"),
        (lambda: gyrowheel.sweep(moon, points=5, stop_time=0.1, workers=0), ArgumentTypeError, "points",
         "points must be a pandas DataFrame, a list of {name: value} dicts (one a point) or a {name: values} dict "
         "of columns, got int 5"),
        (lambda: gyrowheel.animate(run, tmp_path / "x.gif", fps="25"), ArgumentTypeError, "fps",
         "fps must be a number, got str '25'"),
        (lambda: gyrowheel.animate(run, None), ArgumentTypeError, "output",
         "output must be a file path (.gif, .mp4 or .html), got NoneType"),
    ]
    for call, error, argument, message in cases:
        with pytest.raises(error) as exc:
            call()
        _names(exc, argument, message)
        assert str(exc.value).startswith(message) and "--" not in str(exc.value)
        assert isinstance(exc.value, TypeError) == (error is ArgumentTypeError)
    assert not (tmp_path / "x.fmu").exists() and not (tmp_path / "x.gif").exists()


# -- sweep: the argument the user gave, as given ---------------------------------------------------

@pytest.mark.parametrize("kwargs, error, argument, message", [
    (dict(solver="taylor"), gyrowheel.SweepSpecError, "solver",
     "solver: value 'taylor' for 'solver' is not one of its items; valid: euler, rk4, dopri5, rosenbrock, dop853, auto "
     "(or their numbers); taylor needs an FMU built with the Taylor kernel: gyrowheel.build(scene, output, taylor=True)"),
    (dict(solver="nope"), gyrowheel.SweepSpecError, "solver",
     "solver: value 'nope' for 'solver' is not one of its items; valid: "),
    (dict(max_step=math.nan), gyrowheel.SweepSpecError, "max_step", "max_step: value nan for 'max_step' is not finite"),
    (dict(grid="beta_deg=60:80:3"), ArgumentTypeError, "grid",
     "grid: expected a mapping or a list of 'NAME=SPEC' strings, got str 'beta_deg=60:80:3'"),
    (dict(fixed="gamma_dot=8"), ArgumentTypeError, "fixed",
     "fixed: expected a mapping or a list of 'NAME=VALUE' strings, got str 'gamma_dot=8'"),
    (dict(metric_functions="mod:f"), ArgumentTypeError, "metric_functions",
     "metric_functions: expected a list of 'module:function' references or functions, got str 'mod:f'"),
    # samples without random would run every grid point 5 times alike
    (dict(samples=5), gyrowheel.SweepSpecError, "samples",
     "samples 5 without random: there is nothing to draw; give random NAME=DIST, or leave samples out"),
    (dict(workers=2, scheduler="tcp://127.0.0.1:1"), gyrowheel.SweepSpecError, "workers",
     "workers and scheduler exclude each other: give one of them"),
    (dict(ensemble="x"), ArgumentTypeError, "ensemble", "ensemble must be True or False, got str 'x'"),
    (dict(fixed=["gamma_dot=8", "gamma_dot=9"]), gyrowheel.SweepSpecError, "fixed",
     "fixed['gamma_dot']: given twice, as gamma_dot=8 and gamma_dot=9"),
    # an axis of 10^9 values (8 GB as numpy's array) is refused before it is made
    (dict(grid={"beta_deg": "60:89:1000000000"}), gyrowheel.SweepSpecError, "grid",
     "grid['beta_deg'] = '60:89:1000000000': 1000000000 values, more than the 10000000 points of one sweep"),
])
def test_sweep_names_the_argument_given(moon, kwargs, error, argument, message):
    kwargs = {"grid": {"gamma_dot": [5.0]}, "stop_time": 0.1, **({} if "scheduler" in kwargs else {"workers": 0}),
              **kwargs}
    t0 = time.monotonic()
    with pytest.raises(error) as exc:
        gyrowheel.sweep(moon, **kwargs)
    _names(exc, argument, message)
    assert str(exc.value).startswith(message[:12]) and time.monotonic() - t0 < 20


@pytest.mark.parametrize("kwargs, argument, engine", [
    (dict(rel_tol=-1.0), "rel_tol", "--rel-tol: the unit refuses -1.0 for every point: fmi2SetReal: rel_tol = -1 is "
                                    "outside its valid range"),
    (dict(max_step=-1.0), "max_step", "--max-step: the unit refuses -1.0 for every point: fmi2SetReal: max_step"),
    (dict(fixed={"abs_tol": -1.0}), "fixed", "--set abs_tol: the unit refuses -1.0 for every point: fmi2SetReal: "),
])
def test_sweep_values_every_point_would_fail_with_are_refused_before_it_runs(moon, tmp_path, kwargs, argument,
                                                                               engine):
    """A value the unit refuses for every point (`--rel-tol -1`) is refused before the sweep,
    naming the argument, rather than written as a table whose every row failed."""
    started = []
    with pytest.raises(gyrowheel.SweepSpecError) as exc:
        gyrowheel.sweep(moon, grid={"beta_deg": "60:80:3"}, stop_time=2.0, workers=0, output=tmp_path / "rt.csv",
                        on_start=started.append, **kwargs)
    _names(exc, argument, engine.split(": ", 1)[1])
    assert exc.value.engine_text.startswith(engine)
    assert not started and not (tmp_path / "rt.csv").exists()


def test_sweep_table_columns_do_not_depend_on_failed_points(moon):
    """Every point failing (each with a mass the model refuses: a point's own value, as a fixed
    one is refused before the sweep runs) still gives the metric columns, empty: a table's
    columns do not depend on its outcomes."""
    kw = dict(stop_time=0.1, workers=0)
    ok = gyrowheel.sweep(moon, grid={"gamma_dot": [5.0, 6.0], "M": [2.0]}, **kw)
    failed = gyrowheel.sweep(moon, points=[{"gamma_dot": 5.0, "M": -1.0}, {"gamma_dot": 6.0, "M": -2.0}], **kw)
    assert (ok["status"] == "ok").all() and (failed["status"] == "error").all()
    assert list(failed.columns) == list(ok.columns)
    assert failed["survived"].isna().all() and (failed["event"] == "").all() and failed["fall_time"].isna().all()
    assert failed["reason"].str.contains("M \\(mass\\) must be > 0").all()


def test_a_metric_function_must_return_numbers(moon):
    """A metric function's number is a column; anything else fails the point, the reason naming
    the function and what it returned (a column of text would break the table's numbers)."""
    table = gyrowheel.sweep(moon, grid={"gamma_dot": [5.0, 6.0]}, stop_time=0.1, workers=0, metrics=["survived"],
                            metric_functions=[lambda traj: 5, lambda traj: {"lean": float(traj["beta"][-1])}])
    assert list(table["<lambda>"]) == [5, 5] and table["lean"].notna().all() and (table["status"] == "ok").all()

    def text(traj):
        return "abc"
    table = gyrowheel.sweep(moon, grid={"gamma_dot": [5.0, 6.0]}, stop_time=0.1, workers=0, metrics=["survived"],
                            metric_functions=[text])
    assert (table["status"] == "error").all() and "text" not in table
    assert (table["reason"] == "metric function text: returned str 'abc', not a number or a dict of numbers "
                               "{column name: number}").all()


# -- simulate -------------------------------------------------------------------------------------

def test_simulate_names_what_it_cannot_use(moon, tmp_path):
    """A start value given twice is refused (which one was meant?); solver taylor on an FMU
    without the kernel lists the solvers and says how to get taylor (docs/interface.md)."""
    with pytest.raises(gyrowheel.ArgumentError) as exc:
        gyrowheel.simulate(moon, start_values=["gamma_dot=8", "gamma_dot=9"])
    _names(exc, "start_values", "start_values: 'gamma_dot' given twice (gamma_dot=8, gamma_dot=9)")
    with pytest.raises(gyrowheel.ArgumentError) as exc:
        gyrowheel.simulate(moon, start_values={"solver": "taylor"})
    _names(exc, "start_values", "valid: euler, rk4, dopri5, rosenbrock, dop853, auto; taylor needs an FMU built with the "
                                "Taylor kernel: gyrowheel.build(scene, output, taylor=True) or `gyrowheel build "
                                "--taylor SCENE -o FMU`")


def test_a_figure_names_its_run_once(moon, tmp_path, monkeypatch):
    """`simulate --plot` names the FMU once: the column's title, no figure title repeating it."""
    import matplotlib.figure
    titles = []
    monkeypatch.setattr(matplotlib.figure.Figure, "suptitle", lambda self, text, **kw: titles.append(text))
    gyrowheel.simulate(moon, stop_time=0.1, plot=tmp_path / "p.png")
    assert titles == [] and (tmp_path / "p.png").stat().st_size > 10_000
    from gyrowheel.plotting import plot_trajectories
    run = gyrowheel.simulate(moon, stop_time=0.1)
    plot_trajectories({"a": run, "b": run}, tmp_path / "two.png", title="runs")
    assert titles == ["runs"]



def test_an_unknown_start_value_name_is_a_key_error_and_an_argument_error(moon):
    """A name the FMU does not have is an UnknownNameError (a KeyError, README "Errors") and an
    ArgumentError (a ValueError) naming start_values, whatever the value."""
    with pytest.raises(gyrowheel.UnknownArgumentNameError) as exc:
        gyrowheel.simulate(moon.fmu, start_values={"nosuch": 1}, stop_time=0.1)
    error = exc.value
    assert isinstance(error, KeyError) and isinstance(error, gyrowheel.UnknownNameError)
    assert isinstance(error, ValueError) and isinstance(error, gyrowheel.ArgumentError)
    assert error.argument == "start_values"
    assert str(error).startswith("start_values: unknown variable 'nosuch'; settable: ")  # not quoted as KeyError's


def test_a_name_looked_up_that_is_no_string_is_an_argument_type_error(moon, fmi3_earth_fmu):
    """info(fmu).variable(3) and EnsembleResult.output(3): an ArgumentTypeError (a TypeError and
    an ArgumentError) naming the argument `name`, not an UnknownNameError saying the FMU has no
    variable 3; a string it does not have stays an UnknownNameError listing the names."""
    import numpy as np

    from gyrowheel.taylor.ensemble import EnsembleResult
    result = EnsembleResult(status=np.zeros(1, int), t_final=np.zeros(1), x_final=np.zeros((1, 1)),
                            y_final=np.zeros((1, 1)), steps=np.zeros(1, int), output_names=["energy"],
                            state_names=["x"])
    lookups = [(gyrowheel.info(fmu).variable, "a variable's name") for fmu in (moon, fmi3_earth_fmu)]
    for lookup, what in [*lookups, (result.output, "an output's name")]:
        for name in (3, None, b"g"):
            with pytest.raises(ArgumentTypeError) as exc:
                lookup(name)
            _names(exc, "name", f"name must be {what} (str), got {type(name).__name__} {name!r}")
            assert not isinstance(exc.value, KeyError)
        with pytest.raises(gyrowheel.UnknownNameError, match="; (variables|outputs): "):
            lookup("nosuch")
    assert lookups[1][0]("g").start == 9.81 and result.output("energy").tolist() == [0.0]
