"""Small result tables for the animation tests, written as `gyrowheel simulate` writes them."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

R = 0.17


def rolling_csv(path: Path, stop: float = 2.0, interval: float = 0.01, gyrover: bool = False,
                beta: float = math.radians(80.0), omega: float = 0.8, spin: float = 6.0) -> Path:
    """A wheel at constant lean beta turning at omega (rad/s) and spinning at `spin`, its centre on the
    circle its rolling implies (a picture test: the columns are consistent, the dynamics need not be)."""
    t = np.arange(0.0, stop + interval / 2, interval)
    alpha, gamma = omega * t, spin * t
    radius = R * spin / omega  # centre speed R spin along the heading
    cols = {"time": t, "x": radius * np.sin(alpha), "y": radius * (1 - np.cos(alpha)), "alpha": alpha,
            "beta": np.full_like(t, beta), "gamma": gamma, "alpha_dot": np.full_like(t, omega),
            "beta_dot": 0 * t, "gamma_dot": np.full_like(t, spin), "z": R * np.sin(np.full_like(t, beta)),
            "vx": R * spin * np.cos(alpha), "vy": R * spin * np.sin(alpha)}
    if gyrover:
        cols["theta_p"], cols["tilt"] = 0.2 * np.sin(t), 0.4 * np.sin(2 * t)
    cols["fallen"] = np.zeros_like(t)
    lines = [",".join(f'"{name}"' for name in cols)]  # fmpy.util.write_csv's layout
    lines += [",".join(repr(float(v)) for v in row) for row in zip(*cols.values())]
    path.write_text("\n".join(lines) + "\n")
    return path
