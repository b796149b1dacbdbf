"""Planar Gyrover with Coulomb rolling resistance and true stiction: an independent reference.

The upright Gyrover rolling straight on flat ground is a planar two-degree-of-freedom system,
derived here with sympy from its own Lagrangian (not from model/):

* wheel: mass M, axial inertia I_a = k_axial M R^2, spin gamma; rolling x = R gamma (upright,
  alpha = 0: the frame of docs/model.md has l = -k, m = -i, n = +j, and v_A = omega x (R k)
  = R gamma_dot i);
* internal assembly: point mass m_fly at A + L_pend (cos(th) l + sin(th) m) =
  (x - L sin th, R - L cos th), turning with th_dot about n; the flywheel (axis n while
  tilt = 0) spins at th_dot + flywheel_rate about it, inertia I_fly_axial;
* T = 1/2 (M R^2 + I_a) gamma_dot^2 + 1/2 m_fly |v_p|^2 + 1/2 I_fly_axial (th_dot + Omega)^2,
  V = m_fly g (R - L cos th) (+ M g R);
* drive: +tau on th, -tau on gamma; rolling resistance Q_gamma = -c_rr R F_n m while sliding
  (m = +1 / -1), the holding force H while stuck (gamma_dot = 0);
* F_n = (M + m_fly) g + m_fly z_p_ddot (vertical momentum of both bodies).

Hybrid simulation with scipy's DOP853 and located events, the same switching rule as stated in
docs/effects.md (stick where the rate reaches 0 and H^2 < (c_rr R F_n (1 + 1e-9))^2, otherwise
reverse; break away where H^2 reaches that limit, sliding against H).

API: ``simulate(tau, c_rr, t_end, params) -> (events [(t, new mode)], sample(t) -> (gamma_dot, th, th_dot))``.
"""
from __future__ import annotations

import functools

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

BREAKAWAY = 1e-9
DEFAULTS = dict(M=2.0, R=0.17, k_axial=0.4, m_fly=0.4, L_pend=0.03, I_fly_axial=5e-4, flywheel_rate=400.0,
                g=9.81)


@functools.lru_cache(maxsize=None)
def _equations():
    """Lambdified (mass matrix, right-hand side without Q_gamma, F_n affine in th_ddot)."""
    ga, th = sp.symbols("gamma theta")
    gd, thd, gdd, thdd = sp.symbols("gamma_dot theta_dot gamma_ddot theta_ddot")
    M, R, ka, mf, L, If, Om, g, tau = sp.symbols("M R k_axial m_fly L_pend I_fly_axial Omega g tau")
    t = sp.symbols("t")
    q = [sp.Function("gamma")(t), sp.Function("theta")(t)]
    x = R * q[0]
    xp, zp = x - L * sp.sin(q[1]), R - L * sp.cos(q[1])
    T = (sp.Rational(1, 2) * (M * R**2 + ka * M * R**2) * q[0].diff(t)**2
         + sp.Rational(1, 2) * mf * (xp.diff(t)**2 + zp.diff(t)**2)
         + sp.Rational(1, 2) * If * (q[1].diff(t) + Om)**2)
    V = mf * g * zp + M * g * R
    Lag = T - V
    eqs = [sp.diff(Lag.diff(qi.diff(t)), t) - Lag.diff(qi) for qi in q]  # = Q
    subs = [(q[0].diff(t, 2), gdd), (q[1].diff(t, 2), thdd), (q[0].diff(t), gd), (q[1].diff(t), thd),
            (q[0], ga), (q[1], th)]  # derivatives first
    eqs = [sp.expand(e.subs(subs)) for e in eqs]
    Fn = sp.expand(((M + mf) * g + mf * zp.diff(t, 2)).subs(subs))
    acc = [gdd, thdd]
    mass = sp.Matrix([[e.coeff(a) for a in acc] for e in eqs])
    bias = sp.Matrix([e.subs({gdd: 0, thdd: 0}) for e in eqs])
    Q = sp.Matrix([-tau, tau])  # the drive
    args = (th, gd, thd, M, R, ka, mf, L, If, Om, g, tau)
    return (sp.lambdify(args, mass, "numpy"), sp.lambdify(args, Q - bias, "numpy"),
            sp.lambdify(args, [Fn.subs(thdd, 0), Fn.coeff(thdd)], "numpy"))


class Planar:
    """The planar hybrid system for one drive torque tau and coefficient c_rr."""

    def __init__(self, tau: float, c_rr: float, **params):
        self.p = {**DEFAULTS, **params}
        self.tau, self.c_rr = tau, c_rr
        self.mass, self.force, self.normal = _equations()

    def _args(self, th, gd, thd):
        p = self.p
        return (th, gd, thd, p["M"], p["R"], p["k_axial"], p["m_fly"], p["L_pend"], p["I_fly_axial"],
                p["flywheel_rate"], p["g"], self.tau)

    def solve(self, y, mode):
        """(gamma_ddot, th_ddot, F_n, H) in mode (0 stuck: gamma_ddot = 0, H the holding force)."""
        _, gd, th, thd = y  # y = (gamma, gamma_dot, th, th_dot)
        a = self._args(th, gd, thd)
        Mm, f = np.array(self.mass(*a), float), np.array(self.force(*a), float).ravel()
        fn0, fn1 = self.normal(*a)
        k = self.c_rr * self.p["R"]
        # unknowns (gamma_ddot, th_ddot, H): rows gamma, theta, mode; Q_gamma = -k F_n m + s H
        s = 1.0 if mode == 0 else 0.0
        A = np.array([[Mm[0, 0], Mm[0, 1] + k * fn1 * mode, -s],
                      [Mm[1, 0], Mm[1, 1], 0.0],
                      [s, 0.0, 1.0 - s]])
        b = np.array([f[0] - k * fn0 * mode, f[1], 0.0])
        gdd, thdd, H = np.linalg.solve(A, b)
        return gdd, thdd, fn0 + fn1 * thdd, H

    def limit2(self, y):
        _, _, Fn, H = self.solve(y, 0)
        return (self.c_rr * self.p["R"] * Fn * (1 + BREAKAWAY))**2, H

    def simulate(self, t_end: float, rtol: float = 1e-12):
        """From rest (stuck, th = 0) to t_end: list of (t, new mode) and a dense sampler."""
        y, t, mode = np.zeros(4), 0.0, 0
        events, pieces = [], []
        lim2, H = self.limit2(y)
        if H * H >= lim2:
            mode = -1 if H > 0 else 1
            events.append((0.0, mode))
        while t < t_end:
            def rhs(_, yy, m=mode):
                gdd, thdd, _, _ = self.solve(yy, m)
                return [yy[1], gdd, yy[3], thdd]

            if mode == 0:
                def ev(_, yy):
                    l2, h = self.limit2(yy)
                    return l2 - h * h
            else:
                def ev(_, yy, m=mode):
                    return m * yy[1]
            ev.terminal, ev.direction = True, -1
            sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=rtol, atol=1e-14, events=ev,
                            dense_output=True)
            pieces.append((t, sol.t[-1], sol.sol, mode))
            if sol.status != 1:
                break
            t, y = sol.t_events[0][0], sol.y_events[0][0].copy()
            y[1] = 0.0  # the rate exactly 0 (as the model's update)
            lim2, H = self.limit2(y)
            if mode == 0:  # the located breakaway (the root estimate may lie a hair before it)
                mode = -1 if H > 0 else 1
            else:  # stick where the holding force needed is within the limit, else turn back
                mode = 0 if H * H < lim2 else (-1 if H > 0 else 1)
            events.append((t, mode))

        def sample(ts):
            out = []
            for tt in np.atleast_1d(ts):
                for a, b, f, _ in pieces:
                    if a <= tt <= b:
                        yy = f(tt)
                        out.append((yy[1], yy[2], yy[3]))
                        break
            return np.array(out)
        return events, sample
