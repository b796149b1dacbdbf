"""Independent Newton-Euler reference model of the rolling wheel (Nandy & Xu).

Method (deliberately *not* Lagrange, so it cross-checks the project's model):

* Body unit vectors l, m, n of eqs. (9)-(11), angular velocity of the wheel eq. (12)
  ``omega = -alpha_dot sin(beta) l + beta_dot m + (gamma_dot + alpha_dot cos(beta)) n``.
  The (l, m, n) triad is *not* fixed in the wheel: it turns with
  ``omega_frame = alpha_dot k + beta_dot m`` (the wheel has the extra spin
  ``gamma_dot n``).  This is verified symbolically in :func:`derive`.
* Contact point C = A + R l; rolling without slip v_C = 0 gives
  ``v_A = omega x (-R l)``; ``a_A`` is its total time derivative (chain rule through the
  angles and their rates).
* Newton:  ``M a_A = F - M g k``  (F: contact force on the wheel, unknown).
* Euler about the centre of mass A:  ``dH_A/dt = (C - A) x F = R l x F`` with
  ``H_A = I_diam (w_l l + w_m m) + I_axial w_n n``; because l, m, n rotate with
  ``omega_frame``: ``dH_A/dt = (dH_l/dt) l + (dH_m/dt) m + (dH_n/dt) n + omega_frame x H_A``.
* F is eliminated by substituting Newton into Euler; the three components of the
  Euler equation (projected on l, m, n) are linear in (alpha_ddot, beta_ddot,
  gamma_ddot) and are solved symbolically.

Conventions: state ``(x, y, alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot)``,
params ``(M, R, k_diam, k_axial, g)``, I_diam = k_diam M R^2 (about l and m),
I_axial = k_axial M R^2 (about n), z = R sin(beta), gravity along -z.

Public API (all numeric functions accept plain sequences / numpy arrays):

* ``rhs(state, params) -> ndarray (8,)``
* ``accelerations(state, params) -> ndarray (3,)``   (alpha_ddot, beta_ddot, gamma_ddot)
* ``contact_force(state, params) -> ndarray (3,)``   (Fx, Fy, Fz) on the wheel, ground frame
* ``energy(state, params) -> float``                 T + M g R sin(beta)
* ``steady_precession_rate(beta, rho, params) -> float``  alpha_dot > 0 of steady precession
* ``steady_precession_spin(beta, rho, alpha_dot, params) -> float``  the matching gamma_dot
* ``steady_precession_state(beta, rho, params, alpha0=0.0) -> ndarray (8,)``
* ``critical_spin(params) -> float``                 w_c of straight upright rolling
* ``centre_velocity(state, params) -> ndarray (3,)`` (x_dot, y_dot, z_dot) from the constraint
* ``simulate(state0, params, t_end, t_eval=None, rtol=1e-11, atol=1e-12, **kw)``
  -> ``scipy.integrate.solve_ivp`` result (DOP853)
* ``derive()`` -> dict of the symbolic results (cached); ``symbols()`` -> the sympy symbols.

Results of the derivation (asserted symbolically in :func:`derive`):

* steady precession on a circle of radius rho of the wheel centre
  (beta_dot = beta_ddot = alpha_ddot = gamma_ddot = 0)::

      gamma_dot   = -(rho/R + cos(beta)) alpha_dot
      alpha_dot^2 = M g R^2 cot(beta) / ((I_axial + M R^2) rho + I_diam R cos(beta))

  (for I_diam = M R^2/4, I_axial = 2 M R^2/5 this is the paper's eq. (52),
  20 g cot(beta) / (5 R cos(beta) + 28 rho)).
* straight upright rolling (beta = pi/2, alpha_dot = beta_dot = 0, gamma_dot = w) is
  (neutrally) stable iff w^2 > w_c^2 with::

      w_c^2 = M g R I_diam / (I_axial (I_axial + M R^2))
"""

from __future__ import annotations

import functools
import math

import numpy as np
import sympy as sp

__all__ = [
    "STATE_NAMES",
    "PARAM_NAMES",
    "PAPER_PARAMS",
    "symbols",
    "derive",
    "rhs",
    "accelerations",
    "contact_force",
    "energy",
    "centre_velocity",
    "steady_precession_rate",
    "steady_precession_spin",
    "steady_precession_state",
    "critical_spin",
    "simulate",
]

STATE_NAMES = ("x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot")
PARAM_NAMES = ("M", "R", "k_diam", "k_axial", "g")
#: the paper's simulation parameters (M = 2 kg, R = 0.17 m, I_diam = MR^2/4, I_axial = 2MR^2/5)
PAPER_PARAMS = (2.0, 0.17, 0.25, 0.4, 9.81)


@functools.lru_cache(maxsize=None)
def symbols():
    """The sympy symbols: dict with q, qd, qdd (angles only), params."""
    x, y = sp.symbols("x y", real=True)
    al, be, ga = sp.symbols("alpha beta gamma", real=True)
    ad, bd, gd = sp.symbols("alpha_dot beta_dot gamma_dot", real=True)
    add, bdd, gdd = sp.symbols("alpha_ddot beta_ddot gamma_ddot", real=True)
    M, R, kd, ka, g = sp.symbols("M R k_diam k_axial g", positive=True)
    return dict(
        x=x, y=y, alpha=al, beta=be, gamma=ga,
        alpha_dot=ad, beta_dot=bd, gamma_dot=gd,
        alpha_ddot=add, beta_ddot=bdd, gamma_ddot=gdd,
        M=M, R=R, k_diam=kd, k_axial=ka, g=g,
        state=(x, y, al, be, ga, ad, bd, gd),
        params=(M, R, kd, ka, g),
        angles=(al, be, ga), rates=(ad, bd, gd), accels=(add, bdd, gdd),
    )


def _ddt(expr, s):
    """Total time derivative of an expression in (angles, rates)."""
    out = 0
    for q, qd in zip(s["angles"], s["rates"]):
        out += sp.diff(expr, q) * qd
    for qd, qdd in zip(s["rates"], s["accels"]):
        out += sp.diff(expr, qd) * qdd
    return out


def _ddt_vec(v, s):
    return v.applyfunc(lambda e: _ddt(e, s))


def _is_zero(expr):
    return sp.simplify(sp.expand_trig(sp.expand(expr))) == 0


@functools.lru_cache(maxsize=None)
def derive():
    """Newton-Euler derivation; returns a dict of sympy expressions (cached).

    Keys: l, m, n, k, omega, omega_frame, v_A, a_A, F (contact force, in terms of the
    accelerations), H, dHdt, eqs (3 Euler equations with F eliminated, projected on
    l, m, n), accels (solution dict), T, V, E, steady_alpha_dot_sq,
    steady_gamma_dot_factor, critical_spin_sq, linearisation (dict).
    """
    s = symbols()
    al, be = s["alpha"], s["beta"]
    ad, bd, gd = s["rates"]
    add, bdd, gdd = s["accels"]
    M, R, kd, ka, g = s["params"]
    sa, ca, sb, cb = sp.sin(al), sp.cos(al), sp.sin(be), sp.cos(be)

    I_d = kd * M * R**2
    I_a = ka * M * R**2

    # body triad, eqs (9)-(11), and the vertical
    l = sp.Matrix([-sa * cb, ca * cb, -sb])
    m = sp.Matrix([-ca, -sa, 0])
    n = sp.Matrix([-sa * sb, ca * sb, cb])
    k = sp.Matrix([0, 0, 1])
    assert _is_zero((l.cross(m) - n).norm() ** 2), "l, m, n not right-handed"

    # angular velocity of the triad and of the wheel
    w_frame = ad * k + bd * m
    for e in (l, m, n):
        d = _ddt_vec(e, s) - w_frame.cross(e)
        assert all(_is_zero(c) for c in d), "triad does not rotate with alpha_dot k + beta_dot m"
    w_l, w_m, w_n = -ad * sb, bd, gd + ad * cb
    omega = w_l * l + w_m * m + w_n * n
    assert all(_is_zero(c) for c in (omega - (w_frame + gd * n))), "eq. (12) inconsistent"

    # rolling without slip: v_C = v_A + omega x (R l) = 0
    v_A = omega.cross(-R * l)
    v_A = v_A.applyfunc(lambda e: sp.simplify(sp.expand(e)))
    assert _is_zero(v_A[2] - R * bd * cb), "z_dot must be d/dt(R sin beta)"
    a_A = _ddt_vec(v_A, s)

    # Newton: M a_A = F - M g k
    F = M * a_A + M * g * k

    # Euler about the centre of mass, in the rotating (l, m, n) triad
    H_c = (I_d * w_l, I_d * w_m, I_a * w_n)
    H = H_c[0] * l + H_c[1] * m + H_c[2] * n
    dHdt = sum((_ddt(c, s) * e for c, e in zip(H_c, (l, m, n))), sp.zeros(3, 1)) + w_frame.cross(H)
    torque = (R * l).cross(F)
    resid = dHdt - torque
    eqs = [sp.simplify(sp.expand(e.dot(resid))) for e in (l, m, n)]

    # linear in the accelerations: A acc = b
    acc = sp.Matrix([add, bdd, gdd])
    A = sp.Matrix(3, 3, lambda i, j: sp.simplify(sp.diff(eqs[i], acc[j])))
    b = sp.Matrix([-sp.simplify(eqs[i].subs({add: 0, bdd: 0, gdd: 0})) for i in range(3)])
    sol_vec = A.LUsolve(b)
    accels = {a: sp.simplify(sp.together(e)) for a, e in zip((add, bdd, gdd), sol_vec)}

    # energy
    T = sp.Rational(1, 2) * M * (v_A.dot(v_A)) + sp.Rational(1, 2) * (
        I_d * (w_l**2 + w_m**2) + I_a * w_n**2
    )
    T = sp.simplify(T)
    V = M * g * R * sb
    E = T + V

    # ---- steady precession on a circle of radius rho (centre) ----
    rho = sp.Symbol("rho", real=True)
    on_steady = {bd: 0}
    for a in (add, gdd):
        assert sp.simplify(accels[a].subs(on_steady)) == 0, "beta_dot = 0 must give %s = 0" % a
    # centre velocity for beta_dot = 0 is R (gamma_dot + alpha_dot cos beta) (cos a, sin a, 0);
    # the circle x = -rho sin a, y = rho cos a has velocity -rho alpha_dot (cos a, sin a, 0):
    gd_circle = sp.solve(sp.Eq(v_A[0].subs(on_steady), -rho * ad * ca), gd)
    assert len(gd_circle) == 1
    gd_circle = sp.simplify(gd_circle[0])
    assert sp.simplify(v_A[1].subs(on_steady).subs(gd, gd_circle) + rho * ad * sa) == 0
    steady_gamma_dot_factor = sp.simplify(gd_circle / ad)  # = -(rho/R + cos beta)
    assert sp.simplify(steady_gamma_dot_factor + (rho / R + cb)) == 0
    bdd_num = sp.numer(sp.together(accels[bdd].subs(on_steady).subs(gd, gd_circle)))
    X = sp.Symbol("X", positive=True)  # X = alpha_dot^2
    bdd_num_X = sp.expand(bdd_num).subs(ad**2, X)
    assert ad not in bdd_num_X.free_symbols, bdd_num_X
    sols = sp.solve(bdd_num_X, X)
    assert len(sols) == 1, sols
    steady_sq = sp.simplify(sols[0])
    expected = M * g * R**2 * sp.cot(be) / ((I_a + M * R**2) * rho + I_d * R * cb)
    assert sp.simplify(steady_sq - expected) == 0, steady_sq
    # paper's eq. (52) for I_diam = MR^2/4, I_axial = 2MR^2/5
    eq52 = 20 * g * sp.cot(be) / (5 * R * cb + 28 * rho)
    assert sp.simplify(steady_sq.subs({kd: sp.Rational(1, 4), ka: sp.Rational(2, 5)}) - eq52) == 0

    # ---- linearisation about straight upright rolling ----
    w = sp.Symbol("w", real=True)
    eq_pt = {be: sp.pi / 2, ad: 0, bd: 0, gd: w}
    xs = (be, ad, bd, gd)
    f = {be: bd, ad: accels[add], bd: accels[bdd], gd: accels[gdd]}
    for v, fv in f.items():
        assert sp.simplify(fv.subs(eq_pt)) == 0, "upright rolling is not an equilibrium"
    J = sp.Matrix(4, 4, lambda i, j: sp.simplify(sp.diff(f[xs[i]], xs[j]).subs(eq_pt)))
    lam = sp.Symbol("lambda")
    charpoly = sp.factor(sp.expand((J - lam * sp.eye(4)).det()))
    # expected structure: lambda^2 (lambda^2 + c); stable (oscillatory) iff c > 0
    c_coef = sp.simplify(sp.Poly(sp.expand(charpoly), lam).coeff_monomial(lam**2))
    assert sp.simplify(sp.expand(charpoly) - (lam**4 + c_coef * lam**2)) == 0, charpoly
    Wsq = sp.Symbol("Wsq", positive=True)
    wc_sols = sp.solve(sp.expand(c_coef).subs(w**2, Wsq), Wsq)
    assert len(wc_sols) == 1, wc_sols
    critical_sq = sp.simplify(wc_sols[0])
    expected_wc = M * g * R * I_d / (I_a * (I_a + M * R**2))
    assert sp.simplify(critical_sq - expected_wc) == 0, critical_sq
    # c increases with w^2 (c = a (w^2 - w_c^2), a > 0) -> stable above w_c
    slope = sp.simplify(sp.diff(c_coef, w, 2) / 2)
    assert slope.is_positive or sp.simplify(slope).subs({M: 1, R: 1, kd: 1, ka: 1, g: 1}) > 0

    return dict(
        symbols=s, l=l, m=m, n=n, k=k, omega=omega, omega_frame=w_frame,
        v_A=v_A, a_A=a_A, F=F, H=H, dHdt=dHdt, torque=torque, eqs=eqs,
        A=A, b=b, accels=accels, T=T, V=V, E=E,
        rho=rho, steady_alpha_dot_sq=steady_sq, steady_gamma_dot_factor=steady_gamma_dot_factor,
        w=w, critical_spin_sq=critical_sq,
        linearisation=dict(jacobian=J, states=xs, charpoly=charpoly, c=c_coef, lam=lam),
    )


@functools.lru_cache(maxsize=None)
def _numeric():
    d = derive()
    s = d["symbols"]
    st, pa = s["state"], s["params"]
    acc = s["accels"]
    acc_exprs = [d["accels"][a] for a in acc]
    f_acc = sp.lambdify((st, pa), acc_exprs, modules="math", cse=True)
    f_vel = sp.lambdify((st, pa), list(d["v_A"]), modules="math", cse=True)
    f_F = sp.lambdify((st, acc, pa), list(d["F"]), modules="numpy", cse=True)
    f_E = sp.lambdify((st, pa), d["E"], modules="numpy", cse=True)
    rho, be = d["rho"], s["beta"]
    f_steady = sp.lambdify((be, rho, pa), d["steady_alpha_dot_sq"], modules="numpy")
    f_steady_g = sp.lambdify((be, rho, s["alpha_dot"], pa),
                             d["steady_gamma_dot_factor"] * s["alpha_dot"], modules="numpy")
    f_wc = sp.lambdify((pa,), d["critical_spin_sq"], modules="numpy")
    return dict(acc=f_acc, vel=f_vel, F=f_F, E=f_E, steady=f_steady,
                steady_g=f_steady_g, wc=f_wc)


def _tup(v):
    return tuple(float(a) for a in np.asarray(v, dtype=float).ravel())


def rhs(state, params) -> np.ndarray:
    """d state / dt = (x_dot, y_dot, alpha_dot, beta_dot, gamma_dot, alpha_ddot, beta_ddot, gamma_ddot)."""
    f = _numeric()
    st, pa = _tup(state), _tup(params)
    vx, vy, _ = f["vel"](st, pa)
    aa, bb, gg = f["acc"](st, pa)
    return np.array([vx, vy, st[5], st[6], st[7], aa, bb, gg])


def accelerations(state, params) -> np.ndarray:
    """(alpha_ddot, beta_ddot, gamma_ddot)."""
    f = _numeric()
    return np.array(f["acc"](_tup(state), _tup(params)))


def centre_velocity(state, params) -> np.ndarray:
    """(x_dot, y_dot, z_dot) of the wheel centre from the rolling constraint."""
    f = _numeric()
    return np.array(f["vel"](_tup(state), _tup(params)))


def contact_force(state, params) -> np.ndarray:
    """Contact force on the wheel (Fx, Fy, Fz) in the ground frame: F = M (a_A + g k)."""
    f = _numeric()
    st, pa = _tup(state), _tup(params)
    acc = tuple(f["acc"](st, pa))
    return np.array(f["F"](st, acc, pa), dtype=float)


def energy(state, params):
    """Total mechanical energy T + M g R sin(beta); T includes M/2 (x_dot^2+y_dot^2+z_dot^2).

    ``state`` may be (8,) or (8, N) (then an array of N energies is returned)."""
    f = _numeric()
    st = np.asarray(state, dtype=float)
    return f["E"](tuple(st), _tup(params))


def steady_precession_rate(beta, rho, params) -> float:
    """alpha_dot (> 0 root) of steady precession with lean beta, wheel centre on a circle of radius rho.

    alpha_dot^2 = M g R^2 cot(beta) / ((I_axial + M R^2) rho + I_diam R cos(beta)).
    The circle is x = -rho sin(alpha), y = rho cos(alpha): for beta < pi/2 use rho > 0; a wheel
    leaning the other way (beta > pi/2) precesses about a circle with rho < 0.
    Returns nan when the right-hand side is negative (no such steady motion)."""
    sq = float(_numeric()["steady"](float(beta), float(rho), _tup(params)))
    return math.sqrt(sq) if sq >= 0 else float("nan")


def steady_precession_spin(beta, rho, alpha_dot, params) -> float:
    """gamma_dot = -(rho/R + cos(beta)) alpha_dot (the corrected eq. 49)."""
    return float(_numeric()["steady_g"](float(beta), float(rho), float(alpha_dot), _tup(params)))


def steady_precession_state(beta, rho, params, alpha0=0.0) -> np.ndarray:
    """Full state of steady precession, centre on the circle x = -rho sin(alpha), y = rho cos(alpha)."""
    ad = steady_precession_rate(beta, rho, params)
    gd = steady_precession_spin(beta, rho, ad, params)
    return np.array([-rho * math.sin(alpha0), rho * math.cos(alpha0), alpha0, beta, 0.0, ad, 0.0, gd])


def critical_spin(params) -> float:
    """w_c = sqrt(M g R I_diam / (I_axial (I_axial + M R^2))) for straight upright rolling."""
    return math.sqrt(float(_numeric()["wc"](_tup(params))))


def simulate(state0, params, t_end, t_eval=None, rtol=1e-11, atol=1e-12, **kwargs):
    """Integrate :func:`rhs` with scipy's DOP853 from t = 0 to t_end; returns the solve_ivp result."""
    from scipy.integrate import solve_ivp

    f = _numeric()
    pa = _tup(params)
    f_acc, f_vel = f["acc"], f["vel"]

    def fun(t, y):
        st = tuple(y)
        vx, vy, _ = f_vel(st, pa)
        aa, bb, gg = f_acc(st, pa)
        return [vx, vy, y[5], y[6], y[7], aa, bb, gg]

    return solve_ivp(fun, (0.0, float(t_end)), np.asarray(state0, dtype=float), method="DOP853",
                     rtol=rtol, atol=atol, t_eval=t_eval, **kwargs)
