"""The sweep engine's ensemble path (studies/ensemble_path.py): with solver taylor, a
batch of points runs through the ensemble library (c_src/gw_ensemble.c) and gives the table the
plain loop (one FMU run per point) gives, falls, failures and batch splits included."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gyrowheel.taylor.ensemble import Ensemble
from gyrowheel.studies import SweepSpecError, sweep

METRICS = ["survived", "fall_time", "end_time", "event", "min_beta", "max:beta", "final:x", "final:alpha",
           "energy_drift"]


@pytest.fixture(scope="module")
def taylor_fmu(example_build):
    return example_build("paper_earth", taylor=True).fmu


@pytest.fixture
def ensemble_calls(monkeypatch):
    calls = []
    run = Ensemble.run

    def spy(self, *args, **kwargs):
        calls.append(kwargs.get("grid"))
        return run(self, *args, **kwargs)
    monkeypatch.setattr(Ensemble, "run", spy)
    return calls


POINTS = ([dict(gamma_dot=g, beta=math.radians(b), M=2.0) for g in (0.0, 0.7, 3.0, 6.0, 9.0) for b in (70.0, 85.0)]
          + [dict(gamma_dot=6.0, beta=math.radians(80.0), M=-1.0)])  # refused: M must be > 0


def _both(fmu, **kw):
    return (sweep(fmu, points=POINTS, metrics=METRICS, workers=0, **kw),
            sweep(fmu, points=POINTS, metrics=METRICS, workers=0, ensemble=False, **kw))


def test_ensemble_table_equals_plain_loop(taylor_fmu, ensemble_calls):
    ens, plain = _both(taylor_fmu, stop_time=4.0, output_interval=0.05, solver="taylor", rel_tol=1e-10,
                       abs_tol=1e-12, batch_size=4)
    assert len(ensemble_calls) == 3  # 11 points in batches of 4: every batch took the ensemble path
    assert all(len(g) == 80 and g[-1] == 4.0 for g in ensemble_calls)
    assert list(ens["status"]) == list(plain["status"]) == ["ok"] * 10 + ["error"], list(ens["reason"])
    assert ens["reason"].iloc[-1] == plain["reason"].iloc[-1] and "M" in ens["reason"].iloc[-1]
    assert (~ens["survived"].iloc[:10]).sum() >= 2  # some points fall: the event path is covered
    for col in ("survived", "event"):
        assert list(ens[col].iloc[:10]) == list(plain[col].iloc[:10]), col
    for col in ("fall_time", "end_time", "min_beta", "max_beta", "final_x", "final_alpha"):
        np.testing.assert_allclose(ens[col].iloc[:10], plain[col].iloc[:10], rtol=1e-9, atol=1e-9,
                                   err_msg=col)  # the ensemble library uses FMA contraction
    np.testing.assert_allclose(ens["energy_drift"].iloc[:10], plain["energy_drift"].iloc[:10], atol=1e-12)


def test_default_build_under_auto_takes_the_ensemble_path(example_build, ensemble_calls):
    """The default build (solver auto, the Taylor kernel built in: auto integrates with taylor)
    swept with no solver named goes through the ensemble, as with solver taylor, and equals the
    plain loop; the target reads auto's rule from the FMU's sources as gyrowheel info does."""
    from gyrowheel.description import read_info
    from gyrowheel.studies.target import FmuTarget

    fmu = example_build("paper_earth").fmu
    assert read_info(fmu).auto_solver == "taylor" and FmuTarget(fmu).auto_taylor
    kw = dict(stop_time=2.0, output_interval=0.1, rel_tol=1e-10, batch_size=6)
    ens = sweep(fmu, points=POINTS, metrics=METRICS, workers=0, **kw)
    assert len(ensemble_calls) == 2  # 11 points in batches of 6
    plain = sweep(fmu, points=POINTS, metrics=METRICS, workers=0, ensemble=False, **kw)
    assert len(ensemble_calls) == 2
    assert list(ens["status"]) == list(plain["status"]) == ["ok"] * 10 + ["error"]
    for col in ("survived", "event"):
        assert list(ens[col]) == list(plain[col]), col
    for col in ("fall_time", "end_time", "min_beta", "final_x", "final_alpha"):
        np.testing.assert_allclose(ens[col].iloc[:10], plain[col].iloc[:10], rtol=1e-9, atol=1e-9, err_msg=col)


def test_auto_takes_the_ensemble_path_only_where_it_integrates_with_taylor():
    """Solver auto (7) sends a sweep to the ensemble only for an FMU whose auto is taylor: with
    mode switches (contact modes, stiction) auto integrates with dop853, and so does every point."""
    from types import SimpleNamespace

    from gyrowheel.studies import ensemble_path

    def target(auto_taylor):
        start = {"solver": 7, "rel_tol": 1e-8, "abs_tol": 0.0, "max_step": 0.0}
        variables = {k: SimpleNamespace(start=v) for k, v in start.items()}
        return SimpleNamespace(taylor_kernel=True, auto_taylor=auto_taylor, variables=lambda: variables)
    assert ensemble_path._settings(target(True), {})["solver"] == 7
    assert ensemble_path._settings(target(False), {}) is None
    assert ensemble_path._settings(target(False), {"solver": 6})["solver"] == 6
    assert ensemble_path._settings(target(True), {"solver": 5}) is None


def test_plain_path_when_the_solver_is_not_taylor(taylor_fmu, ensemble_calls):
    """dop853 (the sweep's solver), or a per-point solver setting: no ensemble."""
    table = sweep(taylor_fmu, points=POINTS[:2], metrics=["survived"], stop_time=0.5, output_interval=0.1,
                  solver="dop853", workers=0)
    assert (table["status"] == "ok").all() and ensemble_calls == []
    table = sweep(taylor_fmu, points=[dict(p, rel_tol=1e-8) for p in POINTS[:2]], metrics=["survived"],
                  stop_time=0.5, output_interval=0.1, solver="taylor", workers=0)
    assert (table["status"] == "ok").all() and ensemble_calls == []


def test_default_fmu_refuses_solver_taylor_before_running(example_build, ensemble_calls):
    """An FMU without the kernel lists no solver taylor: the sweep is refused before it runs."""
    earth_fmu = example_build("paper_earth", taylor=False).fmu
    with pytest.raises(SweepSpecError, match="'taylor' for 'solver'.*valid: euler, rk4, dopri5, rosenbrock, dop853, auto "):
        sweep(earth_fmu, points=POINTS[:2], metrics=["survived"], stop_time=0.5, output_interval=0.1,
              solver="taylor", workers=0)
    assert ensemble_calls == []


def test_ensemble_path_leaves_no_file_in_the_temp_directory(taylor_fmu, ensemble_calls, monkeypatch, tmp_path):
    """The FMU's bytes go to a private directory removed once the library is loaded: nothing such
    as /tmp/gyrowheel-sweep-ens-<digest>.fmu is left behind for good (one per FMU ever swept), and
    no file of a predictable name that anyone could put there is compiled and loaded."""
    import tempfile

    from gyrowheel.studies import ensemble_path
    shared = tmp_path / "tmp"
    shared.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(shared))
    monkeypatch.setattr(ensemble_path, "_ENSEMBLES", {})  # load the library again in this process
    table = sweep(taylor_fmu, points=POINTS[:3], metrics=["survived"], stop_time=0.5, output_interval=0.1,
                  solver="taylor", workers=0)
    assert (table["status"] == "ok").all() and len(ensemble_calls) == 1
    assert list(shared.iterdir()) == []


def test_ensemble_path_points_do_not_depend_on_the_batch(taylor_fmu, ensemble_calls):
    """docs/sweeps.md 'Determinism' on the ensemble path: a point's metrics are the same bits
    whatever the batch size and the order of the points (a point alone in its batch, or left
    alone at a batch's end, must not run on a one-lane kernel that the library's FMA contraction
    rounds otherwise: fall_time, min_beta, final_x ... would differ at 1e-14)."""
    kw = dict(metrics=METRICS, workers=0, stop_time=3.0, output_interval=0.5, solver="taylor", rel_tol=1e-9)
    whole = sweep(taylor_fmu, points=POINTS[:10], batch_size=10, **kw)
    single = sweep(taylor_fmu, points=POINTS[:10], batch_size=1, **kw)
    back = sweep(taylor_fmu, points=POINTS[9::-1], batch_size=3, **kw).iloc[::-1].reset_index(drop=True)
    assert len(ensemble_calls) == 1 + 10 + 4 and (~whole["survived"]).sum() >= 2
    for other in (single, back):
        for col in METRICS[:2] + ["end_time", "event", "min_beta", "max_beta", "final_x", "final_alpha", "energy_drift"]:
            np.testing.assert_array_equal(other[col].to_numpy(), whole[col].to_numpy(), err_msg=col)
