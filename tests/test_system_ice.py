"""The Gyrover's closed loop on ice (docs/system.md, "On ice"): the earth loop's controller, built
for rolling, flying controller/surface.py's brake_and_turn mission with the wheel of
examples/scenes/gyrover_ice.toml (on_slip = "slide").

Checked against what the run did not compute itself: Coulomb's law while sliding (|F_t| = mu_k F_n),
the energy balance of the wheel (energy + dissipated_energy - actuator_work constant), the sliding
wheel on high friction against the rolling wheel's FMU (an FMU without the sliding mode), and the
documented outcomes (slip episodes at mu = 0.1 and none on dry ground; the harder brake lost on
every surface, by a fall on mu = 0.1).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gyrowheel.controller.surface import brake_and_turn, contact_report, mission_starts, surface_system
from gyrowheel.cosim.master import run

STEP = 0.01


@pytest.fixture(scope="module")
def ice_fmu(example_build):
    return example_build("gyrover_ice").fmu  # the run's one build of the example scene


def fly(wheel_fmu, controller_fmu, mission, **wheel):
    r = run(surface_system(wheel_fmu, controller_fmu, 25.0), STEP,
            start_values={"wheel": wheel, "controller": mission_starts(mission)})
    return r.data, r.stopped_by


def test_brake_and_turn_on_ice_slips_and_is_held(ice_fmu, earth_loop):
    mu, mu_k = 0.1, 0.08
    data, stopped = fly(ice_fmu, earth_loop.controller_fmu, brake_and_turn(), mu=mu, mu_k=mu_k)
    rep = contact_report(data, stopped, mu_k)
    assert rep.finite
    assert stopped is None and rep.up_s == pytest.approx(25.0)
    assert rep.slip_episodes >= 2 and 0.05 < rep.sliding_s < 1.0  # measured: 3 episodes, 0.21 s
    assert 1e-3 < rep.slip_speed_max < 0.2  # measured 0.041 m/s: held, not a runaway
    assert rep.friction_law_error < 1e-9  # Coulomb: |F_t| = mu_k F_n in every sliding row
    assert rep.friction_use_max_rolling <= mu * (1 + 1e-9)  # rolling only inside the cone
    assert rep.energy_drift < 1e-9  # measured 8.5e-12
    assert abs(rep.lean_min) < 10 and abs(rep.lean_max) < 10


def test_dry_ground_does_not_slip_and_matches_the_rolling_wheel(ice_fmu, earth_loop):
    mission = brake_and_turn()
    data, stopped = fly(ice_fmu, earth_loop.controller_fmu, mission, mu=0.8, mu_k=0.64)
    rolling, stopped_rolling = fly(earth_loop.wheel_fmu, earth_loop.controller_fmu, mission)
    rep = contact_report(data, stopped, 0.64)
    assert stopped is None and stopped_rolling is None
    assert rep.slip_episodes == 0 and rep.slip_speed_max == 0.0
    assert rep.friction_use_max_rolling > 0.1  # the manoeuvre needs more than mu = 0.1 gives
    for name in ("beta", "alpha", "x", "y", "gamma_dot"):  # two FMUs, one rolling trajectory
        assert np.abs(data[f"wheel.{name}"] - rolling[f"wheel.{name}"]).max() < 1e-5, name
    assert rep.energy_drift < 1e-9


def test_too_hard_a_brake_is_lost_on_dry_ground_and_falls_on_ice(ice_fmu, earth_loop):
    mission = brake_and_turn(braked=1.0, brake=1.0)
    dry, stopped_dry = fly(earth_loop.wheel_fmu, earth_loop.controller_fmu, mission)
    assert stopped_dry == "controller" and 5.0 < dry["time"][-1] < 6.0  # the controller's `lost`
    data, stopped = fly(ice_fmu, earth_loop.controller_fmu, mission, mu=0.1, mu_k=0.08)
    rep = contact_report(data, stopped, 0.08)
    assert rep.finite and stopped == "wheel"  # the wheel's fall event, after a slip runaway
    assert rep.slip_speed_max > 1.0 and rep.lean_min < -40  # measured 1.87 m/s, -47 deg
    assert rep.friction_law_error < 1e-9
    assert rep.energy_drift < 1e-8  # measured 2.5e-10
    assert math.isclose(data["time"][-1], 5.65, abs_tol=0.05)


def test_brake_and_turn_refuses_what_it_cannot_fly():
    m = brake_and_turn()
    assert len(m.points) == 11 and m.points[2] == (5.0, 0.0, 1.2)
    _, rate, speed = m.evaluate(np.array([4.5, 8.5, 13.0]))
    assert speed[0] == pytest.approx(1.35) and rate[1] == 0.5 and rate[2] == -0.5
    with pytest.raises(ValueError, match="brake must be > 0 s"):
        brake_and_turn(brake=0.0)
    with pytest.raises(ValueError, match=r"end must be after the last turn \(15 s\)"):
        brake_and_turn(end=15.0)
