"""Section 2: the Gyrover controller: design facts, closed-loop eigenvalues against simulation."""
from __future__ import annotations

import math

import numpy as np
import pytest

from controller.design import closed_loop_matrix, controllable_basis, zero_yaw_momentum_rate
from cosim.master import run


def test_yaw_momentum_is_not_controllable(earth_design):
    """Two directions no input reaches (yaw momentum and the heading-tilt relation); all else is."""
    m = earth_design.matrices()
    T = controllable_basis(m["A"], m["B"])
    assert T.shape[1] == len(earth_design.x_names) - 2
    W = np.array(earth_design.conserved)
    assert np.abs(W @ m["B"]).max() < 1e-9
    assert np.abs(W @ m["A"] @ T).max() < 1e-9  # the controllable subspace never leaks into them
    # a held heading offset needs a held tilt: about 0.23 rad of heading per rad of tilt
    assert 1 / m["Nx"][earth_design.x_names.index("tilt"), 0] == pytest.approx(0.23, abs=0.01)


def test_regulator_and_observer_are_stable_on_the_controllable_part(earth_design):
    ev = np.linalg.eigvals(closed_loop_matrix(earth_design))
    nonzero = ev[np.abs(ev) > 1e-7]
    assert len(ev) - len(nonzero) == 2
    assert nonzero.real.max() < -0.05


def test_closed_loop_decay_matches_the_linear_model(earth_loop):
    """A 0.2 deg lean (zero yaw momentum) decays in the co-simulated loop (1 ms step) like the
    linear closed loop [plant; observer] predicts: lean at 0.25 s and 0.5 s within 10 %."""
    from scipy.linalg import expm
    d = earth_loop.design
    lean0 = math.radians(-0.2)
    ad = zero_yaw_momentum_rate(d, lean0)
    r = run(earth_loop.system, 0.001, stop_time=0.5,
            start_values={"wheel": {"beta": math.pi / 2 + lean0, "alpha_dot": ad},
                          "controller": {f"mission_heading_{k}": 0.0 for k in range(11)}})
    Acl = closed_loop_matrix(d)
    n = len(d.x_names)
    z0 = np.zeros(2 * n)
    z0[d.x_names.index("beta")] = lean0
    z0[d.x_names.index("alpha_dot")] = ad
    for t in (0.25, 0.5):
        lin = (expm(Acl * t) @ z0)[d.x_names.index("beta")]
        sim = np.interp(t, r.data["time"], r.data["wheel.beta"]) - math.pi / 2
        assert sim == pytest.approx(lin, rel=0.1, abs=2e-3 * abs(lean0))


def test_mission_on_earth_stays_up_and_tracks(earth_loop):
    d = earth_loop.design
    r = run(earth_loop.system, 0.01, stop_time=30.0,
            start_values={"wheel": {"alpha_dot": zero_yaw_momentum_rate(d, math.radians(-5.0))}})
    assert r.stopped_by is None
    late = r.data["time"] > 5.0
    assert np.abs(r.data["wheel.beta"][late] - math.pi / 2).max() < math.radians(0.1)
    assert np.abs(r.data["controller.heading_error"][late]).max() < math.radians(5.0)
    assert np.abs(r.data["controller.tilt_cmd"]).max() <= d.tilt_max + 1e-12
    assert np.abs(r.data["controller.drive_torque"]).max() <= d.drive_max + 1e-12
