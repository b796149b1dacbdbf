"""Solver taylor through a near pole: lunar_rover with the smoothed rolling resistance
tanh(omega / eps), where the spin rate crosses zero on the way to the fall and the step size
from the last two coefficients is far too long.

- the defect check of every step keeps the error at the tolerance, through fmi2DoStep and the
  ensemble path alike, and the fall is located as DOP853 locates it;
- the deferred defect check (f(t1, P(h)) from the next step's series) rejects where the check
  with a right-hand side evaluation does;
- the ensemble's lanes retry rejected steps on their series fetched from the batch, bit for bit
  as the build that copies every lane's series every step.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conftest import SCENES, STATES
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.taylor.ensemble import STATUS_OK, Ensemble
from taylor_helpers import TAYLOR, fmu_runner, one_step


@pytest.fixture(scope="module")
def lunar(tmp_path_factory):
    """lunar_rover with the smoothed rolling resistance c_rr R F_n tanh(omega / rr_omega_eps) (the
    law of every scene before stiction became the default), contact forces, the kernel."""
    work = tmp_path_factory.mktemp("lunar")
    text = (SCENES / "lunar_rover.toml").read_text()
    assert "c_rr = 0.05\n" in text
    text = text.replace("c_rr = 0.05\n", 'c_rr = 0.05\nlaw = "smoothed"\n')
    return build_fmu(parse_scene(text, "lunar_rover.toml"), work / "lunar_rover.fmu", build_dir=work / "b",
                     taylor=True)


# spin rate 8.4 rad/s falling at 5000 rad/s^2 to zero within 2.7 ms, where the rolling resistance
# tanh(omega / 0.01) turns it into a stiff, nearly discontinuous decay
NEAR_FALL = dict(x=12.819282792842362, y=-9.94660362227494, alpha=-8.926627197498364, beta=0.011077986863648658,
                 gamma=165.05761343062568, alpha_dot=-1.768003941167051, beta_dot=-1.1145939382724355,
                 gamma_dot=8.441488319529059)


def test_step_size_defect_checked_through_a_near_pole(lunar):
    """The step size from the last two coefficients (Jorba & Zou) misses the near pole of
    tanh(omega / eps) where the spin rate crosses zero: without a check the full scene's fall
    comes 2e-8 s late with the rates 0.7 rad/s off at rel_tol 1e-12, 0.24 rad/s at 1e-9 (299
    steps to 17.47 s where DOP853 takes 1820).  The defect check of every step keeps the error at the
    tolerance, through fmi2DoStep and the ensemble path alike.  Reference: DOP853 at rel_tol 1e-13
    with max_step 1e-5."""
    runner, T = fmu_runner(lunar.fmu), 0.004
    ref = one_step(runner, T, STATES, solver=5, rel_tol=1e-13, abs_tol=1e-15, max_step=1e-5, **NEAR_FALL)
    assert ref[7] == pytest.approx(-6.1479961e-4, rel=1e-6)  # the spin rate crossed zero
    ens = Ensemble(lunar.fmu, cache=lunar.fmu.parent / "ens")
    for tol in (1e-6, 1e-9, 1e-12):
        got = one_step(runner, T, STATES, solver=TAYLOR, rel_tol=tol, abs_tol=tol * 1e-2, **NEAR_FALL)
        assert np.max(np.abs(got - ref)) < max(100 * tol, 1e-12), tol
        res = ens.run(T, starts={k: [v] for k, v in NEAR_FALL.items()}, rel_tol=tol, abs_tol=tol * 1e-2)
        assert res.status[0] == STATUS_OK
        assert np.max(np.abs(res.x_final[0, :8] - ref)) < max(100 * tol, 1e-12), tol
    # the whole scene (its output interval, 0.02 s): the fall located as DOP853 locates it
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated
    times = {}
    for solver, tol in ((5, 1e-13), (TAYLOR, 1e-12)):
        runner.start(solver=solver, rel_tol=tol, abs_tol=tol * 1e-2, max_step=60.0)
        with pytest.raises(FMICallException):
            for k in range(3000):
                runner.slave.doStep(k * 0.02, 0.02)
        assert runner.slave.getBooleanStatus(fmi2Terminated)
        times[solver] = runner.slave.getRealStatus(fmi2LastSuccessfulTime)
    # the check: Taylor against DOP853 at rel_tol 1e-13, two methods sharing nothing but the model
    assert abs(times[TAYLOR] - times[5]) < 1e-11, times
    assert times[TAYLOR] == pytest.approx(FALL_REGRESSION_PIN, abs=1e-9), times


# A regression pin, not an independent value: the fall time of the smoothed lunar_rover scene as
# the FMU's own DOP853 locates it at rel_tol 1e-13.  It catches a change of the model, the scene
# or the event location; the independent check is the agreement of Taylor and DOP853 above.
FALL_REGRESSION_PIN = 17.4747724753


def _rejections(fmu: Path, unzipdir: Path | None, T: float, tol: float) -> list[tuple[float, float]]:
    """(t, h) of every rejected Taylor step of one fmi2DoStep(0, T) from NEAR_FALL, from the
    solver log ("taylor step rejected at t=... h=...")."""
    import re

    from fmi_helpers import Slave
    s = Slave(fmu, unzipdir=unzipdir)
    try:
        s.init(solver=TAYLOR, rel_tol=tol, abs_tol=tol * 1e-2, max_step=60.0, **NEAR_FALL)
        s.slave.doStep(0.0, T)
        return [(float(m.group(1)), float(m.group(2))) for _, _, text in s.messages
                for m in [re.search(r"taylor step rejected at t=(\S+): h=(\S+) ", text)] if m]
    finally:
        s.free()


def test_deferred_defect_check_rejects_where_the_rhs_check_does(lunar, tmp_path):
    """The defect check takes f(t1, P(h)) from the series of the next step (order 1), computed at
    the attempt's end point anyway, instead of a right-hand side evaluation: the same numbers to
    rounding, so the same steps are rejected. The FMU's own sources compiled with
    GW_TAYLOR_DEFECT_RHS=1 (every step checked with a right-hand side evaluation) reject at the
    same times with the same step sizes on the near-pole case."""
    from fmpy import extract

    from gyrowheel.fmu_build.compiler import UNITY_SOURCE, compile_shared
    rhs_dir = Path(extract(str(lunar.fmu), unzipdir=str(tmp_path / "rhs")))
    so = next((rhs_dir / "binaries").rglob("*.so"))
    compile_shared(rhs_dir / "sources" / UNITY_SOURCE, [rhs_dir / "sources"], so,
                   extra_flags=["-DGW_TAYLOR_DEFECT_RHS=1"])
    total = 0
    for tol in (1e-6, 1e-9, 1e-12):
        deferred = _rejections(lunar.fmu, None, 0.004, tol)
        rhs = _rejections(lunar.fmu, rhs_dir, 0.004, tol)
        assert len(deferred) == len(rhs), (tol, deferred, rhs)
        np.testing.assert_allclose(np.array(deferred), np.array(rhs).reshape(-1, 2), rtol=1e-9, err_msg=str(tol))
        total += len(rhs)
    assert total >= 3  # the check does reject there (the step from the coefficients is too long)


def test_ensemble_rejected_steps_retry_on_the_lane_series(lunar, tmp_path):
    """The batch leaves each lane's series in its block and copies it into the lane's instance
    only where solver code reads it (gw_ensemble.c, gw_ens_fetch): a rejected step's retries, a
    landing step, event location (through I->tl_fetch).  On the near-pole case (steps rejected by
    the defect check, in every lane of a full batch) the lazily fetched series give the numbers
    of the build that copies every lane's series every step (GW_ENSEMBLE_LANE_STEPS=1) bit for
    bit, and the error stays at the tolerance against DOP853 at rel_tol 1e-13."""
    T, tol = 0.004, 1e-9
    assert _rejections(lunar.fmu, None, T, tol)  # the single run rejects steps here
    runner = fmu_runner(lunar.fmu)
    ref = one_step(runner, T, STATES, solver=5, rel_tol=1e-13, abs_tol=1e-15, max_step=1e-5, **NEAR_FALL)
    starts = {k: [v] * 4 for k, v in NEAR_FALL.items()}
    starts["gamma_dot"] = [NEAR_FALL["gamma_dot"] * f for f in (1.0, 1.0001, 0.9999, 1.0002)]
    lazy = Ensemble(lunar.fmu, lanes=4, cache=tmp_path).run(T, starts=starts, rel_tol=tol)
    eager = Ensemble(lunar.fmu, lanes=4, cache=tmp_path, defines={"GW_ENSEMBLE_LANE_STEPS": 1}).run(
        T, starts=starts, rel_tol=tol)
    assert list(lazy.status) == [STATUS_OK] * 4 and list(lazy.steps) == list(eager.steps)
    np.testing.assert_array_equal(lazy.x_final, eager.x_final)
    assert np.max(np.abs(lazy.x_final[0, :8] - ref)) < 100 * tol
