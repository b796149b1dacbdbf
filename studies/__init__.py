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
    steady   the linearised stability of the wheel's steady motions (their closed forms,
             eqs. 49, 52, 53 and the critical spin: gyrowheel.model.steady)
    api      sweep(): all of the above in one call (gyrowheel.sweep is its public face)
    analysis, scipy_reference  measurements on results; scipy's integrator on a ModelSpec

The names below are loaded on first use: importing a module of this package does not import
Dask or pandas (the core install has neither; the sweep extra does). The errors live with
gyrowheel's others (gyrowheel.errors), so `except SweepSpecError` needs no pandas.
"""
from importlib import import_module

_EXPORTS = {"open_target": "studies.api", "plan_sweep": "studies.api", "run_plan": "studies.api",
            "sweep": "studies.api", "read_table": "studies.output", "SweepSpecError": "errors",
            "SweepInterrupted": "errors", "FmuTarget": "studies.target", "PointFailure": "studies.target"}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(import_module(f"gyrowheel.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'gyrowheel.studies' has no attribute {name!r}")
