"""model/hoist.py: the parameter-only part of the right-hand side, computed once per parameter change.

The split must not change the function (every example scene, random points), and the runtime must
recompute the hoisted values whenever a parameter changes (a tunable parameter set during the run
acts at once, exactly as in an instance started with the new value).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from conftest import ROOT
from fmi_helpers import Slave
from fmu_build import load_scene
from fmu_build.builder import build_spec_fmu
from fmu_build.codegen import hoisted
from model.build import build_model
from model.hoist import split_parameters
from model.system import System

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
