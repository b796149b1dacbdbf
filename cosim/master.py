"""gyrowheel's own co-simulation master on fmpy: fixed communication step, Jacobi exchange.

Every component steps from t to t + h with its inputs held, then the connections carry the
outputs to the inputs, in the levels of gyrowheel.cosim.exchange.exchange_levels: within a level
every output is read before any input is set (Jacobi: the file's order of the connections does
not matter); an output with direct feedthrough (ModelStructure dependencies, FMI 2.0.4 section
2.2.8) is read in a later level than the connections setting the inputs it depends on, so a
chain of pass-through components carries the value of the communication point through, and an
algebraic loop is refused before the run (cosim/exchange.py). A connection's linear
transformation (SSP 1.0 ssc:LinearTransformation) is applied to the value it carries. In
Initialization Mode the exchange is repeated until a pass sets the values the previous one set
(consistent initial values); if they keep changing the run is refused, naming the connections.
Components may be FMI 2.0 and FMI 3.0 Co-Simulation FMUs side by side (cosim/units.py). A
component that ends the run (FMI 2.0: fmi2Discard with fmi2Terminated; FMI 3.0: fmi3DoStep's
terminateSimulation; e.g. the wheel falling flat) stops the system there: the last row is at its
last successful time (fmi2LastSuccessfulTime, fmi3DoStep's lastSuccessfulTime). The result holds
every output of every component as "<component>.<variable>", sampled at the communication points.
"""
from __future__ import annotations

import math
import re
import shutil
import time as _time
from dataclasses import dataclass
from functools import partial

import numpy as np
from fmpy import read_model_description

from gyrowheel.arguments import check_memory
from gyrowheel.arguments import count as count_text
from gyrowheel.errors import GyrowheelError
from gyrowheel.cosim.exchange import exchange, settle
from gyrowheel.cosim.system import SystemDescription, SystemFileError, describe
from gyrowheel.cosim.ssp import coerce_value
from gyrowheel.cosim.units import Unit, kind_of, new_unit, scalar_outputs

NUMERIC = ("Real", "Integer", "Boolean")  # recorded as numbers; String and Binary outputs as NaN


class MasterError(GyrowheelError, RuntimeError):
    """A component refused a call; the message names the component and carries its log."""


class StartValueRefusedError(MasterError):
    """A component refused its start values before the run began (a value out of its range, a
    combination its model cannot take): bad input, not a failure of the run. The message names
    the component, the FMU's reason and the values it names: `wheel refused the start values: M
    (mass) must be > 0 (wheel.M = -1)`. given: whether one of the values it names (or, naming
    none, one of the component's) came from run()'s start_values rather than the system's
    bindings."""

    def __init__(self, message: str, given: bool):
        super().__init__(message)
        self.given = given


def _refused_start_values(units: list[Unit], applied: dict[str, dict], given: dict[str, dict]):
    """The StartValueRefusedError of the first unit that logged an error while its start values
    were set and the system initialised (before the first step: a value out of range, an output
    that is not finite with them), its reasons once each without the calls' names; else None."""
    for u in units:
        reasons = [m.split(":", 1)[1].strip() if re.match(r"fmi[23]\w+:", m) else m for m in u.messages]
        reason = "; ".join(dict.fromkeys(reasons))
        if not reason:
            continue
        values = applied.get(u.name, {})
        named = [n for n in values if re.search(rf"(?<![\w.]){re.escape(n)}\b", reason)]
        shown = "".join(f" ({u.name}.{n} = {values[n]!r})" for n in named)
        user = given.get(u.name, {})
        return StartValueRefusedError(f"{u.name} refused the start values: {reason}{shown}",
                                      any(n in user for n in named) if named else bool(user))
    return None


@dataclass
class RunResult:
    data: np.ndarray  # structured: time, <component>.<output>...
    stopped_by: str | None  # component that ended the run early, or None
    wall_time: float  # seconds spent in the stepping loop


def _set(unit: Unit, name: str, value) -> None:
    v = unit.vars.get(name)
    if v is None:
        raise MasterError(f"{unit.name}: no variable {name!r}")
    try:  # the bindings' checks: 1.5 for an Integer is refused, not truncated; "false" is false
        value = coerce_value(v, value, f"{unit.name}.{name}")
    except SystemFileError as exc:
        raise MasterError(str(exc)) from None
    unit.put(v.valueReference, v.type, value)


def run(system: SystemDescription, step: float, stop_time: float | None = None,
        start_values: dict[str, dict[str, float]] | None = None) -> RunResult:
    """Run the system with communication step `step` [s] to stop_time (default: the system's).

    start_values: {component: {variable: value}} on top of the system's own. Raises
    MasterError if a component fails (fmi2Error, fmi3Error; the message carries the FMU's logged reason),
    ValueError for a bad step or stop time, ArgumentError (a ValueError, naming stop_time) for a
    result that would take more than half of this machine's memory
    (gyrowheel.arguments.check_memory), SystemFileError (a ValueError) for a system whose
    connections do not fit its FMUs or that holds an algebraic loop, MasterError for initial
    values that do not settle.
    """
    if not (step > 0 and math.isfinite(step)):
        raise ValueError(f"step must be a positive number of seconds, got {step!r}")
    t0 = system.start_time
    stop = system.stop_time if stop_time is None else stop_time
    if not math.isfinite(stop):
        raise ValueError(f"stop time must be a finite number of seconds, got {stop!r}")
    if not stop > t0:
        raise ValueError(f"stop time {stop:g} must be after the start time {t0:g}")
    steps = (stop - t0) / step
    n_steps = int(round(steps))
    if n_steps < 1 or abs(n_steps - steps) > 1e-9 * max(1.0, steps):
        below, above = t0 + math.floor(steps) * step, t0 + math.ceil(steps) * step
        near = f"{below:.12g} or {above:.12g}" if math.floor(steps) >= 1 else f"{above:.12g}"
        raise ValueError(f"stop time {stop:.12g} is not a whole number (>= 1) of steps {step:g} from {t0:g}: "
                         f"stop at {near}, or choose a step that divides {stop - t0:.12g} s")
    levels = system.check()
    columns = 1 + sum(len(scalar_outputs(read_model_description(str(c.fmu)))) for c in system.components)
    # the result: every point in one float64 array, copied once at the end (data[:count].copy())
    check_memory((n_steps + 1) * columns, 16, f"stop_time {stop:g} s with step {step:g} s: "
                 f"{count_text(n_steps + 1)} communication points of {columns} columns",
                 "choose a shorter stop_time or a longer step", argument="stop_time")
    units = []
    applied: dict[str, dict] = {}  # the start values set, by component; cleared once the run begins
    try:
        for c in system.components:
            unit = new_unit(c.name, read_model_description(str(c.fmu)))
            units.append(unit)
            unit.unpack(c.fmu)
            unit.instantiate()
        by_name = {u.name: u for u in units}
        links = []
        for k in system.connections:
            src, dst = by_name[k.start_element], by_name[k.end_element]
            sv, dv = src.vars[k.start_connector], dst.vars[k.end_connector]
            links.append((partial(src.get, sv.valueReference, sv.type), partial(dst.put, dv.valueReference, dv.type),
                          (k.factor, k.offset) if k.transformed else None))
        for c, u in zip(system.components, units):
            u.before_start_values(t0)
            applied[c.name] = {**c.start_values, **(start_values or {}).get(c.name, {})}
            for name, value in applied[c.name].items():
                _set(u, name, value)
            u.enter_initialization(t0)

        moving = settle(levels, links)  # system.check(): both ends of a connection have one type
        if moving:
            raise MasterError(f"system {system.name!r}: the initial values are not consistent: after "
                              f"{len(links) + 2} exchanges in Initialization Mode "
                              + ", ".join(describe(system.connections[i]) for i in moving) + " still change")
        for u in units:
            u.slave.exitInitializationMode()
        applied = {}
        names = ["time"] + [f"{u.name}.{o}" for u in units for o in u.outputs]
        data = np.zeros(n_steps + 1, dtype=[(n, np.float64) for n in names])  # every point, filled as it runs
        count = 0

        def record(t):
            nonlocal count
            row = [t]
            for u in units:
                for o in u.outputs:
                    v = u.vars[o]
                    row.append(float(u.get(v.valueReference, v.type)) if kind_of(v.type) in NUMERIC else math.nan)
            data[count] = tuple(row)
            count += 1

        record(t0)
        stopped_by = t_end = None
        wall = _time.perf_counter()
        for k in range(n_steps):
            t = t0 + k * step
            for u in units:
                ended = u.do_step(t, step)
                if ended is not None and stopped_by is None:
                    stopped_by, t_end = u.name, ended
            if stopped_by:
                record(t_end)
                break
            exchange(levels, links)
            record(t0 + (k + 1) * step)
        wall = _time.perf_counter() - wall
        for u in units:
            u.slave.terminate()
        return RunResult(data[:count].copy(), stopped_by, wall)
    except MasterError:
        raise
    except Exception as exc:  # fmpy raises FMICallException (fmi2Error, fmi3Error) and plain Exceptions
        refused = _refused_start_values(units, applied, start_values or {}) if applied else None
        if refused is not None:
            raise refused from None
        logged = "; ".join(f"{u.name}: {m}" for u in units for m in u.messages)
        raise MasterError(f"{logged} ({exc})" if logged else str(exc)) from None
    finally:
        for u in units:
            u.free()
            if u.unzipdir:
                shutil.rmtree(u.unzipdir, ignore_errors=True)
