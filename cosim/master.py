"""gyrowheel's own co-simulation master on fmpy: fixed communication step, Jacobi exchange.

Like libcosim's fixed-step algorithm: every component steps from t to t + h with its inputs
held, then every connection copies the output to the input (Jacobi); before the first step,
in Initialization Mode, the connections are copied once (components with direct feedthrough
would need more; the Gyrover's controller has none). A component that ends the run
(fmi2Discard with fmi2Terminated, e.g. the wheel falling flat) stops the system there: the
last row is at its fmi2LastSuccessfulTime. The result holds every output of every component
as "<component>.<variable>", sampled at the communication points.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2Discard

from cosim.system import SystemDescription


class MasterError(RuntimeError):
    """A component refused a call; the message names the component and carries its log."""


@dataclass
class _Unit:
    name: str
    slave: FMU2Slave
    vars: dict
    outputs: list[str]


@dataclass
class RunResult:
    data: np.ndarray  # structured: time, <component>.<output>...
    stopped_by: str | None  # component that ended the run early, or None
    wall_time: float  # seconds spent in the stepping loop


def _set(unit: _Unit, name: str, value) -> None:
    v = unit.vars.get(name)
    if v is None:
        raise MasterError(f"{unit.name}: no variable {name!r}")
    if v.type == "Real":
        unit.slave.setReal([v.valueReference], [float(value)])
    elif v.type in ("Integer", "Enumeration"):
        unit.slave.setInteger([v.valueReference], [int(value)])
    elif v.type == "Boolean":
        unit.slave.setBoolean([v.valueReference], [bool(value)])
    else:
        raise MasterError(f"{unit.name}.{name}: type {v.type} not supported")


def run(system: SystemDescription, step: float, stop_time: float | None = None,
        start_values: dict[str, dict[str, float]] | None = None) -> RunResult:
    """Run the system with communication step `step` [s] to stop_time (default: the system's).

    start_values: {component: {variable: value}} on top of the system's own. Raises
    MasterError if a component fails (fmi2Error), ValueError for a bad step.
    """
    if not (step > 0 and math.isfinite(step)):
        raise ValueError(f"step must be a positive number of seconds, got {step!r}")
    t0 = system.start_time
    stop = system.stop_time if stop_time is None else stop_time
    if not stop > t0:
        raise ValueError(f"stop time {stop} must be after the start time {t0}")
    n_steps = int(round((stop - t0) / step))
    if abs(t0 + n_steps * step - stop) > 1e-9 * max(1.0, abs(stop)):
        raise ValueError(f"stop time {stop} is not a whole number of steps {step} from {t0}")
    units = []
    try:
        for c in system.components:
            md = read_model_description(str(c.fmu))
            unit = _Unit(c.name, None, {v.name: v for v in md.modelVariables},
                         [v.name for v in md.modelVariables if v.causality == "output"])
            unit.slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(c.fmu)),
                                   modelIdentifier=md.coSimulation.modelIdentifier, instanceName=c.name)
            unit.slave.instantiate(loggingOn=False)
            units.append(unit)
        by_name = {u.name: u for u in units}
        links = [(by_name[k.start_element], by_name[k.start_element].vars[k.start_connector].valueReference,
                  by_name[k.end_element], by_name[k.end_element].vars[k.end_connector].valueReference)
                 for k in system.connections]
        for c, u in zip(system.components, units):
            u.slave.setupExperiment(startTime=t0)
            for name, value in {**c.start_values, **(start_values or {}).get(c.name, {})}.items():
                _set(u, name, value)
            u.slave.enterInitializationMode()

        def exchange():
            for src, svr, dst, dvr in links:
                dst.slave.setReal([dvr], src.slave.getReal([svr]))

        exchange()
        for u in units:
            u.slave.exitInitializationMode()
        names = ["time"] + [f"{u.name}.{o}" for u in units for o in u.outputs]
        rows = []

        def record(t):
            row = [t]
            for u in units:
                for o in u.outputs:
                    v = u.vars[o]
                    if v.type == "Boolean":
                        row.append(float(u.slave.getBoolean([v.valueReference])[0]))
                    elif v.type in ("Integer", "Enumeration"):
                        row.append(float(u.slave.getInteger([v.valueReference])[0]))
                    else:
                        row.append(u.slave.getReal([v.valueReference])[0])
            rows.append(row)

        record(t0)
        stopped_by = None
        wall = _time.perf_counter()
        for k in range(n_steps):
            t = t0 + k * step
            for u in units:
                try:
                    u.slave.doStep(t, step)
                except FMICallException as exc:
                    if exc.status != fmi2Discard:
                        raise
                    stopped_by = u.name
            if stopped_by:
                t_end = by_name[stopped_by].slave.getRealStatus(2)  # fmi2LastSuccessfulTime
                record(t_end)
                break
            exchange()
            record(t0 + (k + 1) * step)
        wall = _time.perf_counter() - wall
        for u in units:
            u.slave.terminate()
        data = np.array([tuple(r) for r in rows], dtype=[(n, np.float64) for n in names])
        return RunResult(data, stopped_by, wall)
    except MasterError:
        raise
    except Exception as exc:  # fmpy raises FMICallException (fmi2Error) and plain Exceptions
        raise MasterError(f"{exc} (run again with the FMU's logging categories on to see its reason)") from None
    finally:
        for u in units:
            try:
                u.slave.freeInstance()
            except Exception:
                pass
