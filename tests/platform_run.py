"""Run an FMU's binaries for other platforms on this machine: tests/platform_driver/fmu_driver.c
(a minimal FMI 2.0 Co-Simulation master) or fmu3_driver.c (FMI 3.0) built for each platform,
and the emulators that run it.

x86_64-linux runs natively (the driver built by gcc); aarch64-linux under qemu-user with the
aarch64 C library of Debian's libc6-arm64-cross; x86_64-windows under Wine with a private
prefix; qemu-x86_64 -cpu qemu64 runs the x86_64 binary on a CPU without AVX2 and FMA.  Every
tool missing fails with the Debian package to install (`make test` installs them as root).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import fmpy
import pytest

ROOT = Path(__file__).resolve().parent.parent
DRIVERS = {2: ROOT / "tests" / "platform_driver" / "fmu_driver.c",  # each FMI version's master
           3: ROOT / "tests" / "platform_driver" / "fmu3_driver.c"}
FMI_HEADERS = Path(fmpy.__file__).resolve().parent / "c-code"
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-O2"]
AARCH64_ROOT = Path("/usr/aarch64-linux-gnu")  # Debian libc6-arm64-cross: qemu-aarch64 -L
AARCH64_LOADER = AARCH64_ROOT / "lib" / "ld-linux-aarch64.so.1"
DEBIAN_WINE64 = Path("/usr/lib/wine/wine64")  # Debian's wine64: the loader `wine` runs 64-bit programs with
DRIVER_PLATFORMS = ("x86_64-linux", "aarch64-linux", "x86_64-windows")


def build_drivers(out: Path, fmi: int = 2) -> dict[str, Path]:
    """The driver of FMI version `fmi` (DRIVERS) built for DRIVER_PLATFORMS into `out`, all at
    once: x86_64-linux by gcc, the others by zig's C compiler
    (gyrowheel.fmu_build.platforms.zig_command), each with the strict flags; a warning is an
    error.  zig's builds are stripped (-s) as the FMU's are (platforms.cross_compile): zig
    builds a target's C library once per set of such flags, so the drivers link the libraries
    the all-platforms FMU's build left in zig's cache (Windows': 51 s of CPU when built again
    unstripped).  Returns {platform: executable}."""
    from gyrowheel.fmu_build.platforms import PLATFORMS, zig_command

    zig = zig_command()
    source = DRIVERS[fmi]
    # fmi3FunctionTypes.h declares two callbacks without a prototype, void (*)(), which zig's
    # clang reports under -Wpedantic (c_src/gw_fmi3.h turns it off around its include)
    quiet = ["-Wno-strict-prototypes"] if fmi == 3 else []
    common = [*STRICT, *quiet, f"-I{FMI_HEADERS}", str(source)]
    exes = {"x86_64-linux": out / source.stem, "aarch64-linux": out / f"{source.stem}_aarch64",
            "x86_64-windows": out / f"{source.stem}.exe"}
    commands = {
        "x86_64-linux": ["gcc", *common, "-ldl", "-o", str(exes["x86_64-linux"])],
        # glibc 2.17 (the FMU's aarch64 binary's target) keeps dlopen in libdl
        "aarch64-linux": [*zig, "cc", "-target", PLATFORMS["aarch64-linux"].zig_target, *common, "-s", "-ldl",
                          "-o", str(exes["aarch64-linux"])],
        "x86_64-windows": [*zig, "cc", "-target", PLATFORMS["x86_64-windows"].zig_target, *common, "-s",
                           "-o", str(exes["x86_64-windows"])],
    }
    with ThreadPoolExecutor(max_workers=len(commands)) as pool:
        done = dict(zip(commands, pool.map(lambda c: subprocess.run(c, capture_output=True, text=True),
                                           commands.values())))
    for name, r in done.items():
        assert r.returncode == 0 and not (r.stdout + r.stderr).strip(), \
            f"{source.name} for {name}: {' '.join(commands[name])}\n{r.stdout}{r.stderr}"
    return exes


def require(tool: str, package: str) -> str:
    """The path of `tool`, or the test fails naming the Debian package that has it."""
    path = shutil.which(tool)
    if path is None:
        pytest.fail(f"{tool} is missing: install Debian's {package} (make test installs it as root)")
    return path


def require_aarch64_libc() -> None:
    if not AARCH64_LOADER.exists():
        pytest.fail(f"{AARCH64_LOADER} is missing: install Debian's libc6-arm64-cross "
                    "(make test installs it as root)")


def wine_command() -> str:
    """wine64 when on the PATH, else Debian's `wine`, which starts a 64-bit program with
    /usr/lib/wine/wine64 (package wine64); fails naming the Debian packages when either is missing."""
    wine64 = shutil.which("wine64") or (DEBIAN_WINE64 if DEBIAN_WINE64.exists() else None)
    wine = shutil.which("wine")
    if wine64 is None or (wine is None and not shutil.which("wine64")):
        pytest.fail("wine or wine64 is missing: install Debian's wine and wine64 (make test installs them as root)")
    return shutil.which("wine64") or wine


def windows_path(path: Path) -> str:
    """`path` as Wine's programs see it: drive Z: is the Unix root."""
    return "Z:" + str(path).replace("/", "\\")


@dataclass
class Run:
    """What a driver printed: rows[i] = [time, value...] at each communication point (the
    last one at the fall when the FMU ended the run), fall = the fall's time or None,
    terminated = the FMU ended the run (FMI 2: fmi2Terminated after fmi2Discard; FMI 3:
    terminateSimulation), early = FMI 3's earlyReturn with it, seconds = the wall time of the
    run (with its emulator)."""
    rows: list[list[float]]
    fall: float | None
    terminated: bool
    seconds: float
    stderr: str
    early: bool = False


def parse(stdout: str) -> tuple[list[list[float]], float | None, bool, bool]:
    """(rows, fall, terminated, early) of a driver's output: `# discard terminated=0|1 time=T`
    (fmu_driver) or `# terminate early=0|1 time=T` (fmu3_driver) ends a run at T."""
    rows, fall, terminated, early = [], None, False, False
    for line in stdout.splitlines():
        if line.startswith(("# discard", "# terminate")):
            fields = dict(f.split("=") for f in line.split()[2:])
            terminated = fields.get("terminated", "1") == "1"
            fall, early = float(fields["time"]), fields.get("early") == "1"
        elif line.strip():
            rows.append([float(v) for v in line.split()])
    return rows, fall, terminated, early


def run_quietly(command: list[str], env: dict | None = None, timeout: float = 300):
    """Run `command` with its output in files, not pipes: Wine's service processes (started by
    the first program of a wineserver, living as long as it does) inherit the output handles,
    and a pipe would stay open until they end.  Returns (exit status, stdout, stderr, seconds)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        status = subprocess.run(command, stdin=subprocess.DEVNULL, stdout=out, stderr=err, timeout=timeout,
                                env=None if env is None else {**os.environ, **env}).returncode
        seconds = time.perf_counter() - start
        out.seek(0)
        err.seek(0)
        return status, out.read(), err.read(), seconds


def run_driver(command: list[str], env: dict | None = None, timeout: float = 300) -> Run:
    """Run a driver (with its emulator in front); asserts exit 0."""
    status, stdout, stderr, seconds = run_quietly(command, env, timeout)
    assert status == 0, f"{' '.join(command)} exited {status}\n{stderr}\n{stdout[-2000:]}"
    rows, fall, terminated, early = parse(stdout)
    return Run(rows, fall, terminated, seconds, stderr, early)
