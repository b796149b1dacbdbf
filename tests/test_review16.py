"""Review of the Taylor rewrite and the hoisted event indicators (branches graphopt, enslow).

- a system whose derivatives are all constant (x' = k): its Taylor kernel has no node with a
  series, and the FMU built with it must still compile under -Wall -Wextra -Werror and integrate;
- the hoisted event indicator evt(t, x, u, p, c) in Model Exchange: a tunable parameter set in
  Event Mode is seen by the next fmi2GetEventIndicators without a step, a restored FMU state
  brings its own parameters' c back, fmi2Reset and a new start value give the new c, and two
  instances with different parameters keep their own c;
- the rewrite (taylor/rewrite.py) on random graphs of every supported kind of op, with
  parameters 0, negative and infinite, against the un-rewritten kernel.
"""
from __future__ import annotations

import ctypes
import math
import random

import casadi as ca
import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model

from gyrowheel.fmu_build.builder import build_spec_fmu
from gyrowheel.fmu_build.codegen import optimised
from gyrowheel.taylor.graph import decompose
from gyrowheel.model.system import System
from test_taylor_rewrite import Jet


def test_taylor_kernel_of_constant_derivatives_builds(tmp_path):
    """x' = k: no node of the kernel has a series (its vk was set but never read: -Werror)."""
    s = System("ramp", "x' = k")
    k = s.parameter("k", 2.0, "1/s", "rate")
    x = s.state("x", 0.5, "1", "value")
    s.der(x, k)
    fmu = build_spec_fmu(s.spec(), tmp_path / "ramp.fmu", taylor=True).fmu
    r = simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.25, start_values={"solver": 6})
    np.testing.assert_allclose(r["x"], 0.5 + 2.0 * r["time"], rtol=0, atol=1e-14)


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


def _random_expr(rng: random.Random, x: ca.SX, p: ca.SX, t: ca.SX, depth: int) -> ca.SX:
    """a random expression of the states, parameters and time: every rewrite rule's pattern
    (factors, reciprocals, x (c x), a (c b + d), shared products) among nonlinear ops"""
    if depth == 0 or rng.random() < 0.2:
        return rng.choice([x[0], x[1], x[2], p[0], p[1], p[2], t, ca.SX(rng.choice([0.0, -1.5, 2.0]))])
    a, b = _random_expr(rng, x, p, t, depth - 1), _random_expr(rng, x, p, t, depth - 1)
    c = rng.choice([p[0], p[1], p[2], 2.0, -0.5])
    return rng.choice([
        a + b, a - b, a * b, c * a, a / (b * b + 1.5), a / c, c / (2.0 * (a * a + 1.0)), -a, 2 * a,
        ca.sin(a), ca.cos(0.5 * a), ca.exp(0.3 * ca.sin(a)), ca.sqrt(a * a + 1.0), ca.atan2(a, b + 3.0),
        (a * a + 1.0) ** 1.5, (a * a + 1.0) ** (0.3 * ca.sin(b)), ca.tanh(a), ca.fabs(a),
        ca.fmin(a, b), ca.fmax(a, b), ca.if_else(a > 0.1, b, 2.0 * a), ca.atan(a), ca.log(a * a + 2.0),
        (a * b) * (c * a) + (b * a) / (a * a + 1.0), a * (c * a), a * (c * b - p[1]) + a])


@pytest.mark.parametrize("seed", range(40))
def test_random_graphs_rewritten_equal_unrewritten(seed, tmp_path):
    """The rewritten kernel's series equal the un-rewritten one's on random graphs, also with
    parameters 0, negative and infinite: no finite coefficient becomes NaN or inf (a factor
    divided by, a product reassociated through 0 inf)."""
    rng = random.Random(seed)
    x, t, p = ca.SX.sym("x", 3), ca.SX.sym("t"), ca.SX.sym("p", 3)
    f = [_random_expr(rng, x, p, t, 4) + 0.1 * x[i] for i in range(3)]
    ode = optimised(ca.Function("gw_ode", [t, x, ca.SX.sym("u", 0), p], [ca.vertcat(*f)],
                                ["t", "x", "u", "p"], ["xdot"]))
    new, old = Jet(decompose(ode), tmp_path, "new"), Jet(decompose(ode, rewrite=False), tmp_path, "old")
    points = np.random.default_rng(seed)
    for pv in ([0.7, 1.1, -0.4], [0.0, 0.0, 0.0], [-1.3, 0.0, 2.0], [math.inf, 1.0, 0.5], [1.0, -math.inf, 0.0]):
        xv = points.uniform(-0.9, 0.9, 3)
        got, ref = new.series(0.37, xv, [], pv), old.series(0.37, xv, [], pv)
        finite = np.isfinite(ref)
        assert np.all(np.isfinite(got[finite])), f"p = {pv}: finite coefficients became {got[finite & ~np.isfinite(got)]}"
        got, ref = np.where(finite, got, 0.0), np.where(finite, ref, 0.0)
        scale = np.max(np.abs(ref), axis=1, keepdims=True)
        err = np.max(np.abs(got - ref) / np.where(scale > 0, scale, 1.0))
        assert err < 1e-10, f"p = {pv}: series differ by {err:.1e} of their largest coefficient"
