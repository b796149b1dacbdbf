"""Hard-case family 10 (examples/hard_cases.py): inconsistent input gives a clear fmi2Error with a
logged reason, never a hang or a NaN.

Initial states on the wrong side of beta_min, NaN / Inf parameters and start values, absurd rates
(gamma_dot = 1e9 rad/s: the rim would move at 1.7e8 m/s) and, for contrast, large but sane rates
(2e4 rad/s) that must simply work.
"""
from __future__ import annotations

import math
import time

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime

from conftest import STATES
from fmi_helpers import Slave
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.model.build import BETA_MIN_DEFAULT

SCENE = """
[model]
name = "hard_inputs"
# [wheel]: the defaults, the paper wheel (M 2 kg, R 0.17 m, k 0.25 / 0.4, beta_min 1e-3)
[effects.gravity]
g = 9.81
[experiment]
max_step = 0.05
"""


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    root = tmp_path_factory.mktemp("hard_inputs")
    return str(build_fmu(parse_scene(SCENE, "hard_inputs.toml"), root / "hard_inputs.fmu").fmu)


@pytest.fixture
def slave(fmu):
    s = Slave(fmu)
    yield s
    s.free()


def _error_logged(s: Slave) -> bool:
    return any(status >= 3 for status, _, _ in s.messages)


@pytest.mark.parametrize("values", [
    {"beta": 5e-4},                           # below beta_min
    {"beta": math.pi - 5e-4},                 # beyond pi - beta_min (flat on the other side)
    {"beta": BETA_MIN_DEFAULT},               # exactly at beta_min: the fall indicator is 0
    {"beta": 0.3, "beta_min": 0.5},           # a larger beta_min puts a leaning start on the wrong side
])
def test_initial_state_on_the_wrong_side_of_beta_min(slave, values):
    with pytest.raises(FMICallException) as exc:
        slave.init(**values)
    assert exc.value.status == 3  # fmi2Error
    assert "initial lean beta must lie between beta_min and pi - beta_min" in slave.log_text()
    assert _error_logged(slave)


@pytest.mark.parametrize("values,fragment", [
    ({"beta": -0.1}, "beta (initial lean) must be > 0"),
    ({"beta": 3.2}, "beta (initial lean) must be < pi"),
])
def test_initial_lean_outside_0_pi(slave, values, fragment):
    with pytest.raises(FMICallException):
        slave.init(**values)
    assert fragment in slave.log_text()


@pytest.mark.parametrize("name", ["M", "R", "k_diam", "k_axial", "g", "beta_min", "rel_tol", "abs_tol", "max_step",
                                  "x", "beta", "alpha_dot", "gamma_dot"])
@pytest.mark.parametrize("value", [float("nan"), float("inf"), float("-inf")])
def test_non_finite_values_are_refused_when_set(slave, name, value):
    """fmi2SetReal refuses NaN / Inf for every parameter and start value, naming the variable."""
    slave.slave.setupExperiment(startTime=0.0)
    with pytest.raises(FMICallException) as exc:
        slave.set(**{name: value})
    assert exc.value.status == 3
    assert f"variable {name} " in slave.log_text() and "not finite" in slave.log_text()


def test_overflowing_start_value_fails_at_initialisation(slave):
    """gamma_dot = 1e300 is finite, but its energy is not: refused by the start rates' range
    (model/spec.py RATE_RANGE), not propagated as inf."""
    with pytest.raises(FMICallException):
        slave.init(gamma_dot=1e300)
    assert "fmi2ExitInitializationMode: gamma_dot must lie in [-1e+09, 1e+09] rad/s" in slave.log_text()


@pytest.mark.parametrize("solver", [3, 5])  # dopri5, dop853
@pytest.mark.parametrize("rate", ["gamma_dot", "alpha_dot"])
def test_huge_rates_fail_fast_with_a_reason(slave, solver, rate):
    """1e9 rad/s: fmi2Error within seconds (no hang), state restored to the step start, nothing NaN."""
    slave.init(solver=solver, **{rate: 1e9})
    t0 = time.process_time()
    with pytest.raises(FMICallException) as exc:
        slave.slave.doStep(0.0, 1.0)
    elapsed = time.process_time() - t0
    assert exc.value.status == 3
    assert elapsed < 3.0, elapsed
    log = slave.log_text()
    assert "would need about" in log or "step size underflow" in log, log[-500:]
    assert slave.slave.getRealStatus(fmi2LastSuccessfulTime) == 0.0
    values = slave.get(*STATES)
    assert all(math.isfinite(v) for v in values)
    assert slave.get(rate) == 1e9  # back at the start of the step


BETA_MIN = 0.02


@pytest.mark.parametrize("solver", [3, 5])
def test_huge_lean_rate_falls_within_nanoseconds(slave, solver):
    """beta_dot = 1e9 rad/s is not too fast to simulate: the wheel swings through upright and lies
    flat on the other side (beta = pi - beta_min) after (pi - beta_min - beta0) / 1e9 = 1.7 ns,
    and the FMU says exactly that: a located fall, fmi2Discard, within a few seconds.
    beta_min = 0.02 (not the default 1e-3): below 0.01 rad from flat at 1e9 rad/s, beta_ddot ~ 1e16
    forces steps of 5e-13 s, and DOPRI5's step budget, which extrapolates that step over the whole
    remaining 1 s, refuses (fmi2Error with the estimate) 1e-11 s before the fall."""
    slave.init(solver=solver, beta_dot=1e9, beta_min=BETA_MIN)
    t0 = time.process_time()
    with pytest.raises(FMICallException) as exc:
        slave.slave.doStep(0.0, 1.0)
    assert time.process_time() - t0 < 3.0
    assert exc.value.status == 2
    t_fall = slave.slave.getRealStatus(fmi2LastSuccessfulTime)
    assert t_fall == pytest.approx((math.pi - BETA_MIN - math.radians(80)) / 1e9, rel=1e-3)
    assert slave.get("beta") == pytest.approx(math.pi - BETA_MIN, abs=1e-9)
    assert all(math.isfinite(v) for v in slave.get(*STATES))


def test_huge_spin_guard_names_the_step_count(slave):
    slave.init(solver=5, gamma_dot=1e9)
    with pytest.raises(FMICallException):
        slave.slave.doStep(0.0, 1.0)
    assert "internal steps of h=" in slave.log_text()
    assert "try solver rosenbrock" in slave.log_text()


def test_huge_spin_with_rosenbrock_returns_fast(slave):
    """Rosenbrock (L-stable) damps the 1e9 rad/s nutation's fast mode instead of resolving it
    and finishes the second in a few dozen steps; the slow motion is right: rolling along x at
    R gamma_dot, lean held by the gyroscopic stiffness, energy conserved."""
    slave.init(solver=4, gamma_dot=1e9)
    e0 = slave.get("energy")
    t0 = time.process_time()
    slave.slave.doStep(0.0, 1.0)
    assert time.process_time() - t0 < 3.0
    assert all(math.isfinite(v) for v in slave.get(*STATES))
    x, beta, gamma_dot, e = slave.get("x", "beta", "gamma_dot", "energy")
    assert x == pytest.approx(0.17 * 1e9, rel=1e-9)
    assert beta == pytest.approx(math.radians(80), abs=1e-9)
    assert gamma_dot == pytest.approx(1e9, rel=1e-12)
    assert e == pytest.approx(e0, rel=1e-9)


@pytest.mark.parametrize("max_step", [0.01, 0.05])
def test_huge_spin_with_a_fixed_step_solver_is_not_reported_as_a_fall(slave, max_step):
    """RK4 at max_step 0.01 or 0.05 s is unstable at 1e9 rad/s (h |lambda| ~ 1e7). Whatever the runtime does,
    it must not pass the blow-up off as a located fall with an absurd state: either a clear
    fmi2Error with a reason, or a finite, physical state."""
    slave.init(solver=2, gamma_dot=1e9, max_step=max_step)
    try:
        slave.slave.doStep(0.0, 1.0)
        status = 0
    except FMICallException as exc:
        status = exc.status
    values = slave.get(*STATES)
    assert all(math.isfinite(v) for v in values)
    if status == 3:
        assert _error_logged(slave)
        return
    beta, alpha_dot = slave.get("beta", "alpha_dot")
    assert 0.0 < beta < math.pi, f"status {status}, beta = {beta} rad:\n{slave.log_text()[-400:]}"
    assert abs(alpha_dot) < 1e3, f"status {status}, alpha_dot = {alpha_dot} rad/s"


# Fixed steps beyond the solvers' stability limits, as users ran them (gyrowheel simulate on the
# paper wheel): (solver, start values, max_step = communication step, stop time).  Before the
# limits were checked, each ended in a "fall" with an absurd state: beta = -31.4, 185 or 927 rad,
# energy up 10^3 to 10^14 times, exit status 0.
UNSTABLE_FIXED_STEPS = [
    ("euler", {"gamma_dot": 1e5}, 0.01, 0.2),
    ("euler", {"gamma_dot": 1e5}, 0.001, 0.2),
    ("euler", {}, 0.01, 20.0),  # the paper's run with euler at 0.01 s: energy x800 by the "fall" at 4.85 s
    ("rk4", {"gamma_dot": 20.0}, 1.0, 100.0),
    ("rk4", {"gamma_dot": 1e3}, 0.01, 20.0),
    # a dip towards flat (the reference survives it, beta >= 0.105 rad): its rates grow as 1 / sin(beta),
    # and the step that turned to garbage near its end (energy x2.5e19) passed RK4's check of its stages
    ("rk4", {"gamma_dot": 3.0, "beta": math.radians(45)}, 0.05, 5.0),
]


@pytest.mark.parametrize("solver, values, h, stop", UNSTABLE_FIXED_STEPS,
                         ids=[f"{s}-h{h:g}-{'-'.join(f'{k}{v:g}' for k, v in v.items()) or 'paper'}"
                              for s, v, h, _ in UNSTABLE_FIXED_STEPS])
def test_fixed_steps_beyond_their_stability_limit_are_refused_not_a_fall(slave, solver, values, h, stop):
    """Each communication step of h with max_step = h: the run stops with fmi2Error naming the
    solver's instability and its h |lambda| estimate, before the wheel has 'fallen'; the state
    is the last good one (finite, beta inside (0, pi))."""
    slave.init(solver={"euler": 1, "rk4": 2}[solver], max_step=h, **values)
    t, status = 0.0, 0
    while t < stop - 1e-12 and status == 0:
        try:
            slave.slave.doStep(t, h)
            t += h
        except FMICallException as exc:
            status = exc.status
    log = slave.log_text()
    assert status == 3, f"{solver} ran to t = {t:g} s with fallen = {slave.get('fallen')}:\n{log[-400:]}"
    assert f"{solver} is unstable at t=" in log and "h |lambda| ~ " in log, log[-400:]
    assert not slave.get("fallen")
    beta, *states = slave.get("beta", *STATES)
    assert all(math.isfinite(v) for v in states) and 0.0 < beta < math.pi


@pytest.mark.parametrize("solver, h", [("euler", 1e-4), ("rk4", 0.01)])
def test_fixed_steps_inside_their_stability_limit_run(slave, solver, h):
    """The paper's 20 s in communication steps of h = max_step: euler at 1e-4 s drifts in energy
    (docs/accuracy.md: 2.7e-3 in 20 s), rk4 at 0.01 s keeps it to 1e-6; neither is refused."""
    slave.init(solver={"euler": 1, "rk4": 2}[solver], max_step=h)
    e0 = slave.get("energy")
    slave.slave.doStep(0.0, 20.0)
    assert not slave.get("fallen") and "unstable" not in slave.log_text()
    assert slave.get("energy") == pytest.approx(e0, rel={"euler": 1e-2, "rk4": 1e-6}[solver])


@pytest.mark.parametrize("solver", [3, 4, 5])
def test_large_but_sane_spin_simply_works(fmu, solver):
    """gamma_dot = 2e4 rad/s (rim at 3.4 km/s): 1 s in one step, in under 2 s of process CPU time
    (not wall time, which a loaded machine stretches),
    energy conserved, rolling at R gamma_dot, lean held."""
    s = Slave(fmu)
    try:
        s.init(solver=solver, gamma_dot=2e4, rel_tol=1e-10, abs_tol=1e-12, max_step=1.0)
        e0 = s.get("energy")
        t0 = time.process_time()
        s.slave.doStep(0.0, 1.0)
        elapsed = time.process_time() - t0
        x, beta, gamma, e = s.get("x", "beta", "gamma", "energy")
    finally:
        s.free()
    assert elapsed < 2.0
    assert e == pytest.approx(e0, rel=1e-8)
    assert x == pytest.approx(0.17 * 2e4, rel=1e-6)
    assert gamma == pytest.approx(2e4, rel=1e-6)
    assert beta == pytest.approx(math.radians(80), abs=1e-7)
