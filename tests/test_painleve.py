"""The Painleve stop of the sliding mode (model/painleve.py; docs/effects.md, "Sliding").

Independent reference: the Delassus matrix of a rigid wheel (mass M, diametral inertia
k_diam M R^2) at its lowest rim point, by hand. With r = -R l from the centre to the contact (l in
the wheel plane, from the contact to the centre), n the ground normal and y the horizontal unit
vector across the heading, the contact point's velocity change under an impulse P is
P / M + (I^-1 (r x P)) x r, so W_ab = a . b / M + (r x a) . I^-1 (r x b). At lean beta,
n = sin(beta) l + cos(beta) a and y = cos(beta) l - sin(beta) a (a the axle); r x n and r x y are
both along the diameter l x a (arms R cos(beta), R sin(beta)), r x (heading) is along the axle:

    W_nn = (1 + cos^2 beta / k_diam) / M,   W_ny = -sin beta cos beta / (k_diam M),   W_n,heading = 0,

so D / W_nn = 1 - mu_k e_lat sin(beta) cos(beta) / (k_diam + cos^2 beta) for a slip direction e with
lateral component e_lat (+: slip_lat > 0, the side on which friction lowers D for beta < pi/2). D = 0
at mu_k = (k_diam + cos^2 beta) / (sin beta cos beta), smallest, 2 sqrt(k_diam (1 + k_diam)), at
tan beta = sqrt((1 + k_diam) / k_diam) (the Painleve rod's condition, Stewart 2000, section 3).
The FMU computes D from the free system's mass matrix (CasADi); nothing here comes from it.

A switch into sliding can land directly where D / W_nn <= PAINLEVE_MARGIN: rolling -> sliding,
whose friction direction is the onset direction d = -F_t / |F_t| (F_t the friction the rolling
constraint needed), and a touchdown that lands sliding, e along the slip the impact leaves. Sliding
cannot be continued there, so the run stops in the switch's instant with the event painleve (a
continuous approach is located at D / W_nn = 0.05 instead). The rolling dynamics and the slip onset
(|F_t| = mu F_n (1 + 1e-9)) do not depend on mu_k, nor does d, so the kinetic coefficient at which
the switch lands on the margin follows from the closed form at the switch: mu_k* = (1 - margin)
(k_diam + cos^2 beta) / (e_lat sin(beta) cos(beta)); 1 % above it the run stops at the switch, 1 %
below it the wheel slides on.
"""
from __future__ import annotations

import math
import re
import subprocess
import sys

import numpy as np
import pytest
from fmpy import simulate_fmu

import gyrowheel

K_DIAM = 0.25  # examples/scenes/drop_bounce.toml
MARGIN = 0.05  # model/painleve.py, PAINLEVE_MARGIN
# thrown from 0.1 m, leaning and spinning: it lands sliding at t = 0.19535 s
THROWN = {"height": 0.1, "beta": 1.17, "beta_dot": -5.8, "gamma_dot": 29.0, "alpha_dot": -5.0, "mu": 1.3}


@pytest.fixture(scope="module")
def drop(example_build):
    return str(example_build("drop_bounce").fmu)


def share(beta, mu_k, e_lat):
    """D / W_nn of the module docstring (1)."""
    s, c = np.sin(beta), np.cos(beta)
    return 1 - mu_k * e_lat * s * c / (K_DIAM + c * c)


def run_cli(fmu, out, mu_k):
    args = [sys.executable, "-m", "gyrowheel", "simulate", fmu, "-o", str(out), "--stop-time", "1.5",
            "--set", f"mu_k={mu_k}"]
    for k, v in THROWN.items():
        args += ["--set", f"{k}={v!r}"]
    r = subprocess.run(args, capture_output=True, text=True)
    return r, np.genfromtxt(out, delimiter=",", names=True)


def test_sliding_into_the_paradox_stops_where_d_reaches_the_margin(drop, tmp_path):
    """The thrown wheel at mu_k = 1.15: it lands sliding at D / W_nn = 0.117 and D / W_nn falls to
    the margin while it slides, F_n growing; the run ends there with event painleve, exit 0, one
    warning line, no NaN."""
    r, out = run_cli(drop, tmp_path / "p.csv", 1.15)
    assert r.returncode == 0, r.stderr
    t_end = out["time"][-1]
    assert 0.1979 < t_end < 0.1980
    assert r.stderr == (f"gyrowheel: warning: sliding stopped at t = {t_end:.9g} s (event painleve): the friction's "
                        "share of the normal inverse mass reached D / W_nn <= 0.05, where the normal force diverges "
                        "or turns negative against a contact driven into the ground (Painleve's paradox); the rigid "
                        "Coulomb contact has no solution beyond it: lower mu_k\n")
    assert f"painleve at t = {t_end:.6g} s)" in r.stdout
    assert all(np.isfinite(out[n]).all() for n in out.dtype.names)
    assert out["painleve_paradox"][-1] and not out["painleve_paradox"][:-1].any()
    assert out["contact_mode"][-1] == 1 and not out["fallen"][-1]
    sliding = out["contact_mode"] == 1
    assert sliding.sum() >= 3  # rows at 0.196, 0.197 and the stop
    e_lat = out["slip_lat"] / np.hypot(out["slip_long"], out["slip_lat"]).clip(1e-300)
    d = share(out["beta"], 1.15, e_lat)
    assert d[-1] == pytest.approx(MARGIN, abs=1e-6)  # located where the hand-derived D reaches it
    assert (d[sliding][:-1] > MARGIN + 1e-3).all()
    assert out["F_n"][-1] > out["F_n"][sliding][0]


def test_lower_kinetic_friction_completes_the_same_run(drop, tmp_path):
    r, out = run_cli(drop, tmp_path / "p.csv", 1.0)
    assert r.returncode == 0 and r.stderr == ""
    assert out["time"][-1] == 1.5 and not out["painleve_paradox"].any()
    s = out[out["contact_mode"] == 1]
    assert len(s) > 10
    assert (share(s["beta"], 1.0, s["slip_lat"] / np.hypot(s["slip_long"], s["slip_lat"])) > MARGIN).all()


@pytest.mark.parametrize("beta", [0.5, math.pi / 4, 1.1])
def test_start_sliding_past_the_margin_is_refused_with_the_analytic_indicator(drop, beta):
    """Sliding sideways from the start (height 0, slip_lat > 0) at mu_k just past the margin's
    coefficient: refused at initialisation with the indicator D / W_nn - margin of the closed form;
    just below it, and with the slip to the other side, the run goes."""
    s, c = math.sin(beta), math.cos(beta)
    mu_margin = (1 - MARGIN) * (K_DIAM + c * c) / (s * c)
    start = {"height": 0.0, "beta": beta, "slip_lat": 0.5, "mu": 3 * mu_margin}
    with pytest.raises(gyrowheel.ArgumentError) as exc:
        gyrowheel.simulate(drop, stop_time=1e-3, start_values={**start, "mu_k": 1.01 * mu_margin})
    m = re.fullmatch(r"start_values: the FMU refused the start values: the initial state already triggers "
                     r"event painleve \(indicator (\S+) <= 0\)", str(exc.value))
    assert m, str(exc.value)
    assert float(m.group(1)) == pytest.approx(share(beta, 1.01 * mu_margin, 1) - MARGIN, rel=1e-5)
    for mu_k, slip in ((0.99 * mu_margin, 0.5), (1.01 * mu_margin, -0.5)):
        gyrowheel.simulate(drop, stop_time=1e-3, start_values={**start, "mu_k": mu_k, "slip_lat": slip})


# a leaning wheel spinning fast with a large lean rate on the ground (height 0): at mu = 2 the
# friction it needs reaches the limit at t = 0.0148 s, with the onset direction across the heading
ROLLING = {"height": 0.0, "beta": 1.88, "beta_dot": -5.66, "gamma_dot": 39.3, "alpha_dot": 4.6, "mu": 2.0}
def run_from(drop, start, mu_k, stop=0.2):
    """gyrowheel.simulate from `start` at kinetic coefficient mu_k, a row per ms."""
    return gyrowheel.simulate(drop, stop_time=stop, output_interval=1e-3, start_values={**start, "mu_k": mu_k})


def test_rolling_to_sliding_switch_past_the_margin_stops_at_the_switch(drop):
    """mu_k = mu: the onset lands below the margin (D / W_nn = -0.21 from the closed form); the
    run's last row is the switch's instant, sliding, with both flags; every row before rolls.
    Then mu_k 1 % above and below the closed form's mu_k*: stop at the same instant, slide on."""
    out = run_from(drop, ROLLING, 2.0)
    last = out[-1]
    t_switch = out["time"][-1]
    assert 0.0148 < t_switch < 0.0149
    assert last["painleve_paradox"] and last["contact_switched"] and last["contact_mode"] == 1
    assert not out["painleve_paradox"][:-1].any() and (out["contact_mode"][:-1] == 0).all()
    assert all(np.isfinite(out[n]).all() for n in out.dtype.names)
    # the sliding friction at the switch is -mu_k F_n d (v_slip = 0): d from the last row
    e = -np.array([last["F_long"], last["F_lat"]]) / (2.0 * last["F_n"])
    assert np.hypot(*e) == pytest.approx(1, abs=1e-9)
    assert share(last["beta"], 2.0, e[1]) < MARGIN - 0.2
    s, c = np.sin(last["beta"]), np.cos(last["beta"])
    mu_star = (1 - MARGIN) * (K_DIAM + c * c) / (e[1] * s * c)
    assert 0 < mu_star < 2.0

    above = run_from(drop, ROLLING, 1.01 * mu_star)
    assert above["time"][-1] == pytest.approx(t_switch, abs=1e-12)
    assert above["painleve_paradox"][-1] and above["contact_mode"][-1] == 1
    assert share(above["beta"][-1], 1.01 * mu_star, e[1]) < MARGIN

    below = run_from(drop, ROLLING, 0.99 * mu_star)
    assert below["contact_switched"][-1]  # it did switch to sliding, and lifted off soon after
    # it flies and lands again at t = 0.0884 s, sliding past the limit (D / W_nn < 0): the stop
    # there, never below the ground
    last = below[-1]
    assert 0.088 < last["time"] < 0.089 and last["painleve_paradox"] and last["contact_flown"]
    assert (below["contact_mode"][(below["time"] > t_switch + 1e-3)][:-1] == 2).all()
    e_lat = last["slip_lat"] / np.hypot(last["slip_long"], last["slip_lat"])
    assert share(last["beta"], 0.99 * mu_star, e_lat) < 0
    assert below["height"].min() >= -1e-9


def test_touchdown_landing_past_the_margin_stops_at_the_touchdown(drop):
    """The thrown wheel lands sliding at D / W_nn = 0.0026 (closed form, e along the slip the impact
    leaves): the run stops in the touchdown's instant (the row before is in flight, 4.3e-8 m above
    the ground), no NaN. With mu_k = 1 the same flight lands and the run goes on."""
    out = run_from(drop, THROWN, 1.3, stop=0.3)
    last = out[-1]
    assert 0.1953 < out["time"][-1] < 0.1954
    assert last["painleve_paradox"] and last["contact_mode"] == 1
    assert (out["contact_mode"][:-1] == 2).all() and not out["painleve_paradox"][:-1].any()
    assert 0 < out["height"][-2] < 1e-6
    assert all(np.isfinite(out[n]).all() for n in out.dtype.names)
    e_lat = last["slip_lat"] / np.hypot(last["slip_long"], last["slip_lat"])
    d = share(last["beta"], 1.3, e_lat)
    assert d < MARGIN - 0.04  # below the margin at once: a continuous approach stops at 0.05

    lower = run_from(drop, THROWN, 1.0, stop=0.3)
    assert lower["time"][-1] == 0.3 and not lower["painleve_paradox"].any()
    assert lower["contact_flown"].any() and (lower["contact_mode"] != 2).any()


# dropped from 2 cm, leaning 45 degrees, slipping sideways, plastic: past D = 0 for mu_k > 1.5
# (closed form at e_lat = 1: D / W_nn = 1 - mu_k sin(b) cos(b) / (k_diam + cos^2 b) = 1 - mu_k / 1.5)
SIDEWAYS = {"height": 0.02, "beta": math.pi / 4, "slip_lat": 0.5, "mu": 3.0, "restitution": 0.0}
G_DROP = 9.81  # examples/scenes/drop_bounce.toml


def test_landing_past_d_zero_stops_at_the_touchdown_and_never_sinks(drop):
    """mu_k = 2.5: the sliding end mode has D / W_nn = -0.67 (closed form), so F_n = -N / D < 0 with
    the contact point accelerating into the ground: no lift-off but the Painleve stop, in the
    touchdown's instant, the free fall's sqrt(2 h / g) (the wheel neither turns nor leans in flight).
    Legal mu_k (the margin's 1.425 and below): it slides until it lies flat, never below the ground."""
    out = run_from(drop, SIDEWAYS, 2.5, stop=0.5)
    last = out[-1]
    assert out["time"][-1] == pytest.approx(math.sqrt(2 * 0.02 / G_DROP), abs=1e-9)
    assert last["painleve_paradox"] and last["contact_flown"] and last["contact_mode"] == 1
    assert (out["contact_mode"][:-1] == 2).all()
    e_lat = last["slip_lat"] / np.hypot(last["slip_long"], last["slip_lat"])
    assert share(last["beta"], 2.5, e_lat) == pytest.approx(1 - 2.5 / 1.5, abs=1e-6)
    assert out["height"].min() >= -1e-9
    for mu_k in (0.5, 1.0, 1.4):
        legal = run_from(drop, SIDEWAYS, mu_k, stop=0.5)
        # it slides on the ground until it lies flat (event fall, beta_min), never flying below it
        assert legal["fallen"][-1] and not legal["painleve_paradox"].any(), mu_k
        assert 0.19 < legal["time"][-1] < 0.5, mu_k
        assert legal["height"].min() >= -1e-9 and legal["z"].min() > 0, mu_k
        assert not legal["flat_in_flight"].any(), mu_k


@pytest.mark.parametrize("mu_k", [1.44, 1.48, 1.6, 2.5])
def test_start_sliding_past_d_zero_is_refused(drop, mu_k):
    """From the ground (height 0) the same sideways slip: refused for every mu_k past the margin's
    1.425, D > 0 or D <= 0 (F_n < 0 there is no lift-off), the indicator the closed form's; at 1.4 the
    run goes, slides until it lies flat and never sinks."""
    start = {**SIDEWAYS, "height": 0.0}
    start.pop("restitution")
    with pytest.raises(gyrowheel.ArgumentError) as exc:
        gyrowheel.simulate(drop, stop_time=1e-3, start_values={**start, "mu_k": mu_k})
    m = re.fullmatch(r"start_values: the FMU refused the start values: the initial state already triggers "
                     r"event painleve \(indicator (\S+) <= 0\)", str(exc.value))
    assert m, str(exc.value)
    assert float(m.group(1)) == pytest.approx(1 - mu_k / 1.5 - MARGIN, rel=1e-5)
    if mu_k == 1.44:
        out = run_from(drop, start, 1.4, stop=0.5)
        assert out["fallen"][-1] and not out["painleve_paradox"].any()  # slides until it lies flat
        assert out["height"].min() >= -1e-9 and out["z"].min() > 0


def test_model_exchange_landing_past_d_zero_stops_at_the_touchdown(drop):
    """The same landing with fmpy's CVode (Model Exchange): the FMU asks to terminate in the
    touchdown's instant (fmpy records that instant's values from before the event: in flight, at
    the ground to 1e-12 m), and the wheel is never below the ground."""
    out = simulate_fmu(drop, stop_time=0.5, output_interval=1e-3, fmi_type="ModelExchange", solver="CVode",
                       relative_tolerance=1e-10, start_values={**SIDEWAYS, "mu_k": 2.5}, record_events=True,
                       output=["height", "contact_mode"])
    assert out["time"][-1] == pytest.approx(math.sqrt(2 * 0.02 / G_DROP), abs=1e-6)
    assert abs(out["height"][-1]) < 1e-12 and (out["contact_mode"] == 2).all()
    assert out["height"].min() >= -1e-9
