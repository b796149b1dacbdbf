"""The sliding friction's dissipated power is Coulomb's, mu_k F_n |v_slip| >= 0
(model/contact_modes.py, declare_sliding; docs/effects.md, "Sliding"): dissipated_power >= 0 and
dissipated_energy never falls.

The friction direction e carries a seed along the stored direction d (where the slip starts); a
slip of round-off size pointing against d (just after an onset at mu_k = mu) makes the regularised
force's power mu_k F_n e . v_slip negative. Checked at the model (sliding states whose slip is 1e-9
of a random one and points against d: the power counted is 0.5 F_n |v_slip| for mu_k = 0.5, >= 0) and
on a drop that lands, rolls and starts to slide at mu_k = mu (the power >= 0 on every row,
dissipated_energy never steps down, energy + dissipated_energy within 1e-9 of the energy).
"""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest


def test_friction_power_is_coulombs_for_a_tiny_slip_against_the_seed():
    from gyrowheel.model.build import build_model
    spec = build_model({}, {}, {"gravity": {}, "contact_forces": {"on_slip": "slide", "mu": 0.5, "mu_k": 0.5},
                                "energy": {}})
    f = spec.functions()
    p = [q.start for q in spec.parameters]
    idx = {n: i for i, n in enumerate(spec.x_names)}
    out = {q.name: i for i, (q, _) in enumerate(spec.outputs)}
    rng = np.random.default_rng(7)
    for _ in range(20):
        x = rng.uniform(-1, 1, len(spec.x_names))
        x[idx["beta"]] = rng.uniform(0.6, 2.5)
        x[idx["contact_state"]] = 1
        x[idx["slip_dir_x"]], x[idx["slip_dir_y"]] = 1.0, 0.0

        def slip(x):
            y = np.array(f["out"](0, x, [], p)).ravel()
            a, s_long, s_lat = x[idx["alpha"]], y[out["slip_long"]], y[out["slip_lat"]]
            return np.array([s_long * np.cos(a) - s_lat * np.sin(a), s_long * np.sin(a) + s_lat * np.cos(a)]), y
        v, _ = slip(x)
        x[idx["x_dot"]] -= (1 - 1e-9) * v[0]  # the slip is linear in the centre velocity, coefficient 1
        x[idx["y_dot"]] -= (1 - 1e-9) * v[1]
        v, _ = slip(x)
        assert 0 < np.linalg.norm(v) < 1e-8
        turn = rng.uniform(-1.2, 1.2)  # d against the slip, within 70 degrees of -v
        c, s = np.cos(turn), np.sin(turn)
        d = -np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]]) / np.linalg.norm(v)
        x[idx["slip_dir_x"]], x[idx["slip_dir_y"]] = d
        _, y = slip(x)
        assert y[out["dissipated_power"]] >= 0
        assert y[out["dissipated_power"]] == pytest.approx(0.5 * y[out["F_n"]] * np.linalg.norm(v), rel=1e-6)


def test_dissipated_energy_does_not_fall_at_a_slip_onset(example_build, tmp_path):
    """A drop (examples/scenes/drop_bounce.toml, mu = mu_k = 1) that lands, rolls from t ~ 0.125 s and
    starts to slide at t ~ 0.1315 s: no negative power, no step down beyond 1e-14 relative."""
    fmu = str(example_build("drop_bounce").fmu)
    start = {"height": 0.22228333597144767, "beta": 2.004416424359003, "gamma_dot": 8.520647251300993,
             "alpha_dot": -4.659544177222246, "beta_dot": -0.7053585536112248, "slip_long": 0.3704071797996853,
             "slip_lat": -0.6873067001928272, "restitution": 0, "mu": 1, "mu_k": 1, "vz": -2.8809951271803786}
    args = [sys.executable, "-m", "gyrowheel", "simulate", fmu, "-o", str(tmp_path / "c.csv"), "--stop-time", "1.5"]
    for k, v in start.items():
        args += ["--set", f"{k}={v!r}"]
    r = subprocess.run(args, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = np.genfromtxt(tmp_path / "c.csv", delimiter=",", names=True)
    mode = out["contact_mode"]
    assert (mode == 0).any() and (mode[np.argmax(mode == 0):] == 1).any()  # rolls, then slides
    assert out["dissipated_power"].min() >= 0
    E = out["dissipated_energy"]
    assert (np.diff(E) >= -1e-14 * E[1:]).all()
    total = out["energy"] + E
    assert np.ptp(total) < 1e-9 * total[0]
