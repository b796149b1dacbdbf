"""Animations of a wheel run: GIF and MP4 (matplotlib) and a standalone interactive HTML page (three.js).

    from gyrowheel.animation import animate
    animate("paper_earth.csv", "paper_earth.gif", fps=12, speed=2)

(gyrowheel.animate is the public face of animate(): the same, its errors worded in its
argument names; the animation's own modules word them in the command line's flags.)

The poses come from the model's own kinematics (geometry.py); the result table is read by column
name (table.py); timeline.py decides what each frame shows; render.py and html.py draw it.
"""
from __future__ import annotations

import os
from pathlib import Path

from gyrowheel.animation.table import (AnimationError, Parameters, ResultTable, _component_columns, read_result,
                                       resolve_parameters)
from gyrowheel.animation.timeline import Options, Timeline, build_timeline
from gyrowheel.output_files import check_output_file, replaced_atomically

FORMATS = (".gif", ".mp4", ".html")
DATA_NAME = "result"  # how errors name a result given as data (there is no file)

__all__ = ["FORMATS", "AnimationError", "Options", "Parameters", "Timeline", "animate", "build_timeline",
           "read_result", "resolve_parameters", "result_table"]


def result_table(result, component: str | None = None) -> ResultTable:
    """A run as the animation reads it: a result CSV (a path: read_result), or the result as
    data: a structured numpy array with the CSV's columns (fmpy's and gyrowheel.simulate's) or an
    object holding one as .data (a system run's RunResult). component: see read_result.
    Raises AnimationError (named 'result' for data), TypeError for anything else."""
    if isinstance(result, (str, os.PathLike)):
        return read_result(result, component)
    import numpy as np

    data = result if isinstance(result, np.ndarray) else getattr(result, "data", None)  # (ndarray.data: its buffer)
    names = data.dtype.names if isinstance(data, np.ndarray) else None
    if not names or data.ndim != 1:
        raise TypeError(f"result must be a result CSV (a path) or a run's structured array (gyrowheel.simulate's), "
                        f"got {type(result).__name__}")
    path = Path(DATA_NAME)
    columns, component = _component_columns(path, list(names), component)
    if len(data) == 0:
        raise AnimationError(f"{path}: no rows")
    text = {}
    for name, column in zip(names, columns):
        if column is not None:
            if data.dtype[name].kind not in "biuf":
                raise AnimationError(f"{path}: column {name!r} is not numeric ({data.dtype[name]})")
            text[column] = [repr(float(v)) for v in data[name]]  # read back exactly by ResultTable.number
    return ResultTable(path, text, len(data), component)


def animate(result, output: str | Path, R: float | None = None, fmu: str | Path | None = None,
            component: str | None = None, **options) -> Timeline:
    """Write the animation of a run to output (.gif, .mp4 or .html, by its extension).

    result: a result CSV or the result as data (see result_table). R (m) or fmu (its start
    values; or an .ssp: its wheel component's) give the wheel's geometry when the result does
    not (see resolve_parameters); component picks the component of a system's result
    (read_result); options are those of Options (fps, speed, size, trail, start, stop).
    The output's directory must exist (it is not made); the file is written whole or not at all
    (gyrowheel.output_files): an error or a Ctrl-C leaves what was there before. A GIF plays in
    real time (times speed) to the centisecond, at no more than gif.MAX_FPS frames a second
    (gif.py, docs/animation.md): its Timeline's options.fps is the fps written and delays_cs
    each frame's delay.
    Returns the Timeline drawn. Raises AnimationError for bad input, with a one-line message
    (an output path that exists and is no regular file included).
    """
    output = Path(output)
    fmt = output.suffix.lower()
    if fmt not in FORMATS:
        raise AnimationError(f"{output}: unknown output format {output.suffix!r}: use .gif, .mp4 or .html")
    check_output_file(output, "-o", error=AnimationError)  # refused before anything runs
    table = result_table(result, component)
    timeline = build_timeline(table, resolve_parameters(table, R=R, fmu=fmu), Options(**options),
                              gif=fmt == ".gif")
    try:
        with replaced_atomically(output, "-o", error=AnimationError) as part:
            if fmt == ".html":
                from gyrowheel.animation.html import write_html
                write_html(timeline, part, title=f"gyrowheel: {table.path.name}")
            else:
                from gyrowheel.animation.render import render_video
                render_video(timeline, part)
    except OSError as exc:
        raise AnimationError(f"{exc.filename or output}: cannot write: {exc.strerror or exc}") from None
    return timeline
