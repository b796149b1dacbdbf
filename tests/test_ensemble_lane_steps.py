"""The ensemble batch's ordinary lane-steps concluded and attempted inline, the lanes' states left
in the batch's columns (c_src/gw_ensemble_batch.h: gw_ens_fast_accept, gw_ens_fast_attempt,
gw_ens_sync), beside lanes whose step goes through the solver code in the same batch (an event
indicator changing sign: a fall, a stick or slip update; a communication point; a landing step;
the budget's projection refusing a trajectory; a new trajectory in a lane): every lane's steps,
times, states, grid outputs, event flags and messages bit for bit those of the same library
built with GW_ENSEMBLE_LANE_STEPS=1, where every lane-step goes through the solver code
(gw_taylor_conclude, gw_taylor_attempt) on the lane's own copy of its series and states."""
from __future__ import annotations

import numpy as np
import pytest

from gyrowheel.taylor.ensemble import STATUS_ERROR, STATUS_OK, STATUS_TERMINATED, Ensemble
from taylor_helpers import same_results as _same  # every result field equal, messages too


@pytest.fixture(scope="module")
def paper(example_build):
    return example_build("paper_earth", taylor=True)


@pytest.fixture(scope="module")
def slope(example_build):
    return example_build("slope_hold", taylor=True)


def _both(fmu, tmp_path):
    """The library as built (inline lane-steps) and with GW_ENSEMBLE_LANE_STEPS=1."""
    return (Ensemble(fmu, lanes=4, cache=tmp_path),
            Ensemble(fmu, lanes=4, cache=tmp_path, defines={"GW_ENSEMBLE_LANE_STEPS": 1}))


@pytest.mark.parametrize("rel_tol", [1e-4, 1e-7])
def test_paper_lanes_falling_refused_and_on_a_grid_equal_the_solver_code(paper, tmp_path, rel_tol):
    """11 trajectories on 4 lanes: some fall (terminating event, each at its own time, the lane
    refilled at once), a fast one (gamma_dot 1e4: 60,000 steps beside the others' hundred), at
    1e-7 one refused by the budget's projection (gamma_dot 1e9: 'max_internal_steps'), the rest
    run to the end beside them; without and with a communication grid (every lane lands on each
    point, its budget and guard starting anew).  (Fast spins:
    test_fast_spin_and_early_stick_equal_the_solver_code.)"""
    inline, per_lane = _both(paper.fmu, tmp_path)
    g = np.array([9.81, 3.721, 9.81, 9.81, 0.0, 9.81, 5.0, 1.625, 9.81, 9.81, 2.0])
    spin = np.array([6.0, 6.0, 1.0, 0.5, 3.0, 1e9 if rel_tol < 1e-5 else 30.0, 0.2, 1e4, 6.1, 0.8, 6.0])
    kw = dict(parameters={"g": g, "beta_min": 0.1}, starts={"gamma_dot": spin}, rel_tol=rel_tol,
              abs_tol=rel_tol * 1e-2)
    for extra in ({}, {"grid": np.linspace(0.4, 8.0, 19)}):
        a, b = inline.run(8.0, **kw, **extra), per_lane.run(8.0, **kw, **extra)
        _same(a, b)
        if rel_tol < 1e-5:
            assert a.status[5] == STATUS_ERROR and any("max_internal_steps" in m for m in a.messages)
        assert 2 <= (a.status == STATUS_TERMINATED).sum() and (a.status == STATUS_OK).sum() >= 5
        assert a.steps[0] > 20 and a.steps[7] > 30000  # the ordinary steps between the events


def test_budget_spent_after_ordinary_steps_equals_the_solver_code(paper, tmp_path):
    """gamma_dot 1e7 beside three ordinary trajectories: 840,000 ordinary steps in one call, then
    the budget's projection refuses it; the message gives the call's step count (the inline
    attempts count against the budget like gw_next_attempt's), as one call and from a
    communication point on."""
    inline, per_lane = _both(paper.fmu, tmp_path)
    kw = dict(parameters={"g": [9.81, 3.721, 9.81, 2.0], "beta_min": 0.1},
              starts={"gamma_dot": [6.0, 6.0, 6.0, 1e7]}, rel_tol=1e-7)
    for grid in (None, [0.2, 8.0]):
        a, b = inline.run(8.0, grid=grid, **kw), per_lane.run(8.0, grid=grid, **kw)
        _same(a, b)
        assert list(a.status) == [STATUS_OK] * 3 + [STATUS_ERROR] and a.steps[3] > 800000
        assert len(a.messages) == 1 and "steps taken in this call" in a.messages[0]


def test_stick_slip_updates_beside_ordinary_steps_equal_the_solver_code(slope, tmp_path):
    """slope_hold (rolling resistance with stiction: update events switching stick and slip, the
    state jumping at the located time): lanes whose step has an update event, whose state then
    moves (a new series at the event), beside lanes taking ordinary steps, with and without a grid."""
    inline, per_lane = _both(slope.fmu, tmp_path)
    n = 6
    assert "gamma_dot" in inline.start_names
    starts = {"gamma_dot": np.linspace(-3.0, 3.0, n)}  # uphill (< 0) stops at 0.5 .. 2.5 s
    for extra in ({}, {"grid": np.linspace(0.5, 4.0, 8)}):
        a, b = (e.run(4.0, starts=starts, rel_tol=1e-6, **extra) for e in (inline, per_lane))
        _same(a, b)
        assert list(a.status) == [STATUS_OK] * n
        assert a.flags.any(), "no update event fired: the case tests nothing"


def test_fast_spin_and_early_stick_equal_the_solver_code(paper, slope, tmp_path):
    """gamma_dot 1e5 at rel_tol 1e-4 (70,000 steps) and slope_hold at rel_tol 1e-3 (order 7: a
    stick event, then one landing step): the builds 1-2 ulp apart (from step 3100 on) if the
    increments pass (gw_ens_increments) fuses fewer sums than gw_taylor_increment under the
    library's FMA contraction (tests/c/test_ens_increments.c)."""
    inline, per_lane = _both(paper.fmu, tmp_path)
    kw = dict(parameters={"beta_min": [0.1] * 4}, starts={"gamma_dot": [1e5, 6.0, 3e4, 0.5]}, rel_tol=1e-4)
    for grid in (None, [0.25, 0.5, 1.0]):
        a = inline.run(1.0, grid=grid, **kw)
        _same(a, per_lane.run(1.0, grid=grid, **kw))
        assert a.steps[0] > 60000
    inline, per_lane = _both(slope.fmu, tmp_path / "slope")
    starts = {"gamma_dot": np.random.default_rng(2).uniform(-3.0, 3.0, 9)}
    a = inline.run(4.0, starts=starts, rel_tol=1e-3)
    _same(a, per_lane.run(4.0, starts=starts, rel_tol=1e-3))
    assert a.flags.any()
