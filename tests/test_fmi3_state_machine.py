"""Every fmi3 function in every state of both interfaces against FMI 3.0.2's state machine
(tests/fmi3_state_table.py), on the FMI 3 FMU of paper_earth through fmpy's FMU3Slave / FMU3Model.

For each (interface, state, function) the instance is driven into the state, the function is
called with well-formed arguments (tests/fmi3_helpers.py well_formed), and
  legal    its documented status (fmi3OK; fmi3Warning for fmi3Terminate once more or after an
           error) and the state the standard's state machine leads to;
  illegal  fmi3Error, the reason in the log ("<function>: illegal call in state <state>", the
           other interface's or the absent function's reason), and the instance in state Error.
The state afterwards is read from the FMU itself: a probe call that is illegal in the expected
state must be refused naming that state. Co-Simulation is checked twice: instantiated with
eventModeUsed (Event Mode reachable) and without (fmi3EnterEventMode refused)."""
from __future__ import annotations

import ctypes as C

import pytest

import fmi3_state_table as T
from fmi_state_table import named_state
from fmi3_helpers import B, ERROR, OK, WARNING, Instance3, well_formed

D = C.c_double


def _ok(status: int, what: str) -> None:
    assert status in (OK, WARNING), what


def reach(inst: Instance3, state: str) -> None:
    """Drive the instance into state from wherever it is (fmi3Reset first: legal in every state)."""
    _ok(inst.raw("fmi3Reset"), "fmi3Reset")
    if state == T.INSTANTIATED:
        return
    _ok(inst.raw("fmi3EnterInitializationMode", B(False), D(0.0), D(0.0), B(False), D(0.0)), "enter")
    if state == T.INIT_MODE:
        return
    _ok(inst.raw("fmi3ExitInitializationMode"), "exit")
    if inst.iface == "ME" and state in (T.CT_MODE, T.TERMINATED):
        _ok(inst.update_discrete_states()[0], "fmi3UpdateDiscreteStates")
        _ok(inst.raw("fmi3EnterContinuousTimeMode"), "fmi3EnterContinuousTimeMode")
    if inst.iface == "CS" and inst.event_mode_used and state in (T.STEP_MODE, T.TERMINATED):
        _ok(inst.update_discrete_states()[0], "fmi3UpdateDiscreteStates")
        _ok(inst.raw("fmi3EnterStepMode"), "fmi3EnterStepMode")
    if state == T.TERMINATED:
        _ok(inst.raw("fmi3Terminate"), "fmi3Terminate")
    if state == T.ERROR:  # an argument the function refuses: fmi3Error in a legal state
        unknown = (C.c_uint32 * 1)(10_000)
        assert inst.raw("fmi3GetFloat64", unknown, 1, (D * 1)(), 1) == ERROR


def expected_status(iface: str, fn: str, state: str) -> set[int]:
    """The documented status of a legal, well-formed call."""
    if fn == "fmi3Terminate" and state in (T.TERMINATED, T.ERROR):
        return {WARNING}  # a repeat, or after an error (the last consistent state kept)
    return {OK}


PROBES = ("fmi3ExitInitializationMode", "fmi3EnterInitializationMode", "fmi3EnterStepMode",
          "fmi3CompletedIntegratorStep")


def state_now(inst: Instance3, expected: str, last: str) -> str:
    """The FMU's state, as its refusal of a probe call names it: a probe of the instance's own
    interface, illegal in expected and not the call just made (a message repeating the one before
    is counted, not logged). The probe leaves the instance in Error."""
    probe = next(p for p in PROBES if p != last and not T.other_interface(inst.iface, p)
                 and not T.legal(inst.iface, p, expected, inst.event_mode_used))
    n = len(inst.messages)
    status = well_formed(inst, probe)
    return named_state(probe, status, [m for _, _, m in inst.messages[n:]], expected)


def check_cell(inst: Instance3, state: str, fn: str) -> str:
    """'' if fn in state answers as the table says, else what went wrong."""
    iface, emu = inst.iface, inst.event_mode_used
    reach(inst, state)
    n = len(inst.messages)
    status = well_formed(inst, fn)
    log = [m for _, _, m in inst.messages[n:]]
    if T.legal(iface, fn, state, emu):
        want = T.after(iface, fn, state, emu)
        if status not in expected_status(iface, fn, state):
            return f"legal, answered {status}: {log}"
    else:
        want = T.ERROR
        if status != ERROR:
            return f"illegal, answered {status}: {log}"
        reason = T.refusal(iface, fn, state, emu)
        if not any(m.startswith(fn) and reason in m for m in log):
            return f"illegal, fmi3Error without {reason!r}: {log}"
    got = state_now(inst, want, fn)
    return "" if got == want else f"state afterwards {got}, expected {want}"


CASES = [("CS", True), ("CS", False), ("ME", False)]


@pytest.mark.parametrize("iface,event_mode_used", CASES, ids=["CS-eventModeUsed", "CS", "ME"])
def test_every_function_in_every_state(fmi3_earth_fmu, iface, event_mode_used):
    inst = Instance3(fmi3_earth_fmu, iface, logging_on=False, event_mode_used=event_mode_used)
    try:
        states = [s for s in T.STATES[iface] if s != T.EVENT_MODE or iface == "ME" or event_mode_used]
        wrong, cells = [], 0
        for state in states:
            for fn in T.functions(iface):
                cells += 1
                answer = check_cell(inst, state, fn)
                if answer:
                    wrong.append(f"{iface} {state} {fn}: {answer}")
        print(f"{iface}: {cells} cells, {len(wrong)} wrong")
        assert cells == len(states) * len(T.FUNCTIONS) and not wrong, "\n".join(wrong)
    finally:
        inst.free()


def test_the_table_covers_every_function_of_the_header():
    """Every fmi3 function that takes an instance (fmi3FunctionTypes.h) has a row."""
    import re
    from pathlib import Path

    import fmpy
    header = (Path(fmpy.__file__).parent / "c-code" / "fmi3FunctionTypes.h").read_text()
    declared = set(re.findall(r"typedef fmi3Status (fmi3\w+)TYPE\s*\(\s*fmi3Instance", header))
    assert declared - {"fmi3FreeInstance"} == set(T.FUNCTIONS)
