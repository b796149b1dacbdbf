"""`gyrowheel sweep`: the command-line face of gyrowheel.studies (docs/sweeps.md).

Bad input (a malformed spec, an unknown variable, a bad value) is one line and exit 2 before
anything runs; Ctrl-C stops the sweep with the rows done so far on disk (exit 130).
"""
from __future__ import annotations

import sys


def add_parser(sub) -> None:
    from gyrowheel.cli import finite_float

    s = sub.add_parser("sweep", help="parameter sweep / Monte Carlo of a scene or FMU (on Dask)",
                       description="Run many points of a scene or FMU; one row per point in a Parquet or CSV table.")
    s.add_argument("source", help="scene (.toml, built first), FMU (.fmu) or system of FMUs (.ssp)")
    g = s.add_argument_group("points")
    g.add_argument("--grid", action="append", metavar="NAME=SPEC",
                   help="START:STOP:N, START:STOP:N:log or V1,V2,... (repeatable; grids multiply); "
                        "angles also as NAME_deg")
    g.add_argument("--random", action="append", metavar="NAME=DIST", help="normal:MU:SIGMA or uniform:A:B (repeatable)")
    g.add_argument("--samples", type=int, help="number of random samples (crossed with the grid)")
    g.add_argument("--seed", type=int, default=0, help="seed of numpy's default_rng (default 0)")
    g.add_argument("--set", action="append", metavar="NAME=VALUE", help="a value for every point (repeatable)")
    g.add_argument("--derive", metavar="FUNC", help="module:function or file.py:function turning a point's "
                   "inputs into unit values: f(point, values) -> dict")
    e = s.add_argument_group("experiment")
    e.add_argument("--stop-time", type=finite_float, help="s (default: the unit's DefaultExperiment)")
    e.add_argument("--output-interval", type=finite_float, help="communication step, s (default: the unit's step size)")
    e.add_argument("--solver", help="euler, rk4, dopri5, dop853, rosenbrock, taylor (FMUs with the Taylor kernel), "
                   "auto (default: the unit's)")
    e.add_argument("--rel-tol", type=finite_float, help="relative tolerance of the adaptive solvers (default: the unit's)")
    e.add_argument("--abs-tol", type=finite_float, help="absolute tolerance of the adaptive solvers (default: the unit's)")
    e.add_argument("--max-step", type=finite_float, help="largest internal step, s (default: the unit's)")
    m = s.add_argument_group("metrics and output")
    m.add_argument("--metrics", help="comma-separated: survived, fall_time, end_time, event, min_beta, max_beta, "
                   "max_lean, final_position, energy_drift, final:NAME, max:NAME, min:NAME, mean:NAME")
    m.add_argument("--metric-function", action="append", metavar="FUNC",
                   help="module:function or file.py:function of the trajectory (repeatable)")
    m.add_argument("-o", "--output", default="sweep.parquet", help=".parquet or .csv (default sweep.parquet)")
    m.add_argument("--plot", metavar="PNG", help="also plot the table")
    m.add_argument("--plot-metric", help="the column to plot (default: fall_time if most points fell, else the first "
                   "metric with a value at most points)")
    x = s.add_argument_group("execution")
    x.add_argument("--workers", type=int, help="LocalCluster processes (default: one per core; 0: in-process loop; "
                   "at most 4 per core and one per point)")
    x.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786")
    x.add_argument("--batch-size", type=int, help="points per task (default: about 4 tasks per worker)")
    x.add_argument("--no-progress", action="store_true", help="no progress bar")
    x.add_argument("--no-ensemble", action="store_true",
                   help="with solver taylor (or auto integrating with taylor), run every point through the "
                   "FMU instead of the ensemble path")
    s.set_defaults(func=cmd_sweep)


def cmd_sweep(args) -> int:
    """gyrowheel.sweep with the command's arguments; prints what it runs and what it wrote."""
    from gyrowheel.cli import CliError
    from gyrowheel.errors import SweepInterrupted, SweepSpecError
    from gyrowheel.extras import require
    from gyrowheel.wording import command_line_text

    require("sweep", "gyrowheel sweep")  # before anything imports Dask or pandas
    from gyrowheel.api import sweep

    from gyrowheel.studies.execute import local_workers

    def announce(plan) -> None:
        if args.scheduler:
            where = f"the Dask scheduler at {args.scheduler}"
        elif args.workers == 0:
            where = "an in-process loop"
        else:
            where = f"a LocalCluster of {local_workers(args.workers, len(plan.values))[1]}"
        print(f"sweep: {len(plan.values)} points, t = {plan.settings.start_time:g} .. "
              f"{plan.settings.stop_time:g} s every {plan.settings.output_interval:g} s, on {where}", file=sys.stderr)

    try:
        table = sweep(args.source, grid=args.grid, random=args.random, samples=args.samples, seed=args.seed,
                      fixed=args.set or {}, derive=args.derive, stop_time=args.stop_time,
                      output_interval=args.output_interval, solver=args.solver, rel_tol=args.rel_tol,
                      abs_tol=args.abs_tol, max_step=args.max_step, metrics=args.metrics,
                      metric_functions=args.metric_function or (), workers=args.workers, scheduler=args.scheduler,
                      batch_size=args.batch_size, output=args.output, plot=args.plot, plot_metric=args.plot_metric,
                      progress=not args.no_progress, ensemble=not args.no_ensemble, on_start=announce)
    except SweepInterrupted as stop:  # the points done are on disk
        if stop.written or stop.output is None:
            print(f"gyrowheel: interrupted: {stop.written} of {stop.total} points written"
                  + (f" to {args.output}" if stop.output is not None else ""), file=sys.stderr)
        else:
            print(f"gyrowheel: interrupted: 0 of {stop.total} points finished, {args.output} left as it was",
                  file=sys.stderr)
        return 130
    except SweepSpecError as exc:
        raise CliError(command_line_text(exc)) from None
    except (OSError, TimeoutError) as exc:  # e.g. no scheduler at the address
        raise CliError(f"{type(exc).__name__}: {exc}", 1) from None
    failed = int((table["status"] != "ok").sum())
    print(f"wrote {args.output}: {len(table)} rows ({failed} failed)")
    if args.plot:
        print(f"wrote {args.plot}")
    return 0
