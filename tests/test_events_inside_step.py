"""Events that start and end inside one internal step (c_src/gw_events.c, docs/runtime.md).

Results must not depend on max_step or the communication grid beyond the solver's tolerance:
an indicator changes sign once per physical crossing (the stiction laws' signed stuck form,
docs/effects.md "Stiction"), and an indicator with the same sign at both ends of a step is
searched inside it where its cubic interpolant shows a dip across 0.

References the code did not produce: scipy's DOP853 with its own event location on the CasADi
model (studies/scipy_reference.py), and for the break-away before lift-off the values of an
independent reference (0.363059972 s and 0.3664304670 s, leaning 10 deg, heading 0.7 rad);
fmpy's CVode with its own event location on the Model Exchange interface for the lunar rover.
"""
from __future__ import annotations

import ctypes
import math
import re

import numpy as np
import pytest
from fmpy import simulate_fmu

from fmi_helpers import Model, Slave
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.model.build import build_model
from paper_wheel import PAPER_WHEEL_TOML as WHEEL
from reference.hybrid_lift_off import to_lift_off

EFFECTS = {"gravity": {}, "slope": {}, "rolling_resistance": {}, "spin_friction": {}, "energy": {}}
TIGHT = {"rel_tol": 1e-10, "abs_tol": 1e-12}


def leaning(lean_deg: float, heading: float) -> dict:
    """A wheel at rest on a 0.5 deg slope, leaning lean_deg, both laws held (c_rr 0.02, c_pivot 0.002)."""
    return dict(slope_angle=math.radians(0.5), c_rr=0.02, c_pivot=0.002, beta=math.radians(90.0 - lean_deg),
                alpha=heading, gamma_dot=0.0)


@pytest.fixture(scope="module")
def lean_fmu(tmp_path_factory) -> str:
    root = tmp_path_factory.mktemp("lean")
    scene = parse_scene('[model]\nname = "lean"\n' + WHEEL + "[effects.slope]\n[effects.rolling_resistance]\n"
                        "[effects.spin_friction]\n[effects.energy]\n", "lean.toml")
    return str(build_fmu(scene, root / "lean.fmu", build_dir=root / "build").fmu)


def run_events(fmu, stop, dt, fmi_type="CoSimulation", **start):
    """simulate_fmu with the logEvents messages: (result, [(event name, t)])."""
    logs: list[str] = []

    def logger(*args):
        text = args[-1]
        logs.append(text.decode() if isinstance(text, bytes) else str(text))
    kw = {"solver": "CVode", "relative_tolerance": 1e-10} if fmi_type == "ModelExchange" else {}
    r = simulate_fmu(fmu, stop_time=stop, output_interval=dt, fmi_type=fmi_type, start_values=start,
                     debug_logging=True, logger=logger, output=["gamma_dot", "rolling_mode"], **kw)
    events = [(m.group(1), float(m.group(2))) for line in logs
              for m in [re.search(r"event (\w+) at t=(\S+?):? ", line + " ")] if m]
    return r, events


_REFERENCES: dict = {}


def scipy_reference(lean_deg: float, heading: float):
    """(break-away of the rolling law, lift-off) from scipy's DOP853 on the CasADi model."""
    key = (lean_deg, heading)
    if key not in _REFERENCES:
        t_lift, _, switches = to_lift_off(EFFECTS, leaning(lean_deg, heading), 1.0)
        t_break = [t for t, name in switches if name == "rolling_stiction"]
        _REFERENCES[key] = (t_break, t_lift)
    return _REFERENCES[key]


# (lean deg, heading rad, break-away s, lift-off s): the independent reference's values where it gave them
CASES = [(10.0, 0.7, 0.363059972, 0.3664304670), (5.0, 1.2, 0.456258857, None)]


@pytest.mark.parametrize("max_step", [None, 1e-2, 1e-3])
@pytest.mark.parametrize("lean_deg, heading, t_break, t_lift", CASES)
def test_break_away_just_before_lift_off_is_seen_at_every_max_step(lean_fmu, lean_deg, heading, t_break, t_lift,
                                                                     max_step):
    """The rolling law breaks away a few ms before lift-off; the stuck indicator is negative only
    in between (F_n, and the limit with it, then drops below 0). Co-Simulation with 0.05 s
    communication steps sees the break-away at every max_step and lifts off rolling."""
    start = {**leaning(lean_deg, heading), **TIGHT}
    if max_step is not None:
        start["max_step"] = max_step
    r, events = run_events(lean_fmu, 1.0, 0.05, **start)
    ref_break, ref_lift = scipy_reference(lean_deg, heading)
    assert [n for n, _ in events] == ["pivot_stiction", "rolling_stiction", "lift_off"]
    assert len(ref_break) == 1
    assert events[1][1] == pytest.approx(ref_break[0], abs=1e-9)
    assert events[1][1] == pytest.approx(t_break, abs=1e-9)  # the reference's 9 digits
    assert events[2][1] == pytest.approx(ref_lift, abs=1e-9)
    if t_lift is not None:
        assert events[2][1] == pytest.approx(t_lift, abs=1e-9)
    assert r["rolling_mode"][-1] == 1.0 and r["gamma_dot"][-1] > 0.0  # lifts off rolling


def test_lift_off_is_reported_on_its_far_side(lean_fmu):
    """The state a terminating event ends at is the right end of its final bracket: the lift-off
    indicator F_n evaluated there (by the same FMU's C, through Model Exchange) is <= 0. A location
    at the left end (F_n still > 0 there) fails here; the time is the independent root's."""
    start = {**leaning(10.0, 0.7), **TIGHT}
    events = [e.name for e in build_model(effects=EFFECTS).events]
    s = Slave(lean_fmu)
    s.init(**start)
    t = 0.0
    while not s.get("lifted_off"):
        assert t < 1.0
        s.raw("fmi2DoStep", ctypes.c_double(t), ctypes.c_double(0.05), 1)
        t += 0.05
    t_end = s.fmu2.getRealStatus(2)  # fmi2LastSuccessfulTime
    m = Model(lean_fmu, name="check")
    m.init(**start)
    m.fmu2.enterContinuousTimeMode()
    x = np.array([s.get(d.variable.derivative.name) for d in m.md.derivatives])
    m.set_states(t_end, x)
    z = m.indicators()
    assert len(z) == len(events)
    assert z[events.index("lift_off")] <= 0.0
    assert t_end == pytest.approx(0.3664304670, abs=1e-9)
    s.free()
    m.free()


@pytest.mark.parametrize("max_step", [None, 1e-2, 1e-3])
def test_short_second_slip_is_reported_by_co_simulation_as_by_model_exchange(example_build, max_step):
    """lunar_rover with the scene's defaults: the slip indicator, negative since the first slip,
    rises above 0 for about a millisecond and falls back at 17.4668 s, inside one internal step.
    Co-Simulation reports that second slip as fmpy's CVode does through Model Exchange."""
    fmu = example_build("lunar_rover").fmu
    start = {} if max_step is None else {"max_step": max_step}
    _, cs = run_events(fmu, 17.5, 0.02, **start)
    _, me = run_events(fmu, 17.5, 0.02, "ModelExchange")
    assert [n for n, _ in cs] == [n for n, _ in me] == ["slip", "slip", "rolling_stiction", "fall"]
    for (_, t_cs), (_, t_me) in zip(cs, me):
        assert t_cs == pytest.approx(t_me, abs=1e-6)  # CVode's own location at rtol 1e-10: 7e-8 apart
    assert cs[1][1] == pytest.approx(17.4668, abs=1e-4)


def test_a_law_that_fires_while_stuck_breaks_away():
    """The update of a stuck law (its indicator reached 0) leaves the stuck mode even where the hold
    test at the located point passes by a rounding: re-sticking there would fire the same
    break-away again at once. Upright on a slope whose tangent is just below c_rr (it holds: the
    stuck indicator is > 0), the update forced anyway slides downhill, mode -sign(H)."""
    spec = build_model(effects={"gravity": {}, "slope": {}, "rolling_resistance": {}})
    fns = spec.functions()
    start = dict(slope_angle=math.atan(0.02 * (1 - 1e-12)), c_rr=0.02, beta=math.pi / 2, gamma_dot=0.0)
    p = np.array([start.get(q.name, q.start) for q in spec.parameters])
    x0 = np.array(fns["init"]([start.get(q.name, q.start) for q in spec.starts], p)).ravel()
    k = [e.name for e in spec.events].index("rolling_stiction")
    i_mode = spec.x_names.index("rolling_mode")
    assert x0[i_mode] == 0.0 and float(fns["evt"](0.0, x0, [], p)[k]) > 0.0  # held
    x1 = np.array(fns["upd"](0.0, x0, [], p, k)).ravel()
    assert x1[i_mode] != 0.0
    # and a sliding law that reaches 0 there sticks: the same hold test, the indicator's own form
    sliding = x0.copy()
    sliding[i_mode] = 1.0
    assert np.array(fns["upd"](0.0, sliding, [], p, k)).ravel()[i_mode] == 0.0
