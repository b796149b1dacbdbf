"""Animations of a wheel run: GIF and MP4 (matplotlib) and a standalone interactive HTML page (three.js).

    from gyrowheel.animation import animate
    animate("paper_earth.csv", "paper_earth.gif", fps=12, speed=2)

The poses come from the model's own kinematics (geometry.py); the result table is read by column
name (table.py); timeline.py decides what each frame shows; render.py and html.py draw it.
"""
from __future__ import annotations

from pathlib import Path

from gyrowheel.animation.table import AnimationError, Parameters, read_result, resolve_parameters
from gyrowheel.animation.timeline import Options, Timeline, build_timeline

FORMATS = (".gif", ".mp4", ".html")

__all__ = ["FORMATS", "AnimationError", "Options", "Parameters", "Timeline", "animate", "build_timeline",
           "read_result", "resolve_parameters"]


def animate(result: str | Path, output: str | Path, R: float | None = None, fmu: str | Path | None = None,
            component: str | None = None, **options) -> Timeline:
    """Write the animation of a result CSV to output (.gif, .mp4 or .html, by its extension).

    R (m) or fmu (its start values; or an .ssp: its wheel component's) give the wheel's geometry
    when the CSV does not (see resolve_parameters); component picks the component of a system's
    result (read_result); options are those of Options (fps, speed, size, trail, start, stop).
    The output's directory is created.
    Returns the Timeline drawn. Raises AnimationError for bad input, with a one-line message.
    """
    output = Path(output)
    if output.suffix.lower() not in FORMATS:
        raise AnimationError(f"{output}: unknown output format {output.suffix!r}: use .gif, .mp4 or .html")
    if output.is_dir():
        raise AnimationError(f"{output}: is a directory; give a file name")
    table = read_result(result, component)
    timeline = build_timeline(table, resolve_parameters(table, R=R, fmu=fmu), Options(**options))
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
        if output.suffix.lower() == ".html":
            from gyrowheel.animation.html import write_html
            write_html(timeline, output, title=f"gyrowheel: {Path(result).name}")
        else:
            from gyrowheel.animation.render import render_video
            render_video(timeline, output)
    except OSError as exc:
        raise AnimationError(f"{exc.filename or output}: cannot write: {exc.strerror or exc}") from None
    return timeline
