"""Drive an FMI 3.0 FMU through fmpy's FMU3Slave / FMU3Model, capturing its log messages, and call
any fmi3 function of it with well-formed arguments.

FMI 3.0 passes the logger to fmi3Instantiate* itself (no process-global proxy as fmpy has for FMI
2.0): each instance logs through a callback of its own (fmpy holds it on the FMU object) into its
own message list.  Values are accessed by name with the getter/setter of the variable's FMI 3.0 type
(Float64, Int32, Enumeration as Int64, Boolean).
"""
from __future__ import annotations

import ctypes as C
import re
from pathlib import Path

import numpy as np
from fmpy.fmi3 import FMU3Model, FMU3Slave

from fmi_helpers import StateVector, unpack

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
B = C.c_bool  # fmi3Boolean
EVENT = re.compile(r"event (\w+) at t=(\S+?):? ")


def event_times(messages: list[str]) -> list[tuple[str, float]]:
    """The events an FMU logged in category logEvents ("event NAME at t=%.17g..."), in order: the
    17 digits give the located time exactly."""
    return [(m.group(1), float(m.group(2))) for line in messages for m in [EVENT.search(line + " ")] if m]


class Instance3(StateVector):
    """One FMI 3 instance, iface "CS" (Co-Simulation) or "ME" (Model Exchange), with named access to
    its variables (and, in Model Exchange, numpy access to its state vector: StateVector);
    raw(fn, ...) calls any fmi3 function of the library with fmpy's argument types and returns the
    fmi3Status (fmpy's wrappers raise above fmi3Warning)."""

    get_derivatives = "getContinuousStateDerivatives"

    def __init__(self, fmu: str | Path, iface: str = "CS", unzipdir=None, md=None, name: str = "wheel",
                 logging_on: bool = True, event_mode_used: bool = False, early_return_allowed: bool = False):
        unpack(self, fmu, unzipdir, md)
        self.iface = iface
        self.nx = len(self.md.derivatives)
        self.nz = len(self.md.eventIndicators)
        cls = FMU3Slave if iface == "CS" else FMU3Model
        ident = (self.md.coSimulation if iface == "CS" else self.md.modelExchange).modelIdentifier
        self.fmu3 = cls(guid=self.md.guid, unzipDirectory=self.unzipdir, modelIdentifier=ident,
                        instanceName=name)
        self.me = self.fmu3
        self.instantiate(logging_on, event_mode_used, early_return_allowed)

    def instantiate(self, logging_on: bool = True, event_mode_used: bool = False,
                    early_return_allowed: bool = False) -> None:
        """A new instance of the library (the old one, if any, freed first)."""
        if getattr(self.fmu3, "component", None):
            self.free()
        self.event_mode_used, self.early_return_allowed = event_mode_used, early_return_allowed
        messages = self.messages  # the callback must not keep the instance alive

        def logger(env, status, category, message):
            messages.append((int(status), (category or b"").decode(errors="replace"),
                             (message or b"").decode(errors="replace")))
        if self.iface == "CS":
            self.fmu3.instantiate(loggingOn=logging_on, eventModeUsed=event_mode_used,
                                  earlyReturnAllowed=early_return_allowed, logMessage=logger)
        else:
            self.fmu3.instantiate(loggingOn=logging_on, logMessage=logger)

    @property
    def slave(self):
        return self.fmu3

    def raw(self, fn: str, *args, out=None) -> int:
        """out: the array the call writes (for a caller that checks it; unused here)"""
        return self.fmu3._functions[fn](self.fmu3.component, *args)

    def log(self) -> list[str]:
        return [m for _, _, m in self.messages]

    def log_text(self) -> str:
        return "\n".join(self.log())

    def vr(self, name: str) -> int:
        return self.vars[name].valueReference

    # a variable's type -> the fmpy accessor's name and the Python type of its values
    ACCESS = {"Float64": ("Float64", float), "Int32": ("Int32", int), "Int64": ("Int64", int),
              "Enumeration": ("Int64", int), "Boolean": ("Boolean", bool)}

    def set(self, **values) -> None:
        for name, value in values.items():
            v = self.vars[name]
            kind, cast = self.ACCESS[v.type]
            getattr(self.fmu3, f"set{kind}")([v.valueReference], [cast(value)])

    def size(self, name: str) -> int:
        """The number of values of a variable: 1 for a scalar, the product of an array's
        dimensions (FMI 3.0.2 section 2.4.7.2)."""
        return int(np.prod([int(d.start) for d in self.vars[name].dimensions]))

    def get(self, *names: str):
        """A scalar's value, an array variable's values as a list (nValues its size)."""
        out = []
        for name in names:
            v = self.vars[name]
            kind, cast = self.ACCESS[v.type]
            values = [cast(x) for x in getattr(self.fmu3, f"get{kind}")([v.valueReference], nValues=self.size(name))]
            out.append(values if v.dimensions else values[0])
        return out[0] if len(out) == 1 else out

    def init(self, start_time: float = 0.0, tolerance: float | None = None, stop_time: float | None = None,
             **values) -> None:
        """Start values, fmi3EnterInitializationMode, fmi3ExitInitializationMode."""
        self.set(**values)
        self.fmu3.enterInitializationMode(tolerance=tolerance, startTime=start_time, stopTime=stop_time)
        self.fmu3.exitInitializationMode()

    def do_step(self, t: float, h: float, no_set_prior: bool = True):
        """fmi3DoStep: (status, eventHandlingNeeded, terminateSimulation, earlyReturn,
        lastSuccessfulTime), whatever the status."""
        flags = [B(), B(), B()]
        last = C.c_double(float("nan"))
        status = self.raw("fmi3DoStep", C.c_double(t), C.c_double(h), B(no_set_prior),
                          *[C.byref(f) for f in flags], C.byref(last))
        return (status, *[f.value for f in flags], last.value)

    def update_discrete_states(self):
        """fmi3UpdateDiscreteStates: (status, discreteStatesNeedUpdate, terminateSimulation,
        nominalsOfContinuousStatesChanged, valuesOfContinuousStatesChanged, nextEventTimeDefined,
        nextEventTime)."""
        flags = [B() for _ in range(5)]
        t_next = C.c_double()
        status = self.raw("fmi3UpdateDiscreteStates", *[C.byref(f) for f in flags], C.byref(t_next))
        return (status, *[f.value for f in flags], t_next.value)

    def free(self) -> None:
        """fmi3FreeInstance (the library stays loaded: fmpy's freeInstance would unload it)"""
        if self.fmu3.component:
            self.fmu3.fmi3FreeInstance(self.fmu3.component)
            self.fmu3.component = None


def Slave3(fmu, **kw) -> Instance3:
    return Instance3(fmu, "CS", **kw)


def Model3(fmu, **kw) -> Instance3:
    return Instance3(fmu, "ME", **kw)


# ---- any fmi3 function with well-formed arguments ------------------------------------------------
_NOTHING = ("fmi3EnterInitializationMode", "fmi3ExitInitializationMode", "fmi3EnterEventMode", "fmi3Terminate",
            "fmi3Reset", "fmi3EnterContinuousTimeMode", "fmi3EnterStepMode", "fmi3EvaluateDiscreteStates",
            "fmi3EnterConfigurationMode", "fmi3ExitConfigurationMode")


def well_formed(inst: Instance3, fn: str, t: float = 0.0, call=None) -> int:
    """fn with valid arguments (nothing to get or set where a count may be 0; states and
    derivatives with the model's sizes; fmi3DoStep from t); the fmi3Status. call(fn, *args,
    out=array or None) makes the calls (default: inst.raw)."""
    call = call or inst.raw
    nx, nz = max(inst.nx, 1), max(inst.nz, 1)
    if fn == "fmi3SetDebugLogging":
        return call(fn, B(False), 0, None)
    if fn == "fmi3EnterInitializationMode":
        return call(fn, B(False), C.c_double(0.0), C.c_double(0.0), B(False), C.c_double(0.0))
    if fn in _NOTHING:
        return call(fn)
    if fn in ("fmi3GetBinary", "fmi3SetBinary"):
        return call(fn, None, 0, None, None, 0)
    if fn in ("fmi3GetClock", "fmi3SetClock", "fmi3GetShiftDecimal", "fmi3SetShiftDecimal",
              "fmi3SetIntervalDecimal"):
        return call(fn, None, 0, None)
    if fn in ("fmi3GetIntervalDecimal", "fmi3GetShiftFraction", "fmi3SetShiftFraction", "fmi3SetIntervalFraction"):
        return call(fn, None, 0, None, None)
    if fn == "fmi3GetIntervalFraction":
        return call(fn, None, 0, None, None, None)
    if fn[:7] in ("fmi3Get", "fmi3Set") and fn[7:] in ("Float32", "Float64", "Int8", "UInt8", "Int16", "UInt16",
                                                       "Int32", "UInt32", "Int64", "UInt64", "Boolean", "String"):
        return call(fn, None, 0, None, 0)
    if fn == "fmi3GetFMUState":
        state = C.c_void_p()
        status = call(fn, C.byref(state))
        if state.value:
            call("fmi3FreeFMUState", C.byref(state))
        return status
    if fn == "fmi3FreeFMUState":
        return call(fn, C.byref(C.c_void_p()))
    if fn in ("fmi3SetFMUState", "fmi3SerializedFMUStateSize", "fmi3SerializeFMUState", "fmi3DeserializeFMUState"):
        return _with_own_state(call, fn)
    if fn in ("fmi3GetDirectionalDerivative", "fmi3GetAdjointDerivative"):
        return call(fn, None, 0, None, 0, None, 0, None, 0)
    if fn == "fmi3UpdateDiscreteStates":
        return call(fn, *[C.byref(B()) for _ in range(5)], C.byref(C.c_double()))
    if fn == "fmi3CompletedIntegratorStep":
        a, b = B(), B()
        return call(fn, B(True), C.byref(a), C.byref(b))
    if fn == "fmi3SetTime":
        return call(fn, C.c_double(t))
    if fn == "fmi3SetContinuousStates":
        return call(fn, (C.c_double * nx)(*([0.1] * nx)), nx)  # any finite states
    if fn == "fmi3GetEventIndicators":
        z = (C.c_double * nz)()
        return call(fn, z, inst.nz, out=z)
    if fn in ("fmi3GetContinuousStates", "fmi3GetContinuousStateDerivatives", "fmi3GetNominalsOfContinuousStates"):
        x = (C.c_double * nx)()
        return call(fn, x, inst.nx, out=x)
    if fn in ("fmi3GetNumberOfContinuousStates", "fmi3GetNumberOfEventIndicators"):
        n = C.c_size_t()
        return call(fn, C.byref(n))
    if fn == "fmi3GetOutputDerivatives":
        return call(fn, None, 0, None, None, 0)
    if fn == "fmi3DoStep":
        flags, last = [B(), B(), B()], C.c_double()
        return call(fn, C.c_double(t), C.c_double(0.01), B(True), *[C.byref(f) for f in flags], C.byref(last))
    if fn == "fmi3GetNumberOfVariableDependencies":
        n = C.c_size_t()
        return call(fn, 1, C.byref(n))
    if fn == "fmi3GetVariableDependencies":
        return call(fn, 1, None, None, None, None, 0)
    if fn == "fmi3ActivateModelPartition":
        return call(fn, 0, C.c_double(t))
    raise ValueError(f"no well-formed call of {fn}")


def _with_own_state(call, fn: str) -> int:
    """fn on an FMU state of the instance's own current state (taken first: legal everywhere)."""
    state = C.c_void_p()
    if call("fmi3GetFMUState", C.byref(state)) != OK:
        return -1
    try:
        if fn == "fmi3SetFMUState":
            return call(fn, state)
        size = C.c_size_t()
        status = call("fmi3SerializedFMUStateSize", state, C.byref(size))
        if fn == "fmi3SerializedFMUStateSize":
            return status
        buf = (C.c_ubyte * size.value)()
        status = call("fmi3SerializeFMUState", state, buf, size)
        if fn == "fmi3SerializeFMUState":
            return status
        new = C.c_void_p()
        status = call(fn, buf, size, C.byref(new))
        if new.value:
            call("fmi3FreeFMUState", C.byref(new))
        return status
    finally:
        call("fmi3FreeFMUState", C.byref(state))
