"""Sweeps of a system of FMUs (.ssp): the Gyrover's wheel + controller against gyrowheel's own
master (cosim/master.py), names of both components, a fall of the wheel as a result."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gyrowheel.cosim.master import run
from gyrowheel.studies import SweepSpecError, sweep

DISTURBED = -2.3983435979786334  # alpha_dot [rad/s] of a disturbed start (any start does: sweep and master must agree)


def test_closed_loop_sweep_equals_the_master(earth_loop):
    """Same system, start values and 10 ms step: the sweep's end state is the master's (to round-off:
    the sweep's grid t_i = i h and the master's t + h differ in the last bits)."""
    table = sweep(earth_loop.ssp, grid={"M": [2.0, 2.4], "controller.gain_scale": [1.0, 2.0]},
                  fixed={"alpha_dot": DISTURBED}, stop_time=3.0, output_interval=0.01, workers=0,
                  metrics=["survived", "max_lean", "final:beta", "final:x", "final:controller.tilt_cmd"])
    assert (table["status"] == "ok").all() and table["survived"].all()
    for _, row in table.iterrows():
        ref = run(earth_loop.system, 0.01, 3.0, start_values={
            "wheel": {"alpha_dot": DISTURBED, "M": row["M"]},
            "controller": {"gain_scale": row["controller.gain_scale"]}}).data
        assert row["final_beta"] == pytest.approx(ref["wheel.beta"][-1], abs=1e-9)
        assert row["final_x"] == pytest.approx(ref["wheel.x"][-1], abs=1e-9)
        assert row["final_controller.tilt_cmd"] == pytest.approx(ref["controller.tilt_cmd"][-1], abs=1e-9)
        assert row["max_lean"] == pytest.approx(np.max(np.abs(ref["wheel.beta"] - math.pi / 2)), abs=1e-9)


def test_closed_loop_fall_is_a_metric(earth_loop):
    """A wheel standing still at 60 deg is beyond the controller (no rolling, no gyroscopic authority):
    the run ends early as a result, by the wheel's fall or the controller's `lost` event (a rate
    ran away); a negative mass is refused by the wheel as a failed row."""
    table = sweep(earth_loop.ssp, points=[{"beta_deg": 60.0, "gamma_dot": 0.0, "M": 2.0, "beta_min": 0.02},
                                          {"beta_deg": 85.0, "gamma_dot": 8.8, "M": -1.0, "beta_min": 0.02}],
                  stop_time=5.0, output_interval=0.01, workers=0)
    fell, refused = table.iloc[0], table.iloc[1]
    assert fell["status"] == "ok" and not fell["survived"]
    assert fell["event"] in ("fallen", "controller.lost", "fallen,controller.lost"), fell["event"]
    assert 0 < fell["end_time"] < 5.0
    assert refused["status"] == "error" and "mass" in refused["reason"], refused["reason"]


def test_system_names_are_checked(earth_loop):
    with pytest.raises(SweepSpecError, match="unknown variable 'controller.nope'"):
        sweep(earth_loop.ssp, grid={"controller.nope": [1.0]}, stop_time=1.0, workers=0)
    with pytest.raises(SweepSpecError, match="no Real output 'tilt_cmd'"):  # the controller's, not the plant's
        sweep(earth_loop.ssp, grid={"M": [2.0]}, metrics="final:tilt_cmd", stop_time=1.0, workers=0)


@pytest.mark.parametrize("kwargs, message", [
    (dict(grid={"M": [1.8, 2.2]}, fixed={"wheel.M": 3.0}), "both swept and fixed"),
    (dict(grid={"M": [1.8], "wheel.M": [2.2]}), "swept twice"),
    (dict(grid={"beta_deg": [80.0], "wheel.beta": [1.0]}), "swept twice"),
    (dict(grid={"M": [1.8]}, fixed={"beta": 1.0, "wheel.beta_deg": 80.0}), "given twice"),
])
def test_system_aliases_are_one_variable(earth_loop, kwargs, message):
    """In an .ssp the wheel's M is also wheel.M: setting it under both names must not let one win silently."""
    with pytest.raises(SweepSpecError, match=message):
        sweep(earth_loop.ssp, stop_time=0.1, workers=0, **kwargs)
