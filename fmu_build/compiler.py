"""Compile the FMU's C sources into binaries/<platform>/<identifier>.so (linux64 in FMI 2,
x86_64-linux in FMI 3).

The FMU is one translation unit (c_src/gw_fmu.c, or gw_fmu3.c for FMI 3, includes the
generated model, the core and the FMI layer), so the build is a single compiler call with the
flags a strict user would use: C99, -Wall -Wextra -Wpedantic -Werror, portable optimisation
(no -march=native).  No flag hides symbols: every internal function is static, and only the
fmi2* (fmi3*) functions (default visibility through FMI2_Export, FMI3_Export) are exported.
"""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import fmpy

from gyrowheel.errors import GyrowheelError
from gyrowheel.fmu_build import build_cache
from gyrowheel.fmu_build.runtime import UNITY_SOURCES
from gyrowheel.scratch import temporary_directory

STANDARD = ["-std=c99"]
WARNINGS = ["-Wall", "-Wextra", "-Wpedantic", "-Werror"]
OPTIMISE = ["-O2", "-fno-math-errno"]
# GCC's -O2 time grows faster than linearly with the size of one function, and CasADi writes each
# function as one straight-line body: the Gyrover controller's 4.6 MB of generated C (gain schedule
# of 45 designs, with its Jacobians) took 199 s at -O2, 40 s at -O1 (13 s at -O0) on the 2-core
# CI machine, and its closed-loop run took the same 2.6 s with either binary (results identical).
# Past this size the FMU is compiled at -O1.
LARGE_SOURCE_BYTES = 1_500_000
OPTIMISE_LARGE = ["-O1", "-fno-math-errno"]
# GYROWHEEL_OPTIMISE="-O1" (say) compiles every build at that level instead: a quicker build when
# the binary's speed does not matter (the test suite sets -O1: GCC's -O2 takes most of a build's
# time, 34 s against 9 s for euler_disk_end's 1.3 MB of generated C).  Without -ffast-math the
# levels compute the same IEEE operations in the same order (C99: no contraction into FMA; the
# Taylor kernel, which fuses, asks GCC for its FMA pass at any level: c_src/gw_taylor.c), so -O1
# gives -O2's results bit for bit (tests/test_fmu_sources.py checks a run's).
OPTIMISE_ENV = "GYROWHEEL_OPTIMISE"
LEVELS = ("-O0", "-O1", "-O2", "-O3", "-Os", "-Og")
UNITY_SOURCE = UNITY_SOURCES[2]  # an FMI 2 FMU's only <SourceFiles> entry


class CompileError(GyrowheelError, RuntimeError):
    """The C compiler failed; the message carries its output."""


class OptimiseLevelError(CompileError):
    """GYROWHEEL_OPTIMISE names no level of LEVELS: a setting of the user's, refused before the
    compiler runs (the CLI reports it as bad input, not as a failed compilation)."""


def fmi_headers_dir() -> Path:
    """FMI 2.0 and 3.0 headers shipped with fmpy, not a copy in the repository (docs/architecture.md)."""
    return Path(fmpy.__file__).parent / "c-code"


def compiler() -> str:
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        raise CompileError("no C compiler found: install gcc (Debian: apt-get install gcc) or set CC")
    return cc


def _run(cmd: list[str]) -> None:
    """Run the compiler; its own temporary files (gcc's cc*.s) go into a directory of ours
    (gyrowheel.scratch), so a build killed while compiling leaves none past the next verb."""
    with temporary_directory("cc") as tmp:
        proc = subprocess.run(cmd, capture_output=True, text=True, env=_env(tmp))
    if proc.returncode != 0:
        raise CompileError(f"{' '.join(cmd)}\n{proc.stdout}{proc.stderr}")


def _env(tmp) -> dict:
    return {**os.environ, "TMPDIR": str(tmp)}


def optimisation_for(source_dir: Path) -> list[str]:
    """OPTIMISE, or OPTIMISE_LARGE when one C file in `source_dir` exceeds LARGE_SOURCE_BYTES;
    the level GYROWHEEL_OPTIMISE names instead, when it is set and not empty.

    Raises OptimiseLevelError (a CompileError) when GYROWHEEL_OPTIMISE is not one of LEVELS."""
    level = os.environ.get(OPTIMISE_ENV, "")
    if level:
        if level not in LEVELS:
            raise OptimiseLevelError(f"{OPTIMISE_ENV}={level!r}: not an optimisation level; use one of "
                               f"{', '.join(LEVELS)} (unset: {OPTIMISE[0]})")
        return [level, *OPTIMISE[1:]]
    largest = max((f.stat().st_size for f in Path(source_dir).glob("*.c")), default=0)
    return OPTIMISE_LARGE if largest > LARGE_SOURCE_BYTES else OPTIMISE


def compile_shared(source: Path, include_dirs: list[Path], output: Path,
                   extra_flags: list[str] | None = None) -> Path:
    """Compile the unity source (gw_fmu.c, or gw_fmu3.c for FMI 3) into the shared library `output`.

    Raises CompileError with the compiler's output. The optimisation level is optimisation_for()
    the source's directory (the unity build includes the generated C beside it).  With
    GYROWHEEL_BUILD_CACHE set, a library built before from the same preprocessed source, flags
    and compiler is copied from that cache instead (gyrowheel.fmu_build.build_cache)."""
    cc = compiler()
    output.parent.mkdir(parents=True, exist_ok=True)
    flags = [*STANDARD, "-shared", "-fPIC", *optimisation_for(source.parent), *WARNINGS, *(extra_flags or [])]
    includes = [f"-I{d}" for d in include_dirs]
    libraries = ["-lm", "-static-libgcc"]
    compile_ = lambda: _run([cc, *flags, *includes, str(source), "-o", str(output), *libraries])  # noqa: E731
    directory = build_cache.cache_dir()
    if directory is None:
        compile_()
        return output
    try:
        with temporary_directory("cc") as tmp:
            key = build_cache.build_key(cc, [*flags, *libraries], include_dirs, source, _env(tmp))
    except subprocess.CalledProcessError:
        compile_()  # the compiler's own message, from the compile
        return output
    build_cache.cached_build(directory, key, output, compile_)
    return output
