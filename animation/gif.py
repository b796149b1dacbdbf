"""GIF playback in real time, and a GIF writer that streams: one frame in memory, not all of them.

Timing. A GIF's frame delays are whole centiseconds (GIF89a, section 23: Graphic Control
Extension, "Delay Time"), and browsers show a delay of 1 cs or less as 10 cs (some also one of
2 cs), so a GIF keeps time only with delays of MIN_DELAY_CS = 2 cs or more: at most MAX_FPS = 50
frames a second.
The rule (gif_schedule): the frame times asked for are placed on the playback clock
(tau_k = (t_k - start) / speed) and, at every instant of playback, the GIF shows the frame
nearest to it: frame k from the midpoint with its predecessor to the midpoint with its successor
(the first frame from 0, the last up to the end, so the loop is (stop - start) / speed long).
Each such boundary is rounded to the centisecond on its own (not each delay), so the error does
not accumulate: every boundary, and so the total, is within 0.5 cs of the real time. A frame
that would get less than MIN_DELAY_CS is dropped and its neighbours share its turn; the first
and the last frame (start and stop) are always kept.

Writing. Pillow's own multi-frame GIF save keeps every frame until the end
(PIL.GifImagePlugin._write_multiple_frames), which for a long run is gigabytes. GifStream
writes each frame when the next one arrives: only the changed rectangle of a frame (its
bounding box against the previous frame) is quantised by Pillow to its own palette of at most
256 colours (exact when it has no more) and written as one image with a local colour table
(GIF89a, section 20: Image Descriptor, and 21: Local Color Table); a frame identical to the
previous one lengthens the previous one's delay.
"""
from __future__ import annotations

import io
import math
import struct
from typing import TYPE_CHECKING, BinaryIO

import numpy as np

if TYPE_CHECKING:  # Pillow is imported where a frame is written: the schedule needs numpy only
    from PIL import Image

MAX_FPS = 50.0  # frames per second a GIF can show on time (delays >= MIN_DELAY_CS)
MIN_DELAY_CS = 2  # shortest delay browsers honour, cs
MAX_DELAY_CS = 0xFFFF  # GIF's delay field: 16 bits (a longer delay: GifStream splits it)


def centiseconds(seconds: float) -> int:
    """Seconds to whole centiseconds, halves up."""
    return int(math.floor(100.0 * seconds + 0.5))


def gif_schedule(playback: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Which frames a GIF shows and for how long, in real time: the rule of the module docstring.

    playback: (N,) ascending seconds of playback at which each frame's simulated time is reached,
    playback[0] = 0 and playback[-1] the loop's length ((stop - start) / speed); step: the nominal
    frame step in seconds of playback (1 / fps), the delay of a single frame (N = 1).
    Returns (indices of the frames kept, (K,) int; their delays in cs, (K,) int, each >=
    MIN_DELAY_CS). The delays sum to round(100 playback[-1]) except when the loop is shorter
    than MIN_DELAY_CS per frame kept (start and stop both within a few cs): then each of the two
    lasts MIN_DELAY_CS and the GIF plays longer than the run.
    """
    n = len(playback)
    if n == 1:
        return np.array([0]), np.array([max(centiseconds(step), MIN_DELAY_CS)])
    total = centiseconds(playback[-1])

    def bound(i: int, j: int) -> int:
        return centiseconds(0.5 * (playback[i] + playback[j]))

    kept = [0]
    lower = 0  # where the last kept frame's turn begins
    for k in range(1, n - 1):
        b = bound(kept[-1], k)
        if b - lower >= MIN_DELAY_CS and bound(k, k + 1) - b >= MIN_DELAY_CS:
            kept.append(k)
            lower = b
    while len(kept) > 1 and total - bound(kept[-1], n - 1) < MIN_DELAY_CS:
        kept.pop()  # the stop's turn is too short: its predecessor gives way
    kept.append(n - 1)
    bounds = [0] + [bound(a, b) for a, b in zip(kept, kept[1:])] + [total]
    delays = np.maximum(np.diff(bounds), MIN_DELAY_CS)
    return np.array(kept), delays.astype(int)


def _sub_blocks(data: bytes, i: int) -> int:
    """The offset just past a chain of data sub-blocks starting at data[i] (GIF89a section 15)."""
    while data[i]:
        i += data[i] + 1
    return i + 1


def _one_image(image: Image.Image) -> tuple[bytes, bytes, bool]:
    """(colour table, LZW image data with its sub-blocks, interlaced) of `image` as Pillow writes
    it alone into a GIF: read back from that file's blocks (GIF89a sections 18-22)."""
    buf = io.BytesIO()
    image.save(buf, "GIF", interlace=False)
    data = buf.getvalue()
    packed = data[10]
    i = 13
    table = b""
    if packed & 0x80:  # global colour table
        i += 3 << ((packed & 7) + 1)
        table = data[13:i]
    while data[i] == 0x21:  # extensions before the image: skipped
        i = _sub_blocks(data, i + 2)
    if data[i] != 0x2C or not (table or data[i + 9] & 0x80):
        raise RuntimeError("Pillow wrote a GIF without an image descriptor or colour table")
    local = data[i + 9]
    i += 10
    if local & 0x80:
        end = i + (3 << ((local & 7) + 1))
        table, i = data[i:end], end
    start = i
    i = _sub_blocks(data, i + 1)  # LZW minimum code size, then the sub-blocks
    return table, data[start:i], bool(local & 0x40)


def _image_block(rgb: np.ndarray, box: tuple[int, int, int, int]) -> bytes:
    """The rectangle box = (x0, y0, x1, y1) of rgb as one GIF image: Image Descriptor, Local Color
    Table (a palette of that rectangle's colours, quantised by Pillow when there are more than
    256), image data."""
    from PIL import Image

    x0, y0, x1, y1 = box
    part = Image.fromarray(np.ascontiguousarray(rgb[y0:y1, x0:x1]), "RGB")
    if part.getcolors(256) is not None:  # 256 colours or fewer: each its own palette entry, no loss
        palette = part.convert("P", palette=Image.Palette.ADAPTIVE)
    else:  # a drawn frame's anti-aliasing: the fast octree (a third less time than median cut, as good)
        palette = part.quantize(256, method=Image.Quantize.FASTOCTREE)
    table, data, interlaced = _one_image(palette)
    size_bits = max(0, (len(table) // 3).bit_length() - 2)  # a table of 2^(bits + 1) entries
    return (b"\x2c" + struct.pack("<HHHHB", x0, y0, x1 - x0, y1 - y0, 0x80 | (0x40 if interlaced else 0) | size_bits)
            + table + data)


class GifStream:
    """A looping GIF written frame by frame to a binary file: add(frame, delay) then close().

    Memory: the previous frame's pixels and one encoded frame, whatever the number of frames."""

    def __init__(self, fp: BinaryIO, size: tuple[int, int]):
        self.fp, self.size = fp, size
        self._previous: np.ndarray | None = None  # (h, w, 3) uint8: the picture shown so far
        self._pending: tuple[bytes, int] | None = None  # the last frame, encoded, and its delay (cs)
        self.frames = 0
        w, h = size
        fp.write(b"GIF89a" + struct.pack("<HHBBB", w, h, 0, 0, 0))  # no global colour table
        fp.write(b"\x21\xff\x0bNETSCAPE2.0\x03\x01" + struct.pack("<H", 0) + b"\x00")  # loop forever

    def add(self, rgb: np.ndarray, delay_cs: int) -> None:
        """Append a frame: rgb (height, width, 3) uint8 shown for delay_cs centiseconds (an int >= 1;
        one longer than GIF's 16-bit field is carried on by one-pixel frames that change nothing).
        Raises ValueError for a frame of another shape or type, or a delay < 1."""
        w, h = self.size
        if rgb.shape != (h, w, 3) or rgb.dtype != np.uint8:
            raise ValueError(f"frame must be ({h}, {w}, 3) uint8, got {rgb.shape} {rgb.dtype}")
        if not (isinstance(delay_cs, (int, np.integer)) and delay_cs >= 1):
            raise ValueError(f"delay must be a whole number of centiseconds >= 1, got {delay_cs!r}")
        if self._previous is None:
            box = (0, 0, w, h)
        else:
            changed = np.any(rgb != self._previous, axis=2)
            rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
            if rows.size == 0:  # the same picture: the one before stays longer
                image, delay = self._pending
                self._pending = (image, delay + int(delay_cs))
                return
            box = (int(cols[0]), int(rows[0]), int(cols[-1]) + 1, int(rows[-1]) + 1)
        self._flush()
        self._pending = (_image_block(rgb, box), int(delay_cs))
        self._previous = rgb.copy()

    def _flush(self) -> None:
        """Write the pending frame; a delay past MAX_DELAY_CS goes on in one-pixel frames."""
        if self._pending is None:
            return
        image, delay = self._pending
        while True:
            part = min(delay, MAX_DELAY_CS)
            # Graphic Control Extension: disposal 1 (leave the frame in place), the delay, no transparency
            self.fp.write(b"\x21\xf9\x04\x04" + struct.pack("<H", part) + b"\x00\x00" + image)
            delay -= part
            if delay == 0:
                break
            image = _image_block(self._previous, (0, 0, 1, 1))  # the top-left pixel again: no change
        self.frames += 1
        self._pending = None

    def close(self) -> None:
        """Write the last frame and the trailer. Raises ValueError when no frame was added."""
        if self._pending is None:
            raise ValueError("a GIF needs at least one frame")
        self._flush()
        self.fp.write(b"\x3b")
