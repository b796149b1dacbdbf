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
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import pandas as pd

from gyrowheel.errors import SweepInterrupted
from gyrowheel.studies.execute import execute
from gyrowheel.studies.output import TableWriter, check_output_path
from gyrowheel.studies.plan import Plan, make_plan
from gyrowheel.studies.plot import check_plot_path
from gyrowheel.studies.spec import (SweepSpecError, as_axis, as_random, parse_grid, parse_random,
                                  point_table)
from gyrowheel.studies.target import FmuTarget


@contextlib.contextmanager
def open_target(source, fmu_out: str | Path | None = None):
    """A scene (.toml or a Scene: built first), an FMU (.fmu, or the BuildResult of one), a
    system (.ssp) or a ready target object -> target. TypeError for anything else."""
    if hasattr(source, "open") and hasattr(source, "variables"):
        yield source
        return
    if not isinstance(source, (str, os.PathLike)):
        from gyrowheel.fmu_build.scene import Scene
        if not isinstance(source, Scene):
            raise TypeError(f"source must be a path (.toml, .fmu, .ssp), a gyrowheel.Scene, the BuildResult of an "
                            f"FMU or a sweep target, got {type(source).__name__}")
        with _built(source, fmu_out) as target:
            yield target
        return
    path = Path(source)
    suffix = path.suffix.lower()
    if suffix == ".toml":
        from gyrowheel.fmu_build.scene import load_scene
        with _built(load_scene(path), fmu_out) as target:
            yield target
        return
    if suffix == ".ssp":
        from gyrowheel.cosim.system import SystemFileError

        from gyrowheel.studies.system_target import SspTarget
        try:
            yield SspTarget(path)
        except SystemFileError as exc:
            raise SweepSpecError(str(exc)) from None
        return
    if suffix != ".fmu":
        raise SweepSpecError(f"{path}: expected a scene (.toml), an FMU (.fmu) or a system (.ssp)")
    if not path.is_file():
        raise SweepSpecError(f"{path}: no such FMU file")
    try:
        yield FmuTarget(path)
    except ValueError as exc:
        raise SweepSpecError(str(exc)) from None


@contextlib.contextmanager
def _built(scene, fmu_out: str | Path | None):
    """The target of a scene's FMU, built into a temporary directory (or fmu_out) first."""
    from gyrowheel.fmu_build.builder import build_fmu

    with tempfile.TemporaryDirectory(prefix="gyrowheel-sweep-build-") as tmp:
        fmu = Path(fmu_out) if fmu_out else Path(tmp) / f"{scene.name}.fmu"
        build_fmu(scene, fmu, build_dir=Path(tmp) / "build")
        yield FmuTarget(fmu)


def _axes(grid) -> list:
    if grid is None:
        return []
    if isinstance(grid, Mapping):
        return [as_axis(n, s) for n, s in grid.items()]
    return [parse_grid(item) for item in grid]


def _randoms(random) -> list:
    if random is None:
        return []
    if isinstance(random, Mapping):
        return [as_random(n, s) for n, s in random.items()]
    return [parse_random(item) for item in random]


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
        inputs = pd.DataFrame(points).reset_index(drop=True)
        inputs.index.name = "point"
        if inputs.empty:
            raise SweepSpecError("points: empty table")
    else:
        inputs = point_table(_axes(grid), _randoms(random), samples, seed)
    fixed = dict(fixed or {})
    for name, value in (("solver", solver), ("rel_tol", rel_tol), ("abs_tol", abs_tol), ("max_step", max_step)):
        if value is not None:
            if name in fixed:
                raise SweepSpecError(f"{name!r} given twice (--{name.replace('_', '-')} and --set {name})")
            fixed[name] = value
    return make_plan(target, inputs, fixed=fixed, derive=derive, stop_time=stop_time,
                     output_interval=output_interval, start_time=start_time, metrics=metrics,
                     metric_functions=metric_functions, ensemble=ensemble)


def check_execution(workers: int | None, batch_size: int | None) -> None:
    if batch_size is not None and batch_size < 1:
        raise SweepSpecError(f"--batch-size must be >= 1, got {batch_size}")
    if workers is not None and workers < 0:
        raise SweepSpecError(f"--workers must be >= 0, got {workers}")


def run_plan(plan: Plan, *, output: str | Path | None = None, workers: int | None = None,
             scheduler: str | None = None, client=None, batch_size: int | None = None,
             progress: bool = False, writer: TableWriter | None = None) -> pd.DataFrame:
    """Run a plan; returns the table (and keeps `output` up to date while it runs)."""
    check_execution(workers, batch_size)
    writer = writer or TableWriter(check_output_path(output), plan.inputs)
    try:
        execute(plan, writer, workers=workers, scheduler=scheduler, client=client, batch_size=batch_size,
                progress=progress)
    finally:
        table = writer.flush()
    return table


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
    workers (0: in-process loop; default: a LocalCluster with one process per core), scheduler
    (address of a running Dask scheduler) or client (a distributed.Client); batch_size points
    per task (default: gyrowheel.studies.execute.auto_batch_size).
    ensemble: when the unit is an FMU with the Taylor kernel and the sweep's solver is taylor,
    each batch runs through the ensemble path (gyrowheel.studies.ensemble_path: several points
    at once, results equal to the plain loop to rounding); False: always one FMU run per point.
    output: .parquet or .csv, kept current while the sweep runs; plot: a PNG of the table
    (plot_metric: the column). on_start(plan): called once everything is checked, just before
    the first point runs.
    Returns a DataFrame with one row per point: point, inputs, metrics, status, reason, wall_time.
    Raises SweepSpecError (a ValueError) for any bad name, value or spec, before anything runs
    (plot_metric: after, when it names no column of the table); SweepInterrupted (a
    KeyboardInterrupt) when Ctrl-C stops the run, with the points done (on disk in `output`).
    """
    output = check_output_path(output)
    check_plot_path(plot)
    check_execution(workers, batch_size)
    with open_target(source) as target:
        plan = plan_sweep(target, grid=grid, random=random, samples=samples, seed=seed, points=points,
                          fixed=fixed, derive=derive, stop_time=stop_time, output_interval=output_interval,
                          start_time=start_time, solver=solver, rel_tol=rel_tol, abs_tol=abs_tol,
                          max_step=max_step, metrics=metrics, metric_functions=metric_functions,
                          ensemble=ensemble)
        writer = TableWriter(output, plan.inputs)
        try:  # from here on, Ctrl-C leaves a complete table of the points done (none, if it comes now)
            if on_start is not None:
                on_start(plan)
            table = run_plan(plan, workers=workers, scheduler=scheduler, client=client,
                             batch_size=batch_size, progress=progress, writer=writer)
        except KeyboardInterrupt as exc:
            if not writer.flushed:  # stopped before run_plan wrote: no table yet, or a previous sweep's
                writer.flush()
            raise SweepInterrupted(writer.table(), writer.written, len(plan.values), output) from exc
    if plot:
        from gyrowheel.studies.plot import plot_table
        try:
            plot_table(table, plot, inputs=list(plan.inputs.columns), metric=plot_metric)
        except ValueError as exc:  # --plot-metric names no column, or the table has no metric to plot
            raise SweepSpecError(str(exc)) from None
    return table
