"""A standalone interactive HTML page of a run: three.js (vendored, inline), orbit, scrub, play.

One file, no network, no server: the vendored three.js (vendor/three/, MIT) is embedded as text and
loaded from blob URLs (assets/page.js), the poses as JSON. The page marks its progress on the
element #status (data-rendered: frames three.js has drawn), which the tests read in a headless
browser.
"""
from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from string import Template

import numpy as np

from gyrowheel.animation.render import FLYWHEEL_COLOUR, RIM_COLOURS
from gyrowheel.animation.timeline import Timeline

CORE_SPECIFIER = '"./three.core.min.js"'  # how three.module.min.js imports its core
THREE_SPECIFIER = "'three'"  # how OrbitControls.js imports three


def _asset(*parts: str) -> str:
    return resources.files("gyrowheel.animation").joinpath(*parts).read_text(encoding="utf-8")


def three_sources() -> dict[str, str]:
    """The vendored three.js modules as text, with the import specifiers the page rewrites.

    Raises RuntimeError when a re-vendored version no longer imports its parts as expected."""
    src = {"core": _asset("vendor", "three", "three.core.min.js"),
           "module": _asset("vendor", "three", "three.module.min.js"),
           "orbit": _asset("vendor", "three", "OrbitControls.js"),
           "coreSpecifier": CORE_SPECIFIER, "threeSpecifier": THREE_SPECIFIER}
    if CORE_SPECIFIER not in src["module"] or f"from {THREE_SPECIFIER}" not in src["orbit"]:
        raise RuntimeError("the vendored three.js no longer imports its core as ./three.core.min.js "
                           "(see animation/vendor/three/README.md)")
    return src


def _script_json(value) -> str:
    """JSON safe inside <script>: '</' cannot end the element, '<!--' cannot open a comment."""
    return json.dumps(value, separators=(",", ":")).replace("</", "<\\/").replace("<!--", "<\\!--")


def _flat(a: np.ndarray, digits: int = 6) -> list[float]:
    return [float(v) for v in np.round(np.asarray(a, dtype=float).ravel(), digits)]


def run_data(tl: Timeline, title: str) -> dict:
    """What the page draws, as JSON-ready lists (row-major 3x3 frames, metres, seconds)."""
    p, R = tl.poses, tl.parameters.R
    track = tl.track[:, :2]
    extent = [float(track[:, 0].min()), float(track[:, 0].max()), float(track[:, 1].min()), float(track[:, 1].max())]
    data = {
        "title": title, "R": R, "fps": tl.options.fps, "speed": tl.options.speed, "trail": tl.options.trail,
        "time": _flat(tl.time, 9), "centre": _flat(p.centre), "body": _flat(p.body), "contact": _flat(p.contact),
        "heading": _flat(p.heading[:, :2]), "readout": tl.readout,
        "track_time": _flat(tl.track_time, 9), "track": _flat(track), "extent": extent,
        "rim_colours": list(RIM_COLOURS), "fly": None,
    }
    if tl.gyrover:
        data["fly"] = {"radius": tl.fly_radius, "colour": FLYWHEEL_COLOUR,
                       "centre": _flat(p.fly_centre), "frame": _flat(p.fly_frame)}
    return data


def write_html(tl: Timeline, path: str | Path, title: str = "gyrowheel") -> Path:
    """Write the standalone page to path (.html); returns the path."""
    path = Path(path)
    page = Template(_asset("assets", "page.html")).substitute(
        title=title.replace("&", "&amp;").replace("<", "&lt;"),
        data=_script_json(run_data(tl, title)),
        three=_script_json(three_sources()),
        page=_asset("assets", "page.js"))
    path.write_text(page, encoding="utf-8")
    return path
