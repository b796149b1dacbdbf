"""Time the FMU's own integrator: instantiate, initialise, one fmi2DoStep."""
from __future__ import annotations

import atexit
import shutil
import time
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

_CACHE: dict[str, tuple] = {}
# fmpy's logger proxy is process-global and calls the logger registered last: the one of
# solver_counts must outlive the call (a dead one crashed the next FMU's error message)
_COUNT_MESSAGES: list[str] = []
_COUNT_LOGGER = None


def _open(fmu: Path):
    key = str(fmu)
    if key not in _CACHE:
        md = read_model_description(key)
        _CACHE[key] = (md, extract(key))
        atexit.register(shutil.rmtree, _CACHE[key][1], True)  # fmpy.extract's temporary directory
    return _CACHE[key]


def one_step_seconds(fmu: Path, stop: float, **values) -> float:
    """CPU time of fmi2DoStep(0, stop) alone (instantiation and set-up excluded)."""
    runner = FmuRunner(fmu)
    try:
        runner.one_step(stop, [], **values)
        return runner.last_seconds
    finally:
        runner.free()


def many_steps_seconds(fmu: Path, n_steps: int, h: float, read: tuple[str, ...] = (),
                       **values) -> tuple[float, float, bool, dict[str, float]]:
    """Wall time of n_steps calls fmi2DoStep(t, h) through fmpy's FMU2Slave (set-up excluded).

    Returns (seconds, time reached, terminated, {name: final value} for the names in `read`):
    a step that ends in fmi2Discard (the wheel fell, or a "terminate" event fired) stops the
    loop; `terminated` is then true and the time reached is fmi2LastSuccessfulTime.
    """
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated

    runner = FmuRunner(fmu)
    try:
        runner.start(**values)
        s = runner.slave
        do_step, done = s.doStep, 0
        t0 = time.perf_counter()
        try:
            for done in range(n_steps):
                do_step(done * h, h)
            done = n_steps
        except FMICallException:
            pass
        dt = time.perf_counter() - t0
        t = done * h
        terminated = done < n_steps and s.getBooleanStatus(fmi2Terminated)
        if terminated:
            t = s.getRealStatus(fmi2LastSuccessfulTime)
        finals = {name: s.getReal([runner.vr[name]])[0] for name in read}
        return dt, t, terminated, finals
    finally:
        runner.free()


class FmuRunner:
    """One instance reused for many runs: reset, set, initialise, one fmi2DoStep(0, stop).

    `one_step` returns the values of `names` at the end; `last_seconds` is the time of the
    fmi2DoStep call alone (instantiation, reset and initialisation excluded); `last_call_seconds`
    the whole run as a user of fmpy's FMU2Slave makes it on an instance it holds: reset, set
    the values, initialise, fmi2DoStep, read the values (instantiation excluded).
    """

    def __init__(self, fmu: Path):
        self.md, unzipdir = _open(fmu)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=unzipdir,
                               modelIdentifier=self.md.coSimulation.modelIdentifier)
        self.slave.instantiate()
        self.last_seconds = self.last_call_seconds = float("nan")
        self._fresh = True

    def start(self, tolerance: float | None = None, **values) -> None:
        """Reset (after the first run), set up the experiment (with `tolerance`, when given, as
        fmi2SetupExperiment's), set the values (one call per FMI type, as a user sets several
        values) and initialise."""
        s = self.slave
        if not self._fresh:
            s.reset()
        self._fresh = False
        s.setupExperiment(tolerance=tolerance, startTime=0.0)
        ints = [name for name in values if self.types[name] in ("Integer", "Enumeration")]
        reals = [name for name in values if name not in ints]
        if ints:
            s.setInteger([self.vr[n] for n in ints], [int(values[n]) for n in ints])
        if reals:
            s.setReal([self.vr[n] for n in reals], [float(values[n]) for n in reals])
        s.enterInitializationMode()
        s.exitInitializationMode()

    def one_step(self, stop: float, names: list[str], tolerance: float | None = None,
                 **values) -> list[float]:
        t_call = time.thread_time()
        self.start(tolerance, **values)
        t0 = time.thread_time()
        self.slave.doStep(0.0, stop)
        t1 = time.thread_time()
        out = list(self.slave.getReal([self.vr[n] for n in names]))
        self.last_seconds, self.last_call_seconds = t1 - t0, time.thread_time() - t_call
        return out

    def free(self) -> None:
        self.slave.freeInstance()


def solver_counts(fmu: Path, stop: float, **values) -> dict[str, int]:
    """Accepted and rejected internal steps and RHS evaluations of one fmi2DoStep(0, stop),
    read from the FMU's logSolver message (debug logging on)."""
    import re
    from ctypes import byref

    from fmpy import calloc, free
    from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                           fmi2CallbackLoggerTYPE)
    from fmpy.logging import addLoggerProxy

    global _COUNT_LOGGER
    md, unzipdir = _open(fmu)
    messages = _COUNT_MESSAGES
    messages.clear()
    if _COUNT_LOGGER is None:
        _COUNT_LOGGER = fmi2CallbackLoggerTYPE(
            lambda env, inst, status, cat, msg: _COUNT_MESSAGES.append((msg or b"").decode()))
    cb = fmi2CallbackFunctions()
    cb.logger = _COUNT_LOGGER
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(cb))
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier)
    s.instantiate(callbacks=cb, loggingOn=True)
    try:
        s.setDebugLogging(True, ["logSolver"])
        vr = {v.name: v for v in md.modelVariables}
        s.setupExperiment(startTime=0.0)
        for name, value in values.items():
            if vr[name].type in ("Integer", "Enumeration"):
                s.setInteger([vr[name].valueReference], [int(value)])
            else:
                s.setReal([vr[name].valueReference], [float(value)])
        s.enterInitializationMode()
        s.exitInitializationMode()
        s.doStep(0.0, stop)
    finally:
        s.freeInstance()
    for msg in messages:
        m = re.search(r"accepted=(\d+) rejected=(\d+) rhs=(\d+)", msg)
        if m:
            return {"accepted": int(m[1]), "rejected": int(m[2]), "rhs": int(m[3])}
    raise RuntimeError("no logSolver message with the step counts")
