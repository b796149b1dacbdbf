"""Drive an FMI 3.0 FMU through fmpy's low-level FMU3Slave / FMU3Model, capturing its log messages.

FMI 3.0 passes the logger to fmi3Instantiate* (no process-global proxy as fmpy's FMI 2.0 path
has): each instance keeps its own ctypes callback (fmpy holds it on the FMU object) and its own
message list.  Values are accessed by name with the getter/setter of the variable's FMI 3.0 type
(Float64, Int32, Enumeration as Int64, Boolean).
"""
from __future__ import annotations

import ctypes
import re
from pathlib import Path

from fmpy.fmi3 import FMU3Model, FMU3Slave

from fmi_helpers import StateVector, unpack

EVENT = re.compile(r"event (\w+) at t=(\S+?):? ")


def event_times(messages: list[str]) -> list[tuple[str, float]]:
    """The events an FMU logged in category logEvents ("event NAME at t=%.17g..."), in order: the
    17 digits give the located time exactly."""
    return [(m.group(1), float(m.group(2))) for line in messages for m in [EVENT.search(line + " ")] if m]


class Instance3(StateVector):
    """One FMI 3.0 instance (Co-Simulation or Model Exchange) with named access to its variables
    (and, in Model Exchange, numpy access to its state vector: StateVector)."""

    get_derivatives = "getContinuousStateDerivatives"

    def __init__(self, fmu: str | Path, interface: str = "CoSimulation", name: str = "wheel",
                 logging_on: bool = True, event_mode_used: bool = False, early_return_allowed: bool = False,
                 unzipdir: str | Path | None = None, md=None):
        unpack(self, fmu, unzipdir, md)
        messages = self.messages  # the callback must not keep the instance alive

        def logger(env, status, category, message):
            messages.append((int(status), (category or b"").decode(), (message or b"").decode()))
        cs = interface == "CoSimulation"
        iface = self.md.coSimulation if cs else self.md.modelExchange
        cls = FMU3Slave if cs else FMU3Model
        self.fmu3 = cls(guid=self.md.guid, unzipDirectory=self.unzipdir, modelIdentifier=iface.modelIdentifier,
                        instanceName=name)
        if cs:
            self.fmu3.instantiate(loggingOn=logging_on, eventModeUsed=event_mode_used,
                                  earlyReturnAllowed=early_return_allowed, logMessage=logger)
        else:
            self.fmu3.instantiate(loggingOn=logging_on, logMessage=logger)
        self.me = self.fmu3
        self.nx = self.md.numberOfContinuousStates
        self.nz = self.md.numberOfEventIndicators

    # ---- values by name
    def vr(self, name: str) -> int:
        return self.vars[name].valueReference

    def _access(self, v, what: str):
        kind = {"Float64": "Float64", "Int32": "Int32", "Enumeration": "Int64", "Int64": "Int64",
                "Boolean": "Boolean"}[v.type]
        return getattr(self.fmu3, f"{what}{kind}")

    def set(self, **values) -> None:
        for name, value in values.items():
            v = self.vars[name]
            cast = {"Float64": float, "Boolean": bool}.get(v.type, int)
            self._access(v, "set")([v.valueReference], [cast(value)])

    def get(self, *names: str):
        out = []
        for name in names:
            v = self.vars[name]
            value = self._access(v, "get")([v.valueReference])[0]
            out.append(bool(value) if v.type == "Boolean" else value)
        return out[0] if len(out) == 1 else out

    def raw(self, function: str, *args) -> int:
        """Call an fmi3 function of the shared library directly (fmpy's wrappers raise on a
        status above fmi3Warning), the instance first; returns the fmi3Status."""
        f = getattr(self.fmu3.dll, function)
        f.restype = ctypes.c_int
        return f(ctypes.c_void_p(self.fmu3.component), *args)

    def log(self) -> list[str]:
        return [m for _, _, m in self.messages]

    def log_text(self) -> str:
        return "\n".join(self.log())

    # ---- life cycle
    def init(self, start_time: float = 0.0, tolerance: float | None = None, stop_time: float | None = None,
             **values) -> None:
        """Initialization Mode with the values set, then out of it (CS: Step Mode or, with
        eventModeUsed, Event Mode; ME: Event Mode)."""
        self.set(**values)
        self.fmu3.enterInitializationMode(tolerance=tolerance, startTime=start_time, stopTime=stop_time)
        self.fmu3.exitInitializationMode()

    def free(self) -> None:
        self.fmu3.freeInstance()

    def do_step(self, t: float, h: float, no_set_prior: bool = True):
        """fmi3DoStep through the raw function: (status, eventHandlingNeeded, terminateSimulation,
        earlyReturn, lastSuccessfulTime)."""
        flags = [ctypes.c_bool() for _ in range(3)]
        last = ctypes.c_double()
        st = self.raw("fmi3DoStep", ctypes.c_double(t), ctypes.c_double(h), ctypes.c_bool(no_set_prior),
                      *[ctypes.byref(f) for f in flags], ctypes.byref(last))
        return (st, *[f.value for f in flags], last.value)
