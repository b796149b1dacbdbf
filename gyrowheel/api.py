"""gyrowheel's Python API: the verbs of the `gyrowheel` command as functions.

    import gyrowheel
    fmu = gyrowheel.build("examples/scenes/paper_moon.toml", "moon.fmu")     # -> BuildResult
    run = gyrowheel.simulate(fmu, stop_time=5.0, start_values={"gamma_dot": 8.0})
    run["beta"][-1]                                 # a structured numpy array, as fmpy returns
    gyrowheel.info(fmu).variable("g").start          # 1.625 (m/s2)

Every function takes a path or the parsed object alike (a scene: a path or a gyrowheel.Scene;
an FMU: a path or the BuildResult that built it; a system: a path to an .ssp or its
SystemDescription; a result: a CSV path or the array simulate returned), returns data, and
names its own arguments in its errors (`grid['beta_deg'] = '60:89': ...`, `stop_time must be
> 0`), every one a GyrowheelError (gyrowheel/errors.py; the checks every function shares:
gyrowheel/arguments.py, the FMU a run needs: gyrowheel.description.open_fmu). The `gyrowheel`
command calls exactly these functions (gyrowheel/cli.py).

Importing this module imports no third-party package: each function imports what it uses,
and a function whose optional part is not installed raises MissingExtraError
(gyrowheel.extras) before it imports anything of it.
"""
from __future__ import annotations

import math
import numbers
import os
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from gyrowheel import arguments
from gyrowheel.arguments import check_memory, count, existing_file, flag, number, path
from gyrowheel.errors import (ArgumentError, ArgumentTypeError, GyrowheelError, MissingExtraError, SweepSpecError,
                              UnknownArgumentNameError)
from gyrowheel.extras import require
from gyrowheel.output_files import check_output_file, replaced_atomically
from gyrowheel.scratch import temporary_directory
from gyrowheel.wording import ANIMATE, SWEEP, reworded


# -- arguments ---------------------------------------------------------------------------------

def one_line(exc: BaseException) -> str:
    """The last non-empty line of an exception's message (CasADi puts the reason there)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[-1] if lines else type(exc).__name__


def _scene(scene):
    """(Scene, how errors name it, the scene file's name or '') from a path or a Scene."""
    from gyrowheel.fmu_build.scene import Scene, SceneError, load_scene

    if isinstance(scene, Scene):
        return scene, f"scene {scene.name!r}", ""
    if isinstance(scene, str) and "\n" in scene:
        raise ArgumentError("scene: got TOML text, not a path; read text with gyrowheel.parse_scene(text) "
                            "and pass the Scene", argument="scene")
    file = path(scene, "scene", "a path to a scene file (.toml) or a gyrowheel.Scene")
    try:  # load_scene says what is wrong with the file (also what it is, when it is no scene)
        return load_scene(file), str(file), file.name
    except SceneError as exc:
        exc.argument = exc.argument or "scene"
        raise


def _seconds(value, argument: str) -> float | None:
    """None, or a finite number of seconds > 0 (ArgumentError naming the argument)."""
    if value is None:
        return None
    value = number(value, argument, what="a number of seconds")
    if not value > 0:
        raise ArgumentError(f"{argument} must be > 0, got {value!r}", argument=argument)
    return value


def _output_file(value, argument: str = "output") -> Path:
    """A file a function will write: not a directory, nor any other path that is not a regular
    file (a device such as /dev/full, a FIFO), in a directory that exists
    (gyrowheel.output_files.check_output_file: a missing directory is refused, not made).
    Checked before the work, not after it. Raises ArgumentError naming the argument. Write it
    with gyrowheel.output_files.replaced_atomically."""
    file = path(value, argument, "a file path")
    check_output_file(file, argument)
    return file


def _figure_file(value, argument: str) -> Path:
    """An output file for a matplotlib figure (_output_file), its format named by its suffix:
    one matplotlib writes (FigureCanvasBase.get_supported_filetypes: .png, .pdf, .svg, ...),
    checked before the work. Raises ArgumentError naming the argument."""
    from matplotlib.backend_bases import FigureCanvasBase

    file = _output_file(value, argument)
    formats = sorted(FigureCanvasBase.get_supported_filetypes())
    suffix = file.suffix[1:].lower()
    if suffix not in formats:
        got = f"'.{suffix}' is not a figure format matplotlib writes" if suffix else "has no extension"
        raise ArgumentError(f"{argument} {file}: {got}; give a name ending in one of "
                            f"{', '.join('.' + f for f in formats)}", argument=argument)
    return file


def _output_directory(value, argument: str) -> Path:
    """A directory a function will write into: a directory, or a new one made now in a directory
    that exists (its parents are never made: the rule of check_output_file). Raises
    ArgumentError naming the argument otherwise."""
    directory = path(value, argument, "a directory path")
    if directory.exists() and not directory.is_dir():
        raise ArgumentError(f"{argument} {directory}: exists and is not a directory", argument=argument)
    if not directory.absolute().parent.is_dir():
        blocker = next((p for p in directory.absolute().parents if p.exists() and not p.is_dir()), None)
        reason = f"{blocker} is not a directory" if blocker else f"directory {directory.parent} does not exist"
        raise ArgumentError(f"{argument} {directory}: cannot write: {reason}", argument=argument)
    try:
        directory.mkdir(exist_ok=True)
    except OSError as exc:
        raise ArgumentError(f"{argument} {directory}: cannot write: {exc.strerror or exc}",
                            argument=argument) from None
    return directory


def _written(exc: OSError, paths: Mapping[str, Path | None], error: type = ArgumentError) -> GyrowheelError | None:
    """An OSError while writing one of `paths` ({argument: path}) as `error` naming that argument
    (`output /proc/x: cannot write: No such file or directory`); None if it names none of them."""
    if not exc.filename:
        return None
    failed = Path(exc.filename).absolute()
    for argument, given in paths.items():
        if given is None:
            continue
        mine = given.absolute()
        inside = failed == mine or mine in failed.parents
        beside = failed.parent == mine.parent and failed.name.startswith(mine.name)  # its .part while written
        if inside or beside:
            return error(f"{argument} {given}: cannot write: {exc.strerror or exc}", argument=argument)
    return None


def _assignments(values, argument: str) -> dict[str, object]:
    """Start values as {name: value}: a mapping, or NAME=VALUE strings as the command line gives
    them (values stay text, checked later against the FMU). ArgumentError names a bad item, and
    a name given twice (the last does not silently win)."""
    if values is None:
        return {}
    if isinstance(values, Mapping):
        for key in values:
            if not isinstance(key, str) or not key:
                raise ArgumentError(f"{argument}: names must be non-empty strings, got {key!r}", argument=argument)
        return dict(values)
    if isinstance(values, str) or not isinstance(values, Sequence):
        raise ArgumentError(f"{argument}: expected a mapping {{name: value}} or a list of 'NAME=VALUE' "
                            f"strings, got {values!r}", argument=argument)
    out: dict[str, object] = {}
    for item in values:
        if not isinstance(item, str) or "=" not in item or not item.split("=", 1)[0].strip():
            raise ArgumentError(f"{argument} {item!r}: expected NAME=VALUE", argument=argument)
        name, text = (part.strip() for part in item.split("=", 1))
        if name in out:
            raise ArgumentError(f"{argument}: {name!r} given twice ({name}={out[name]}, {name}={text})",
                                argument=argument)
        out[name] = text
    return out


# -- the verbs ---------------------------------------------------------------------------------

def build(scene, output=None, *, build_dir=None, taylor: bool | None = None, platforms=None, fmi=None,
          arrays=None):
    """Build the FMI 2.0 or 3.0 FMU of a scene (Co-Simulation and Model Exchange, sources
    included).

    scene: a scene file (str or os.PathLike, TOML: docs/scenes.md) or a gyrowheel.Scene.
    output: the .fmu to write (default: '<scene name>.fmu' in the working directory); its
    directory is created. build_dir: keep the generated C and objects there (default: a
    temporary directory, removed). taylor: True: generate the Taylor kernel (solver taylor at
    run time, gyrowheel.Ensemble) whatever the scene's solver; False: leave it out (refused
    for solver = "taylor"); None (default): the scene's [build] taylor, else the kernel for
    solver taylor, and for solver auto (the default solver) where the model's operations
    allow it, so that auto integrates with taylor (docs/accuracy.md, "Solver auto").
    platforms: the platforms whose binaries the FMU carries, as FMI 3.0 platform tuples
    (FMI 3.0, section 2.5.1.4.1; each in the folder FMI 2.0.4, section 2.3 prescribes:
    docs/fmi.md, "Platforms"): "all" (x86_64-linux, aarch64-linux, x86_64-windows,
    x86_64-darwin, aarch64-darwin), "host" (this machine's only), a list of tuples such as
    ["x86_64-linux", "x86_64-windows"] or the same as one comma-separated string (also
    x86-windows, aarch64-windows); None (default): the scene's [build] platforms, else the
    host only. The host's binary is compiled by the host's C compiler, every other by zig's
    (needs gyrowheel[platforms]). An FMI 3 FMU keeps every binary in its platform tuple's
    folder (FMI 3.0.2, section 2.5.1.4.1), both Mac ones apart.
    fmi: the FMI version, 2 (FMI 2.0.4) or 3 (FMI 3.0.2: the event indicators as variables,
    early return from fmi3DoStep at events, Event Mode in Co-Simulation: docs/fmi.md); None
    (default): the scene's [build] fmi, else 2.
    arrays: an FMI 3 FMU's array outputs x_state (the continuous states) and contact_force
    ([F_long, F_lat, F_n]) beside the scalars (True) or not (False: for importers that read
    no arrays); None (default): the scene's [build] arrays, else True. FMI 2 FMUs have none:
    False with FMI 2 is refused (ArgumentError naming arrays; [build] arrays = false: SceneError).
    Returns a gyrowheel.BuildResult: fmu (the path), spec (the ModelSpec: variables, effects),
    sources (the C sources' directory, kept only with build_dir), identifier (the model
    identifier); it is os.PathLike, so it stands for its FMU in every other function.
    Raises SceneError (the file, table and key at fault; a file that is no scene, e.g. an FMU; a
    combination the model refuses), ArgumentError (output or build_dir that cannot be written,
    named; platforms: an unknown platform, in one line listing the valid ones; fmi: not 2 or 3;
    arrays False with FMI 2),
    ArgumentTypeError (an argument of the wrong type), MissingExtraError (a platform other than
    the host's without gyrowheel[platforms]: its pip command), CompileError (a C compiler
    failed, with its output; a cross build names the platform and the compiler's first error;
    no FMU is written then, and an FMU already at output is left as it was).
    """
    from gyrowheel.fmu_build import builder
    from gyrowheel.fmu_build.scene import SceneError

    parsed, where, _ = _scene(scene)
    out = path(output if output is not None else f"{parsed.name}.fmu", "output", "a file path ending in .fmu")
    if out.is_dir():  # said first: a directory has no .fmu to check
        raise ArgumentError(f"output {out}: is a directory; give a file name", argument="output")
    out = _output_file(builder.check_output(out, parsed.file), "output")  # (.fmu, not the scene: made after)
    build_dir = None if build_dir is None else _output_directory(build_dir, "build_dir")
    taylor = None if taylor is None else flag(taylor, "taylor")
    arrays = None if arrays is None else flag(arrays, "arrays")
    try:
        return builder.build_fmu(parsed, out, build_dir=build_dir, taylor=taylor, platforms=platforms, fmi=fmi,
                                 arrays=arrays)
    except MissingExtraError as exc:  # zig, for a platform not the host's: checked before the model is built
        verb = "gyrowheel.build(platforms=...)" if platforms is not None else "gyrowheel.build() ([build] platforms)"
        raise MissingExtraError(exc.extra, verb, exc.missing) from None
    except GyrowheelError:
        raise
    except OSError as exc:  # the FMU or the build directory could not be written
        error = _written(exc, {"output": out, "build_dir": build_dir})
        if error is None:
            raise
        raise error from None
    except ValueError as exc:  # a combination the model refuses (the message names the key)
        raise SceneError(f"{where}: {one_line(exc)}") from exc


def simulate(fmu, *, stop_time=None, output_interval=None, start_values=None, output=None, plot=None,
             events=None):
    """Simulate an FMI 2.0 or 3.0 FMU in Co-Simulation with fmpy (FMI 2.0.4, section 4; FMI
    3.0.2, section 4), from its start to stop_time.

    fmu: the .fmu, FMI 2.0 or 3.0 (a path, or the BuildResult of gyrowheel.build). stop_time
    [s] (default: the FMU's DefaultExperiment); output_interval [s]: the communication step, one
    row each (default: the DefaultExperiment's step size). start_values: {name: value} (parameters,
    solver settings, initial states: 'gamma_dot', 'solver': 'rk4', 'beta': 1.4 rad) or
    'NAME=VALUE' strings; each checked against the FMU by name and type before the run
    (1.5 for an Integer is refused, not truncated). output: also write the result as CSV
    (Booleans as 0/1); plot: also write a PNG of the trajectory (needs gyrowheel[plot]); events:
    a list to which each event the FMU reports is appended as (event name, t [s]) in firing order
    (a jump's update or a termination, located in time: `('contact_flight', 0.1427843)`); the
    same events, names and times, from an FMU's FMI 2.0 and 3.0 builds.
    Returns fmpy's structured array, shape (n,): one row per communication point, fields 'time'
    [s] and every output by name (units: gyrowheel.info). A terminating event (the wheel falling
    flat) ends the run early; its last row is at the event and the Boolean output 'fallen' is
    True there.
    Raises FmuError (the fmu cannot run here: no such file, not an FMU, another FMI version
    than 2.0 and 3.0, no Co-Simulation, no binary for this platform or one that does not load:
    which and why), ArgumentError (a bad time, start value or output path, named: an Integer
    outside its 32 bits with the variable's range, `start_values: value '1e10' for
    'max_internal_steps' is out of range [1, 2147483647] (Integer)`; a start value the FMU
    refuses at initialisation, out of its range or in a combination the model cannot take:
    `start_values: the FMU refused the start values: restitution must be <= 1`; a run whose
    rows would take more than half of this machine's memory, naming stop_time and
    output_interval),
    ArgumentTypeError (an argument of the wrong type), SimulationError (the FMU refused the run:
    its logged reason), MissingExtraError (plot without matplotlib).
    """
    from gyrowheel.simulation import SimulationError, StartValueError, check_start_values, run, write_csv

    checked = _fmu(fmu)
    path, md = checked.path, checked.model_description
    stop_time, output_interval = _seconds(stop_time, "stop_time"), _seconds(output_interval, "output_interval")
    if plot is not None:
        require("plot", "gyrowheel.simulate(plot=...)")
    csv = _output_file(output, "output") if output is not None else None
    png = _figure_file(plot, "plot") if plot is not None else None
    if events is not None and not isinstance(events, list):
        raise ArgumentTypeError(f"events must be a list (the events are appended to it), got "
                                f"{arguments.shown(events)}", argument="events")
    try:
        given = _assignments(start_values, "start_values")
        starts = check_start_values(path, given)
    except SimulationError as exc:
        raise _start_value_error(exc, "start_values") from None
    _check_rows(md, stop_time, output_interval)
    try:
        result = run(path, stop_time=stop_time, output_interval=output_interval, start_values=starts,
                     events=events, stacklevel=3)  # (the warnings: the line calling simulate)
    except StartValueError as exc:  # a parameter out of its range, a combination the model refuses
        raise ArgumentError(f"start_values: {exc}{_as_given_in_degrees(str(exc), given, starts)}",
                            argument="start_values") from None
    if csv is not None:
        with replaced_atomically(csv, "output") as part:
            write_csv(result, part)
    if png is not None:
        from gyrowheel.plotting import plot_trajectories
        with replaced_atomically(png, "plot") as part:
            plot_trajectories({path.stem: result}, part, title=path.stem, changed=given)
    return result


def _fmu(fmu, argument: str = "fmu", **which):
    """The FMU argument of a run, checked (gyrowheel.description.open_fmu; `which`: its
    versions and reader): an FmuFile."""
    from gyrowheel.description import open_fmu
    return open_fmu(fmu, argument, to_run=True, **which)


def _check_rows(md, stop_time: float | None, output_interval: float | None) -> None:
    """The memory rule (gyrowheel.arguments.check_memory) for fmpy's run of an FMU: one row of
    every scalar output (what gyrowheel.simulate records) per communication point, from the
    start time to stop_time, as simulate_fmu picks the defaults (the DefaultExperiment, else a
    stop time of 1 s and 500 intervals)."""
    exp = md.defaultExperiment
    start = float(exp.startTime) if exp is not None and exp.startTime else 0.0
    stop = stop_time if stop_time is not None else (float(exp.stopTime) if exp is not None and exp.stopTime
                                                    else start + 1.0)
    interval = output_interval if output_interval is not None else (
        float(exp.stepSize) if exp is not None and exp.stepSize else (stop - start) / 500)
    if not (stop > start and interval > 0):
        return  # fmpy refuses these itself
    rows = math.floor((stop - start) / interval) + 2  # every point, the last landing on stop_time
    columns = 1 + sum(v.causality == "output" and not v.dimensions for v in md.modelVariables)
    check_memory(rows * columns, arguments.FMPY_BYTES_PER_VALUE,
                 f"stop_time {stop:g} s with output_interval {interval:g} s: {count(rows)} communication points "
                 f"of {columns} columns", "choose a shorter stop_time or a longer output_interval",
                 argument="stop_time" if stop_time is not None or output_interval is None else "output_interval")


def info(fmu):
    """Describe an FMI 2.0 or 3.0 FMU, from its modelDescription.xml (FMI 2.0.4, section 2.2;
    FMI 3.0.2, section 2.4) and its archive.

    fmu: the .fmu (a path, or the BuildResult of gyrowheel.build).
    Returns gyrowheel.FmuInfo: model name, FMI version, generation tool and date, guid,
    interfaces, default experiment [s], every variable with causality, variability, start
    (typed), unit and description, the effects, the solver choices, the platforms in
    binaries/, whether it carries sources and the Taylor kernel. str(info) is the text
    `gyrowheel info` prints, info.as_dict() the JSON of `gyrowheel info --json`.
    fmu may be an FMI 2.0 or 3.0 FMU (fmi_version says which; an FMI 3.0 FMU's variables keep
    their FMI 3.0 types, Float64, Int32, ..., and array variables their dimensions).
    Raises FmuError (no such file, not an FMU, another FMI version than 2.0 and 3.0, a
    modelDescription.xml that breaks its version's schema: which and why), ArgumentTypeError
    (fmu of the wrong type).
    """
    from gyrowheel.description import read_info
    return read_info(fmu)


def sweep(source, *, grid=None, random=None, samples: int | None = None, seed: int = 0, points=None,
          fixed=None, derive=None, stop_time: float | None = None, output_interval: float | None = None,
          start_time: float = 0.0, solver: str | None = None, rel_tol: float | None = None,
          abs_tol: float | None = None, max_step: float | None = None, metrics=None, metric_functions=(),
          workers: int | None = None, scheduler: str | None = None, client=None, batch_size: int | None = None,
          output=None, plot=None, plot_metric: str | None = None, progress: bool = False,
          ensemble: bool = True, on_start: Callable | None = None):
    """Run a parameter sweep or Monte Carlo study on Dask; returns the table (docs/sweeps.md).

    source: a scene (a .toml path or a gyrowheel.Scene: built first, in a temporary
    directory), an FMU (.fmu path or BuildResult), a system of FMUs (.ssp path) or a sweep target
    (gyrowheel.studies.target).
    grid: {name: 'START:STOP:N' | 'START:STOP:N:log' | [values] | value}, or 'NAME=SPEC'
    strings; grids multiply. random: {name: 'normal:MU:SIGMA' | 'uniform:A:B' | (dist, a, b)}
    or 'NAME=DIST' strings, with samples (count, crossed with the grid) and seed (numpy's
    default_rng). points: an explicit table (DataFrame or list of dicts) instead of grid/random.
    Names: the unit's settable variables, angles also as NAME_deg (degrees), presets by name
    (g='moon'), enumeration items by name (solver='rk4'); other names need derive
    ('module:function', 'file.py:function' or a callable f(point, values) -> {name: value}).
    fixed: {name: value} (or 'NAME=VALUE' strings) for every point; solver, rel_tol, abs_tol,
    max_step: solver settings for every point. stop_time, output_interval, start_time [s]: the
    communication grid (default: the unit's DefaultExperiment). metrics: names or a
    comma-separated string (survived, fall_time, end_time, event, min_beta, max_beta, max_lean,
    final_position, energy_drift, final:NAME, max:NAME, min:NAME, mean:NAME); metric_functions:
    'module:function' references or callables of the trajectory.
    workers (0: an in-process loop; default: a LocalCluster, one process per core), scheduler
    (a Dask scheduler's address) or client (a distributed.Client); batch_size: points per task.
    output: a .parquet or .csv kept complete on disk while the sweep runs; plot: a PNG of the
    table (plot_metric: its column); progress: a progress bar on a terminal. ensemble: with
    solver taylor, run batches on the ensemble path (False: one FMU run per point).
    on_start: called with the gyrowheel.studies.plan.Plan (its inputs, values and settings)
    once everything is checked, just before the first point runs.
    Returns a pandas DataFrame, one row per point: point, the inputs, the metrics, status
    ('ok', 'error'), reason, wall_time [s].
    Raises SweepSpecError naming the argument (`grid['beta_deg'] = '60:89': ...`,
    `fixed['R']: ...`, `stop_time ...`, a value every point sets that the unit refuses as it is
    set or at initialisation with every point's values, with the unit's reason, e.g.
    `rel_tol: ... outside its valid range`, `fixed['R']: the unit refuses -1.0 for every point:
    fmi2ExitInitializationMode: R (radius) must be > 0`, a run whose rows would take more than
    half of this machine's memory) before anything runs (a value of one point the unit refuses
    is that point's row, status 'error'); ArgumentTypeError naming an argument of the wrong
    type; FmuError for an FMU source that cannot run here (as gyrowheel.simulate's fmu) or
    is an FMI 3.0 FMU (a sweep runs FMI 2.0 FMUs);
    SweepInterrupted (a KeyboardInterrupt) when Ctrl-C stops it, with the table of the points
    done; SceneError for a scene that cannot be read or built; MissingExtraError without
    gyrowheel[sweep]; OSError / TimeoutError for a scheduler that cannot be reached.
    """
    given = dict(locals())  # every argument, forwarded as given (fixed as strings: parsed below)
    require("sweep", "gyrowheel.sweep()")
    from gyrowheel.studies.api import sweep as run_sweep
    from gyrowheel.studies.spec import parse_assignments

    if isinstance(source, (str, os.PathLike)) and (Path(source).suffix.lower() == ".fmu"
                                                   or arguments.file_kind(Path(source)) == "fmu"):
        _fmu(source, "source", versions=("2.0",), reader="a sweep")  # its runner calls the FMI 2.0 API
    by_name = tuple(name for name in ("grid", "random") if isinstance(given[name], Mapping))
    with reworded(SWEEP, (SweepSpecError, ArgumentTypeError), by_name):
        if fixed is not None and not isinstance(fixed, Mapping):
            given["fixed"] = parse_assignments(fixed)
        return run_sweep(**given)


def export_c(scene, output=None, *, check: bool = True):
    """Write a scene's model as plain C with a C API (no FMI): docs/c_api.md.

    scene: a scene file (str or os.PathLike) or a gyrowheel.Scene. output: the directory to
    write (default: '<scene name>_c'): new, empty, or a previous export (its files are replaced,
    the user's kept). check: first probe the model name against the C library's declarations,
    and afterwards compile '<model>.c' strictly (C99, all warnings as errors).
    Returns gyrowheel.ExportResult: directory, identifier, files (relative), spec.
    Raises SceneError (as build), ExportError (a model name C cannot take, an output directory
    that cannot be used or written, named), ArgumentTypeError (an argument of the wrong type),
    CompileError.
    """
    from gyrowheel.fmu_build.export_c import ExportError
    from gyrowheel.fmu_build.export_c import export_c as write_export
    from gyrowheel.fmu_build.scene import SceneError

    parsed, where, scene_file = _scene(scene)
    out = path(output if output is not None else f"{parsed.name}_c", "output", "a directory path")
    check = flag(check, "check")
    try:
        return write_export(parsed, out, check=check, scene_file=scene_file)
    except GyrowheelError:
        raise
    except OSError as exc:  # the output directory could not be written (e.g. /proc/x)
        error = _written(exc, {"output": out}, ExportError)
        if error is None:
            raise
        raise error from None
    except ValueError as exc:  # a combination the model refuses, or an output table it cannot hold
        raise SceneError(f"{where}: {one_line(exc)}") from exc


def animate(result, output, *, R: float | None = None, fmu=None, component: str | None = None,
            fps: float = 25.0, speed: float = 1.0, size=(640, 480), trail: float | None = None,
            start: float | None = None, stop: float | None = None):
    """Write an animation of a run: a GIF or MP4 (matplotlib), or a standalone interactive HTML
    page (three.js), chosen by output's extension (.gif, .mp4, .html): docs/animation.md.

    result: a result CSV (gyrowheel simulate's, or any table with its column names) or the
    result as data: the structured array gyrowheel.simulate returns, or gyrowheel.system_run's
    RunResult (component: which component of a system's result to draw; default: the one with
    the wheel's columns). output: the file to write; its directory is created.
    R [m]: the wheel radius, or fmu: an FMU (path or BuildResult) or an .ssp whose start values
    give R and the flywheel's geometry (default: z / sin(beta) from the result).
    fps: frames per second of playback (0, 120], a GIF's at most 50 (it plays in real time to the
    centisecond: docs/animation.md, GIF timing); speed: simulated seconds per second of
    playback; size: (width, height) in pixels or 'WIDTHxHEIGHT', 64 to 4096; trail: seconds of
    contact track behind the wheel (default: all); start, stop [s]: the part of the run shown.
    Returns the animation's Timeline (frame times, poses, parameters with their sources).
    Raises AnimationError naming the argument or the file, column and row at fault;
    ArgumentTypeError naming an argument of the wrong type; MissingExtraError without
    gyrowheel[animate].
    """
    require("animate", "gyrowheel.animate()")
    from gyrowheel.animation import AnimationError
    from gyrowheel.animation import animate as draw
    from gyrowheel.animation.command import parse_size

    if not (isinstance(result, (str, os.PathLike)) or hasattr(result, "dtype") or hasattr(result, "data")):
        raise ArgumentTypeError(f"result must be a result CSV (a path), the structured array of gyrowheel.simulate "
                                f"or a gyrowheel.RunResult, got {type(result).__name__}", argument="result")
    output = path(output, "output", "a file path (.gif, .mp4 or .html)")
    for name, value in (("fps", fps), ("speed", speed), ("trail", trail), ("start", start), ("stop", stop)):
        if value is not None or name in ("fps", "speed"):  # their types; the ranges (and R): the engine
            number(value, name, finite=False)
    if component is not None and not isinstance(component, str):
        raise ArgumentTypeError(f"component must be a component's name, got {arguments.shown(component)}",
                                argument="component")
    if fmu is not None:
        fmu = path(fmu, "fmu", "a path to an FMU or .ssp, or a gyrowheel.BuildResult")
        if fmu.is_dir():
            raise AnimationError(f"{fmu}: is a directory, not an FMU or SSP file", argument="fmu")
    with reworded(ANIMATE, (AnimationError,)):
        if isinstance(size, str):
            size = parse_size(size)
        elif not (isinstance(size, Sequence) and len(size) == 2
                  and all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in size)):
            raise AnimationError(f"size: expected (WIDTH, HEIGHT) in pixels or 'WIDTHxHEIGHT', got {size!r}",
                                 argument="size")
        timeline = draw(result, output, R=R, fmu=fmu, component=component, fps=fps, speed=speed,
                        size=tuple(int(v) for v in size), trail=trail, start=start, stop=stop)
    if timeline.parameters.source.get("R") == "--R":  # the engine's label for a radius given
        timeline.parameters.source["R"] = "R"
    return timeline


def system_run(system, *, step: float = 0.01, stop_time: float | None = None, start_values=None, output=None):
    """Run a system of FMUs (SSP 1.0; FMI 2.0 and FMI 3.0 Co-Simulation FMUs, side by side) with
    gyrowheel's own master on fmpy: fixed communication step, Jacobi exchange, like libcosim's
    fixed-step algorithm (docs/system.md).

    system: an .ssp file (a path; its FMUs are unpacked into a temporary directory, removed
    after the run) or a gyrowheel.cosim.system.SystemDescription. step [s]: the communication
    step; stop_time [s]: default the system's DefaultExperiment; it must be a whole number of
    steps from the start. start_values: {'COMPONENT.VARIABLE': value}, {COMPONENT: {VARIABLE:
    value}} or 'COMPONENT.VARIABLE=VALUE' strings, on top of the system's own bindings; each
    checked against the component's FMU by name and type. output: also write the result as CSV.
    Returns gyrowheel.cosim.master.RunResult: data (structured array: time [s] and every
    output as '<component>.<variable>'), stopped_by (the component that ended the run early,
    e.g. the wheel falling flat, or None), wall_time [s].
    Raises SystemFileError (the .ssp, naming the element at fault; a file that is no .ssp),
    ArgumentError (step, stop_time, start_values, output; a run whose rows would take more than
    half of this machine's memory), ArgumentTypeError (an argument of the wrong type),
    MasterError (a component failed: its logged reason). A component that refuses its start
    values before the run (a value out of its range) is bad input: ArgumentError naming
    start_values when a value given here is named (`start_values: wheel refused the start values:
    M (mass) must lie in [1e-30, 1e+30] kg ... (wheel.M = 1e+150)`), SystemFileError when one of
    the system's own bindings is.
    """
    from gyrowheel.cosim.master import StartValueRefusedError, run
    from gyrowheel.cosim.system import SystemDescription, SystemFileError
    from gyrowheel.cosim.ssp import read_ssp
    from gyrowheel.simulation import write_csv

    step = _seconds(step, "step")
    if step is None:
        raise ArgumentError("step must be a number of seconds > 0, got None", argument="step")
    stop_time = _seconds(stop_time, "stop_time")
    csv = _output_file(output, "output") if output is not None else None
    with temporary_directory("system") as tmp:
        if isinstance(system, SystemDescription):
            description = system
        else:
            description = read_ssp(existing_file(system, "system", "ssp", what="a path to an .ssp or a "
                                                 "SystemDescription", error=SystemFileError), tmp)
        starts = _system_start_values(description, start_values)
        try:
            result = run(description, step, stop_time, start_values=starts)
        except StartValueRefusedError as exc:  # bad input: the user's value or the system file's
            if exc.given:
                raise ArgumentError(f"start_values: {exc}", argument="start_values") from None
            raise SystemFileError(f"{system if description is not system else 'system'}: {exc}") from None
        except GyrowheelError:
            raise
        except ValueError as exc:  # the master's checks: a stop time off the step grid, a result too large
            text = str(exc)
            raise ArgumentError(text, argument="stop_time" if text.startswith("stop time") else None) from None
    if csv is not None:
        with replaced_atomically(csv, "output") as part:
            write_csv(result.data, part)
    return result


def _as_given_in_degrees(reason: str, given: dict[str, str], starts: dict[str, object]) -> str:
    """The FMU checks angles in rad: for each angle its refusal names that was given as
    <angle>_deg, the text '; <angle> given as <angle>_deg = 100 (1.745 rad)', else ''."""
    notes = [f"; {name[:-4]} given as {name} = {text} ({starts[name[:-4]]!r} rad)"
             for name, text in given.items()
             if name.endswith("_deg") and name[:-4] in starts and re.search(rf"\b{re.escape(name[:-4])}\b", reason)]
    return "".join(notes)


def _start_value_error(exc: Exception, where: str) -> ArgumentError:
    """A start value refused while checked against the FMU, as the error naming start_values: an
    UnknownArgumentNameError (also a KeyError) for a name the FMU does not have, else an
    ArgumentError."""
    from gyrowheel.simulation import UnknownVariableError
    error = UnknownArgumentNameError if isinstance(exc, UnknownVariableError) else ArgumentError
    return error(f"{where}: {exc}", argument="start_values")


def _system_start_values(system, values) -> dict[str, dict[str, object]]:
    """start_values (see system_run) -> {component: {variable: typed value}}, checked against
    each component's FMU as simulate checks them. Raises ArgumentError naming the entry."""
    from gyrowheel.simulation import SimulationError, check_start_values

    names = [c.name for c in system.components]
    listed = f"a component of {', '.join(names)}"
    by_component: dict[str, dict[str, object]] = {}
    if isinstance(values, Mapping) and values and all(isinstance(v, Mapping) for v in values.values()):
        for component, own in values.items():
            if component not in names:
                raise ArgumentError(f"start_values[{component!r}]: no such component; expected {listed}",
                                    argument="start_values")
            by_component[component] = dict(own)
    else:
        keyed = isinstance(values, Mapping)  # else 'COMPONENT.VARIABLE=VALUE' strings
        for key, value in _assignments(values, "start_values").items():
            component, _, variable = key.partition(".")
            if component not in names or not variable:
                where = f"start_values[{key!r}]" if keyed else f"start_values {key + '=' + str(value)!r}"
                form = "COMPONENT.VARIABLE" if keyed else "COMPONENT.VARIABLE=VALUE"
                raise ArgumentError(f"{where}: expected {form} with {listed}", argument="start_values")
            by_component.setdefault(component, {})[variable] = value
    out = {}
    for component, own in by_component.items():
        try:
            out[component] = check_start_values(system.component(component).fmu, own)
        except SimulationError as exc:
            raise _start_value_error(exc, f"start_values, component {component}") from None
    return out
