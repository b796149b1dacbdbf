"""Missions: heading and speed references, piecewise linear in time.

A mission is a list of points (t [s], heading [rad], speed [m/s]); between points the
references are linear, before the first and after the last they hold. The controller FMU
carries the points as parameters (mission_t_k, mission_heading_k, mission_speed_k), so a
system file can change the mission without rebuilding.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np


@dataclass
class Mission:
    name: str
    points: list[tuple[float, float, float]]  # (t, heading, speed)

    def __post_init__(self):
        ts = [p[0] for p in self.points]
        if len(ts) < 2 or any(b <= a for a, b in zip(ts, ts[1:])):
            raise ValueError(f"mission {self.name!r}: needs >= 2 points with strictly increasing times")

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray]:
        """(heading, speed) references at times t (numpy)."""
        ts, hs, vs = (np.array(c, dtype=float) for c in zip(*self.points))
        return np.interp(t, ts, hs), np.interp(t, ts, vs)


def interpolate(t: ca.SX, ts: list[ca.SX], vs: list[ca.SX]) -> ca.SX:
    """Piecewise-linear interpolation in CasADi, holding the end values (ts increasing)."""
    value = vs[0]
    for k in range(len(ts) - 1):
        frac = ca.fmin(ca.fmax((t - ts[k]) / (ts[k + 1] - ts[k]), 0.0), 1.0)
        value = value + frac * (vs[k + 1] - vs[k])
    return value


def standard(speed: float = 1.5, heading_step: float = math.radians(1.0)) -> Mission:
    """The closed-loop mission of docs/system.md: settle, a turn, S-turns, a speed change, 60 s.

    Heading offsets stay inside what the actuation can hold (docs/system.md, controllability:
    about 0.23 rad of heading per rad of held flywheel tilt at 1.5 m/s).
    """
    h = heading_step
    return Mission("standard", [
        (0.0, 0.0, speed), (10.0, 0.0, speed), (14.0, h, speed),          # the turn
        (22.0, h, speed), (26.0, -h, speed), (30.0, h, speed), (34.0, -h, speed), (38.0, 0.0, speed),  # S-turns
        (44.0, 0.0, speed), (52.0, 0.0, speed + 0.2), (60.0, 0.0, speed + 0.2),  # speed change
    ])


def figure_eight(speed: float = 1.5, radius: float = 3.0, start: float = 10.0) -> Mission:
    """A figure eight of the given radius: heading +2 pi then back to 0 at the rate speed / radius.

    Not flyable with the Gyrover's actuation (docs/system.md): kept to show where it fails.
    """
    T = 2 * math.pi * radius / speed
    return Mission("figure_eight", [(0.0, 0.0, speed), (start, 0.0, speed), (start + T, 2 * math.pi, speed),
                                    (start + 2 * T, 0.0, speed), (start + 2 * T + 1.0, 0.0, speed)])
