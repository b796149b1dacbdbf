"""The platforms an FMU carries binaries for, and the cross compiler that builds them.

An FMU holds one shared library per platform under binaries/ (FMI 2.0.4, section 2.3 "FMU
Distribution"). FMI 2.0.4 names six folders: win32, win64, linux32, linux64, darwin32 and
darwin64, where 32 and 64 stand for 32- and 64-bit x86; "for any other platforms the platform
tuples defined in the FMI 3.0 Specification, 2.5.1.4.1" are used (aarch64-linux,
aarch64-darwin, aarch64-windows). FMI 3.0 FMUs use the tuples for every platform.

The host's binary is compiled by the host's C compiler (fmu_build/compiler.py); every other
platform by zig's C compiler (clang with the C libraries of every target, PyPI `ziglang`, the
optional part `gyrowheel[platforms]`), with the same language standard, warnings and
optimisation. A universal Mach-O (x86_64 and arm64 slices) goes to darwin64 when both Mac
platforms are built: darwin64 then still runs on 64-bit x86, and importers that look only in
darwin64 on Apple silicon (fmpy 0.3's FMI 2 loader) find an arm64 slice there too.
"""
from __future__ import annotations

import os
import platform as _platform
import re
import shutil
import struct
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from gyrowheel.errors import ArgumentError, ArgumentTypeError
from gyrowheel.extras import require
from gyrowheel.fmu_build.compiler import CompileError
from gyrowheel.scratch import temporary_directory


@dataclass(frozen=True)
class Platform:
    """One platform an FMU can carry a binary for.

    name        the FMI 3.0 platform tuple <arch>-<sys> (FMI 3.0, section 2.5.1.4.1), the name
                users give (`--platforms`, [build] platforms)
    fmi2_dir    its folder under binaries/ in an FMI 2 FMU (FMI 2.0.4, section 2.3)
    extension   the shared library's extension: .so, .dll, .dylib
    zig_target  zig's -target for it (Linux: the oldest glibc the binary needs, 2.17)
    description what it is, in words
    """

    name: str
    fmi2_dir: str
    extension: str
    zig_target: str
    description: str

    @property
    def fmi3_dir(self) -> str:
        """Its folder under binaries/ in an FMI 3 FMU: the platform tuple."""
        return self.name


PLATFORMS: dict[str, Platform] = {p.name: p for p in (
    Platform("x86_64-linux", "linux64", ".so", "x86_64-linux-gnu.2.17", "Linux on 64-bit x86"),
    Platform("aarch64-linux", "aarch64-linux", ".so", "aarch64-linux-gnu.2.17", "Linux on 64-bit ARM"),
    Platform("x86_64-windows", "win64", ".dll", "x86_64-windows-gnu", "Windows on 64-bit x86"),
    Platform("x86-windows", "win32", ".dll", "x86-windows-gnu", "Windows on 32-bit x86"),
    Platform("aarch64-windows", "aarch64-windows", ".dll", "aarch64-windows-gnu", "Windows on 64-bit ARM"),
    Platform("x86_64-darwin", "darwin64", ".dylib", "x86_64-macos", "macOS on 64-bit x86 (Intel)"),
    Platform("aarch64-darwin", "aarch64-darwin", ".dylib", "aarch64-macos", "macOS on Apple silicon"),
)}

# `all`: the platforms users run FMU importers on (Windows tools, Macs, Linux workstations and
# ARM rigs); x86-windows and aarch64-windows are built when named
ALL = ("x86_64-linux", "aarch64-linux", "x86_64-windows", "x86_64-darwin", "aarch64-darwin")
UNIVERSAL_DARWIN = ("x86_64-darwin", "aarch64-darwin")  # both built: darwin64 holds both slices

_ARCH = {"x86_64": "x86_64", "amd64": "x86_64", "aarch64": "aarch64", "arm64": "aarch64",
         "i386": "x86", "i686": "x86", "x86": "x86"}
_SYSTEM = {"Linux": ("linux", ".so"), "Windows": ("windows", ".dll"), "Darwin": ("darwin", ".dylib")}
_FMI2_X86 = {("x86_64", "linux"): "linux64", ("x86", "linux"): "linux32", ("x86_64", "windows"): "win64",
             ("x86", "windows"): "win32", ("x86_64", "darwin"): "darwin64", ("x86", "darwin"): "darwin32"}


def host_platform() -> Platform:
    """The platform this Python runs on, from platform.system() and platform.machine() (and the
    interpreter's pointer size: 32-bit Python on 64-bit x86 is x86). A platform outside
    PLATFORMS (e.g. riscv64-linux) gets its tuple as its folder, as FMI 2.0.4 says."""
    machine = _platform.machine().lower()
    arch = _ARCH.get(machine, machine)
    if arch == "x86_64" and sys.maxsize <= 2 ** 32:
        arch = "x86"
    system, extension = _SYSTEM.get(_platform.system(), (_platform.system().lower(), ".so"))
    name = f"{arch}-{system}"
    if name in PLATFORMS:
        return PLATFORMS[name]
    return Platform(name, _FMI2_X86.get((arch, system), name), extension, "", f"{system} on {arch}")


def parse_platforms(value, argument: str = "platforms") -> tuple[str, ...]:
    """The platform names `value` asks for, in PLATFORMS' order, each once.

    value: None or "host" (the host only), "all" (ALL), a comma-separated string or a list of
    names, where "host" and "all" may appear among the names. Raises ArgumentError naming
    `argument` with the valid names for an unknown name or an empty list, ArgumentTypeError (an
    ArgumentError) for a value of another type.
    """
    if value is None:
        return (host_platform().name,)
    if isinstance(value, str):
        names = [v.strip() for v in value.split(",")]
    elif isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
        names = [v.strip() for v in value]
    else:
        raise ArgumentTypeError(f"{argument}: expected platform names (a list of strings or one comma-separated "
                                f"string), got {type(value).__name__}; valid: {_valid()}", argument=argument)
    if not names or any(not n for n in names):
        what = "no platform named" if not names else "an empty platform name"
        raise ArgumentError(f"{argument}: {what} in {value!r}; valid: {_valid()}", argument=argument)
    wanted: set[str] = set()
    for n in names:
        if n == "all":
            wanted.update(ALL)
        elif n == "host":
            wanted.add(host_platform().name)
        elif n in PLATFORMS:
            wanted.add(n)
        else:
            raise ArgumentError(f"{argument}: unknown platform {n!r}; valid: {_valid()}", argument=argument)
    order = list(PLATFORMS)
    return tuple(sorted(wanted, key=lambda n: order.index(n) if n in order else -1))


def _valid() -> str:
    return ", ".join(["all", "host", *PLATFORMS])


def platform_of_folder(folder: str) -> str:
    """The platform tuple of a binaries/ folder of an FMI 2 or FMI 3 FMU (linux64 ->
    x86_64-linux, aarch64-linux -> aarch64-linux); a folder no standard names is returned as it is."""
    for p in PLATFORMS.values():
        if folder in (p.fmi2_dir, p.fmi3_dir):
            return p.name
    return {v: f"{a}-{s}" for (a, s), v in _FMI2_X86.items()}.get(folder, folder)


def zig_command(verb: str = "gyrowheel build --platforms") -> list[str]:
    """The command that runs zig (`python -m ziglang`, PyPI ziglang). Raises MissingExtraError
    naming the optional part 'platforms' when ziglang is not installed (gyrowheel.extras)."""
    require("platforms", verb)
    return [sys.executable, "-m", "ziglang"]


def first_error(output: str) -> str:
    """The compiler's first error line in `output` (clang: '<file>:<line>:<col>: error: ...'),
    else its first non-empty line."""
    lines = [line.strip() for line in output.splitlines() if line.strip()]
    for line in lines:
        if re.search(r"\berror\b", line):
            return line
    return lines[0] if lines else "(no output)"


# The runtime's x86-64 fast paths (the Taylor kernel's copy for AVX2 with FMA, c_src/gw_taylor.c)
# ask __builtin_cpu_supports; zig 0.17's compiler-rt answers it with a stub that reports no
# feature (lib/compiler_rt/fmv.zig), so a zig-built binary would carry a copy it never runs:
# it is built with the portable copy only (GW_NO_CLONES), the copy any x86-64 CPU runs.
ZIG_DEFINES = ["-DGW_NO_CLONES"]


# A cold build of Windows' C library takes 60-110 s on 2 cores; a compiler still running after
# this long is stuck (zig 0.17 spins without a word when its cache cannot be written)
ZIG_TIMEOUT = 1800.0


def zig_cache_dir() -> Path:
    """The directory zig 0.17 keeps its global cache in (the C libraries it builds per target):
    ZIG_GLOBAL_CACHE_DIR, else $XDG_CACHE_HOME/zig, else ~/.cache/zig."""
    if os.environ.get("ZIG_GLOBAL_CACHE_DIR"):
        return Path(os.environ["ZIG_GLOBAL_CACHE_DIR"])
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]) / "zig"
    return Path.home() / ".cache" / "zig"


def check_zig_cache() -> Path:
    """zig_cache_dir(), made if missing; CompileError when it cannot be made or written (zig
    itself then spins without a word instead of failing)."""
    cache = zig_cache_dir()
    try:
        cache.mkdir(parents=True, exist_ok=True)
        reason = None if os.access(cache, os.W_OK | os.X_OK) else ""
    except OSError as exc:
        reason = f" ({exc.strerror})"
    if reason is not None:
        raise CompileError(f"zig's cache directory {cache}{reason} cannot be written: set ZIG_GLOBAL_CACHE_DIR "
                           "to a writable directory")
    return cache


def cross_compile(target: Platform, source: Path, include_dirs: list[Path], output: Path,
                  flags: list[str]) -> Path:
    """Compile the unity source `source` into `output`, the shared library of `target`, with
    zig's C compiler and `flags` (the host's standard, warnings and optimisation).

    zig writes its by-products (Windows: an import library and a PDB) beside its output, so the
    library is linked in a directory of ours, under its own file name (a DLL's export table
    names it), and only it is copied to `output`. A Mach-O library's install name is
    @rpath/<its file name>, not the path it was linked at (which would differ on every build).
    Debug information is stripped (-s), as the host's binary carries none; ZIG_DEFINES say
    which copies of the runtime's machine-specific code zig's binaries hold.
    Raises CompileError naming the target, the command and the compiler's first error, with its
    whole output below."""
    zig = zig_command()
    check_zig_cache()
    with temporary_directory("zig") as tmp:
        built = Path(tmp) / output.name
        install_name = [f"-Wl,-install_name,@rpath/{output.name}"] if target.extension == ".dylib" else []
        cmd = [*zig, "cc", "-target", target.zig_target, "-shared", *([] if target.extension == ".dll" else ["-fPIC"]),
               *flags, *ZIG_DEFINES, "-s", *[f"-I{d}" for d in include_dirs], str(source), "-o", str(built), "-lm", *install_name]
        failed = f"cross build for {target.name} failed (zig cc -target {target.zig_target})"
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=ZIG_TIMEOUT,
                                  env={**os.environ, "TMPDIR": str(tmp)})
        except subprocess.TimeoutExpired:
            raise CompileError(f"{failed}: no result after {ZIG_TIMEOUT:.0f} s (zig's cache: "
                               f"{zig_cache_dir()})\n{' '.join(cmd)}") from None
        if proc.returncode != 0 or not built.is_file():
            out = proc.stdout + proc.stderr
            why = first_error(out) if out.strip() or proc.returncode >= 0 else \
                f"the compiler was ended by signal {-proc.returncode}"
            raise CompileError(f"{failed}: {why}\n{' '.join(cmd)}\n{out}")
        output.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, output)
    return output


def cross_compile_all(targets: list[Platform], source: Path, include_dirs: list[Path], outputs: list[Path],
                      flags: list[str]) -> list[Path]:
    """cross_compile each target into its output, as many at once as the machine has cores.
    The first failure (in `targets`' order) is raised after every compile has ended."""
    if not targets:
        return []
    pool = ThreadPoolExecutor(max_workers=max(1, min(len(targets), os.cpu_count() or 1)))
    try:
        futures = [pool.submit(cross_compile, t, source, include_dirs, o, flags) for t, o in zip(targets, outputs)]
        for f in futures:
            f.exception()  # wait: Ctrl-C lands here, in the main thread
    except BaseException:
        # interrupted: start no queued target (it would make a scratch directory while the
        # process ends); the running compilers got the same SIGINT from the terminal
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return [f.result() for f in futures]


# Mach-O universal ("fat") file: a big-endian header, one entry per slice, each slice aligned
# (mach-o/fat.h: FAT_MAGIC 0xcafebabe, struct fat_arch {cputype, cpusubtype, offset, size, align})
FAT_MAGIC = 0xCAFEBABE
MH_MAGIC_64 = 0xFEEDFACF
FAT_ALIGN = 14  # 2^14 = 16 KiB, the arm64 page size (x86_64's 4 KiB divides it)


def write_universal(slices: list[Path], output: Path) -> Path:
    """Write the universal Mach-O `output` holding the thin 64-bit Mach-O files `slices`, each
    at an offset aligned to 2^FAT_ALIGN after the header's page.
    Raises ValueError for a slice that is not a thin 64-bit Mach-O."""
    align = 1 << FAT_ALIGN
    head, body = struct.pack(">II", FAT_MAGIC, len(slices)), bytearray()
    for s in slices:
        data = Path(s).read_bytes()
        magic, cputype, cpusubtype = struct.unpack_from("<III", data, 0)
        if magic != MH_MAGIC_64:
            raise ValueError(f"{s}: not a thin 64-bit Mach-O file (magic {magic:#x})")
        body += bytes(-len(body) % align)  # the slice starts on a boundary
        head += struct.pack(">IIIII", cputype, cpusubtype, align + len(body), len(data), FAT_ALIGN)
        body += data
    output.write_bytes(head + bytes(align - len(head)) + body)
    return output
