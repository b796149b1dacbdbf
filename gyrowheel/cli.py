"""The `gyrowheel` command: build, simulate, describe, sweep, animate and export wheel FMUs.

Each verb is one call of gyrowheel's Python API (gyrowheel/api.py) and prints what it returned.
Errors are one line on stderr, `gyrowheel: error: ...`, never a traceback, and the exit status
says which kind (docs/architecture.md, "Errors"):

    0    done (also when the reader of the output goes away: `gyrowheel info --json | head`)
    2    bad input: an argument the command line itself refuses (argparse), or a ValueError or
         ImportError of gyrowheel's (a file that is missing or of the wrong kind, a value out of
         range, a scene, FMU or system that cannot be used, an output that cannot be written, a
         run too large for the memory, an optional part not installed: its pip command)
    1    a failure: the FMU, the system or the C compiler failed (their reason), an operating
         system error
    130  interrupted (Ctrl-C)

Setting up the parser imports no optional part, so `--help` works in the core install.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import signal
import sys
import threading
import warnings
from pathlib import Path

from gyrowheel import __version__
from gyrowheel.errors import GyrowheelError
from gyrowheel.extras import require
from gyrowheel.scratch import remove_stale
from gyrowheel.wording import command_line_text

EXIT_BAD_INPUT = 2
EXIT_FAILURE = 1

# API argument -> the flag that gives it, per verb (errors naming an argument name the flag)
BUILD_FLAGS = {"output": "-o", "build_dir": "--keep-build", "platforms": "--platforms", "fmi": "--fmi",
               "arrays": "--no-arrays"}
SIMULATE_FLAGS = {"stop_time": "--stop-time", "output_interval": "--output-interval", "start_values": "--set",
                  "output": "-o", "plot": "--plot"}
SYSTEM_FLAGS = {"step": "--step", "stop_time": "--stop-time", "start_values": "--set", "output": "-o"}
EXPORT_FLAGS = {"output": "-o"}


class Parser(argparse.ArgumentParser):
    """argparse's parser with its errors in one line, as every other error of the command
    (argparse prints the usage first): `gyrowheel: error: argument --stop-time: 'nan' is not a
    finite number (see gyrowheel simulate --help)`, exit 2. The sub-commands' parsers are
    Parsers too (add_subparsers makes them of the parser's class)."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"gyrowheel: error: {message} (see {self.prog} --help)\n")


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


def flagged(exc: BaseException, flags: dict[str, str]) -> str:
    """An API error in the command's words: the engines' own text (they word their errors in the
    flags already: gyrowheel.wording), or the message with the arguments it names given as their
    flags: the argument it begins with (`stop_time must be > 0` -> `--stop-time must be > 0`)
    and any other argument whose name cannot be a word of the text (`... choose a shorter
    stop_time or a longer output_interval` -> `... --stop-time ... --output-interval`)."""
    text = command_line_text(exc)
    argument = getattr(exc, "argument", None)
    if argument in flags and re.match(rf"{re.escape(argument)}(?![\w./\\-])", text):
        text = flags[argument] + text[len(argument):]
    for name, flag in flags.items():
        if "_" in name:
            text = re.sub(rf"(?<![\w.-]){re.escape(name)}(?![\w-])", flag, text)
    return text


def _failed(what: str, where: str, exc: BaseException) -> CliError:
    """A failure that is gyrowheel's own defect (CasADi or a bug): one line, exit 1."""
    from gyrowheel.api import one_line
    return CliError(f"{where}: {what} failed ({type(exc).__name__}: {one_line(exc)}); "
                    "this is a gyrowheel defect, please report it with the scene", EXIT_FAILURE)


def compile_failed(exc, what: str) -> CliError:
    """The CLI's error for a CompileError of building `what`: a bad GYROWHEEL_OPTIMISE is the
    user's setting (exit 2, its own message), anything else a failed compilation (exit 1)."""
    from gyrowheel.fmu_build.compiler import OptimiseLevelError
    if isinstance(exc, OptimiseLevelError):
        return CliError(str(exc))
    return CliError(f"compiling {what} failed: {exc}", EXIT_FAILURE)


def print_warnings(caught, *kinds) -> None:
    """The warnings `caught` (warnings.catch_warnings(record=True)) of the given kinds as one line
    each, `gyrowheel: warning: ...`; any other shown as Python shows it."""
    for w in caught:
        if issubclass(w.category, kinds):
            print(f"gyrowheel: warning: {w.message}", file=sys.stderr)
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)


def cmd_build(args) -> int:
    from gyrowheel.api import build
    from gyrowheel.fmu_build.build_cache import BuildCacheWarning
    from gyrowheel.errors import ArgumentError, MissingExtraError
    from gyrowheel.fmu_build.compiler import CompileError

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", BuildCacheWarning)
            result = build(args.scene, args.output, build_dir=args.keep_build, taylor=args.taylor,
                           platforms=args.platforms, fmi=args.fmi, arrays=args.arrays)
    except MissingExtraError as exc:  # zig, for a platform not the host's (exit 2)
        verb = "gyrowheel build --platforms" if args.platforms is not None else "gyrowheel build ([build] platforms)"
        raise MissingExtraError(exc.extra, verb, exc.missing) from None
    except ArgumentError as exc:  # an output or build directory that cannot be written, a platform (exit 2)
        raise CliError(flagged(exc, BUILD_FLAGS)) from None
    except CompileError as exc:
        raise compile_failed(exc, "the FMU") from None
    except GyrowheelError:  # the scene: one line naming the file, table and key (exit 2)
        raise
    except OSError as exc:
        raise CliError(f"{exc.filename or args.output or 'the FMU'}: cannot write: {exc.strerror or exc}",
                       EXIT_FAILURE) from None
    except Exception as exc:  # CasADi or a defect of gyrowheel: still one line, never a traceback
        raise _failed("building the FMU", args.scene, exc) from None
    print_warnings(caught, BuildCacheWarning)
    print(f"built {result.fmu} (model {result.identifier}, effects: {', '.join(result.spec.effects) or 'none'}; "
          f"platforms: {', '.join(result.platforms)}{'; FMI 3.0' if result.fmi == 3 else ''})")
    return 0


def cmd_simulate(args) -> int:
    from gyrowheel.api import simulate
    from gyrowheel.fmu_build.build_cache import BuildCacheWarning
    from gyrowheel.simulation import FmuWarning, SimulationError

    if args.plot:
        require("plot", "gyrowheel simulate --plot")
    output = args.output or Path(args.fmu).with_suffix(".csv").name
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", FmuWarning)
            warnings.simplefilter("always", BuildCacheWarning)
            events: list[tuple[str, float]] = []
            result = simulate(args.fmu, stop_time=args.stop_time, output_interval=args.output_interval,
                              start_values=args.set or [], output=output, plot=args.plot, events=events)
    except SimulationError as exc:  # the FMU refused the run: its logged reason
        raise CliError(str(exc), EXIT_FAILURE) from None
    except GyrowheelError as exc:
        raise CliError(flagged(exc, SIMULATE_FLAGS)) from None
    # the FMU's warnings (a fixed-step solver for the contact modes) and the build cache's, one line each
    print_warnings(caught, FmuWarning, BuildCacheWarning)
    print(f"wrote {output}: {len(result)} rows, t = {result['time'][0]:g} .. {result['time'][-1]:g} s"
          + events_summary(events))
    if "painleve_paradox" in result.dtype.names and result["painleve_paradox"][-1]:
        print(f"gyrowheel: warning: {PAINLEVE_STOP.format(t=result['time'][-1])}", file=sys.stderr)
    if args.plot:
        print(f"wrote {args.plot}")
    return 0


# the Painleve stop's reason and remedy (model/painleve.py; docs/effects.md, "Sliding")
PAINLEVE_STOP = ("sliding stopped at t = {t:.9g} s (event painleve): the friction's share of the normal inverse "
                 "mass reached D / W_nn <= 0.05, where the normal force diverges or turns negative against a "
                 "contact driven into the ground (Painleve's paradox); the rigid Coulomb contact has no solution "
                 "beyond it: lower mu_k")


def events_summary(events: list[tuple[str, float]]) -> str:
    """' (events: contact_flight: 11 times, t = 0.142784 .. 0.428074 s; fall at t = 1.2 s)': each
    event the FMU reported ((name, t [s]) in firing order, gyrowheel.simulate's events) in the
    words of gyrowheel.simulation.fired_events; '' if none fired."""
    from gyrowheel.simulation import fired_events

    fired = fired_events(events)
    return f" (events: {'; '.join(fired)})" if fired else ""


def cmd_info(args) -> int:
    from gyrowheel.api import info

    try:
        description = info(args.fmu)
    except GyrowheelError as exc:
        raise CliError(flagged(exc, {})) from None
    print(json.dumps(description.as_dict(), indent=2) if args.json else description)
    return 0


def cmd_system_run(args) -> int:
    """Run an .ssp (SSP 1.0) with gyrowheel's own master on fmpy (cosim/master.py)."""
    from gyrowheel.api import system_run
    from gyrowheel.cosim.master import MasterError

    output = args.output or Path(args.ssp).with_suffix(".csv").name
    try:
        result = system_run(args.ssp, step=args.step, stop_time=args.stop_time, start_values=args.set or [],
                            output=output)
    except MasterError as exc:
        raise CliError(f"the system failed: {exc}", EXIT_FAILURE) from None
    except GyrowheelError as exc:
        raise CliError(flagged(exc, SYSTEM_FLAGS)) from None
    ended = f", stopped by {result.stopped_by} at t = {result.data['time'][-1]:.6g} s" if result.stopped_by else ""
    print(f"wrote {output}: {len(result.data)} rows{ended}")
    return 0


def cmd_export_c(args) -> int:
    """Write the scene's model as plain C with the C API (fmu_build/export_c.py, docs/c_api.md)."""
    from gyrowheel.api import export_c
    from gyrowheel.fmu_build.compiler import CompileError
    from gyrowheel.fmu_build.scene import SceneError

    try:
        result = export_c(args.scene, args.output, check=not args.no_compile)
    except SceneError:  # one line naming the file, table and key
        raise
    except CompileError as exc:
        raise compile_failed(exc, "the export") from None
    except GyrowheelError as exc:
        raise CliError(f"{args.scene}: {flagged(exc, EXPORT_FLAGS)}") from None
    except OSError as exc:
        raise CliError(f"{exc.filename or args.output or 'the export'}: cannot write: {exc.strerror or exc}",
                       EXIT_FAILURE) from None
    print(f"wrote {result.directory}/ (model {result.identifier}: {result.identifier}.h, {result.identifier}.c, "
          f"CMakeLists.txt, examples/; {len(result.files)} files)")
    return 0


def cmd_animate(args) -> int:
    from gyrowheel.animation.command import run

    require("animate", "gyrowheel animate")
    try:
        return run(args)
    except GyrowheelError as exc:
        raise CliError(command_line_text(exc)) from None


def make_parser() -> argparse.ArgumentParser:
    from gyrowheel.animation.command import add_arguments as add_animate_arguments
    from gyrowheel.studies.cli import add_parser as add_sweep_parser  # no Dask import until it runs

    parser = Parser(prog="gyrowheel", description="Build and run FMI 2.0 and 3.0 FMUs of a rolling wheel.")
    parser.add_argument("--version", action="version", version=f"gyrowheel {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build an FMU from a scene file")
    b.add_argument("scene", help="scene file (TOML)")
    b.add_argument("-o", "--output", help="FMU to write (default: <scene name>.fmu)")
    b.add_argument("--keep-build", metavar="DIR", help="keep generated sources and objects in DIR")
    kernel = b.add_mutually_exclusive_group()
    kernel.add_argument("--taylor", action="store_true", default=None,
                        help="generate the Taylor kernel (solver taylor at run time, the ensemble path) "
                             "whatever the scene's solver; by default it is built for solver taylor, and "
                             "for solver auto where the model allows it")
    kernel.add_argument("--no-taylor", dest="taylor", action="store_false",
                        help="leave the Taylor kernel out (a faster build; solver auto then uses dop853)")
    b.add_argument("--platforms", metavar="LIST",
                   help="the platforms to carry binaries for, comma-separated FMI 3.0 tuples "
                        "(x86_64-linux, aarch64-linux, x86_64-windows, x86-windows, aarch64-windows, "
                        "x86_64-darwin, aarch64-darwin), 'all' (the five of them without x86-windows "
                        "and aarch64-windows) or 'host'; default: the scene's [build] platforms, else "
                        "the host only; others than the host's need gyrowheel[platforms] (zig)")
    b.add_argument("--fmi", type=int, choices=(2, 3),
                   help="the FMI version of the FMU: 2 (FMI 2.0) or 3 (FMI 3.0); default: the scene's "
                        "[build] fmi, else 2")
    b.add_argument("--no-arrays", dest="arrays", action="store_const", const=False, default=None,
                   help="FMI 3: leave out the array outputs x_state and contact_force (for importers "
                        "that read no arrays; refused for an FMI 2 FMU); default: the scene's [build] arrays, else with them")
    b.set_defaults(func=cmd_build)
    s = sub.add_parser("simulate", help="simulate an FMU in Co-Simulation with fmpy")
    s.add_argument("fmu", help="FMU to simulate (.fmu, built by gyrowheel build)")
    s.add_argument("--stop-time", type=finite_float, metavar="SECONDS",
                   help="end time [s] (default: the FMU's DefaultExperiment stop time)")
    s.add_argument("--output-interval", type=finite_float, metavar="SECONDS",
                   help="time between result rows [s] (default: the FMU's DefaultExperiment step size)")
    s.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="start value or parameter, e.g. beta=1.4 or beta_deg=80 (repeatable)")
    s.add_argument("-o", "--output", help="CSV file to write (default: <fmu name>.csv)")
    s.add_argument("--plot", metavar="PNG", help="also plot the trajectory (needs gyrowheel[plot])")
    s.set_defaults(func=cmd_simulate)
    y = sub.add_parser("system", help="systems of FMUs (SSP 1.0)").add_subparsers(dest="system_command", required=True)
    yr = y.add_parser("run", help="run an .ssp with gyrowheel's master (fixed communication step, fmpy)")
    yr.add_argument("ssp", help="system to run (.ssp, SSP 1.0)")
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
    a = sub.add_parser("animate", help="animate a result CSV as .gif, .mp4 or an interactive .html "
                                       "(needs gyrowheel[animate])")
    add_animate_arguments(a)
    a.set_defaults(func=cmd_animate)
    i = sub.add_parser("info", help="describe an FMU")
    i.add_argument("fmu", help="FMU to describe (.fmu)")
    i.add_argument("--json", action="store_true", help="print the description as JSON")
    i.set_defaults(func=cmd_info)
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
    try:  # make_parser imports the subcommands' modules: a Ctrl-C there is exit 130 too
        parser = make_parser()
    except KeyboardInterrupt:
        return 130
    try:
        args = parser.parse_args(argv)
    except SystemExit:  # --help, --version, or argparse's one-line error
        try:
            sys.stdout.flush()
        except BrokenPipeError:  # `gyrowheel --help | head -1`
            _quiet_stdout()
        raise
    try:
        remove_stale()  # the temporary directories of killed gyrowheel processes (gyrowheel.scratch)
        code = args.func(args)
        sys.stdout.flush()  # here, where a reader gone away is seen (below), not at Python's exit
        return code
    except CliError as exc:
        print(f"gyrowheel: error: {exc}", file=sys.stderr)
        return exc.code
    except GyrowheelError as exc:  # a scene that cannot be read, an optional part not installed, ...
        print(f"gyrowheel: error: {command_line_text(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT if isinstance(exc, (ValueError, ImportError)) else EXIT_FAILURE
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # the reader went away (`gyrowheel info --json | head -2`): no error
        _quiet_stdout()
        return 0
    except OSError as exc:  # a file the command could not write or read: one line, never a traceback
        print(f"gyrowheel: error: {exc.filename or ''}{': ' if exc.filename else ''}{exc.strerror or exc}",
              file=sys.stderr)
        return EXIT_FAILURE


def _quiet_stdout() -> None:
    """Send what is left for stdout to /dev/null: its reader has gone, and Python would report
    the broken pipe again when it flushes stdout at exit."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # stdout is no file (captured): nothing to flush
        pass


if __name__ == "__main__":
    sys.exit(main())
