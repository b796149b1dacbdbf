"""The event indicators' hoisted parameter part (evt(t, x, u, p, c): c computed once per parameter
change) in Model Exchange: a tunable parameter set in Event Mode is seen by the next
fmi2GetEventIndicators without a step, a restored FMU state brings its own parameters' c back,
fmi2Reset and a new start value give the new c, and two instances with different parameters
keep their own c.
"""
from __future__ import annotations

import ctypes
import math

import casadi as ca
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Model

from gyrowheel.fmu_build.builder import build_spec_fmu
from gyrowheel.model.system import System


@pytest.fixture(scope="module")
def threshold_fmu(tmp_path_factory):
    """x' = -1 from 1, event x - 2 sin(thr) (2 sin(thr) hoisted), thr tunable"""
    s = System("thr", "a falling value and a tunable threshold")
    thr = s.parameter("thr", 0.2, "1", "threshold", tunable=True)
    x = s.state("x", 1.0, "1", "value")
    s.der(x, ca.SX(-1.0))
    s.event("low", x - 2.0 * ca.sin(thr), "terminate", "is_low")
    return str(build_spec_fmu(s.spec(), tmp_path_factory.mktemp("thr") / "thr.fmu").fmu)


def _indicator(m: FMU2Model) -> float:
    z = (ctypes.c_double * 1)()
    m.getEventIndicators(z, 1)
    return z[0]


def _expected(thr: float, x: float = 1.0) -> float:
    return x - 2.0 * math.sin(thr)


def test_hoisted_event_indicator_follows_parameters_in_model_exchange(threshold_fmu):
    md = read_model_description(threshold_fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}["thr"]
    d = extract(threshold_fmu)
    a, b = (FMU2Model(guid=md.guid, unzipDirectory=d, modelIdentifier=md.modelExchange.modelIdentifier,
                      instanceName=n) for n in "ab")
    for m, thr in ((a, 0.2), (b, 0.35)):
        m.instantiate()
        m.setupExperiment(startTime=0.0)
        m.setReal([vr], [thr])
        m.enterInitializationMode()
        assert _indicator(m) == pytest.approx(_expected(thr), abs=1e-15)
        m.exitInitializationMode()
        m.newDiscreteStates()
        m.enterContinuousTimeMode()
    assert _indicator(a) == pytest.approx(_expected(0.2), abs=1e-15)
    a.enterEventMode()
    a.setReal([vr], [0.3])  # tunable, in Event Mode: no step before the indicators are read
    assert _indicator(a) == pytest.approx(_expected(0.3), abs=1e-15)
    assert _indicator(b) == pytest.approx(_expected(0.35), abs=1e-15)  # its own c
    state = a.getFMUstate()
    a.setReal([vr], [0.4])
    assert _indicator(a) == pytest.approx(_expected(0.4), abs=1e-15)
    a.setFMUstate(state)  # thr = 0.3 again, and its c
    assert _indicator(a) == pytest.approx(_expected(0.3), abs=1e-15)
    a.freeFMUstate(state)
    a.reset()
    a.setupExperiment(startTime=0.0)
    a.enterInitializationMode()  # the start value again
    assert _indicator(a) == pytest.approx(_expected(0.2), abs=1e-15)
    b.terminate()
    for m in (a, b):
        m.freeInstance()
