"""The sweep engine's entry points: one call from a scene or FMU to the result table.

    import gyrowheel
    table = gyrowheel.sweep("examples/scenes/paper_moon.toml",
                            grid={"beta_deg": "60:89:30", "gamma_dot": "0:20:41"},
                            stop_time=20, metrics=["survived", "fall_time", "max_lean"],
                            workers=2, output="moon.parquet")

gyrowheel.sweep (gyrowheel/api.py) is the public face of sweep() here: the same arguments, its
errors worded in the argument names. The engine words them in the command line's flags (the
`--grid 'NAME=SPEC'` strings are its spec language), which `gyrowheel sweep` prints.
"""
from __future__ import annotations

import contextlib
import numbers
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from gyrowheel.arguments import flag as flag_value
from gyrowheel.arguments import number, shown, whole
from gyrowheel.errors import ArgumentTypeError, SweepInterrupted
from gyrowheel.studies.execute import check_size, check_workers, execute
from gyrowheel.studies.output import TableWriter, check_output_path
from gyrowheel.studies.plan import Plan, make_plan
from gyrowheel.studies.plot import check_plot_path
from gyrowheel.scratch import temporary_directory
from gyrowheel.studies.spec import (SweepSpecError, as_axis, as_random, items_of, parse_assignments, parse_grid,
                                  parse_random, point_table)
from gyrowheel.studies.target import FmuTarget


@contextlib.contextmanager
def open_target(source, fmu_out: str | Path | None = None):
    """A scene (.toml or a Scene: built first), an FMU (.fmu, or the BuildResult of one), a
    system (.ssp) or a ready target object -> target. ArgumentTypeError (a TypeError) for
    anything else, SweepSpecError for a path that is none of these."""
    if hasattr(source, "open") and hasattr(source, "variables"):
        yield source
        return
    if not isinstance(source, (str, os.PathLike)):
        from gyrowheel.fmu_build.scene import Scene
        if not isinstance(source, Scene):
            raise ArgumentTypeError(f"source must be a path (.toml, .fmu, .ssp), a gyrowheel.Scene, the BuildResult "
                                    f"of an FMU or a sweep target, got {type(source).__name__}", argument="source")
        with _built(source, fmu_out) as target:
            yield target
        return
    path = Path(source)
    if path.is_dir():
        raise SweepSpecError(f"{path}: is a directory, not a scene, FMU or system file", argument="source")
    suffix = path.suffix.lower()
    if suffix == ".toml":
        from gyrowheel.fmu_build.scene import load_scene
        with _built(load_scene(path), fmu_out) as target:
            yield target
        return
    if suffix == ".ssp":
        from gyrowheel.cosim.system import SystemFileError

        from gyrowheel.studies.system_target import SspTarget
        try:  # (only the target's own errors: the caller's block raises its own)
            target = SspTarget(path)
        except SystemFileError as exc:
            raise SweepSpecError(str(exc)) from None
        yield target
        return
    if suffix != ".fmu":
        raise SweepSpecError(f"{path}: expected a scene (.toml), an FMU (.fmu) or a system (.ssp)")
    if not path.is_file():
        raise SweepSpecError(f"{path}: no such FMU file")
    try:
        target = FmuTarget(path)
    except ValueError as exc:
        raise SweepSpecError(str(exc)) from None
    yield target


@contextlib.contextmanager
def _built(scene, fmu_out: str | Path | None):
    """The target of a scene's FMU, built into a temporary directory (or fmu_out) first."""
    from gyrowheel.fmu_build.builder import build_fmu

    with temporary_directory("sweep-build") as tmp:
        fmu = Path(fmu_out) if fmu_out else Path(tmp) / f"{scene.name}.fmu"
        build_fmu(scene, fmu, build_dir=Path(tmp) / "build")
        yield FmuTarget(fmu)


def _axes(grid) -> list:
    if grid is None:
        return []
    if isinstance(grid, Mapping):
        return [as_axis(n, s) for n, s in grid.items()]
    items = items_of(grid, "--grid", "a mapping or a list of 'NAME=SPEC' strings")
    return [parse_grid(_item(item, "--grid", "NAME=SPEC")) for item in items]


def _randoms(random) -> list:
    if random is None:
        return []
    if isinstance(random, Mapping):
        return [as_random(n, s) for n, s in random.items()]
    items = items_of(random, "--random", "a mapping or a list of 'NAME=DIST' strings")
    return [parse_random(_item(item, "--random", "NAME=DIST")) for item in items]


def _item(item, flag: str, form: str) -> str:
    if not isinstance(item, str):
        raise SweepSpecError(f"{flag} {item!r}: expected {form}")
    return item


def _points(points) -> pd.DataFrame:
    """An explicit table of points: a DataFrame, a list of {name: value} dicts (one a point) or a
    {name: values} dict of columns of one length."""
    columns = isinstance(points, Mapping) and all(
        isinstance(v, (Sequence, np.ndarray)) and not isinstance(v, str) for v in points.values())
    if isinstance(points, pd.DataFrame):
        table = points
    elif isinstance(points, Sequence) and not isinstance(points, str) and all(isinstance(p, Mapping) for p in points):
        table = pd.DataFrame(list(points))
    elif columns and len({len(v) for v in points.values()}) <= 1:
        table = pd.DataFrame({name: list(v) for name, v in points.items()})
    elif columns:
        raise SweepSpecError(f"points: columns of different lengths {sorted({len(v) for v in points.values()})}")
    else:
        raise ArgumentTypeError(f"points must be a pandas DataFrame, a list of {{name: value}} dicts (one a point) or "
                                f"a {{name: values}} dict of columns, got {shown(points)}", argument="points")
    table = table.reset_index(drop=True)
    table.index.name = "point"
    if table.empty:
        raise SweepSpecError("points: empty table")
    return table


def plan_sweep(target, *, grid=None, random=None, samples: int | None = None, seed: int = 0,
               points: pd.DataFrame | Sequence[Mapping] | None = None, fixed: Mapping | None = None,
               derive=None, stop_time: float | None = None, output_interval: float | None = None,
               start_time: float = 0.0, solver: str | None = None, rel_tol: float | None = None,
               abs_tol: float | None = None, max_step: float | None = None, metrics=None,
               metric_functions=(), ensemble: bool = True) -> Plan:
    """The points and settings of a sweep, every name and value checked (SweepSpecError if not)."""
    if points is not None:
        if grid or random:
            raise SweepSpecError("give either points or grid/random, not both")
        inputs = _points(points)
    else:
        inputs = point_table(_axes(grid), _randoms(random), samples, seed)
    fixed = parse_assignments(fixed)
    settings = {}
    for name, value in (("solver", solver), ("rel_tol", rel_tol), ("abs_tol", abs_tol), ("max_step", max_step)):
        if value is not None:
            flag = f"--{name.replace('_', '-')}"
            if name in fixed:
                raise SweepSpecError(f"{name!r} given twice ({flag} and --set {name})")
            if name == "solver":
                if isinstance(value, bool) or not isinstance(value, (str, numbers.Integral)):
                    raise ArgumentTypeError(f"--solver must be a solver's name (e.g. 'rk4') or its number, "
                                            f"got {shown(value)}")
            else:
                number(value, flag, finite=False)  # its type; the unit checks the value (make_plan)
            settings[name] = value
    return make_plan(target, inputs, fixed=fixed, solver_settings=settings, derive=derive, stop_time=stop_time,
                     output_interval=output_interval, start_time=start_time, metrics=metrics,
                     metric_functions=metric_functions, ensemble=flag_value(ensemble, "ensemble"))


def check_execution(workers: int | None, batch_size: int | None, scheduler: str | None = None,
                    client=None) -> None:
    """Where the sweep runs, checked: workers a whole number >= 0 and at most WORKERS_PER_CORE
    per core (gyrowheel.studies.execute.check_workers), batch_size >= 1, scheduler an address,
    client a distributed.Client, and at most one of workers, scheduler and client."""
    if batch_size is not None:
        whole(batch_size, "--batch-size", minimum=1, error=SweepSpecError)
    if workers is not None:
        whole(workers, "--workers", minimum=0, error=SweepSpecError)
        check_workers(workers)
    if scheduler is not None and not isinstance(scheduler, str):
        raise ArgumentTypeError(f"--scheduler must be a Dask scheduler's address (e.g. 'tcp://host:8786'), "
                                f"got {shown(scheduler)}")
    if client is not None and not all(callable(getattr(client, m, None)) for m in ("submit", "nthreads", "cancel")):
        raise ArgumentTypeError(f"client must be a distributed.Client, got {type(client).__name__}", argument="client")
    given = [name for name, value in (("--workers", workers), ("--scheduler", scheduler), ("client", client))
             if value is not None]
    if len(given) > 1:
        raise SweepSpecError(f"{' and '.join(given)} exclude each other: give one of them")


def run_plan(plan: Plan, *, output: str | Path | None = None, workers: int | None = None,
             scheduler: str | None = None, client=None, batch_size: int | None = None,
             progress: bool = False, writer: TableWriter | None = None) -> pd.DataFrame:
    """Run a plan; returns the table (and keeps `output` up to date while it runs)."""
    check_execution(workers, batch_size, scheduler, client)
    check_size(plan, workers=workers, scheduler=scheduler, client=client, batch_size=batch_size)
    writer = writer or TableWriter(check_output_path(output), plan.inputs, plan.metrics.columns())
    try:
        execute(plan, writer, workers=workers, scheduler=scheduler, client=client, batch_size=batch_size,
                progress=progress)
    except BaseException:  # an error or Ctrl-C: the rows done so far, if any (else `output` as it was)
        writer.flush(finished=False)
        raise
    return writer.flush()


def sweep(source, *, grid=None, random=None, samples: int | None = None, seed: int = 0, points=None,
          fixed: Mapping | None = None, derive=None, stop_time: float | None = None,
          output_interval: float | None = None, start_time: float = 0.0, solver: str | None = None,
          rel_tol: float | None = None, abs_tol: float | None = None, max_step: float | None = None,
          metrics=None, metric_functions=(), workers: int | None = None, scheduler: str | None = None,
          client=None, batch_size: int | None = None, output: str | Path | None = None,
          plot: str | Path | None = None, plot_metric: str | None = None, progress: bool = False,
          ensemble: bool = True, on_start: Callable[[Plan], None] | None = None) -> pd.DataFrame:
    """Run a parameter sweep or Monte Carlo study of a scene, an FMU or a target; returns the table.

    source: scene (.toml or a Scene, built first), FMU (.fmu or its BuildResult), system of FMUs
    (.ssp: gyrowheel.studies.system_target) or a target (gyrowheel.studies.target).
    grid: {name: 'START:STOP:N' | 'START:STOP:N:log' | [values] | value} (or --grid strings);
    random: {name: 'normal:MU:SIGMA' | 'uniform:A:B'} with samples (count) and seed;
    points: an explicit table of inputs instead of grid/random. Names: the unit's settable
    variables, angles also as NAME_deg; other names need derive (module:function, file.py:function
    or a callable: derive(point, values) -> {unit name: value}).
    fixed: values set for every point; solver, rel_tol, abs_tol, max_step: solver settings.
    stop_time, output_interval, start_time [s]: the communication grid (defaults: the unit's
    DefaultExperiment); metrics: names (gyrowheel.studies.metrics), metric_functions: user functions.
    workers (0: in-process loop; default: a LocalCluster with one process per core; never more
    processes than points; more than 4 per core is refused: use a scheduler), scheduler
    (address of a running Dask scheduler) or client (a distributed.Client); batch_size points
    per task (default: gyrowheel.studies.execute.auto_batch_size).
    ensemble: when the unit is an FMU with the Taylor kernel and the sweep's solver is taylor (or
    auto, the default, where auto integrates with taylor: FmuInfo.auto_solver), each batch runs through the ensemble path (gyrowheel.studies.ensemble_path: several points
    at once, results equal to the plain loop to rounding); False: always one FMU run per point.
    output: .parquet or .csv, kept current while the sweep runs (gyrowheel.studies.output: an
    existing file is replaced once a point has finished, and left as it was by a sweep that
    fails or is interrupted before that; a sweep that fails later leaves the table of the points
    done and raises its error); plot: a PNG of the table
    (plot_metric: the column). on_start(plan): called once everything is checked, just before
    the first point runs.
    Returns a DataFrame with one row per point: point, inputs, metrics, status, reason, wall_time.
    Raises SweepSpecError (a ValueError) for any bad name, value or spec, before anything runs
    (a value every point sets included, checked by the unit: plan.make_plan)
    (plot_metric: after, when it names no column of the table); SweepInterrupted (a
    KeyboardInterrupt) when Ctrl-C stops the run, with the points done (on disk in `output` when
    there are any).
    """
    output = check_output_path(output)
    plot = check_plot_path(plot)  # absolute: written after the run, wherever the cwd went
    check_execution(workers, batch_size, scheduler, client)
    progress = flag_value(progress, "progress")
    if plot_metric is not None and not isinstance(plot_metric, str):
        raise ArgumentTypeError(f"--plot-metric must be a column's name, got {shown(plot_metric)}")
    if on_start is not None and not callable(on_start):
        raise ArgumentTypeError(f"on_start must be a function of the plan, got {shown(on_start)}",
                                argument="on_start")
    with open_target(source) as target:
        plan = plan_sweep(target, grid=grid, random=random, samples=samples, seed=seed, points=points,
                          fixed=fixed, derive=derive, stop_time=stop_time, output_interval=output_interval,
                          start_time=start_time, solver=solver, rel_tol=rel_tol, abs_tol=abs_tol,
                          max_step=max_step, metrics=metrics, metric_functions=metric_functions,
                          ensemble=ensemble)
        units = {name: v.unit for name, v in target.variables().items() if getattr(v, "unit", None)}
        check_size(plan, workers=workers, scheduler=scheduler, client=client, batch_size=batch_size)
        writer = TableWriter(output, plan.inputs, plan.metrics.columns())
        try:  # from here on, Ctrl-C leaves a complete table of the points done (output as it was if none)
            if on_start is not None:
                on_start(plan)
            table = run_plan(plan, workers=workers, scheduler=scheduler, client=client,
                             batch_size=batch_size, progress=progress, writer=writer)
        except KeyboardInterrupt as exc:
            raise SweepInterrupted(writer.table(), writer.written, len(plan.values), output) from exc
    if plot:
        from gyrowheel.studies.plot import plot_table
        try:
            plot_table(table, plot, inputs=list(plan.inputs.columns), metric=plot_metric, units=units)
        except ValueError as exc:  # --plot-metric names no column, or the table has no metric to plot
            raise SweepSpecError(str(exc)) from None
    return table
