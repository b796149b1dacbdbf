"""The sliding contact mode and its switches (docs/effects.md, "Sliding").

Against results the code did not produce: the upright wheel launched sliding on level ground
(the slip decays at mu_k g (1 + 1/k_axial); rolling starts when it reaches 0, at the speed the
angular momentum about the contact point gives), the incline (rolling holds exactly while
tan(theta) <= mu (1 + k_axial) / k_axial; above, the centre accelerates at g (sin - mu_k cos) and
the spin at mu_k g cos(theta) / (k_axial R)), the energy balance through the switches, FMU states
that keep the mode, and a leaning wheel on low friction that slips and re-sticks.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest
from fmpy import simulate_fmu

from fmi_helpers import Slave
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.fmu_build.scene import SceneError
from paper_wheel import G, KA, M, R
from paper_wheel import PAPER_WHEEL_TOML as WHEEL

TIGHT = {"rel_tol": 1e-12, "abs_tol": 1e-14}
MU = 0.3
SLIDE = """
[effects.slope]
slope_angle = 0.0
[effects.contact_forces]
on_slip = "slide"
mu = 0.3
[effects.energy]
"""
OUT = ["x", "vx", "gamma_dot", "beta", "contact_mode", "slip_long", "slip_lat", "energy", "dissipated_energy",
       "F_n", "F_long", "contact_switched"]


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    root = tmp_path_factory.mktemp("sliding")
    scene = parse_scene('[model]\nname = "sliding"\n' + WHEEL + SLIDE, "sliding.toml")
    return str(build_fmu(scene, root / "sliding.fmu", build_dir=root / "build").fmu)


def run(fmu, stop, dt=0.01, **start):
    """simulate_fmu with the FMU's event messages: (result, [(event name, t)])."""
    logs: list[str] = []

    def logger(*args):
        text = args[-1]
        logs.append(text.decode() if isinstance(text, bytes) else str(text))
    r = simulate_fmu(fmu, stop_time=stop, output_interval=dt, start_values={**TIGHT, **start},
                     debug_logging=True, logger=logger, output=OUT)
    events = [(m.group(1), float(m.group(2))) for line in logs
              for m in [re.search(r"event (\w+) at t=(\S+?):? ", line + " ")] if m]
    return r, events


def slip_rate(mu_k: float) -> float:
    """d|slip|/dt of an upright wheel sliding straight on level ground: the friction -mu_k M g sign(s)
    decelerates the centre by mu_k g and turns the spin by mu_k M g R / (k_axial M R^2), so the
    contact point's slip s = v - R gamma_dot changes at mu_k g (1 + 1/k_axial)."""
    return mu_k * G * (1 + 1 / KA)


@pytest.mark.parametrize("v0, w0", [(2.0, -5.0), (0.5, 20.0)], ids=["backspin", "topspin"])
def test_upright_wheel_launched_sliding_starts_rolling(fmu, v0, w0):
    """Angular momentum about the contact point, M R (v + k_axial R w), is conserved (friction acts at
    the point, gravity and the normal force along the vertical through it); rolling (v = R w) starts
    at t* = |s0| / (mu_k g (1 + 1/k)) with v* = (v0 + k R w0) / (1 + k), whichever way it slips."""
    mu_k = 0.25
    s0 = v0 - R * w0
    t_star = abs(s0) / slip_rate(mu_k)
    v_star = (v0 + KA * R * w0) / (1 + KA)
    r, events = run(fmu, 1.2, beta=math.pi / 2, gamma_dot=w0, slip_long=s0, mu_k=mu_k)
    assert [name for name, _ in events] == ["contact_slip"]
    assert events[0][1] == pytest.approx(t_star, abs=1e-9)
    before = r["time"] < t_star - 1e-6
    assert np.all(r["contact_mode"][before] == 1)
    expected = s0 - math.copysign(slip_rate(mu_k), s0) * r["time"][before]
    assert np.max(np.abs(r["slip_long"][before] - expected)) < 1e-9 * abs(s0)
    assert np.max(np.abs(r["vx"][before] - (v0 - math.copysign(mu_k * G, s0) * r["time"][before]))) < 1e-9
    after = r["time"] > t_star
    assert np.all(r["contact_mode"][after] == 0)
    assert np.max(np.abs(r["vx"][after] - v_star)) < 1e-9 * abs(v_star)
    assert np.max(np.abs(R * r["gamma_dot"][after] - v_star)) < 1e-9 * abs(v_star)
    assert np.all(r["slip_long"][after] == 0) and np.all(r["F_long"][after] == pytest.approx(0, abs=1e-9))


def test_energy_balance_through_the_switches(fmu):
    """energy + dissipated_energy constant through the slide and the switch to rolling; the friction's
    work is mu_k M g times the slip's path, |s0|^2 / (2 mu_k g (1 + 1/k)) for the slip s."""
    mu_k, v0, w0 = 0.25, 2.0, -5.0
    s0 = v0 - R * w0
    r, events = run(fmu, 1.0, beta=math.pi / 2, gamma_dot=w0, slip_long=s0, mu_k=mu_k)
    assert len(events) == 1
    total = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(total - total[0])) < 1e-10 * total[0]
    lost = mu_k * M * G * s0**2 / (2 * slip_rate(mu_k))
    assert r["dissipated_energy"][-1] == pytest.approx(lost, rel=1e-9)


def test_incline_rolls_exactly_up_to_the_friction_limit(fmu):
    """Rolling straight down an incline needs the friction M g sin(th) k / (1 + k) against the normal
    force M g cos(th): it holds while tan(th) <= mu (1 + k) / k. Just below (1 - 1e-6) the wheel rolls
    at g sin(th) / (1 + k) without a switch; just above (1 + 1e-6) it slides from the start, the centre
    at g (sin th - mu_k cos th), the spin at mu_k g cos(th) / (k R)."""
    limit = math.atan(MU * (1 + KA) / KA)
    below = limit * (1 - 1e-6)
    r, events = run(fmu, 0.5, beta=math.pi / 2, gamma_dot=0.0, slope_angle=below)
    assert events == [] and not r["contact_switched"].any()
    a = G * math.sin(below) / (1 + KA)
    assert np.max(np.abs(r["x"] - 0.5 * a * r["time"]**2)) < 1e-9 * 0.5 * a * 0.25
    above = limit * (1 + 1e-6)
    for mu_k in (MU, 0.2):
        r, events = run(fmu, 0.5, beta=math.pi / 2, gamma_dot=0.0, slope_angle=above, mu_k=mu_k)
        assert [name for name, _ in events] == ["contact_slip"] and events[0][1] == 0.0
        assert np.all(r["contact_mode"] == 1)
        a = G * (math.sin(above) - mu_k * math.cos(above))
        spin = mu_k * G * math.cos(above) / (KA * R)
        t = r["time"]
        assert np.max(np.abs(r["vx"] - a * t)) < 1e-9 * a * t[-1]
        assert np.max(np.abs(r["x"] - 0.5 * a * t**2)) < 1e-9 * 0.5 * a * t[-1]**2
        assert np.max(np.abs(r["gamma_dot"] - spin * t)) < 1e-9 * spin * t[-1]
        assert np.all(r["slip_long"][1:] > 0)


def test_fmu_state_keeps_the_mode(fmu):
    """An FMU state saved mid-slide and restored reproduces the run exactly, the switch included."""
    s = Slave(fmu, logging_on=False)
    s.init(**TIGHT, beta=math.pi / 2, gamma_dot=-5.0, slip_long=2.85, mu_k=0.25)
    s.slave.doStep(0.0, 0.1)
    assert s.get("contact_mode") == 1.0
    state = s.slave.getFMUState()

    def rest():
        out = []
        for k in range(10):
            s.slave.doStep(0.1 + 0.05 * k, 0.05)
            out.append(s.get("contact_mode", "vx", "gamma_dot", "slip_long", "dissipated_energy"))
        return out
    first = rest()
    assert first[-1][0] == 0.0 and first[0][0] == 1.0
    s.slave.setFMUState(state)
    assert s.get("contact_mode") == 1.0
    assert rest() == first
    s.slave.freeFMUState(state)
    s.free()


def test_leaning_wheel_on_low_friction_slips_and_resticks(fmu):
    """A leaning, spinning wheel on mu = 0.1 (mu_k 0.08): it slips and rolls again; no NaN, a bounded
    number of switches, the run within the default step budget, the energy balance kept."""
    r, events = run(fmu, 3.0, dt=0.01, beta=math.radians(80), gamma_dot=8.0, mu=0.1, mu_k=0.08)
    switches = [t for name, t in events if name == "contact_slip"]
    for key in ("x", "vx", "beta", "slip_long", "slip_lat", "energy"):
        assert np.all(np.isfinite(r[key]))
    assert 2 <= len(switches) <= 50
    assert set(r["contact_mode"]) == {0.0, 1.0}
    total = r["energy"] + r["dissipated_energy"]
    assert np.max(np.abs(total - total[0])) < 1e-9 * total[0]


@pytest.mark.parametrize("text, message", [
    ('[effects.contact_forces]\nmu_k = 0.2\n', 'mu_k: is the kinetic friction of on_slip = "slide"'),
    ('[effects.contact_forces]\non_slip = "slide"\nmu = 0.3\nmu_k = 0.4\n', "mu_k: must be <= mu"),
    ('[effects.contact_forces]\non_slip = "slide"\non_lift_off = "warn"\n', 'on_lift_off: must be "terminate"'),
    ('[effects.contact_forces]\n[initial]\nslip_long = 1.0\n', 'slip_long: is a start value of the sliding mode'),
    ('[model]\nformulation = "multipliers"\n[effects.contact_forces]\non_slip = "slide"\n',
     'on_slip: "slide" needs formulation = "reduced"'),
])
def test_scene_refuses_what_sliding_cannot_honour(text, message):
    with pytest.raises(SceneError, match=re.escape(message)):
        parse_scene(WHEEL + text, "s.toml")
