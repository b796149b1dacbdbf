"""From a result table to what each frame shows: frame times, poses, the contact track, readouts.

Frame k shows simulated time start + k * speed / fps (the last frame is the stop time itself, also
when one step of speed / fps is longer than the whole window: then start and stop are all), the
coordinates linearly interpolated between output rows (angles as the FMU writes them: continuous,
not wrapped). The contact track is drawn from the rows themselves, not from the frames, so a fast
playback does not cut corners off the path. A GIF's frames are those times at no more than
gif.MAX_FPS frames a second, less the few the GIF's centisecond clock cannot show (gif.py): it
plays in real time.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from gyrowheel.animation.geometry import Poses, flywheel_radius, wheel_poses
from gyrowheel.animation.gif import MAX_FPS, gif_schedule
from gyrowheel.animation.table import GYROVER, AnimationError, Parameters, ResultTable

MAX_FRAMES = 20_000
TRACK_POINTS_PER_FRAME = 8


@dataclass
class Options:
    """Playback options; times in simulated seconds, size in pixels (width, height)."""

    fps: float = 25.0
    speed: float = 1.0  # simulated seconds per second of playback
    size: tuple[int, int] = (640, 480)
    trail: float | None = None  # seconds of contact track behind the wheel; None: all of it
    start: float | None = None
    stop: float | None = None

    def check(self) -> None:
        """Raises AnimationError naming the option."""
        if not (0 < self.fps <= 120):
            raise AnimationError(f"--fps must be in (0, 120], got {self.fps:g}")
        if not (self.speed > 0 and math.isfinite(self.speed)):
            raise AnimationError(f"--speed must be > 0, got {self.speed:g}")
        w, h = self.size
        if not (64 <= w <= 4096 and 64 <= h <= 4096):
            raise AnimationError(f"--size must be between 64x64 and 4096x4096 pixels, got {w}x{h}")
        if self.trail is not None and not self.trail >= 0:
            raise AnimationError(f"--trail must be >= 0 seconds, got {self.trail:g}")


@dataclass
class Timeline:
    """Everything a renderer draws. Arrays over F frames or over T track points."""

    time: np.ndarray  # (F,) s
    poses: Poses  # at the frame times
    readout: list[str]  # (F,) one line per frame: time, lean, heading (wrapped), speed, tilt
    track_time: np.ndarray  # (T,) s, the rows within [start, stop]
    track: np.ndarray  # (T, 3) contact points (z = 0)
    parameters: Parameters
    fly_radius: float  # drawn flywheel radius, m (0 without a gyrover)
    options: Options
    spin_per_frame: float  # largest |gamma| change between frames, rad (aliasing when > pi / 2)
    delays_cs: np.ndarray | None = None  # (F,) int: a GIF's frame delays, centiseconds; None for MP4, HTML

    @property
    def gyrover(self) -> bool:
        return self.poses.fly_centre is not None


def frame_times(t_first: float, t_last: float, options: Options) -> np.ndarray:
    """start, start + dt, ..., stop with dt = speed / fps; raises AnimationError on a bad window."""
    start = t_first if options.start is None else options.start
    stop = t_last if options.stop is None else options.stop
    for flag, value in (("--start", start), ("--stop", stop)):
        if not (t_first - 1e-9 <= value <= t_last + 1e-9):
            raise AnimationError(f"{flag} {value:g} is outside the run's time {t_first:g} .. {t_last:g} s")
    if stop < start:
        raise AnimationError(f"--stop {stop:g} is before --start {start:g}")
    dt = options.speed / options.fps
    # frame steps to the stop (a last step that is a whole one up to rounding is not split off);
    # a window longer than 0 has at least one, however fast the playback: its stop is shown
    steps = int(math.ceil((stop - start) / dt - 1e-9))
    count = max(steps, 1 if stop > start else 0) + 1
    if count > MAX_FRAMES:
        raise AnimationError(f"{count} frames is more than {MAX_FRAMES}: raise --speed, lower --fps "
                             "or narrow --start/--stop")
    times = np.minimum(start + dt * np.arange(count), stop)
    times[0] = start  # (dt may overflow to inf: 0 * inf is no time)
    return times


def _rows(table: ResultTable) -> tuple[np.ndarray, np.ndarray]:
    """Row times and the row index kept for each (a repeated time keeps its last row: event rows)."""
    t = table.number("time")
    if np.any(np.diff(t) < 0):
        i = int(np.argmax(np.diff(t) < 0))
        raise AnimationError(f"{table.path}: time decreases at row {i + 3} ({t[i]:g} -> {t[i + 1]:g} s)")
    keep = np.append(np.diff(t) > 0, True)
    return t[keep], np.flatnonzero(keep)


def _check_contact(table: ResultTable, rows: np.ndarray, contact: np.ndarray, R: float) -> None:
    """The model's contact-point outputs (energy effect) must be where the drawn rim touches the ground."""
    if "contact_x" not in table or "contact_y" not in table:
        return
    given = np.column_stack([table.number("contact_x")[rows], table.number("contact_y")[rows]])
    error = float(np.max(np.abs(given - contact[:, :2])))
    if error > 1e-4 * R:
        raise AnimationError(f"{table.path}: the drawn contact point misses the CSV's contact_x/contact_y by "
                             f"{error:.3g} m: R = {R:g} m is not this run's radius")


def build_timeline(table: ResultTable, parameters: Parameters, options: Options, gif: bool = False) -> Timeline:
    """Frames and track of a run. Raises AnimationError on inconsistent input.

    gif: the frames of a GIF that plays in real time (gif.gif_schedule): options.fps is then at
    most gif.MAX_FPS (the Timeline's options say the fps written) and delays_cs gives each
    frame's delay."""
    options.check()
    if gif and options.fps > MAX_FPS:
        options = replace(options, fps=MAX_FPS)
    present = [c for c in GYROVER if c in table]
    if len(present) == 1:
        missing = next(c for c in GYROVER if c not in table)
        raise AnimationError(f"{table.path}: has {present[0]!r} but not {missing!r}: a gyrover run needs both")
    gyrover = len(present) == 2
    t_rows, rows = _rows(table)
    times = frame_times(float(t_rows[0]), float(t_rows[-1]), options)
    delays = None
    if gif:
        kept, delays = gif_schedule((times - times[0]) / options.speed, 1.0 / options.fps)
        times = times[kept]
    names = ["x", "y", "alpha", "beta", "gamma"] + (list(GYROVER) if gyrover else [])
    data = {n: table.number(n)[rows] for n in names}
    for n in ("vx", "vy"):
        if n in table:
            data[n] = table.number(n)[rows]

    def at(name, when):
        return np.interp(when, t_rows, data[name]) if len(t_rows) > 1 else np.full(len(when), data[name][0])

    def poses_at(when):
        q = np.column_stack([at(n, when) for n in ("x", "y", "alpha", "beta", "gamma")])
        if not gyrover:
            return wheel_poses(q, parameters.R)
        return wheel_poses(q, parameters.R, at("theta_p", when), at("tilt", when), parameters.L_pend)

    # every row: check against the model's contact output; the track keeps the rows in the window
    row_poses = wheel_poses(np.column_stack([data[n] for n in ("x", "y", "alpha", "beta", "gamma")]),
                            parameters.R)
    _check_contact(table, rows, row_poses.contact, parameters.R)
    inside = (t_rows > times[0]) & (t_rows < times[-1])
    stride = max(1, int(np.ceil(inside.sum() / (TRACK_POINTS_PER_FRAME * len(times)))))
    track_time = np.concatenate([[times[0]], t_rows[inside][::stride], [times[-1]]] if len(times) > 1
                                else [[times[0]]])
    track = poses_at(track_time).contact
    poses = poses_at(times)
    gamma = at("gamma", times)
    spin = float(np.max(np.abs(np.diff(gamma)))) if len(times) > 1 else 0.0
    beta = np.degrees(at("beta", times))
    alpha = 0.0 - ((180.0 - np.degrees(at("alpha", times))) % 360.0 - 180.0)  # heading in (-180, 180]
    speed = np.hypot(at("vx", times), at("vy", times)) if "vx" in data and "vy" in data else None
    tilt = np.degrees(at("tilt", times)) if gyrover else None
    readout = []
    for k, t in enumerate(times):
        line = f"t = {t:7.2f} s   beta = {beta[k]:5.1f}°   alpha = {alpha[k]:6.1f}°"
        if speed is not None:
            line += f"   v = {speed[k]:4.2f} m/s"
        if tilt is not None:
            line += f"   tilt = {tilt[k]:5.1f}°"
        readout.append(line)
    fly = flywheel_radius(parameters.I_fly_axial, parameters.m_fly, parameters.R) if gyrover else 0.0
    return Timeline(time=times, poses=poses, readout=readout, track_time=track_time, track=track,
                    parameters=parameters, fly_radius=fly, options=options, spin_per_frame=spin,
                    delays_cs=delays)
