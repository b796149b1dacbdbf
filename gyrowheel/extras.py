"""gyrowheel's optional parts (pip extras) and the check a verb makes before it uses one.

The core install (`pip install gyrowheel`: casadi, fmpy, numpy) builds, simulates, describes and
exports FMUs and runs a system of FMUs. The rest comes with an extra (pyproject.toml):

    plot     `gyrowheel simulate --plot`                  matplotlib
    sweep    `gyrowheel sweep` (Dask, the table, its plot) dask, distributed, pandas, pyarrow, tqdm,
                                                           matplotlib
    animate  `gyrowheel animate` (GIF, MP4)                matplotlib, pillow, imageio-ffmpeg
    system   the Gyrover's controller design, writing      scipy, pyssp-standard, matplotlib
             SSP 1.0 systems
    platforms `gyrowheel build --platforms` (binaries for  ziglang
             other platforms: zig's C compiler;
             gyrowheel.fmu_build.platforms.zig_command)
    all      every one of them but platforms (IN_ALL: zig is a whole C toolchain, ~400 MB,
             and a machine can build its own binary without it)

require(extra, verb) looks each import name up with importlib.util.find_spec, which imports
nothing, and raises MissingExtraError naming the pip command when one is missing.
"""
from __future__ import annotations

import importlib.util

from gyrowheel.errors import MissingExtraError, UnknownNameError

# extra -> the top-level import names of the distributions it installs (pyproject.toml's
# [project.optional-dependencies]; tests/test_extras.py checks the two agree)
EXTRAS: dict[str, tuple[str, ...]] = {
    "plot": ("matplotlib",),
    "sweep": ("dask", "distributed", "pandas", "pyarrow", "tqdm", "matplotlib"),
    "animate": ("matplotlib", "PIL", "imageio_ffmpeg"),
    "system": ("scipy", "pyssp_standard", "matplotlib"),
    "platforms": ("ziglang",),
}
IN_ALL = tuple(e for e in EXTRAS if e != "platforms")  # the extras gyrowheel[all] installs


def _found(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):  # a broken or half-imported module counts as missing
        return False


def missing(extra: str) -> list[str]:
    """The import names of `extra` that are not installed (empty: the extra is complete).

    Raises KeyError for an unknown extra, listing the known ones."""
    try:
        names = EXTRAS[extra]
    except KeyError:
        raise UnknownNameError(f"no optional part {extra!r}; known: {', '.join(EXTRAS)}") from None
    return [name for name in names if not _found(name)]


def require(extra: str, verb: str) -> None:
    """Raise MissingExtraError unless every import name of `extra` is installed.

    verb: what needs the extra, as the user called it, shown in the message: 'gyrowheel sweep'
    (a command), 'gyrowheel.sweep()' (a function), 'gyrowheel.controller' (a module). Nothing
    is imported. Raises KeyError for an unknown extra.
    """
    absent = missing(extra)
    if absent:
        raise MissingExtraError(extra, verb, absent)
