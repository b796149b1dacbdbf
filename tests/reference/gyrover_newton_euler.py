"""Independent Newton-Euler reference of the wheel with the Gyrover's actuation (for tests only).

The project derives the Gyrover (model/effects/gyrover.py) from one Lagrangian in CasADi, with
angular velocities by the addition theorem. This reference shares none of that:

* Orientation by explicit rotation matrices (sympy): the wheel R_w = [l m n] Rz(gamma) with
  l, m, n of the paper's eqs. (9)-(11); the assembly R_p = [l m n] Rz(theta_p) (it swings about the
  axle n); the flywheel R_f = R_p Ry(tilt) Rz(phi): Xu & Ou's tilt (Control of Single Wheel
  Robots, Table 2.1: beta_a, "the tilt angle between the link l1 and the z_a-axis of the
  flywheel") turns the spin axis about m_p, the assembly axis normal to the link l_p and to the
  axle, so a = R_f e_z = cos(tilt) n + sin(tilt) l_p; then the spin phi about a.
  Angular velocities from skew(w) = R_dot R^T.
* Rolling without slip v_A = w_w x (-R l); the flywheel's centre r_f = A + L_pend l_p carries the
  assembly's point mass m_fly.
* Momentum balances, with the contact force F eliminated by Newton's law for both bodies
  F = M a_A + m_fly a_f - (M + m_fly) g_vec:
    - whole system about the wheel centre A (3 equations):
      dH_w/dt + dH_f/dt + (r_f - A) x m_fly a_f = (C - A) x F + (r_f - A) x m_fly g_vec;
    - assembly + flywheel about the axle through A (1 equation; the bearing passes a force
      through A and moments normal to n, the drive motor drive_torque n):
      n . [dH_f/dt + (r_f - A) x m_fly (a_f - g_vec)] = drive_torque.
  Four equations, linear in (alpha_ddot, beta_ddot, gamma_ddot, theta_p_ddot), solved
  numerically; tilt and phi are prescribed (servo law, constant flywheel_rate).
* Motor torques on the flywheel about its centre (the gimbal is massless; the tilt bearing
  passes moments normal to m_p, the spin bearing moments normal to a):
  tilt_torque = m_p . dH_f/dt, flywheel_torque = a . dH_f/dt.

H_w = I_diam w_w + (I_axial - I_diam)(w_w . n) n, H_f likewise with (I_fly_diam, I_fly_axial, a).
API: ``evaluate(state, inputs, params) -> dict`` (accelerations, tilt_torque, flywheel_torque).
"""
from __future__ import annotations

import functools

import numpy as np
import sympy as sp

COORDS = ("alpha", "beta", "gamma", "theta_p", "tilt", "phi")
PARAMS = ("M", "R", "k_diam", "k_axial", "g", "m_fly", "L_pend", "I_fly_axial", "I_fly_diam")


def _rz(a):
    c, s = sp.cos(a), sp.sin(a)
    return sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _ry(a):
    c, s = sp.cos(a), sp.sin(a)
    return sp.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _vee(W):
    return sp.Matrix([W[2, 1], W[0, 2], W[1, 0]])


@functools.lru_cache(maxsize=None)
def _derive():
    q = sp.symbols(" ".join(COORDS), real=True)
    qd = sp.symbols(" ".join(c + "_dot" for c in COORDS), real=True)
    qdd = sp.symbols(" ".join(c + "_ddot" for c in COORDS), real=True)
    M, R, kd, ka, g, mf, L, Ifa, Ifd = sp.symbols(" ".join(PARAMS), real=True)
    drive = sp.Symbol("drive_torque", real=True)
    al, be, ga, th, ti, ph = q

    def ddt(e):
        return sum((sp.diff(e, a) * b for a, b in zip(q + qd, qd + qdd)), sp.Integer(0))

    def ddt_vec(v):
        return v.applyfunc(ddt)

    sa, ca, sb, cb = sp.sin(al), sp.cos(al), sp.sin(be), sp.cos(be)
    l = sp.Matrix([-sa * cb, ca * cb, -sb])  # eqs. (9)-(11)
    m = sp.Matrix([-ca, -sa, 0])
    n = sp.Matrix([-sa * sb, ca * sb, cb])
    frame = sp.Matrix.hstack(l, m, n)
    R_w = frame * _rz(ga)
    R_p = frame * _rz(th)
    R_f = R_p * _ry(ti) * _rz(ph)
    l_p, m_p = R_p[:, 0], R_p[:, 1]
    a = R_f[:, 2]
    w_w = _vee(ddt_vec(R_w) * R_w.T)
    w_f = _vee(ddt_vec(R_f) * R_f.T)

    I_d, I_a = kd * M * R**2, ka * M * R**2
    H_w = I_d * w_w + (I_a - I_d) * w_w.dot(n) * n
    H_f = Ifd * w_f + (Ifa - Ifd) * w_f.dot(a) * a
    dH_w, dH_f = ddt_vec(H_w), ddt_vec(H_f)

    v_A = w_w.cross(-R * l)
    a_A = ddt_vec(v_A)
    arm = L * l_p  # r_f - A
    a_f = a_A + ddt_vec(ddt_vec(arm))
    g_vec = sp.Matrix([0, 0, -g])
    F = M * a_A + mf * a_f - (M + mf) * g_vec
    system = dH_w + dH_f + arm.cross(mf * a_f) - (R * l).cross(F) - arm.cross(mf * g_vec)
    assembly = n.dot(dH_f + arm.cross(mf * (a_f - g_vec))) - drive
    resid = sp.Matrix([system[0], system[1], system[2], assembly])
    outs = sp.Matrix([m_p.dot(dH_f), a.dot(dH_f)])
    args = (q, qd, qdd, (M, R, kd, ka, g, mf, L, Ifa, Ifd), drive)
    return dict(resid=sp.lambdify(args, resid, "numpy", cse=True), outs=sp.lambdify(args, outs, "numpy", cse=True),
                v_A=sp.lambdify(args, v_A, "numpy", cse=True))


def evaluate(state: dict, inputs: dict, params: dict) -> dict:
    """Accelerations and motor torques at one state.

    state: alpha, beta, gamma, theta_p, tilt [rad], alpha_dot, beta_dot, gamma_dot, theta_p_dot,
    tilt_rate [rad/s]; inputs: tilt_cmd [rad], drive_torque [N m]; params: PARAMS plus
    flywheel_rate [rad/s], tilt_omega [rad/s], tilt_zeta [1]. Returns alpha_ddot, beta_ddot,
    gamma_ddot, theta_p_ddot, tilt_ddot [rad/s2], tilt_torque, flywheel_torque [N m], vx, vy [m/s].
    """
    f = _derive()
    w, z = params["tilt_omega"], params["tilt_zeta"]
    tilt_ddot = w**2 * (inputs["tilt_cmd"] - state["tilt"]) - 2 * z * w * state["tilt_rate"]
    q = tuple(float(state[c]) for c in COORDS[:5]) + (0.0,)
    qd = tuple(float(state[c + "_dot"]) for c in COORDS[:4]) + (float(state["tilt_rate"]), float(params["flywheel_rate"]))
    par, drive = tuple(float(params[p]) for p in PARAMS), float(inputs["drive_torque"])

    def resid(acc):
        return np.array(f["resid"](q, qd, tuple(acc) + (tilt_ddot, 0.0), par, drive), dtype=float).ravel()

    # the residual is affine in the four unknown accelerations: its columns give the matrix exactly
    b = resid(np.zeros(4))
    J = np.column_stack([resid(e) - b for e in np.eye(4)])
    acc = np.linalg.solve(J, -b)
    qdd = tuple(acc) + (tilt_ddot, 0.0)
    tilt_torque, flywheel_torque = np.array(f["outs"](q, qd, qdd, par, drive), dtype=float).ravel()
    vx, vy, _ = np.array(f["v_A"](q, qd, qdd, par, drive), dtype=float).ravel()
    return dict(alpha_ddot=acc[0], beta_ddot=acc[1], gamma_ddot=acc[2], theta_p_ddot=acc[3], tilt_ddot=tilt_ddot,
                tilt_torque=tilt_torque, flywheel_torque=flywheel_torque, vx=vx, vy=vy)
