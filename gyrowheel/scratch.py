"""gyrowheel's temporary directories: each names the process that owns it, none outlives it.

Every directory any verb (build, simulate, system run, animate, export_c, sweep) makes in the
temporary directory (tempfile.gettempdir(): $TMPDIR, else /tmp) is called

    gyrowheel-<kind>-<pid>-<host>-<random>

kind: what it holds, lower-case words joined by '-' (build: an FMU being built; run: an FMU
unpacked for simulate; system: a system's FMUs for system run; unit: one component's FMU
unpacked by the co-simulation master; animate, export, name, ssp, ens: a file for a moment;
sweep-run: a LocalCluster's whole sweep; sweep-unit: an FMU a sweep's worker keeps unpacked;
sweep-build, sweep-ens, sweep-ssp: a sweep's FMU being built or held); pid: the process that
made it; host: 8 hex digits of the SHA-1 of the machine's name. A process that ends normally
removes its own (a `with` block, or atexit for the FMU a sweep's worker keeps unpacked for all
its tasks). A process that is killed (SIGKILL, the OOM killer, a unit that crashes it) runs
neither, so every verb, when it starts, and every new directory first, removes the
directories of processes of this machine that no longer exist (remove_stale: os.kill(pid, 0),
POSIX): a killed verb leaves nothing past the next verb on that machine. A sweep's
LocalCluster workers get a directory of the sweep, owned by the command (TMPDIR and Dask's
local_directory point into it): whatever they leave there goes with it when the sweep ends
(sweep_directory), however the workers ended.

Only the standard library is used: every room may import this module.
"""
from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import socket
import stat
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

PREFIX = "gyrowheel-"
_KIND = re.compile(r"^[a-z]+(?:-[a-z]+)*$")
_NAME = re.compile(rf"^{PREFIX}([a-z]+(?:-[a-z]+)*)-([0-9]+)-([0-9a-f]{{8}})-")


def host_tag() -> str:
    """This machine in a directory's name: 8 hex digits of the SHA-1 of its host name."""
    return hashlib.sha1(socket.gethostname().encode()).hexdigest()[:8]


def prefix(kind: str) -> str:
    """The name a directory of `kind` (lower-case words joined by '-') made by this process
    begins with. Raises ValueError for any other kind."""
    if not isinstance(kind, str) or not _KIND.match(kind):
        raise ValueError(f"kind {kind!r}: expected lower-case letters (words joined by '-')")
    return f"{PREFIX}{kind}-{os.getpid()}-{host_tag()}-"


def new_directory(kind: str) -> Path:
    """A new private directory (mode 0700) of `kind` in the temporary directory, made after
    removing the stale ones there (remove_stale). The caller removes it."""
    remove_stale()
    return Path(tempfile.mkdtemp(prefix=prefix(kind)))


@contextlib.contextmanager
def temporary_directory(kind: str) -> Iterator[Path]:
    """new_directory(kind) for the block, removed with everything in it however the block ends."""
    path = new_directory(kind)
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


def owner(name: str) -> tuple[int, str] | None:
    """(pid, host tag) of a directory named by prefix(), None for any other name."""
    match = _NAME.match(name)
    return None if match is None else (int(match[2]), match[3])


def alive(pid: int) -> bool:
    """Whether a process `pid` exists on this machine (one of another user's counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OverflowError:  # no process has a pid that large
        return False
    return True


def remove_orphans(where: str | os.PathLike, pid_of: Callable[[str], int | None], kind: int) -> list[Path]:
    """Remove the entries of `where` left by processes of this machine that are gone: those whose
    name gives a pid (pid_of(name), None: not ours), not this process's, of no existing process,
    owned by this user and of file type `kind` (stat.S_IFDIR: removed with their content;
    stat.S_IFREG). Returns the entries removed; nothing where processes cannot be asked (not
    POSIX: there os.kill(pid, 0) is no question) or `where` cannot be read."""
    if os.name != "posix":
        return []
    uid, removed = os.getuid(), []
    try:
        entries = list(os.scandir(where))
    except OSError:
        return []
    for entry in entries:
        pid = pid_of(entry.name)
        if pid is None or pid == os.getpid() or alive(pid):
            continue
        try:
            info = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if stat.S_IFMT(info.st_mode) != kind or info.st_uid != uid:
            continue
        if kind == stat.S_IFDIR:
            shutil.rmtree(entry.path, ignore_errors=True)
        else:
            try:
                os.unlink(entry.path)
            except OSError:
                continue
        removed.append(Path(entry.path))
    return removed


def remove_stale(where: str | os.PathLike | None = None) -> list[Path]:
    """Remove the directories in `where` (default: the temporary directory) whose process is
    gone: named by prefix() with this machine's host tag, owned by this user, and no process of
    their pid exists (remove_orphans). Returns the directories removed. A directory of another
    machine (a temporary directory shared between machines) is left alone."""
    host = host_tag()

    def pid_of(name: str) -> int | None:
        found = owner(name)
        return found[0] if found is not None and found[1] == host else None

    return remove_orphans(tempfile.gettempdir() if where is None else where, pid_of, stat.S_IFDIR)


@contextlib.contextmanager
def sweep_directory() -> Iterator[Path]:
    """A directory for one sweep's LocalCluster (new_directory('sweep-run')), removed with
    everything in it when the block ends, and the stale directories with it."""
    path = new_directory("sweep-run")
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)
        remove_stale()
