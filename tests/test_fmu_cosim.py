"""The paper FMU as an FMI 2.0 Co-Simulation unit: validation, results, events, errors, state."""
from __future__ import annotations

import math
import subprocess
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated
from fmpy.validation import validate_fmu

from conftest import CasadiWheel, PAPER, STATES
from fmi_helpers import Slave
from gyrowheel.model.build import BETA_MIN_DEFAULT



@pytest.fixture(scope="module")
def md(earth_fmu):
    return read_model_description(str(earth_fmu))


@pytest.fixture(scope="module")
def reference_5s():
    """The CasADi model integrated by scipy DOP853 at rtol 1e-12 (an independent integrator)."""
    wheel = CasadiWheel(**PAPER)
    sol = wheel.integrate(wheel.x0(), 5.0, rtol=1e-12, atol=1e-13)
    return sol.y[:, -1]


def test_fmpy_validate_is_clean(earth_fmu):
    assert validate_fmu(str(earth_fmu)) == []


def test_interface_variables(md):
    """docs/interface.md: names, causality, variability, initial, units and defaults."""
    v = {x.name: x for x in md.modelVariables}
    for name, unit, start in [("M", "kg", 2.0), ("R", "m", 0.17), ("k_diam", None, 0.25),
                              ("k_axial", None, 0.4), ("g", "m/s2", 9.81), ("beta_min", "rad", BETA_MIN_DEFAULT)]:
        assert (v[name].causality, v[name].variability, v[name].initial) == ("parameter", "fixed", "exact")
        assert v[name].unit == unit
        assert float(v[name].start) == pytest.approx(start)
    for name, unit, start in [("x", "m", 0), ("y", "m", 0), ("alpha", "rad", 0), ("beta", "rad", 1.3962634),
                              ("gamma", "rad", 0), ("alpha_dot", "rad/s", 0), ("beta_dot", "rad/s", 0),
                              ("gamma_dot", "rad/s", 6)]:
        assert (v[name].causality, v[name].variability, v[name].initial) == ("output", "continuous", "exact")
        assert v[name].unit == unit
        assert float(v[name].start) == pytest.approx(start, abs=1e-7)
    for name, unit in [("z", "m"), ("vx", "m/s"), ("vy", "m/s"), ("energy", "J")]:
        assert (v[name].causality, v[name].initial) == ("output", "calculated")
        assert v[name].unit == unit
    assert (v["fallen"].type, v["fallen"].variability, v["fallen"].initial) == ("Boolean", "discrete", "calculated")
    assert v["solver"].type == "Enumeration"
    assert [(i.name, int(i.value)) for i in v["solver"].declaredType.items] == [
        ("euler", 1), ("rk4", 2), ("dopri5", 3), ("rosenbrock", 4), ("dop853", 5), ("taylor", 6), ("auto", 7)]
    assert int(v["solver"].start) == 7  # auto: the scene names no solver
    for name in ("rel_tol", "abs_tol", "max_step"):
        assert v[name].causality == "parameter"
    cs = md.coSimulation
    assert cs.canHandleVariableCommunicationStepSize and cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    assert float(md.defaultExperiment.stopTime) == 20.0
    assert {u.name for u in md.unitDefinitions} >= {"rad", "m", "kg", "J", "m/s", "rad/s"}
    rad = next(u for u in md.unitDefinitions if u.name == "rad")
    assert rad.displayUnits[0].name == "deg"


def test_archive_layout_and_exports(earth_fmu, tmp_path):
    """binaries/linux64/<id>.so exporting only fmi2*, the unity source listed alone, documentation."""
    with zipfile.ZipFile(earth_fmu) as zf:
        names = set(zf.namelist())
        zf.extractall(tmp_path)
    md = read_model_description(str(earth_fmu))
    ident = md.coSimulation.modelIdentifier
    assert {"modelDescription.xml", f"binaries/linux64/{ident}.so", "documentation/index.html"} <= names
    sources = {n.split("/", 1)[1] for n in names if n.startswith("sources/") and n.endswith(".c")}
    # one translation unit (docs/runtime.md): gw_fmu.c includes every other .c file of sources/
    assert md.buildConfigurations[0].sourceFileSets[0].sourceFiles == ["gw_fmu.c"]
    unity = (tmp_path / "sources" / "gw_fmu.c").read_text() + (tmp_path / "sources" / "gw_core.c").read_text()
    # but the ensemble library's sources, which an FMU with the Taylor kernel (this one: solver auto)
    # carries for gyrowheel.Ensemble to compile on the host (docs/taylor.md)
    assert {s for s in sources if f'#include "{s}"' not in unity} == {"gw_fmu.c", "gw_ensemble.c", "gw_ensemble_lib.c"}
    nm = subprocess.run(["nm", "-D", "--defined-only", str(tmp_path / "binaries/linux64" / f"{ident}.so")],
                        capture_output=True, text=True, check=True).stdout
    exported = {line.split()[-1] for line in nm.splitlines() if line.strip()}
    assert exported and all(name.startswith("fmi2") for name in exported), sorted(exported)
    assert "fmi2DoStep" in exported and "fmi2GetDerivatives" in exported
    html = (tmp_path / "documentation/index.html").read_text()
    assert "gamma_dot" in html and "[effects.gravity]" in html


def test_simulate_fmu_reproduces_reference(earth_fmu, reference_5s):
    r = simulate_fmu(str(earth_fmu), stop_time=5.0, output_interval=0.05,
                     start_values={"rel_tol": 1e-11, "abs_tol": 1e-12})
    assert r["time"][-1] == pytest.approx(5.0, abs=1e-12)
    got = np.array([r[n][-1] for n in STATES])
    np.testing.assert_allclose(got, reference_5s, rtol=0, atol=2e-7)
    assert np.all(np.isfinite(r["energy"]))
    assert np.ptp(r["energy"]) / r["energy"][0] < 1e-8


def test_against_independent_newton_euler_derivation(earth_fmu):
    """The FMU against a sympy Newton-Euler derivation integrated by scipy."""
    from reference import newton_euler as ne
    x0 = np.array([0, 0, 0, math.radians(80), 0, 0, 0, 6.0])
    ref = ne.simulate(x0, ne.PAPER_PARAMS, 5.0, rtol=1e-12, atol=1e-13)
    r = simulate_fmu(str(earth_fmu), stop_time=5.0, output_interval=0.05,
                     start_values={"rel_tol": 1e-11, "abs_tol": 1e-12})
    got = np.array([r[n][-1] for n in STATES])
    np.testing.assert_allclose(got, ref.y[:, -1], atol=2e-7)


def _reference_fall_time(beta_min: float, **start) -> float:
    return CasadiWheel(**PAPER, beta_min=beta_min).fall_time(beta_min, 1e-12, 1e-13, **start)


@pytest.mark.parametrize("beta_min,start", [
    (0.1, {"gamma_dot": 1.0}),   # slow rolling: dips to beta = 0.091 rad after a wide swing
    (0.02, {"gamma_dot": 0.0}),  # no spin: the planar fall
])
def test_fall_event_stops_cleanly(earth_fmu, beta_min, start):
    """The step ends at the located fall with fmi2Discard + fmi2Terminated, outputs finite."""
    t_fall = _reference_fall_time(beta_min, **start)
    s = Slave(earth_fmu)
    try:
        s.init(beta_min=beta_min, rel_tol=1e-10, abs_tol=1e-12, **start)
        t, h = 0.0, 0.1
        status = None
        while t < 20:
            try:
                s.slave.doStep(t, h)
            except FMICallException as exc:
                status = exc.status
                break
            t += h
        assert status == 2  # fmi2Discard
        assert s.slave.getBooleanStatus(fmi2Terminated)
        t_event = s.slave.getRealStatus(fmi2LastSuccessfulTime)
        assert t_event == pytest.approx(t_fall, abs=1e-7)
        beta, fallen = s.get("beta", "fallen")
        assert fallen
        assert math.sin(beta) == pytest.approx(math.sin(beta_min), abs=1e-9)
        values = s.slave.getReal([v.valueReference for v in s.md.modelVariables if v.type == "Real"])
        assert all(math.isfinite(v) for v in values)
        assert "fall" in s.log_text()
        with pytest.raises(FMICallException):  # no stepping on after the end
            s.slave.doStep(t_event, 0.1)
    finally:
        s.free()


def test_simulate_fmu_stops_at_the_fall(earth_fmu):
    r = simulate_fmu(str(earth_fmu), stop_time=20.0, output_interval=0.1,
                     start_values={"gamma_dot": 1.0, "beta_min": 0.1})
    assert r["fallen"][-1] and not r["fallen"][0]
    assert r["time"][-1] == pytest.approx(_reference_fall_time(0.1, gamma_dot=1.0), abs=1e-6)
    assert np.all(np.isfinite(r["beta"]))


@pytest.mark.parametrize("values,fragment", [
    ({"M": -1.0}, "M (mass) must be > 0"),
    ({"R": 0.0}, "R (radius) must be > 0"),
    ({"k_axial": 0.9, "k_diam": 0.25}, "k_axial must be <= 2 k_diam"),
    ({"beta": 5e-4}, "initial lean beta must lie between beta_min and pi - beta_min"),
    ({"beta": 3.2}, "beta (initial lean) must be < pi"),
    ({"beta_min": 2.0}, "beta_min must be < pi/2"),
    ({"g": -9.81}, "g must be >= 0"),
    ({"rel_tol": -1.0}, "rel_tol"),
    ({"max_step": 0.0}, "max_step"),
])
def test_bad_parameters_give_error_with_reason(earth_fmu, values, fragment):
    s = Slave(earth_fmu)
    try:
        with pytest.raises(FMICallException):
            s.init(**values)
        assert fragment in s.log_text()
        assert any(status >= 3 for status, _, _ in s.messages)
    finally:
        s.free()


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_non_finite_parameter_rejected(earth_fmu, value):
    s = Slave(earth_fmu)
    try:
        with pytest.raises(FMICallException):
            s.set(M=value)
        assert "M" in s.log_text()
    finally:
        s.free()


def test_unknown_solver_rejected(earth_fmu):
    s = Slave(earth_fmu)
    try:
        with pytest.raises(FMICallException):
            s.init(solver=8)  # items 1 .. 7 (auto)
        assert "solver" in s.log_text()
    finally:
        s.free()


@pytest.mark.parametrize("h", [1e-6, 1e-3 / 3, 0.1, 0.7777777, 3.0])
def test_every_step_lands_exactly(earth_fmu, h):
    s = Slave(earth_fmu)
    try:
        s.init()
        t = 0.0
        for _ in range(5):
            s.slave.doStep(t, h)
            t += h
        assert s.slave.getRealStatus(fmi2LastSuccessfulTime) == t
    finally:
        s.free()


def test_one_huge_step_equals_many_small(earth_fmu):
    """100 s in one fmi2DoStep (a moon wheel that does not fall) matches 1000 steps of 0.1 s."""
    def run(steps, h):
        s = Slave(earth_fmu)
        try:
            s.init(g=1.625, rel_tol=1e-10, abs_tol=1e-12)
            t = 0.0
            for _ in range(steps):
                s.slave.doStep(t, h)
                t += h
            return np.array(s.get(*STATES)), s.get("fallen")
        finally:
            s.free()
    one, fallen1 = run(1, 100.0)
    many, fallen2 = run(1000, 0.1)
    assert not fallen1 and not fallen2
    np.testing.assert_allclose(one[3:], many[3:], atol=1e-5)


def _final_error(fmu, reference, **start):
    r = simulate_fmu(str(fmu), stop_time=5.0, output_interval=0.5, start_values=start)
    return np.max(np.abs(np.array([r[n][-1] for n in STATES]) - reference))


@pytest.mark.parametrize("solver,h,order", [("euler", 2e-4, 1), ("rk4", 4e-3, 4)])
def test_fixed_step_solvers_have_their_order(earth_fmu, reference_5s, solver, h, order):
    """Halving max_step divides the error by 2^order (euler 1, rk4 4)."""
    code = {"euler": 1, "rk4": 2}[solver]
    coarse = _final_error(earth_fmu, reference_5s, solver=code, max_step=h)
    fine = _final_error(earth_fmu, reference_5s, solver=code, max_step=h / 2)
    assert fine < coarse
    assert math.log2(coarse / fine) == pytest.approx(order, abs=0.3)


@pytest.mark.parametrize("solver", [3, 4, 5])  # dopri5, rosenbrock, dop853
@pytest.mark.parametrize("rel_tol,bound", [(1e-6, 1e-3), (1e-9, 1e-6), (1e-12, 1e-8)])
def test_adaptive_error_follows_tolerance(earth_fmu, reference_5s, solver, rel_tol, bound):
    err = _final_error(earth_fmu, reference_5s, solver=solver, rel_tol=rel_tol, abs_tol=rel_tol / 100, max_step=1.0)
    assert err < bound


def test_state_save_restore_and_serialize(earth_fmu):
    s = Slave(earth_fmu)
    try:
        s.init()
        s.slave.doStep(0.0, 1.0)
        state = s.slave.getFMUstate()
        blob = s.slave.serializeFMUstate(state)
        s.slave.doStep(1.0, 1.0)
        first = s.get(*STATES)
        s.slave.setFMUstate(state)
        s.slave.doStep(1.0, 1.0)
        assert s.get(*STATES) == first
        restored = s.slave.deSerializeFMUstate(blob)
        s.slave.setFMUstate(restored)
        s.slave.doStep(1.0, 1.0)
        assert s.get(*STATES) == first
        s.slave.freeFMUstate(state)
        s.slave.freeFMUstate(restored)
        broken = bytearray(blob)
        broken[0:4] = b"XXXX"
        with pytest.raises(Exception):
            s.slave.deSerializeFMUstate(bytes(broken))
    finally:
        s.free()


def test_reset_restores_defaults(earth_fmu):
    s = Slave(earth_fmu)
    try:
        s.init(gamma_dot=8.0)
        s.slave.doStep(0.0, 1.0)
        s.slave.reset()
        s.init()
        assert s.get("gamma_dot") == 6.0 and s.get("beta") == pytest.approx(math.radians(80))
    finally:
        s.free()


def test_two_instances_side_by_side(earth_fmu, md):
    """Interleaved stepping of two instances with different gravity equals separate runs."""
    a, b = Slave(earth_fmu, name="a", md=md), Slave(earth_fmu, name="b", md=md)
    try:
        a.init()
        b.init(g=1.625)
        t = 0.0
        for _ in range(20):
            a.slave.doStep(t, 0.1)
            b.slave.doStep(t, 0.1)
            t += 0.1
        ya, yb = a.get(*STATES), b.get(*STATES)
    finally:
        a.free()
        b.free()
    solo_a = simulate_fmu(str(earth_fmu), stop_time=2.0, output_interval=0.1)
    solo_b = simulate_fmu(str(earth_fmu), stop_time=2.0, output_interval=0.1, start_values={"g": 1.625})
    assert ya == pytest.approx([solo_a[n][-1] for n in STATES], abs=1e-12)
    assert yb == pytest.approx([solo_b[n][-1] for n in STATES], abs=1e-12)
    assert ya != pytest.approx(yb)


def test_initial_outputs_readable_in_initialization_mode(earth_fmu):
    s = Slave(earth_fmu)
    try:
        s.slave.setupExperiment(startTime=0.0)
        s.set(gamma_dot=5.0)
        s.slave.enterInitializationMode()
        vx, z = s.get("vx", "z")
        assert vx == pytest.approx(0.17 * 5.0)
        assert z == pytest.approx(0.17 * math.sin(math.radians(80)))
        s.slave.exitInitializationMode()
    finally:
        s.free()


def test_log_categories_match_the_runtime(earth_fmu, md):
    """Every category in modelDescription.xml is accepted by fmi2SetDebugLogging; others are not."""
    categories = [c.name for c in md.logCategories]
    assert set(categories) == {"logEvents", "logSolver", "logStatusWarning", "logStatusDiscard",
                               "logStatusError", "logStatusFatal", "logAll"}
    s = Slave(earth_fmu)
    try:
        s.slave.setDebugLogging(True, categories)
        s.init()
        s.slave.doStep(0.0, 0.1)
        assert "fmi2DoStep" in s.log_text()  # logSolver's per-step summary
        with pytest.raises(FMICallException):
            s.slave.setDebugLogging(True, ["logEverything"])
        assert "logEverything" in s.log_text()
    finally:
        s.free()
