"""FMI 3.0.2's state machine as data: in which states each fmi3 function taking an instance may be
called (sections 2.3 "State Machine and Semantics", 3.2 Model Exchange, 4.2 Co-Simulation), the
state a legal call leads to, what the FMU answers for the functions of what it does not have
(clocks, Scheduled Execution, configuration mode, variable types other than Float64, Int32, Int64
and Boolean) and the text of each refusal. Used by tests/test_fmi3_state_machine.py and the
fuzzer (tests/fuzz/fmi3_fuzz.py).

States this FMU can be in: Co-Simulation Instantiated, InitializationMode, EventMode (only with
eventModeUsed), StepMode, Terminated; Model Exchange the same with ContinuousTimeMode for StepMode.
ConfigurationMode, ReconfigurationMode, ClockActivationMode and IntermediateUpdateMode need what
the FMU does not have (structural parameters, clocks, Scheduled Execution, intermediate update).
FMI 3.0.2 sends an instance whose call returned fmi3Error to Terminated (2.3.1); the FMU calls that
state Error and allows in it what Terminated allows, and fmi3Terminate (a master's clean-up:
fmi3Warning, the last consistent state kept, after an initialisation).
"""
from __future__ import annotations

INSTANTIATED, INIT_MODE, EVENT_MODE = "Instantiated", "InitializationMode", "EventMode"
CT_MODE, STEP_MODE, TERMINATED, ERROR = "ContinuousTimeMode", "StepMode", "Terminated", "Error"

STATES = {"CS": (INSTANTIATED, INIT_MODE, EVENT_MODE, STEP_MODE, TERMINATED, ERROR),
          "ME": (INSTANTIATED, INIT_MODE, EVENT_MODE, CT_MODE, TERMINATED, ERROR)}

_ALL = {INSTANTIATED, INIT_MODE, EVENT_MODE, CT_MODE, STEP_MODE, TERMINATED, ERROR}
_INITIALIZED = {EVENT_MODE, CT_MODE, STEP_MODE}  # the super state Initialized (2.3.4)
_GET = {INSTANTIATED, INIT_MODE} | _INITIALIZED | {TERMINATED, ERROR}
_SET_FLOAT = {INSTANTIATED, INIT_MODE, EVENT_MODE, CT_MODE, STEP_MODE}  # continuous inputs in CT mode
_SET_DISCRETE = _SET_FLOAT - {CT_MODE}
_ME_GET = {INIT_MODE, EVENT_MODE, CT_MODE, TERMINATED, ERROR}

# the variable types of this FMU's variables (docs/fmi.md, FMI 3.0); the other types' functions
# answer fmi3OK for no value reference and fmi3Error naming the variable's type for any
TYPES = ("Float64", "Int32", "Int64", "Boolean")
OTHER_TYPES = ("Float32", "Int8", "UInt8", "Int16", "UInt16", "UInt32", "UInt64", "String", "Binary")

# function -> the states FMI 3.0.2 allows it in (each interface restricted to its own states)
STANDARD: dict[str, set[str]] = {
    "fmi3SetDebugLogging": _ALL,
    "fmi3Reset": _ALL,
    "fmi3EnterInitializationMode": {INSTANTIATED},
    "fmi3ExitInitializationMode": {INIT_MODE},
    "fmi3EnterEventMode": {CT_MODE, STEP_MODE},
    "fmi3Terminate": _INITIALIZED,
    **{f"fmi3Get{t}": _GET for t in TYPES + OTHER_TYPES},
    "fmi3SetFloat64": _SET_FLOAT, "fmi3SetFloat32": _SET_FLOAT,
    **{f"fmi3Set{t}": _SET_DISCRETE for t in TYPES + OTHER_TYPES if t not in ("Float64", "Float32")},
    "fmi3GetFMUState": _ALL, "fmi3SetFMUState": _ALL, "fmi3FreeFMUState": _ALL,
    "fmi3SerializedFMUStateSize": _ALL, "fmi3SerializeFMUState": _ALL, "fmi3DeserializeFMUState": _ALL,
    "fmi3GetDirectionalDerivative": {INIT_MODE} | _INITIALIZED | {TERMINATED, ERROR},
    "fmi3GetAdjointDerivative": {INIT_MODE} | _INITIALIZED | {TERMINATED, ERROR},
    "fmi3UpdateDiscreteStates": {EVENT_MODE},
    "fmi3GetClock": {EVENT_MODE}, "fmi3SetClock": {EVENT_MODE},  # (no clock: only an empty list is right)
    # Model Exchange
    "fmi3EnterContinuousTimeMode": {EVENT_MODE},
    "fmi3CompletedIntegratorStep": {CT_MODE},
    "fmi3SetTime": {EVENT_MODE, CT_MODE},
    "fmi3SetContinuousStates": {CT_MODE},
    "fmi3GetContinuousStateDerivatives": _ME_GET,
    "fmi3GetEventIndicators": _ME_GET,
    "fmi3GetContinuousStates": _ME_GET,
    "fmi3GetNominalsOfContinuousStates": _ME_GET,
    "fmi3GetNumberOfContinuousStates": _ALL,
    "fmi3GetNumberOfEventIndicators": _ALL,
    # Co-Simulation
    "fmi3EnterStepMode": {EVENT_MODE},
    "fmi3DoStep": {STEP_MODE},
}
ME_ONLY = ("fmi3EnterContinuousTimeMode", "fmi3CompletedIntegratorStep", "fmi3SetTime", "fmi3SetContinuousStates",
           "fmi3GetContinuousStateDerivatives", "fmi3GetEventIndicators", "fmi3GetContinuousStates",
           "fmi3GetNominalsOfContinuousStates", "fmi3GetNumberOfContinuousStates", "fmi3GetNumberOfEventIndicators")
CS_ONLY = ("fmi3EnterStepMode", "fmi3GetOutputDerivatives", "fmi3DoStep")

# what the FMU does not have: fmi3Error in every state, both interfaces, the reason logged (holding
# the text here)
ABSENT: dict[str, str] = {
    "fmi3GetIntervalDecimal": "no clocks", "fmi3GetIntervalFraction": "no clocks",
    "fmi3GetShiftDecimal": "no clocks", "fmi3GetShiftFraction": "no clocks",
    "fmi3SetIntervalDecimal": "no clocks", "fmi3SetIntervalFraction": "no clocks",
    "fmi3SetShiftDecimal": "no clocks", "fmi3SetShiftFraction": "no clocks",
    "fmi3ActivateModelPartition": "Scheduled Execution",
    "fmi3EvaluateDiscreteStates": "providesEvaluateDiscreteStates=false",
    "fmi3EnterConfigurationMode": "structural parameter",
    "fmi3ExitConfigurationMode": "structural parameter",
    "fmi3GetOutputDerivatives": "maxOutputDerivativeOrder=0",
    "fmi3GetNumberOfVariableDependencies": "providesPerElementDependencies=false",
    "fmi3GetVariableDependencies": "providesPerElementDependencies=false",
}

# Where the FMU answers a call the standard does not list, (interface or "*", function) -> (states,
# why); docs/fmi.md says each.
ANSWERED: dict[tuple[str, str], tuple[set[str], str]] = {
    ("*", "fmi3Terminate"): ({TERMINATED, ERROR}, "a second fmi3Terminate, or one after fmi3Error: fmi3Warning"),
    ("*", "fmi3GetClock"): (_ALL, "no clock: an empty list is fmi3OK in any state, as every typed getter"),
    ("*", "fmi3SetClock"): (_ALL, "as fmi3GetClock"),
    ("ME", "fmi3GetNominalsOfContinuousStates"): ({INSTANTIATED}, "the nominals are constants, as in FMI 2.0"),
}

FUNCTIONS = tuple(STANDARD) + tuple(f for f in ABSENT if f not in STANDARD)
COMMON = tuple(f for f in FUNCTIONS if f not in ME_ONLY and f not in CS_ONLY)


def functions(iface: str) -> tuple[str, ...]:
    """Every fmi3 function taking an instance (the other interface's too)."""
    return FUNCTIONS


def other_interface(iface: str, fn: str) -> bool:
    return fn in (ME_ONLY if iface == "CS" else CS_ONLY)


def refusal(iface: str, fn: str, state: str, event_mode_used: bool = True) -> str:
    """The text the log of an illegal call holds."""
    if other_interface(iface, fn):
        return f"{fn}: Model Exchange function" if iface == "CS" else f"{fn}: Co-Simulation function"
    if fn in ABSENT:
        return ABSENT[fn]
    if iface == "CS" and fn == "fmi3EnterEventMode" and not event_mode_used and state == STEP_MODE:
        return "instantiated with eventModeUsed = false"
    return f"{fn}: illegal call in state {state}"


def legal(iface: str, fn: str, state: str, event_mode_used: bool = True, ended: bool = False) -> bool:
    """Whether the FMU accepts fn in state (the standard's states plus ANSWERED); event_mode_used:
    the Co-Simulation instance was instantiated with it (else fmi3EnterEventMode is refused);
    ended: a terminating event ended the run (fmi3DoStep is then answered in Terminated too:
    fmi3Discard, as after fmi2DoStep's fall, docs/fmi.md "After the simulation terminated")."""
    if fn in ABSENT or other_interface(iface, fn):
        return False
    if iface == "CS" and fn == "fmi3EnterEventMode" and not event_mode_used:
        return False
    if fn == "fmi3DoStep" and ended and state == TERMINATED:
        return True
    extra = ANSWERED.get((iface, fn), ANSWERED.get(("*", fn), (set(), "")))[0]
    return state in STANDARD[fn] | extra


def after(iface: str, fn: str, state: str, event_mode_used: bool = True) -> str:
    """The state after a legal call of fn in state (the state machines of 2.3, 3.2 and 4.2)."""
    if fn == "fmi3EnterInitializationMode":
        return INIT_MODE
    if fn == "fmi3ExitInitializationMode":
        return EVENT_MODE if iface == "ME" or event_mode_used else STEP_MODE
    if fn == "fmi3Terminate":
        return TERMINATED
    if fn == "fmi3Reset":
        return INSTANTIATED
    if fn == "fmi3EnterEventMode":
        return EVENT_MODE
    if fn == "fmi3EnterContinuousTimeMode":
        return CT_MODE
    if fn == "fmi3EnterStepMode":
        return STEP_MODE
    return state
