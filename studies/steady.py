"""Linearised stability of the unactuated wheel's steady motions (for the maps of docs/sweeps.md).

The steady motions themselves (steady precession, eqs. 49 corrected, 52, 53; the critical spin of
upright rolling) are closed forms in gyrowheel.model.steady. Here their stability comes from the
model itself: x, y, alpha, gamma are cyclic, so the reduced equations of motion (null-space form)
close on z = (beta, alpha_dot, beta_dot, gamma_dot). A steady motion is an equilibrium z* of
z_dot = f(z); CasADi differentiates the model's own ode (the function that becomes the FMU's C)
to J = df/dz at z*, and the motion is linearly unstable when an eigenvalue of J has a positive
real part. Steady motions come in a two-parameter family, so two eigenvalues are zero; the other
two are +-i w (stable) or +-l (unstable). The linearisation of any ModelSpec with inputs and
outputs is gyrowheel.model.linearise.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from gyrowheel.model.steady import precession_rates

REDUCED = ("beta", "alpha_dot", "beta_dot", "gamma_dot")


@lru_cache(maxsize=1)
def _jacobian_function():
    """CasADi function (z, p) -> df/dz of the model's reduced ode (gravity only, symbolic parameters)."""
    import casadi as ca

    from gyrowheel import model
    spec = model.build_model(effects={"gravity": {}})
    rows = [spec.x_names.index(n) for n in REDUCED]
    J = ca.jacobian(spec.ode[rows], spec.x)[:, rows]
    fn = ca.Function("reduced_jacobian", [spec.x, spec.p], [ca.densify(J)])
    return fn, spec.x_names, [q.name for q in spec.parameters], {q.name: q.start for q in spec.parameters}


def reduced_jacobian(beta: float, alpha_dot: float, gamma_dot: float, **params) -> np.ndarray:
    """4x4 Jacobian of (beta, alpha_dot, beta_dot, gamma_dot)_dot at beta_dot = 0 (params: M, R, k_diam, k_axial, g)."""
    fn, x_names, p_names, defaults = _jacobian_function()
    x = np.zeros(len(x_names))
    x[x_names.index("beta")], x[x_names.index("alpha_dot")], x[x_names.index("gamma_dot")] = beta, alpha_dot, gamma_dot
    unknown = set(params) - set(p_names)
    if unknown:
        raise KeyError(f"unknown parameters {sorted(unknown)}; valid: {p_names}")
    p = np.array([params.get(n, defaults[n]) for n in p_names], dtype=float)
    return np.array(fn(x, p))


def growth_rate(beta: float, alpha_dot: float, gamma_dot: float, **params) -> float:
    """Largest real part [1/s] of the eigenvalues of reduced_jacobian: > 0 means linearly unstable."""
    return float(np.max(np.linalg.eigvals(reduced_jacobian(beta, alpha_dot, gamma_dot, **params)).real))


def upright_boundary(M: float, R: float, k_diam: float, k_axial: float, g: float) -> float:
    """The spin [rad/s] where upright rolling turns stable, found from the eigenvalues alone (bisection).

    Compare gyrowheel.model.steady.critical_spin(): the two must agree (tests/test_sweep_steady.py).
    """
    params = dict(M=M, R=R, k_diam=k_diam, k_axial=k_axial, g=g)
    scale = math.sqrt(g / R)
    lo, hi = 0.0, 10 * scale
    if growth_rate(math.pi / 2, 0.0, hi, **params) > 1e-9 * scale:
        raise ValueError("upright rolling is unstable at every spin up to 10 sqrt(g/R)")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if growth_rate(math.pi / 2, 0.0, mid, **params) > 1e-9 * scale:
            lo = mid
        else:
            hi = mid
    return hi


def precession_growth_rate(beta: float, rho: float, M: float, R: float, k_diam: float, k_axial: float,
                           g: float) -> float:
    """Growth rate [1/s] of disturbances of steady precession at (beta, rho); > 0: unstable."""
    alpha_dot, gamma_dot = precession_rates(beta, rho, M, R, k_diam, k_axial, g)
    return growth_rate(beta, alpha_dot, gamma_dot, M=M, R=R, k_diam=k_diam, k_axial=k_axial, g=g)
