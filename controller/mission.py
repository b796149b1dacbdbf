"""Missions: turn-rate and speed references, piecewise linear in time; the heading is their integral.

A mission is a list of points (t [s], heading rate [rad/s], speed [m/s]); between points the
references are linear, before the first and after the last they hold. The heading reference is
the integral of the heading rate from 0 at t = 0 (piecewise quadratic, so turns begin and end
with a continuous rate). A rolling wheel at speed v turning at rate r follows a circle of radius
v / r: a figure eight is a full circle one way, then one the other. The controller FMU carries
the points as parameters (mission_t_k, mission_rate_k, mission_speed_k), so a system file can
change the mission without rebuilding.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np


@dataclass
class Mission:
    name: str
    points: list[tuple[float, float, float]]  # (t, heading rate, speed)

    def __post_init__(self):
        ts = [p[0] for p in self.points]
        if len(ts) < 2 or any(b <= a for a, b in zip(ts, ts[1:])):
            raise ValueError(f"mission {self.name!r}: needs >= 2 points with strictly increasing times")

    @property
    def duration(self) -> float:
        return float(self.points[-1][0])

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(heading [rad], heading rate [rad/s], speed [m/s]) references at times t (numpy)."""
        ts, rs, vs = (np.array(c, dtype=float) for c in zip(*self.points))
        t = np.asarray(t, dtype=float)
        heading = np.zeros_like(t)
        for k in range(len(ts) - 1):
            heading = heading + _segment_integral(np.clip(t - ts[k], 0.0, ts[k + 1] - ts[k]), ts[k + 1] - ts[k],
                                                  rs[k], rs[k + 1])
        heading = heading + rs[-1] * np.maximum(t - ts[-1], 0.0) + rs[0] * np.minimum(t - ts[0], 0.0)
        return heading, np.interp(t, ts, rs), np.interp(t, ts, vs)


def _segment_integral(d, length, r0, r1):
    """Integral over [0, d] of the rate going linearly from r0 to r1 over `length`."""
    return r0 * d + (r1 - r0) * d * d / (2.0 * length)


def interpolate(t: ca.SX, ts: list[ca.SX], vs: list[ca.SX]) -> ca.SX:
    """Piecewise-linear interpolation in CasADi, holding the end values (ts increasing)."""
    value = vs[0]
    for k in range(len(ts) - 1):
        frac = ca.fmin(ca.fmax((t - ts[k]) / (ts[k + 1] - ts[k]), 0.0), 1.0)
        value = value + frac * (vs[k + 1] - vs[k])
    return value


def integrate(t: ca.SX, ts: list[ca.SX], rs: list[ca.SX]) -> ca.SX:
    """Integral from 0 to t of the piecewise-linear interpolation of (ts, rs) (CasADi; ts[0] = 0)."""
    total = rs[0] * ca.fmin(t - ts[0], 0.0) + rs[-1] * ca.fmax(t - ts[-1], 0.0)
    for k in range(len(ts) - 1):
        length = ts[k + 1] - ts[k]
        total = total + _segment_integral(ca.fmin(ca.fmax(t - ts[k], 0.0), length), length, rs[k], rs[k + 1])
    return total


def _turn(points: list, t: float, rate: float, angle: float, speed: float, ramp: float) -> float:
    """Append a turn by `angle` [rad] at |rate|, rate ramped in and out over `ramp` s; returns its end."""
    hold = abs(angle / rate) - ramp
    if hold < 0:
        raise ValueError(f"turn of {angle:g} rad too short for a {ramp:g} s ramp at {rate:g} rad/s")
    points += [(t + ramp, rate, speed), (t + ramp + hold, rate, speed), (t + 2 * ramp + hold, 0.0, speed)]
    return t + 2 * ramp + hold


def standard(speed: float = 1.5, radius: float = 3.0, settle: float = 4.0, straight: float = 2.0,
             ramp: float = 0.5, end: float | None = None) -> Mission:
    """The closed-loop mission of docs/system.md at constant speed: settle; a 90 deg turn to the
    left on a circle of `radius` [m]; straight; a figure eight of that radius (a full circle to
    the left, then one to the right, the rate reversed over 2 ramp s); straight to `end` (default:
    at least 60 s, at least `straight` after the eight). Turn rates speed / radius [rad/s]."""
    r = speed / radius
    pts = [(0.0, 0.0, speed), (settle, 0.0, speed)]
    t = _turn(pts, settle, r, math.pi / 2, speed, ramp) + straight
    pts.append((t, 0.0, speed))
    hold = 2 * math.pi / r - ramp  # each loop turns r (ramp / 2 + hold + ramp / 2) = 2 pi
    pts += [(t + ramp, r, speed), (t + ramp + hold, r, speed), (t + 3 * ramp + hold, -r, speed),
            (t + 3 * ramp + 2 * hold, -r, speed), (t + 4 * ramp + 2 * hold, 0.0, speed)]
    t = t + 4 * ramp + 2 * hold
    stop = float(max(60, math.ceil(t + straight))) if end is None else end
    if stop <= t:
        raise ValueError(f"mission end {stop:g} s is before the figure eight ends ({t:.1f} s)")
    pts.append((stop, 0.0, speed))
    return Mission(f"turn_and_eight_r{radius:g}", pts)


def straight(speed: float = 1.5, duration: float = 60.0) -> Mission:
    """Straight rolling at constant heading and speed."""
    return Mission("straight", [(0.0, 0.0, speed), (duration, 0.0, speed)])


# The course per world (docs/system.md): circles as tight as the world allows with the tilt
# inside its stop. A turn of rate r needs the lean of r (M v h + H) / (M g h) roughly (h the
# height of the centre of mass, H the spin momenta), six times more on the moon than on earth.
COURSES = {"earth": {"radius": 3.0, "ramp": 1.0}, "moon": {"radius": 10.0, "ramp": 3.0}}


def course(world: str, speed: float = 1.5) -> Mission:
    """The standard mission on the world's course (COURSES)."""
    if world not in COURSES:
        raise ValueError(f"no course for {world!r}; worlds: {', '.join(COURSES)}")
    return standard(speed, **COURSES[world])
