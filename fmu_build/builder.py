"""ModelSpec -> FMU: generated C, modelDescription.xml, compile, zip.

build_spec_fmu serves every model (a wheel, a controller, any small CasADi system);
build_fmu is the wheel's path: scene -> ModelSpec -> build_spec_fmu.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import uuid
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from gyrowheel.fmu_build.codegen import (FUNCTION_FILE, generate_functions, generate_taylor, kernel_choice,
                                        write_model_desc)
from gyrowheel.fmu_build.compiler import (STANDARD, WARNINGS, compile_shared, fmi_headers_dir,
                                          optimisation_for)
from gyrowheel.fmu_build import platforms as _platforms
from gyrowheel.fmu_build.documentation import write_index_html
from gyrowheel.fmu_build.model_description import write_model_description
from gyrowheel.fmu_build.model_description3 import write_build_description, write_model_description3
from gyrowheel.fmu_build.runtime import UNITY_SOURCES, runtime_sources
from gyrowheel.errors import ArgumentError, ArgumentTypeError
from gyrowheel.output_files import check_output_file, replaced_atomically
from gyrowheel.scratch import new_directory
from gyrowheel.fmu_build.scene import Experiment, Scene, SceneError, check_scene, fmi_problem
from gyrowheel.fmu_build.variables import build_table
from gyrowheel.model.build import build_model
from gyrowheel.model.spec import ModelSpec

# the headers of each FMI version an FMU's sources/ carries (fmpy's copies: compiler.fmi_headers_dir)
FMI_HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
               3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}
BUILD_DESCRIPTION = "buildDescription.xml"  # an FMI 3 FMU's list of sources (FMI 3.0.2, section 2.5.1.2)
FMU_SUFFIX = ".fmu"  # an FMU's file name extension (FMI 2.0.4, section 2.1: "*.fmu")


@dataclass
class BuildResult:
    """What build_fmu / build_spec_fmu (and gyrowheel.build) built.

    fmu         path of the FMU written (the `output` given)
    spec        the model built: its ModelSpec (variables with units, effects, events, the
                CasADi Functions); left out of repr()
    sources     directory of the FMU's C sources (generated and runtime) in the kept build
                directory (build_dir/fmu/sources), or None when no build_dir was given (the
                temporary build directory is removed)
    identifier  the FMU's modelIdentifier (the scene's name): its binary and C prefix
    platforms   the platforms it carries binaries for, as FMI 3.0 platform tuples
                (fmu_build/platforms.py), e.g. ('x86_64-linux', 'aarch64-linux')
    fmi         its FMI version: 2 (FMI 2.0.4) or 3 (FMI 3.0.2); left out of repr()

    A BuildResult is os.PathLike: it stands for its FMU wherever a path of one does
    (gyrowheel.simulate, info, sweep, Ensemble). repr() shows the FMU, its identifier and
    platforms.
    """

    fmu: Path
    spec: ModelSpec = field(repr=False)
    sources: Path | None = field(repr=False)  # directory holding every C file of the FMU, if kept
    identifier: str
    platforms: tuple[str, ...] = ()  # the platforms (FMI 3.0 tuples) whose binaries it carries
    fmi: int = field(default=2, repr=False)  # its FMI version, 2 or 3

    def __fspath__(self) -> str:
        """The FMU's path: a BuildResult serves wherever a path of its FMU does (os.PathLike)."""
        return str(self.fmu)


# runtime files only an FMU with the Taylor kernel carries: the recurrences the kernel includes,
# solver taylor's step size rule and increments (without a kernel gw_solver_taylor.c includes
# neither), and the ensemble path's sources (gyrowheel.taylor.ensemble builds them from the FMU's
# sources/; not part of the FMU's unity build, compiled on their own they are empty)
TAYLOR_ONLY = {"gw_taylor_ops.h", "gw_solver_taylor_step.h", "gw_solver_taylor_increment.h",
               "gw_ensemble.c", "gw_ensemble.h", "gw_ensemble_passes.h", "gw_ensemble_ctx.h",
               "gw_ensemble_batch.h", "gw_ensemble_lib.c", "gw_fm_logexp.h"}
# runtime files gyrowheel compiles on the host from the installed runtime, never part of an FMU or
# an export: the ensemble's lane-count probe (gyrowheel.taylor.lanes)
HOST_ONLY = {"gw_cpu_lanes.c"}


def model_spec(scene: Scene) -> ModelSpec:
    """The wheel's ModelSpec of `scene`, checked first (check_scene: SceneError naming the
    field); ValueError for a combination only the model can refuse."""
    return _spec(check_scene(scene))


def _spec(scene: Scene) -> ModelSpec:
    """The ModelSpec of a checked scene."""
    return build_model(wheel=scene.wheel, initial=scene.initial, effects=scene.effects,
                       formulation=scene.formulation, name=scene.name, description=scene.description)


def check_output(output: str | Path, scene_file: str | Path | None = None) -> Path:
    """The FMU's output path, refused before anything is built when it cannot be an FMU: a name
    not ending in .fmu (FMI 2.0.4, section 2.1: an FMU is a zip file "*.fmu"; out.toml, noext),
    or the scene file itself (the FMU would overwrite the scene it is built from), or an existing
    path that is not a regular file, or a directory that does not exist
    (gyrowheel.output_files.check_output_file).
    Raises ArgumentError naming `output`."""
    if not isinstance(output, (str, os.PathLike)):
        raise ArgumentError(f"output must be a file path ending in {FMU_SUFFIX}, got {type(output).__name__}",
                            argument="output")
    output = Path(output)
    if scene_file is not None and output.exists() and Path(scene_file).exists() \
            and os.path.samefile(output, scene_file):
        raise ArgumentError(f"output {output}: is the scene file the FMU is built from; writing the FMU "
                            f"there would overwrite it: give a path ending in {FMU_SUFFIX}", argument="output")
    if output.suffix != FMU_SUFFIX:
        got = f"ends in {output.suffix!r}" if output.suffix else "has no extension"
        raise ArgumentError(f"output {output}: {got}; an FMU's file name ends in {FMU_SUFFIX} "
                            "(FMI 2.0.4, section 2.1)", argument="output")
    check_output_file(output, "output")  # a directory, a device, a FIFO, no such directory: refused
    return output


def check_fmi(fmi) -> int:
    """The FMI version `fmi` asks for: 2 or 3 (an int). Raises ArgumentTypeError naming `fmi`
    for a value that is not an int (text, a float, a bool), ArgumentError for another int,
    e.g. `fmi: must be 2 or 3 (the FMI version), got 4`."""
    if not isinstance(fmi, int) or isinstance(fmi, bool):
        raise ArgumentTypeError(f"fmi: must be the integer 2 or 3 (the FMI version), got {fmi!r} "
                                f"({type(fmi).__name__})", argument="fmi")
    problem = fmi_problem(fmi)
    if problem is not None:
        raise ArgumentError(f"fmi: {problem}", argument="fmi")
    return int(fmi)


def check_arrays(fmi: int, arrays) -> None:
    """ArgumentError naming `arrays` for arrays=False with an FMI 2 FMU: it has no array outputs
    to leave out (they are FMI 3's, variables.build_table)."""
    if fmi == 2 and arrays is not None and not arrays:
        raise ArgumentError("arrays: leaving out the array outputs is for FMI 3 FMUs; an FMI 2 FMU has none",
                            argument="arrays")


def _guid(*parts: str) -> str:
    digest = hashlib.sha256("\0".join(parts).encode()).digest()
    return "{" + str(uuid.UUID(bytes=digest[:16], version=5)) + "}"


def build_fmu(scene: Scene, output: str | Path, build_dir: str | Path | None = None,
              taylor: bool | None = None, platforms=None, fmi: int | None = None,
              arrays: bool | None = None) -> BuildResult:
    """Build the FMU of `scene` at `output`: the wheel's ModelSpec through build_spec_fmu.

    scene: a Scene, checked first by the scene file's rules (check_scene); output: the .fmu to
    write (check_output: a name ending in .fmu, not the scene's own file); build_dir: keep the
    generated C there (BuildResult.sources), else a temporary directory is used and removed;
    taylor: True: generate the Taylor kernel (solver taylor, the ensemble path) whatever the
    scene's solver; False: none (ArgumentError with solver taylor); None: the scene's [build]
    taylor, and without one the kernel where the solver is taylor, or auto and the model's
    operations allow it (codegen.kernel_choice); platforms: the platforms to carry binaries for
    (fmu_build/platforms.py parse_platforms: "all", "host", a comma-separated string or a list
    of FMI 3.0 platform tuples), overriding the scene's [build] platforms; None: the scene's
    [build] platforms, and without one the host only; fmi: the FMI version, 2 or 3, overriding
    the scene's [build] fmi; None: the scene's (default 2); arrays: an FMI 3 FMU's array
    outputs (True) or none (False), overriding the scene's [build] arrays; None: the scene's.
    Returns the BuildResult. Raises SceneError (the scene, naming the field; [build] arrays =
    false for an FMI 2 FMU), ArgumentError (output; platforms: an unknown platform, the valid
    ones listed; fmi: not 2 or 3; arrays False for an FMI 2 FMU), ArgumentTypeError (fmi not
    an int), and what build_spec_fmu raises.
    """
    scene = check_scene(scene)
    version = scene.fmi if fmi is None else check_fmi(fmi)
    check_arrays(version, arrays)
    if version == 2 and arrays is None and not scene.arrays:
        where = scene.file if scene.file is not None else f"scene {scene.name!r}"
        fix = ("fmi 2 was asked for (the --fmi option, the fmi argument) over the scene's [build] fmi = 3: "
               "ask for FMI 3" if scene.fmi == 3 else "build FMI 3 ([build] fmi = 3)")
        raise SceneError(f"{where}: [build] arrays: false leaves out an FMI 3 FMU's array outputs; an "
                         f"FMI 2 FMU has none: {fix} or remove the key")
    output = check_output(output, scene.file)
    wanted = _wanted_platforms(scene.platforms if platforms is None else platforms)  # before the model
    return build_spec_fmu(_spec(scene), output, scene.experiment, build_dir=build_dir,
                          keep=scene.outputs, source=scene.source, taylor=scene.taylor if taylor is None else taylor,
                          platforms=wanted, fmi=version,
                          arrays=scene.arrays if arrays is None else arrays)


def build_spec_fmu(spec: ModelSpec, output: str | Path, experiment: Experiment | None = None,
                   build_dir: str | Path | None = None, keep: list[str] | None = None,
                   source: str = "", taylor: bool | None = None, platforms=None, fmi: int = 2,
                   arrays: bool = True) -> BuildResult:
    """Build the FMI 2.0 or 3.0 FMU of any ModelSpec (a wheel's, a controller's: model/system.py),
    Co-Simulation and Model Exchange, its C sources included.

    experiment: DefaultExperiment and the solver settings' defaults (Experiment() if None);
    keep: the outputs to expose (None: all); source: text shipped in documentation/index.html
    (the scene file, the gains); taylor: the Taylor kernel of solver taylor and the ensemble
    path, by codegen.kernel_choice(experiment.solver, taylor, modes): True always, False never,
    None for solver taylor, and for solver auto where the model has no update events and its
    operations allow it;
    platforms: the platforms whose binaries the FMU carries (parse_platforms; None: the host
    only): the host's compiled by the host's C compiler, the others by zig (write_binaries);
    fmi: the FMI version, 2 (FMI 2.0.4: modelDescription.xml lists gw_fmu.c, binaries in
    linux64, win64, darwin64, ...) or 3 (FMI 3.0.2: the event indicators as variables,
    sources/buildDescription.xml lists gw_fmu3.c, binaries in platform-tuple folders); each
    FMU carries its own version's layer and headers only (runtime_sources); arrays: an FMI 3
    FMU has the array outputs x_state and contact_force (variables.build_table; FMI 2: none).
    Sources stay in build_dir if given (BuildResult.sources; None without build_dir).
    Raises ArgumentError for an output that is no .fmu name (check_output), an unknown
    platform (naming `platforms`), an fmi other than 2 and 3 (naming `fmi`) or arrays False with
    fmi 2 (naming `arrays`), ValueError for a bad table,
    gyrowheel.taylor.graph.TaylorUnsupportedError (a ValueError) for a kernel the ode's
    operations do not allow, CompileError if a C compiler fails (a cross build: naming the
    platform and the compiler's first error), MissingExtraError when a platform other than the
    host's needs zig and ziglang is not installed (before anything is generated).
    """
    experiment = (experiment or Experiment()).resolved()  # max_step as built: its default resolved
    fmi = check_fmi(fmi)
    check_arrays(fmi, arrays)
    output = check_output(output)
    wanted = _wanted_platforms(platforms)
    tmp = None
    if build_dir is None:
        tmp = new_directory("build")
        build_dir = tmp
    build_dir = Path(build_dir)
    root = build_dir / "fmu"
    if root.exists():
        shutil.rmtree(root)
    src = root / "sources"
    try:
        table = build_table(spec, experiment, keep, fmi, arrays)
        identifier = spec.name
        unity = UNITY_SOURCES[fmi]
        fns = generate_functions(spec, src, table)
        modes = any(e.action == "update" for e in spec.events)
        kernel = generate_taylor(fns, spec.name, src, wanted=kernel_choice(experiment.solver, taylor, modes))
        for f in runtime_sources(fmi):
            if f.name in HOST_ONLY:
                continue
            if f.name in TAYLOR_ONLY and isinstance(kernel, str):
                continue  # no kernel: nothing of solver taylor beyond the one-comment model file
            shutil.copy2(f, src / f.name)
        for h in FMI_HEADERS[fmi]:
            shutil.copy2(fmi_headers_dir() / h, src / h)
        funcs_c = (src / f"{FUNCTION_FILE}.c").read_text()
        guid = _guid(funcs_c, repr([(v.vr, v.name, v.kind, v.index, v.start) for v in table]),
                     repr(experiment), identifier, *(["FMI 3.0"] if fmi == 3 else []))
        write_model_desc(spec, table, experiment, identifier, guid, fns, src, kernel, unity=unity)
        # one translation unit: only fmi2* (fmi3*) symbols are global, whatever flags an importer uses
        write_binaries(src / unity, [src], root / "binaries", identifier, wanted, fmi)
        has_kernel = not isinstance(kernel, str)
        if fmi == 3:
            xml = write_model_description3(spec.name, experiment, table, identifier, guid, spec.description,
                                           taylor=has_kernel, reinit=modes)
            (src / BUILD_DESCRIPTION).write_text(write_build_description(identifier, unity))
        else:
            xml = write_model_description(spec.name, experiment, table, identifier, guid, [unity], spec.description,
                                          model_exchange=True, directional=True, taylor=has_kernel)
        (root / "modelDescription.xml").write_text(xml)
        (root / "documentation").mkdir(exist_ok=True)
        (root / "documentation" / "index.html").write_text(write_index_html(spec, experiment, table, identifier, guid,
                                                                                   source, fmi))
        _zip(root, output)
        return BuildResult(fmu=output, spec=spec, sources=src if tmp is None else None, identifier=identifier,
                           platforms=wanted, fmi=fmi)
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


def _wanted_platforms(platforms) -> tuple[str, ...]:
    """The platform names `platforms` asks for (parse_platforms), zig found if any is not the
    host's. Raises ArgumentError naming `platforms`, MissingExtraError naming gyrowheel[platforms]."""
    wanted = _platforms.parse_platforms(platforms)
    if any(n != _platforms.host_platform().name for n in wanted):
        _platforms.zig_command()
    return wanted


def write_binaries(source: Path, include_dirs: list[Path], binaries: Path, identifier: str,
                   names: tuple[str, ...], fmi: int = 2) -> dict[str, Path]:
    """Compile the unity source for each platform of `names` into
    binaries/<folder>/<identifier><extension>: for fmi 2, FMI 2.0.4 section 2.3's folders
    (linux64, win64, darwin64 for 64-bit x86, platform tuples for the others); for fmi 3, the
    platform tuple for every platform (FMI 3.0.2, section 2.5.1.4.1: x86_64-linux, ...).

    The host's binary is built by the host's C compiler (compile_shared), the others by zig with
    the same standard, warnings and optimisation, all at once. FMI 2 with both Mac platforms:
    darwin64 holds a universal binary of both slices (fmu_build/platforms.py); FMI 3 keeps
    them apart (x86_64-darwin, aarch64-darwin). Returns {name: library}.
    Raises CompileError (naming the platform for a cross build)."""
    host = _platforms.host_platform()
    libraries: dict[str, Path] = {}
    cross = []
    for name in names:
        p = host if name == host.name else _platforms.PLATFORMS[name]
        libraries[name] = binaries / (p.fmi2_dir if fmi == 2 else p.fmi3_dir) / f"{identifier}{p.extension}"
        if name != host.name:
            cross.append(p)
    if host.name in names:
        compile_shared(source, include_dirs, libraries[host.name])
    flags = [*STANDARD, *optimisation_for(source.parent), *WARNINGS]
    _platforms.cross_compile_all(cross, source, include_dirs, [libraries[p.name] for p in cross], flags)
    if fmi == 2 and all(n in names for n in _platforms.UNIVERSAL_DARWIN):
        intel, arm = (libraries[n] for n in _platforms.UNIVERSAL_DARWIN)
        thin = intel.with_name(intel.name + ".x86_64")
        intel.rename(thin)
        _platforms.write_universal([thin, arm], intel)
        thin.unlink()
    return libraries


def _zip(root: Path, output: Path) -> None:
    """Zip the FMU's tree at `output`, whole or not at all (gyrowheel.output_files: an output
    that is not a regular file, e.g. /dev/full, is refused, never renamed over)."""
    with replaced_atomically(output, "output") as part:
        with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as zf:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    zf.write(path, path.relative_to(root).as_posix())
