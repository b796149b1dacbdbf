"""Variable descriptions say what each value is in every contact mode the scene has.

A scene with sliding and flight (examples/scenes/drop_bounce.toml): z, vx, vy, the contact forces
and points, the slip and contact_switched describe flight too, not only rolling's formula; a run
of the FMU holds them to it (in flight z = height + R sin(beta), the lowest rim point height above
the centre's R sin(beta); vx = dx/dt; F_n = 0; friction_use = -1), and a rolling-only scene keeps
its descriptions."""
from __future__ import annotations

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from gyrowheel.model.build import build_model

FLY = {"gravity": {}, "contact_forces": {"on_slip": "slide", "on_lift_off": "fly"}, "energy": {}}
MODE_DEPENDENT = ("z", "vx", "vy", "F_n", "F_long", "F_lat", "friction_use", "contact_x", "contact_y",
                  "slip_long", "slip_lat")


def _descriptions(spec) -> dict[str, str]:
    out = {q.name: q.description for q, _ in spec.outputs}
    out.update({ev.flag.name: ev.flag.description for ev in spec.events})
    return out


def test_a_scene_with_flight_describes_flight():
    d = _descriptions(build_model(effects=FLY))
    for name in MODE_DEPENDENT:
        assert "in flight" in d[name], (name, d[name])
    assert d["z"].startswith("centre height: R sin(beta) in contact") and "z_centre" in d["z"]
    assert "rolling and sliding" in d["contact_switched"] and "contact_flown" in d["contact_switched"]


def test_a_sliding_scene_describes_sliding_and_a_rolling_scene_rolling():
    sliding = _descriptions(build_model(effects={"gravity": {}, "contact_forces": {"on_slip": "slide"}}))
    assert sliding["vx"] == "centre velocity x, from the rolling constraint while rolling, free (a state) while sliding"
    assert not any("flight" in sliding[n] for n in MODE_DEPENDENT if n in sliding)
    rolling = _descriptions(build_model())
    assert rolling["z"] == "centre height R sin(beta)" and rolling["vx"] == "centre velocity x, from the rolling constraint"


def test_the_drops_run_is_what_the_descriptions_say(example_build):
    fmu = str(example_build("drop_bounce").fmu)
    md = {v.name: v.description for v in read_model_description(fmu).modelVariables}
    assert "in flight" in md["z"] and "in flight" in md["vx"] and "contact_flown" in md["contact_switched"]
    r = simulate_fmu(fmu, stop_time=0.6, output_interval=1e-3, start_values={"gamma_dot": 5.0})
    flight, rolling = r["contact_mode"] == 2, r["contact_mode"] == 0
    assert flight.sum() > 100 and rolling.sum() > 50
    R = 0.17
    assert np.max(np.abs(r["z"][flight] - (r["height"][flight] + R * np.sin(r["beta"][flight])))) < 1e-12
    assert r["z"][0] == pytest.approx(0.27, abs=1e-15)  # 0.1 m drop: not R sin(beta) = 0.17
    assert np.max(np.abs(r["z"][rolling] - R * np.sin(r["beta"][rolling]))) < 1e-12
    assert np.all(r["F_n"][flight] == 0) and np.all(r["friction_use"][flight] == -1)
    t, x, vx = r["time"], r["x"], r["vx"]
    inner = np.flatnonzero(flight[:-1] & flight[1:])
    rate = (x[inner + 1] - x[inner]) / (t[inner + 1] - t[inner])
    assert np.max(np.abs(rate - 0.5 * (vx[inner] + vx[inner + 1]))) < 1e-9  # free flight: vx constant
