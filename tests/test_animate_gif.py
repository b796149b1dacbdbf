"""GIFs that play in real time, are written frame by frame, and are whole or not written at all."""
from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from animate_data import rolling_csv
from gyrowheel.animation import animate
from gyrowheel.animation.gif import MIN_DELAY_CS, GifStream, gif_schedule
from gyrowheel.cli import main


def _durations_ms(path) -> list[int]:
    """Every frame's delay as Pillow reads it back (ms; GIF stores whole centiseconds)."""
    with Image.open(path) as im:
        out = []
        for k in range(im.n_frames):
            im.seek(k)
            out.append(im.info.get("duration", 0))
    return out


@pytest.fixture(scope="module")
def run_csv(tmp_path_factory):
    return rolling_csv(tmp_path_factory.mktemp("gif") / "run.csv", stop=2.0)


@pytest.mark.parametrize("fps", [10, 24, 30, 60, 100, 120])
def test_gif_plays_in_real_time_whatever_the_fps(run_csv, tmp_path, fps):
    # 2 s of the run at x4: the GIF must loop in 0.5 s, every delay one that browsers honour (>= 20 ms)
    out = tmp_path / "run.gif"
    tl = animate(run_csv, out, fps=fps, speed=4.0, size=(64, 64))
    durations = _durations_ms(out)
    assert len(durations) == len(tl.time)
    assert min(durations) >= 20, durations
    assert sum(durations) == pytest.approx((2.0 - 0.0) / 4.0 * 1000, rel=0.02)
    assert tl.options.fps == min(fps, 50) and tl.time[0] == 0.0 and tl.time[-1] == 2.0
    # and each frame is on screen when the playback clock passes its time (nearest frame, to 0.5 cs)
    ends = np.cumsum(durations) / 1000.0
    begins = ends - np.array(durations) / 1000.0
    clock = (tl.time - tl.time[0]) / 4.0
    assert np.all(clock >= begins - 0.005) and np.all(clock <= ends + 0.005)


def test_the_command_says_a_gif_is_written_at_50_fps(run_csv, tmp_path, capsys):
    assert main(["animate", str(run_csv), "-o", str(tmp_path / "a.gif"), "--fps", "100", "--speed", "4",
                 "--size", "64x64"]) == 0
    out, err = capsys.readouterr()
    assert " at 50 fps, 64x64" in out
    assert ("note: a GIF shows at most 50 frames a second on time (its delays are whole hundredths of a second "
            "and browsers slow shorter ones): written at 50 fps, not 100; .mp4 and .html play 100") in err


@pytest.mark.parametrize("fps,speed,stop", [(10, 1, 2.0), (24, 1, 2.0), (30, 1.3, 7.77), (45, 0.7, 1.01),
                                            (50, 1, 3.0), (50, 2, 0.05), (7, 0.1, 0.999), (25, 1, 0.013)])
def test_schedule_keeps_time_to_the_centisecond(fps, speed, stop):
    # frame times as timeline.frame_times makes them: a step of speed / fps, the stop itself last
    times = np.minimum(np.arange(int(np.ceil(stop * fps / speed - 1e-9)) + 1) * speed / fps, stop)
    kept, delays = gif_schedule(times / speed, 1.0 / fps)
    total_cs = stop / speed * 100
    assert kept[0] == 0 and kept[-1] == len(times) - 1 and np.all(np.diff(kept) > 0)
    assert delays.min() >= MIN_DELAY_CS
    if total_cs >= 2 * MIN_DELAY_CS:
        assert abs(delays.sum() - total_cs) <= 0.5 + 1e-9  # each boundary rounded once, not each delay
        begins = np.concatenate([[0], np.cumsum(delays)[:-1]])
        clock = times[kept] / speed * 100
        assert np.all(clock >= begins - 0.5 - 1e-9) and np.all(clock <= begins + delays + 0.5 + 1e-9)
        assert len(kept) >= len(times) - 2 * (fps > 25) - 1  # only the ends' and a short last step's frames go
    else:  # a loop too short for two GIF frames: start and stop each at the shortest delay
        assert list(delays) == [MIN_DELAY_CS] * len(kept)


def test_gif_stream_writes_what_pillow_reads_back():
    rng = np.random.default_rng(7)
    w, h = 40, 30
    frames = [np.full((h, w, 3), 255, np.uint8)]
    for k in range(5):
        f = frames[-1].copy()
        f[3 + k:12 + k, 5:30] = rng.integers(0, 4, (9, 25, 3), dtype=np.uint8) * 80  # 64 colours: no loss
        frames.append(f)
    frames.append(frames[-1].copy())  # the same picture again: one frame, shown longer
    delays = [2, 3, 4, 5, 6, 7, 8]
    buf = io.BytesIO()
    gif = GifStream(buf, (w, h))
    for f, d in zip(frames, delays):
        gif.add(f, d)
    gif.close()
    buf.seek(0)
    with Image.open(buf) as im:
        assert im.n_frames == 6 and im.info.get("loop") == 0
        for k in range(6):
            im.seek(k)
            assert np.array_equal(np.asarray(im.convert("RGB")), frames[k]), k
            assert im.info["duration"] == 10 * (delays[k] + (delays[6] if k == 5 else 0))
    with pytest.raises(ValueError, match=r"frame must be \(30, 40, 3\) uint8"):
        gif.add(frames[0][:, :20], 2)
    # a delay past GIF's 16-bit field (655.35 s) goes on in a second frame that changes nothing
    buf = io.BytesIO()
    gif = GifStream(buf, (w, h))
    gif.add(frames[3], 70000)
    gif.close()
    buf.seek(0)
    with Image.open(buf) as im:
        assert im.n_frames == 2
        for k, duration in enumerate((655350, 44650)):
            im.seek(k)
            assert im.info["duration"] == duration and np.array_equal(np.asarray(im.convert("RGB")), frames[3])


def _status_kb(field: str) -> int:
    """A field of /proc/self/status in kB (VmRSS: resident now; VmHWM: its peak)."""
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith(field + ":"))


def test_gif_memory_does_not_grow_with_the_frames(run_csv, tmp_path):
    # 21 frames of 480x360 (0.5 MB each as RGB): held until the end (matplotlib's PillowWriter)
    # they add 24 MB to the peak, written as they are drawn about 2.5 MB (for 60 s at 25 fps,
    # 640x480, all frames held took 2.4 GB). The peak is the process's resident high-water
    # mark, reset just before (Linux: /proc/self/clear_refs); Pillow's images are not Python
    # objects, so tracemalloc would not see them.
    size = (480, 360)
    animate(run_csv, tmp_path / "warm.gif", fps=1, speed=2.0, size=size)  # imports and font caches first
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")  # VmHWM := VmRSS
    except OSError as exc:
        pytest.skip(f"the resident peak cannot be reset here: {exc}")
    before = _status_kb("VmRSS")
    tl = animate(run_csv, tmp_path / "run.gif", fps=10, speed=1.0, size=size)
    growth = (_status_kb("VmHWM") - before) * 1024
    assert len(tl.time) == 21
    assert growth < 8 * size[0] * size[1] * 3, f"{growth / 1e6:.1f} MB"


def _interrupted(update, at: int):
    """The drawing of frame k, with a Ctrl-C (KeyboardInterrupt) at frame `at`."""

    def drawn(scene, k):
        if k == at:
            raise KeyboardInterrupt
        return update(scene, k)

    return drawn


@pytest.mark.parametrize("suffix", [".gif", ".mp4", ".html"])
@pytest.mark.parametrize("before", [b"the previous animation", None])
def test_ctrl_c_leaves_the_previous_file_or_nothing(run_csv, tmp_path, monkeypatch, suffix, before):
    from gyrowheel.animation import html, render

    out = tmp_path / f"run{suffix}"
    if before is not None:
        out.write_bytes(before)
    monkeypatch.setattr(render._Scene, "update", _interrupted(render._Scene.update, at=4))

    def half_written(self, text, *args, **kwargs):  # Ctrl-C halfway through writing the page
        with open(self, "w", encoding="utf-8") as f:
            f.write(text[:len(text) // 2])
        raise KeyboardInterrupt

    monkeypatch.setattr(html.Path, "write_text", half_written)
    with pytest.raises(KeyboardInterrupt):
        animate(run_csv, out, fps=10, size=(64, 64))
    assert (out.read_bytes() if out.exists() else None) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ([out.name] if before is not None else [])
