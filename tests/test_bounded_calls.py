"""Every fmi2DoStep returns in bounded time: the budget of internal steps (docs/fmi.md).

`max_internal_steps` (an FMI parameter and a scene setting) bounds the internal steps, accepted and
rejected together, of one call. A step that needs more is refused up front when the count is known
(ceil(H / max_step) is a lower bound for every solver, exact for euler and rk4) or stopped when the
budget runs out, with the estimate in the message; the instance stays at the start of the step.
Each case is a call a fuzzer made, here with a small budget so that it runs in milliseconds; the
docstring gives the time the call takes without a budget and the test asserts that it returns at
once.
"""
from __future__ import annotations

import math
import re
import time

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime

from conftest import ROOT, STATES
from fmi_helpers import Slave
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.fmu_build.scene import SceneError

SCENE = "[model]\nname = 'bounded'\n[effects.gravity]\ng = 9.81\n[experiment]\nmax_step = 0.05\n"


@pytest.fixture(scope="module")
def euler_disk_smoothed(tmp_path_factory):
    """examples/scenes/euler_disk.toml with law = "smoothed" for rolling_resistance: the law of the
    fuzzer's report (the tanh law is stiff at huge c_rr; the default stiction law is not)."""
    root = tmp_path_factory.mktemp("bounded_disk")
    text = (ROOT / "examples" / "scenes" / "euler_disk.toml").read_text()
    text = text.replace("[effects.rolling_resistance]\n", '[effects.rolling_resistance]\nlaw = "smoothed"\n', 1)
    assert 'law = "smoothed"' in text
    return str(build_fmu(parse_scene(text, "euler_disk_smoothed.toml"), root / "disk.fmu").fmu)


@pytest.fixture
def slave(earth_fmu):
    """the paper's earth wheel (examples/scenes/paper_earth.toml: dopri5, max_step 0.05 s)"""
    s = Slave(earth_fmu)
    yield s
    s.free()


def refused(s: Slave, t: float, h: float) -> tuple[float, str]:
    """fmi2DoStep(t, h) must fail with fmi2Error; returns (seconds, log)."""
    t0 = time.process_time()
    with pytest.raises(FMICallException) as exc:
        s.slave.doStep(t, h)
    seconds = time.process_time() - t0
    assert exc.value.status == 3
    return seconds, s.log_text()


def assert_state_kept(s: Slave, before: list[float], t: float) -> None:
    assert s.get(*STATES) == before
    assert s.slave.getRealStatus(fmi2LastSuccessfulTime) == t


def steps_taken(log: str) -> int:
    return int(re.search(r"\((\d+) steps taken in this call\)", log)[1])


def test_huge_communication_step_is_refused_up_front(slave):
    """fmi2DoStep(0, 1e9), hours without a budget (1e4 s take 1.6 s with 720k DOPRI5 steps): refused
    before any work, since at max_step 0.05 s (set) it needs at least 2e10 steps, more than the default
    budget 1e6."""
    slave.init(solver=3, max_step=0.05)
    before = slave.get(*STATES)
    seconds, log = refused(slave, 0.0, 1e9)
    assert seconds < 0.5
    assert "would need at least 2e+10 internal steps of max_step=0.05" in log
    assert "max_internal_steps = 1000000" in log and "refused before any work" in log
    assert_state_kept(slave, before, 0.0)
    slave.slave.reset()  # after fmi2Error FMI 2.0 allows reset; the instance works again
    slave.init(solver=3, max_step=0.05)
    slave.slave.doStep(0.0, 0.1)
    assert slave.get("beta") != before[3]


def test_huge_step_with_a_huge_max_step_stops_when_the_budget_is_spent(slave):
    """The same with max_step = 1e9 (so the up-front count says nothing): DOPRI5 stops within the budget
    (here 2000 steps, accepted and rejected), either when the settled step size projects 100x more than
    the budget has left or when the budget is spent, with its estimate of what the rest needs."""
    slave.init(solver=3, max_step=1e9, max_internal_steps=2000)
    before = slave.get(*STATES)
    seconds, log = refused(slave, 0.0, 1e4)
    assert seconds < 0.5
    assert "max_internal_steps = 2000" in log
    assert "the budget of internal steps is spent" in log or "the step size has settled" in log
    assert steps_taken(log) <= 2000
    estimate = float(re.search(r"would need about ([0-9.e+]+) internal steps", log)[1])
    assert 1e5 < estimate < 1e7  # 720k steps for 1e4 s, measured without a budget
    assert_state_kept(slave, before, 0.0)


def test_a_long_communication_step_of_a_benign_run_is_told_to_shorten_it(slave):
    """The paper's wheel at its defaults in one call of 1e6 s (as `gyrowheel simulate --stop-time 1e6
    --output-interval 1e6` makes it): the steps are ordinary (tens of ms), the call is simply longer
    than the budget covers.  The message says so first, and leaves the diagnosis of a too fast or
    stiff motion to a step far below the motion's time scale, which it quotes."""
    slave.init(max_step=1e6)
    _, log = refused(slave, 0.0, 1e6)
    h = float(re.search(r"internal steps of h=(\S+), more than", log)[1])
    assert 1e-3 < h < 1.0, log[-600:]
    assert (f"steps taken in this call): shorten the communication step or raise max_internal_steps; if steps of "
            f"{h:g} s are far below the time scale of the motion, the dynamics are too fast") in log, log[-600:]
    assert "far too fast" not in log


def test_rosenbrock_long_step_is_bounded(slave):
    """rosenbrock fmi2DoStep(0, 1e5), more than 30 s without a budget: refused up front at max_step
    0.05 s (2e6 steps), and with max_step relaxed stopped by a budget of 300 steps in milliseconds."""
    slave.init(solver=4, max_step=0.05)
    seconds, log = refused(slave, 0.0, 1e5)
    assert seconds < 0.5 and "would need at least 2e+06 internal steps" in log
    slave.slave.reset()
    slave.messages.clear()
    slave.init(solver=4, max_step=1e5, max_internal_steps=300)
    before = slave.get(*STATES)
    seconds, log = refused(slave, 0.0, 1e5)
    assert seconds < 1.0
    assert steps_taken(log) <= 300 and "max_internal_steps = 300" in log
    assert_state_kept(slave, before, 0.0)


def test_budget_stops_a_step_the_projection_lets_through(slave):
    """With the projection out of the way (a budget close to what the step needs, 20 s at loose
    tolerance with max_step 1 s), the budget itself stops the call at exactly its count."""
    slave.init(solver=5, max_step=1.0, rel_tol=1e-10, max_internal_steps=200)
    before = slave.get(*STATES)
    _, log = refused(slave, 0.0, 20.0)
    assert "the budget of internal steps is spent" in log and steps_taken(log) == 200
    assert_state_kept(slave, before, 0.0)


def test_tiny_max_step_is_refused_up_front(slave):
    """max_step = 1e-10, then a 0.01 s step (4 minutes without a budget): refused at once, 1e8 steps needed."""
    slave.init(solver=3, max_step=1e-10)
    before = slave.get(*STATES)
    seconds, log = refused(slave, 0.0, 0.01)
    assert seconds < 0.5 and "would need at least 1e+08 internal steps of max_step=1e-10" in log
    assert_state_kept(slave, before, 0.0)


def test_rk4_exact_step_count_is_refused_up_front(slave):
    """rk4 with max_step = 1e-9 over 1 s (25 minutes without a budget): refused at once; the fixed step's
    count is exact (1e9)."""
    slave.init(solver=2, max_step=1e-9)
    before = slave.get(*STATES)
    seconds, log = refused(slave, 0.0, 1.0)
    assert seconds < 0.5
    assert "would need 1e+09 internal steps of max_step=1e-09" in log and "at least" not in log
    assert_state_kept(slave, before, 0.0)


def test_rk4_within_the_budget_runs(slave):
    """The exact count is the limit: 100 substeps with a budget of 100 run, 101 are refused."""
    slave.init(solver=2, max_step=0.01, max_internal_steps=100)
    slave.slave.doStep(0.0, 1.0)
    _, log = refused(slave, 1.0, 1.01 - 1e-9 + 0.0)
    assert "would need 101 internal steps" in log


def test_stiff_rolling_resistance_is_stopped_by_the_budget(euler_disk_smoothed):
    """euler_disk with c_rr = 1.001e6 (accepted), smoothed law, 12.7 s for a 1e-4 s step without a
    budget: the step is stopped by a budget of 5000 steps (or refused earlier by the projection), in
    milliseconds, and the instance is back at the step start. (With the default law, stiction, the
    same c_rr is not stiff: the rim sticks at once, test_stiction.py::test_huge_rolling_resistance_brakes_at_once.)"""
    s = Slave(euler_disk_smoothed)
    try:
        s.init(c_rr=1.001e6, max_internal_steps=5000)
        before = s.get(*STATES)
        seconds, log = refused(s, 0.0, 1e-4)
        assert seconds < 1.0
        assert "max_internal_steps = 5000" in log and "would need about" in log
        assert steps_taken(log) <= 5000
        assert_state_kept(s, before, 0.0)
    finally:
        s.free()


def test_rejected_steps_count_against_the_budget(slave):
    """A budget smaller than what a step costs stops it however accepted and rejected steps mix: the
    count in the message is the budget, and it includes the rejected ones (at loose tolerance from a
    wild start DOPRI5 rejects some)."""
    slave.init(solver=3, max_step=10.0, rel_tol=1e-3, gamma_dot=2000.0, beta=1.2, max_internal_steps=50)
    _, log = refused(slave, 0.0, 10.0)
    assert steps_taken(log) == 50


@pytest.mark.parametrize("value", [0, -5])
def test_budget_must_be_positive(slave, value):
    """Refused at the call, fmi2SetInteger itself, like every setting (docs/fmi.md, "Settings and
    their valid ranges"), not only later at fmi2ExitInitializationMode."""
    slave.slave.setupExperiment(startTime=0.0)
    with pytest.raises(FMICallException) as exc:
        slave.set(max_internal_steps=value)
    assert exc.value.status == 3
    assert f"fmi2SetInteger: max_internal_steps = {value} must be a whole number from 1 to 2147483647" \
        in slave.log_text()


def test_budget_is_a_scene_setting(tmp_path):
    scene = parse_scene(SCENE + "max_internal_steps = 20\n", "b.toml")
    assert scene.experiment.max_internal_steps == 20
    built = build_fmu(scene, tmp_path / "b.fmu")
    s = Slave(str(built.fmu))
    try:
        s.init(solver=3, max_step=1.0)
        assert s.get("max_internal_steps") == 20
        _, log = refused(s, 0.0, 100.0)
        assert "would need at least 100 internal steps of max_step=1" in log
    finally:
        s.free()
    for bad in ("0", "1.5", "true", "3000000000"):
        with pytest.raises(SceneError, match=r"\[experiment\] max_internal_steps: must be a whole number"):
            parse_scene(SCENE + f"max_internal_steps = {bad}\n", "b.toml")


def test_budget_survives_a_saved_state(slave):
    slave.init(solver=3, max_internal_steps=1234)
    state = slave.slave.getFMUstate()
    slave.slave.reset()
    slave.init(solver=3)
    slave.slave.setFMUstate(state)
    assert slave.get("max_internal_steps") == 1234
    assert math.isfinite(slave.get("beta"))


def test_a_budget_set_below_the_default_is_named_as_the_cause(example_build, tmp_path, capsys):
    """The drop (examples/scenes/drop_bounce.toml) with max_internal_steps = 1: 1 ms communication
    steps of a 1 s run need about 1000 internal steps, which the default budget (1e6) covers; the
    run stops at t = 0.1 s (100 x the budget spent) and says that the budget set is the cause, not
    fast dynamics."""
    from gyrowheel.cli import main
    fmu = example_build("drop_bounce").fmu
    assert main(["simulate", str(fmu), "--set", "max_internal_steps=1", "-o", str(tmp_path / "d.csv")]) == 1
    err = capsys.readouterr().err
    assert "at t=0.10000000000000001 (the run's budget refuses the rest) the step budget max_internal_steps = 1 " \
           "is exhausted" in err and "raise it" in err, err
    s = Slave(fmu)
    try:
        s.init(max_internal_steps=1)
        t = 0.0
        with pytest.raises(FMICallException):
            while t < 1.0:
                s.slave.doStep(t, 1e-3)
                t += 1e-3
        log = s.log_text()
    finally:
        s.free()
    assert "the step budget max_internal_steps = 1 is exhausted" in log and "raise it" in log
    assert "far too fast" not in log and "rosenbrock" not in log
