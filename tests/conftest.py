"""Shared fixtures: the paper model, built FMUs (once per session) and integration helpers."""
from __future__ import annotations

import fcntl
import math
import os
import pickle
import shutil
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from gyrowheel import model
from gyrowheel.fmu_build import build_fmu, load_scene
from gyrowheel.model.steady import critical_spin, precession_rates  # noqa: F401 (critical_spin: for the tests)

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "examples" / "scenes"
PAPER = dict(M=2.0, R=0.17, k_diam=0.25, k_axial=0.4, g=9.81)
STATES = ["x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot"]  # docs/interface.md order


class CasadiWheel:
    """The project's CasADi model as numpy callables (parameters by name)."""

    def __init__(self, formulation: str = "reduced", **values):
        wheel = {k: v for k, v in values.items() if k in ("M", "R", "k_diam", "k_axial", "beta_min")}
        g = values.get("g", 9.81)
        self.spec = model.build_model(wheel=wheel, effects={"gravity": {"g": g}}, formulation=formulation)
        self.fns = self.spec.functions()
        self.p = np.array([q.start for q in self.spec.parameters], dtype=float)
        self.out_names = [q.name for q, _ in self.spec.outputs]

    def x0(self, **start) -> np.ndarray:
        s = np.array([start.get(q.name, q.start) for q in self.spec.starts], dtype=float)
        return np.array(self.fns["init"](s, self.p)).ravel()

    def rhs(self, t, x):
        return np.array(self.fns["ode"](t, x, [], self.p)).ravel()

    def out(self, x) -> dict[str, float]:
        y = np.array(self.fns["out"](0.0, x, [], self.p)).ravel()
        return dict(zip(self.out_names, y))

    def integrate(self, x0, t_end, rtol=1e-11, atol=1e-12, t_eval=None, beta_min=None):
        """scipy DOP853 on the CasADi model; with beta_min, the fall is a terminal event."""
        from scipy.integrate import solve_ivp
        events = None
        if beta_min is not None:
            def fall(t, x):
                return math.sin(x[3]) - math.sin(beta_min)
            fall.terminal, fall.direction = True, -1
            events = fall
        sol = solve_ivp(self.rhs, (0.0, t_end), x0, method="DOP853", rtol=rtol, atol=atol,
                        t_eval=t_eval, dense_output=False, events=events)
        assert sol.success, sol.message
        return sol

    def fall_time(self, beta_min, rtol, atol, t_end=20.0, **start) -> float:
        """Reference time of the fall from the start values, located by scipy's event finder."""
        return float(self.integrate(self.x0(**start), t_end, rtol, atol, beta_min=beta_min).t_events[0][0])


def steady_precession(beta: float, rho: float, M: float, R: float, k_diam: float, k_axial: float,
                      g: float, sign: float = -1.0) -> dict[str, float]:
    """Start values of steady precession by state name (gyrowheel.model.steady.precession_rates)."""
    alpha_dot, gamma_dot = precession_rates(beta, rho, M, R, k_diam, k_axial, g, sign)
    return dict(beta=beta, alpha_dot=alpha_dot, gamma_dot=gamma_dot, beta_dot=0.0)


@pytest.fixture(autouse=True)
def _fmpy_logger_alive():
    """After every test, fmpy's process-global logger proxy points at a living callback: the
    process-lived dispatcher of tests/fmi_helpers.py (a test's own logger dies with it)."""
    yield
    from fmi_helpers import reproxy
    reproxy()


@pytest.fixture(scope="session")
def paper_model() -> CasadiWheel:
    return CasadiWheel(**PAPER)


@pytest.fixture(scope="session")
def casadi_wheel() -> type[CasadiWheel]:
    """The CasADi model at parameters of a test's own: casadi_wheel(M=..., k_diam=..., g=...)."""
    return CasadiWheel


# The most expensive test files, most expensive first: started first, so that a parallel run
# does not end with one of them on one worker while the other idles (longest processing time
# first).  `make test` runs pytest-xdist with --no-loadscope-reorder so that this order, not the
# number of tests per file, decides; the other files follow, largest first.  Files that make the
# same shared builds (conftest shared_build) are kept apart, so that one worker does not wait on
# the other's build: test_fmi3_agreement.py builds every example scene as FMI 2.0 and 3.0 early,
# test_fmi3_build.py (the same FMI 3.0 builds) runs after it; test_system_files.py builds the
# earth loop early, test_system_fmi3.py (which starts from it) runs after it.  The order is that
# of each file's share of a whole run, measured with
#   .venv/bin/python -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder --junitxml=run.xml
# (the sum of the <testcase> times of each file).
EXPENSIVE_FIRST = (
    "test_platforms_run.py", "test_fmi3_agreement.py", "test_system_files.py", "test_taylor_events.py",
    "test_export_c_sanitizers.py", "test_effects.py", "test_fmu_sources.py", "test_c_runtime.py",
    "test_fastmath.py", "test_contact_solvers.py", "test_c_fmi3_me.py", "test_c_fmi3.py", "test_export_c_cross.py",
    "test_only_what_is_called_for.py", "test_ensemble_lane_steps.py", "test_wheel_install.py", "test_export_c.py",
    "test_system_fmi3.py", "test_fmi3_build.py", "test_taylor_solver.py", "test_contact_flight.py",
    "test_flight_effects.py", "test_c_fmi3_partials.py", "test_sweep_cluster.py", "test_taylor_rewrite.py",
    "test_cli.py", "test_c_solvers.py", "test_cli_new_user.py", "test_taylor_kernel.py", "test_c_model_exchange.py",
    "test_contact_sliding.py", "test_ensemble.py", "test_hard_dynamics.py",
)


def pytest_collection_modifyitems(config, items):
    """Order the files: EXPENSIVE_FIRST, then the others by their number of tests (xdist's own
    order); the tests inside a file keep theirs (a stable sort)."""
    rank = {name: i for i, name in enumerate(EXPENSIVE_FIRST)}
    counts: dict[str, int] = {}
    for item in items:
        counts[item.path.name] = counts.get(item.path.name, 0) + 1
    items.sort(key=lambda item: (rank.get(item.path.name, len(rank)), -counts[item.path.name], item.path.name))


@contextmanager
def compiled_at(level: str):
    """Within: every FMU build (compile_shared and the cross builds) compiles at optimisation
    `level` ("-O2"), through GYROWHEEL_OPTIMISE (gyrowheel.fmu_build.compiler), so command-line
    builds the tests start follow it too."""
    from gyrowheel.fmu_build.compiler import OPTIMISE_ENV
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(OPTIMISE_ENV, level)
        yield


def _run_dir(tmp_path_factory) -> Path:
    """The directory of this test run that all of its pytest-xdist workers share: a worker's
    basetemp is <run>/popen-gwN, a run without xdist has its basetemp alone."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@pytest.fixture(scope="session", autouse=True)
def _build_cache(tmp_path_factory):
    """compile_shared's cache (gyrowheel.fmu_build.build_cache) in a directory of this test run,
    shared by its workers: tests that compile the same source with the same flags and compiler
    (the same FMU built in several modules' directories, an Ensemble's library in each test's
    cache) run the compiler once; builds of the same model (an FMU's FMI 2.0 and 3.0 builds)
    generate its C once (gyrowheel.fmu_build.codegen_cache).  Set for the whole run, so the
    command-line runs the tests start use it too; nothing is reused from an earlier run.  Every
    build compiles at -O1 (compiled_at): the same bits as the product's -O2 in a quarter of the
    compile time (tests/test_fmu_sources.py checks the bits)."""
    from gyrowheel.fmu_build.build_cache import ENV
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(ENV, str(_run_dir(tmp_path_factory) / "build_cache"))
        with compiled_at("-O1"):
            yield


@pytest.fixture
def own_build_cache(tmp_path, monkeypatch):
    """A build cache of the test's own (GYROWHEEL_BUILD_CACHE, in place of the run's), and
    `own_build_cache.calls(owner, name)`: the arguments of every later call of owner.name,
    which still runs (a test counts the compiles, the code generations, it caused)."""
    from gyrowheel.fmu_build.build_cache import ENV

    class Cache:
        path = tmp_path / "cache"

        @staticmethod
        def calls(owner, name: str) -> list[tuple]:
            made: list[tuple] = []
            original = getattr(owner, name)

            def counted(*args):
                made.append(args)
                return original(*args)
            monkeypatch.setattr(owner, name, counted)
            return made
    monkeypatch.setenv(ENV, str(Cache.path))
    return Cache


def shared_build(tmp_path_factory, key: str, make):
    """make(directory) run once per test run, whichever worker asks first; its result (pickled)
    for every worker.  The others wait on a lock file (fcntl.flock) meanwhile, so a build is
    never read half-written, and never made twice at once.  The directory lives in this run's
    basetemp only: nothing is reused from an earlier run (no stale FMU after an edit of model/,
    fmu_build/ or c_src/).  A make that raises leaves no result: the next asker tries again and
    fails in its own test too.  Results are read-only for the tests (several modules, and both
    workers, use the same files)."""
    root = _run_dir(tmp_path_factory) / "shared_builds"
    root.mkdir(exist_ok=True)
    out, done = root / key, root / f"{key}.pickle"
    with open(root / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if done.exists():
            return pickle.loads(done.read_bytes())
        if out.exists():
            shutil.rmtree(out)  # left by a make that raised
        out.mkdir()
        result = make(out)
        part = done.with_suffix(".part")
        part.write_bytes(pickle.dumps(result))
        part.replace(done)
        return result


class _Built:
    """A BuildResult passed between workers: its spec (CasADi SX, not picklable) is made again
    from the scene (cheap, deterministic: the same model_spec the build used)."""

    def __init__(self, built, scene_text: str, scene_name: str):
        self.fmu, self.sources, self.identifier, self.platforms = built.fmu, built.sources, built.identifier, \
            built.platforms
        self.fmi = built.fmi
        self.scene_text, self.scene_name = scene_text, scene_name

    def result(self):
        from gyrowheel.fmu_build.builder import BuildResult, model_spec
        from gyrowheel.fmu_build.scene import parse_scene
        spec = model_spec(parse_scene(self.scene_text, self.scene_name))
        return BuildResult(fmu=self.fmu, spec=spec, sources=self.sources, identifier=self.identifier,
                           platforms=self.platforms, fmi=self.fmi)


@pytest.fixture(scope="session")
def example_build(tmp_path_factory):
    """example_build("euler_disk", taylor=None, fmi=2): the BuildResult of
    examples/scenes/<name>.toml (as an FMI 3 FMU with fmi=3; taylor as build_fmu's: None, the
    scene's default), built once per test run (for every module and xdist worker that asks;
    sources kept beside). Several modules test the same example FMU; the build is the same call,
    made once."""
    cache: dict = {}

    def _build(name: str, taylor: bool | None = None, fmi: int = 2):
        kernel = {None: "", True: "_taylor", False: "_no_taylor"}[taylor]
        key = f"{name}{kernel}{'_fmi3' if fmi == 3 else ''}"
        if key not in cache:
            path = SCENES / f"{name}.toml"

            def make(out: Path):
                built = build_fmu(load_scene(path), out / f"{name}.fmu", build_dir=out / "build", taylor=taylor,
                                  fmi=fmi)
                return _Built(built, path.read_text(), path.name)
            cache[key] = shared_build(tmp_path_factory, key, make).result()
        return cache[key]
    return _build


@pytest.fixture(scope="session")
def fmi3_build(example_build):
    """fmi3_build("paper_earth"): the FMI 3.0 BuildResult of an example scene, built once per
    test run (example_build(name, fmi=3)); its FMI 2.0 twin is example_build(name)."""
    return lambda name: example_build(name, fmi=3)


@pytest.fixture(scope="session")
def earth_build(example_build):
    """The paper's earth scene, built once (sources kept: earth_build.sources)."""
    return example_build("paper_earth")


@pytest.fixture(scope="session")
def earth_fmu(earth_build) -> Path:
    return earth_build.fmu


@pytest.fixture(scope="session")
def fmi3_fmu(example_build):
    """fmi3_fmu("slope_hold"): the FMI 3.0 FMU of examples/scenes/<name>.toml, built once."""
    return lambda name: example_build(name, fmi=3).fmu


@pytest.fixture(scope="session")
def fmi3_earth_fmu(fmi3_fmu) -> Path:
    """The paper's earth scene as an FMI 3.0 FMU."""
    return fmi3_fmu("paper_earth")


def _all_platforms(tmp_path_factory, fmi: int):
    """The paper's earth scene with the Taylor kernel and binaries for every platform of `all`,
    as an FMI `fmi` FMU, built once per run, sources kept."""
    path = SCENES / "paper_earth.toml"

    def make(out: Path):
        built = build_fmu(load_scene(path), out / "paper_earth.fmu", build_dir=out / "build", taylor=True,
                          platforms="all", fmi=fmi)
        return _Built(built, path.read_text(), path.name)
    key = "paper_earth_all_platforms" + ("_fmi3" if fmi == 3 else "")
    return shared_build(tmp_path_factory, key, make).result()


@pytest.fixture(scope="session")
def all_platforms_build(tmp_path_factory):
    """The paper's earth scene with the Taylor kernel and binaries for every platform of `all`
    (gyrowheel.fmu_build.platforms.ALL), built once per run, sources kept (.sources).  zig keeps
    its C libraries in its global cache: on a fresh machine the first build also builds them
    (about 80 s, most of it Windows' C library); later runs take about 10 s."""
    return _all_platforms(tmp_path_factory, 2)


@pytest.fixture(scope="session")
def all_platforms_build_fmi3(tmp_path_factory):
    """The same FMU as all_platforms_build as an FMI 3.0 FMU: binaries in the platform-tuple
    folders (x86_64-linux, ..., x86_64-darwin and aarch64-darwin apart).  zig's C libraries
    are those of the FMI 2 build, from zig's cache: about 10 s more."""
    return _all_platforms(tmp_path_factory, 3)


@pytest.fixture(scope="session")
def earth_loop(tmp_path_factory):
    """The Gyrover closed loop on earth (wheel + controller FMUs, .ssp) on the earth's course, built once."""
    from gyrowheel.controller.closed_loop import build_closed_loop
    from gyrowheel.controller.mission import course
    return shared_build(tmp_path_factory, "closed_loop_earth", lambda out: build_closed_loop(
        load_scene(SCENES / "gyrover_mission_earth.toml"), out, course("earth")))


@pytest.fixture(scope="session")
def earth_loop_fmi3(tmp_path_factory, earth_loop):
    """The same closed loop (the earth loop's schedule, mission and scene) with both FMUs built as
    FMI 3.0, built once; its .ssp is written by the same path."""
    from gyrowheel.controller.closed_loop import build_closed_loop
    from gyrowheel.controller.mission import course
    return shared_build(tmp_path_factory, "closed_loop_earth_fmi3", lambda out: build_closed_loop(
        load_scene(SCENES / "gyrover_mission_earth.toml"), out, course("earth"), schedule=earth_loop.schedule,
        fmi=3))


def loop_accuracy() -> dict[str, dict[str, float]]:
    """The rel_tol the closed loop's .ssp binds on each component: the mission scene's [experiment]
    (read from the scene file) and the controller's build experiment."""
    import tomllib

    from gyrowheel.controller.compensator import EXPERIMENT
    scene = tomllib.loads((SCENES / "gyrover_mission_earth.toml").read_text())
    return {"wheel": {"rel_tol": scene["experiment"]["rel_tol"]}, "controller": {"rel_tol": EXPERIMENT.rel_tol}}


@pytest.fixture(scope="session")
def earth_design(earth_loop):
    return earth_loop.design


@pytest.fixture(scope="session")
def controller_fmu(earth_loop):
    return earth_loop.controller_fmu


# ---- `gyrowheel export-c` (test_export_c.py, test_export_c_realtime.py) -------------------------

@pytest.fixture(scope="session")
def earth(tmp_path_factory) -> Path:
    """paper_earth exported through the command line (with its strict compile check)."""
    from export_c_helpers import gyrowheel

    def make(d: Path) -> Path:
        out = d / "paper_earth"
        r = gyrowheel("export-c", SCENES / "paper_earth.toml", "-o", out)
        assert r.returncode == 0, r.stderr
        assert r.stdout.startswith(f"wrote {out}/") and r.stderr == ""
        return out
    return shared_build(tmp_path_factory, "export_paper_earth", make)


@pytest.fixture(scope="session")
def earth_gcc(earth, tmp_path_factory) -> dict:
    """The export's library object and both examples, gcc -O2, strict; and what gcc printed."""
    from export_c_helpers import STRICT, cc

    def make(out: Path) -> dict:
        built = {"obj": out / "paper_earth.o", "example": out / "example", "realtime": out / "realtime"}
        diagnostics = cc("gcc", *STRICT, "-O2", "-c", earth / "paper_earth.c", "-o", built["obj"]).stderr
        for name in ("example", "realtime"):
            src = earth / "examples" / ("main.c" if name == "example" else "realtime.c")
            diagnostics += cc("gcc", *STRICT, "-O2", f"-I{earth}", src, built["obj"], "-lm", "-o", built[name]).stderr
        built["diagnostics"] = diagnostics
        return built
    return shared_build(tmp_path_factory, "export_paper_earth_gcc", make)


@pytest.fixture(scope="session")
def platform_drivers(all_platforms_build, tmp_path_factory) -> dict:
    """tests/platform_driver/fmu_driver.c built for x86_64-linux (gcc), aarch64-linux and
    x86_64-windows (zig), once per run: {platform: executable} (tests/platform_run.py).  After
    the all-platforms build, whose zig C libraries it reuses from zig's cache (a fresh machine
    builds Windows' once, in that build)."""
    from platform_run import build_drivers
    return shared_build(tmp_path_factory, "platform_drivers", build_drivers)


@pytest.fixture(scope="session")
def platform_drivers_fmi3(all_platforms_build_fmi3, tmp_path_factory) -> dict:
    """tests/platform_driver/fmu3_driver.c (an FMI 3.0 Co-Simulation master) built as
    platform_drivers builds the FMI 2.0 one: {platform: executable}."""
    from platform_run import build_drivers
    return shared_build(tmp_path_factory, "platform_drivers_fmi3", lambda out: build_drivers(out, fmi=3))
