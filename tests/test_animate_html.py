"""The standalone HTML page in a real headless browser (Debian's chromium), offline, from file://.

`make test` installs chromium where it is missing and apt-get is usable (Makefile target browser);
.ci/run installs it on CI. Without it these tests fail with that instruction rather than skip.
"""
from __future__ import annotations

import hashlib
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from animate_data import rolling_csv
from browser import Chromium, chromium_path
from gyrowheel.animation import animate
from gyrowheel.animation.render import RIM_COLOURS

VENDOR = Path(__file__).resolve().parent.parent / "animation" / "vendor" / "three"
FRAMES = 5  # three.js frames the page must have rendered


def _pixels_near(image: np.ndarray, colour: str, tol: int = 12) -> int:
    rgb = np.array([int(colour[i:i + 2], 16) for i in (1, 3, 5)])
    return int((np.abs(image.astype(int) - rgb).max(axis=2) <= tol).sum())


@pytest.fixture(scope="module")
def page(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("html")
    out = d / "gyrover.html"
    animate(rolling_csv(d / "gyrover.csv", stop=3.0, gyrover=True), out, fps=20, speed=0.5)
    return out


def test_page_is_standalone(page):
    html = page.read_text()
    assert not re.search(r"<(script|link|img)[^>]+(src|href)=", html)  # nothing fetched
    assert html.count("<script") == 3 and "@license" in html and "Three.js Authors" in html
    size = page.stat().st_size
    assert 750_000 < size < 2_000_000, size  # three.js (~790 kB) plus the run


def test_browser_draws_the_wheel(page, tmp_path):
    if chromium_path() is None:
        pytest.fail("Debian's chromium is needed for the HTML test: `make browser` (as root) or "
                    "`apt-get install chromium`")
    with Chromium(800, 600) as browser:
        browser.open(page.as_uri())
        rendered = browser.wait_for(f"Number(document.getElementById('status').dataset.rendered) >= {FRAMES} "
                                    "&& document.getElementById('status').dataset.rendered")
        status = browser.evaluate("document.getElementById('status').textContent")
        readout = browser.evaluate("document.getElementById('readout').textContent")
        png = browser.screenshot()
        assert browser.console == []
    assert int(rendered) >= FRAMES and status.startswith("three.js r185: rendered frame"), status
    assert readout.startswith("t = ") and "tilt =" in readout and "beta =  80.0°" in readout
    shot = tmp_path / "shot.png"
    shot.write_bytes(png)
    image = np.asarray(Image.open(shot).convert("RGB"))
    assert image.shape == (600, 800, 3)
    background = _pixels_near(image, "#ffffff", tol=3)
    assert background < 0.9 * image.shape[0] * image.shape[1]  # the ground and the wheel are drawn
    for colour in RIM_COLOURS:  # the wheel's rim quadrants (unlit colours, exact)
        assert _pixels_near(image, colour) > 50, colour
    # the Gyrover's flywheel (lit, so shades of its brown: red well above green, almost no blue)
    r_, g_, b_ = (image[:, :, i].astype(int) for i in range(3))
    assert ((r_ > 50) & (r_ > 2 * g_) & (b_ < 0.15 * r_)).sum() > 200


def test_vendored_three_is_unchanged():
    """SHA256SUMS (vendor/three/README.md) pins the vendored files; the licence travels with them."""
    sums = dict(reversed(line.split()) for line in (VENDOR / "SHA256SUMS").read_text().splitlines())
    assert set(sums) == {"three.core.min.js", "three.module.min.js", "OrbitControls.js", "LICENSE"}
    for name, digest in sums.items():
        assert hashlib.sha256((VENDOR / name).read_bytes()).hexdigest() == digest, name
    assert "MIT License" in (VENDOR / "LICENSE").read_text()
    assert 'const t="185"' in (VENDOR / "three.core.min.js").read_text()[:400]
