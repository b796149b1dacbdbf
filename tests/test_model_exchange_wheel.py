"""Model Exchange and directional derivatives of the real wheel FMU (paper_earth scene).

Part A drives the compiled binary through fmpy's low-level FMU2Model API
(instantiate, setupExperiment, enter/exit initialization, newDiscreteStates,
enterContinuousTimeMode, setTime, setContinuousStates, getDerivatives, ...) and
compares with the CasADi model of the same scene.

Part B checks the declared interface: the <ModelExchange> element validates, and
fmpy.simulate_fmu(fmi_type="ModelExchange", solver="CVode") agrees with Co-Simulation.
"""

from __future__ import annotations

import ctypes
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model, FMU2Slave, fmi2LastSuccessfulTime
from fmpy.validation import validate_fmu

from conftest import STATES
from gyrowheel.fmu_build import load_scene
from gyrowheel.fmu_build.builder import model_spec
from gyrowheel.model.build import BETA_MIN_DEFAULT

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "scenes" / "paper_earth.toml"


@pytest.fixture(scope="module")
def spec():
    return model_spec(load_scene(SCENE))


@pytest.fixture(scope="module")
def casadi_fns(spec):
    return spec.functions()


@pytest.fixture(scope="module")
def unzipped(earth_fmu, tmp_path_factory):
    return extract(str(earth_fmu), str(tmp_path_factory.mktemp("me_unzip")))


@pytest.fixture(scope="module")
def md(earth_fmu):
    return read_model_description(str(earth_fmu))


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


class ME:
    """A Model Exchange instance of the wheel, driven through fmpy's FMU2Model."""

    def __init__(self, md, unzipped, name="me", start: dict[str, float] | None = None):
        ident = (md.modelExchange or md.coSimulation).modelIdentifier
        self.fmu = FMU2Model(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=ident,
                             instanceName=name)
        self.fmu.instantiate()
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.nx = len(STATES)
        self.nz = 1
        self.fmu.setupExperiment(startTime=0.0)
        for k, v in (start or {}).items():
            self.fmu.setReal([self.vr[k]], [v])
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        need, term, *_ = self.fmu.newDiscreteStates()
        assert not need and not term
        self.fmu.enterContinuousTimeMode()

    def x(self) -> np.ndarray:
        x = np.zeros(self.nx)
        self.fmu.getContinuousStates(_ptr(x), self.nx)
        return x

    def set(self, t: float, x: np.ndarray) -> None:
        self.fmu.setTime(t)
        xc = np.ascontiguousarray(x, dtype=float)
        self.fmu.setContinuousStates(_ptr(xc), self.nx)

    def dx(self, t: float, x: np.ndarray) -> np.ndarray:
        self.set(t, x)
        d = np.zeros(self.nx)
        self.fmu.getDerivatives(_ptr(d), self.nx)
        return d

    def z(self, t: float, x: np.ndarray) -> np.ndarray:
        self.set(t, x)
        z = np.zeros(self.nz)
        self.fmu.getEventIndicators(_ptr(z), self.nz)
        return z

    def free(self):
        self.fmu.freeInstance()


def _rk4(me: ME, t, x, h):
    k1 = me.dx(t, x)
    k2 = me.dx(t + h / 2, x + h / 2 * k1)
    k3 = me.dx(t + h / 2, x + h / 2 * k2)
    k4 = me.dx(t + h, x + h * k3)
    return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


# ---- Part A: the binary's Model Exchange functions (no <ModelExchange> needed) ----------

def test_derivatives_match_casadi(md, unzipped, spec, casadi_fns):
    me = ME(md, unzipped)
    try:
        p = np.array([q.start for q in spec.parameters], dtype=float)
        ode = casadi_fns["ode"]
        rng = np.random.default_rng(1)
        x0 = me.x()
        worst = 0.0
        for k in range(20):
            x = x0 if k == 0 else x0 + rng.normal(scale=[0.1, 0.1, 0.5, 0.3, 0.5, 1, 1, 2])
            t = 0.1 * k
            d_fmu = me.dx(t, x)
            d_ca = np.array(ode(t, x, [], p)).ravel()
            scale = np.maximum(1.0, np.abs(d_ca))
            worst = max(worst, float(np.max(np.abs(d_fmu - d_ca) / scale)))
            # the derivative variables der(...) and the state variables agree too
            der = me.fmu.getReal([me.vr[f"der({n})"] for n in STATES])
            assert np.array_equal(np.array(der), d_fmu)
            assert np.array_equal(np.array(me.fmu.getReal([me.vr[n] for n in STATES])), x)
        print(f"getDerivatives vs CasADi ode: worst relative difference {worst:.3g}")
        assert worst < 1e-12
    finally:
        me.free()


def test_directional_derivatives_match_casadi_and_fd(md, unzipped, spec, casadi_fns):
    me = ME(md, unzipped)
    try:
        p = np.array([q.start for q in spec.parameters], dtype=float)
        nx = me.nx
        x = me.x() + np.array([0.01, -0.02, 0.3, -0.1, 0.2, 0.4, -0.3, 0.5])
        t = 0.25
        me.set(t, x)
        # CasADi reference: d[ode; out]/dx
        xs = ca.SX.sym("x", nx)
        J_ca = ca.Function("J", [xs], [ca.jacobian(ca.vertcat(casadi_fns["ode"](t, xs, [], p),
                                                              casadi_fns["out"](t, xs, [], p)), xs)])
        J_ref = np.array(J_ca(x))
        out_names = [q.name for q, _ in spec.outputs]
        unknowns = [f"der({n})" for n in STATES] + out_names
        uvr = [me.vr[n] for n in unknowns]
        kvr = [me.vr[n] for n in STATES]
        worst_ca = worst_fd = 0.0
        for j in range(nx):
            seed = [0.0] * nx
            seed[j] = 1.0
            col = np.array(me.fmu.getDirectionalDerivative(uvr, kvr, seed))
            worst_ca = max(worst_ca, float(np.max(np.abs(col - J_ref[:, j]) /
                                                   np.maximum(1.0, np.abs(J_ref[:, j])))))
            # central differences of getDerivatives / getReal
            h = 1e-6 * max(1.0, abs(x[j]))
            vals = []
            for sgn in (1, -1):
                xp = x.copy()
                xp[j] += sgn * h
                me.set(t, xp)
                vals.append(np.array(me.fmu.getReal(uvr)))
            me.set(t, x)
            fd = (vals[0] - vals[1]) / (2 * h)
            worst_fd = max(worst_fd, float(np.max(np.abs(col - fd) / np.maximum(1.0, np.abs(fd)))))
        print(f"directional derivatives: vs CasADi {worst_ca:.3g}, vs central differences "
              f"{worst_fd:.3g}")
        assert worst_ca < 1e-12
        assert worst_fd < 1e-6
        # a state as unknown is the identity row; a combined seed is the linear combination
        seed = np.linspace(-1, 1, nx)
        r = me.fmu.getDirectionalDerivative([me.vr["beta"], me.vr["der(beta)"]], kvr, list(seed))
        assert r[0] == seed[3]
        assert r[1] == pytest.approx(float(J_ref[3] @ seed), rel=1e-12, abs=1e-12)
    finally:
        me.free()


def test_rk4_importer_until_the_wheel_falls(md, unzipped, earth_fmu):
    """An ME importer (RK4, h = 1 ms, bisection on the indicator) against Co-Simulation."""
    start = {"gamma_dot": 0.0}  # no spin: the wheel falls flat at t = 0.43 s
    me = ME(md, unzipped, start=start)
    try:
        t, x, h = 0.0, me.x(), 1e-3
        z = me.z(t, x)
        while t < 10.0:
            xn = _rk4(me, t, x, h)
            zn = me.z(t + h, xn)
            if z[0] > 0 >= zn[0]:
                a, b, xb = 0.0, h, xn
                while b - a > 1e-13:
                    m = 0.5 * (a + b)
                    xm = _rk4(me, t, x, m)
                    if me.z(t + m, xm)[0] <= 0:
                        b, xb = m, xm
                    else:
                        a = m
                t, x = t + b, xb
                me.set(t, x)
                me.fmu.enterEventMode()
                need, term, *_ = me.fmu.newDiscreteStates()
                assert term and not need
                assert me.fmu.getBoolean([me.vr["fallen"]]) == [True]
                break
            t, x, z = t + h, xn, zn
        else:
            pytest.fail("the wheel did not fall")
        t_me = t
        y_me = dict(zip(STATES, me.fmu.getReal([me.vr[n] for n in STATES])))
        assert np.isfinite(list(y_me.values())).all()
        me.fmu.terminate()
    finally:
        me.free()

    cs = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                   modelIdentifier=md.coSimulation.modelIdentifier, instanceName="cs")
    try:
        cs.instantiate()
        vr = {v.name: v.valueReference for v in md.modelVariables}
        cs.setReal([vr["rel_tol"], vr["abs_tol"]], [1e-12, 1e-14])
        cs.setupExperiment(startTime=0.0)
        for k, v in start.items():
            cs.setReal([vr[k]], [v])
        cs.enterInitializationMode()
        cs.exitInitializationMode()
        tc = 0.0
        while tc < 10.0:
            try:
                cs.doStep(tc, 0.1)
            except Exception:
                break
            tc += 0.1
        t_cs = cs.getRealStatus(fmi2LastSuccessfulTime)
        y_cs = dict(zip(STATES, cs.getReal([vr[n] for n in STATES])))
        cs.terminate()
    finally:
        cs.freeInstance()
    print(f"fall time ME (RK4 1 ms) {t_me:.12f}, CS (dopri5 1e-12) {t_cs:.12f}, "
          f"difference {abs(t_me - t_cs):.3g}")
    assert abs(t_me - t_cs) < 1e-6
    for n in STATES:
        assert y_me[n] == pytest.approx(y_cs[n], rel=1e-6, abs=1e-6), n


# ---- Part B: the declared Model Exchange interface ------------------------------------------

def _need_me(md):
    assert md.modelExchange is not None, "modelDescription.xml must declare <ModelExchange>"


def test_me_element_validates(md, earth_fmu):
    _need_me(md)
    assert md.modelExchange.providesDirectionalDerivative
    assert md.numberOfEventIndicators == 1
    assert validate_fmu(str(earth_fmu)) == []


def test_simulate_model_exchange_cvode_agrees_with_cosimulation(md, earth_fmu):
    _need_me(md)
    opts = dict(stop_time=5.0, output_interval=0.01, relative_tolerance=1e-10)
    outputs = STATES + ["z", "energy"]
    cs = simulate_fmu(str(earth_fmu), fmi_type="CoSimulation", output=outputs,
                      start_values={"rel_tol": 1e-12, "abs_tol": 1e-14}, **opts)
    me = simulate_fmu(str(earth_fmu), fmi_type="ModelExchange", solver="CVode", output=outputs,
                      **opts)
    assert me["time"][-1] == pytest.approx(5.0)
    worst = 0.0
    for n in outputs:
        a = np.interp(cs["time"], me["time"], me[n])
        worst = max(worst, float(np.max(np.abs(a - cs[n]) / np.maximum(1.0, np.abs(cs[n])))))
    print(f"ModelExchange (CVode rtol 1e-10) vs CoSimulation (dopri5 rtol 1e-12), 5 s: "
          f"worst relative difference {worst:.3g}")
    assert worst < 1e-6


def test_simulate_model_exchange_terminates_when_the_wheel_falls(md, earth_fmu):
    """fmpy stops at terminateSimulation; the fall time agrees with Co-Simulation.

    fmpy records the last sample before the event update (the left limit), so `fallen`
    (a discrete variable, set in fmi2NewDiscreteStates) is still false in that row."""
    _need_me(md)
    start = {"gamma_dot": 0.0}
    me = simulate_fmu(str(earth_fmu), fmi_type="ModelExchange", solver="CVode", stop_time=5.0,
                      start_values=start, output=["beta"], relative_tolerance=1e-10)
    cs = simulate_fmu(str(earth_fmu), fmi_type="CoSimulation", stop_time=5.0,
                      start_values=dict(start, rel_tol=1e-12, abs_tol=1e-14), output=["beta"])
    print(f"fall time ModelExchange/CVode {me['time'][-1]:.12f}, CoSimulation {cs['time'][-1]:.12f}")
    assert me["time"][-1] == pytest.approx(cs["time"][-1], abs=1e-6)
    assert me["beta"][-1] == pytest.approx(BETA_MIN_DEFAULT, abs=1e-6)
