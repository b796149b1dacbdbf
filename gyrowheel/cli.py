"""The `gyrowheel` command: build, simulate and inspect wheel FMUs.

Errors are one line on stderr and a non-zero exit (2: bad input, 1: failure),
never a traceback.
"""
from __future__ import annotations

import argparse
import math
import signal
import sys
import threading
from pathlib import Path

EXIT_BAD_INPUT = 2
EXIT_FAILURE = 1


class CliError(Exception):
    def __init__(self, message: str, code: int = EXIT_BAD_INPUT):
        super().__init__(message)
        self.code = code


def finite_float(text: str) -> float:
    """argparse type of every number option: a finite float (inf and nan are not seconds)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def output_file(path: str | Path, flag: str = "-o") -> Path:
    """An output file the command can write: its directory is created (as `gyrowheel build` does)
    and it must not be a directory. Checked before the run, not after it. Raises CliError."""
    path = Path(path)
    if path.is_dir():
        raise CliError(f"{flag} {path}: is a directory; give a file name")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise CliError(f"{flag} {path}: {path.parent} is not a directory") from None
    except OSError as exc:
        raise CliError(f"{flag} {path}: cannot create its directory: {exc.strerror or exc}", EXIT_FAILURE) from None
    return path


def _fmu_path(text: str) -> Path:
    path = Path(text)
    if not path.is_file():
        raise CliError(f"{path}: no such FMU file")
    return path


def cmd_build(args) -> int:
    from gyrowheel.fmu_build.builder import build_fmu
    from gyrowheel.fmu_build.compiler import CompileError
    from gyrowheel.fmu_build.scene import load_scene

    from gyrowheel.fmu_build.scene import SceneError
    try:
        scene = load_scene(args.scene)
    except SceneError:
        raise
    except Exception as exc:  # a defect of the reader: still one line
        raise CliError(f"{args.scene}: reading the scene failed ({type(exc).__name__}: {_one_line(exc)}); "
                       "this is a gyrowheel defect, please report it with the scene", EXIT_FAILURE) from None
    output = Path(args.output or f"{scene.name}.fmu")
    try:  # before the build, not after a long compile
        output.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CliError(f"{output}: cannot write: {exc.strerror or exc}", EXIT_FAILURE) from None
    try:
        result = build_fmu(scene, output, build_dir=args.keep_build, taylor=args.taylor)
    except CompileError as exc:
        raise CliError(f"compiling the FMU failed: {exc}", EXIT_FAILURE) from None
    except ValueError as exc:  # a combination the model refuses (its message names the key)
        raise CliError(f"{args.scene}: {_one_line(exc)}") from None
    except OSError as exc:
        raise CliError(f"{exc.filename or output}: cannot write: {exc.strerror or exc}", EXIT_FAILURE) from None
    except Exception as exc:  # CasADi or a defect of gyrowheel: still one line, never a traceback
        raise CliError(f"{args.scene}: building the model failed ({type(exc).__name__}: {_one_line(exc)}); "
                       "this is a gyrowheel defect, please report it with the scene", EXIT_FAILURE) from None
    print(f"built {result.fmu} (model {result.identifier}, effects: {', '.join(result.spec.effects) or 'none'})")
    return 0


def _one_line(exc: BaseException) -> str:
    """The last non-empty line of an exception's message (CasADi puts the reason there)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[-1] if lines else type(exc).__name__


def _parse_sets(items: list[str]) -> dict[str, str]:
    out = {}
    for item in items or []:
        if "=" not in item:
            raise CliError(f"--set {item!r}: expected NAME=VALUE")
        name, value = item.split("=", 1)
        out[name.strip()] = value.strip()
    return out


def cmd_simulate(args) -> int:
    from fmpy.util import write_csv

    from gyrowheel.plotting import plot_trajectories
    from gyrowheel.simulation import SimulationError, coerce_start_values, run

    fmu = _fmu_path(args.fmu)
    for flag, value in (("--stop-time", args.stop_time), ("--output-interval", args.output_interval)):
        if value is not None and not value > 0:
            raise CliError(f"{flag} must be > 0, got {value}")
    output = output_file(args.output or fmu.with_suffix(".csv").name)
    if args.plot:
        output_file(args.plot, "--plot")
    try:
        start = coerce_start_values(fmu, _parse_sets(args.set))
        result = run(fmu, stop_time=args.stop_time, output_interval=args.output_interval, start_values=start)
    except SimulationError as exc:
        raise CliError(str(exc), EXIT_FAILURE if "reported" in str(exc) else EXIT_BAD_INPUT) from None
    write_csv(str(output), _numeric(result))
    print(f"wrote {output}: {len(result)} rows, t = {result['time'][0]:g} .. {result['time'][-1]:g} s"
          + _events_summary(result))
    if args.plot:
        plot_trajectories({fmu.stem: result}, args.plot, title=fmu.stem)
        print(f"wrote {args.plot}")
    return 0


def _numeric(result):
    """Booleans as 0/1, so that the CSV reads back as numbers (fmpy.util.read_csv, numpy)."""
    import numpy as np
    dtype = [(n, "i1" if result.dtype[n] == np.bool_ else result.dtype[n]) for n in result.dtype.names]
    return result.astype(dtype)


def _events_summary(result) -> str:
    """' (events: fallen at t = 17.46 s, slipping at t = 3.2 s)' for every Boolean flag that turned true."""
    import numpy as np
    fired = []
    for name in result.dtype.names:
        if result.dtype[name] == np.bool_ and result[name][-1]:
            i = int(np.argmax(result[name]))
            when = "at" if i == len(result) - 1 else "by"  # a terminal event ends the run: exact time
            fired.append(f"{name} {when} t = {result['time'][i]:.6g} s")
    return f" (events: {', '.join(fired)})" if fired else ""


def cmd_info(args) -> int:
    from fmpy import read_model_description

    fmu = _fmu_path(args.fmu)
    try:
        md = read_model_description(str(fmu))
    except Exception as exc:  # fmpy raises plain Exceptions for broken archives
        raise CliError(f"{fmu}: not a readable FMU: {exc}") from None
    exp = md.defaultExperiment
    print(f"model        {md.modelName}  (FMI {md.fmiVersion}, generated by {md.generationTool})")
    print(f"description  {md.description}")
    print(f"guid         {md.guid}")
    if exp is not None:
        print(f"experiment   {exp.startTime} .. {exp.stopTime} s, step {exp.stepSize}, tolerance {exp.tolerance}")
    print(f"{'name':<16}{'causality':<11}{'variability':<12}{'start':>14}  unit  description")
    for v in md.modelVariables:
        start = "" if v.start is None else str(v.start)
        print(f"{v.name:<16}{v.causality:<11}{v.variability:<12}{start:>14}  {v.unit or '':<5} {v.description or ''}")
    return 0


def cmd_bench(args) -> int:
    """Run benchmarks/work_precision.py (it lives in the source tree, beside the packages)."""
    import runpy
    script = Path(__file__).resolve().parent.parent / "benchmarks" / "work_precision.py"
    if not script.is_file():
        raise CliError(f"{script}: benchmark script not found (run from a gyrowheel source checkout)",
                       EXIT_FAILURE)
    argv = [str(script), "--out", args.out] + (["--quick"] if args.quick else [])
    if args.scenarios:
        argv += ["--scenarios", *args.scenarios]
    saved = sys.argv
    try:
        sys.argv = argv
        runpy.run_path(str(script), run_name="__main__")
    except SystemExit as exc:
        return int(exc.code or 0)
    finally:
        sys.argv = saved
    return 0


def cmd_system_run(args) -> int:
    """Run an .ssp (SSP 1.0) with gyrowheel's own master on fmpy (cosim/master.py)."""
    import tempfile

    from fmpy.util import write_csv

    from gyrowheel.cosim.master import MasterError, run
    from gyrowheel.cosim.system import SystemFileError, read_ssp

    if not args.step > 0:
        raise CliError(f"--step must be > 0, got {args.step}")
    if args.stop_time is not None and not args.stop_time > 0:
        raise CliError(f"--stop-time must be > 0, got {args.stop_time}")
    output = output_file(args.output or Path(args.ssp).with_suffix(".csv").name)
    sets = _parse_sets(args.set)
    with tempfile.TemporaryDirectory(prefix="gyrowheel-system-") as tmp:
        try:
            system = read_ssp(args.ssp, tmp)
            starts = _system_start_values(system, sets)
            result = run(system, args.step, args.stop_time, start_values=starts)
        except (SystemFileError, ValueError) as exc:
            raise CliError(str(exc)) from None
        except MasterError as exc:
            raise CliError(f"the system failed: {exc}", EXIT_FAILURE) from None
    write_csv(str(output), result.data)
    ended = f", stopped by {result.stopped_by} at t = {result.data['time'][-1]:.6g} s" if result.stopped_by else ""
    print(f"wrote {output}: {len(result.data)} rows{ended}")
    return 0


def _system_start_values(system, sets: dict[str, str]) -> dict[str, dict[str, object]]:
    """--set COMPONENT.VARIABLE=VALUE -> {component: {variable: typed value}} (as `simulate --set`
    checks them against each component's FMU: name, settable, type). Raises CliError."""
    from gyrowheel.simulation import SimulationError, coerce_start_values
    names = [c.name for c in system.components]
    by_component: dict[str, dict[str, str]] = {}
    for key, text in sets.items():
        component, _, variable = key.partition(".")
        if component not in names or not variable:
            raise CliError(f"--set {key}={text}: expected COMPONENT.VARIABLE=VALUE with a component of "
                           f"{', '.join(names)}")
        by_component.setdefault(component, {})[variable] = text
    out = {}
    for c, values in by_component.items():
        try:
            out[c] = coerce_start_values(system.component(c).fmu, values)
        except SimulationError as exc:
            raise CliError(f"--set, component {c}: {exc}") from None
    return out


def cmd_export_c(args) -> int:
    """Write the scene's model as plain C with the C API (fmu_build/export_c.py, docs/c_api.md)."""
    from gyrowheel.fmu_build.compiler import CompileError
    from gyrowheel.fmu_build.export_c import ExportError, export_c
    from gyrowheel.fmu_build.scene import load_scene

    scene = load_scene(args.scene)
    out = Path(args.output or f"{scene.name}_c")
    if out.exists() and not out.is_dir():
        raise CliError(f"-o {out}: exists and is not a directory")
    try:
        result = export_c(scene, out, check=not args.no_compile, scene_file=Path(args.scene).name)
    except CompileError as exc:
        raise CliError(f"compiling the export failed: {exc}", EXIT_FAILURE) from None
    except (ExportError, ValueError) as exc:
        raise CliError(f"{args.scene}: {exc}") from None
    except OSError as exc:
        raise CliError(f"{exc.filename or out}: cannot write: {exc.strerror or exc}", EXIT_FAILURE) from None
    print(f"wrote {out}/ (model {result.identifier}: {result.identifier}.h, {result.identifier}.c, "
          f"CMakeLists.txt, examples/; {len(result.files)} files)")
    return 0


def cmd_animate(args) -> int:
    from gyrowheel.animation import AnimationError
    from gyrowheel.animation.command import run
    try:
        return run(args)
    except AnimationError as exc:
        raise CliError(str(exc)) from None


def make_parser() -> argparse.ArgumentParser:
    from gyrowheel.animation.command import add_arguments as add_animate_arguments

    parser = argparse.ArgumentParser(prog="gyrowheel", description="Build and run FMI 2.0 FMUs of a rolling wheel.")
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build an FMU from a scene file")
    b.add_argument("scene", help="scene file (TOML)")
    b.add_argument("-o", "--output", help="FMU to write (default: <scene name>.fmu)")
    b.add_argument("--keep-build", metavar="DIR", help="keep generated sources and objects in DIR")
    b.add_argument("--taylor", action="store_true",
                   help="also generate the Taylor kernel (solver taylor at run time, the ensemble "
                        "path); implied by solver = \"taylor\" in the scene")
    b.set_defaults(func=cmd_build)
    s = sub.add_parser("simulate", help="simulate an FMU in Co-Simulation with fmpy")
    s.add_argument("fmu")
    s.add_argument("--stop-time", type=finite_float)
    s.add_argument("--output-interval", type=finite_float)
    s.add_argument("--set", action="append", metavar="NAME=VALUE", help="start value (repeatable)")
    s.add_argument("-o", "--output", help="CSV file to write")
    s.add_argument("--plot", metavar="PNG", help="also plot the trajectory")
    s.set_defaults(func=cmd_simulate)
    w = sub.add_parser("bench", help="work-precision benchmark of every solver against peers")
    w.add_argument("--quick", action="store_true", help="a short smoke run")
    w.add_argument("--scenarios", nargs="*", help="paper, long, stiff, near_flat (default: all)")
    w.add_argument("--out", default="results/bench", help="directory for the figures and the table")
    w.set_defaults(func=cmd_bench)
    y = sub.add_parser("system", help="systems of FMUs (SSP 1.0)").add_subparsers(dest="system_command", required=True)
    yr = y.add_parser("run", help="run an .ssp with gyrowheel's master (fixed communication step, fmpy)")
    yr.add_argument("ssp")
    yr.add_argument("--step", type=finite_float, default=0.01, help="communication step [s] (default 0.01)")
    yr.add_argument("--stop-time", type=finite_float, help="default: the .ssp's DefaultExperiment")
    yr.add_argument("--set", action="append", metavar="COMPONENT.NAME=VALUE",
                    help="start value of a component's variable, e.g. wheel.M=2.1 (repeatable)")
    yr.add_argument("-o", "--output", help="CSV file to write (<component>.<variable> columns)")
    yr.set_defaults(func=cmd_system_run)
    x = sub.add_parser("export-c", help="write the scene's model as plain C with a C API (no FMI)")
    x.add_argument("scene", help="scene file (TOML)")
    x.add_argument("-o", "--output", metavar="DIR", help="directory to write (default: <scene name>_c)")
    x.add_argument("--no-compile", action="store_true", help="skip the strict test compilation of the export")
    x.set_defaults(func=cmd_export_c)
    a = sub.add_parser("animate", help="animate a result CSV as .gif, .mp4 or an interactive .html")
    add_animate_arguments(a)
    a.set_defaults(func=cmd_animate)
    i = sub.add_parser("info", help="describe an FMU")
    i.add_argument("fmu")
    i.set_defaults(func=cmd_info)
    from gyrowheel.studies.cli import add_parser as add_sweep_parser  # no Dask import until it runs
    add_sweep_parser(sub)
    return parser




def main(argv: list[str] | None = None) -> int:
    """The `gyrowheel` command; returns its exit status (130 after a Ctrl-C)."""
    code = _main(argv)
    if code == 130 and argv is None and threading.current_thread() is threading.main_thread():
        # The program is stopping as asked. A second Ctrl-C while Python exits (joining Dask's
        # client threads: ~0.3 s after `gyrowheel sweep --scheduler ...` is interrupted) killed
        # it by SIGINT, status -2 instead of 130: further Ctrl-Cs ask for the same stop, ignored.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    return code


def _main(argv: list[str] | None) -> int:
    from gyrowheel.fmu_build.scene import SceneError

    try:  # make_parser imports the subcommands (pandas, dask): a Ctrl-C there is exit 130 too
        parser = make_parser()
    except KeyboardInterrupt:
        return 130
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (CliError, SceneError) as exc:
        print(f"gyrowheel: error: {exc}", file=sys.stderr)
        return getattr(exc, "code", EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        return 130
    except OSError as exc:  # a file the command could not write or read: one line, never a traceback
        print(f"gyrowheel: error: {exc.filename or ''}{': ' if exc.filename else ''}{exc.strerror or exc}",
              file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":
    sys.exit(main())
