"""Drive an FMU through fmpy's low-level FMU2Slave / FMU2Model, capturing its log messages.

fmpy's logger proxy (fmpy.logging.addLoggerProxy, fmpy 0.3.32) formats the FMU's message and
forwards it to ONE process-global Python callback: the last one proxied. If that callback is
garbage collected, the next FMU that logs through fmpy's default callbacks calls freed memory.
So every instance here logs through one module-level callback, kept alive for the process,
that dispatches on componentEnvironment to the instance's own message list.
"""
from __future__ import annotations

import ctypes
import itertools
import re
import shutil
import weakref
from ctypes import byref
from pathlib import Path

import numpy as np
from fmpy import calloc, extract, free, read_model_description  # fmpy's C allocator
from fmpy.fmi2 import (FMU2Model, FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
from fmpy.logging import addLoggerProxy

_INSTANCES: "weakref.WeakValueDictionary[int, _Instance]" = weakref.WeakValueDictionary()
_IDS = itertools.count(1)
ORPHANS: list[tuple[int, str, str]] = []  # messages of instances already gone


def _dispatch(env, instance, status, category, message):
    record = (int(status), (category or b"").decode(), (message or b"").decode())
    target = _INSTANCES.get(env or 0)
    (target.messages if target is not None else ORPHANS).append(record)


_LOGGER = fmi2CallbackLoggerTYPE(_dispatch)  # alive as long as the process


def reproxy() -> None:
    """Point fmpy's global logger proxy at the dispatcher again (after a simulate_fmu(logger=...)
    whose callback is gone); instances keep receiving their own messages."""
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = _LOGGER
    addLoggerProxy(byref(callbacks))


def unpack(inst, fmu: str | Path, unzipdir=None, md=None) -> None:
    """An instance's FMU file, model description, unzipped directory (fmpy.extract's temporary
    one, removed with the instance, unless given), variables by name and empty message list."""
    inst.fmu = str(fmu)
    inst.md = md or read_model_description(inst.fmu)
    inst.unzipdir = str(unzipdir or extract(inst.fmu))
    if unzipdir is None:
        weakref.finalize(inst, shutil.rmtree, inst.unzipdir, True)
    inst.vars = {v.name: v for v in inst.md.modelVariables}
    inst.messages = []


class _Instance:
    """One FMU instance of either interface with named access to its variables."""

    def __init__(self, fmu: str | Path, cls, unzipdir=None, name: str = "wheel", md=None,
                 logging_on: bool = True):
        unpack(self, fmu, unzipdir, md)
        self.env_id = next(_IDS)
        _INSTANCES[self.env_id] = self
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = _LOGGER
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._callbacks.componentEnvironment = self.env_id
        addLoggerProxy(byref(self._callbacks))
        iface = self.md.coSimulation if cls is FMU2Slave else (self.md.modelExchange or self.md.coSimulation)
        self.fmu2 = cls(guid=self.md.guid, unzipDirectory=self.unzipdir,
                        modelIdentifier=iface.modelIdentifier, instanceName=name)
        self.fmu2.instantiate(callbacks=self._callbacks, loggingOn=logging_on)

    @property
    def slave(self):  # the name the Co-Simulation tests use
        return self.fmu2

    def raw(self, function: str, *args) -> int:
        """Call an fmi2 function of the shared library directly (fmpy's wrappers raise on a
        status above fmi2Warning); the component is passed first. Returns the fmi2Status."""
        f = getattr(self.fmu2.dll, function)
        f.restype = ctypes.c_int
        return f(ctypes.c_void_p(self.fmu2.component), *args)

    def log_text(self) -> str:
        return "\n".join(m for _, _, m in self.messages)

    def vr(self, name: str) -> int:
        return self.vars[name].valueReference

    def set(self, **values) -> None:
        for name, value in values.items():
            v = self.vars[name]
            if v.type == "Real":
                self.fmu2.setReal([v.valueReference], [float(value)])
            elif v.type in ("Integer", "Enumeration"):
                self.fmu2.setInteger([v.valueReference], [int(value)])
            elif v.type == "Boolean":
                self.fmu2.setBoolean([v.valueReference], [bool(value)])

    def get(self, *names: str):
        out = []
        for name in names:
            v = self.vars[name]
            if v.type == "Real":
                out.append(self.fmu2.getReal([v.valueReference])[0])
            elif v.type in ("Integer", "Enumeration"):
                out.append(self.fmu2.getInteger([v.valueReference])[0])
            else:
                out.append(bool(self.fmu2.getBoolean([v.valueReference])[0]))
        return out[0] if len(out) == 1 else out

    def init(self, start_time: float = 0.0, tolerance: float | None = None, stop_time: float | None = None,
             **values) -> None:
        self.fmu2.setupExperiment(tolerance=tolerance, startTime=start_time, stopTime=stop_time)
        self.set(**values)
        self.fmu2.enterInitializationMode()
        self.fmu2.exitInitializationMode()

    def free(self) -> None:
        self.fmu2.freeInstance()


class Slave(_Instance):
    """A Co-Simulation instance (FMU2Slave)."""

    def __init__(self, fmu: str | Path, unzipdir: str | Path | None = None, name: str = "wheel",
                 md=None, logging_on: bool = True):
        super().__init__(fmu, FMU2Slave, unzipdir, name, md, logging_on)


def rolled_state(fmu: str | Path, seconds: float = 1.0) -> tuple[Slave, bytes]:
    """A Co-Simulation instance initialised with the scene's values and stepped `seconds`, and its
    serialised FMU state there."""
    s = Slave(fmu, logging_on=False)
    s.init()
    s.slave.doStep(0.0, seconds)
    return s, bytes(s.slave.serializeFMUstate(s.slave.getFMUstate()))


class StateVector:
    """numpy access to the continuous states of a Model Exchange instance: self.me is the fmpy
    FMU2Model or FMU3Model, self.nx the number of states, self.get_derivatives the name of the
    version's derivatives function."""

    me = None
    nx = 0
    get_derivatives = "getDerivatives"

    @staticmethod
    def _ptr(a: np.ndarray):
        return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))

    def states(self) -> np.ndarray:
        x = np.zeros(self.nx)
        self.me.getContinuousStates(self._ptr(x), self.nx)
        return x

    def set_states(self, t: float, x: np.ndarray) -> None:
        self.me.setTime(t)
        xc = np.ascontiguousarray(x, dtype=float)
        self.me.setContinuousStates(self._ptr(xc), self.nx)

    def derivatives(self) -> np.ndarray:
        d = np.zeros(self.nx)
        getattr(self.me, self.get_derivatives)(self._ptr(d), self.nx)
        return d


class Model(StateVector, _Instance):
    """A Model Exchange instance (FMU2Model) with numpy access to the state vector."""

    def __init__(self, fmu: str | Path, unzipdir: str | Path | None = None, name: str = "wheel",
                 md=None, logging_on: bool = True):
        super().__init__(fmu, FMU2Model, unzipdir, name, md, logging_on)
        self.me = self.fmu2
        self.nx = len(self.md.derivatives)
        self.nz = self.md.numberOfEventIndicators

    def indicators(self) -> np.ndarray:
        z = np.zeros(self.nz)
        self.fmu2.getEventIndicators(self._ptr(z), self.nz)
        return z


def simulate_logged(fmu: str | Path, stop: float, dt: float, output: list[str], start: dict):
    """fmpy's simulate_fmu (Co-Simulation) with the FMU's debug log parsed for its events:
    (result, [(event name, t)]), in the order the runtime reported them."""
    from fmpy import simulate_fmu
    logs: list[str] = []

    def logger(*args):
        text = args[-1]
        logs.append(text.decode() if isinstance(text, bytes) else str(text))
    r = simulate_fmu(str(fmu), stop_time=stop, output_interval=dt, start_values=start, debug_logging=True,
                     logger=logger, output=output)
    events = [(m.group(1), float(m.group(2))) for line in logs
              for m in [re.search(r"event (\w+) at t=(\S+?):? ", line + " ")] if m]
    return r, events


def replayed(slave: "Slave", t0: float, dt: float, steps: int, names: tuple[str, ...]):
    """Save the FMU state at t0, step on `steps` times by dt reading `names`, restore the state and
    step again: (first run, second run), lists of the values after each step."""
    state = slave.slave.getFMUState()
    runs = []
    for _ in range(2):
        slave.slave.setFMUState(state)
        out = []
        for k in range(steps):
            slave.slave.doStep(t0 + dt * k, dt)
            out.append(slave.get(*names))
        runs.append(out)
    slave.slave.freeFMUState(state)
    return runs[0], runs[1]
