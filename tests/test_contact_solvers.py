"""Every solver with the contact modes (docs/effects.md, "Contact modes and solvers").

One FMU serves all: examples/scenes/drop_bounce.toml (rolling, sliding, flight) built with the
Taylor kernel. Against results the code did not produce:
- the upright wheel launched sliding with backspin: rolling at t* = |s0| / (mu_k g (1 + 1/k_axial))
  with v* = (v0 + k_axial R w0) / (1 + k_axial) (angular momentum about the contact point);
- the upright drop: apex heights e^(2k) h of the lowest rim point, rest after N impacts at the
  truncated series' time (tests/test_contact_flight.py, drop_series);
- the leaning wheel on ice: the switch times of four integrators that share nothing but the event
  locator agree;
- the fixed step RK4: exact in flight (the flight of an upright wheel is a parabola, which RK4
  integrates exactly), and its documented limit at the end of a slip: the Coulomb friction's
  direction flips inside a step, and once the slip is below h a / 2 (a = mu_k g (1 + 1/k_axial))
  RK4's stage slopes -a, +a, -a, +a cancel (-1 + 2 (1 - 1) + 1 = 0): the slip freezes;
- the Ensemble: lanes in different modes at once, each lane's bits those of its trajectory alone,
  the analytic results, and the FMU's single taylor run to rounding;
- FMU states mid-slide and mid-flight: Model Exchange (a deterministic importer over
  fmi2GetDerivatives / fmi2GetEventIndicators / fmi2NewDiscreteStates) and Co-Simulation, through
  serialisation into a fresh instance, bit for bit the uninterrupted run; the switch logged in
  category logEvents inside one fmi2DoStep.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmi_helpers import Model, Slave, simulate_logged
from paper_wheel import G, KA, R
from test_contact_flight import drop_series

TIGHT = {"rel_tol": 1e-12, "abs_tol": 1e-14}
SOLVERS = {"dopri5": 3, "rosenbrock": 4, "dop853": 5, "taylor": 6}
RK4 = 2
OUT = ["x", "vx", "vz", "height", "contact_mode", "slip_long", "gamma_dot", "beta", "energy", "dissipated_energy"]
V0, W0, MU_K = 2.0, -5.0, 0.25  # the backspin launch
S0 = V0 - R * W0
SLIP_DECAY = MU_K * G * (1 + 1 / KA)  # d|slip|/dt while the upright wheel slides
T_STAR = abs(S0) / SLIP_DECAY
V_STAR = (V0 + KA * R * W0) / (1 + KA)
BACKSPIN = {"beta": math.pi / 2, "gamma_dot": W0, "slip_long": S0, "mu_k": MU_K, "height": 0.0}
DROP = {"height": 0.1, "restitution": 0.5, "beta": math.pi / 2, "gamma_dot": 0.0}
ICE = {"beta": math.radians(80), "gamma_dot": 8.0, "mu": 0.1, "mu_k": 0.08, "height": 0.0}


@pytest.fixture(scope="module")
def hybrid(example_build):
    """drop_bounce with the Taylor kernel (every solver of the enumeration)."""
    return str(example_build("drop_bounce", taylor=True).fmu)


def check_drop(t, height, vz, times, h=0.1, e=0.5):
    """The upright drop's impacts and apexes against the rigid series."""
    n, rest, _, _ = drop_series(h, e)
    assert len(times) == n + 1
    assert times[-1] == pytest.approx(rest, abs=1e-9)
    for k in range(1, n):
        inside = (t > times[k - 1] + 1e-6) & (t < times[k] - 1e-6)
        if inside.any():
            apex = height[inside] + vz[inside] ** 2 / (2 * G)
            assert np.max(np.abs(apex - e ** (2 * k) * h)) < 1e-9, k


@pytest.mark.parametrize("solver", sorted(SOLVERS))
def test_adaptive_solvers_switch_the_backspin_launch_to_rolling_at_t_star(hybrid, solver):
    r, events = simulate_logged(hybrid, 0.6, 0.01, OUT, {**TIGHT, **BACKSPIN, "solver": SOLVERS[solver]})
    assert [name for name, _ in events] == ["contact_slip"]
    assert events[0][1] == pytest.approx(T_STAR, abs=1e-9)
    after = r["time"] > T_STAR
    assert np.all(r["contact_mode"][after] == 0) and np.all(r["contact_mode"][~after] == 1)
    assert np.max(np.abs(r["vx"][after] - V_STAR)) < 1e-9 * V_STAR


@pytest.mark.parametrize("solver", sorted(SOLVERS) + ["rk4"])
def test_every_solver_bounces_the_drop_to_rest_at_the_series_time(hybrid, solver):
    """RK4 included (max_step 1e-4): the upright wheel's flight is a parabola, which RK4's fourth
    order integrates exactly, and each touchdown is located on the dense output."""
    extra = {"solver": RK4, "max_step": 1e-4} if solver == "rk4" else {"solver": SOLVERS[solver]}
    r, events = simulate_logged(hybrid, 0.5, 0.001, OUT, {**TIGHT, **DROP, **extra})
    times = [t for name, t in events if name == "contact_flight"]
    check_drop(r["time"], r["height"], r["vz"], times)
    assert r["contact_mode"][-1] == 0


def test_leaning_slide_switches_alike_with_every_adaptive_solver(hybrid):
    """The leaning wheel on ice (80 deg, 8 rad/s, mu 0.1, mu_k 0.08): slides from t = 0, d reseeded
    twice, rolls again; the four integrators' switch times within 1e-9 s of each other, the final
    x within 1e-9 m."""
    runs = {s: simulate_logged(hybrid, 3.0, 0.01, OUT, {**TIGHT, **ICE, "solver": v}) for s, v in SOLVERS.items()}
    times = np.array([[t for _, t in events] for _, events in runs.values()])
    assert times.shape == (4, 4) and np.all(times[:, 0] == 0.0)
    assert np.max(np.ptp(times, axis=0)) < 1e-9
    assert times[0, 3] == pytest.approx(2.2055, abs=1e-4)  # docs/effects.md, the scipy reference's
    x = [r["x"][-1] for r, _ in runs.values()]
    assert max(x) - min(x) < 1e-9
    assert all(r["contact_mode"][-1] == 0 for r, _ in runs.values())


def test_rk4_freezes_a_dying_slip_below_half_a_step_of_its_decay(hybrid):
    """The documented limit of the fixed step: at a slip's end the friction flips inside the step
    (the adaptive solvers reject such steps). With h = 1e-4 s the slip at the last step end before
    t* lies in (0, h a); below h a / 2 the stages cancel and it stays there, so the switch to rolling
    comes late (1e-3 s and more) instead of at t*."""
    h = 1e-4
    r, events = simulate_logged(hybrid, 0.4, h, ["slip_long", "contact_mode"],
                                {**TIGHT, **BACKSPIN, "solver": RK4, "max_step": h})
    t, slip = r["time"], r["slip_long"]
    frozen = (t > T_STAR) & (t < T_STAR + 1e-3)
    assert frozen.sum() >= 9
    s = slip[frozen]
    assert np.all(s == s[0]) and 0 < s[0] < h * SLIP_DECAY / 2
    assert np.all(r["contact_mode"][frozen] == 1)
    assert [name for name, _ in events] == ["contact_slip"] and events[0][1] > T_STAR + 1e-3


def test_ensemble_runs_lanes_in_different_modes(hybrid, tmp_path):
    """Five trajectories at once: a backspin slide (sliding -> rolling), the upright drop (flight ->
    bounces -> rolling), the leaning wheel on ice (sliding), a wheel rolling upright, a leaning
    spinning drop (flight -> sliding). Each lane's bits are those of its trajectory run alone (so
    no lane's mode leaks into another's), the analytic results hold, and the final states equal
    the FMU's single taylor runs to rounding (the library is built with FMA contraction). Two
    lanes: lane counts 2 to 16 give the same bits (tests/test_ensemble.py), and the library of
    two compiles in half the time of four's (34 s against 69 s of CPU for this model)."""
    from gyrowheel.taylor.ensemble import Ensemble
    ens = Ensemble(hybrid, lanes=2, cache=tmp_path)
    rows = [BACKSPIN, DROP, ICE, {"beta": math.pi / 2, "gamma_dot": 5.0, "height": 0.0},
            {"height": 0.05, "beta": 1.1, "gamma_dot": 15.0, "alpha_dot": 1.0, "slip_long": 0.3, "restitution": 0.5}]
    P = np.tile(np.array(ens.default_parameters, float), (len(rows), 1))
    S = np.tile(np.array(ens.default_starts, float), (len(rows), 1))
    for j, row in enumerate(rows):
        for name, value in row.items():
            if name in ens.parameter_names:
                P[j, ens.parameter_names.index(name)] = value
            else:
                S[j, ens.start_names.index(name)] = value
    grid = np.round(np.arange(1, 1001) * 1e-3, 12)
    kw = dict(rel_tol=1e-12, abs_tol=1e-14, grid=grid)
    res = ens.run(1.0, parameters=P, starts=S, **kw)
    assert list(res.status) == [0] * 5, res.messages
    y = {name: res.y_grid[:, :, res.output_names.index(name)] for name in ("contact_mode", "vx", "height", "vz")}
    modes = [set(m) for m in y["contact_mode"]]
    assert modes == [{0.0, 1.0}, {0.0, 2.0}, {1.0}, {0.0}, {1.0, 2.0}]
    t = res.grid
    backspin = y["contact_mode"][0]
    assert np.all(backspin[t < T_STAR] == 1) and np.all(backspin[t > T_STAR] == 0)
    assert np.max(np.abs(y["vx"][0][t > T_STAR] - V_STAR)) < 1e-9 * V_STAR
    n, rest, _, _ = drop_series(0.1, 0.5)
    # the drop's impacts from the grid: the apexes of each flight between two grid-visible landings
    flying = y["contact_mode"][1] == 2
    for k, (a, b) in enumerate(_flights(flying)[1:4], start=1):
        apex = y["height"][1][a:b] + y["vz"][1][a:b] ** 2 / (2 * G)
        assert np.max(np.abs(apex - 0.5 ** (2 * k) * 0.1)) < 1e-9, k
    assert np.all(y["contact_mode"][1][t > rest + 1e-9] == 0)
    for j in range(len(rows)):
        alone = ens.run(1.0, parameters=P[j:j + 1], starts=S[j:j + 1], **kw)
        assert alone.steps[0] == res.steps[j]
        np.testing.assert_array_equal(alone.x_final[0], res.x_final[j])
        np.testing.assert_array_equal(alone.y_grid[0], res.y_grid[j])
    s = Slave(hybrid, logging_on=False)
    for j, row in enumerate(rows):
        s.slave.reset()
        s.init(**TIGHT, solver=SOLVERS["taylor"], **row)
        s.slave.doStep(0.0, 1.0)
        for k, name in enumerate(res.state_names):
            assert res.x_final[j, k] == pytest.approx(s.get(name), rel=1e-9, abs=1e-10), (j, name)
    s.free()


def _flights(flying: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [a, b) of consecutive True values."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], flying.astype(int), [0]])))
    return list(zip(edges[::2], edges[1::2]))


class Importer:
    """A deterministic Model Exchange importer: explicit Euler steps of h over fmi2GetDerivatives
    (one slope per step: no stage can reach past a slip's end, see the RK4 limit above); a crossing
    of an indicator (> 0 to <= 0) at a step's end is located on the step's line by bisection to
    1e-14 s, the step cut there, and fmi2NewDiscreteStates called until no more is needed."""

    def __init__(self, m: Model, t: float):
        self.m, self.t = m, t
        self.x = m.states()
        self.z = m.indicators()
        self.events = 0
        self.reinitialised = []  # valuesOfContinuousStatesChanged of each event
        self.times = []  # of each event

    def crossed(self, tau: float, k1: np.ndarray) -> bool:
        self.m.set_states(self.t + tau, self.x + tau * k1)
        return bool(np.any((self.z > 0) & (self.m.indicators() <= 0)))

    def run(self, steps: int, h: float) -> list[np.ndarray]:
        out = []
        for _ in range(steps):
            self.m.set_states(self.t, self.x)
            k1 = self.m.derivatives()
            tau = h
            if self.crossed(h, k1):
                lo = 0.0
                while tau - lo > 1e-14:
                    mid = 0.5 * (lo + tau)
                    lo, tau = (lo, mid) if self.crossed(mid, k1) else (mid, tau)
            self.t, self.x = self.t + tau, self.x + tau * k1
            self.m.set_states(self.t, self.x)
            self.m.fmu2.completedIntegratorStep()
            z = self.m.indicators()
            if np.any((self.z > 0) & (z <= 0)):
                self.m.fmu2.enterEventMode()
                self.events += 1
                changed = False
                while True:
                    needed, _, _, values_changed, _, _ = self.m.fmu2.newDiscreteStates()
                    changed |= values_changed
                    if not needed:
                        break
                self.reinitialised.append(changed)
                self.times.append(self.t)
                self.m.fmu2.enterContinuousTimeMode()
                self.x = self.m.states()
                z = self.m.indicators()
            self.z = z
            out.append(np.concatenate([[self.t], self.x, [self.m.get("contact_mode")]]))
        return out


def _me_start(fmu, start) -> Importer:
    m = Model(fmu, logging_on=False)
    m.init(**TIGHT, **start)
    while m.fmu2.newDiscreteStates()[0]:
        pass
    m.fmu2.enterContinuousTimeMode()
    return Importer(m, 0.0)


@pytest.mark.parametrize("start, t_save, mode", [(BACKSPIN, 0.2, 1.0), (DROP, 0.2, 2.0)], ids=["slide", "flight"])
def test_model_exchange_state_keeps_the_mode(hybrid, start, t_save, mode):
    """Each switch is an event the importer finds on the indicators, fmi2NewDiscreteStates reports
    valuesOfContinuousStatesChanged (the upright slide's at t*: its motion is linear in t, which
    Euler steps exactly). Save the FMU state mid-slide (mid-flight), serialise it, restore it into a
    fresh instance: the mode, the local states (x_dot, y_dot, slip direction, z_centre, z_dot) and
    the indicators come back, and the importer's run from there, through the switch to rolling
    (through impacts), equals the uninterrupted run bit for bit."""
    h = 1e-3
    a = _me_start(hybrid, start)
    first = a.run(int(round(t_save / h)), h)
    assert first[-1][-1] == mode
    state = a.m.fmu2.getFMUstate()
    blob = a.m.fmu2.serializeFMUstate(state)
    a.m.fmu2.freeFMUstate(state)
    x_saved, z_saved = a.x.copy(), a.z.copy()
    a.events = 0
    rest = a.run(int(round((0.6 - t_save) / h)), h)
    if mode == 1.0:  # the switch to rolling after the save
        assert a.events == 1 and rest[-1][-1] == 0.0
        assert a.times[0] == pytest.approx(T_STAR, abs=1e-9)
    else:  # impacts after the save
        assert a.events >= 2
    assert all(a.reinitialised)  # each switch re-initialises the continuous states (FMI 2.0, 3.2.2)
    b = Model(hybrid, logging_on=False)
    b.init(**TIGHT)  # other start values: everything must come from the state
    restored = b.fmu2.deSerializeFMUstate(blob)
    b.fmu2.setFMUstate(restored)
    b.fmu2.freeFMUstate(restored)
    assert b.get("contact_mode") == mode
    np.testing.assert_array_equal(b.states(), x_saved)
    np.testing.assert_array_equal(b.indicators(), z_saved)
    again = Importer(b, first[-1][0])
    np.testing.assert_array_equal(np.array(again.run(len(rest), h)), np.array(rest))
    a.m.free()
    b.free()


@pytest.mark.parametrize("start, t_save, mode", [(BACKSPIN, 0.2, 1.0), (DROP, 0.2, 2.0)], ids=["slide", "flight"])
def test_cosimulation_state_serialised_keeps_the_mode_and_logs_the_switch(hybrid, start, t_save, mode):
    """Co-Simulation: the switch is located inside one fmi2DoStep and logged in category logEvents;
    a state serialised mid-slide (mid-flight) and restored into a fresh instance reproduces the
    rest of the run bit for bit."""
    names = ("contact_mode", "x", "vx", "gamma_dot", "height", "vz", "slip_long", "dissipated_energy")
    a = Slave(hybrid)
    a.slave.setDebugLogging(True, ["logEvents"])
    a.init(**TIGHT, **start)
    a.slave.doStep(0.0, t_save)
    assert a.get("contact_mode") == mode
    blob = a.slave.serializeFMUstate(a.slave.getFMUstate())
    a.messages.clear()
    first = []
    for k in range(4):
        a.slave.doStep(t_save + 0.1 * k, 0.1)
        first.append(a.get(*names))
    assert first[-1][0] == 0.0
    switches = [(cat, text) for _, cat, text in a.messages if text.startswith("event contact_")]
    assert switches and all(cat == "logEvents" for cat, _ in switches)
    b = Slave(hybrid, logging_on=False)
    b.init(**TIGHT)
    b.slave.setFMUstate(b.slave.deSerializeFMUstate(blob))
    assert b.get("contact_mode") == mode
    second = []
    for k in range(4):
        b.slave.doStep(t_save + 0.1 * k, 0.1)
        second.append(b.get(*names))
    assert second == first
    a.free()
    b.free()
