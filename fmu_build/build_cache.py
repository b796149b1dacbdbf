"""A content-addressed cache of the shared libraries compile_shared builds (opt-in).

With the environment variable GYROWHEEL_BUILD_CACHE set to a directory, compile_shared looks a
build up there before it runs the compiler, and stores what the compiler built.  Unset or empty:
no cache, every build compiles (the default).  The test suite sets it to a directory of its run
(tests/conftest.py), so tests that build the same FMU share one compile.

The key (sha256, hex) covers everything the library's bytes depend on:
  - the compiler: its resolved path and what `cc --version` prints;
  - the command: every argument but the source's and the output's path and the -I directories;
  - the source as the compiler sees it: `cc -E` with the same flags (every header included,
    every macro expanded), with the directories of its line markers dropped (a build in another
    directory of the same files hits; a file's name, line numbers and system-header flags stay).
An entry is one file, <key>.so.entry: the sha256 of the library (64 hex digits, a newline),
then the library.  It is written to a temporary file and renamed (os.replace), so a reader
never sees half an entry; an entry whose digest does not match its bytes (a damaged disk, a
copy cut short) is not used: the library is built again and the entry rewritten.  Builds of one
key wait for each other (an advisory lock, fcntl.flock, where the platform has it), so two
processes asking at once compile once.  The generated C's entries (gyrowheel.fmu_build.codegen_cache)
live in the same directory and are kept the same way (cached_entry).
"""
from __future__ import annotations

import functools
import hashlib
import os
import re
import shutil
import subprocess
import warnings
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

from gyrowheel.errors import ArgumentError

try:
    import fcntl
except ImportError:  # not POSIX: builds of one key may run at once (each result is still whole)
    fcntl = None

ENV = "GYROWHEEL_BUILD_CACHE"
SUFFIX = ".so.entry"
_LINE_MARKER = re.compile(rb'^(#\s*\d+\s+)"((?:[^"\\]|\\.)*)"', re.MULTILINE)
# the linker's arguments, left out of the preprocessor's call (they still enter the key): clang
# with -Werror refuses an argument a call does not use ("-lm: 'linker' input unused")
_LINK_ONLY = re.compile(r"^(-l.*|-L.*|-Wl,.*|-shared|-static-libgcc|-static)$")


class BuildCacheError(ArgumentError):
    """GYROWHEEL_BUILD_CACHE names a path that cannot be the cache: a file, or a directory that
    cannot be made.  Raised before anything is built."""


class BuildCacheWarning(UserWarning):
    """The cache could not store a build (a read-only directory, a full disk): the build itself
    is made and used all the same, only not kept."""


def cache_dir() -> Path | None:
    """The directory GYROWHEEL_BUILD_CACHE names (made when missing), or None when it is unset.

    Raises BuildCacheError when the path is not a directory or cannot be made."""
    value = os.environ.get(ENV, "")
    if not value:
        return None
    path = Path(value)
    if path.exists() and not path.is_dir():
        raise BuildCacheError(f"{ENV}={value!r}: not a directory; name a directory for the build cache, "
                              f"or unset it to build without one")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BuildCacheError(f"{ENV}={value!r}: the cache's directory cannot be made: "
                              f"{exc.strerror or exc}") from None
    return path


@functools.lru_cache(maxsize=16)
def _compiler_identity(path: str, size: int, mtime_ns: int) -> bytes:
    proc = subprocess.run([path, "--version"], capture_output=True)
    return path.encode() + b"\0" + proc.stdout + proc.stderr


def compiler_identity(cc: str) -> bytes:
    """The compiler's resolved path and its `--version` output (kept per binary and its mtime)."""
    found = shutil.which(cc) or cc
    real = os.path.realpath(found)
    st = os.stat(real)
    return _compiler_identity(real, st.st_size, st.st_mtime_ns)


def _strip_directories(preprocessed: bytes) -> bytes:
    """Line markers `# 12 "/build/dir/gw_fmu.c" 1` keep the file name only."""
    return _LINE_MARKER.sub(lambda m: m.group(1) + b'"' + m.group(2).rsplit(b"/", 1)[-1] + b'"', preprocessed)


def build_key(cc: str, flags: list[str], include_dirs: list[Path], source: Path, env: dict) -> str:
    """The cache key of `cc flags -I<include_dirs> source -o <anything>` (see the module's doc).

    flags: every argument but the source, the output (-o and its path) and the -I directories.
    Raises subprocess.CalledProcessError when the preprocessor fails (the caller compiles and
    reports the compiler's own message)."""
    includes = [f"-I{d}" for d in include_dirs]
    compile_flags = [f for f in flags if not _LINK_ONLY.match(f)]  # (clang -Werror: "unused" otherwise)
    pre = subprocess.run([cc, "-E", *compile_flags, *includes, str(source)], capture_output=True, env=env,
                         check=True).stdout
    digest = hashlib.sha256()
    for part in (compiler_identity(cc), "\0".join(flags).encode(), _strip_directories(pre)):
        digest.update(len(part).to_bytes(8, "little"))
        digest.update(part)
    return digest.hexdigest()


def _read_entry(entry: Path) -> bytes | None:
    """The bytes an entry holds, or None when it is missing, cannot be read or its digest does
    not match."""
    try:
        data = entry.read_bytes()
    except OSError:
        return None
    head, sep, library = data.partition(b"\n")
    if not sep or hashlib.sha256(library).hexdigest().encode() != head:
        return None
    return library


def _write_atomic(path: Path, data: bytes) -> None:
    part = path.with_name(f"{path.name}.{os.getpid()}.{id(data)}.part")
    try:
        part.write_bytes(data)
        os.replace(part, path)
    finally:
        part.unlink(missing_ok=True)


@contextmanager
def _locked(lock_path: Path):
    """The key's lock; in a cache that cannot be written (read-only), the lock file opened for
    reading where it exists (flock needs no write access), else none: such a cache is only read."""
    if fcntl is None:
        yield
        return
    try:
        lock = open(lock_path, "a")
    except OSError:
        try:
            lock = open(lock_path)
        except OSError:
            yield
            return
    with lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        yield


def cached_entry(directory: Path, key: str, suffix: str, make: Callable[[], bytes]) -> tuple[bytes, bool]:
    """The bytes of entry <key><suffix> in the cache directory when a sound one is there, else
    make()'s, then stored (digest line, bytes; written atomically).  Makers of one key wait for
    each other (the key's lock), so two processes asking at once make once.  (bytes, hit)."""
    entry = directory / f"{key}{suffix}"
    with _locked(directory / f"{key}.lock"):
        data = _read_entry(entry)
        if data is not None:
            return data, True
        data = make()
        try:
            _write_atomic(entry, hashlib.sha256(data).hexdigest().encode() + b"\n" + data)
        except OSError as exc:  # a read-only cache, a full disk: the build stands, only not kept
            warnings.warn(BuildCacheWarning(f"{ENV}={str(directory)!r}: cannot store this build in the cache "
                                            f"({exc.strerror or exc}); it was built and is used without it"),
                          stacklevel=2)
        return data, False


def cached_build(directory: Path, key: str, output: Path, build: Callable[[], None]) -> bool:
    """Write the library of `key` to `output`: from the cache directory when a sound entry is
    there, else by build() (which writes `output`), then stored.  True on a hit."""
    def make() -> bytes:
        build()
        return output.read_bytes()
    library, hit = cached_entry(directory, key, SUFFIX, make)
    if hit:
        _write_atomic(output, library)
    return hit
