"""gyrowheel: a rolling wheel derived in CasADi and shipped as FMI 2.0 or 3.0 FMUs (docs/architecture.md).

The command line's verbs as functions (gyrowheel/api.py), each taking a path or the parsed
object alike and returning data:

    build(scene, output)        -> BuildResult       a scene (.toml or Scene) -> an FMU
    simulate(fmu, ...)          -> structured array  fmpy Co-Simulation run
    info(fmu)                   -> FmuInfo           what an FMU is, as data
    sweep(source, ...)          -> pandas.DataFrame  sweeps and Monte Carlo on Dask   [sweep]
    Ensemble(fmu)                                    many trajectories at once (solver taylor)
    export_c(scene, output)     -> ExportResult      the model as plain C with a C API
    animate(result, output)     -> Timeline          GIF, MP4 or interactive HTML    [animate]
    system_run(system, ...)     -> RunResult         a system of FMUs (SSP 1.0)

and the scene types (Scene, load_scene, parse_scene) and errors (GyrowheelError and the rest,
gyrowheel/errors.py). [extra]: needs that optional part (pip install "gyrowheel[extra]").
Everything is loaded on first use: `import gyrowheel` imports no third-party package.
"""
from importlib import import_module
from pathlib import Path as _Path

__version__ = "0.1.0"

# In a source checkout the other rooms (model/, fmu_build/, taylor/, ...) are siblings of this
# folder; installed, pyproject.toml's package-dir puts them inside it. Python started in the
# checkout's root imports this folder rather than an installed gyrowheel, so the rooms are then
# looked up beside it too (site-packages holds no pyproject.toml: an install is unaffected).
_ROOT = _Path(__file__).resolve().parent.parent
if (_ROOT / "pyproject.toml").is_file() and (_ROOT / "c_src" / "__init__.py").is_file():
    __path__.append(str(_ROOT))

_EXPORTS = {
    # the verbs
    "build": "gyrowheel.api", "simulate": "gyrowheel.api", "info": "gyrowheel.api", "sweep": "gyrowheel.api",
    "export_c": "gyrowheel.api", "animate": "gyrowheel.api", "system_run": "gyrowheel.api",
    "Ensemble": "gyrowheel.taylor.ensemble", "EnsembleResult": "gyrowheel.taylor.ensemble",
    # what they take and return
    "Scene": "gyrowheel.fmu_build.scene", "load_scene": "gyrowheel.fmu_build.scene",
    "parse_scene": "gyrowheel.fmu_build.scene", "BuildResult": "gyrowheel.fmu_build.builder",
    "FmuInfo": "gyrowheel.description", "VariableInfo": "gyrowheel.description",
    "DefaultExperiment": "gyrowheel.description", "ExportResult": "gyrowheel.fmu_build.export_c",
    "RunResult": "gyrowheel.cosim.master", "SystemDescription": "gyrowheel.cosim.system",
    "Timeline": "gyrowheel.animation.timeline",
    # errors
    "GyrowheelError": "gyrowheel.errors", "ArgumentError": "gyrowheel.errors",
    "ArgumentTypeError": "gyrowheel.errors", "FmuError": "gyrowheel.errors",
    "SweepSpecError": "gyrowheel.errors", "SweepInterrupted": "gyrowheel.errors",
    "MissingExtraError": "gyrowheel.errors", "UnknownNameError": "gyrowheel.errors",
    "UnknownArgumentNameError": "gyrowheel.errors", "SceneError": "gyrowheel.fmu_build.scene",
    "SimulationError": "gyrowheel.simulation", "ExportError": "gyrowheel.fmu_build.export_c",
    "CompileError": "gyrowheel.fmu_build.compiler", "AnimationError": "gyrowheel.animation.table",
    "SystemFileError": "gyrowheel.cosim.system", "MasterError": "gyrowheel.cosim.master",
    "EnsembleError": "gyrowheel.taylor.ensemble",
}
__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str):
    """The names above, imported on first use (PEP 562)."""
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'gyrowheel' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value  # once loaded, a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
