"""Drive an FMU through fmpy's low-level FMU2Slave, capturing its log messages."""
from __future__ import annotations

from ctypes import byref
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
from fmpy import calloc, free  # the C library allocator, as fmpy itself uses it
from fmpy.logging import addLoggerProxy


class Slave:
    """One instance of a Co-Simulation FMU with named access to its variables."""

    def __init__(self, fmu: str | Path, unzipdir: str | Path | None = None, name: str = "wheel",
                 md=None):
        self.fmu = str(fmu)
        self.md = md or read_model_description(self.fmu)
        self.unzipdir = str(unzipdir or extract(self.fmu))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.messages: list[tuple[int, str, str]] = []
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(byref(self._callbacks))
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzipdir,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.slave.instantiate(callbacks=self._callbacks, loggingOn=True)

    def _log(self, env, instance, status, category, message):
        self.messages.append((int(status), (category or b"").decode(), (message or b"").decode()))

    def log_text(self) -> str:
        return "\n".join(m for _, _, m in self.messages)

    def vr(self, name: str) -> int:
        return self.vars[name].valueReference

    def set(self, **values) -> None:
        for name, value in values.items():
            v = self.vars[name]
            if v.type == "Real":
                self.slave.setReal([v.valueReference], [float(value)])
            elif v.type in ("Integer", "Enumeration"):
                self.slave.setInteger([v.valueReference], [int(value)])
            elif v.type == "Boolean":
                self.slave.setBoolean([v.valueReference], [bool(value)])

    def get(self, *names: str):
        out = []
        for name in names:
            v = self.vars[name]
            if v.type == "Real":
                out.append(self.slave.getReal([v.valueReference])[0])
            elif v.type in ("Integer", "Enumeration"):
                out.append(self.slave.getInteger([v.valueReference])[0])
            else:
                out.append(bool(self.slave.getBoolean([v.valueReference])[0]))
        return out[0] if len(out) == 1 else out

    def init(self, start_time: float = 0.0, tolerance: float | None = None, stop_time: float | None = None,
             **values) -> None:
        self.slave.setupExperiment(tolerance=tolerance, startTime=start_time, stopTime=stop_time)
        self.set(**values)
        self.slave.enterInitializationMode()
        self.slave.exitInitializationMode()

    def free(self) -> None:
        self.slave.freeInstance()
