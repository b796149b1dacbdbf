"""GIF (pillow) and MP4 (imageio) files: frame count, size, timing, and the wheel's marks in them."""
from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest
from PIL import Image

from animate_data import rolling_csv
from gyrowheel.animation import AnimationError, animate
from gyrowheel.animation.render import RIM_COLOURS


def _colour_pixels(frame: np.ndarray, colour: str, tol: int = 40) -> int:
    rgb = np.array([int(colour[i:i + 2], 16) for i in (1, 3, 5)])
    return int((np.abs(frame[:, :, :3].astype(int) - rgb).max(axis=2) < tol).sum())


@pytest.fixture(scope="module")
def gyrover_csv(tmp_path_factory):
    return rolling_csv(tmp_path_factory.mktemp("render") / "gyrover.csv", stop=2.0, gyrover=True)


def test_gif_frames_size_and_timing(gyrover_csv, tmp_path):
    out = tmp_path / "run.gif"
    tl = animate(gyrover_csv, out, fps=10, speed=1.0, size=(200, 150))
    assert len(tl.time) == 21 and tl.gyrover  # 0, 0.1, ..., 2.0 s
    with Image.open(out) as im:
        assert im.format == "GIF" and im.size == (200, 150) and im.n_frames == 21
        frames = []
        for k in range(im.n_frames):
            im.seek(k)
            # 100 ms at 10 fps, each frame from halfway after the one before to halfway to the next:
            # the first and the last 50 ms, so the GIF loops in the run's 2 s
            assert im.info["duration"] == (50 if k in (0, 20) else 100)
            frames.append(np.asarray(im.convert("RGB")))
    # every rim quadrant's colour is drawn, and the spin changes the picture from frame to frame
    for colour in RIM_COLOURS:
        assert _colour_pixels(frames[0], colour) > 20, colour
    assert all(np.abs(a.astype(int) - b).sum() > 0 for a, b in zip(frames, frames[1:]))


def test_gif_window_and_speed(gyrover_csv, tmp_path):
    out = tmp_path / "window.gif"
    tl = animate(gyrover_csv, out, fps=8, speed=0.25, start=0.5, stop=1.25, size=(96, 64), trail=0.2)
    assert len(tl.time) == 25 and tl.time[0] == 0.5 and tl.time[-1] == 1.25  # 0.75 s in steps of 1/32 s
    with Image.open(out) as im:
        assert im.n_frames == 25 and im.size == (96, 64)


def test_mp4_is_readable_with_the_expected_frames(gyrover_csv, tmp_path):
    out = tmp_path / "run.mp4"
    tl = animate(gyrover_csv, out, fps=12, speed=2.0, size=(240, 160))
    assert len(tl.time) == 13  # 0 .. 2 s in steps of 1/6 s
    frames = iio.imread(out, plugin="FFMPEG", index=None)
    assert frames.shape == (13, 160, 240, 3)
    meta = iio.immeta(out, plugin="FFMPEG")
    assert meta["fps"] == pytest.approx(12) and meta["codec"] == "h264"
    assert _colour_pixels(frames[0], RIM_COLOURS[0], tol=60) > 20


def test_mp4_needs_even_sizes_and_formats_are_named(gyrover_csv, tmp_path):
    with pytest.raises(AnimationError, match="even width and height, got 241x160"):
        animate(gyrover_csv, tmp_path / "odd.mp4", size=(241, 160))
    with pytest.raises(AnimationError, match=r"unknown output format '\.avi': use \.gif, \.mp4 or \.html"):
        animate(gyrover_csv, tmp_path / "run.avi")
    assert not (tmp_path / "odd.mp4").exists() and not (tmp_path / "run.avi").exists()
