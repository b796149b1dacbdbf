"""model/hoist.py: the parameter-only part of the right-hand side and of the event indicators,
computed once per parameter change.

The split must not change the functions (every example scene, random points), and the runtime must
recompute the hoisted values whenever a parameter changes (a tunable parameter set during the run
acts at once, exactly as in an instance started with the new value), for the right-hand side and
for the events alike.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from conftest import ROOT
from fmi_helpers import Slave
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime
from gyrowheel.fmu_build import load_scene
from gyrowheel.fmu_build.builder import build_spec_fmu
from gyrowheel.fmu_build.codegen import hoisted
from gyrowheel.model.build import build_model
from gyrowheel.model.hoist import split_parameters
from gyrowheel.model.system import System

SCENES = sorted(p.stem for p in (ROOT / "examples" / "scenes").glob("*.toml"))


@pytest.mark.parametrize("name", SCENES)
def test_split_keeps_the_function(name):
    sc = load_scene(ROOT / "examples" / "scenes" / f"{name}.toml")
    spec = build_model(sc.wheel, sc.initial, sc.effects, sc.formulation, sc.name)
    fns = hoisted(spec)
    full = spec.functions()["ode"]
    p = np.array([q.start for q in spec.parameters])
    rng = np.random.default_rng(5)
    if "ode_pre" not in fns:
        return
    c = fns["ode_pre"](p)
    for _ in range(10):
        x = rng.uniform(0.2, 1.3, spec.x.numel())
        u = rng.uniform(-0.5, 0.5, spec.u.numel())
        a = np.array(fns["ode"](0.3, x, u, p, c)).ravel()
        b = np.array(full(0.3, x, u, p)).ravel()
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.max(np.abs(b))))


@pytest.mark.parametrize("name", SCENES)
def test_split_keeps_the_events(name):
    """evt(t, x, u, p, c) equals the unsplit evt(t, x, u, p) (same operations: bit for bit), and
    nothing of the parameters alone is left in it (the fall event's sin(beta_min) is in c)."""
    sc = load_scene(ROOT / "examples" / "scenes" / f"{name}.toml")
    spec = build_model(sc.wheel, sc.initial, sc.effects, sc.formulation, sc.name)
    fns, full = hoisted(spec), spec.functions()["evt"]
    assert "ode_pre" in fns and fns["evt"].n_in() == 5  # every scene's fall event hoists sin(beta_min)
    p = np.array([q.start for q in spec.parameters])
    c = fns["ode_pre"](p)
    rng = np.random.default_rng(7)
    for _ in range(10):
        x = rng.uniform(0.2, 1.3, spec.x.numel())
        u = rng.uniform(-0.5, 0.5, spec.u.numel())
        np.testing.assert_array_equal(np.array(fns["evt"](0.3, x, u, p, c)).ravel(),
                                      np.array(full(0.3, x, u, p)).ravel())
    t, x, u, _, c_sym = fns["evt"].sx_in()
    again, _, _ = split_parameters(fns["evt"](t, x, u, spec.p, c_sym), [t, x, u, c_sym], spec.p)
    assert again.numel() == 0


def test_nothing_to_hoist_and_bare_parameters_stay():
    a, k = ca.SX.sym("a"), ca.SX.sym("k", 2)
    c, e, cs = split_parameters(ca.vertcat(a * k[0], a + 1), [a], k)
    assert c.numel() == 0 and cs.numel() == 0
    c, e, cs = split_parameters(ca.vertcat(a * (k[0] + k[1]), ca.sin(a) * (k[0] + k[1]) + k[0] * k[1]), [a], k)
    assert c.numel() == 2  # k0 + k1 (shared by both rows) and k0 k1
    f = ca.Function("f", [a, k, cs], [e])
    g = ca.Function("g", [k], [c])
    kv = [0.7, -1.3]
    np.testing.assert_allclose(np.array(f(0.4, kv, g(kv))).ravel(),
                               [0.4 * (-0.6), math.sin(0.4) * (-0.6) + 0.7 * -1.3], rtol=1e-15)


@pytest.fixture(scope="module")
def decay_fmu(tmp_path_factory):
    """x_dot = -(k1 + k2) x with k1 tunable: (k1 + k2) is hoisted into ode_pre."""
    s = System("hoist_decay")
    k1 = s.parameter("k1", 1.0, tunable=True)
    k2 = s.parameter("k2", 0.5)
    x = s.state("x", 1.0)
    s.der(x, -(k1 + k2) * x)
    spec = s.spec()
    assert "ode_pre" in hoisted(spec)
    return str(build_spec_fmu(spec, tmp_path_factory.mktemp("hoist") / "d.fmu").fmu)


def test_a_tunable_parameter_acts_at_once(decay_fmu):
    s = Slave(decay_fmu)
    try:
        s.init(solver=5, rel_tol=1e-12, abs_tol=1e-14, max_step=1.0)
        s.slave.doStep(0.0, 1.0)
        assert s.get("x") == pytest.approx(math.exp(-1.5), rel=1e-10)
        s.set(k1=2.0)  # tunable: the hoisted k1 + k2 must follow
        s.slave.doStep(1.0, 1.0)
        assert s.get("x") == pytest.approx(math.exp(-1.5) * math.exp(-2.5), rel=1e-10)
    finally:
        s.free()


def _event_time(fmu: str, h: float = 0.05, at: float | None = None, **later) -> float:
    """Time of the terminating event of a run in steps of h (dop853, tight tolerances); the
    parameters `later` set after the step ending at `at`."""
    s = Slave(fmu)
    try:
        s.init(solver=5, rel_tol=1e-12, abs_tol=1e-14, max_step=1.0)
        t = 0.0
        while t < 10.0:
            try:
                s.slave.doStep(t, h)
            except FMICallException:
                return s.slave.getRealStatus(fmi2LastSuccessfulTime)
            t += h
            if at is not None and abs(t - at) < 1e-12:
                s.set(**later)
        raise AssertionError("no event within 10 s")
    finally:
        s.free()


def test_hoisted_event_parameters_and_a_tunable_one_set_mid_run(tmp_path):
    """x_dot = -k x (nothing to hoist in ode), event x - a b (a b hoisted, a tunable): the event
    at ln(1 / (a b)) / k, and at once at the new threshold when a changes during the run."""
    s = System("hoist_event")
    k = s.parameter("k", 2.0)
    a = s.parameter("a", 0.5, tunable=True)
    b = s.parameter("b", 0.4)
    x = s.state("x", 1.0)
    s.der(x, -k * x)
    s.event("low", x - a * b)
    spec = s.spec()
    fns = hoisted(spec)
    assert fns["ode_pre"].numel_out(0) == 1 and fns["evt"].n_in() == 5 and fns["ode"].n_in() == 5
    fmu = str(build_spec_fmu(spec, tmp_path / "e.fmu").fmu)
    assert _event_time(fmu) == pytest.approx(math.log(1.0 / 0.2) / 2.0, abs=1e-9)
    # a = 0.25 after t = 0.2: x(0.2) = exp(-0.4), the event where exp(-0.4 - 2 (t - 0.2)) = 0.1
    assert _event_time(fmu, at=0.2, a=0.25) == pytest.approx(0.2 + (math.log(10.0) - 0.4) / 2.0, abs=1e-9)


def test_event_without_a_parameter_part_beside_a_hoisted_ode(tmp_path):
    """x_dot = -(k1 + k2) x (k1 + k2 hoisted), event x - 0.5 (nothing of p): evt takes the unused
    c too, builds and fires at ln 2 / (k1 + k2)."""
    s = System("hoist_event_plain")
    k1, k2 = s.parameter("k1", 1.0), s.parameter("k2", 0.5)
    x = s.state("x", 1.0)
    s.der(x, -(k1 + k2) * x)
    s.event("half", x - 0.5)
    spec = s.spec()
    fns = hoisted(spec)
    assert fns["ode_pre"].numel_out(0) == 1 and fns["evt"].n_in() == 5
    fmu = str(build_spec_fmu(spec, tmp_path / "p.fmu").fmu)
    assert _event_time(fmu) == pytest.approx(math.log(2.0) / 1.5, abs=1e-9)
