"""`gyrowheel animate RESULT.csv -o run.gif|run.mp4|run.html`: arguments and the run."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path


def parse_size(text: str) -> tuple[int, int]:
    """'640x480' -> (640, 480); raises AnimationError."""
    from gyrowheel.animation import AnimationError
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise AnimationError(f"--size: expected WIDTHxHEIGHT in pixels, e.g. 640x480, got {text!r}") from None
    return w, h


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from gyrowheel.cli import finite_float

    parser.add_argument("result", help="result CSV (gyrowheel simulate, or any table with its column names)")
    parser.add_argument("-o", "--output", help="animation to write: .gif, .mp4 or .html (default: RESULT.gif)")
    parser.add_argument("--fmu", help="read R and the flywheel's geometry from this FMU's start values "
                        "(or from a system's .ssp: its wheel component's FMU and bindings)")
    parser.add_argument("--component", help="for a system's result (<component>.<variable> columns, "
                        "gyrowheel system run): the component to draw (default: the one with the wheel's columns)")
    parser.add_argument("--R", type=finite_float, help="wheel radius in m (default: the FMU's, or z / sin(beta))")
    parser.add_argument("--fps", type=finite_float, default=25.0,
                        help="frames per second of playback, (0, 120]; a GIF's at most 50 (default 25)")
    parser.add_argument("--speed", type=finite_float, default=1.0,
                        help="simulated seconds per second of playback (default 1)")
    parser.add_argument("--size", default="640x480", help="WIDTHxHEIGHT in pixels (default 640x480)")
    parser.add_argument("--trail", type=finite_float, help="seconds of contact track behind the wheel (default: all)")
    parser.add_argument("--start", type=finite_float, help="first simulated time shown, s (default: the run's start)")
    parser.add_argument("--stop", type=finite_float, help="last simulated time shown, s (default: the run's end)")


def run(args: argparse.Namespace) -> int:
    """Write the animation (gyrowheel.animate) and say what was written (the fps written: a GIF's
    is at most 50, noted). Raises AnimationError for bad input (its engine_text in the command's
    flags: gyrowheel.wording)."""
    from gyrowheel.animation.gif import centiseconds
    from gyrowheel.api import animate

    output = Path(args.output or Path(args.result).with_suffix(".gif").name)
    tl = animate(args.result, output, R=args.R, fmu=args.fmu, component=args.component, fps=args.fps,
                 speed=args.speed, size=args.size, trail=args.trail, start=args.start, stop=args.stop)
    size = tl.options.size
    t0, t1 = tl.time[0], tl.time[-1]
    fps = tl.options.fps  # a GIF's: at most gif.MAX_FPS
    what = f"{len(tl.time)} frame{'s' * (len(tl.time) != 1)} at {fps:g} fps" + ("" if output.suffix.lower() == ".html"
                                                                                 else f", {size[0]}x{size[1]}")
    source = {"R": "--R"}.get(tl.parameters.source["R"], tl.parameters.source["R"])  # a radius given: by --R
    print(f"wrote {output}: {what}, t = {t0:g} .. {t1:g} s at ×{args.speed:g} (R = {tl.parameters.R:g} m "
          f"from {source})")
    defaults = [n for n, s in tl.parameters.source.items() if s == "model default"]
    if defaults:
        print(f"note: flywheel geometry {', '.join(defaults)} from the model's defaults; pass --fmu for the run's",
              file=sys.stderr)
    if fps < args.fps:
        print(f"note: a GIF shows at most {fps:g} frames a second on time (its delays are whole hundredths of a "
              f"second and browsers slow shorter ones): written at {fps:g} fps, not {args.fps:g}; .mp4 and .html "
              f"play {args.fps:g}", file=sys.stderr)
    if tl.delays_cs is not None and int(tl.delays_cs.sum()) > centiseconds((t1 - t0) / args.speed):
        print(f"note: the GIF plays {tl.delays_cs.sum() / 100:g} s, longer than the {(t1 - t0) / args.speed:.3g} s "
              "of the run at this speed: a GIF frame lasts at least 0.02 s; lower --speed", file=sys.stderr)
    if len(tl.time) == 2 and tl.time[1] - tl.time[0] < args.speed / args.fps:
        print(f"note: at ×{args.speed:g} and {args.fps:g} fps one frame is {args.speed / args.fps:g} s of the run, "
              f"more than the {t1 - t0:g} s shown: the animation shows only its first and last instant; "
              "lower --speed", file=sys.stderr)
    if tl.spin_per_frame > math.pi / 2:
        print(f"note: the wheel turns up to {tl.spin_per_frame:.1f} rad between frames, so its marks may seem to "
              "turn backwards; lower --speed or raise --fps", file=sys.stderr)
    return 0
