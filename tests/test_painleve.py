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
"""
from __future__ import annotations

import math
import re
import subprocess
import sys

import numpy as np
import pytest

import gyrowheel

K_DIAM = 0.25  # examples/scenes/drop_bounce.toml
MARGIN = 0.05  # model/painleve.py, PAINLEVE_MARGIN
REPORTED = {"height": 0.1701167455156187, "beta": 0.26110964694417926, "gamma_dot": 7.23102942678814,
            "alpha_dot": -3.3398884695278297, "beta_dot": 1.7787370856730949, "slip_long": -0.9578492911122178,
            "slip_lat": -0.37885960589361023, "restitution": 0, "mu": 5, "vz": 0.23037827926346788}


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
    for k, v in REPORTED.items():
        args += ["--set", f"{k}={v!r}"]
    r = subprocess.run(args, capture_output=True, text=True)
    return r, np.genfromtxt(out, delimiter=",", names=True)


def test_sliding_into_the_paradox_stops_where_d_reaches_the_margin(drop, tmp_path):
    """The reported drop at mu_k = 4: it lands, slides, and D / W_nn falls to the margin while F_n
    diverges; the run ends there with event painleve, exit 0, one warning line, no NaN."""
    r, out = run_cli(drop, tmp_path / "p.csv", 4)
    assert r.returncode == 0, r.stderr
    t_end = out["time"][-1]
    assert 0.18 < t_end < 0.19
    assert r.stderr == (f"gyrowheel: warning: sliding stopped at t = {t_end:.9g} s (event painleve): the normal "
                        "force diverges there, the friction's share of the normal inverse mass reached D / W_nn = "
                        "0.05 (Painleve's paradox); the rigid Coulomb contact has no solution beyond it: lower mu_k\n")
    assert "painleve_paradox at t = " in r.stdout
    assert all(np.isfinite(out[n]).all() for n in out.dtype.names)
    assert out["painleve_paradox"][-1] and not out["painleve_paradox"][:-1].any()
    assert out["contact_mode"][-1] == 1 and not out["fallen"][-1]
    sliding = out["contact_mode"] == 1
    e_lat = out["slip_lat"] / np.hypot(out["slip_long"], out["slip_lat"])
    d = share(out["beta"], 4, e_lat)
    assert d[-1] == pytest.approx(MARGIN, abs=1e-6)  # located where the hand-derived D reaches it
    assert (d[sliding][:-1] > MARGIN + 1e-3).all()
    # F_n = -N / D: the frictionless normal force F_n D / W_nn stays bounded while F_n grows
    f0 = out["F_n"][sliding] * d[sliding]
    assert out["F_n"][-1] > 3 * out["F_n"][sliding][0]
    assert f0.max() < 1.5 * f0.min()


def test_lower_kinetic_friction_completes_the_same_run(drop, tmp_path):
    r, out = run_cli(drop, tmp_path / "p.csv", 3)
    assert r.returncode == 0 and r.stderr == ""
    assert out["time"][-1] == 1.5 and not out["painleve_paradox"].any()
    s = out[out["contact_mode"] == 1]
    assert len(s) > 10
    assert (share(s["beta"], 3, s["slip_lat"] / np.hypot(s["slip_long"], s["slip_lat"])) > MARGIN).all()


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
