"""The ensemble path's memory kept between runs (gw_ensemble_new / gw_ensemble_run_in, a context
per run in flight, fmu_build/ensemble.py): runs of one Ensemble reuse the lanes' instances and
the batch memory, so nothing of one run may reach the next, and runs from several threads at
once must each have their own context."""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from conftest import SCENES
from fmu_build import build_fmu, load_scene
from fmu_build.ensemble import STATUS_ERROR, STATUS_OK, Ensemble


@pytest.fixture(scope="module")
def paper(tmp_path_factory):
    work = tmp_path_factory.mktemp("ensemble")
    return build_fmu(load_scene(SCENES / "paper_earth.toml"), work / "paper_earth.fmu",
                     build_dir=work / "build", taylor=True)


# 7 trajectories (some fall, at different times) on a grid, then jobs that leave a context in
# another state: fewer lanes busy, a trajectory failing at initialisation and one in its steps,
# another tolerance (another order: the series blocks' stride), no grid
JOB = dict(parameters={"g": [9.81, 3.721, 9.81, 9.81, 0.0, 9.81, 5.0], "beta_min": 0.1},
           starts={"gamma_dot": [6.0, 6.0, 1.0, 0.5, 3.0, 8.0, 0.2]}, rel_tol=1e-9,
           grid=np.linspace(0.5, 6.0, 12))
OTHERS = [dict(parameters={"M": [2.0, -1.0]}, rel_tol=1e-6),
          dict(starts={"gamma_dot": [6.0, 1e9, 6.0]}, rel_tol=1e-12),
          dict(starts={"gamma_dot": [4.0]}, rel_tol=1e-4)]


def _same(a, b):
    assert list(a.status) == list(b.status) and list(a.steps) == list(b.steps)
    np.testing.assert_array_equal(a.t_final, b.t_final)
    np.testing.assert_array_equal(a.x_final, b.x_final)
    np.testing.assert_array_equal(a.y_grid, b.y_grid)
    np.testing.assert_array_equal(a.flags, b.flags)
    assert a.messages == b.messages


def test_runs_reusing_a_context_equal_fresh_runs(paper, tmp_path):
    """A job run after others on the same Ensemble (one context, reused) returns what it
    returns on a fresh Ensemble, bit for bit, messages included; the other jobs' messages stay
    with their own results."""
    fresh = Ensemble(paper.fmu, cache=tmp_path).run(6.0, **JOB)
    assert 0 < fresh.terminated.sum() < 7 and set(fresh.status) <= {STATUS_OK, 2}
    ens = Ensemble(paper.fmu, cache=tmp_path)
    first = ens.run(6.0, **JOB)
    _same(first, fresh)
    for other in OTHERS:
        res = ens.run(2.0, **other)
        assert len(ens._contexts) == 1  # the same context each time
        assert all(m.startswith("ensemble trajectory ") for m in res.messages)
        assert bool(res.messages) == (STATUS_ERROR in res.status)
        _same(ens.run(6.0, **JOB), fresh)


def test_runs_from_several_threads_have_their_own_contexts(paper, tmp_path):
    """The sweep engine may call one Ensemble from several threads (the C call releases the
    GIL): each run takes a context of its own from the pool, so concurrent runs return what
    one run alone returns."""
    ens = Ensemble(paper.fmu, cache=tmp_path)
    alone = ens.run(6.0, **JOB)
    with ThreadPoolExecutor(4) as pool:
        results = list(pool.map(lambda _: ens.run(6.0, **JOB), range(8)))
    for res in results:
        _same(res, alone)
    assert 1 <= len(ens._contexts) <= 4
