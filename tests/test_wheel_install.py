"""gyrowheel as users install it: the wheel built from this checkout, installed with pip (not
editable) into a fresh virtual environment, and used from a directory outside the checkout.

The tests form one scenario and run in the order written (pytest keeps a file's order; under
pytest-xdist `--dist loadfile` the file stays on one worker):
1. the wheel: its files are the repository's package folders, nothing else (one top-level
   name, `gyrowheel`, beside its dist-info), its script and its core dependencies;
2. the core install (casadi, fmpy, lxml, numpy from PyPI): build an FMU from a scene, simulate it,
   describe it, rebuild it from its sources, export the C and compile its example; the verbs of
   an extra (sweep, animate, simulate --plot) say which extra to install;
3. the [sweep] extra installed into the same environment: a 4-point sweep in-process, the
   Ensemble compiled from the installed runtime;
4. what the install put into site-packages: only `gyrowheel/` and its dist-info.

pip takes the dependencies from PyPI (its cache makes a second run fast): without a network the
test fails with pip's own error.  Every failure names the command, its directory and its output.
"""
from __future__ import annotations

import configparser
import csv
import json
import os
import shutil
import subprocess
import sys
import tomllib
import zipfile
from email.parser import Parser
from pathlib import Path

import pytest
from packaging.requirements import Requirement

import gyrowheel

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
# installed package -> repository folder (pyproject [tool.setuptools.package-dir])
PACKAGE_DIR: dict[str, str] = PYPROJECT["tool"]["setuptools"]["package-dir"]
VERSION = gyrowheel.__version__
DIST_INFO = f"gyrowheel-{VERSION}.dist-info"
SCENE = ROOT / "examples" / "scenes" / "paper_earth.toml"
CORE = {"casadi", "fmpy", "lxml", "numpy"}
# modules that only the extras bring (pyproject [project.optional-dependencies]): absent from the
# core install, so that its commands are seen to work without them
EXTRA_MODULES = ["matplotlib", "pandas", "dask", "distributed", "pyarrow", "tqdm", "PIL",
                 "imageio_ffmpeg", "scipy", "pyssp_standard"]
SWEEP_POINTS = [2.0, 4.0, 6.0, 8.0]  # gamma_dot [rad/s] of the sweep and of the Ensemble


def _describe(r: subprocess.CompletedProcess, cwd: Path) -> str:
    """The command, where it ran, its exit status and its output (the tail of long output)."""
    return (f"`{' '.join(map(str, r.args))}` in {cwd} exited {r.returncode}\n"
            f"--- stdout\n{r.stdout[-6000:]}\n--- stderr\n{r.stderr[-6000:]}")


def _run(args, cwd: Path, env: dict | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)


def _check(r: subprocess.CompletedProcess, cwd: Path, hint: str = "") -> subprocess.CompletedProcess:
    assert r.returncode == 0, _describe(r, cwd) + hint
    return r


# files of the package folders that are for the maintainers, not the users: not in the wheel
MAINTAINER_FILES = {"gyrowheel/animation/vendor/three/update.sh"}


def _repository_files() -> set[str]:
    """Every file of the package folders (bytecode and MAINTAINER_FILES aside) as its path in the
    wheel: each folder of [tool.setuptools.package-dir] ships whole, its Python and its data."""
    files = set()
    for package, folder in PACKAGE_DIR.items():
        base = ROOT / folder
        for path in base.rglob("*"):
            if path.is_file() and "__pycache__" not in path.parts and path.suffix != ".pyc":
                files.add(f"{package.replace('.', '/')}/{path.relative_to(base).as_posix()}")
    assert MAINTAINER_FILES <= files, "a maintainer file moved: update MAINTAINER_FILES"
    return files - MAINTAINER_FILES


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel, built with this environment's setuptools (no network, no isolation) from a copy
    of the checkout's top-level files and package folders: the build writes its build/ and
    egg-info into the copy, never into the checkout, and nothing an earlier build left there
    (setuptools' build/lib keeps deleted files) can reach the wheel."""
    base = tmp_path_factory.mktemp("wheel")
    src, out = base / "src", base / "dist"
    src.mkdir()
    for path in ROOT.iterdir():
        if path.is_file():
            shutil.copy2(path, src / path.name)
    for folder in set(PACKAGE_DIR.values()):
        shutil.copytree(ROOT / folder, src / folder, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    r = _check(_run([sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", out, src], base), base)
    wheels = sorted(out.glob("*.whl"))
    assert [w.name for w in wheels] == [f"gyrowheel-{VERSION}-py3-none-any.whl"], r.stdout[-3000:]
    return wheels[0]


class Venv:
    """A fresh virtual environment and a user's working directory outside the checkout.

    Commands run as in an activated environment: its bin/ first on PATH, no PYTHONPATH (nor any
    other PYTHON* variable), the checkout's own environment off PATH; gyrowheel's commands keep
    their caches (the Ensemble's libraries) in a directory of this test, pip uses the user's cache."""

    def __init__(self, base: Path):
        self.root, self.work, self.cache = base / "venv", base / "work", base / "cache"
        self.work.mkdir()
        self.cache.mkdir()
        assert not self.work.is_relative_to(ROOT), f"{self.work} is inside the checkout {ROOT}"
        own_bins = {str(Path(sys.prefix) / "bin"), str(ROOT / ".venv" / "bin")}
        path = [p for p in os.environ.get("PATH", "").split(os.pathsep) if p and p not in own_bins]
        self.env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON") and k != "VIRTUAL_ENV"}
        self.env.update(PATH=os.pathsep.join([str(self.root / "bin"), *path]), VIRTUAL_ENV=str(self.root))
        self.tool_env = dict(self.env, XDG_CACHE_HOME=str(self.cache))
        _check(_run([sys.executable, "-m", "venv", self.root], base), base)
        self.python = self.root / "bin" / "python"
        self.site = Path(self.run_python("import sysconfig; print(sysconfig.get_paths()['purelib'])").stdout.strip())

    def pip_install(self, requirement: str) -> subprocess.CompletedProcess:
        """pip install REQUIREMENT, without compiling the dependencies' bytecode up front (half
        the CPU time of the [sweep] install; Python compiles what it imports)."""
        return _check(_run([self.python, "-m", "pip", "install", "--no-input", "--progress-bar", "off",
                            "--no-compile", requirement], self.work, self.env, timeout=1800), self.work,
                      "\n(pip takes gyrowheel's dependencies from PyPI: this test needs the network)")

    def gyrowheel(self, *args, cwd: Path | None = None) -> subprocess.CompletedProcess:
        """The installed `gyrowheel` script, output captured (not checked)."""
        return _run([self.root / "bin" / "gyrowheel", *args], cwd or self.work, self.tool_env)

    def ok(self, *args, cwd: Path | None = None) -> subprocess.CompletedProcess:
        """`gyrowheel ARGS`, which must succeed."""
        return _check(self.gyrowheel(*args, cwd=cwd), cwd or self.work)

    def run_python(self, code: str) -> subprocess.CompletedProcess:
        """`python -c CODE` of the environment in the working directory, which must succeed."""
        return _check(_run([self.python, "-c", code], self.work, self.tool_env), self.work)

    def importable(self, names: list[str]) -> list[str]:
        """Those of names that the environment's Python finds, from the working directory."""
        code = ("import importlib.util, json, sys; "
                "print(json.dumps([n for n in sys.argv[1:] if importlib.util.find_spec(n)]))")
        r = _check(_run([self.python, "-c", code, *names], self.work, self.tool_env), self.work)
        return json.loads(r.stdout)


@pytest.fixture(scope="module")
def venv(wheel, tmp_path_factory) -> Venv:
    """The core install: `pip install gyrowheel-<version>-py3-none-any.whl` into a fresh venv.
    It stays with the run's temporary files (0.8 GB with the [sweep] extra; pytest keeps the
    last three runs'): removing it here took 55 s of a loaded 2-core machine."""
    env = Venv(tmp_path_factory.mktemp("installed"))
    env.pip_install(str(wheel))
    return env


@pytest.fixture(scope="module")
def installed_earth(venv):
    """The paper's earth scene, copied to the working directory, built and simulated (its
    experiment, 20 s) by the installed command: (FMU, CSV, build's result, simulate's result)."""
    shutil.copy2(SCENE, venv.work / SCENE.name)
    built = venv.ok("build", SCENE.name, "-o", "earth.fmu")
    simulated = venv.ok("simulate", "earth.fmu", "-o", "earth.csv")
    return venv.work / "earth.fmu", venv.work / "earth.csv", built, simulated


def _read_csv(path: Path) -> tuple[list[str], list[list[float]]]:
    with path.open(newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], [[float(v) for v in row] for row in rows[1:]]


# ---- 1. the wheel ---------------------------------------------------------------------------------

def test_wheel_holds_the_package_folders_under_one_name(wheel):
    with zipfile.ZipFile(wheel) as zf:
        names = [n for n in zf.namelist() if not n.endswith("/")]
        entry_points = zf.read(f"{DIST_INFO}/entry_points.txt").decode()
        metadata = Parser().parsestr(zf.read(f"{DIST_INFO}/METADATA").decode())
    assert {n.split("/")[0] for n in names} == {"gyrowheel", DIST_INFO}
    assert f"{DIST_INFO}/licenses/LICENSE" in names  # the project's licence travels with it
    shipped = {n for n in names if not n.startswith(f"{DIST_INFO}/")}
    expected = _repository_files()
    assert shipped == expected, (
        f"in the repository's package folders, not in the wheel (pyproject.toml packages / "
        f"package-data): {sorted(expected - shipped)}; in the wheel, not in those folders: "
        f"{sorted(shipped - expected)}")
    # one file of each kind the commands read (the comparison above cannot pass empty-handed):
    # code, the runtime, the export's templates and examples, the HTML page, three.js, the schemas
    assert {"gyrowheel/cli.py", "gyrowheel/model/effects/__init__.py", "gyrowheel/c_src/gw_core.c",
            "gyrowheel/c_src/export/model.c.in", "gyrowheel/c_src/export/examples/main.c",
            "gyrowheel/animation/assets/page.html", "gyrowheel/animation/vendor/three/three.module.min.js",
            "gyrowheel/cosim/schemas/ssp1/SystemStructureDescription.xsd"} <= shipped
    scripts = configparser.ConfigParser()
    scripts.read_string(entry_points)
    assert scripts.sections() == ["console_scripts"]
    assert dict(scripts["console_scripts"]) == {"gyrowheel": "gyrowheel.cli:main"}
    requires = [Requirement(text) for text in metadata.get_all("Requires-Dist")]
    assert {req.name for req in requires if req.marker is None} == CORE
    assert {"plot", "sweep", "animate", "system", "all"} <= set(metadata.get_all("Provides-Extra"))


# ---- 2. the core install --------------------------------------------------------------------------

def test_core_install_is_the_wheel_with_its_core_dependencies(venv):
    code = ("import json, gyrowheel, gyrowheel.fmu_build.runtime as r; "
            "print(json.dumps([gyrowheel.__version__, gyrowheel.__file__, str(r.RUNTIME_DIR)]))")
    version, init, runtime = json.loads(venv.run_python(code).stdout)
    assert version == VERSION
    assert Path(init) == venv.site / "gyrowheel" / "__init__.py"
    assert Path(runtime) == venv.site / "gyrowheel" / "c_src"
    printed = venv.run_python("import gyrowheel; print(gyrowheel.__version__)").stdout.strip()
    assert printed == VERSION
    assert venv.importable(sorted(CORE)) == sorted(CORE)
    assert venv.importable(EXTRA_MODULES) == [], "the core install brought in an extra's packages"


def test_core_install_builds_simulates_and_describes_an_fmu(venv, installed_earth):
    fmu, result, built, simulated = installed_earth
    assert "built earth.fmu (model paper_earth" in built.stdout
    with zipfile.ZipFile(fmu) as zf:
        names = set(zf.namelist())
    assert {"modelDescription.xml", "binaries/linux64/paper_earth.so", "sources/gw_fmu.c"} <= names
    header, rows = _read_csv(result)
    assert header[:6] == ["time", "x", "y", "alpha", "beta", "gamma"]
    assert len(rows) == 2001 and rows[0][0] == 0.0 and rows[-1][0] == 20.0
    assert f"wrote earth.csv: {len(rows)} rows" in simulated.stdout
    info = venv.ok("info", "earth.fmu").stdout
    assert "model        paper_earth  (FMI 2.0, generated by gyrowheel)" in info
    assert "gamma_dot" in info


def test_core_install_fmu_rebuilds_from_its_sources(venv, installed_earth):
    """fmpy compiles the FMU's sources/ (the installed runtime, copied in) into a new binary,
    which gives the same trajectory as the one gyrowheel built."""
    code = """
import json, zipfile
from pathlib import Path
from fmpy import simulate_fmu
from fmpy.build import build_platform_binary
root = Path("rebuilt").resolve()
zipfile.ZipFile("earth.fmu").extractall(root)
(root / "binaries" / "linux64" / "paper_earth.so").unlink()
build_platform_binary(str(root))
new = simulate_fmu(str(root), stop_time=2.0)
old = simulate_fmu("earth.fmu", stop_time=2.0)
print(json.dumps([(root / "binaries" / "linux64" / "paper_earth.so").is_file(), len(new),
                  float(abs(new["beta"] - old["beta"]).max())]))
"""
    built, rows, difference = json.loads(venv.run_python(code).stdout.strip().splitlines()[-1])
    assert built and rows == 201
    assert difference == 0.0


def test_core_install_exports_c_that_compiles_and_runs(venv, installed_earth):
    """`gyrowheel export-c` (which compiles its export strictly), then the README's plain cc call
    of its example, whose CSV of the scene's experiment is the FMU's, bit for bit."""
    cc = shutil.which("cc", path=venv.env["PATH"])
    assert cc, "no C compiler `cc` on PATH (Debian: apt-get install gcc)"
    out = venv.ok("export-c", SCENE.name, "-o", "earth_c").stdout
    assert out.startswith("wrote earth_c/ (model paper_earth")
    export = venv.work / "earth_c"
    assert {"CMakeLists.txt", "paper_earth.c", "paper_earth.h", "gyrowheel_api.h"} <= {p.name for p in export.iterdir()}
    _check(_run([cc, "-std=c99", "-O2", "-I.", "examples/main.c", "paper_earth.c", "-lm", "-o",
                 "paper_earth_example"], export, venv.env), export)
    example = _check(_run([export / "paper_earth_example"], export, venv.env), export)
    (venv.work / "example.csv").write_text(example.stdout)
    assert _read_csv(venv.work / "example.csv") == _read_csv(installed_earth[1])


def test_core_install_verbs_of_an_extra_name_it(venv, installed_earth):
    """`gyrowheel sweep`, `gyrowheel animate` and `gyrowheel simulate --plot` without their extra:
    exit 2, one line saying what to install (valid inputs, so that only the missing extra can
    stop them)."""
    assert venv.importable(EXTRA_MODULES) == [], "an extra is installed: these tests run in order"
    venv.ok("simulate", "earth.fmu", "--stop-time", "1", "-o", "short.csv")
    for args, extra in ((["sweep", "earth.fmu", "--grid", "gamma_dot=2:8:4", "--workers", "0",
                          "-o", "core_sweep.csv"], "sweep"),
                        (["animate", "short.csv", "--fmu", "earth.fmu", "-o", "short.gif"], "animate"),
                        (["simulate", "earth.fmu", "--stop-time", "1", "-o", "plotted.csv",
                          "--plot", "plotted.png"], "plot")):
        r = venv.gyrowheel(*args)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1, _describe(r, venv.work)
        assert f'pip install "gyrowheel[{extra}]"' in lines[0], _describe(r, venv.work)


# ---- 3. the [sweep] extra -------------------------------------------------------------------------

def test_sweep_extra_runs_a_sweep_and_the_ensemble(venv, wheel, installed_earth):
    venv.pip_install(f"{wheel}[sweep]")
    assert venv.importable(["dask", "distributed", "pandas", "pyarrow", "tqdm", "matplotlib"]) == \
        ["dask", "distributed", "pandas", "pyarrow", "tqdm", "matplotlib"]
    r = venv.ok("sweep", "earth.fmu", "--grid", "gamma_dot=2:8:4", "--stop-time", "1", "--workers", "0",
                "--metrics", "survived,final:beta", "-o", "sweep.csv", "--plot", "sweep.png", "--no-progress")
    assert "wrote sweep.csv: 4 rows (0 failed)" in r.stdout
    with (venv.work / "sweep.csv").open(newline="") as f:
        table = list(csv.DictReader(f))
    assert [float(row["gamma_dot"]) for row in table] == SWEEP_POINTS
    assert [row["status"] for row in table] == ["ok"] * 4
    assert (venv.work / "sweep.png").stat().st_size > 10_000
    # the Ensemble compiles the FMU's sources with the installed runtime (taylor kernel included)
    venv.ok("build", SCENE.name, "--taylor", "-o", "earth_taylor.fmu")
    cache = venv.work / "ensemble_cache"
    code = f"""
import json
from gyrowheel.taylor.ensemble import Ensemble
ens = Ensemble("earth_taylor.fmu", cache={str(cache)!r})
res = ens.run(1.0, starts={{"gamma_dot": {SWEEP_POINTS}}})
print(json.dumps([str(ens.library), res.status.tolist(), res.t_final.tolist(), res.output("beta").tolist()]))
"""
    library, status, t_final, beta = json.loads(venv.run_python(code).stdout.strip().splitlines()[-1])
    assert Path(library).parent.parent == cache and Path(library).is_file()
    assert status == [0] * 4 and t_final == [1.0] * 4
    # solver taylor against the sweep's dopri5 at the scene's tolerances (rel_tol 1e-8)
    assert beta == pytest.approx([float(row["final_beta"]) for row in table], rel=1e-6)


# ---- 4. site-packages ------------------------------------------------------------------------------

def test_installed_files_lie_under_gyrowheel_only(venv):
    """The RECORD of the installed wheel: gyrowheel/ and its dist-info, and the script bin/gyrowheel;
    no repository folder became a top-level module."""
    with (venv.site / DIST_INFO / "RECORD").open(newline="") as f:
        record = [row[0] for row in csv.reader(f)]
    outside = [p for p in record if p.split("/")[0] not in ("gyrowheel", DIST_INFO)]
    assert [(venv.site / p).resolve() for p in outside] == [(venv.root / "bin" / "gyrowheel").resolve()], outside
    folders = sorted(set(PACKAGE_DIR.values()) - {"gyrowheel"})
    assert [name for name in folders if (venv.site / name).exists()] == []
    assert venv.importable(folders) == [], "a repository folder is importable as a top-level module"
    installed = [p.name for p in venv.site.iterdir() if p.name.lower().startswith("gyrowheel")]
    assert sorted(installed) == sorted(["gyrowheel", DIST_INFO])


def test_python_started_in_the_checkout_imports_the_checkouts_rooms(venv):
    """Python started in the checkout's root imports the checkout's gyrowheel/ folder, not the
    installed package (the current directory comes first on sys.path); its subpackages are the
    checkout's sibling folders then (gyrowheel/__init__.py), so `python -m gyrowheel` and the
    README's Python example work there too, with the checkout's code."""
    code = ("import json, gyrowheel, gyrowheel.fmu_build.builder as b, gyrowheel.animation as a; "
            "print(json.dumps([gyrowheel.__file__, b.__file__, a.__file__]))")
    r = _check(_run([venv.python, "-c", code], ROOT, venv.tool_env), ROOT)
    init, builder, animation = (Path(p) for p in json.loads(r.stdout))
    assert init == ROOT / "gyrowheel" / "__init__.py"
    assert builder == ROOT / "fmu_build" / "builder.py" and animation == ROOT / "animation" / "__init__.py"
    r = _check(_run([venv.python, "-m", "gyrowheel", "--version"], ROOT, venv.tool_env), ROOT)
    assert r.stdout.strip() == f"gyrowheel {VERSION}"
