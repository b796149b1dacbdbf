"""An instance refused a call before its initialisation has ended keeps its start values.

FMI puts an instance that returned fmi2Error / fmi3Error into the Error state, where the getters
and the partial derivatives still answer (FMI 2.0.4 section 4.3.4, FMI 3.0.2 section 4.2.5;
docs/fmi.md, "Variables and their types", "Directional and adjoint derivatives"). Before the end
of the initialisation they answer from the start values (the state x = init(s, p) and what follows
from it), and so they must after such an error: not from an uninitialised state of zeros
(where a load-proportional law even divides by zero). Checked in both versions, in Instantiated and
in Initialization Mode, by value against the same call before the error, and through an FMU state
taken in Error and set into another instance.
"""
from __future__ import annotations

import ctypes as C

import pytest

from fmi3_helpers import ERROR, Slave3
from fmi_helpers import Slave


def _pair(md):
    """An InitialUnknown and one variable it depends on: (unknown vr, known vr)."""
    u = next(u for u in md.initialUnknowns if u.dependencies)
    return u.variable.valueReference, u.dependencies[0].valueReference


@pytest.mark.parametrize("mode", ["instantiated", "initialization"])
def test_fmi2_getters_and_partials_answer_from_the_start_values_after_an_error(earth_fmu, mode):
    s = Slave(earth_fmu)
    s.fmu2.setupExperiment(startTime=0.0)
    s.set(beta=1.2, gamma_dot=7.0)
    if mode == "initialization":
        s.fmu2.enterInitializationMode()
    names = ["beta", "gamma_dot", "vx", "energy"]
    before = [s.get(n) for n in names]
    unknown, known = _pair(s.md)
    if mode == "initialization":
        d_before = s.fmu2.getDirectionalDerivative([unknown], [known], [1.0])[0]
    value = (C.c_double * 1)()
    assert s.raw("fmi2GetReal", (C.c_uint * 1)(99999), C.c_size_t(1), value) == 3  # fmi2Error
    assert "99999" in s.log_text()
    assert [s.get(n) for n in names] == before
    assert before[:2] == [1.2, 7.0]
    if mode == "initialization":
        assert s.fmu2.getDirectionalDerivative([unknown], [known], [1.0])[0] == d_before
    state = s.fmu2.getFMUstate()
    other = Slave(earth_fmu)
    other.fmu2.setFMUstate(state)
    assert [other.get(n) for n in names] == before
    s.fmu2.freeFMUstate(state)


@pytest.mark.parametrize("scene", ["paper_earth", "slope_hold"])
def test_fmi3_getters_and_partials_answer_from_the_start_values_after_an_error(fmi3_fmu, scene):
    """slope_hold: rolling resistance and pivot friction, proportional to the normal force, whose
    outputs were NaN from a state of zeros."""
    s = Slave3(fmi3_fmu(scene))
    s.set(beta=1.3)
    s.fmu3.enterInitializationMode(startTime=0.0)
    names = [v.name for v in s.md.modelVariables if v.causality == "output" and v.type == "Float64"]
    unknown, known = _pair(s.md)
    d_before = s.fmu3.getDirectionalDerivative([unknown], [known], [1.0], nSensitivity=1)[0]
    # a refused call: x_state read with too few values
    assert s.raw("fmi3GetFloat64", (C.c_uint * 1)(s.vr("x_state")), C.c_size_t(1), (C.c_double * 1)(),
                 C.c_size_t(1)) == ERROR
    after = {n: s.get(n) for n in names}
    assert after["x_state"][3] == after["beta"] == 1.3  # x, y, alpha, beta, ...
    s2 = Slave3(fmi3_fmu(scene))
    s2.set(beta=1.3)
    s2.fmu3.enterInitializationMode(startTime=0.0)
    assert after == {n: s2.get(n) for n in names}  # the same as without the error
    assert s.fmu3.getDirectionalDerivative([unknown], [known], [1.0], nSensitivity=1)[0] == d_before
