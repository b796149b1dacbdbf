"""Hard-case families 7-8 (examples/hard_cases.py): communication steps from 1e-7 s to 100 s, a fall
inside one step, reversibility."""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated

from conftest import CasadiWheel, PAPER, STATES
from fmi_helpers import Slave
from gyrowheel.fmu_build import build_fmu, parse_scene

SCENE = """
[model]
name = "hard_steps"
[wheel]
M = 2.0
R = 0.17
k_diam = 0.25
k_axial = 0.4
beta_min = 0.1
[effects.gravity]
g = 9.81
[experiment]
rel_tol = 1e-10
abs_tol = 1e-12
max_step = 1.0
"""
TIGHT = dict(rel_tol=1e-12, abs_tol=1e-14)


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    root = tmp_path_factory.mktemp("hard_steps")
    # every run names dopri5, rosenbrock or dop853: no Taylor kernel
    return str(build_fmu(parse_scene(SCENE, "hard_steps.toml"), root / "hard_steps.fmu", taylor=False).fmu)


def _steps(fmu, hs, **start):
    """Run the list of communication steps hs; return (times, final states)."""
    s = Slave(fmu)
    try:
        s.init(**start)
        t, times = 0.0, []
        for h in hs:
            s.slave.doStep(t, h)
            t += h
            times.append((t, s.slave.getRealStatus(fmi2LastSuccessfulTime)))
        return times, np.array(s.get(*STATES))
    finally:
        s.free()


# -- 7. communication steps ---------------------------------------------------------

def test_tiny_steps_land_exactly_and_agree_with_one_step(fmu):
    """1000 steps of 1e-7 s land exactly on every t0 + h and agree with one step of 1e-4 s."""
    times, many = _steps(fmu, [1e-7] * 1000, solver=5, **TIGHT)
    assert all(t == last for t, last in times)
    _, one = _steps(fmu, [1e-4], solver=5, **TIGHT)
    np.testing.assert_allclose(many, one, rtol=0, atol=1e-13)


@pytest.fixture(scope="module")
def moon_100s():
    wheel = CasadiWheel(**{**PAPER, "g": 1.625})
    return wheel.integrate(wheel.x0(), 100.0, rtol=1e-12, atol=1e-13).y[:, -1]


@pytest.mark.parametrize("solver", [3, 4, 5])
def test_one_100_s_step_equals_fine_stepping_and_the_reference(fmu, moon_100s, solver):
    """100 s of rolling on the moon (no fall) in one fmi2DoStep, in 10^4 steps of 0.01 s and with a
    mixed sequence (1e-7 s ... 60 s): all land on t = 100 exactly and agree with scipy DOP853."""
    tol = dict(rel_tol=1e-11, abs_tol=1e-13) if solver != 4 else dict(rel_tol=1e-9, abs_tol=1e-11)
    bound = 2e-6 if solver != 4 else 1e-3
    start = dict(g=1.625, solver=solver, **tol)
    one_times, one = _steps(fmu, [100.0], **start)
    last1 = one_times[-1][1]
    mixed_hs = [1e-7, 1e-5, 1e-3, 0.1, 0.7777777, 3.0, 60.0]
    mixed_hs.append(100.0 - sum(mixed_hs))
    times, mixed = _steps(fmu, mixed_hs, **start)
    assert last1 == 100.0 and times[-1][1] == times[-1][0]
    assert all(t == last for t, last in times)
    ref = moon_100s
    # angles (alpha, beta) and rates: absolute; x, y, gamma grow: relative to their size
    scale = np.maximum(1.0, np.abs(ref))
    assert np.max(np.abs(one - ref) / scale) < bound
    assert np.max(np.abs(mixed - ref) / scale) < bound
    if solver == 5:
        _, fine = _steps(fmu, [0.01] * 10000, **start)
        assert np.max(np.abs(fine - one) / scale) < bound


def _reference_fall_time(beta_min: float, **start) -> float:
    return CasadiWheel(**PAPER, beta_min=beta_min).fall_time(beta_min, 1e-13, 1e-14, **start)


@pytest.fixture(scope="module")
def fall_times():
    return {"spin": _reference_fall_time(0.1, gamma_dot=1.0), "planar": _reference_fall_time(0.1, gamma_dot=0.0)}


def _fall(fmu, h, solver, **start):
    s = Slave(fmu)
    try:
        s.init(solver=solver, **TIGHT, **start)
        t, status = 0.0, None
        while t < 25.0:
            try:
                s.slave.doStep(t, h)
            except FMICallException as exc:
                status = exc.status
                break
            t += h
        beta, fallen = s.get("beta", "fallen")
        return (status, s.slave.getBooleanStatus(fmi2Terminated), s.slave.getRealStatus(fmi2LastSuccessfulTime),
                beta, fallen, t)
    finally:
        s.free()


@pytest.mark.parametrize("case,start", [("spin", {"gamma_dot": 1.0}), ("planar", {"gamma_dot": 0.0})])
@pytest.mark.parametrize("solver", [3, 4, 5])
def test_fall_time_independent_of_the_communication_step(fmu, fall_times, case, start, solver):
    """The fall inside one step of 1e-3 ... 20 s: fmi2Discard, terminated, LastSuccessfulTime the
    event time, the same for every step size to 1e-9 s and equal to scipy's located event."""
    events = []
    for h in (1e-3, 0.01, 0.1, 0.7, 3.0, 20.0):
        status, terminated, t_event, beta, fallen, t_comm = _fall(fmu, h, solver, **start)
        assert status == 2 and terminated and fallen
        assert t_comm <= t_event < t_comm + h  # inside the step that was asked for
        assert math.sin(beta) == pytest.approx(math.sin(0.1), abs=1e-9)
        events.append(t_event)
    spread = max(events) - min(events)
    assert spread < 1e-9, spread
    assert np.mean(events) == pytest.approx(fall_times[case], abs=1e-8 if solver != 4 else 1e-6)


# -- 8. reversibility ------------------------------------------------------------------

START = dict(beta=math.radians(80), gamma_dot=6.0, alpha_dot=0.3, beta_dot=-0.2)


def _forward_back(fmu, solver, rel_tol, T=5.0):
    opts = dict(solver=solver, rel_tol=rel_tol, abs_tol=rel_tol / 100, max_step=1.0, beta_min=0.02)
    _, end = _steps(fmu, [T], **opts, **START)
    back = dict(zip(STATES, end))
    for name in ("alpha_dot", "beta_dot", "gamma_dot"):
        back[name] = -back[name]
    _, final = _steps(fmu, [T], **opts, **back)
    expected = dict(x=0.0, y=0.0, alpha=0.0, gamma=0.0, **START)
    expected = np.array([expected[n] * (-1 if n.endswith("_dot") else 1) for n in STATES])
    return np.max(np.abs(final - expected)), np.max(np.abs(end[:2]))


@pytest.mark.parametrize("solver", [3, 5])
def test_reversibility_forward_flip_back(fmu, solver):
    """Forward 5 s (0.3 m of travel), rates flipped, 5 s back: the start is recovered to
    ~ 100 rel_tol, and the error falls with the tolerance."""
    errors = {}
    for rel_tol in (1e-8, 1e-10, 1e-12):
        errors[rel_tol], travel = _forward_back(fmu, solver, rel_tol)
        assert travel > 0.2
        assert errors[rel_tol] < 100 * rel_tol, (rel_tol, errors[rel_tol])
    assert errors[1e-12] < errors[1e-10] / 10 < errors[1e-8] / 100
