"""Parameter sweeps and Monte Carlo studies of gyrowheel FMUs on Dask (docs/sweeps.md).

    spec     grids and random samples -> the table of points
    plan     names and values checked against the unit, converted to unit values
    target   the FMU (or any unit with the same interface) opened once per task on a worker
    system_target  a system of FMUs (.ssp: the wheel and its controller) as one target
    batch    one task: a batch of points in one instance (reset, set, step)
    metrics  fall time, survived, lean extremes, final position, energy drift, user functions
    execute  plain loop, LocalCluster or a scheduler address; progress bar; Ctrl-C
    interrupt  Ctrl-C as a stop request while Dask is at work, acted on between steps
    output   the tidy table, kept complete on disk while it grows (Parquet or CSV)
    plot     a first look at a table
    steady   steady motions of the wheel (eqs. 49, 52, 53) and their linearised stability
    api      sweep(): all of the above in one call
"""
from fmu_build.sweep.api import open_target, plan_sweep, run_plan, sweep
from fmu_build.sweep.output import read_table
from fmu_build.sweep.spec import SweepSpecError
from fmu_build.sweep.target import FmuTarget, PointFailure

__all__ = ["FmuTarget", "PointFailure", "SweepSpecError", "open_target", "plan_sweep", "read_table",
           "run_plan", "sweep"]
