"""Optional parts as pip extras (gyrowheel.extras): the core install builds, simulates, describes,
exports and runs systems; a verb whose extra is missing says, in one line, which pip command
installs it (exit 2), and so does the Python API (MissingExtraError). A core install is simulated
in a subprocess by making every extra's packages unimportable (sys.modules[name] = None: import
fails and importlib.util.find_spec reports the package missing)."""
from __future__ import annotations

import re
import subprocess
import sys
import textwrap
import tomllib

import pytest

from conftest import ROOT, SCENES
from gyrowheel.errors import GyrowheelError, MissingExtraError
from gyrowheel.extras import EXTRAS, IN_ALL, missing, require

# distribution (pyproject.toml) -> top-level import name
IMPORT_NAMES = {"matplotlib": "matplotlib", "dask": "dask", "distributed": "distributed", "pandas": "pandas",
                "pyarrow": "pyarrow", "tqdm": "tqdm", "pillow": "PIL", "imageio-ffmpeg": "imageio_ffmpeg",
                "scipy": "scipy", "pyssp-standard": "pyssp_standard", "ziglang": "ziglang"}
BLOCKED = sorted({name for names in EXTRAS.values() for name in names})
CORE = textwrap.dedent(f"""
    import sys
    for name in {BLOCKED!r}:
        sys.modules[name] = None
    try:
        import dask
    except ImportError:
        pass
    else:
        raise SystemExit("the core install's simulation failed: dask is importable")
    """)


def _distribution(requirement: str) -> str:
    return re.split(r"[\[<>=!~ ;]", requirement, maxsplit=1)[0].lower()


def _core(code: str, cwd) -> subprocess.CompletedProcess:
    """Run `code` in a Python where no optional part is installed."""
    return subprocess.run([sys.executable, "-c", CORE + textwrap.dedent(code)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def test_extras_are_those_of_pyproject():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert sorted(_distribution(r) for r in project["dependencies"]) == ["casadi", "fmpy", "lxml", "numpy"]
    optional = project["optional-dependencies"]
    for extra, names in EXTRAS.items():
        assert sorted({IMPORT_NAMES[_distribution(r)] for r in optional[extra]}) == sorted(names), extra
    assert optional["all"] == [f"gyrowheel[{','.join(IN_ALL)}]"]


def test_require_names_the_pip_command(monkeypatch):
    assert missing("sweep") == [] and require("sweep", "gyrowheel sweep") is None  # the test install has all
    monkeypatch.setitem(sys.modules, "dask", None)
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    assert missing("sweep") == ["dask", "pyarrow"]
    with pytest.raises(MissingExtraError) as exc:
        require("sweep", "gyrowheel sweep")
    assert str(exc.value) == '`gyrowheel sweep` needs the optional part \'sweep\': pip install "gyrowheel[sweep]"'
    assert isinstance(exc.value, ImportError) and isinstance(exc.value, GyrowheelError)
    assert (exc.value.extra, exc.value.missing, exc.value.name) == ("sweep", ["dask", "pyarrow"], "dask")
    assert missing("plot") == []
    with pytest.raises(KeyError, match="no optional part 'plots'; known: plot, sweep, animate, system"):
        require("plots", "x")


@pytest.mark.parametrize("argv, extra, verb", [
    (["sweep", "x.fmu", "--grid", "M=1,2", "-o", "t.parquet"], "sweep", "gyrowheel sweep"),
    (["animate", "x.csv", "-o", "x.gif"], "animate", "gyrowheel animate"),
    (["simulate", "x.fmu", "--plot", "x.png", "-o", "x.csv"], "plot", "gyrowheel simulate --plot"),
])
def test_a_verb_without_its_extra_is_one_line_and_exit_2(tmp_path, argv, extra, verb):
    r = _core(f"from gyrowheel.cli import main\nsys.exit(main({argv!r}))", tmp_path)
    assert r.returncode == 2 and r.stdout == "", r.stderr
    assert r.stderr == f'gyrowheel: error: `{verb}` needs the optional part \'{extra}\': pip install "gyrowheel[{extra}]"\n'
    assert list(tmp_path.iterdir()) == []  # refused before anything ran or was written


def test_the_core_install_runs_the_core_verbs(earth_fmu, tmp_path):
    """build, simulate, info (text and JSON), export-c and system run, and every --help, with no
    optional part installed; none of them imports one."""
    from gyrowheel.cosim.system import Component, SystemDescription
    from gyrowheel.cosim.ssp import write_ssp
    ssp = write_ssp(SystemDescription("solo", [Component("wheel", earth_fmu)], [], 0.0, 1.0), tmp_path / "solo.ssp")
    scene = SCENES / "paper_moon.toml"
    code = f"""
        import contextlib, io, json
        from gyrowheel.cli import main
        helps = [[], ["build"], ["simulate"], ["system", "run"], ["export-c"], ["animate"], ["info"], ["sweep"]]
        for argv in helps:
            with contextlib.redirect_stdout(io.StringIO()) as out:
                try:
                    main([*argv, "--help"])
                except SystemExit as exc:
                    assert exc.code == 0, (argv, exc.code)
            assert "usage: gyrowheel" in out.getvalue(), argv
        assert main(["build", {str(scene)!r}, "-o", "moon.fmu"]) == 0
        assert main(["simulate", "moon.fmu", "--stop-time", "0.1", "-o", "moon.csv"]) == 0
        assert main(["info", "moon.fmu"]) == 0
        with contextlib.redirect_stdout(io.StringIO()) as out:
            assert main(["info", "--json", "moon.fmu"]) == 0
        assert json.loads(out.getvalue())["model_name"] == "paper_moon"
        assert main(["export-c", {str(scene)!r}, "-o", "moon_c", "--no-compile"]) == 0
        assert main(["system", "run", {str(ssp)!r}, "--stop-time", "0.1", "-o", "solo.csv"]) == 0
        import gyrowheel
        print("errors", gyrowheel.SweepSpecError.__name__, gyrowheel.SweepInterrupted.__name__)
        print("loaded", sorted(m for m in {BLOCKED!r} if sys.modules.get(m) is not None))
        """
    r = _core(code, tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    lines = r.stdout.splitlines()
    assert lines[-2:] == ["errors SweepSpecError SweepInterrupted", "loaded []"], r.stdout
    assert any(line.startswith("built ") for line in lines) and any(line.startswith("wrote moon.csv: 11 rows")
                                                                    for line in lines)
    for name in ("moon.fmu", "moon.csv", "moon_c/paper_moon.h", "solo.csv"):
        assert (tmp_path / name).is_file(), name


def test_the_api_names_the_extra_it_needs(earth_fmu, tmp_path):
    code = f"""
        import gyrowheel
        from gyrowheel.errors import MissingExtraError
        def says(call):
            try:
                call()
            except MissingExtraError as exc:
                print(exc)
            else:
                print("no error")
        says(lambda: gyrowheel.sweep({str(earth_fmu)!r}, grid={{"M": [1.0]}}))
        says(lambda: gyrowheel.animate("x.csv", "x.gif"))
        says(lambda: gyrowheel.simulate({str(earth_fmu)!r}, plot="x.png"))
        says(lambda: __import__("gyrowheel.controller.design"))
        from gyrowheel.cosim.system import Component, SystemDescription
        from gyrowheel.cosim.ssp import write_ssp
        says(lambda: write_ssp(SystemDescription("s", [Component("w", {str(earth_fmu)!r})], []), "s.ssp"))
        import gyrowheel.controller.mission  # no scipy in it: there in the core install
        """
    r = _core(code, tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == [
        '`gyrowheel.sweep()` needs the optional part \'sweep\': pip install "gyrowheel[sweep]"',
        '`gyrowheel.animate()` needs the optional part \'animate\': pip install "gyrowheel[animate]"',
        '`gyrowheel.simulate(plot=...)` needs the optional part \'plot\': pip install "gyrowheel[plot]"',
        '`gyrowheel.controller` needs the optional part \'system\': pip install "gyrowheel[system]"',
        '`gyrowheel.cosim.ssp.write_ssp()` needs the optional part \'system\': pip install "gyrowheel[system]"']
    assert list(tmp_path.iterdir()) == []
