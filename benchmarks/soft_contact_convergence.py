"""Convergence of the soft-contact reference (tests/reference/soft_contact.py) to the closed forms
of rigid contact, as the penalty stiffness kappa grows and the friction's regularisation eps
shrinks; with the wall time of each run (one core).

Tables (the paper wheel M = 2 kg, R = 0.17 m, k_diam = 0.25, k_axial = 0.4; g = 9.81, mu_k = 0.3,
e = 0.5; solver rtol 1e-8, atol 1e-10):
1. sliding launch, upright on level ground, v0 = 2 m/s, w0 = -5 rad/s (backspin): the rolling
   time and speed against t* = |s0| / (mu_k g (1 + 1/k_axial)) and
   v* = (v0 + k_axial R w0) / (1 + k_axial), over eps and kappa;
2. incline at 1.1 x the rolling limit tan(theta) = mu (1 + k_axial) / k_axial: the centre's
   acceleration against g (sin - mu_k cos), and at 0.9 x against g sin / (1 + k_axial);
3. drop of an upright wheel from h = 0.2 m: the first three apex heights against e^(2k) h, the
   rebound ratio of the first impact against e, the rest time against t0 (1 + e) / (1 - e);
4. flight: the precession rate against |L| / I_diam, the centre against its parabola;
5. a leaning spinning drop: the first impact's impulses and energy loss (their convergence in
   kappa; no closed form), the energy balance E + W.
The closed forms are derived in tests/test_soft_contact_reference.py's docstring.

    .venv/bin/python benchmarks/soft_contact_convergence.py          (about 30 s)
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from reference.soft_contact import Wheel  # noqa: E402
from reference.soft_contact_scenarios import (drop, extrapolate, flight, incline, leaning_drop,  # noqa: E402
                                              sliding_launch)

WHEEL, G, MU, E = Wheel(), 9.81, 0.3, 0.5


def timed(fun, *args, **kw):
    t0 = time.perf_counter()
    result = fun(*args, **kw)
    return result, time.perf_counter() - t0


def sliding_table():
    v0, w0 = 2.0, -5.0
    a = MU * G * (1 + 1 / WHEEL.k_axial)
    t_star = abs(v0 - WHEEL.R * w0) / a
    v_star = (v0 + WHEEL.k_axial * WHEEL.R * w0) / (1 + WHEEL.k_axial)
    print(f"\n1. sliding launch, v0 = {v0} m/s, w0 = {w0} rad/s: t* = {t_star:.6f} s, v* = {v_star:.6f} m/s")
    print("| kappa (1/s^2) | eps (m/s) | t_roll - t* (s) | v_roll - v* (m/s) | slip rate / -a - 1 | wall (s) |")
    print("|---|---|---|---|---|---|")
    for kappa, eps in ((1e4, 1e-3), (1e5, 1e-4), (1e6, 1e-5), (1e6, 1e-6), (1e7, 1e-6)):
        r, wall = timed(sliding_launch, v0, w0, WHEEL, mu_k=MU, stiffness=kappa, eps=eps, restitution=E, g=G)
        print(f"| {kappa:.0e} | {eps:.0e} | {r['t_roll'] - t_star:.2e} | {r['v_roll'] - v_star:.2e} | "
              f"{r['slip_rate'] / -a - 1:.1e} | {wall:.2f} |")


def incline_table():
    limit = MU * (1 + WHEEL.k_axial) / WHEEL.k_axial
    print("\n2. incline, upright from rest; a the centre's acceleration downhill (window 0.2-0.5 s)")
    print("| tan / limit | kappa (1/s^2) | eps (m/s) | a (m/s^2) | a - closed form (m/s^2) | sliding | wall (s) |")
    print("|---|---|---|---|---|---|---|")
    for ratio in (0.9, 1.1):
        theta = math.atan(ratio * limit)
        exact = (G * math.sin(theta) / (1 + WHEEL.k_axial) if ratio < 1
                 else G * (math.sin(theta) - MU * math.cos(theta)))
        for kappa, eps in ((1e4, 1e-3), (1e5, 1e-4), (1e6, 1e-5)):
            r, wall = timed(incline, theta, WHEEL, mu_k=MU, stiffness=kappa, eps=eps, restitution=E, g=G)
            print(f"| {ratio} | {kappa:.0e} | {eps:.0e} | {r['accel']:.9f} | {r['accel'] - exact:.1e} | "
                  f"{r['sliding']} | {wall:.2f} |")


def drop_table():
    h = 0.2
    t_rest = math.sqrt(2 * h / G) * (1 + E) / (1 - E)
    print(f"\n3. drop from h = {h} m, e = {E}: apex k / (e^2k h) - 1; rest time t0 (1+e)/(1-e) = {t_rest:.6f} s")
    print("(extrapolated: Richardson's, kappa^-1/2, from this row and the one above)")
    print("| kappa (1/s^2) | apex 1 | apex 2 | apex 3 | apex 1 extrapolated | e_eff(1) - e | e_eff extrapolated | "
          "bounces | t_rest - closed (s) | wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    previous = None
    for kappa in (1e4, 1e5, 1e6, 1e7, 1e8):
        r, wall = timed(drop, h, E, WHEEL, stiffness=kappa, mu_k=MU, g=G)
        rel = [f"{a / (E ** (2 * k) * h) - 1:.2e}" for k, a in enumerate(r["apex"][:3], start=1)]
        rel += ["-"] * (3 - len(rel))
        extra = ["-", "-"]
        if previous is not None:
            extra = [f"{extrapolate(previous['apex'][0], r['apex'][0]) / (E ** 2 * h) - 1:.1e}",
                     f"{extrapolate(previous['e_eff'][0], r['e_eff'][0]) - E:.1e}"]
        print(f"| {kappa:.0e} | {' | '.join(rel)} | {extra[0]} | {r['e_eff'][0] - E:.2e} | {extra[1]} | "
              f"{len(r['touchdowns'])} | {r['t_rest'] - t_rest:.2e} | {wall:.2f} |")
        previous = r


def flight_table():
    r, wall = timed(flight, beta0=1.2, gamma_dot0=10.0, alpha_dot0=4.0, beta_dot0=3.0, wheel=WHEEL, g=G)
    i_diam = WHEEL.k_diam * WHEEL.M * WHEEL.R ** 2
    t = r["t"][:, None]
    parabola = r["r"][0] + r["v"][0] * t + 0.5 * np.array([0, 0, -G]) * t ** 2
    print("\n4. flight, 0.6 s (rtol 1e-11): precession about L against |L| / I_diam; centre against the parabola")
    print(f"precession {r['precession']:.12f} rad/s, |L| / I_diam {np.linalg.norm(r['L'][0]) / i_diam:.12f} "
          f"rad/s (cone {r['cone']:.3f} rad); centre off the parabola by "
          f"{np.abs(r['r'] - parabola).max():.1e} m; {wall:.2f} s")


def leaning_drop_table():
    print("\n5. leaning drop (beta0 = 1.1 rad, gamma_dot0 = 15, alpha_dot0 = 1 rad/s, rim point sliding at"
          " 0.3 m/s, h = 0.05 m): the first impact; E + W drift over 0.4 s")
    print("| kappa (1/s^2) | impacts | J_n (N s) | J_t / (mu_k J_n) | E after - E before (J) | max drift (J) | wall (s) |")
    print("|---|---|---|---|---|---|---|")
    for kappa in (1e5, 1e6, 1e7):
        r, wall = timed(leaning_drop, wheel=WHEEL, stiffness=kappa, mu_k=MU, restitution=E, g=G)
        first = r["impacts"][0]
        print(f"| {kappa:.0e} | {len(r['impacts'])} | {first['J_n']:.6f} | {first['J_t'] / (MU * first['J_n']):.6f} | "
              f"{first['E_after'] - first['E_before']:.6f} | {r['drift']:.1e} | {wall:.2f} |")


if __name__ == "__main__":
    sliding_table()
    incline_table()
    drop_table()
    flight_table()
    leaning_drop_table()
