"""What a sweep runs: a target that opens one reusable instance per task on a worker.

A target is small and picklable (it travels with every task); its payload (here the FMU's
bytes) is sent to each worker once (Dask scatter) and unpacked once per worker process. Any
object with the same three members can be swept, e.g. a system of the wheel and a controller
run by gyrowheel's co-simulation master (studies/system_target.py):

    target.variables() -> {name: Variable}     settable inputs, parameters, outputs (on the client)
    target.payload()   -> bytes or None         shipped to the workers once
    target.open(payload) -> instance            on the worker, once per task; the instance has
        output_names                            Real outputs recorded at every communication point
        start(values, start_time)               reset (after the first point), set, initialise
        step(t, h) -> None | float              one communication step; the event time if the
                                                unit terminated (fmi2Discard + fmi2Terminated)
        read(row)                               the outputs into a float64 array
        flags() -> list[str]                    Boolean outputs that are true (e.g. 'fallen')
        close()
    target.refused(values, start_time, points) -> None | (name, reason)   optional: the first
                                                of the values every point sets that the unit
                                                refuses (as set, or at initialisation with the
                                                points' own values)
    A point that the instance refuses raises PointFailure(reason); the sweep records it and goes on.

FmuTarget drives a Co-Simulation FMU through fmpy's FMU2Slave and the raw fmi2 functions
(FMI 2.0.4, sections 2.1.5-2.1.7 and 4.2): one instance, fmi2Reset between points.
"""
from __future__ import annotations

import atexit
import hashlib
import os
import shutil
import threading
import zipfile
from ctypes import byref, c_double, c_int, c_uint
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrowheel.cosim.fmi_log import forget_messages, logging_callbacks
from gyrowheel.scratch import new_directory

_UNPACKED: dict[str, str] = {}  # FMU digest -> extraction directory, per process (removed at its exit)
_LOCK = threading.Lock()  # fmpy's FMU2Slave() changes the working directory while loading


class PointFailure(Exception):
    """A point the unit refused or could not finish; str() is the reason recorded in the table."""


@dataclass(frozen=True)
class Variable:
    """One model variable as the sweep sees it (from modelDescription.xml)."""

    name: str
    type: str  # Real, Integer, Enumeration, Boolean, String
    causality: str
    variability: str
    initial: str | None
    unit: str | None
    start: object
    vr: int
    items: dict = field(default_factory=dict)  # enumeration item name -> value
    min: str | None = None  # the declared range, as modelDescription.xml writes it (None: not declared)
    max: str | None = None

    @property
    def settable(self) -> bool:
        return self.causality in ("parameter", "input") or self.initial in ("exact", "approx")


def _read_variables(md) -> dict[str, Variable]:
    enums = {t.name: {i.name: int(i.value) for i in t.items} for t in md.typeDefinitions}
    out = {}
    for v in md.modelVariables:
        start = v.start
        if start is not None and v.type in ("Real",):
            start = float(start)
        items = enums.get(v.declaredType.name, {}) if v.type == "Enumeration" and v.declaredType else {}
        if v.type == "Enumeration" and isinstance(start, str) and start.lstrip("-").isdigit():
            start = int(start)
        out[v.name] = Variable(v.name, v.type, v.causality, v.variability, v.initial,
                               v.unit or (v.declaredType.unit if v.declaredType else None), start,
                               v.valueReference, items, v.min, v.max)
    return out


class FmuTarget:
    """A built Co-Simulation FMU as a sweep target (picklable without its bytes)."""

    def __init__(self, path: str | Path):
        from fmpy import read_model_description

        self.path = Path(path)
        try:
            self._data: bytes | None = self.path.read_bytes()
            md = read_model_description(str(self.path))
        except FileNotFoundError:
            raise FileNotFoundError(f"{self.path}: no such FMU file") from None
        except Exception as exc:  # fmpy raises plain Exceptions for broken archives
            raise ValueError(f"{self.path}: not a readable FMU: {exc}") from None
        if md.coSimulation is None:
            raise ValueError(f"{self.path}: the FMU does not support Co-Simulation")
        self.digest = hashlib.sha256(self._data).hexdigest()
        self.identifier = md.coSimulation.modelIdentifier
        self.guid = md.guid
        self._variables = _read_variables(md)
        exp = md.defaultExperiment
        self.default_stop_time = float(exp.stopTime) if exp is not None and exp.stopTime else None
        self.default_step = float(exp.stepSize) if exp is not None and exp.stepSize else None
        self.outputs = [v.name for v in self._variables.values() if v.causality == "output" and v.type == "Real"]
        self.flag_names = [v.name for v in self._variables.values()
                           if v.causality == "output" and v.type == "Boolean"]
        # Integer and Enumeration outputs, read at the end of a point only: {name: {value: item}}
        # (the items of an Enumeration; {} for an Integer)
        self.discrete_outputs = {v.name: {value: item for item, value in v.items.items()}
                                 for v in self._variables.values()
                                 if v.causality == "output" and v.type in ("Integer", "Enumeration")}
        # a gyrowheel FMU built with the Taylor kernel: batches may take the ensemble path (with
        # solver taylor, or auto where auto integrates with taylor: no mode switches)
        self.taylor_kernel, self.auto_taylor = _kernel_and_auto(self._data)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_data"] = None  # the bytes go to each worker once, as the payload
        return state

    def variables(self) -> dict[str, Variable]:
        return self._variables

    def payload(self) -> bytes | None:
        return self._data

    def open(self, payload: bytes | None) -> "FmuInstance":
        return FmuInstance(self, _unpack(self, payload))

    def refused(self, values: dict[str, object], start_time: float,
                points: list[dict] = ()) -> tuple[str | None, str] | None:
        """The first of `values` ({variable: value}, what every point sets) the FMU refuses:
        (its name, the FMU's reason); None when it takes them all, or when no instance can be
        made here (the workers will say).

        First each value alone in a fresh experiment (fmi2Set*'s own checks, e.g. rel_tol -1
        outside its range); then, given `points` (each point's own {variable: value}, in point
        order), the FMU's checks at initialisation (e.g. R -1: 'R (radius) must be > 0'), made
        with a point's values, on which they may depend (refused_at_initialisation). Costs one
        instance and, when the first point initialises with the values, one initialisation.
        """
        try:
            instance = self.open(self._data)
        except Exception:  # noqa: BLE001 - e.g. a client that cannot load the workers' binary
            return None
        try:
            for name, value in values.items():
                try:
                    instance.set_values({name: value}, start_time)
                except PointFailure as exc:
                    return name, str(exc)
            return refused_at_initialisation(instance, values, points, start_time)
        finally:
            instance.close()


def refused_at_initialisation(instance, values: dict, points, start_time: float) -> tuple[str | None, str] | None:
    """Whether the unit refuses, at initialisation, `values` (what every point sets) with every
    point's own values (`points`: {variable: value} per point, in order): None, or (the name of
    the value refused, the unit's reason) for the first point that initialises without them,
    or (None, its reason) when only their combination is refused.

    The values are refused only when no point initialises with them: a point that does (the
    first, as a rule: one initialisation) ends the check, and the points refused with them fail
    as points, the others run (beta_min_deg 80 refuses beta_deg 60, not 85).  A point the unit
    refuses on its own says nothing about them (it fails as a point either way).  Each point
    checked costs one or two initialisations of a few microseconds (against a run per point),
    the first that names the culprit one more per shared value.
    """
    def reason(own: dict) -> str | None:
        try:
            instance.start(own, start_time)
        except PointFailure as exc:
            return str(exc)
        return None

    found = None
    for own in points:
        why = reason({**values, **own})  # as the point runs (studies/batch.py)
        if why is None:
            return None
        if found is not None or reason(own) is not None:
            continue  # refused on its own, or the culprit is named already
        found = None, why
        for name, value in values.items():
            alone = reason({name: value, **own})
            if alone is not None:
                found = name, alone
                break
    return found


def _kernel_and_auto(data: bytes) -> tuple[bool, bool]:
    """(the FMU has the Taylor kernel, its solver auto integrates with taylor): auto's rule,
    gyrowheel.description.FmuInfo.auto_solver."""
    import io

    from gyrowheel.description import auto_pick, kernel_and_modes
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            kernel, modes = kernel_and_modes(zf, set(zf.namelist()))
    except (KeyError, zipfile.BadZipFile):
        return False, False
    return kernel, auto_pick(kernel, modes) == "taylor"


def _unpack(target: FmuTarget, payload: bytes | None) -> str:
    with _LOCK:
        where = _UNPACKED.get(target.digest)
        if where is None:
            where = str(new_directory("sweep-unit"))  # (and the directories of dead processes removed)
            atexit.register(shutil.rmtree, where, True)  # a killed process: gyrowheel/scratch.py
            if payload is not None:
                import io
                zipfile.ZipFile(io.BytesIO(payload)).extractall(where)
            else:
                zipfile.ZipFile(target.path).extractall(where)
            _UNPACKED[target.digest] = where
        return where


class FmuInstance:
    """One FMU2Slave, reused: fmi2Reset, set, initialise, fmi2DoStep ... for every point."""

    def __init__(self, target: FmuTarget, unzipdir: str):
        from fmpy.fmi2 import FMU2Slave

        self.target = target
        self.messages: list[str] = []
        self._callbacks, self._id = logging_callbacks(self.messages)
        with _LOCK:
            cwd = os.getcwd()
            try:
                self.slave = FMU2Slave(guid=target.guid, unzipDirectory=unzipdir,
                                       modelIdentifier=target.identifier, instanceName="sweep")
            finally:  # fmpy changes into the library's directory and stays there if loading fails
                os.chdir(cwd)
        self.slave.instantiate(callbacks=self._callbacks, loggingOn=False)
        f = self.slave._functions  # the raw ctypes functions: status codes instead of exceptions
        self._c = self.slave.component
        self._do_step, self._get_real = f["fmi2DoStep"], f["fmi2GetReal"]
        self._f = f
        variables = target.variables()
        self.output_names = list(target.outputs)
        n = len(self.output_names)
        self._out_vr = (c_uint * n)(*[variables[name].vr for name in self.output_names])
        self._out_buf = (c_double * n)()
        self._out_view = np.frombuffer(self._out_buf, dtype=np.float64)
        self._flags = [(name, variables[name].vr) for name in target.flag_names]
        self._vars = variables
        self._fresh = True

    def _check(self, status: int, what: str) -> None:
        if status > 1:  # fmi2Discard and worse
            reason = "; ".join(self.messages) or f"{what} returned status {status}"
            raise PointFailure(reason)

    def start(self, values: dict[str, object], start_time: float) -> None:
        """fmi2Reset (after the first point), fmi2SetupExperiment, set `values`, initialise."""
        self.enter_initialisation(values, start_time)
        self.exit_initialisation()

    def enter_initialisation(self, values: dict[str, object], start_time: float) -> None:
        """fmi2Reset (after the first point), fmi2SetupExperiment, set `values`, fmi2EnterInitializationMode."""
        self.set_values(values, start_time)
        self._check(self._f["fmi2EnterInitializationMode"](self._c), "fmi2EnterInitializationMode")

    def set_values(self, values: dict[str, object], start_time: float) -> None:
        """fmi2Reset (after the first point), fmi2SetupExperiment, set `values` (PointFailure with
        the FMU's reason if it refuses one)."""
        f, c = self._f, self._c
        self.messages.clear()
        if not self._fresh:
            if f["fmi2Reset"](c) > 1:
                self._reinstantiate()
        self._fresh = False
        self._check(f["fmi2SetupExperiment"](c, 0, 0.0, start_time, 0, 0.0), "fmi2SetupExperiment")
        reals, ints, bools = [], [], []
        for name, value in values.items():
            v = self._vars[name]
            (reals if v.type == "Real" else bools if v.type == "Boolean" else ints).append((v.vr, value))
        for group, ctype, setter in ((reals, c_double, "fmi2SetReal"), (ints, c_int, "fmi2SetInteger"),
                                     (bools, c_int, "fmi2SetBoolean")):
            if group:
                vr = (c_uint * len(group))(*[g[0] for g in group])
                val = (ctype * len(group))(*[g[1] for g in group])
                self._check(f[setter](c, vr, len(group), val), setter)

    def exit_initialisation(self) -> None:
        self._check(self._f["fmi2ExitInitializationMode"](self._c), "fmi2ExitInitializationMode")

    def get(self, vr: int, fmi_type: str):
        """The value of variable vr of any FMI 2.0 type but String (fmi2GetReal, fmi2GetInteger,
        fmi2GetBoolean; an Enumeration is an Integer): a float, or an int for the others."""
        if fmi_type == "String":
            raise PointFailure("String connections are not supported by the sweep's master")
        kind = "Real" if fmi_type == "Real" else "Boolean" if fmi_type == "Boolean" else "Integer"
        value = c_double(0.0) if kind == "Real" else c_int(0)
        self._check(self._f[f"fmi2Get{kind}"](self._c, byref(c_uint(vr)), 1, byref(value)), f"fmi2Get{kind}")
        return value.value

    def put(self, vr: int, fmi_type: str, value) -> None:
        """Set variable vr (of the type `get` reads) to value."""
        kind = "Real" if fmi_type == "Real" else "Boolean" if fmi_type == "Boolean" else "Integer"
        ctype = c_double if kind == "Real" else c_int
        self._check(self._f[f"fmi2Set{kind}"](self._c, byref(c_uint(vr)), 1, byref(ctype(value))), f"fmi2Set{kind}")

    def _reinstantiate(self) -> None:
        """After fmi2Fatal (or a refused fmi2Reset) the instance is gone: make a new one."""
        try:
            self.slave.fmi2FreeInstance(self._c)
        except Exception:
            pass
        self.slave.instantiate(callbacks=self._callbacks, loggingOn=False)
        self._c = self.slave.component

    def step(self, t: float, h: float) -> float | None:
        status = self._do_step(self._c, t, h, 1)
        if status <= 1:
            return None
        if status == 2:  # fmi2Discard: a terminating event (the fall) is a result, not a failure
            from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated
            flag, when = c_int(0), c_double(0.0)
            self._f["fmi2GetBooleanStatus"](self._c, fmi2Terminated, byref(flag))
            if flag.value:
                self._f["fmi2GetRealStatus"](self._c, fmi2LastSuccessfulTime, byref(when))
                return when.value
        self._check(status, f"fmi2DoStep(t={t!r}, h={h!r})")
        return None

    def read(self, row: np.ndarray) -> None:
        self._check(self._get_real(self._c, self._out_vr, len(self._out_vr), self._out_buf), "fmi2GetReal")
        row[:] = self._out_view

    def flags(self) -> list[str]:
        out = []
        for name, vr in self._flags:
            value = c_int(0)
            if self._f["fmi2GetBoolean"](self._c, byref(c_uint(vr)), 1, byref(value)) <= 1 and value.value:
                out.append(name)
        return out

    def finals(self, names) -> dict[str, object]:
        """The present values of the Integer/Enumeration outputs `names`: an Enumeration's as its
        item's name (str), an Integer's as int."""
        out = {}
        for name in names:
            v = self._vars[name]
            value = int(self.get(v.vr, v.type))
            if v.type == "Enumeration":
                by_value = {number: item for item, number in v.items.items()}
                out[name] = by_value.get(value, str(value))
            else:
                out[name] = value
        return out

    def close(self) -> None:
        try:
            self.slave.freeInstance()
        except Exception:
            pass
        forget_messages(self._id)
