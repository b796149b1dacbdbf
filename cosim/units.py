"""One FMU of a system as gyrowheel's master drives it, FMI 2.0 or FMI 3.0 Co-Simulation.

A unit hides the version: get/put by the variable's type, initialisation, and do_step, which
returns None when the step reached its end or the time at which the component ended the run:
FMI 2.0 says so with fmi2Discard and fmi2LastSuccessfulTime (FMI 2.0.4 section 4.2.3), FMI 3.0
with fmi3DoStep's terminateSimulation and lastSuccessfulTime (FMI 3.0.2 section 4.2.1). Both
kinds are instantiated without event mode or early return, so every step of every component
ends at the same communication point unless the component stops the run.
The master records and connects scalar variables: an FMI 3.0 array output (FMI 3.0.2 section
2.4.7.2; the wheel's x_state and contact_force) repeats scalar outputs of the same FMU and is
left out (scalar_outputs), as gyrowheel.simulate leaves it out.
"""
from __future__ import annotations

from ctypes import byref
from dataclasses import dataclass, field

from fmpy import extract
from fmpy.fmi1 import FMICallException

from gyrowheel.cosim.fmi_log import fmi3_logger, forget_messages, logging_callbacks
from gyrowheel.fmi_types import FMI3_INTEGERS
from gyrowheel.scratch import new_directory

FMI2_DISCARD = FMI3_DISCARD = 2  # fmi2Discard, fmi3Discard


def kind_of(fmi_type: str) -> str:
    """The FMI 2.0 name of a variable type's kind of value: Real for Float32/Float64, Integer
    for FMI 3.0's integer types and for Enumerations (FMI 2.0 section 2.2.7: they travel as
    Integers; FMI 3.0.2 section 2.4.7.6: as Int64), else the type itself (Boolean, String)."""
    if fmi_type in ("Real", "Float32", "Float64"):
        return "Real"
    if fmi_type in ("Integer", "Enumeration") or fmi_type in FMI3_INTEGERS:
        return "Integer"
    return fmi_type


def scalar_outputs(md) -> list[str]:
    """The names of md's scalar outputs, in modelDescription order: an FMI 3.0 array variable
    (one with <Dimension>s) is left out."""
    return [v.name for v in md.modelVariables if v.causality == "output" and not v.dimensions]


@dataclass
class Unit:
    """A component's FMU, unpacked and instantiated; subclasses per FMI version."""

    name: str
    md: object  # fmpy ModelDescription
    vars: dict = field(init=False)
    outputs: list[str] = field(init=False)
    messages: list = field(default_factory=list)  # the FMU's logged errors (status Error, Fatal)
    slave: object = None
    log_id: int = 0
    unzipdir: str | None = None  # the FMU unpacked (gyrowheel.scratch), removed after the run

    def __post_init__(self):
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.outputs = scalar_outputs(self.md)  # one value each: get() reads one

    def unpack(self, fmu) -> None:
        self.unzipdir = str(new_directory("unit"))
        extract(str(fmu), unzipdir=self.unzipdir)

    def free(self) -> None:
        try:
            if self.slave is not None:
                self.slave.freeInstance()  # also unloads the shared library
        except Exception:
            pass
        forget_messages(self.log_id)


class Fmi2Unit(Unit):
    def instantiate(self) -> None:
        from fmpy.fmi2 import FMU2Slave
        self.callbacks, self.log_id = logging_callbacks(self.messages)
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzipdir,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=self.name)
        self.slave.instantiate(callbacks=self.callbacks, loggingOn=False)

    def get(self, vr: int, fmi_type: str):
        return getattr(self.slave, "get" + _fmi2_access(fmi_type))([vr])[0]

    def put(self, vr: int, fmi_type: str, value) -> None:
        getattr(self.slave, "set" + _fmi2_access(fmi_type))([vr], [value])

    def before_start_values(self, t0: float) -> None:
        self.slave.setupExperiment(startTime=t0)

    def enter_initialization(self, t0: float) -> None:
        self.slave.enterInitializationMode()

    def do_step(self, t: float, h: float) -> float | None:
        try:
            self.slave.doStep(t, h)
        except FMICallException as exc:
            if exc.status != FMI2_DISCARD:
                raise
            return self.slave.getRealStatus(2)  # fmi2LastSuccessfulTime
        return None


def _fmi2_access(fmi_type: str) -> str:
    return {"Real": "Real", "Boolean": "Boolean", "String": "String"}.get(fmi_type, "Integer")


class Fmi3Unit(Unit):
    def instantiate(self) -> None:
        from fmpy.fmi3 import FMU3Slave
        self.slave = FMU3Slave(guid=self.md.instantiationToken, unzipDirectory=self.unzipdir,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=self.name)
        # fmpy keeps the callback alive on the instance (slave.logMessage)
        self.slave.instantiate(loggingOn=False, eventModeUsed=False, earlyReturnAllowed=False,
                               logMessage=fmi3_logger(self.messages))

    def get(self, vr: int, fmi_type: str):
        return getattr(self.slave, "get" + _fmi3_access(fmi_type))([vr])[0]

    def put(self, vr: int, fmi_type: str, value) -> None:
        getattr(self.slave, "set" + _fmi3_access(fmi_type))([vr], [value])

    def before_start_values(self, t0: float) -> None:
        """FMI 3.0 takes the start time in fmi3EnterInitializationMode; start values are set
        in the Instantiated state before it (FMI 3.0.2 section 3.2.1)."""

    def enter_initialization(self, t0: float) -> None:
        self.slave.enterInitializationMode(startTime=t0)

    def do_step(self, t: float, h: float) -> float | None:
        """fmi3DoStep through the raw call, so that the output arguments are read also when it
        returns fmi3Discard (fmpy's doStep raises before returning them)."""
        from fmpy.fmi3 import fmi3Boolean, fmi3Float64
        event, terminate, early, last = fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64(t)
        try:
            self.slave.fmi3DoStep(self.slave.component, t, h, fmi3Boolean(True), byref(event), byref(terminate),
                                  byref(early), byref(last))
        except FMICallException as exc:
            if exc.status != FMI3_DISCARD:
                raise
            return last.value  # a step only partly done: the system stops where the component did
        if terminate.value:
            return last.value
        if early.value:
            raise RuntimeError(f"fmi3DoStep returned early at t = {last.value!r} though early return was "
                               f"not allowed (FMI 3.0.2 section 4.2.1)")
        return None


def _fmi3_access(fmi_type: str) -> str:
    """fmi3Get/Set<name> of a type: an Enumeration is an Int64 (FMI 3.0.2 section 2.4.7.6)."""
    return "Int64" if fmi_type == "Enumeration" else fmi_type


def new_unit(name: str, md) -> Unit:
    """The component `name` of model description md, for its FMI version; then unpack(fmu)
    and instantiate(); the caller frees it (free()) and removes unzipdir, also when those fail."""
    return (Fmi3Unit if md.fmiVersion.startswith("3.") else Fmi2Unit)(name, md)
