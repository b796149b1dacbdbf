"""Small measurements on simulation results: circle fits and energy drift."""
from __future__ import annotations

import numpy as np


def fit_circle(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Least-squares circle (centre x, centre y, radius) through the points.

    Solves x^2 + y^2 = 2 a x + 2 b y + c (Kasa's algebraic fit), fine for arcs of
    a quarter turn or more.
    """
    A = np.c_[2 * x, 2 * y, np.ones_like(x)]
    a, b, c = np.linalg.lstsq(A, x**2 + y**2, rcond=None)[0]
    return float(a), float(b), float(np.sqrt(c + a * a + b * b))


def relative_energy_drift(energy: np.ndarray) -> float:
    """max |E(t) - E(0)| / |E(0)|."""
    return float(np.max(np.abs(energy - energy[0])) / abs(energy[0]))
