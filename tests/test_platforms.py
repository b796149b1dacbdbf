"""The binaries of an FMU built for every platform of `all`, read with LIEF (ELF, PE, Mach-O):
each in the folder FMI 2.0.4 section 2.3 prescribes and for that folder's machine, exporting
exactly the fmi2 functions of fmi2Functions.h, depending on the system's C library only, and
needing no CPU feature it does not check for (docs/fmi.md, "Platforms"); and the names
gyrowheel info gives the folders of any FMU. The FMI 3.0 FMU of the same scene likewise: each
binary in its platform-tuple folder (FMI 3.0.2, section 2.5.1.4.1), exporting exactly the fmi3
functions of fmi3Functions.h. Running the binaries (qemu, Wine) is tests/test_platforms_run.py's;
macOS binaries are only read, here."""
from __future__ import annotations

import re
import subprocess
import zipfile
from pathlib import Path

import lief
import pytest

lief.logging.disable()  # its notes on the universal file's header, not the test's

import gyrowheel
from gyrowheel.fmu_build import compiler, platforms
from gyrowheel.fmu_build.compiler import fmi_headers_dir
from gyrowheel.fmu_build.platforms import ALL, PLATFORMS, platform_of_folder, zig_command

# the functions fmi2Functions.h declares (FMI 2.0.4, section 2.1.1), its `#define fmi2X fmi2FullName(fmi2X)`
FMI2 = frozenset(re.findall(r"^#define\s+(fmi2\w+)\s+fmi2FullName\(", (fmi_headers_dir() / "fmi2Functions.h").read_text(),
                            re.M))
# ... and those fmi3Functions.h declares (FMI 3.0.2, section 2.3), `#define fmi3X fmi3FullName(fmi3X)`
FMI3 = frozenset(re.findall(r"^#define\s+(fmi3\w+)\s+fmi3FullName\(", (fmi_headers_dir() / "fmi3Functions.h").read_text(),
                            re.M))
FUNCTIONS = {2: FMI2, 3: FMI3}
# zig's Mach-O linker (zig 0.17) also exports these two linker-defined symbols (the image's
# Mach-O header and its DSO handle: data, not functions); it drops -exported_symbols_list and
# refuses -unexported_symbol, so they cannot be kept out (docs/fmi.md, "Platforms")
MACHO_LINKER_SYMBOLS = frozenset({"__mh_dylib_header", "___dso_handle"})
FOLDERS = {"x86_64-linux": "linux64", "aarch64-linux": "aarch64-linux", "x86_64-windows": "win64",
           "x86_64-darwin": "darwin64", "aarch64-darwin": "aarch64-darwin"}
X86_HEADERS = re.compile(r'^# \d+ ".*/(immintrin|x86intrin|xmmintrin|emmintrin|pmmintrin|smmintrin|avxintrin|avx2intrin'
                         r'|cpuid)\.h"', re.M)


@pytest.fixture(scope="module")
def unpacked_fmu(request, tmp_path_factory):
    """unpacked_fmu(fmi): the all-platforms FMU of FMI version `fmi` (all_platforms_build,
    all_platforms_build_fmi3: built when first asked for), unpacked."""
    memo: dict[int, Path] = {}

    def _unpacked(fmi: int) -> Path:
        if fmi not in memo:
            built = request.getfixturevalue("all_platforms_build" if fmi == 2 else "all_platforms_build_fmi3")
            memo[fmi] = tmp_path_factory.mktemp(f"all_platforms_fmi{fmi}")
            with zipfile.ZipFile(built.fmu) as zf:
                zf.extractall(memo[fmi])
        return memo[fmi]
    return _unpacked


@pytest.fixture(scope="module")
def unpacked(unpacked_fmu) -> Path:
    return unpacked_fmu(2)


def _library(root: Path, platform: str, fmi: int = 2) -> Path:
    p = PLATFORMS[platform]
    return root / "binaries" / (p.fmi2_dir if fmi == 2 else p.fmi3_dir) / f"paper_earth{p.extension}"


def _macho_slices(path: Path) -> list:
    """The Mach-O binaries of a thin or universal file, each its own (FatBinary.take: a slice
    from .at() dies with its FatBinary). LIEF's objects point into the binary they came from:
    every binary below is kept in a variable while they are used."""
    fat = lief.MachO.parse(str(path))
    cpus = [fat.at(i).header.cpu_type for i in range(fat.size)]
    return [fat.take(cpu) for cpu in cpus]


def test_the_folders_are_those_of_fmi_2_0_4(all_platforms_build, unpacked):
    """linux64, win64, darwin64 for 64-bit x86, the FMI 3.0 tuple for aarch64 (FMI 2.0.4,
    section 2.3); gyrowheel info lists each by tuple and folder; fmpy's validation is clean;
    fmpy 0.3 lists only the folders it knows (FMPy #395, #884: no aarch64-linux)."""
    from fmpy import supported_platforms
    from fmpy.validation import validate_fmu

    assert len(FMI2) == 44
    assert {p: PLATFORMS[p].fmi2_dir for p in ALL} == FOLDERS
    files = sorted(str(f.relative_to(unpacked)) for f in (unpacked / "binaries").rglob("*") if f.is_file())
    assert files == sorted(str(_library(unpacked, p).relative_to(unpacked)) for p in ALL)
    assert {folder: platform_of_folder(folder) for folder in FOLDERS.values()} == {v: k for k, v in FOLDERS.items()}
    info = gyrowheel.info(all_platforms_build.fmu)
    assert [str(p) for p in info.platforms] == [f"{p} (binaries/{FOLDERS[p]})" for p in sorted(ALL)]
    assert validate_fmu(str(all_platforms_build.fmu)) == []
    assert {"linux64", "win64", "darwin64"} <= set(supported_platforms(str(all_platforms_build.fmu)))


def test_each_binary_is_built_for_its_folders_machine(unpacked):
    """ELF e_machine, PE Machine, Mach-O cputype; darwin64 is universal: exactly an x86_64 and an
    arm64 slice (so importers that look only in darwin64 find Apple silicon's too)."""
    assert lief.ELF.parse(str(_library(unpacked, "x86_64-linux"))).header.machine_type == lief.ELF.ARCH.X86_64
    assert lief.ELF.parse(str(_library(unpacked, "aarch64-linux"))).header.machine_type == lief.ELF.ARCH.AARCH64
    pe = lief.PE.parse(str(_library(unpacked, "x86_64-windows")))
    assert pe.header.machine == lief.PE.Header.MACHINE_TYPES.AMD64 and pe.header.characteristics_list  # a DLL
    assert pe.header.has_characteristic(lief.PE.Header.CHARACTERISTICS.DLL)
    cpu = lief.MachO.Header.CPU_TYPE
    assert [s.header.cpu_type for s in _macho_slices(_library(unpacked, "x86_64-darwin"))] == [cpu.X86_64, cpu.ARM64]
    thin = _library(unpacked, "aarch64-darwin")
    assert thin.read_bytes()[:4] == (platforms.MH_MAGIC_64).to_bytes(4, "little")  # not a universal file
    assert [s.header.cpu_type for s in _macho_slices(thin)] == [cpu.ARM64]


@pytest.mark.parametrize("fmi", (2, 3))
def test_each_binary_exports_exactly_the_fmi_functions(unpacked_fmu, fmi):
    """ELF: the dynamic symbols it defines; PE: the export table (named after the DLL); Mach-O:
    the export trie of every slice (each slice the same): exactly the functions of its FMI
    version's header. No resolver (an ELF IFUNC, a `.resolver` symbol, a Mach-O
    stub-and-resolver export), no helper symbol."""
    unpacked, functions = unpacked_fmu(fmi), FUNCTIONS[fmi]
    for platform in ("x86_64-linux", "aarch64-linux"):
        elf = lief.ELF.parse(str(_library(unpacked, platform, fmi)))
        exported = [s for s in elf.dynamic_symbols if s.exported]
        assert {s.name for s in exported} == functions, platform
        assert all(s.type == lief.ELF.Symbol.TYPE.FUNC for s in exported), platform
        assert not [s.name for s in elf.dynamic_symbols
                    if s.type == lief.ELF.Symbol.TYPE.GNU_IFUNC or "resolver" in s.name], platform
    pe = lief.PE.parse(str(_library(unpacked, "x86_64-windows", fmi)))  # kept: its export table points into it
    export = pe.get_export()
    assert export.name == "paper_earth.dll"
    assert sorted(e.name for e in export.entries) == sorted(functions) and not any(e.is_forwarded for e in export.entries)
    slices = [s for p in ("x86_64-darwin", "aarch64-darwin") for s in _macho_slices(_library(unpacked, p, fmi))]
    resolver = (lief.MachO.ExportInfo.FLAGS.STUB_AND_RESOLVER, lief.MachO.ExportInfo.FLAGS.STATIC_RESOLVER)
    for macho in slices:
        names = {s.name for s in macho.exported_symbols}
        assert names == {f"_{f}" for f in functions} | MACHO_LINKER_SYMBOLS, macho.header.cpu_type
        assert not [s.name for s in macho.exported_symbols
                    if s.has_export_info and any(s.export_info.has(f) for f in resolver)]


@pytest.mark.parametrize("fmi", (2, 3))
def test_each_binary_needs_the_c_library_only(unpacked_fmu, fmi):
    """Linux: libc and libm (glibc 2.17 or later); Windows: KERNEL32 and the Universal C
    Runtime's api-ms-win-crt-* (no libgcc, no libwinpthread); macOS: libSystem, and its install
    name @rpath/<file>, not the path it was linked at."""
    unpacked = unpacked_fmu(fmi)
    for platform in ("x86_64-linux", "aarch64-linux"):
        elf = lief.ELF.parse(str(_library(unpacked, platform, fmi)))
        assert set(elf.libraries) <= {"libc.so.6", "libm.so.6"}, platform
    pe = lief.PE.parse(str(_library(unpacked, "x86_64-windows", fmi)))  # kept: what it returns points into it
    imports = [i.name for i in pe.imports]
    assert imports and all(n.lower() == "kernel32.dll" or re.fullmatch(r"api-ms-win-crt-[a-z]+-l1-1-0\.dll", n)
                           for n in imports), imports
    slices = [s for p in ("x86_64-darwin", "aarch64-darwin") for s in _macho_slices(_library(unpacked, p, fmi))]
    kind = lief.MachO.LoadCommand.TYPE
    for macho in slices:
        commands = list(macho.commands)
        dylibs = [(c.command, c.name) for c in commands if c.command in (kind.LOAD_DYLIB, kind.ID_DYLIB)]
        assert dylibs == [(kind.ID_DYLIB, "@rpath/paper_earth.dylib"), (kind.LOAD_DYLIB, "/usr/lib/libSystem.B.dylib")]


def test_fmi3_folders_are_the_platform_tuples(all_platforms_build_fmi3, unpacked_fmu):
    """The FMI 3.0 FMU: one binary per platform of `all` in binaries/<platform tuple> (FMI 3.0.2,
    section 2.5.1.4.1), each built for its tuple's machine; both Mac binaries thin (the
    universal darwin64 file is FMI 2's); gyrowheel info lists each tuple as its own folder;
    fmpy's validation is clean."""
    from fmpy.validation import validate_fmu

    assert len(FMI3) == 75
    unpacked = unpacked_fmu(3)
    files = sorted(str(f.relative_to(unpacked)) for f in (unpacked / "binaries").rglob("*") if f.is_file())
    assert files == sorted(f"binaries/{p}/paper_earth{PLATFORMS[p].extension}" for p in ALL)
    assert lief.ELF.parse(str(_library(unpacked, "x86_64-linux", 3))).header.machine_type == lief.ELF.ARCH.X86_64
    assert lief.ELF.parse(str(_library(unpacked, "aarch64-linux", 3))).header.machine_type == lief.ELF.ARCH.AARCH64
    pe = lief.PE.parse(str(_library(unpacked, "x86_64-windows", 3)))
    assert pe.header.machine == lief.PE.Header.MACHINE_TYPES.AMD64
    assert pe.header.has_characteristic(lief.PE.Header.CHARACTERISTICS.DLL)
    cpu = lief.MachO.Header.CPU_TYPE
    for platform, machine in (("x86_64-darwin", cpu.X86_64), ("aarch64-darwin", cpu.ARM64)):
        thin = _library(unpacked, platform, 3)
        assert thin.read_bytes()[:4] == (platforms.MH_MAGIC_64).to_bytes(4, "little"), platform
        assert [s.header.cpu_type for s in _macho_slices(thin)] == [machine], platform
    info = gyrowheel.info(all_platforms_build_fmi3.fmu)
    assert info.fmi_version == "3.0"
    assert [str(p) for p in info.platforms] == [f"{p} (binaries/{p})" for p in sorted(ALL)]
    assert validate_fmu(str(all_platforms_build_fmi3.fmu)) == []


def test_the_cross_builds_ask_for_no_cpu_feature(tmp_path, monkeypatch):
    """The flags of every build (the host's and zig's) choose no machine (-march, -mcpu, -mavx2,
    ...): x86 binaries run on every 64-bit x86, their faster paths taken after a CPU check."""
    commands = []

    def run(cmd, **kwargs):  # zig's command, recorded; its output made as zig would
        commands.append(cmd)
        Path(cmd[cmd.index("-o") + 1]).write_bytes(b"")
        return subprocess.CompletedProcess(cmd, 0, "", "")
    monkeypatch.setattr(platforms.subprocess, "run", run)
    source = tmp_path / "gw_fmu.c"
    source.write_text("")
    flags = [*compiler.STANDARD, *compiler.OPTIMISE, *compiler.OPTIMISE_LARGE, *compiler.WARNINGS]
    for name in PLATFORMS:
        platforms.cross_compile(PLATFORMS[name], source, [tmp_path], tmp_path / name / "m.so", flags)
    for cmd in commands:
        assert not [a for a in cmd if re.match(r"-m(arch|cpu|tune|avx|fma|sse|neon|fpu)", a)], cmd
    assert [cmd[cmd.index("-target") + 1] for cmd in commands] == [p.zig_target for p in PLATFORMS.values()]


def test_the_zig_builds_have_no_code_for_a_cpu_they_do_not_check(all_platforms_build):
    """The FMU's source preprocessed as zig builds it for each target (zig cc -E, the build's
    flags and platforms.ZIG_DEFINES): the ARM targets include no x86 intrinsics header and no
    code for an x86 target (target attributes, CPU checks); the x86-64 targets hold the portable
    copy only (zig's runtime cannot check the CPU).  The host's gcc build, which can, holds the
    copy for AVX2 with FMA and its check: what these patterns find where the code is."""
    sources = all_platforms_build.sources
    flags = [*compiler.STANDARD, *compiler.optimisation_for(sources)]
    machine_code = re.compile(r"__attribute__\s*\(\(\s*target(_clones)?\s*\(|__builtin_cpu_supports")

    def preprocessed(command: list[str]) -> str:
        r = subprocess.run([*command, *flags, "-E", f"-I{sources}", str(sources / "gw_fmu.c")],
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        return r.stdout

    for platform in ("aarch64-linux", "aarch64-darwin", "x86_64-windows", "x86_64-darwin"):
        text = preprocessed([*zig_command(), "cc", "-target", PLATFORMS[platform].zig_target, *platforms.ZIG_DEFINES])
        if platform.startswith("aarch64"):
            assert X86_HEADERS.search(text) is None, platform
        assert machine_code.search(text) is None, platform
        assert "fmi2DoStep" in text and "gw_taylor_attempt" in text, platform  # the unity source, Taylor too
    if platforms.host_platform().name == "x86_64-linux":
        host = preprocessed([compiler.compiler()])
        assert re.search(r"__attribute__\s*\(\(\s*target\s*\(", host) and "__builtin_cpu_supports" in host


def test_info_names_the_platforms_of_any_fmu(earth_fmu, tmp_path):
    """Folders as other exporters write them (the Reference FMUs' set, and one no standard
    names): each by its FMI 3.0 tuple, an unknown folder by its own name."""
    folders = {"win32": ".dll", "win64": ".dll", "linux64": ".so", "darwin64": ".dylib", "aarch64-darwin": ".dylib",
               "x86_64-windows": ".dll", "riscv64-linux": ".so"}
    other = tmp_path / "other.fmu"
    with zipfile.ZipFile(earth_fmu) as src, zipfile.ZipFile(other, "w") as dst:
        for name in src.namelist():
            if not name.startswith("binaries/"):
                dst.writestr(name, src.read(name))
        for folder, extension in folders.items():
            dst.writestr(f"binaries/{folder}/paper_earth{extension}", b"")
    assert [str(p) for p in gyrowheel.info(other).platforms] == [
        "aarch64-darwin (binaries/aarch64-darwin)", "riscv64-linux (binaries/riscv64-linux)",
        "x86-windows (binaries/win32)", "x86_64-darwin (binaries/darwin64)", "x86_64-linux (binaries/linux64)",
        "x86_64-windows (binaries/win64)", "x86_64-windows (binaries/x86_64-windows)"]
