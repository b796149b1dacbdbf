"""Gain schedule: one LQG design (controller/design.py) per steady turn on a grid of heading rate x tilt.

Why: a design about straight upright rolling with the flywheel at tilt 0 does not stay stable
where the Gyrover actually operates. A held tilt t (to hold a yaw momentum, or in a turn) puts
H_f sin(t) of the flywheel's momentum along the pendulum link, so the pendulum's swing couples
into lean and heading; the Kalman filter designed at t = 0 treats the pendulum as decoupled and its
error dynamics go unstable (moon: from |t| ~ 0.15 rad; earth: ~ 0.45 rad; docs/system.md). Every
steady turn (rate r, tilt t) is an equilibrium (controller/operating_point.py), so the classic
remedy applies (Rugh & Shamma, "Research on gain scheduling", Automatica 36, 2000): design at
each grid point, interpolate the gains, operating points and reference equilibria bilinearly in
the scheduling variables (the mission's rate reference and the estimated tilt), and run the
observer on the wheel's own nonlinear equations, which are right at every operating point.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from gyrowheel.controller.design import Design, design
from gyrowheel.model.spec import ModelSpec


@dataclass
class Schedule:
    """Designs on the grid rates x tilts, row-major: designs[i * len(tilts) + j] at (rates[i], tilts[j])."""

    scene: str
    speed: float
    g: float
    rates: list[float]
    tilts: list[float]
    designs: list[Design]

    def at(self, i: int, j: int) -> Design:
        return self.designs[i * len(self.tilts) + j]

    def nearest(self, rate: float = 0.0, tilt: float = 0.0) -> Design:
        """The design at the grid point nearest to (rate, tilt)."""
        i = int(np.argmin(np.abs(np.array(self.rates) - rate)))
        j = int(np.argmin(np.abs(np.array(self.tilts) - tilt)))
        return self.at(i, j)

    @property
    def centre(self) -> Design:
        """The design at straight upright rolling with the flywheel untilted (rate 0, tilt 0)."""
        return self.nearest(0.0, 0.0)

    def table(self, key: str) -> np.ndarray:
        """Design.matrices()[key] of every grid point: shape (len(rates), len(tilts), *shape)."""
        values = [d.matrices()[key] for d in self.designs]
        return np.array(values).reshape(len(self.rates), len(self.tilts), *values[0].shape)

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(asdict(self)) + "\n")
        return path

    @classmethod
    def load(cls, path: str | Path) -> "Schedule":
        data = json.loads(Path(path).read_text())
        data["designs"] = [Design(**d) for d in data["designs"]]
        return cls(**data)


def uniform(limit: float, count: int) -> list[float]:
    """count points from -limit to limit (count odd, so that 0 is one of them)."""
    if count < 3 or count % 2 == 0:
        raise ValueError(f"a schedule axis needs an odd number >= 3 of points, got {count}")
    return [float(v) for v in np.linspace(-limit, limit, count)]


def design_schedule(spec: ModelSpec, speed: float, rates: list[float], tilts: list[float], scene: str = "",
                    **kw) -> Schedule:
    """A Design (controller/design.py, same keyword arguments) at every steady turn of the grid.

    rates [rad/s] and tilts [rad] must be uniform, increasing and contain 0 (the straight,
    untilted point). Raises ValueError on a bad grid, DesignError where a design fails.
    """
    for name, axis in (("rates", rates), ("tilts", tilts)):
        steps = np.diff(axis)
        if len(axis) < 3 or np.any(steps <= 0) or np.ptp(steps) > 1e-9 * max(1.0, steps.max()) or 0.0 not in axis:
            raise ValueError(f"{name} must be >= 3 uniform increasing values containing 0, got {axis}")
    designs = [design(spec, speed, rate=r, tilt=t, scene=scene, **kw) for r in rates for t in tilts]
    return Schedule(scene, float(speed), designs[0].g, [float(r) for r in rates], [float(t) for t in tilts], designs)
