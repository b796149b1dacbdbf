"""fmi3DoStep returns early at the events it locates inside a communication step (FMI 3.0.2
section 4.2.2, docs/fmi.md): at the fall (terminateSimulation) and, with earlyReturnAllowed, at
the mode switches of stiction (update events), where with eventModeUsed the master handles the
event in Event Mode (fmi3EnterEventMode, fmi3UpdateDiscreteStates, fmi3EnterStepMode).

The reference is the FMI 2.0 FMU of the same scene, which handles every event inside its
fmi2DoStep: its fmi2LastSuccessfulTime at the fall and the event times it logs in category
logEvents ("event NAME at t=%.17g", exact to the last bit).
"""
from __future__ import annotations

import ctypes

import pytest

from fmi3_helpers import Instance3, event_times
from fmi_helpers import Slave

FMI2_OK, FMI2_DISCARD = 0, 2
FMI3_OK, FMI3_DISCARD = 0, 2
LAST_SUCCESSFUL_TIME = 2  # fmi2StatusKind fmi2LastSuccessfulTime


def outputs(inst) -> list[str]:
    """The scalar Float64 outputs and continuous states (FMI 2.0 and 3.0 FMUs name them alike; the
    FMI 3 array outputs repeat them)."""
    states = {d.variable.derivative.name for d in inst.md.derivatives}
    return [v.name for v in inst.md.modelVariables if v.type in ("Real", "Float64") and not v.dimensions
            and (v.causality == "output" or v.name in states)]


def run_fmi2(fmu, dt: float, stop: float, **start):
    """fmi2DoStep over the grid k dt until stop or the terminating event: (final time,
    terminated, [(event, t)] logged, {output: value}, instance)."""
    s = Slave(fmu)
    s.init(**start)
    t, k, terminated = 0.0, 0, False
    while t < stop - 1e-12:
        t_next = min((k + 1) * dt, stop)
        st = s.raw("fmi2DoStep", ctypes.c_double(t), ctypes.c_double(t_next - t), 1)
        if st == FMI2_DISCARD:
            terminated = True
            t = s.fmu2.getRealStatus(LAST_SUCCESSFUL_TIME)
            break
        assert st == FMI2_OK, s.log_text()
        t, k = t_next, k + 1
    values = dict(zip(outputs(s), s.get(*outputs(s))))
    return t, terminated, event_times([m for _, _, m in s.messages]), values, s


def run_fmi3(fmu, dt: float, stop: float, event_mode_used: bool, early_return_allowed: bool, **start):
    """A master over the same grid that continues from lastSuccessfulTime after an early return and,
    with eventModeUsed, handles eventHandlingNeeded in Event Mode: (final time, terminated,
    [(early-return time, eventHandlingNeeded)], {output: value}, instance)."""
    f = Instance3(fmu, event_mode_used=event_mode_used, early_return_allowed=early_return_allowed)
    f.set(**start)
    f.fmu3.enterInitializationMode(startTime=0.0)
    f.fmu3.exitInitializationMode()
    if event_mode_used:  # out of Initialization Mode into Event Mode
        while f.fmu3.updateDiscreteStates()[0]:
            pass
        f.fmu3.enterStepMode()
    t, k, terminated, returns = 0.0, 0, False, []
    while t < stop - 1e-12:
        t_next = min((k + 1) * dt, stop)
        st, handling, terminate, early, last = f.do_step(t, t_next - t)
        assert st == FMI3_OK, f.log_text()
        assert early == (last < t_next) or (terminate and not early_return_allowed), (t, t_next, last, early)
        assert early_return_allowed or not early
        assert event_mode_used or not handling
        if early:
            returns.append((last, handling))
        if terminate:
            terminated = True
            t = last
            break
        if handling:  # the switch is still to come: the master's fmi3UpdateDiscreteStates makes it
            before = f.get(*outputs(f))
            f.fmu3.enterEventMode()
            needs_update, terminate_after, *_ = f.fmu3.updateDiscreteStates()
            assert not needs_update and not terminate_after
            f.fmu3.enterStepMode()
            assert f.get(*outputs(f)) != before
        t = last
        if t == t_next:
            k += 1
    values = dict(zip(outputs(f), f.get(*outputs(f))))
    return t, terminated, returns, values, f


FALLS = [  # scene, start values, communication step, stop: a fall inside a step
    ("paper_earth", {"gamma_dot": 0.0}, 0.1, 2.0),  # without spin it falls at 0.4335 s
    ("euler_disk", {}, 0.05, 20.0),  # the scene's own fall, 10.4295 s
    ("lunar_rover", {}, 0.02, 30.0),  # after slips (warnings) and a stick (update), 17.4748 s
]


@pytest.mark.parametrize("early_return_allowed", [True, False], ids=["early_return", "no_early_return"])
@pytest.mark.parametrize("scene, start, dt, stop", FALLS, ids=[c[0] for c in FALLS])
def test_fall_ends_the_step_where_fmi2_does(scene, start, dt, stop, early_return_allowed, example_build,
                                            fmi3_build):
    """The step with the fall: fmi3OK, terminateSimulation, lastSuccessfulTime exactly FMI 2.0's
    fmi2LastSuccessfulTime, earlyReturn as allowed, the state there FMI 2.0's.  A further step:
    fmi3Discard, terminateSimulation again, its reason logged."""
    t2, fell2, _, y2, s = run_fmi2(example_build(scene).fmu, dt, stop, **start)
    assert fell2 and t2 < stop
    t3, fell3, returns, y3, f = run_fmi3(fmi3_build(scene).fmu, dt, stop, False, early_return_allowed, **start)
    try:
        assert fell3 and t3 == t2
        if early_return_allowed:  # the last early return is the fall's (update events return early too)
            assert returns[-1] == (t2, False)
        else:
            assert returns == []
        assert y3 == y2
        assert f.get("fallen") or f.get("lifted_off")
        grid = (int(t2 / dt) + 1) * dt
        st, handling, terminate, early, last = f.do_step(t3 if early_return_allowed else grid, dt)
        assert (st, handling, terminate, early, last) == (FMI3_DISCARD, False, True, False, t2)
        assert f"fmi3DoStep: the simulation terminated at t={t2:.17g}" in f.log_text()
        assert [m for m in f.messages if m[0] == FMI3_DISCARD][-1][2].startswith("fmi3DoStep: ")
    finally:
        s.free()
        f.free()


STICK_SLIP = [  # scene, communication step, stop
    ("slope_hold", 0.01, 6.0),  # stops (2.111 s), held, tips over: slip, break-away, lift-off (5.700 s)
    ("paper_earth_friction", 0.01, 20.0),  # 33 pivot stick/slip switches
]


@pytest.mark.parametrize("event_mode_used", [True, False], ids=["event_mode", "no_event_mode"])
@pytest.mark.parametrize("scene, dt, stop", STICK_SLIP, ids=[c[0] for c in STICK_SLIP])
def test_mode_switches_return_early_at_fmi2s_event_times(scene, dt, stop, event_mode_used, example_build,
                                                         fmi3_build):
    """With earlyReturnAllowed every update event ends its step at the time FMI 2.0 locates it;
    with eventModeUsed the switch is the master's (eventHandlingNeeded, Event Mode), otherwise
    applied inside.  The run ends where FMI 2.0's does, with its outputs."""
    t2, fell2, events2, y2, s = run_fmi2(example_build(scene).fmu, dt, stop)
    updates = [(name, t) for name, t in events2 if name in ("rolling_stiction", "pivot_stiction")]
    assert len(updates) >= 2
    t3, fell3, returns, y3, f = run_fmi3(fmi3_build(scene).fmu, dt, stop, event_mode_used, True)
    try:
        terminal = [(t2, False)] if fell2 else []
        assert fell3 == fell2 and t3 == t2
        assert [t for t, _ in returns] == [t for _, t in updates] + [t for t, _ in terminal]
        assert all(handling == event_mode_used for _, handling in returns[:len(updates)])
        assert events2 == event_times(f.log())  # the same events, named alike, at the same times
        worst = max(abs(y3[n] - y2[n]) / max(1.0, abs(y2[n])) for n in y2)
        print(f"{scene}: {len(updates)} early returns at FMI 2.0's event times, outputs at t={t2} "
              f"within {worst:.3g}")
        assert worst <= 1e-12
    finally:
        s.free()
        f.free()
