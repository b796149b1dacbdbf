"""Run an FMU (FMI 2.0 or 3.0) with fmpy in Co-Simulation, with start values checked by name
and type."""
from __future__ import annotations

import ctypes
import math
import os
import re
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from ctypes import byref

import numpy as np
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, printLogMessage

from gyrowheel.arguments import missing_item_hint
from gyrowheel.errors import FmuError, GyrowheelError
from gyrowheel.fmi_types import out_of_range, whole_number
from gyrowheel.scratch import temporary_directory

# fmpy 0.3.32 forwards every FMU message through ONE process-global logger (the last one given
# to fmpy.logging.addLoggerProxy). simulate_fmu(logger=...) proxies a callback that dies when it
# returns; the next FMU instantiated with fmpy's default callbacks would then call freed memory
# as soon as it logs (this FMU logs the reason of every non-OK status, e.g. the fall's
# fmi2Discard). restore_fmpy_logger points the proxy back at a printer that lives as long as the
# process; call it after any simulate_fmu(logger=...).
_PRINTER = fmi2CallbackLoggerTYPE(printLogMessage)


def restore_fmpy_logger() -> None:
    """Point fmpy's global logger proxy at a process-lived printer (see above)."""
    from fmpy.logging import addLoggerProxy
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = _PRINTER
    addLoggerProxy(byref(callbacks))


REAL_TYPES = ("Real", "Float64")  # a gyrowheel FMU's real variables: FMI 2.0, FMI 3.0
INTEGER_TYPES = ("Integer", "Int32")


class SimulationError(GyrowheelError, RuntimeError):
    """The FMU refused a value or failed; the message carries the FMU's logged reason."""


class FmuWarning(UserWarning):
    """A warning the FMU logged with status warning whatever its logging categories (e.g. a
    fixed-step solver chosen for a model it serves badly, c_src/gw_simulation.c): run() issues
    each once (warnings.warn), `gyrowheel simulate` prints it as `gyrowheel: warning: ...`."""


class UnknownVariableError(SimulationError):
    """A start value names no variable of the FMU; gyrowheel.simulate and system_run raise it as
    an UnknownArgumentNameError (an ArgumentError and an UnknownNameError) naming start_values."""


class StartValueError(SimulationError):
    """The FMU refused the start values before the run began: a value set (fmi2SetReal, ...) or
    the checks of initialisation (fmi2ExitInitializationMode: a parameter out of its range, a
    combination the model cannot take). Bad input, not a failure of the run: gyrowheel.simulate
    raises it as an ArgumentError naming start_values (`gyrowheel simulate` exits 2)."""


# the calls of FMI 2.0 and 3.0 before the first step: an error logged by one of them is a value
# the FMU refused (its message begins with the call's name, c_src/gw_simulation.c)
BEFORE_THE_RUN = ("fmi2SetReal", "fmi2SetInteger", "fmi2SetBoolean", "fmi2SetString", "fmi2SetupExperiment",
                  "fmi2EnterInitializationMode", "fmi2ExitInitializationMode", "fmi3SetFloat64", "fmi3SetInt32",
                  "fmi3SetBoolean", "fmi3SetString", "fmi3EnterInitializationMode", "fmi3ExitInitializationMode")


def refusal(errors: list[str]) -> tuple[str, bool]:
    """The FMU's logged errors as one line, each reason once (in the order logged), and whether
    every one was logged before the run began (BEFORE_THE_RUN: the start values refused), in
    which case the calls' names are left out: `restitution must be <= 1`."""
    unique = list(dict.fromkeys(errors))
    before = bool(unique) and all(m.split(":", 1)[0] in BEFORE_THE_RUN for m in unique)
    if before:
        unique = list(dict.fromkeys(m.split(":", 1)[1].strip() for m in unique))
    return "; ".join(unique), before


def with_values(reason: str, md, given: dict[str, object]) -> str:
    """reason (the FMU's refusal of the start values) with each variable it names, at its first
    mention, followed by the value the FMU had and where that came from: `mu_k (0.3, the FMU's
    start value) must be <= mu (0, given)`. md: fmpy's model description; given: the start values
    set (by name, checked). Only a refused combination (two or more variables named in the rule,
    before its first bracketed explanation) is annotated: a single value's refusal names its
    variable already."""
    rule, bracket, why = reason.partition(" (")
    by_name = {v.name: v for v in md.modelVariables if v.start is not None}
    names = sorted(by_name, key=len, reverse=True)  # mu_k before mu
    mention = {name: re.compile(rf"(?<![\w.(]){re.escape(name)}(?![\w(=])") for name in names}
    if sum(bool(mention[name].search(rule)) for name in names) < 2:
        return reason
    for name in names:
        if name in given:
            told = f"{_as_text(given[name]).removesuffix('.0')}, given"
        else:
            told = f"{by_name[name].start}, the FMU's start value"
        rule = mention[name].sub(f"{name} ({told})", rule, count=1)
    return rule + bracket + why


EVENT_LOGGED = re.compile(r"(?:warning: )?event (\w+) at t=([-+0-9.eE]+)")
# a warning event whose condition holds at initialisation: flagged at the start time
EVENT_AT_START = re.compile(r"warning: event (\w+) holds already at the start t=([-+0-9.eE]+)")
# FMI 3.0's layer puts the name of the call before every message of the simulation core
# (c_src/gw_fmi3_common.c, gw_fmi3_logger: `fmi3DoStep: event fall at t=T: ...`); FMI 2.0's
# layer passes them on as they are (`event fall at t=T: ...`)
FMI3_CALL = re.compile(r"fmi3\w+: ")


def core_message(text: str) -> str:
    """An event's logged message (EVENT_LOGGED, EVENT_AT_START) without the name of the FMI 3.0
    call that logged it, as FMI 2.0 logs it: `fmi3DoStep: event fall at t=T: ...` -> `event
    fall at t=T: ...`; any other message unchanged."""
    call = FMI3_CALL.match(text)
    if call and (EVENT_LOGGED.match(text, call.end()) or EVENT_AT_START.match(text, call.end())):
        return text[call.end():]
    return text


@dataclass
class Messages:
    """Collects the FMU's log messages: the logger callback of FMI 2.0 (component,
    instanceName, status, category, message) and FMI 3.0 (instanceEnvironment, status, category,
    message); both end with status, category, message, and number the statuses alike. An
    event's message is kept as FMI 2.0 words it (core_message), so that an FMU of either
    version reports the same events and warnings."""

    lines: list[tuple[int, str]] = field(default_factory=list)

    def __call__(self, *arguments):
        status, _, message = arguments[-3:]
        text = core_message(message.decode(errors="replace") if isinstance(message, bytes) else str(message))
        if int(status) == 0 and not EVENT_LOGGED.match(text):  # a step's log (logSolver): not kept
            return
        self.lines.append((int(status), text))

    def errors(self) -> list[str]:
        return [m for s, m in self.lines if s >= 3]  # fmi2Error / fmi3Error, fmi2Fatal / fmi3Fatal

    def events(self) -> list[tuple[str, float]]:
        """(event name, t [s]) of each event logged (category logEvents, c_src/gw_events.c:
        `event NAME at t=T: ...`, `warning: event NAME at t=T`; a warning event holding at the
        start, `... holds already at the start t=T`), in the order logged."""
        return [(m.group(1), float(m.group(2))) for _, line in self.lines
                for m in [EVENT_LOGGED.match(line) or EVENT_AT_START.match(line)] if m]

    def warnings(self) -> list[str]:
        """The messages logged with status warning (fmi2Warning, fmi3Warning), each once, without
        the FMU's own `warning: ` prefix; a warning event (`warning: event NAME at t=T`, an
        event the scene set to warn, logged each time it fires) as one message per event:
        `event NAME at t = T s`, or `event NAME: N times, t = T1 .. Tn s` (fired_events), the words
        of the CLI's events summary; a warning event that holds already at the start and fires no
        more, `event NAME holds already at the start t=T` as logged, and one that fires later too
        is counted from the start time."""
        plain: list[str] = []
        fired: list[tuple[str, float]] = []
        at_start: dict[str, str] = {}  # name -> the message of an event holding at the start
        for s, m in self.lines:
            if s != 1:
                continue
            start = EVENT_AT_START.fullmatch(m)
            event = start or EVENT_LOGGED.fullmatch(m)
            if event:
                fired.append((event.group(1), float(event.group(2))))
                if start:
                    at_start[event.group(1)] = m.removeprefix("warning: ")
            else:
                plain.append(m.removeprefix("warning: "))
        counts = Counter(name for name, _ in fired)  # in the order of first firing, fired_events' order
        return list(dict.fromkeys(plain)) + [
            at_start[name] if name in at_start and counts[name] == 1 else f"event {phrase}"
            for name, phrase in zip(counts, fired_events(fired))]


def fired_events(events: list[tuple[str, float]]) -> list[str]:
    """Each event of `events` ((name, t [s]) in firing order) once, in the order of its first
    firing: `NAME at t = T s` if it fired once, `NAME: N times, t = T1 .. Tn s` (its first and
    last time) otherwise; the words of Messages.warnings and of the CLI's events summary."""
    times: dict[str, list[float]] = {}
    for name, t in events:
        times.setdefault(name, []).append(t)
    return [f"{name} at t = {ts[0]:.6g} s" if len(ts) == 1 else f"{name}: {len(ts)} times, t = {ts[0]:.6g} .. {ts[-1]:.6g} s"
            for name, ts in times.items()]


def coerce_start_values(fmu: str | Path, assignments: dict[str, str]) -> dict[str, object]:
    """NAME=VALUE strings -> typed start values; unknown names and bad types raise.

    An Integer takes a whole number in any notation ('12', '1e3'; 1.5 is refused, not
    truncated); one outside its type's 32 bits is refused naming the variable's range (`value
    '1e10' for 'max_internal_steps' is out of range [1, 2147483647] (Integer)`), one inside
    them left to the FMU's own checks. Raises SimulationError (UnknownVariableError for an
    unknown name) naming the variable."""
    md = read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    enums = {t.name: {i.name: int(i.value) for i in t.items} for t in md.typeDefinitions}
    out: dict[str, object] = {}
    for given, text in assignments.items():
        name, degrees = _angle_name(given, by_name)
        v = by_name.get(name)
        if v is None:
            raise UnknownVariableError(f"unknown variable {name!r}; settable: "
                                  + ", ".join(sorted(n for n, w in by_name.items() if _settable(w)))
                                  + " (angles also as NAME_deg)")
        if name in out:
            raise SimulationError(f"{name!r} given twice (as {name} and {name}_deg)")
        if not _settable(v):
            raise SimulationError(f"variable {name!r} is a calculated {v.causality} and cannot be set")
        try:
            if v.type in REAL_TYPES:
                out[name] = float(text)
                if not math.isfinite(out[name]):
                    raise SimulationError(f"value {text!r} for {given!r} is not finite")
                if degrees:
                    out[name] = math.radians(out[name])
            elif v.type in INTEGER_TYPES:
                out[name] = whole_number(text)
                outside = out_of_range(v, out[name])  # an fmi2Integer, fmi3Int32: 32 bits; fmpy would wrap it
                if outside:
                    raise SimulationError(f"value {text!r} for {given!r} is {outside}")
            elif v.type == "Enumeration":
                items = enums.get(v.declaredType.name if v.declaredType else "", {})
                out[name] = items[text] if text in items else int(text)
                if out[name] not in items.values():
                    raise ValueError
            elif v.type == "Boolean":
                if text.lower() not in ("true", "false", "1", "0"):
                    raise ValueError
                out[name] = text.lower() in ("true", "1")
            else:
                out[name] = text
            if degrees and v.type not in REAL_TYPES:
                raise ValueError
        except ValueError:
            choices = ""
            if v.type == "Enumeration":
                choices = "; valid: " + ", ".join(enums.get(v.declaredType.name, {})) + missing_item_hint(name, text)
            raise SimulationError(f"value {text!r} for {given!r} is not a valid {v.type}{choices}") from None
    return out


def _angle_name(name: str, by_name: dict) -> tuple[str, bool]:
    """(the variable, whether the value is in degrees): NAME_deg names the angle NAME (unit rad)
    in degrees, as scenes and sweeps take it (beta_deg = 80)."""
    if name not in by_name and name.endswith("_deg"):
        base = by_name.get(name[:-4])
        if base is not None and (base.unit or (base.declaredType.unit if base.declaredType else None)) == "rad":
            return base.name, True
    return name, False


def check_start_values(fmu: str | Path, values: dict[str, object]) -> dict[str, object]:
    """Start values given as strings (NAME=VALUE text) or Python values -> typed values, checked
    as coerce_start_values checks them; a Python value is read as its exact text (1.5 for an
    Integer is refused, not truncated). Raises SimulationError naming the variable."""
    return coerce_start_values(fmu, {k: v if isinstance(v, str) else _as_text(v) for k, v in values.items()})


def write_csv(result: np.ndarray, path: str | Path) -> Path:
    """Write a structured result (fmpy's, or a system run's) as CSV with a header row; Booleans
    as 0/1, so that the file reads back as numbers (fmpy.util.read_csv, numpy). Returns the path."""
    from fmpy.util import write_csv as fmpy_write_csv
    dtype = [(n, "i1" if result.dtype[n] == np.bool_ else result.dtype[n]) for n in result.dtype.names]
    fmpy_write_csv(str(path), result.astype(dtype))
    return Path(path)


def _as_text(value: object) -> str:
    """A Python start value as the text coerce_start_values reads: floats by repr (exact round
    trip), so 1.5 given for an Integer is refused instead of truncated by int()."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)


def _settable(v) -> bool:
    return v.causality in ("parameter", "input") or v.initial in ("exact", "approx")


def _grid_rows(result: np.ndarray, start: float, interval: float) -> np.ndarray:
    """The rows of an FMI 3.0 run at the communication points, as an FMI 2.0 run records them:
    fmpy also records a row where the FMU returned early (at an event inside a step, e.g. each
    touchdown of a bouncing wheel; FMI 3.0, section 4.2.4) and then goes on to the next point of
    its grid, start + k interval (fmpy.simulation.simulateCS).  Those rows are dropped; the first
    and the last (a fall's, at its located time, or the stop time) are kept.  (n,) -> (m,), m <= n."""
    t = result["time"]
    keep = start + np.round((t - start) / interval) * interval == t  # fmpy's float operations, bit for bit
    keep[0] = keep[-1] = True
    return result[keep]


def run(fmu: str | Path, stop_time: float | None = None, output_interval: float | None = None,
        start_values: dict[str, object] | None = None, solver_tolerance: float | None = None,
        messages: Messages | None = None, events: list | None = None, stacklevel: int = 2) -> np.ndarray:
    """Simulate in Co-Simulation; returns fmpy's structured result array of the scalar outputs,
    one row per communication point (and a fall's at its located time) from an FMI 2.0 and an
    FMI 3.0 FMU alike (_grid_rows).

    start_values are checked by name and type like `gyrowheel simulate --set` (strings or Python
    values: 1.5 for an Integer is refused, not truncated); stop_time, output_interval and
    solver_tolerance must be numbers. Raises SimulationError naming the value, or with the FMU's
    logged reason. events: a list to which the events the FMU reported (logEvents: its debug
    log, switched on for this) are appended as (event name, t [s]), in the order they fired.
    The FMU's warnings are FmuWarnings attributed to the caller `stacklevel` frames up (2: the
    caller of run; gyrowheel.simulate passes 3, its own caller), so that Python's warning
    filter keeps one per line of the user's code, not one per process."""
    messages = messages or Messages()
    for what, value in (("stop_time", stop_time), ("output_interval", output_interval),
                        ("solver_tolerance", solver_tolerance)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float, np.number))):
            raise SimulationError(f"{what} must be a number, got {type(value).__name__} {value!r}")
    if start_values:
        start_values = check_start_values(fmu, start_values)
    md = read_model_description(str(fmu))
    if output_interval is None:  # fmpy would pick its own; the scene's interval is what users expect
        exp = md.defaultExperiment
        output_interval = float(exp.stepSize) if exp is not None and exp.stepSize else None
    # an FMI 3 FMU's array outputs (x_state, contact_force) repeat scalar outputs: the scalars are
    # recorded, one column each, as from the FMI 2 FMU
    scalars = [v.name for v in md.modelVariables if v.causality == "output" and not v.dimensions]
    recorded = scalars if len(scalars) < sum(v.causality == "output" for v in md.modelVariables) else None
    cwd = os.getcwd()
    # fmpy unpacks into a directory it removes only when the run succeeds; unpacked here, it is
    # removed however the run ends (the FMU refusing, a binary that does not load, Ctrl-C)
    with temporary_directory("run") as where:
        tmp = str(where)
        try:
            unpacked = str(fmu) if Path(fmu).is_dir() else str(extract(str(fmu), unzipdir=tmp, include=_read_by_a_run))
            _load_binary(fmu, unpacked, md)
            # FMI 3: early return allowed, so that a fall inside a step ends the result at its
            # lastSuccessfulTime (fmpy reads it only after an early return), as FMI 2's does
            early = {"early_return_allowed": True} if md.fmiVersion.startswith("3") else {}
            result = simulate_fmu(unpacked, fmi_type="CoSimulation", stop_time=stop_time,
                                  output_interval=output_interval, start_values=start_values or {},
                                  output=recorded, relative_tolerance=solver_tolerance, logger=messages,
                                  debug_logging=events is not None, **early)
            if events is not None:
                events.extend(messages.events())
            for text in messages.warnings():
                warnings.warn(text, FmuWarning, stacklevel=stacklevel)
            if early and output_interval:
                exp = md.defaultExperiment
                start = float(exp.startTime) if exp is not None and exp.startTime is not None else 0.0
                result = _grid_rows(result, start, float(output_interval))
            return result
        except FMICallException as exc:
            reason, before = refusal(messages.errors())
            if before:
                reason = with_values(reason, md, start_values or {})
                raise StartValueError(f"the FMU refused the start values: {reason}") from None
            raise SimulationError(f"the FMU reported an error: {reason or exc}{_underflow_note(reason)}") from None
        except GyrowheelError:
            raise
        except Exception as exc:  # fmpy's own failures are plain Exceptions: one line, the FMU named
            text = " ".join(str(exc).replace(tmp + os.sep, "").split()) or type(exc).__name__
            raise SimulationError(f"{fmu}: fmpy could not run the FMU ({type(exc).__name__}: {text})") from None
        finally:
            os.chdir(cwd)  # fmpy changes into the binary's directory to load it, and stays on failure
            restore_fmpy_logger()


# what "step size underflow" means for a user: the runtime's solvers stop at their step-size floor;
# an explicit one (every solver but rosenbrock) where rosenbrock, implicit and L-stable, may go on
UNDERFLOW_NOTE = ("; the model's fastest time scale is shorter than the solver's smallest step, 16 eps max(|t|, 1) s: "
                  "values that make it this stiff (e.g. strong damping on a light wheel) cannot be integrated "
                  "(docs/interface.md, \"Valid ranges\")")
EXPLICIT_NOTE = ("; the model's fastest time scale is shorter than the solver's smallest step, 16 eps max(|t|, 1) s: "
                 "an explicit solver cannot follow values this stiff (e.g. strong damping on a light wheel); "
                 "solver rosenbrock (implicit, L-stable) may (docs/interface.md, \"Valid ranges\")")


# the same for solver taylor, whose series overflows first (its reason names the time scale)
STIFF_NOTE = ("; values this stiff (e.g. strong damping on a light wheel) need an implicit solver: solver "
              "rosenbrock (L-stable) may integrate them (docs/interface.md, \"Valid ranges\")")


def _underflow_note(reason: str) -> str:
    """What the FMU's reason means for a user: a step size underflow of rosenbrock (UNDERFLOW_NOTE)
    or of an explicit solver (EXPLICIT_NOTE: try rosenbrock), solver taylor's time scale below the
    smallest step (STIFF_NOTE), else ''."""
    if "step size underflow" in reason:
        return UNDERFLOW_NOTE if "solver rosenbrock" in reason else EXPLICIT_NOTE
    return STIFF_NOTE if "too stiff for an explicit method" in reason else ""


def _read_by_a_run(name: str) -> bool:
    """The members of an FMU a run reads (fmpy's choice): its description, binaries, resources."""
    return name == "modelDescription.xml" or name.startswith(("binaries/", "resources/"))


def _load_binary(fmu: str | Path, unpacked: str, md) -> None:
    """Load the FMU's binary for this platform (description.binary_path: FMI 2.0.4, section
    2.3, binaries/linux64/<modelIdentifier>.so; FMI 3.0.2, section 2.5.1.4.1,
    binaries/x86_64-linux/...) as fmpy will, to say in one line why it cannot be: FmuError
    `x.fmu: its binary binaries/linux64/m.so cannot be loaded: file too short`."""
    from gyrowheel.description import binary_path

    if md.coSimulation is None:
        raise FmuError(f"{fmu}: the FMU does not support Co-Simulation", argument="fmu")
    relative = binary_path(md)
    library = os.path.join(unpacked, *relative.split("/"))
    if not os.path.isfile(library):
        raise FmuError(f"{fmu}: no binary for {relative.split('/')[1]} ({relative})", argument="fmu")
    try:
        ctypes.CDLL(library)
    except OSError as exc:
        reason = str(exc).replace(library + ": ", "").replace(library, relative)
        raise FmuError(f"{fmu}: its binary {relative} cannot be loaded: {reason}", argument="fmu") from None
