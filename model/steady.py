"""Closed forms of the unactuated wheel's steady motions: the one home of these formulas.

Source: Nandy & Xu, "Dynamic Model of a Gyroscopic Wheel", section 3, with the corrections of
docs/errata.md (items 23, 25, 26), generalised from the paper's inertia (I_diam = M R^2 / 4,
I_axial = 2 M R^2 / 5, its eq. 24) to I_diam = k_diam M R^2, I_axial = k_axial M R^2.

Steady precession: the centre runs on a circle of radius rho at constant lean beta (pi/2:
upright),
    gamma_dot = -(rho/R + cos beta) alpha_dot                                      (49, corrected)
    alpha_dot^2 = M g R^2 cot beta / ((I_axial + M R^2) rho + I_diam R cos beta)   (52, any inertia)
    v = rho |alpha_dot|                                                            (53)
(for the paper's inertia (52) reads 20 g cot beta / (5 R cos beta + 28 rho), as printed).
Straight upright rolling at spin w = gamma_dot is the limit beta = pi/2; its lean-heading modes
solve lambda^2 I_diam (I_diam + M R^2) = M g R I_diam - w^2 I_axial (I_axial + M R^2), so it is
stable iff
    w^2 > w_c^2 = M g R I_diam / (I_axial (I_axial + M R^2))
(paper wheel: w_c^2 = 25 g / (56 R)).

Units: M [kg], R [m], k_diam, k_axial [1], g [m/s^2], beta [rad], rho [m], rates [rad/s],
speeds [m/s]. The tests check these against what this module does not produce: simulations of
the model (tests/test_model_physics.py, test_hard_equilibria.py), the paper's printed (52) and
(53) (test_sweep_steady.py), the eigenvalues of the model's own Jacobian (test_sweep_steady.py,
test_linearise.py); the formulas themselves are derived independently in sympy (test_errata.py,
test_reference_selfcheck.py).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["inertias", "precession_rates", "precession_speed", "critical_spin", "wheel_mode_eigenvalues"]


def _positive(**values: float) -> None:
    for name, v in values.items():
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be finite and > 0, got {v!r}")


def _gravity(g: float) -> None:
    if not (math.isfinite(g) and g >= 0):
        raise ValueError(f"g must be finite and >= 0, got {g!r}")


def inertias(M: float, R: float, k_diam: float, k_axial: float) -> tuple[float, float]:
    """(I_diam, I_axial) [kg m^2] = (k_diam M R^2, k_axial M R^2) of a wheel of mass M [kg] and
    rolling radius R [m]: the diametral and the axial moment of inertia about the centre of mass
    (the paper's eq. 24 has k_diam = 1/4, k_axial = 2/5).

    Raises ValueError naming the field unless M, R, k_diam, k_axial are finite and > 0.
    """
    _positive(M=M, R=R, k_diam=k_diam, k_axial=k_axial)
    return k_diam * M * R**2, k_axial * M * R**2


def precession_rates(beta: float, rho: float, M: float, R: float, k_diam: float, k_axial: float, g: float,
                     sign: float = -1.0) -> tuple[float, float]:
    """(alpha_dot, gamma_dot) [rad/s] of steady precession at lean beta [rad] with the centre on a
    circle of radius rho [m] (rho = 0: the centre at rest, Euler's disk).

    Eq. (52) for any inertia and eq. (49) corrected (module docstring, docs/errata.md items 23,
    25). sign (+-1) picks the direction of travel: -1 rolls forward (gamma_dot > 0) for
    0 < beta < pi/2. Wheel parameters as inertias(); g [m/s^2].
    Raises ValueError when no real rate exists (e.g. beta past upright, g = 0), naming beta and
    rho, or for a bad wheel parameter or g (naming it).
    """
    _gravity(g)
    I_d, I_a = inertias(M, R, k_diam, k_axial)
    den = (I_a + M * R**2) * rho + I_d * R * math.cos(beta)
    num = M * g * R**2 / math.tan(beta)
    if not num / den > 0:
        raise ValueError(f"no steady precession at beta = {beta!r} rad, rho = {rho!r} m")
    alpha_dot = sign * math.sqrt(num / den)
    return alpha_dot, -(rho / R + math.cos(beta)) * alpha_dot


def precession_speed(beta, rho, M: float, R: float, k_diam: float, k_axial: float, g: float):
    """Centre speed v [m/s] of steady precession at lean beta [rad] on a circle rho [m]: eq. (53)
    for any inertia, v^2 = rho^2 alpha_dot^2 with alpha_dot^2 of eq. (52).

    beta, rho: numbers or numpy arrays (broadcast); returns a numpy array (a 0-d one for
    numbers), NaN where no steady precession exists (e.g. beta past upright: for plotting a
    curve over a range). Raises ValueError for a bad wheel parameter or g (naming it).
    """
    _gravity(g)
    I_d, I_a = inertias(M, R, k_diam, k_axial)
    beta, rho = np.asarray(beta, float), np.asarray(rho, float)
    return np.sqrt(M * g * R**2 / np.tan(beta) * rho**2 / ((I_a + M * R**2) * rho + I_d * R * np.cos(beta)))


def critical_spin(M: float, R: float, k_diam: float, k_axial: float, g: float) -> float:
    """w_c [rad/s]: straight upright rolling at spin gamma_dot is stable iff gamma_dot^2 > w_c^2,
    w_c^2 = M g R I_diam / (I_axial (I_axial + M R^2)) (module docstring; docs/errata.md, notes).

    Wheel parameters as inertias(); g [m/s^2]. Raises ValueError for a bad one (naming it).
    """
    _gravity(g)
    I_d, I_a = inertias(M, R, k_diam, k_axial)
    return math.sqrt(M * g * R * I_d / (I_a * (I_a + M * R**2)))


def wheel_mode_eigenvalues(M: float, R: float, k_diam: float, k_axial: float, g: float,
                           spin: float) -> complex:
    """The lean-heading eigenvalue lambda [1/s] (the + root) of the unactuated wheel rolling
    straight and upright at spin w = gamma_dot [rad/s]:
        lambda^2 = (M g R I_diam - w^2 I_axial (I_axial + M R^2)) / (I_diam (I_diam + M R^2)).
    Real (one growing mode) below the critical spin, imaginary (a neutral weave) above.

    Wheel parameters as inertias(); g [m/s^2]. Raises ValueError for a bad one or a non-finite
    spin (naming it).
    """
    _gravity(g)
    if not math.isfinite(spin):
        raise ValueError(f"spin must be finite, got {spin!r}")
    I_d, I_a = inertias(M, R, k_diam, k_axial)
    lam2 = (M * g * R * I_d - spin**2 * I_a * (I_a + M * R**2)) / (I_d * (I_d + M * R**2))
    return complex(math.sqrt(lam2)) if lam2 >= 0 else complex(0.0, math.sqrt(-lam2))
