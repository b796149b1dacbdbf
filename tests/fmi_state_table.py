"""FMI 2.0.4's state tables as data: in which states each fmi2 function may be called (sections
3.2.3, Model Exchange, and 4.2.4, Co-Simulation), the state a legal call leads to, and where the
FMU answers a call the tables do not list (each such answer documented in docs/fmi.md with its
reason). Used by tests/test_fmi_state_machine.py and the fuzzer (tests/fuzz/fmi2_fuzz.py).

The tables' columns as encoded by the Modelica Association's Reference FMUs (src/fmi2Functions.c,
MASK_fmi2*), restricted to the states this FMU can be in: stepInProgress and stepCanceled need an
asynchronous fmi2DoStep (canRunAsynchronuously = false: never entered), fatal needs a call that
returns fmi2Fatal (none does). A call outside its states returns fmi2Error, logs the reason and
leaves the instance in state Error (2.1.3: "The simulation cannot be continued with this FMU
instance"; only fmi2Reset, fmi2FreeInstance and the FMU-state functions remain).
"""
from __future__ import annotations

INSTANTIATED, INIT_MODE, STEP_COMPLETE, STEP_FAILED = "Instantiated", "InitializationMode", "StepComplete", "StepFailed"
EVENT_MODE, CT_MODE, TERMINATED, ERROR = "EventMode", "ContinuousTimeMode", "Terminated", "Error"

STATES = {"CS": (INSTANTIATED, INIT_MODE, STEP_COMPLETE, STEP_FAILED, TERMINATED, ERROR),
          "ME": (INSTANTIATED, INIT_MODE, EVENT_MODE, CT_MODE, TERMINATED, ERROR)}

_ALL = {INSTANTIATED, INIT_MODE, STEP_COMPLETE, STEP_FAILED, EVENT_MODE, CT_MODE, TERMINATED, ERROR}
_GET = {INIT_MODE, EVENT_MODE, CT_MODE, STEP_COMPLETE, STEP_FAILED, TERMINATED, ERROR}
_SET = {INSTANTIATED, INIT_MODE, EVENT_MODE, CT_MODE, STEP_COMPLETE}

# function -> the states the standard allows it in (both interfaces, each restricted to its own states)
STANDARD: dict[str, set[str]] = {
    "fmi2SetDebugLogging": _ALL,
    "fmi2SetupExperiment": {INSTANTIATED},
    "fmi2EnterInitializationMode": {INSTANTIATED},
    "fmi2ExitInitializationMode": {INIT_MODE},
    "fmi2Terminate": {EVENT_MODE, CT_MODE, STEP_COMPLETE, STEP_FAILED},
    "fmi2Reset": _ALL,
    "fmi2GetReal": _GET, "fmi2GetInteger": _GET, "fmi2GetBoolean": _GET, "fmi2GetString": _GET,
    "fmi2SetReal": _SET,
    "fmi2SetInteger": _SET - {CT_MODE}, "fmi2SetBoolean": _SET - {CT_MODE}, "fmi2SetString": _SET - {CT_MODE},
    "fmi2GetFMUstate": _ALL, "fmi2SetFMUstate": _ALL, "fmi2FreeFMUstate": _ALL,
    "fmi2SerializedFMUstateSize": _ALL, "fmi2SerializeFMUstate": _ALL, "fmi2DeSerializeFMUstate": _ALL,
    "fmi2GetDirectionalDerivative": _GET,
    # Model Exchange
    "fmi2EnterEventMode": {EVENT_MODE, CT_MODE},
    "fmi2NewDiscreteStates": {EVENT_MODE},
    "fmi2EnterContinuousTimeMode": {EVENT_MODE},
    "fmi2CompletedIntegratorStep": {CT_MODE},
    "fmi2SetTime": {EVENT_MODE, CT_MODE},
    "fmi2SetContinuousStates": {CT_MODE},
    "fmi2GetEventIndicators": {INIT_MODE, EVENT_MODE, CT_MODE, TERMINATED, ERROR},
    "fmi2GetContinuousStates": {INIT_MODE, EVENT_MODE, CT_MODE, TERMINATED, ERROR},
    "fmi2GetDerivatives": {EVENT_MODE, CT_MODE, TERMINATED, ERROR},
    "fmi2GetNominalsOfContinuousStates": {INSTANTIATED, EVENT_MODE, CT_MODE, TERMINATED, ERROR},
    # Co-Simulation
    "fmi2SetRealInputDerivatives": {INSTANTIATED, INIT_MODE, STEP_COMPLETE},
    "fmi2GetRealOutputDerivatives": {STEP_COMPLETE, STEP_FAILED, TERMINATED, ERROR},
    "fmi2DoStep": {STEP_COMPLETE},
    "fmi2CancelStep": set(),  # stepInProgress only
    "fmi2GetStatus": {STEP_COMPLETE, STEP_FAILED, TERMINATED},
    "fmi2GetRealStatus": {STEP_COMPLETE, STEP_FAILED, TERMINATED},
    "fmi2GetIntegerStatus": {STEP_COMPLETE, STEP_FAILED, TERMINATED},
    "fmi2GetBooleanStatus": {STEP_COMPLETE, STEP_FAILED, TERMINATED},
    "fmi2GetStringStatus": {STEP_COMPLETE, STEP_FAILED, TERMINATED},
}
ME_ONLY = ("fmi2EnterEventMode", "fmi2NewDiscreteStates", "fmi2EnterContinuousTimeMode", "fmi2CompletedIntegratorStep",
           "fmi2SetTime", "fmi2SetContinuousStates", "fmi2GetEventIndicators", "fmi2GetContinuousStates",
           "fmi2GetDerivatives", "fmi2GetNominalsOfContinuousStates")
CS_ONLY = ("fmi2SetRealInputDerivatives", "fmi2GetRealOutputDerivatives", "fmi2DoStep", "fmi2CancelStep",
           "fmi2GetStatus", "fmi2GetRealStatus", "fmi2GetIntegerStatus", "fmi2GetBooleanStatus", "fmi2GetStringStatus")
COMMON = tuple(f for f in STANDARD if f not in ME_ONLY and f not in CS_ONLY)

# Where the FMU answers a call the tables do not list, (interface or "*", function) -> (states, why).
# The answer is then the legal one below (never a changed simulation): docs/fmi.md says each.
ANSWERED: dict[tuple[str, str], tuple[set[str], str]] = {
    ("*", "fmi2GetReal"): ({INSTANTIATED}, "a read of start values and parameters before initialisation"),
    ("*", "fmi2GetInteger"): ({INSTANTIATED}, "as fmi2GetReal"),
    ("*", "fmi2GetBoolean"): ({INSTANTIATED}, "as fmi2GetReal"),
    ("*", "fmi2GetString"): ({INSTANTIATED}, "as fmi2GetReal"),
    ("*", "fmi2Terminate"): ({TERMINATED, ERROR}, "docs/fmi.md 'After the simulation terminated': fmi2Warning"),
    ("CS", "fmi2SetReal"): ({STEP_FAILED}, "docs/fmi.md: inputs stored after a terminating event"),
    ("CS", "fmi2SetInteger"): ({STEP_FAILED}, "as fmi2SetReal"),
    ("CS", "fmi2SetBoolean"): ({STEP_FAILED}, "as fmi2SetReal"),
    ("CS", "fmi2SetString"): ({STEP_FAILED}, "as fmi2SetReal"),
    # (also in Terminated when a terminating event ended the run; not so after fmi2Terminate alone)
    ("CS", "fmi2DoStep"): ({STEP_FAILED}, "docs/fmi.md: fmi2Discard after a terminating event"),
    ("CS", "fmi2GetStatus"): ({ERROR}, "the status of the failed step stays readable"),
    ("CS", "fmi2GetRealStatus"): ({ERROR}, "fmi2LastSuccessfulTime stays readable after an error"),
    ("CS", "fmi2GetIntegerStatus"): ({ERROR}, "as fmi2GetStatus"),
    ("CS", "fmi2GetBooleanStatus"): ({ERROR}, "as fmi2GetStatus"),
    ("CS", "fmi2GetStringStatus"): ({ERROR}, "as fmi2GetStatus"),
    ("ME", "fmi2GetDerivatives"): ({INIT_MODE}, "the derivatives at x = init(s, p), as fmi2GetReal of der(...)"),
}

# functions that are never supported (capability flags false): fmi2Error with the reason in every state
UNSUPPORTED = {"fmi2SetRealInputDerivatives": "canInterpolateInputs=false",
               "fmi2GetRealOutputDerivatives": "MaxOutputDerivativeOrder=0",
               "fmi2CancelStep": "never asynchronous"}


def refusal(iface: str, fn: str, state: str) -> str:
    """The text the log of an illegal call holds."""
    if fn in (ME_ONLY if iface == "CS" else CS_ONLY):
        return f"{fn}: Co-Simulation function" if iface == "ME" else f"{fn}: Model Exchange is not supported"
    if fn in UNSUPPORTED:
        return UNSUPPORTED[fn]
    return f"{fn}: illegal call in state {state}"


def functions(iface: str) -> tuple[str, ...]:
    """Every fmi2 function taking an instance, of both interfaces (the other interface's too)."""
    return COMMON + CS_ONLY + ME_ONLY


def legal(iface: str, fn: str, state: str, ended: bool = False) -> bool:
    """Whether the FMU accepts fn in state (the standard's table plus ANSWERED); ended: a
    terminating event ended the run (fmi2DoStep is then answered in Terminated too)."""
    if fn in UNSUPPORTED or fn in (ME_ONLY if iface == "CS" else CS_ONLY):
        return False
    if fn == "fmi2DoStep" and ended and state == TERMINATED:
        return True
    extra = ANSWERED.get((iface, fn), ANSWERED.get(("*", fn), (set(), "")))[0]
    return state in STANDARD[fn] | extra


def after(iface: str, fn: str, state: str) -> str:
    """The state after a legal call of fn in state (the standard's state diagrams 3.2.3, 4.2.4)."""
    if fn == "fmi2EnterInitializationMode":
        return INIT_MODE
    if fn == "fmi2ExitInitializationMode":
        return EVENT_MODE if iface == "ME" else STEP_COMPLETE
    if fn == "fmi2Terminate":
        return TERMINATED
    if fn == "fmi2Reset":
        return INSTANTIATED
    if fn == "fmi2EnterEventMode":
        return EVENT_MODE
    if fn == "fmi2EnterContinuousTimeMode":
        return CT_MODE
    return state


def named_state(probe: str, status: int, texts: list[str], expected: str) -> str:
    """The state an instance is in as its refusal of a probe call names it ("<probe>: illegal call
    in state <state>" among texts, the messages the call logged), for FMI 2 and FMI 3 alike; else
    what the answer was instead."""
    if status != 3:  # fmi2Error, fmi3Error
        return f"not {expected}: {probe} answered {status}"
    for text in texts:
        if text.startswith(f"{probe}: illegal call in state "):
            return text.split("illegal call in state ", 1)[1]
    return f"? {texts}"
