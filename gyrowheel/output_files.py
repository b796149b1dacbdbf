"""The one rule for every file gyrowheel writes: complete and right, or not touched.

A verb's output (an FMU, a CSV of a run, a plot, an animation, a sweep's table, exported C) is
written to a hidden sibling in the same directory and moved over the final name with
os.replace only when it is whole. An error or a Ctrl-C while writing removes the sibling and
leaves what was there before (a previous run's file, or nothing). An existing path that is not
a regular file (a directory, a device such as /dev/full, a FIFO, a socket) is refused before
anything runs: renaming over it would replace the device node or the directory entry. A
process killed while writing (SIGKILL) cannot remove its sibling: the next write of the same
file removes the siblings of processes that are gone (remove_stale_parts). The directory of
the file must exist: it is never made (a typo in a path is refused, not a new directory).

    with replaced_atomically(path, "output") as part:
        figure.savefig(part)          # `part` keeps path's suffix: writers choosing by suffix work

Only the standard library is used: every room may import this module.
"""
from __future__ import annotations

import contextlib
import os
import re
import stat
from collections.abc import Iterator
from pathlib import Path

from gyrowheel.errors import ArgumentError
from gyrowheel.scratch import remove_orphans


def check_output_file(path: str | os.PathLike, name: str, *, error: type = ArgumentError,
                      argument: str | None = None) -> Path:
    """The path an output will be written to, checked before anything runs.

    path: the output file; a symbolic link is followed (the file it names is written).
    name: how messages name the argument ('output', '--plot', '-o').
    Returns the path (pathlib.Path) the file will be moved to.
    Raises `error` (ArgumentError by default; `argument` its attribute, else `name` when that is
    an identifier) when the path exists and is not a regular file (a directory, a device, a
    FIFO, a socket) or its directory does not exist (a missing directory is refused, never
    made: every verb of gyrowheel writes only into directories that exist) or is a file.
    """
    path = Path(path)
    argument = argument if argument is not None else (name if name.isidentifier() else None)
    target = path.resolve() if path.is_symlink() else path
    try:
        mode = os.stat(target).st_mode
    except (FileNotFoundError, NotADirectoryError):  # (a file where a directory goes: named below)
        mode = None
    except OSError as exc:
        raise error(f"{name} {path}: cannot be written ({exc.strerror})", argument=argument) from None
    if mode is not None and stat.S_ISDIR(mode):
        raise error(f"{name} {path}: is a directory; give a file name", argument=argument)
    if mode is not None and not stat.S_ISREG(mode):
        raise error(f"{name} {path}: exists and is not a regular file (a device, FIFO or socket); "
                    "give a file name", argument=argument)
    if not target.parent.is_dir():  # never made: a typo in a path is not a new directory
        blocker = next((p for p in target.parents if p.exists() and not p.is_dir()), None)
        if blocker is not None:
            raise error(f"{name} {path}: cannot write: {blocker} is not a directory", argument=argument)
        raise error(f"{name} {path}: directory {target.parent} does not exist", argument=argument)
    return target


def partial_path(target: Path) -> Path:
    """The hidden sibling a file is written to before it replaces `target` (same suffix)."""
    return target.with_name(f".{target.stem}.part-{os.getpid()}{target.suffix}")


def remove_stale_parts(target: Path) -> list[Path]:
    """Remove the siblings `.STEM.part-PID.SUFFIX` of `target` (partial_path) left by a process
    that was killed while writing it: regular files of this user whose PID no longer exists on
    this machine (gyrowheel.scratch.remove_orphans). Returns the files removed; nothing where
    processes cannot be asked (not POSIX)."""
    pattern = re.compile(rf"^\.{re.escape(target.stem)}\.part-([0-9]+){re.escape(target.suffix)}$")

    def pid_of(name: str) -> int | None:
        match = pattern.match(name)
        return None if match is None else int(match[1])

    return remove_orphans(target.parent, pid_of, stat.S_IFREG)


@contextlib.contextmanager
def replaced_atomically(path: str | os.PathLike, name: str = "output", *, error: type = ArgumentError,
                        argument: str | None = None) -> Iterator[Path]:
    """Write a file whole or not at all: yields the sibling to write; on success it replaces `path`.

    path, name, error, argument: as for check_output_file (checked again on entry, so a path
    that turned into a directory or device meanwhile is still refused). The yielded Path is in
    the same directory (os.replace is then atomic on POSIX and Windows) with the same suffix.
    If the block raises (any exception, KeyboardInterrupt included) the sibling is removed and
    `path` is left as it was; the siblings of `path` left by killed processes are removed
    first (remove_stale_parts). Raises `error` if the block wrote nothing to the sibling.
    """
    target = check_output_file(path, name, error=error, argument=argument)
    remove_stale_parts(target)
    part = partial_path(target)
    try:
        yield part
        if not part.exists():
            raise error(f"{name} {path}: nothing was written", argument=argument)
        os.replace(part, target)
    except BaseException:
        with contextlib.suppress(OSError):
            part.unlink()
        raise
