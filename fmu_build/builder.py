"""ModelSpec -> FMU: generated C, modelDescription.xml, compile, zip.

build_spec_fmu serves every model (a wheel, a controller, any small CasADi system);
build_fmu is the wheel's path: scene -> ModelSpec -> build_spec_fmu.
"""
from __future__ import annotations

import hashlib
import shutil
import tempfile
import uuid
import zipfile
from dataclasses import dataclass
from pathlib import Path

from gyrowheel.fmu_build.codegen import FUNCTION_FILE, generate_functions, generate_taylor, write_model_desc
from gyrowheel.fmu_build.compiler import UNITY_SOURCE, compile_shared, fmi_headers_dir
from gyrowheel.fmu_build.documentation import write_index_html
from gyrowheel.fmu_build.model_description import write_model_description
from gyrowheel.fmu_build.runtime import runtime_sources
from gyrowheel.fmu_build.scene import Experiment, Scene
from gyrowheel.fmu_build.variables import build_table
from gyrowheel.model.build import build_model
from gyrowheel.model.spec import ModelSpec

FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
PLATFORM = "linux64"


@dataclass
class BuildResult:
    fmu: Path
    spec: ModelSpec
    sources: Path  # directory holding every C file of the FMU
    identifier: str

    def __fspath__(self) -> str:
        """The FMU's path: a BuildResult serves wherever a path of its FMU does (os.PathLike)."""
        return str(self.fmu)


# runtime files only an FMU with the Taylor kernel carries: the recurrences the kernel includes,
# and the ensemble path's sources (gyrowheel.taylor.ensemble builds them from the FMU's sources/; not part
# of the FMU's unity build, compiled on their own they are empty)
TAYLOR_ONLY = {"gw_taylor_ops.h", "gw_ensemble.c", "gw_ensemble.h", "gw_ensemble_passes.h",
               "gw_ensemble_ctx.h", "gw_ensemble_batch.h", "gw_ensemble_lib.c", "gw_fm_logexp.h"}


def model_spec(scene: Scene) -> ModelSpec:
    return build_model(wheel=scene.wheel, initial=scene.initial, effects=scene.effects,
                       formulation=scene.formulation, name=scene.name, description=scene.description)


def _guid(*parts: str) -> str:
    digest = hashlib.sha256("\0".join(parts).encode()).digest()
    return "{" + str(uuid.UUID(bytes=digest[:16], version=5)) + "}"


def build_fmu(scene: Scene, output: str | Path, build_dir: str | Path | None = None,
              taylor: bool = False) -> BuildResult:
    """Build the FMU of `scene` at `output`: the wheel's ModelSpec through build_spec_fmu.

    taylor: also generate the Taylor kernel (solver taylor, the ensemble path) when the scene's
    solver is not taylor already."""
    return build_spec_fmu(model_spec(scene), output, scene.experiment, build_dir=build_dir,
                          keep=scene.outputs, source=scene.source, taylor=taylor)


def build_spec_fmu(spec: ModelSpec, output: str | Path, experiment: Experiment | None = None,
                   build_dir: str | Path | None = None, keep: list[str] | None = None,
                   source: str = "", taylor: bool = False) -> BuildResult:
    """Build the FMI 2.0 FMU of any ModelSpec (a wheel's, a controller's: model/system.py).

    experiment: DefaultExperiment and the solver settings' defaults (Experiment() if None);
    keep: the outputs to expose (None: all); source: text shipped in documentation/index.html
    (the scene file, the gains); taylor: generate the Taylor kernel of solver taylor and the
    ensemble path even if experiment.solver is not "taylor" (only those FMUs carry it).
    Sources stay in build_dir if given. Raises ValueError for a bad table,
    gyrowheel.taylor.graph.TaylorUnsupportedError (a ValueError) for a kernel the ode's
    operations do not allow, CompileError if the C compiler fails.
    """
    experiment = experiment or Experiment()
    output = Path(output)
    tmp = None
    if build_dir is None:
        tmp = tempfile.TemporaryDirectory(prefix="gyrowheel-")
        build_dir = tmp.name
    build_dir = Path(build_dir)
    root = build_dir / "fmu"
    if root.exists():
        shutil.rmtree(root)
    src = root / "sources"
    try:
        table = build_table(spec, experiment, keep)
        identifier = spec.name
        fns = generate_functions(spec, src, table)
        kernel = generate_taylor(fns, spec.name, src, wanted=taylor or experiment.solver == "taylor")
        for f in runtime_sources():
            if f.name in TAYLOR_ONLY and isinstance(kernel, str):
                continue  # no kernel: nothing of solver taylor beyond the one-comment model file
            shutil.copy2(f, src / f.name)
        for h in FMI_HEADERS:
            shutil.copy2(fmi_headers_dir() / h, src / h)
        funcs_c = (src / f"{FUNCTION_FILE}.c").read_text()
        guid = _guid(funcs_c, repr([(v.vr, v.name, v.kind, v.index, v.start) for v in table]),
                     repr(experiment), identifier)
        write_model_desc(spec, table, experiment, identifier, guid, fns, src, kernel)
        # one translation unit: only fmi2* symbols are global, whatever flags an importer uses
        compile_shared(src / UNITY_SOURCE, [src], root / "binaries" / PLATFORM / f"{identifier}.so")
        xml = write_model_description(spec.name, experiment, table, identifier, guid, [UNITY_SOURCE], spec.description,
                                      model_exchange=True, directional=True,
                                      taylor=not isinstance(kernel, str))
        (root / "modelDescription.xml").write_text(xml)
        (root / "documentation").mkdir(exist_ok=True)
        (root / "documentation" / "index.html").write_text(write_index_html(spec, experiment, table, identifier, guid,
                                                                                   source))
        output.parent.mkdir(parents=True, exist_ok=True)
        _zip(root, output)
        return BuildResult(fmu=output, spec=spec, sources=src, identifier=identifier)
    finally:
        if tmp is not None:
            tmp.cleanup()


def _zip(root: Path, output: Path) -> None:
    tmp = output.with_suffix(output.suffix + ".part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in sorted(root.rglob("*")):
            if path.is_file():
                zf.write(path, path.relative_to(root).as_posix())
    tmp.replace(output)
