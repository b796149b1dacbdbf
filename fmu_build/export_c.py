"""`gyrowheel export-c`: a scene's model as plain C with a documented C API (docs/c_api.md).

The export is the FMU's C without the FMI layer: the CasADi-generated model (gw_funcs.c,
model_desc.c: the same files an FMU of the scene holds), the simulation core (c_src/ minus
gw_fmi2_*), and the C API (c_src/export/): a header <model>.h whose functions are all prefixed
with the model's name, one translation unit <model>.c, a CMakeLists.txt and two examples
(the scene's experiment as CSV; a fixed-step real-time loop).  Layout of DIR:

    <model>.h  gyrowheel_api.h  <model>.c  CMakeLists.txt  README.md
    src/        the model, the core and the API implementation (parts of <model>.c)
    examples/   main.c, realtime.c
    cmake/      zig.cmake: a toolchain file cross-compiling for the FMU platforms
                (gyrowheel.fmu_build.platforms.PLATFORMS) with zig's C compiler

The README names one command per platform for each route (cross_commands).

Only <model>_* functions are external, so two exported models link into one program.
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

from gyrowheel.errors import GyrowheelError
from gyrowheel.fmu_build import c_names
from gyrowheel.fmu_build.builder import HOST_ONLY, TAYLOR_ONLY, _guid, _spec
from gyrowheel.fmu_build.runtime import EXPORT_DIR, fmi_version_of, runtime_sources
from gyrowheel.fmu_build.codegen import (FUNCTION_FILE, generate_functions, generate_taylor, kernel_choice,
                                        write_model_desc)
from gyrowheel.fmu_build.compiler import STANDARD, WARNINGS, CompileError, compiler, optimisation_for
from gyrowheel.fmu_build.platforms import PLATFORMS, Platform
from gyrowheel.fmu_build.scene import Scene, check_scene
from gyrowheel.fmu_build.variables import Variable, build_table
from gyrowheel.model.spec import ModelSpec
from gyrowheel.scratch import temporary_directory

API_SOURCES = ("gw_capi.h", "gw_capi.c", "gw_capi_names.c", "gw_capi_state.c")
TOOLCHAIN = "cmake/zig.cmake"  # the export's CMake toolchain file (c_src/export/cmake/zig.cmake)
MARKER = ".gyrowheel-export"
KINDS = ("PARAMETER", "INITIAL", "INPUT", "STATE", "OUTPUT", "EVENT")  # gyrowheel_kind order
MACRO_LETTER = {"PARAMETER": "P", "INITIAL": "I", "INPUT": "U", "STATE": "X", "OUTPUT": "Y", "EVENT": "E"}


class ExportError(GyrowheelError, ValueError):
    """The scene or the output directory cannot be exported to; the message says why (an error
    about the directory begins with `output` and has argument 'output')."""


@dataclass
class ExportResult:
    """What export_c (gyrowheel.export_c) wrote.

    directory   the export's directory (the `out_dir` given)
    identifier  the model's name: the prefix of the C API (<identifier>_create, ...) and of
                <identifier>.h / <identifier>.c
    files       every file the export wrote, relative to directory (POSIX paths, sorted): the
                list kept in its .gyrowheel-export marker, removed by the next export into it
    spec        the model exported: its ModelSpec (variables with units, effects); left out of
                repr()
    """

    directory: Path
    identifier: str
    files: list[str]  # relative to directory
    spec: ModelSpec = field(repr=False)


@dataclass
class Row:
    """One row of the C API's names/units table."""

    name: str
    unit: str
    description: str
    default: float | None = None
    y_index: int = -1  # outputs: the index in the model's y


def check_identifier(name: str) -> str:
    """The model name as the prefix of C names (fmu_build/c_names.py: an ASCII C identifier,
    no C or C++ keyword, reserved identifier or standard header's name); ExportError if not."""
    try:
        return c_names.check(name)
    except c_names.ModelNameError as exc:
        raise ExportError(str(exc)) from None


# the ensemble library's files (gyrowheel.taylor.ensemble), never part of <model>.c
ENSEMBLE_ONLY = frozenset(n for n in TAYLOR_ONLY if n.startswith("gw_ensemble")) | {"gw_fm_logexp.h"} | HOST_ONLY


def core_sources(kernel: bool) -> list[Path]:
    """The simulation core <model>.c includes: every c_src file but the FMI layers (gw_fmi2_*,
    gw_fmu.c, gw_fmi3_*, gw_fmu3.c: runtime.fmi_version_of) and the ensemble library's (ENSEMBLE_ONLY); with kernel False (a scene without the
    Taylor kernel) none of solver taylor's either (builder.TAYLOR_ONLY), as its FMU."""
    leave = ENSEMBLE_ONLY | (frozenset() if kernel else TAYLOR_ONLY)
    return [f for f in runtime_sources()
            if fmi_version_of(f.name) is None and f.name not in leave]


def api_table(spec: ModelSpec, table: list[Variable]) -> dict[str, list[Row]]:
    """The C API's rows per kind, in index order (inputs, parameters, ... as in the model's
    vectors; outputs as the scene exposes them, in the FMU's order)."""
    units = {v.state_index: v.quantity for v in table if v.state_index >= 0}

    def rows(quantities):
        return [Row(q.name, q.unit, q.description, q.start) for q in quantities]

    outputs = [Row(v.name, v.quantity.unit, v.quantity.description,
                   y_index=v.out_index if v.kind == "start" else v.index)
               for v in table if v.kind in ("start", "output")]
    return {
        "PARAMETER": rows(spec.parameters),
        "INITIAL": rows(spec.starts),
        "INPUT": rows(spec.inputs),
        "STATE": [Row(name, units[i].unit if i in units else "1",
                      units[i].description if i in units else "internal continuous state")
                  for i, name in enumerate(spec.x_names)],
        "OUTPUT": outputs,
        "EVENT": [Row(e.flag.name, "", f"{e.flag.description} (event {e.name}: "
                  f"{'ends the run' if e.action == 'terminate' else 'flagged, the run goes on'})")
                  for e in spec.events],
    }


def c_string(text: str) -> str:
    """A C string literal: printable ASCII as is, everything else as octal UTF-8 bytes."""
    out = []
    for byte in text.encode("utf-8"):
        ch = chr(byte)
        if ch in '"\\':
            out.append("\\" + ch)
        elif 32 <= byte < 127:
            out.append(ch)
        else:
            out.append(f"\\{byte:03o}")
    return '"' + "".join(out) + '"'


def _comment(text: str) -> str:
    return " ".join(text.replace("*/", "* /").split())


def _macro_name(name: str) -> str:
    return re.sub(r"\W", "_", name)


def header_macros(model: str, rows: dict[str, list[Row]], scene: Scene) -> str:
    """Sizes, the scene's experiment and one index macro per variable (<MODEL>_<letter>_<name>)."""
    M = model.upper()
    exp = scene.experiment
    lines = [f"#define {M}_NP {len(rows['PARAMETER'])} /* parameters */",
             f"#define {M}_NI {len(rows['INITIAL'])} /* initial values */",
             f"#define {M}_NU {len(rows['INPUT'])} /* inputs */",
             f"#define {M}_NX {len(rows['STATE'])} /* continuous states */",
             f"#define {M}_NY {len(rows['OUTPUT'])} /* outputs */",
             f"#define {M}_NE {len(rows['EVENT'])} /* events */",
             "",
             "/* the scene's experiment [s] (the examples run it) */",
             f"#define {M}_START_TIME {exp.start_time!r}",
             f"#define {M}_STOP_TIME {exp.stop_time!r}",
             f"#define {M}_OUTPUT_INTERVAL {exp.output_interval!r}"]
    titles = {"PARAMETER": "parameters: index, [unit] description (scene's value)",
              "INITIAL": "initial values: index, [unit] description (scene's value)",
              "INPUT": "inputs: index, [unit] description (default)",
              "STATE": "continuous states: index, [unit]",
              "OUTPUT": "outputs: index, [unit] description",
              "EVENT": "events: index, description"}
    for kind in KINDS:
        if not rows[kind]:
            continue
        lines += ["", f"/* {titles[kind]} */"]
        seen: set[str] = set()
        for i, row in enumerate(rows[kind]):
            macro = f"{M}_{MACRO_LETTER[kind]}_{_macro_name(row.name)}"
            if macro in seen:
                raise ExportError(f"two {kind.lower()} names give the same C macro {macro}")
            seen.add(macro)
            unit = f"[{row.unit}] " if row.unit else ""
            default = f" ({row.default!r})" if row.default is not None and kind != "STATE" else ""
            lines.append(f"#define {macro} {i} /* {_comment(unit + row.description + default)} */")
    return "\n".join(lines)


def capi_desc(rows: dict[str, list[Row]], scene: Scene, model: str) -> str:
    """src/capi_desc.c: GWC_TABLE (c_src/export/gw_capi.h) and the scene's start time."""
    arrays = []
    names = {kind: f"gwc_rows_{kind.lower()}" for kind in KINDS}
    for kind in KINDS:
        body = ",\n".join(f"    {{{c_string(r.name)}, {c_string(r.unit)}, {c_string(r.description)}}}"
                          for r in rows[kind]) or '    {"", "", ""}'
        arrays.append(f"static const gyrowheel_variable {names[kind]}[] = {{\n{body}\n}};")
    ys = ", ".join(str(r.y_index) for r in rows["OUTPUT"]) or "0"
    counts = ", ".join(str(len(rows[k])) for k in KINDS)
    return f"""/* Generated by gyrowheel export-c from model {model!r}; do not edit.
 * The C API's names/units table; part of the single translation unit {model}.c. */
#ifndef GW_UNITY_BUILD
typedef int gw_unity_build_part; /* compiled on its own this file is empty: see {model}.c */
#else

#include "gw_capi.h"

#define GWC_START_TIME {scene.experiment.start_time!r}

{chr(10).join(arrays)}

static const int gwc_output_y[] = {{{ys}}};

static const gwc_table GWC_TABLE = {{
    {{{", ".join(names[k] for k in KINDS)}}},
    {{{counts}}},
    gwc_output_y,
}};

#endif /* GW_UNITY_BUILD */
"""


def force_kinds(spec) -> dict[str, str]:
    """examples/realtime.c's flags of the scene's non-conservative forces (ModelSpec.force_kinds):
    which terms of the energy balance energy + dissipated_energy - actuator_work it needs."""
    kinds = set(spec.force_kinds)
    return {"dissipative_forces": str(int("dissipative" in kinds)), "actuator_forces": str(int("actuator" in kinds)),
            "other_forces": str(int(bool(kinds - {"dissipative", "actuator"})))}


@dataclass(frozen=True)
class CrossCommand:
    """How to build an export's examples for one platform (README.md, docs/c_api.md).

    platform  the Platform (gyrowheel.fmu_build.platforms.PLATFORMS)
    cmake     the one shell command configuring and building with CMake and cmake/zig.cmake,
              into build-<platform name>/
    cc        the one shell command building examples/main.c with zig's C compiler (PyPI
              ziglang), without CMake, into <model>_example (.exe on Windows)
    """

    platform: Platform
    cmake: str
    cc: str


def cross_commands(model: str) -> list[CrossCommand]:
    """The commands that cross-compile the export of `model` for every platform of PLATFORMS, in
    its order: the same zig targets (zig_target: Linux's against glibc 2.17) and the same
    C99 as an FMU's binaries.  The real-time example needs POSIX clock_nanosleep: the CMake
    route builds it for Linux targets only; the cc commands build examples/main.c."""
    out = []
    for p in PLATFORMS.values():
        build = f"build-{p.name}"
        exe = f"{model}_example{'.exe' if p.extension == '.dll' else ''}"
        out.append(CrossCommand(
            p, f"cmake -S . -B {build} -DCMAKE_TOOLCHAIN_FILE={TOOLCHAIN} -DZIG_TARGET={p.zig_target} "
               f"-DCMAKE_BUILD_TYPE=Release && cmake --build {build}",
            f"python -m ziglang cc -target {p.zig_target} -std=c99 -O2 -I. examples/main.c {model}.c -lm -o {exe}"))
    return out


def cross_section(model: str) -> str:
    """README.md's per-platform commands (cross_commands) as Markdown."""
    lines = []
    for c in cross_commands(model):
        lines += ["", f"{c.platform.description} (`{c.platform.name}`):", "", "```sh", c.cmake, c.cc, "```"]
    return "\n".join(lines[1:])


def render(template: str, values: dict[str, str]) -> str:
    """@key@ placeholders (as CMake's configure_file); an unknown one left over is an error."""
    for key, value in values.items():
        template = template.replace(f"@{key}@", value)
    left = re.findall(r"@[A-Za-z_]+@", template)
    if left:
        raise ExportError(f"template placeholder {left[0]} has no value")
    return template


def _previous(out_dir: Path) -> list[str] | None:
    """What is in the way of an export into out_dir: None for a new or empty directory, the
    files of a previous export (its marker's list) for one. Raises ExportError naming `output`
    (export_c's out_dir) for anything else. Nothing is changed."""
    if out_dir.exists() and not out_dir.is_dir():
        raise ExportError(f"output {out_dir}: exists and is not a directory; the export is a directory "
                          "(choose a new or empty one)", argument="output")
    if not out_dir.is_dir() or not any(out_dir.iterdir()):
        return None
    marker = out_dir / MARKER
    if not marker.is_file():
        raise ExportError(f"output {out_dir}: not empty and not a gyrowheel export; choose a new or empty "
                          "directory", argument="output")
    try:
        previous = json.loads(marker.read_text())["files"]
        if not isinstance(previous, list) or not all(isinstance(p, str) for p in previous):
            raise TypeError
    except (ValueError, KeyError, TypeError, OSError):
        raise ExportError(f"output {out_dir}: its {MARKER} is unreadable; remove the directory to export "
                          "into it", argument="output") from None
    return previous


def _commit(stage: Path, out_dir: Path, previous: list[str] | None) -> None:
    """Put the whole export written in `stage` into out_dir by renames (gyrowheel.output_files'
    rule, for a directory): a new out_dir is the stage renamed; into an empty one or a previous
    export, its files move in, a previous export's own files (its marker's list) move out and
    are removed, the files the user added stay. On a failure every move is undone: out_dir is
    as it was."""
    if not out_dir.exists():
        stage.rename(out_dir)
        return
    old = out_dir.absolute().with_name(f".{out_dir.absolute().name}.old-{os.getpid()}")
    shutil.rmtree(old, ignore_errors=True)
    moved: list[tuple[Path, Path]] = []  # (where a file is now, where it was)

    def move(src: Path, dest: Path) -> None:
        dest.parent.mkdir(parents=True, exist_ok=True)
        src.rename(dest)
        moved.append((dest, src))
    try:
        root = out_dir.resolve()
        for rel in [*(previous or []), MARKER]:
            path = out_dir / rel
            if root in path.resolve().parents and (path.is_file() or path.is_symlink()):
                move(path, old / rel)
        for item in sorted(stage.rglob("*")):
            if not item.is_dir():
                rel = item.relative_to(stage)
                if (out_dir / rel).exists():  # a file of the user's where the export now writes one
                    move(out_dir / rel, old / rel)
                move(item, out_dir / rel)
    except BaseException:
        for now, was in reversed(moved):
            with contextlib.suppress(OSError):
                now.rename(was)
        raise
    finally:
        shutil.rmtree(old, ignore_errors=True)
        shutil.rmtree(stage, ignore_errors=True)


def _files(out_dir: Path) -> set[str]:
    """Every file under out_dir (relative, POSIX), the export's marker excepted."""
    return {p.relative_to(out_dir).as_posix() for p in out_dir.rglob("*") if p.is_file() and p.name != MARKER}


def compile_check(unity: Path) -> None:
    """Compile <model>.c as a user would, strictly (C99, all warnings as errors), at the level
    an FMU build of the same C takes (compiler.optimisation_for: GYROWHEEL_OPTIMISE when set,
    OptimiseLevelError for a bad one)."""
    with temporary_directory("export") as tmp:
        cmd = [compiler(), *STANDARD, *WARNINGS, *optimisation_for(unity.parent), "-c", str(unity), "-o",
               str(Path(tmp) / "model.o")]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise CompileError(f"{' '.join(cmd)}\n{proc.stdout}{proc.stderr}")


def export_c(scene: Scene, out_dir: str | Path, check: bool = True, scene_file: str = "") -> ExportResult:
    """Write the C export of `scene` into out_dir (see the module docstring).

    scene: a Scene, checked first by the scene file's rules (check_scene); out_dir: the
    directory (gyrowheel.export_c's `output`): new, empty, or a previous export (its files are
    replaced, the user's kept); check: probe the model name against the C library's
    declarations first, and compile <model>.c strictly afterwards (CompileError if it fails);
    scene_file: the scene file's name, quoted in the header and README.
    Returns the ExportResult. Raises SceneError (the scene, naming the field), ExportError (a
    model name C cannot take; a directory that cannot be used, naming `output`), ValueError
    (bad output table), CompileError.
    """
    scene = check_scene(scene)
    model = check_identifier(scene.name)
    if check:  # a name the C library declares (system, clock, FILE, ...): before anything is written
        try:
            c_names.probe(model, compiler())
        except c_names.ModelNameError as exc:
            raise ExportError(str(exc)) from None
    out_dir = Path(out_dir)
    previous = _previous(out_dir)
    # written whole into a hidden sibling and compiled there; only then put in out_dir's place
    stage = out_dir.absolute().with_name(f".{out_dir.absolute().name}.part-{os.getpid()}")
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        if stage.exists():
            shutil.rmtree(stage)
        stage.mkdir()
        files, spec = _write(scene, model, stage, scene_file, check)
        _commit(stage, out_dir, previous)
    except OSError as exc:  # the stage or out_dir could not be written: named as the output
        shutil.rmtree(stage, ignore_errors=True)
        raise ExportError(f"output {out_dir}: cannot write: {exc.strerror or exc}", argument="output") from None
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    return ExportResult(directory=out_dir, identifier=model, files=files, spec=spec)


def _write(scene: Scene, model: str, out_dir: Path, scene_file: str, check: bool) -> tuple[list[str], ModelSpec]:
    """Write the export of a checked scene into the empty directory out_dir, its marker last,
    and with check compile it strictly; returns its files (relative, POSIX) and the model."""
    spec = _spec(scene)
    exp = scene.experiment
    table = build_table(spec, exp, scene.outputs)
    src = out_dir / "src"
    fns = generate_functions(spec, src)
    modes = any(e.action == "update" for e in spec.events)
    kernel = generate_taylor(fns, model, src, wanted=kernel_choice(exp.solver, scene.taylor, modes))  # as the FMU's
    guid = _guid((src / f"{FUNCTION_FILE}.c").read_text(),
                 repr([(v.vr, v.name, v.kind, v.index, v.start) for v in table]), repr(exp), model)
    write_model_desc(spec, table, exp, model, guid, fns, src, kernel)
    written = set()
    for f in core_sources(kernel=not isinstance(kernel, str)):
        shutil.copy2(f, src / f.name)
        written.add(f"src/{f.name}")
    for name in API_SOURCES:
        shutil.copy2(EXPORT_DIR / name, src / name)
        written.add(f"src/{name}")
    rows = api_table(spec, table)
    (src / "capi_desc.c").write_text(capi_desc(rows, scene, model))
    values = {"model": model, "MODEL": model.upper(), "guid": guid,
              "scene_file": scene_file or f"scene {model!r}",
              "description": _comment(spec.description).rstrip(".") + ".",
              "macros": header_macros(model, rows, scene), "cross": cross_section(model), **force_kinds(spec)}
    outputs = {f"{model}.h": "model.h.in", f"{model}.c": "model.c.in", "CMakeLists.txt": "CMakeLists.txt.in",
               "examples/main.c": "examples/main.c", "examples/realtime.c": "examples/realtime.c",
               "README.md": "README.md.in"}
    for target, template in outputs.items():
        path = out_dir / target
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(render((EXPORT_DIR / template).read_text(), values))
    shutil.copy2(EXPORT_DIR / "gyrowheel_api.h", out_dir / "gyrowheel_api.h")
    (out_dir / TOOLCHAIN).parent.mkdir(exist_ok=True)
    shutil.copy2(EXPORT_DIR / TOOLCHAIN, out_dir / TOOLCHAIN)
    written |= {"src/capi_desc.c", "gyrowheel_api.h", TOOLCHAIN, *outputs}
    files = sorted(_files(out_dir) | written)
    (out_dir / MARKER).write_text(json.dumps({"model": model, "files": files}, indent=1) + "\n")
    if check:
        compile_check(out_dir / f"{model}.c")
    return files, spec
