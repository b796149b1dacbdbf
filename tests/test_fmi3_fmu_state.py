"""FMU states of the FMI 3.0 FMU through fmpy (FMI 3.0.2 section 2.2.10): fmi3GetFMUState,
fmi3SetFMUState, fmi3SerializeFMUState and fmi3DeserializeFMUState in Co-Simulation and Model
Exchange.  A run continued from a restored state repeats the first continuation bit for bit,
across a stiction switch (slope_hold stops at 2.111 s); a state of another FMU is refused
(fmi3Error) with the reason logged.
"""
from __future__ import annotations

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException

from fmi3_helpers import Instance3
from fmi_helpers import rolled_state
from test_fmi_state_fields import changed, read

FMI3_ERROR = 3
PENDING = 0x20  # the FMI 3 word's bit: an event pending for Event Mode (c_src/gw_fmi3_state.c)


def outputs(inst) -> list[str]:
    """The scalar outputs (the array outputs repeat them: tests/test_fmi3_arrays.py)."""
    return [v.name for v in inst.md.modelVariables if v.causality == "output" and not v.dimensions]


def continue_cs(f, t: float, until: float, dt: float = 0.1) -> np.ndarray:
    """fmi3DoStep from t to `until` over fmpy's grid t + k dt; every output after every step."""
    rows = []
    for k in range(round((until - t) / dt)):
        f.fmu3.doStep(t + k * dt, (t + (k + 1) * dt) - (t + k * dt))
        rows.append(f.get(*outputs(f)))
    return np.array(rows, dtype=float)


def repeated_after_restore(f, run) -> tuple[np.ndarray, bytes]:
    """run() from f's current state, then again after fmi3SetFMUState of that state and after
    fmi3DeserializeFMUState of its serialization: bit-identical.  (run()'s rows, the bytes)"""
    state = f.fmu3.getFMUState()
    blob = f.fmu3.serializeFMUState(state)
    first = run()
    f.fmu3.setFMUState(state)
    np.testing.assert_array_equal(run(), first)
    copy = f.fmu3.deserializeFMUState(blob)
    f.fmu3.setFMUState(copy)
    np.testing.assert_array_equal(run(), first)
    f.fmu3.freeFMUState(copy)
    f.fmu3.freeFMUState(state)
    return first, blob


def test_co_simulation_state_restored_and_continued_bit_identically(fmi3_build):
    fmu = fmi3_build("slope_hold").fmu
    f = Instance3(fmu)
    other = Instance3(fmu, name="other")
    try:
        f.init()
        continue_cs(f, 0.0, 1.5)
        first, blob = repeated_after_restore(f, lambda: continue_cs(f, 1.5, 3.0))
        assert first[0, outputs(f).index("gamma_dot")] != 0.0 and first[-1, outputs(f).index("gamma_dot")] == 0.0
        # another instance, initialised with other start values, takes the serialized state
        other.init(gamma_dot=1.0)
        copy = other.fmu3.deserializeFMUState(blob)
        other.fmu3.setFMUState(copy)
        np.testing.assert_array_equal(continue_cs(other, 1.5, 3.0), first)
        other.fmu3.freeFMUState(copy)
        assert [m for inst in (f, other) for m in inst.messages if m[0] > 0] == []
    finally:
        f.free()
        other.free()
    # fmpy's simulate_fmu started from the serialized state (no initialisation) continues alike
    r = simulate_fmu(str(fmu), fmu_state=blob, start_time=1.5, stop_time=3.0, output_interval=0.1, output=outputs(f))
    np.testing.assert_array_equal(np.array([list(row)[1:] for row in r[1:]], dtype=float), first)


def at_pending_update(fmi3_build):
    """A slope_hold Co-Simulation instance with Event Mode used, stepped on fmpy's 0.1 s grid until
    fmi3DoStep returns early with eventHandlingNeeded (the stop at 2.111 s): (instance, time)."""
    f = Instance3(fmi3_build("slope_hold").fmu, event_mode_used=True, early_return_allowed=True)
    f.init()
    while f.fmu3.updateDiscreteStates()[0]:
        pass
    f.fmu3.enterStepMode()
    t, k = 0.0, 0
    while True:
        st, handling, _, early, t = f.do_step(t, (k + 1) * 0.1 - t)
        assert st == 0 and t < 3.0
        if early:
            break
        k += 1
    assert handling and t == pytest.approx(2.111427723, abs=1e-9)
    return f, t


def test_state_taken_with_an_event_pending_is_restored(fmi3_build):
    """Event Mode used: a state taken when fmi3DoStep returned early with eventHandlingNeeded (its
    update still the master's) is set back and handled again alike: the same update
    (fmi3UpdateDiscreteStates' results, the states it leaves), the same steps after."""
    f, t = at_pending_update(fmi3_build)
    states = [d.variable.derivative.name for d in f.md.derivatives]
    try:
        before = f.get(*states)
        updates = []

        def handle_and_continue():
            f.fmu3.enterEventMode()
            update = f.update_discrete_states()
            after = f.get(*states)
            f.fmu3.enterStepMode()
            rows = continue_cs(f, t, t + 0.5, 0.01)
            updates.append((update, after))
            return np.concatenate([update, after, rows.ravel(), f.get(*states)])
        repeated_after_restore(f, handle_and_continue)
        (update, after), *_ = updates
        assert update[0] == 0 and update[4]  # fmi3OK, valuesOfContinuousStatesChanged: applied
        assert after != before  # the update changed the states
        assert f.get("gamma_dot") == 0.0  # the wheel holds on the slope after it
        assert [m for m in f.messages if m[0] > 0] == []
    finally:
        f.free()


def test_state_whose_pending_update_and_word_disagree_is_refused(fmi3_build):
    """The pending update is in the core's event bytes (bit 1: fires when it is applied) and in the
    FMI 3 word (event pending): a state with one and not the other is refused, reason logged."""
    f, _ = at_pending_update(fmi3_build)
    try:
        blob = bytes(f.fmu3.serializeFMUState(f.fmu3.getFMUState()))
        pending = [i for i in range(read(blob, "ne")) if read(blob, f"flags[{i}]") & 2]
        assert pending and read(blob, "front_word") & PENDING
        cases = [({f"flags[{i}]": read(blob, f"flags[{i}]") & 1 for i in pending},
                  "an event pending for Event Mode but no update event to apply"),
                 ({"front_word": read(blob, "front_word") & ~PENDING},
                  f"event flag {pending[0]} = {read(blob, f'flags[{pending[0]}]')} (must be 0 or 1)")]
        for values, reason in cases:
            n = len(f.messages)
            with pytest.raises(FMICallException):
                f.fmu3.deserializeFMUState(changed(blob, **values))
            assert reason in "\n".join(m for _, _, m in f.messages[n:]), reason
    finally:
        f.free()


def continue_me(f, t: float, until: float, h: float = 0.01) -> np.ndarray:
    """Classical RK4 through Model Exchange from t to `until`, a state event handled at the end
    of the step in which an indicator changes sign (fmi3EnterEventMode, fmi3UpdateDiscreteStates):
    every output and state after every step."""
    rows = []
    z = np.zeros(f.nz)
    for k in range(round((until - t) / h)):
        t0 = t + k * h
        x = f.states()
        f.fmu3.getEventIndicators(f._ptr(z), f.nz)
        z0 = z.copy()
        stages = []
        for c, a in ((0.0, 0.0), (0.5, 0.5), (0.5, 0.5), (1.0, 1.0)):
            f.set_states(t0 + c * h, x + a * h * (stages[-1] if stages else 0.0))
            stages.append(f.derivatives())
        f.set_states(t0 + h, x + h / 6 * (stages[0] + 2 * stages[1] + 2 * stages[2] + stages[3]))
        f.fmu3.getEventIndicators(f._ptr(z), f.nz)
        if np.any((z0 > 0) & (z <= 0)):
            f.fmu3.enterEventMode()
            while f.fmu3.updateDiscreteStates()[0]:
                pass
            f.fmu3.enterContinuousTimeMode()
        rows.append(list(f.get(*outputs(f))) + list(f.states()))
    return np.array(rows, dtype=float)


def test_model_exchange_state_restored_and_continued_bit_identically(fmi3_build):
    fmu = fmi3_build("slope_hold").fmu
    f = Instance3(fmu, "ME")
    try:
        f.init()
        while f.fmu3.updateDiscreteStates()[0]:
            pass
        f.fmu3.enterContinuousTimeMode()
        continue_me(f, 0.0, 1.5)
        first, _ = repeated_after_restore(f, lambda: continue_me(f, 1.5, 3.0))
        i_gd = outputs(f).index("gamma_dot")
        i_mode = len(outputs(f)) + [d.variable.derivative.name for d in f.md.derivatives].index("rolling_mode")
        assert first[0, i_gd] < 0.0 and first[0, i_mode] == -1.0  # rolling uphill
        assert first[-1, i_gd] == 0.0 and first[-1, i_mode] == 0.0  # stopped and held: the switch was crossed
        assert [m for m in f.messages if m[0] > 0] == []
    finally:
        f.free()


@pytest.mark.parametrize("source", ["another_scene", "fmi2_of_the_same_scene"])
def test_state_of_another_fmu_is_refused(source, fmi3_build, example_build):
    """paper_moon's FMI 3.0 state (another model token) or the FMI 2.0 paper_earth FMU's state
    deserialized into the paper_earth FMI 3.0 FMU: fmi3Error, the reason logged."""
    if source == "another_scene":
        donor = Instance3(fmi3_build("paper_moon").fmu, name="donor")
        donor.init()
        donor.fmu3.doStep(0.0, 1.0)
        blob = donor.fmu3.serializeFMUState(donor.fmu3.getFMUState())
        donor.free()
        reason = "fmi3DeserializeFMUState: FMU state belongs to another model"
    else:
        s, blob = rolled_state(example_build("paper_earth").fmu)
        s.free()
        reason = "FMU state"  # its model token is the FMI 2.0 build's
    f = Instance3(fmi3_build("paper_earth").fmu)
    try:
        f.init()
        with pytest.raises(FMICallException) as refused:
            f.fmu3.deserializeFMUState(blob)
        assert refused.value.status == FMI3_ERROR
        errors = [m for st, _, m in f.messages if st == FMI3_ERROR]
        assert len(errors) == 1 and errors[0].startswith("fmi3DeserializeFMUState: ") and reason in errors[0], errors
    finally:
        f.free()
