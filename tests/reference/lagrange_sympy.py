"""Small Lagrange-multiplier derivation of the rolling wheel (cross-check of newton_euler).

Transcribes the paper's route with its typos fixed:

* coordinates q = (X, Y, alpha, beta, gamma); Z eliminated with the holonomic
  constraint Z = R sin(beta) (eq. 21), so Z_dot = R beta_dot cos(beta) stays in T;
* T of eq. (25) with general inertia:
  T = M/2 (X_dot^2 + Y_dot^2 + Z_dot^2)
      + 1/2 I_diam (alpha_dot^2 sin^2(beta) + beta_dot^2) + 1/2 I_axial (gamma_dot + alpha_dot cos(beta))^2,
  V = M g R sin(beta) (eq. 23);
* Pfaffian constraints A(q) q_dot = 0 transcribed from eqs. (18), (19);
* d/dt(dL/dq_dot) - dL/dq = A^T lambda (eq. 6), solved together with A q_ddot + A_dot q_dot = 0.

The mass matrix, bias terms and constraint terms are produced by sympy and lambdified;
the 7x7 linear system is solved numerically.

API: ``accelerations(state, params) -> (q_ddot (5,), lam (2,))`` with
state = (x, y, alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot) (x_dot, y_dot are
taken from the constraint), params = (M, R, k_diam, k_axial, g);
``rhs(state, params) -> (8,)`` like ``newton_euler.rhs``;
``energy(state, params)``.  The multipliers are the horizontal contact-force
components (lambda_1 = M X_ddot = F_x, lambda_2 = M Y_ddot = F_y, eqs. 40-41).
"""

from __future__ import annotations

import functools

import numpy as np
import sympy as sp


@functools.lru_cache(maxsize=None)
def derive():
    X, Y, al, be, ga = sp.symbols("X Y alpha beta gamma", real=True)
    Xd, Yd, ad, bd, gd = sp.symbols("X_dot Y_dot alpha_dot beta_dot gamma_dot", real=True)
    M, R, kd, ka, g = sp.symbols("M R k_diam k_axial g", positive=True)
    q = sp.Matrix([X, Y, al, be, ga])
    qd = sp.Matrix([Xd, Yd, ad, bd, gd])
    I_d, I_a = kd * M * R**2, ka * M * R**2
    sa, ca, sb, cb = sp.sin(al), sp.cos(al), sp.sin(be), sp.cos(be)

    Zd = R * bd * cb
    T = (M / 2 * (Xd**2 + Yd**2 + Zd**2)
         + sp.Rational(1, 2) * I_d * ((ad * sb) ** 2 + bd**2)
         + sp.Rational(1, 2) * I_a * (ad * cb + gd) ** 2)
    V = M * g * R * sb
    L = T - V

    # eqs (18), (19) as A q_dot = 0
    A = sp.Matrix([
        [1, 0, -R * ca * cb, R * sa * sb, -R * ca],
        [0, 1, -R * sa * cb, -R * ca * sb, -R * sa],
    ])
    Mq = sp.hessian(T, qd)
    p = sp.Matrix([sp.diff(L, v) for v in qd])
    # d/dt p = Mq q_ddot + (dp/dq) q_dot ;  bias h = (dp/dq) q_dot - dL/dq
    h = p.jacobian(q) * qd - sp.Matrix([sp.diff(L, v) for v in q])
    Adqd = (A * qd).jacobian(q) * qd  # A_dot q_dot
    return dict(q=q, qd=qd, params=(M, R, kd, ka, g), T=T, V=V, L=L, A=A, Mq=Mq, h=h, Adqd=Adqd)


@functools.lru_cache(maxsize=None)
def _numeric():
    d = derive()
    args = (tuple(d["q"]), tuple(d["qd"]), d["params"])
    mk = lambda e: sp.lambdify(args, e, modules="numpy", cse=True)  # noqa: E731
    return dict(Mq=mk(d["Mq"]), h=mk(d["h"]), A=mk(d["A"]), Adqd=mk(d["Adqd"]), E=mk(d["T"] + d["V"]))


def _q_qd(state, params):
    st = np.asarray(state, dtype=float)
    M, R, kd, ka, g = params
    x, y, al, be, ga, ad, bd, gd = st
    # eqs (18), (19)
    Xd = R * (gd * np.cos(al) + ad * np.cos(al) * np.cos(be) - bd * np.sin(al) * np.sin(be))
    Yd = R * (gd * np.sin(al) + ad * np.cos(be) * np.sin(al) + bd * np.cos(al) * np.sin(be))
    return (x, y, al, be, ga), (Xd, Yd, ad, bd, gd)


def accelerations(state, params):
    """Return (q_ddot, lam): q_ddot = (X_ddot, Y_ddot, alpha_ddot, beta_ddot, gamma_ddot), lam = (lambda_1, lambda_2)."""
    f = _numeric()
    pa = tuple(float(v) for v in params)
    q, qd = _q_qd(state, pa)
    Mq = np.array(f["Mq"](q, qd, pa), dtype=float)
    h = np.array(f["h"](q, qd, pa), dtype=float).ravel()
    A = np.array(f["A"](q, qd, pa), dtype=float)
    Adqd = np.array(f["Adqd"](q, qd, pa), dtype=float).ravel()
    K = np.zeros((7, 7))
    K[:5, :5] = Mq
    K[:5, 5:] = -A.T
    K[5:, :5] = A
    rhs = np.concatenate([-h, -Adqd])
    sol = np.linalg.solve(K, rhs)
    return sol[:5], sol[5:]


def rhs(state, params):
    q, qd = _q_qd(state, params)
    qdd, _ = accelerations(state, params)
    return np.array([qd[0], qd[1], qd[2], qd[3], qd[4], qdd[2], qdd[3], qdd[4]])


def energy(state, params):
    q, qd = _q_qd(state, params)
    return float(_numeric()["E"](q, qd, tuple(float(v) for v in params)))
