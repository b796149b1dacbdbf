"""GIF and MP4 of a run: matplotlib's 3D axes and its animation writers.

GIF through gif.GifStream (each frame written as it is drawn, with the delays that make it play in
real time), MP4 (H.264, yuv420p) through matplotlib's FFMpegWriter with the ffmpeg binary that
imageio-ffmpeg ships, so nothing has to be installed system-wide. The view follows the
wheel (a box of 2 * VIEW_HALF_WIDTH R around its centre, ground grid fixed to the world so motion
shows); an inset draws the whole contact track from above.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from matplotlib import rc_context
from matplotlib.animation import FFMpegWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

from gyrowheel.animation.geometry import circle_points
from gyrowheel.animation.gif import GifStream
from gyrowheel.animation.table import AnimationError
from gyrowheel.animation.timeline import Timeline

DPI = 100
VIEW_HALF_WIDTH = 2.5  # in wheel radii
RIM_COLOURS = ("#d62728", "#ffbf00", "#1f77b4", "#2ca02c")  # four rim quadrants: spin is visible
FLYWHEEL_COLOUR = "#8c2d04"
ARC = np.linspace(0.0, np.pi / 2, 16)


class _Scene:
    """The artists of one figure and how to move them to frame k."""

    def __init__(self, tl: Timeline):
        self.tl = tl
        R = tl.parameters.R
        self.h = VIEW_HALF_WIDTH * R
        w, h = tl.options.size
        self.fig = fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI)
        FigureCanvasAgg(fig)
        fig.patch.set_facecolor("white")
        ax = self.ax = fig.add_axes((0.0, 0.0, 1.0, 0.92), projection="3d", computed_zorder=False)
        ax.set_axis_off()
        ax.set_box_aspect((2 * self.h, 2 * self.h, 2.2 * R), zoom=1.3)
        ax.view_init(elev=22, azim=-62)
        ax.set_zlim(0, 2.2 * R)
        floor = [[(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]]
        self.floor = ax.add_collection3d(Poly3DCollection(floor, facecolor="#eef0e6", edgecolor="none", zorder=0), autolim=False)
        self.grid = ax.add_collection3d(Line3DCollection([], colors="#c8ccbc", linewidths=0.6, zorder=1), autolim=False)
        self.trail, = ax.plot([], [], [], color="#555555", lw=1.2, zorder=2)
        self.disc = ax.add_collection3d(Poly3DCollection([], facecolor="#9aa3ad", alpha=0.25, edgecolor="none"), autolim=False)
        self.spokes = ax.add_collection3d(Line3DCollection([], colors="#4d4d4d", linewidths=1.0), autolim=False)
        self.axle, = ax.plot([], [], [], color="black", lw=2.5)
        self.rim = [ax.plot([], [], [], color=c, lw=3.0, solid_capstyle="butt")[0] for c in RIM_COLOURS]
        self.contact, = ax.plot([], [], [], "ko", ms=3)
        self.heading = ax.add_collection3d(Line3DCollection([], colors="#6a3d9a", linewidths=1.6, zorder=3), autolim=False)
        if tl.gyrover:
            self.rod, = ax.plot([], [], [], color="#4d4d4d", lw=1.5)
            self.fly_disc = ax.add_collection3d(Poly3DCollection([], facecolor=FLYWHEEL_COLOUR, alpha=0.55,
                                                                 edgecolor=FLYWHEEL_COLOUR), autolim=False)
            self.fly_axis, = ax.plot([], [], [], color=FLYWHEEL_COLOUR, lw=1.5)
        self.text = fig.text(0.012, 0.965, "", family="monospace", fontsize=max(6.0, min(10.0, w / 80)),
                             va="center")
        self._inset()

    def _inset(self):
        """The whole contact track from above, the wheel's place on it as a dot."""
        tl = self.tl
        inset = self.fig.add_axes((0.74, 0.64, 0.24, 0.26))
        inset.plot(tl.track[:, 0], tl.track[:, 1], color="#999999", lw=0.8)
        inset.set_aspect("equal", adjustable="datalim")
        inset.set_xticks([])
        inset.set_yticks([])
        width = max(np.ptp(tl.track[:, 0]), np.ptp(tl.track[:, 1]))
        inset.set_title(f"track, {width:.3g} m across", fontsize=7, pad=2)
        self.marker, = inset.plot([], [], "o", color=RIM_COLOURS[0], ms=3)

    def update(self, k: int) -> None:
        tl, R, h = self.tl, self.tl.parameters.R, self.h
        p = tl.poses
        c, body = p.centre[k], p.body[k]
        cx, cy = c[0], c[1]
        self.ax.set_xlim(cx - h, cx + h)
        self.ax.set_ylim(cy - h, cy + h)
        self.floor.set_verts([[(cx - h, cy - h, 0), (cx + h, cy - h, 0), (cx + h, cy + h, 0), (cx - h, cy + h, 0)]])
        self.grid.set_segments(_grid(cx, cy, h, R / 2))
        # rim quadrants, disc, spokes and axle: the body frame turns with gamma
        for j, line in enumerate(self.rim):
            pts = circle_points(c[None], body[None], R, ARC + j * np.pi / 2)[0]
            line.set_data_3d(pts[:, 0], pts[:, 1], pts[:, 2])
        ring = circle_points(c[None], body[None], R, np.linspace(0, 2 * np.pi, 49))[0]
        self.disc.set_verts([ring])
        ends = circle_points(c[None], body[None], R, np.arange(4) * np.pi / 2)[0]
        self.spokes.set_segments([[c, e] for e in ends])
        axle = np.array([c - 0.35 * R * body[:, 2], c + 0.35 * R * body[:, 2]])
        self.axle.set_data_3d(axle[:, 0], axle[:, 1], axle[:, 2])
        a = p.contact[k]
        self.contact.set_data_3d([a[0]], [a[1]], [a[2]])
        self.heading.set_segments(_arrow(a, p.heading[k], 1.4 * R))
        self.trail.set_data_3d(*_trail(tl, k, cx, cy, h).T)
        if tl.gyrover:
            f, frame = p.fly_centre[k], p.fly_frame[k]
            self.rod.set_data_3d([c[0], f[0]], [c[1], f[1]], [c[2], f[2]])
            self.fly_disc.set_verts([circle_points(f[None], frame[None], tl.fly_radius,
                                                   np.linspace(0, 2 * np.pi, 33))[0]])
            ax_line = np.array([f - 0.5 * R * frame[:, 2], f + 0.5 * R * frame[:, 2]])
            self.fly_axis.set_data_3d(ax_line[:, 0], ax_line[:, 1], ax_line[:, 2])
        self.text.set_text(tl.readout[k] + f"   ×{tl.options.speed:g}")
        self.marker.set_data([a[0]], [a[1]])


def _grid(cx: float, cy: float, h: float, spacing: float) -> list:
    """World-fixed ground lines inside the view box (they scroll as the view follows the wheel)."""
    xs = np.arange(np.ceil((cx - h) / spacing), np.floor((cx + h) / spacing) + 1) * spacing
    ys = np.arange(np.ceil((cy - h) / spacing), np.floor((cy + h) / spacing) + 1) * spacing
    return ([[(x, cy - h, 0), (x, cy + h, 0)] for x in xs] + [[(cx - h, y, 0), (cx + h, y, 0)] for y in ys])


def _arrow(origin: np.ndarray, direction: np.ndarray, length: float) -> list:
    """An arrow on the ground: shaft and two barbs."""
    tip = origin + length * direction
    side = np.array([-direction[1], direction[0], 0.0])
    barb = 0.25 * length
    return [[origin, tip], [tip, tip - barb * direction + 0.5 * barb * side],
            [tip, tip - barb * direction - 0.5 * barb * side]]


def _trail(tl: Timeline, k: int, cx: float, cy: float, h: float) -> np.ndarray:
    """Contact track up to frame k (the last `trail` seconds), points outside the view box as gaps."""
    t = tl.time[k]
    since = -np.inf if tl.options.trail is None else t - tl.options.trail
    keep = (tl.track_time <= t) & (tl.track_time >= since)
    pts = np.vstack([tl.track[keep], tl.poses.contact[k][None]])
    out = (np.abs(pts[:, 0] - cx) > h) | (np.abs(pts[:, 1] - cy) > h)
    pts = pts.copy()
    pts[out] = np.nan
    return pts


def render_video(tl: Timeline, path: str | Path) -> Path:
    """Write the animation as .gif (gif.GifStream, frames streamed) or .mp4 (H.264 by
    imageio-ffmpeg's ffmpeg) to path, as it is: the caller makes it atomic; returns the path.

    A GIF needs the Timeline's delays (build_timeline(..., gif=True)). Raises AnimationError for
    another extension, a GIF timeline without delays or an MP4 of odd width or height (yuv420p).
    """
    path = Path(path)
    fmt = path.suffix.lower()
    if fmt == ".gif":
        if tl.delays_cs is None:
            raise AnimationError(f"{path}: a GIF needs the frames and delays of build_timeline(..., gif=True)")
        _write_gif(tl, path)
        return path
    if fmt != ".mp4":
        raise AnimationError(f"{path}: unknown output format {path.suffix!r}: use .gif, .mp4 or .html")
    w, h = tl.options.size
    if w % 2 or h % 2:
        raise AnimationError(f"MP4 (H.264, yuv420p) needs an even width and height, got {w}x{h}")
    import imageio_ffmpeg
    scene = _Scene(tl)
    with rc_context({"animation.ffmpeg_path": imageio_ffmpeg.get_ffmpeg_exe()}):
        writer = FFMpegWriter(fps=tl.options.fps, codec="h264", bitrate=-1,
                              extra_args=["-pix_fmt", "yuv420p", "-crf", "23", "-preset", "veryfast"])
        # the writer's own loop (FuncAnimation.save would draw every frame twice on Agg)
        with writer.saving(scene.fig, str(path), dpi=DPI):
            for k in range(len(tl.time)):
                scene.update(k)
                writer.grab_frame()
    return path


def _write_gif(tl: Timeline, path: Path) -> None:
    """Draw frame by frame into a GifStream: one frame in memory at a time."""
    scene = _Scene(tl)
    w, h = tl.options.size
    with open(path, "wb") as fp:
        gif = GifStream(fp, (w, h))
        for k, delay in enumerate(tl.delays_cs):
            scene.update(k)
            buf = io.BytesIO()  # the pixels as matplotlib's animation writers grab them
            scene.fig.savefig(buf, format="rgba", dpi=DPI)
            rgba = np.frombuffer(buf.getbuffer(), dtype=np.uint8).reshape(h, w, 4)
            gif.add(rgba[:, :, :3], int(delay))
        gif.close()
