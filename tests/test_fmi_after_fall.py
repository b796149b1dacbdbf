"""After the wheel falls, importers keep calling; the FMU stays terminated and truthful and never
turns their habits into errors (docs/fmi.md, "After the simulation terminated").

Each importer's pattern is reproduced exactly as a call sequence on fmpy's FMU2Model/FMU2Slave
(paper_earth without spin: the wheel falls flat at t = 0.433 s). What the FMU answers, and what a
strict reading of the state machine would answer instead:
  OMSimulator 3.0, FMU Compliance Checker (ME)  fmi2NewDiscreteStates -> terminateSimulation,
                                                then fmi2EnterContinuousTimeMode once more
      answer:    fmi2OK; fmi2CompletedIntegratorStep keeps saying terminateSimulation; fmi2Terminate OK
      not:       fmi2Error, Error state, fmi2Terminate refused ("illegal call in state Error")
  ecospy 0.7.2 (CS)    ignores fmi2Discard and steps on to the stop time
      answer:    fmi2Discard for every further step, one logged line plus "(repeated N more times)"
      not:       fmi2Error, then one "illegal call in state Error" line per step (1956 lines for
                 euler_disk to 30 s)
  PyFMI 2.21 (CS)      fmi2Terminate twice (the second from the model's destructor)
      answer:    fmi2Warning, ignored, logged
      not:       fmi2Error "illegal call in state Terminated"
"""
from __future__ import annotations

import math

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated

from conftest import STATES
from fmi_helpers import Model, Slave

NO_SPIN = {"gamma_dot": 0.0}  # falls flat (beta = beta_min) at t = 0.4335 s
T_FALL = 0.4335


def _errors(inst) -> list[str]:
    return [m for status, _, m in inst.messages if status >= 3]


def _to_the_fall_me(m: Model) -> float:
    """A minimal ME importer (explicit Euler, 0.1 ms, bisection on the indicator) up to the fall."""
    m.init(**NO_SPIN)
    need, term, *_ = m.fmu2.newDiscreteStates()
    assert not need and not term
    m.fmu2.enterContinuousTimeMode()
    t, h = 0.0, 1e-4
    x, z = m.states(), m.indicators()
    while t < 1.0:
        xn = x + h * m.derivatives()
        m.set_states(t + h, xn)
        zn = m.indicators()
        if z[0] > 0 >= zn[0]:
            break
        t, x, z = t + h, xn, zn
        m.fmu2.completedIntegratorStep()
    else:
        pytest.fail("the wheel did not fall")
    m.fmu2.enterEventMode()
    need, term, *_ = m.fmu2.newDiscreteStates()
    assert term and not need
    return t


def test_me_enter_continuous_time_mode_after_terminate_simulation(earth_fmu):
    """OMSimulator / Compliance Checker: fmi2EnterContinuousTimeMode after terminateSimulation."""
    m = Model(earth_fmu)
    try:
        _to_the_fall_me(m)
        m.fmu2.enterContinuousTimeMode()  # accepted: not fmi2Error, the instance not in Error
        enter, term = m.fmu2.completedIntegratorStep()
        assert term and not enter  # still terminated, truthfully
        assert m.get("fallen") is True
        beta = m.get("beta")  # where this importer's Euler step (0.1 ms) crossed beta_min
        assert math.isfinite(beta) and 0.0 < beta <= m.get("beta_min")
        m.fmu2.terminate()  # accepted, not "fmi2Terminate: illegal call in state Error"
        assert all(math.isfinite(v) for v in m.get(*STATES))
        assert _errors(m) == []
        m.fmu2.reset()
        m.init()
    finally:
        m.free()


def test_cs_steps_after_the_fall_are_discarded_and_logged_once(earth_fmu):
    """ecospy: fmi2DoStep to the stop time after the fall; 950 further steps."""
    s = Slave(earth_fmu, logging_on=False)
    try:
        s.init(**NO_SPIN)
        t, h, statuses = 0.0, 0.01, []
        while t < 10.0 - 1e-9:
            try:
                s.slave.doStep(t, h)
                statuses.append(0)
            except FMICallException as exc:
                statuses.append(exc.status)
            t += h
        n_after = len(statuses) - statuses.index(2) - 1
        assert n_after > 950 and set(statuses[statuses.index(2):]) == {2}  # fmi2Discard, not fmi2Error
        t_fall = s.slave.getRealStatus(fmi2LastSuccessfulTime)
        assert t_fall == pytest.approx(T_FALL, abs=1e-3)
        assert s.slave.getBooleanStatus(fmi2Terminated)
        assert s.get("beta") == pytest.approx(s.get("beta_min"), abs=1e-9)
        # the fall's reason and the refused steps, each logged once whatever the logging
        # settings (not: the fall unlogged, then 950 "illegal call in state Error")
        assert len(s.messages) == 2, s.messages
        assert "fall at t=0.43" in s.messages[0][2] and s.messages[0][0] == 2
        assert "no further step is computed" in s.messages[1][2] and s.messages[1][0] == 2
        s.slave.terminate()
        assert s.messages[2][2] == f"(the previous message was repeated {n_after - 1} more times)"
        assert _errors(s) == []
        assert s.get("beta") == pytest.approx(s.get("beta_min"), abs=1e-9)
    finally:
        s.free()


def test_second_terminate_is_ignored_with_a_warning(earth_fmu):
    """PyFMI: fmi2Terminate, then again from the model's destructor."""
    s = Slave(earth_fmu)
    try:
        s.init(**NO_SPIN)
        with pytest.raises(FMICallException):
            s.slave.doStep(0.0, 1.0)  # the fall: fmi2Discard
        s.slave.terminate()
        status = s.raw("fmi2Terminate")  # raw: fmpy accepts a warning silently
        assert status == 1  # fmi2Warning, not fmi2Error "illegal call in state Terminated"
        assert "fmi2Terminate: already terminated; the call is ignored" in s.log_text()
        assert _errors(s) == []
        s.slave.reset()
    finally:
        s.free()


def test_terminate_after_an_error_keeps_the_last_consistent_state(earth_fmu):
    """A master's clean-up after fmi2Error: fmi2Terminate works (fmi2Warning), the state is the
    one before the failed call, fmi2Reset and fmi2FreeInstance work."""
    s = Slave(earth_fmu)
    try:
        s.init()
        s.slave.doStep(0.0, 0.5)
        before = s.get(*STATES)
        with pytest.raises(FMICallException) as exc:
            s.slave.doStep(0.7, 0.1)  # wrong communication point: fmi2Error
        assert exc.value.status == 3
        assert s.raw("fmi2Terminate") == 1
        assert "called after an fmi2Error" in s.log_text()
        assert s.get(*STATES) == before
        s.slave.reset()
        s.init()
    finally:
        s.free()


def test_terminate_before_initialisation_is_refused_reset_works(earth_fmu):
    s = Slave(earth_fmu)
    try:
        s.slave.setupExperiment(startTime=0.0)
        s.slave.enterInitializationMode()
        with pytest.raises(FMICallException):
            s.slave.terminate()
        assert "illegal call in state InitializationMode" in s.log_text()
        s.slave.reset()
        s.init()
        s.slave.doStep(0.0, 0.1)
    finally:
        s.free()


def test_fall_after_a_logged_run_in_the_same_process(earth_fmu):
    """fmpy's logger proxy is process-global: after simulate_fmu(logger=...) (gyrowheel simulate)
    returned, an FMU on fmpy's default callbacks that logs (the fall's fmi2Discard reason, logged
    always) called a freed callback and crashed the process. gyrowheel.simulation restores a living
    logger after every run."""
    from fmpy import simulate_fmu

    from gyrowheel.simulation import Messages, run
    messages = Messages()
    r = run(earth_fmu, stop_time=1.0, start_values=NO_SPIN, messages=messages)
    assert r["time"][-1] == pytest.approx(T_FALL, abs=1e-3)
    assert any("fall at t=0.43" in m for _, m in messages.lines)
    r = simulate_fmu(str(earth_fmu), stop_time=1.0, start_values=NO_SPIN)  # default callbacks
    assert r["time"][-1] == pytest.approx(T_FALL, abs=1e-3)
