"""The wheel's fall (a terminating event) through FMI 3.0, and what importers call afterwards.

paper_earth without spin falls flat (beta = beta_min) at t = 0.4335 s. In Co-Simulation the step
that contains the fall returns fmi3OK at the located event with terminateSimulation = true,
lastSuccessfulTime = the event time (the very number FMI 2.0's fmi2LastSuccessfulTime gives for the
same step: the same core locates it) and earlyReturn = earlyReturnAllowed; every later fmi3DoStep
answers fmi3Discard (the reason logged once) with terminateSimulation; fmi3Terminate, the last
state's values, fmi3Reset and a new run work. In Model Exchange fmi3UpdateDiscreteStates at the
fall says terminateSimulation."""
from __future__ import annotations

import ctypes as C
import math

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime

from conftest import STATES
from fmi3_helpers import DISCARD, ERROR, OK, WARNING, Model3, Slave3
from fmi_helpers import Slave

NO_SPIN = {"gamma_dot": 0.0}
T_FALL = 0.4335


def _errors(inst) -> list[str]:
    return [m for status, _, m in inst.messages if status >= ERROR]


@pytest.fixture(scope="module")
def fmi2_fall(earth_fmu):
    """FMI 2.0: fmi2DoStep(0, 1) over the fall; (fmi2LastSuccessfulTime, the states there)."""
    s = Slave(earth_fmu, logging_on=False)
    try:
        s.init(**NO_SPIN)
        with pytest.raises(FMICallException):
            s.slave.doStep(0.0, 1.0)
        return s.slave.getRealStatus(fmi2LastSuccessfulTime), s.get(*STATES)
    finally:
        s.free()


@pytest.mark.parametrize("early_return_allowed", [True, False], ids=["earlyReturnAllowed", "no-earlyReturn"])
@pytest.mark.parametrize("event_mode_used", [False, True], ids=["", "eventModeUsed"])
def test_cs_fall_ends_the_step_at_the_event_as_fmi2_does(fmi3_earth_fmu, fmi2_fall, early_return_allowed,
                                                         event_mode_used):
    t2, x2 = fmi2_fall
    s = Slave3(fmi3_earth_fmu, event_mode_used=event_mode_used, early_return_allowed=early_return_allowed)
    try:
        s.init(**NO_SPIN)
        if event_mode_used:
            assert s.update_discrete_states()[0] == OK
            assert s.raw("fmi3EnterStepMode") == OK
        status, need, term, early, last = s.do_step(0.0, 1.0)
        assert status == OK and term and not need
        assert early == early_return_allowed  # earlyReturn only where allowed; the state is the located one anyway
        assert last == t2 and last == pytest.approx(T_FALL, abs=1e-3)  # exactly FMI 2's number
        assert s.get(*STATES) == x2  # the state at the located event, as FMI 2's
        assert s.get("beta") == pytest.approx(s.get("beta_min"), abs=1e-9)
        assert s.fmu3.getFloat64([0])[0] == last  # time, value reference 0
        assert _errors(s) == []
    finally:
        s.free()


def test_cs_calls_after_the_fall(fmi3_earth_fmu, fmi2_fall):
    """An importer stepping on to its stop time, then terminating, reading, resetting."""
    t2, x2 = fmi2_fall
    s = Slave3(fmi3_earth_fmu, logging_on=False, early_return_allowed=True)
    try:
        s.init(**NO_SPIN)
        status, _, term, early, t = s.do_step(0.0, 1.0)
        assert status == OK and term and early
        n = len(s.messages)
        answers = [s.do_step(t + k * 0.01, 0.01) for k in range(50)]
        assert {a[0] for a in answers} == {DISCARD}  # not fmi3Error: the instance is not in Error
        assert all(a[2] for a in answers)  # terminateSimulation each time
        said = s.messages[n:]
        assert said and said[0][0] == DISCARD and said[0][2].startswith("fmi3DoStep: ")
        assert len(said) == 1, said  # logged once, the repeats counted
        assert s.get(*STATES) == x2  # the refused steps changed nothing
        assert s.raw("fmi3Terminate") == OK
        assert "(the previous message was repeated 49 more times)" in s.log_text()
        assert s.get(*STATES) == x2  # the last state stays readable in Terminated
        assert s.raw("fmi3Terminate") == WARNING  # a second one (an importer's destructor): ignored
        assert "fmi3Terminate: already terminated" in s.log_text()
        assert _errors(s) == []
        assert s.raw("fmi3Reset") == OK
        s.init()  # spinning: no fall within 1 s
        status, need, term, early, last = s.do_step(0.0, 1.0)
        assert status == OK and not term and not early and last == 1.0
        assert math.isfinite(s.get("beta")) and s.get("beta") > s.get("beta_min")
    finally:
        s.free()


def test_cs_step_from_a_wrong_time_after_the_fall_is_still_discarded(fmi3_earth_fmu):
    """After the terminating event no step is computed, whatever the communication point."""
    s = Slave3(fmi3_earth_fmu, logging_on=False)
    try:
        s.init(**NO_SPIN)
        assert s.do_step(0.0, 1.0)[:3] == (OK, False, True)
        assert s.do_step(5.0, 0.1)[0] == DISCARD
    finally:
        s.free()


def test_me_update_discrete_states_says_terminate_simulation(fmi3_earth_fmu):
    """A minimal ME importer (explicit Euler, 0.1 ms) up to the fall indicator's sign change, then
    Event Mode: terminateSimulation; fmi3Terminate and the values at the fall."""
    m = Model3(fmi3_earth_fmu, logging_on=False)
    try:
        m.init(**NO_SPIN)
        status, need, term, *_ = m.update_discrete_states()
        assert status == OK and not need and not term
        assert m.raw("fmi3EnterContinuousTimeMode") == OK
        nx, nz = m.nx, m.nz
        x, dx, z = (C.c_double * nx)(), (C.c_double * nx)(), (C.c_double * nz)()
        assert m.raw("fmi3GetContinuousStates", x, nx) == OK
        assert m.raw("fmi3GetEventIndicators", z, nz) == OK
        fall = [k for k, e in enumerate(m.md.eventIndicators) if e.variable.name.startswith("fall")]
        assert fall, [e.variable.name for e in m.md.eventIndicators]
        k = fall[0]
        t, h, z0 = 0.0, 1e-4, z[k]
        while t < 1.0:
            assert m.raw("fmi3GetContinuousStateDerivatives", dx, nx) == OK
            xn = (C.c_double * nx)(*[x[i] + h * dx[i] for i in range(nx)])
            t += h
            assert m.raw("fmi3SetTime", C.c_double(t)) == OK
            assert m.raw("fmi3SetContinuousStates", xn, nx) == OK
            assert m.raw("fmi3GetEventIndicators", z, nz) == OK
            if (z0 > 0) != (z[k] > 0):
                break
            x, z0 = xn, z[k]
            enter, stop = C.c_bool(), C.c_bool()
            assert m.raw("fmi3CompletedIntegratorStep", C.c_bool(True), C.byref(enter), C.byref(stop)) == OK
            assert not stop.value
        else:
            pytest.fail("the wheel did not fall")
        assert t == pytest.approx(T_FALL, abs=2e-3)
        assert m.raw("fmi3EnterEventMode") == OK
        status, need, term, *_ = m.update_discrete_states()
        assert status == OK and term and not need
        assert m.get("fallen") is True
        assert m.raw("fmi3Terminate") == OK
        assert all(math.isfinite(v) for v in m.get(*STATES))
        assert _errors(m) == []
        assert m.raw("fmi3Reset") == OK
        m.init()
    finally:
        m.free()
