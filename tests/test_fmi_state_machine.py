"""Every fmi2 function in every state of both interfaces against FMI 2.0.4's state tables
(tests/fmi_state_table.py), on the built paper_earth FMU through ctypes.

For each (interface, state, function): the instance is driven into the state, the function is
called with valid arguments, and
  legal    its documented status (fmi2OK; the answers docs/fmi.md gives where the tables are silent)
           and the state the standard's diagram leads to;
  illegal  fmi2Error, "<function>: illegal call in state <state>" (or, for a function of the other
           interface or one never supported, the reason) in the log, and the instance in state
           Error.
The state afterwards is read from the FMU itself: a probe call that is illegal in the expected
state must be refused naming that state. Against a runtime that accepted fmi2DoStep in
Initialization Mode, a second fmi2EnterInitializationMode, fmi2ExitInitializationMode from
StepComplete or fmi2SetupExperiment in StepComplete (each alone) this test fails; the rest of the
suite passed with each of them."""
from __future__ import annotations

import ctypes as C

import pytest
from fmpy.fmi2 import fmi2EventInfo as EventInfo

import fmi_state_table as T
from fmi_helpers import Model, Slave

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3




def _ok(status: int, what: str) -> None:
    assert status in (OK, DISCARD), what


def reach(inst, iface: str, state: str) -> None:
    """Drive the instance into state from wherever it is (fmi2Reset first: legal in every state)."""
    _ok(inst.raw("fmi2Reset"), "fmi2Reset")
    if state == T.INSTANTIATED:
        return
    _ok(inst.raw("fmi2SetupExperiment", 0, C.c_double(0.0), C.c_double(0.0), 0, C.c_double(0.0)), "setup")
    if state == T.STEP_FAILED:  # a wheel without spin falls: a terminating event inside the step
        vr = (C.c_uint * 1)(inst.vr("gamma_dot"))
        _ok(inst.raw("fmi2SetReal", vr, C.c_size_t(1), (C.c_double * 1)(0.0)), "gamma_dot")
    _ok(inst.raw("fmi2EnterInitializationMode"), "enter")
    if state == T.INIT_MODE:
        return
    _ok(inst.raw("fmi2ExitInitializationMode"), "exit")
    if iface == "ME" and state in (T.CT_MODE, T.TERMINATED):
        _ok(inst.raw("fmi2NewDiscreteStates", C.byref(EventInfo())), "newDiscreteStates")
        _ok(inst.raw("fmi2EnterContinuousTimeMode"), "enterCT")
    if state == T.STEP_FAILED:
        assert inst.raw("fmi2DoStep", C.c_double(0.0), C.c_double(5.0), 1) == DISCARD
    if state == T.TERMINATED:
        _ok(inst.raw("fmi2Terminate"), "terminate")
    if state == T.ERROR:  # an argument the function refuses: fmi2Error in a legal state
        if iface == "CS":
            assert inst.raw("fmi2DoStep", C.c_double(0.0), C.c_double(-1.0), 1) == ERROR
        else:
            assert inst.raw("fmi2SetTime", C.c_double(float("nan"))) == ERROR


def call(inst, fn: str) -> int:
    """fn with valid arguments (nothing to set or get where a count may be 0)."""
    nx = 8
    if fn == "fmi2SetDebugLogging":
        return inst.raw(fn, 0, C.c_size_t(0), None)
    if fn == "fmi2SetupExperiment":
        return inst.raw(fn, 0, C.c_double(0.0), C.c_double(0.0), 0, C.c_double(0.0))
    if fn in ("fmi2EnterInitializationMode", "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset",
              "fmi2EnterEventMode", "fmi2EnterContinuousTimeMode", "fmi2CancelStep"):
        return inst.raw(fn)
    if fn.startswith("fmi2Get") and fn[7:] in ("Real", "Integer", "Boolean", "String"):
        return inst.raw(fn, None, C.c_size_t(0), None)
    if fn.startswith("fmi2Set") and fn[7:] in ("Real", "Integer", "Boolean", "String"):
        return inst.raw(fn, None, C.c_size_t(0), None)
    if fn == "fmi2GetFMUstate":
        state = C.c_void_p()
        status = inst.raw(fn, C.byref(state))
        if state.value:
            inst.raw("fmi2FreeFMUstate", C.byref(state))
        return status
    if fn == "fmi2FreeFMUstate":
        return inst.raw(fn, C.byref(C.c_void_p()))
    if fn in ("fmi2SetFMUstate", "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate", "fmi2DeSerializeFMUstate"):
        return _with_own_state(inst, fn)
    if fn == "fmi2GetDirectionalDerivative":
        return inst.raw(fn, None, C.c_size_t(0), None, C.c_size_t(0), None, None)
    if fn == "fmi2NewDiscreteStates":
        return inst.raw(fn, C.byref(EventInfo()))
    if fn == "fmi2CompletedIntegratorStep":
        a, b = C.c_int(), C.c_int()
        return inst.raw(fn, 1, C.byref(a), C.byref(b))
    if fn == "fmi2SetTime":
        return inst.raw(fn, C.c_double(0.0))
    if fn == "fmi2SetContinuousStates":
        return inst.raw(fn, (C.c_double * nx)(*([0.1] * nx)), C.c_size_t(nx))  # any finite states
    if fn in ("fmi2GetEventIndicators",):
        z = (C.c_double * 1)()
        return inst.raw(fn, z, C.c_size_t(1))
    if fn in ("fmi2GetContinuousStates", "fmi2GetDerivatives", "fmi2GetNominalsOfContinuousStates"):
        x = (C.c_double * nx)()
        return inst.raw(fn, x, C.c_size_t(nx))
    if fn in ("fmi2SetRealInputDerivatives", "fmi2GetRealOutputDerivatives"):
        return inst.raw(fn, None, C.c_size_t(0), None, None)
    if fn == "fmi2DoStep":  # from the start time (after a fall answered before the time is looked at)
        return inst.raw(fn, C.c_double(0.0), C.c_double(0.01), 1)
    kind = {"fmi2GetStatus": 0, "fmi2GetRealStatus": 2, "fmi2GetIntegerStatus": 0, "fmi2GetBooleanStatus": 3,
            "fmi2GetStringStatus": 1}[fn]
    holder = C.c_double() if fn == "fmi2GetRealStatus" else (C.c_char_p() if fn == "fmi2GetStringStatus" else C.c_int())
    return inst.raw(fn, kind, C.byref(holder))


def _with_own_state(inst, fn: str) -> int:
    """fn on an FMU state of the instance's own current state (taken first: legal everywhere)."""
    state = C.c_void_p()
    if inst.raw("fmi2GetFMUstate", C.byref(state)) != OK:
        return -1
    try:
        if fn == "fmi2SetFMUstate":
            return inst.raw(fn, state)
        size = C.c_size_t()
        status = inst.raw("fmi2SerializedFMUstateSize", state, C.byref(size))
        if fn == "fmi2SerializedFMUstateSize":
            return status
        buf = (C.c_char * size.value)()
        status = inst.raw("fmi2SerializeFMUstate", state, buf, size)
        if fn == "fmi2SerializeFMUstate":
            return status
        new = C.c_void_p()
        status = inst.raw(fn, buf, size, C.byref(new))
        if new.value:
            inst.raw("fmi2FreeFMUstate", C.byref(new))
        return status
    finally:
        inst.raw("fmi2FreeFMUstate", C.byref(state))


def expected_status(iface: str, fn: str, state: str) -> set[int]:
    """The documented status of a legal call."""
    if fn == "fmi2Terminate" and state in (T.TERMINATED, T.ERROR):
        return {WARNING}  # docs/fmi.md "After the simulation terminated"
    if fn == "fmi2DoStep" and state != T.STEP_COMPLETE:
        return {DISCARD}  # after a terminating event
    if fn in ("fmi2GetIntegerStatus", "fmi2GetStringStatus"):
        return {DISCARD}  # a status kind the function does not provide (4.2.3)
    return {OK}


def state_now(inst, expected: str, last: str) -> str:
    """The FMU's state, as its refusal of a probe call names it (the probe is illegal in expected,
    so the answer names the state; the probe leaves the instance in Error). The probe is not the
    last call: a message repeating the one before is counted, not logged."""
    probe = "fmi2SetupExperiment" if expected == T.INIT_MODE else "fmi2ExitInitializationMode"
    if probe == last:
        probe = "fmi2SetupExperiment"
    n = len(inst.messages)
    status = call(inst, probe)
    return T.named_state(probe, status, [m for _, _, m in inst.messages[n:]], expected)


def check_cell(inst, iface: str, state: str, fn: str) -> str:
    """'' if fn in state answers as the table says, else what went wrong."""
    reach(inst, iface, state)
    n = len(inst.messages)
    status = call(inst, fn)
    log = [m for _, _, m in inst.messages[n:]]
    if T.legal(iface, fn, state):
        want = T.after(iface, fn, state)
        if fn == "fmi2SetFMUstate" or fn == "fmi2Reset":
            want = T.INSTANTIATED if fn == "fmi2Reset" else state
        if status not in expected_status(iface, fn, state):
            return f"legal, answered {status}: {log}"
    else:
        want = T.ERROR
        if status != ERROR:
            return f"illegal, answered {status}"
        reason = T.refusal(iface, fn, state)
        if not any(reason in m for m in log):
            return f"illegal, fmi2Error without {reason!r}: {log}"
    got = state_now(inst, want, fn)
    return "" if got == want else f"state afterwards {got}, expected {want}"


@pytest.mark.parametrize("iface", ["CS", "ME"])
def test_every_function_in_every_state(earth_fmu, iface):
    inst = (Slave if iface == "CS" else Model)(earth_fmu, logging_on=False)
    try:
        wrong, cells = [], 0
        for state in T.STATES[iface]:
            for fn in T.functions(iface):
                cells += 1
                answer = check_cell(inst, iface, state, fn)
                if answer:
                    wrong.append(f"{iface} {state} {fn}: {answer}")
        print(f"{iface}: {cells} cells, {len(wrong)} wrong")
        assert cells == len(T.STATES[iface]) * 40 and not wrong, "\n".join(wrong)
    finally:
        inst.free()
