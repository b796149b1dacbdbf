"""What an FMU says about itself, as data: gyrowheel.info(fmu) -> FmuInfo.

From modelDescription.xml (FMI 2.0.4, section 2.2; FMI 3.0.2, section 2.4: the model's
attributes, the DefaultExperiment, the ModelVariables with their types) and from the archive:
the platforms under binaries/ (FMI 2.0.4, section 2.3; FMI 3.0.2, section 2.5.1.4; named by
their FMI 3.0 platform tuples), whether it carries
sources/, and for an FMU built by gyrowheel its effects (documentation/index.html) and whether it has the Taylor kernel (the ensemble path).
str(info) is the text `gyrowheel info` prints; info.as_dict() what `gyrowheel info --json` prints.
open_fmu is where simulate, info and sweep open an FMU and say what is wrong with one.
"""
from __future__ import annotations

import html
import os
import re
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path

from gyrowheel.arguments import existing_file, lookup_name
from gyrowheel.errors import FmuError, UnknownNameError

TAYLOR_HEADER = "sources/gw_taylor_model.h"  # holds GW_TL_NVAR when the model has the Taylor kernel
MODEL_SOURCE = "sources/model_desc.c"  # GW_MODEL (fmu_build/codegen.py write_model_desc) ...
MODES_ABSENT = b".upd = {0, 0},"  # ... with this line when the model has no update events
FMU_WHAT = "a path to an FMU (.fmu) or the gyrowheel.BuildResult of one"
FMI_VERSIONS = ("2.0", "3.0")  # the fmiVersion attributes gyrowheel reads and runs


def binary_path(md) -> str:
    """The archive member of the FMU's Co-Simulation binary for this platform: binaries/
    <folder>/<modelIdentifier><extension>, the folder FMI 2.0.4 section 2.3 names for an FMI 2
    FMU (linux64), the platform tuple for an FMI 3 FMU (x86_64-linux: FMI 3.0.2, section
    2.5.1.4.1)."""
    from fmpy import platform, platform_tuple, sharedLibraryExtension

    folder = platform_tuple if md.fmiVersion.startswith("3.") else platform
    return f"binaries/{folder}/{md.coSimulation.modelIdentifier}{sharedLibraryExtension}"


@dataclass(frozen=True)
class FmuFile:
    """An FMU that open_fmu checked: its path, fmpy's ModelDescription, the archive's file names."""

    path: Path
    model_description: object
    names: tuple[str, ...]


def open_fmu(fmu, argument: str = "fmu", *, to_run: bool = False, versions: tuple[str, ...] = FMI_VERSIONS,
             reader: str = "") -> FmuFile:
    """Check that `fmu` is an FMI 2.0 or 3.0 FMU gyrowheel can read, and with to_run also run
    here; the one place simulate, info and sweep open an FMU and say what is wrong with it.

    fmu: a path (str or os.PathLike: a gyrowheel.BuildResult is one). argument: the name of the
    calling function's argument, which the errors carry. to_run: also require Co-Simulation
    (FMI 2.0.4, section 4; FMI 3.0.2, section 4) and a binary for this platform (binary_path:
    binaries/linux64/<modelIdentifier>.so in FMI 2, binaries/x86_64-linux/... in FMI 3).
    versions: the fmiVersion values the caller takes (FMI_VERSIONS, or fewer), reader: what
    the caller is, as the refusal of a version gyrowheel reads but the caller does not names it
    (`FMI 3.0 is not supported: a sweep runs FMI 2.0 FMUs`).
    Returns an FmuFile. Raises FmuError, the message beginning with the file: no such FMU file,
    a directory, a scene / SSP system instead of an FMU, not a zip archive, no or unreadable
    modelDescription.xml, another FMI version (`FMI 1.0 is not supported: gyrowheel runs FMI
    2.0 and 3.0 FMUs`), a modelDescription.xml that breaks its version's schema (its first
    problem), no Co-Simulation, no binary for this platform (`no binary for linux64; the FMU
    has binaries for win64`); ArgumentTypeError for a value that is no path; FmuError naming
    how to build it for a gyrowheel.Scene.
    """
    import xml.etree.ElementTree as ET

    from fmpy import read_model_description

    if not isinstance(fmu, (str, os.PathLike)):
        from gyrowheel.fmu_build.scene import Scene
        if isinstance(fmu, Scene):
            raise FmuError(f"{argument}: a gyrowheel.Scene, not an FMU; build its FMU first: "
                           "gyrowheel.build(scene)", argument=argument)
    path = existing_file(fmu, argument, "fmu", what=FMU_WHAT, error=FmuError)
    try:
        with zipfile.ZipFile(path) as zf:
            names = tuple(zf.namelist())
            xml = zf.read("modelDescription.xml") if "modelDescription.xml" in names else None
    except (zipfile.BadZipFile, OSError) as exc:
        reason = "not a zip archive" if isinstance(exc, zipfile.BadZipFile) else exc.strerror or str(exc)
        raise FmuError(f"{path}: not a readable FMU: {reason}", argument=argument) from None
    if xml is None:
        raise FmuError(f"{path}: not a readable FMU: no modelDescription.xml", argument=argument)
    try:
        version = ET.fromstring(xml).get("fmiVersion")
    except ET.ParseError as exc:
        raise FmuError(f"{path}: not a readable FMU: modelDescription.xml is not XML ({exc})",
                       argument=argument) from None
    if version not in versions:  # another version than gyrowheel's, or one this caller does not run
        reader, runs = ("gyrowheel", FMI_VERSIONS) if version not in FMI_VERSIONS else (reader, versions)
        raise FmuError(f"{path}: FMI {version} is not supported: {reader} runs FMI {' and '.join(runs)} FMUs",
                       argument=argument)
    try:
        md = read_model_description(str(path))
    except Exception as exc:  # fmpy raises plain Exceptions: the schema's problems, one a line
        problems = [line.strip(" -") for line in str(exc).splitlines() if line.strip(" -")]
        text = problems[0] if problems else type(exc).__name__
        if text.startswith("Failed to validate") and len(problems) > 1:
            more = f" (and {len(problems) - 2} more)" if len(problems) > 2 else ""
            text = f"modelDescription.xml breaks the FMI {version} schema: {problems[1]}{more}"
        raise FmuError(f"{path}: not a readable FMU: {text}", argument=argument) from None
    if to_run:
        if md.coSimulation is None:
            raise FmuError(f"{path}: the FMU does not support Co-Simulation", argument=argument)
        binary = binary_path(md)
        if binary not in names:
            have = platform_infos(names)
            has = f"the FMU has binaries for {', '.join(map(str, have))}" if have else "the FMU has no binaries"
            raise FmuError(f"{path}: no binary for {binary.split('/')[1]} ({binary}); {has}", argument=argument)
    return FmuFile(path, md, names)


@dataclass(frozen=True)
class VariableInfo:
    """One variable: a ScalarVariable (FMI 2.0.4, section 2.2.7) or an FMI 3.0 variable
    (FMI 3.0.2, section 2.4.7), `type` as its FMI version names it.

    start is typed by `type`: float (Real, Float32, Float64), int (Integer, Int8 ... UInt64,
    Enumeration), bool (Boolean), str (String); None when the variable has none (a calculated
    output, FMI 3.0's independent variable time). unit: the variable's own or its declared
    type's. items: an Enumeration's items, {name: value}; empty otherwise. dimensions: an
    array variable's sizes, shown by `gyrowheel info` after its name (x_state[10]).
    """

    name: str
    type: str  # FMI 2: Real, Integer, Enumeration, Boolean, String; FMI 3: Float64, Int32, ...
    causality: str  # parameter, calculatedParameter, input, output, local, independent
    variability: str  # constant, fixed, tunable, discrete, continuous
    initial: str | None  # exact, approx, calculated
    start: float | int | bool | str | None
    unit: str | None
    description: str | None
    value_reference: int
    declared_type: str | None = None
    items: dict[str, int] | None = None
    dimensions: tuple[int, ...] = ()  # an FMI 3.0 array's sizes (section 2.4.7.2); () for a scalar


@dataclass(frozen=True)
class DefaultExperiment:
    """The FMU's DefaultExperiment (section 2.2.5); each value None when the FMU does not give it.
    Times in s; tolerance: relative."""

    start_time: float | None
    stop_time: float | None
    step_size: float | None
    tolerance: float | None


@dataclass(frozen=True)
class PlatformInfo:
    """One platform an FMU carries a binary for.

    name: its FMI 3.0 platform tuple (FMI 3.0, section 2.5.1.4.1: 'x86_64-linux',
    'aarch64-darwin'); folder: the archive's folder holding its binary ('binaries/linux64':
    FMI 2.0.4, section 2.3 names 32/64-bit x86 win32, win64, linux32, linux64, darwin32,
    darwin64, and every other platform by its tuple). A folder that names no platform either
    standard knows keeps its own name as `name`.
    str(): 'x86_64-linux (binaries/linux64)'.
    """

    name: str
    folder: str

    def __str__(self) -> str:
        return f"{self.name} ({self.folder})"


def platform_infos(names) -> list[PlatformInfo]:
    """A PlatformInfo for every folder of binaries/ holding a file among an FMU's member
    `names`, sorted by platform tuple, then folder."""
    from gyrowheel.fmu_build.platforms import platform_of_folder  # (loads the model's packages: only here)

    folders = {n.split("/")[1] for n in names if n.startswith("binaries/") and n.count("/") >= 2 and not n.endswith("/")}
    return sorted((PlatformInfo(platform_of_folder(f), f"binaries/{f}") for f in folders),
                  key=lambda p: (p.name, p.folder))


@dataclass(frozen=True)
class FmuInfo:
    """What an FMU is (gyrowheel.info).

    path: the .fmu; model_name, description, fmi_version ('2.0'), generation_tool,
    generation_date (ISO 8601 text, or None), guid: modelDescription.xml's attributes.
    co_simulation, model_exchange: the interfaces' model identifiers (None: not offered).
    default_experiment: DefaultExperiment or None. variables: every ScalarVariable, in the file's
    order. effects: the effects an FMU built by gyrowheel simulates
    (docs/effects.md; () for none), None for an FMU that does not say. solvers: the items of
    its `solver` parameter (the integrators it can run), () without one. platforms: a
    PlatformInfo for every folder of binaries/ holding a file, by platform tuple
    (x86_64-linux in binaries/linux64); sources: it carries its C sources
    (sources/); taylor: it has the Taylor kernel (solver taylor, gyrowheel.Ensemble); modes: its
    model switches modes at events (update events: the contact modes), read from its sources
    (False for an FMU without them).
    """

    path: Path
    model_name: str
    description: str | None
    fmi_version: str
    generation_tool: str | None
    generation_date: str | None
    guid: str
    co_simulation: str | None
    model_exchange: str | None
    default_experiment: DefaultExperiment | None
    variables: tuple[VariableInfo, ...]
    effects: tuple[str, ...] | None
    solvers: tuple[str, ...]
    platforms: tuple[PlatformInfo, ...]
    sources: bool
    taylor: bool
    modes: bool = False

    @property
    def auto_solver(self) -> str | None:
        """The solver item auto (7) integrates with: "taylor" where the FMU has the Taylor kernel
        (its Solver enumeration lists taylor) and its model no mode switches, "dop853" otherwise,
        at every rel_tol (the rule of c_src gw_solver_auto, docs/accuracy.md "Solver auto");
        None for an FMU without auto."""
        if "auto" not in self.solvers:
            return None
        return auto_pick("taylor" in self.solvers, self.modes)

    def variable(self, name: str) -> VariableInfo:
        """The variable called `name` (a str). Raises UnknownNameError (a KeyError) listing the
        names when there is none; ArgumentTypeError (a TypeError) naming `name` for a name that
        is no str (variable(3))."""
        lookup_name(name, "name", "a variable's name")
        for v in self.variables:
            if v.name == name:
                return v
        raise UnknownNameError(f"no variable {name!r}; variables: {', '.join(v.name for v in self.variables)}")

    def _tolerance_text(self) -> str:
        """The default tolerance, in the words of the auto line."""
        exp = self.default_experiment
        tol = None if exp is None else _text(exp.tolerance)
        return f"the default tolerance {tol}" if tol else "every tolerance"

    def as_dict(self) -> dict:
        """Everything as plain JSON types (path as text, tuples as lists), auto_solver included."""
        out = asdict(self)
        out["path"] = str(self.path)
        out["auto_solver"] = self.auto_solver
        return out

    def __str__(self) -> str:
        exp = self.default_experiment
        lines = [f"model        {self.model_name}  (FMI {self.fmi_version}, generated by {self.generation_tool})",
                 f"description  {self.description or 'none'}",
                 f"guid         {self.guid}"]
        if exp is not None:
            start, stop, step, tol = (_text(x) or "unset" for x in (exp.start_time, exp.stop_time,
                                                                     exp.step_size, exp.tolerance))
            lines.append(f"experiment   {start} .. {stop} s, step {step}, tolerance {tol}")
        interfaces = [f"{kind} ({ident})" for kind, ident in (("Co-Simulation", self.co_simulation),
                                                              ("Model Exchange", self.model_exchange)) if ident]
        lines += [f"interfaces   {', '.join(interfaces) or 'none'}",
                  f"generated    {self.generation_date or 'unknown'}",
                  f"effects      {'not recorded' if self.effects is None else ', '.join(self.effects) or 'none'}",
                  f"solvers      {', '.join(self.solvers) or 'none declared'}",
                  *([f"auto         {self.auto_solver} at {self._tolerance_text()} (rule: taylor at every rel_tol "
                     f"where the FMU has the Taylor kernel and no mode switches, else dop853)"]
                   if self.auto_solver else []),
                  f"platforms    {', '.join(map(str, self.platforms)) or 'none (no binaries)'}",
                  f"sources      {'yes' if self.sources else 'no'}"
                  + (", with the Taylor kernel (solver taylor, the ensemble path)" if self.taylor else "")]
        # the variable table: every column as wide as its longest entry, two spaces apart
        rows = [("name", "causality", "variability", "start", "unit", "description")]
        rows += [(v.name + "".join(f"[{n}]" for n in v.dimensions), v.causality, v.variability, _start_text(v), v.unit or "", v.description or "")
                 for v in self.variables]
        width = [max(len(r[i]) for r in rows) for i in range(5)]
        for r in rows:
            cells = [r[0].ljust(width[0]), r[1].ljust(width[1]), r[2].ljust(width[2]), r[3].rjust(width[3]),
                     r[4].ljust(width[4]), r[5]]
            lines.append("  ".join(cells).rstrip())
        lines += [f"items of {v.name} ({v.declared_type}): "
                  + ", ".join(f"{name} = {value}" for name, value in sorted(v.items.items(), key=lambda kv: kv[1]))
                  for v in self.variables if v.items]
        return "\n".join(lines)


def _start_text(v: VariableInfo) -> str:
    """A start value for the table: an Enumeration's by its item name ('dopri5 (3)')."""
    if v.items and v.start is not None:
        name = next((k for k, value in v.items.items() if value == v.start), None)
        if name is not None:
            return f"{name} ({v.start})"
    return _text(v.start)


def _text(value) -> str:
    """A value as the FMU's XML writes it: booleans true/false, floats by repr, nothing as ''."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


def _typed(text: str | None, fmi_type: str):
    """An XML start value as the Python value of its FMI type (the text if it does not parse)."""
    if text is None:
        return None
    try:
        if fmi_type == "Real" or fmi_type.startswith("Float"):
            return float(text)
        if fmi_type in ("Integer", "Enumeration") or fmi_type.startswith(("Int", "UInt")):
            return int(text)
    except ValueError:
        return text
    if fmi_type == "Boolean":
        return text.strip().lower() in ("true", "1")
    return text


def _number(text) -> float | None:
    try:
        return None if text is None else float(text)
    except ValueError:
        return None


def _effects(index_html: str) -> tuple[str, ...] | None:
    """The effects line of documentation/index.html as gyrowheel writes it, or None."""
    match = re.search(r"<li>effects: ([^<]*)</li>", index_html)
    if match is None:
        return None
    text = html.unescape(match.group(1)).strip()
    return () if text == "none" else tuple(e.strip() for e in text.split(",") if e.strip())


def auto_pick(kernel: bool, modes: bool) -> str:
    """The solver auto integrates with: "taylor" in an FMU with the Taylor kernel whose model has
    no mode switches, else "dop853" (c_src gw_solver_auto's rule, docs/accuracy.md "Solver auto")."""
    return "taylor" if kernel and not modes else "dop853"


def kernel_and_modes(zf: zipfile.ZipFile, names) -> tuple[bool, bool]:
    """(the FMU has the Taylor kernel, its model has mode switches) from its sources: what solver
    auto's rule reads (FmuInfo.auto_solver)."""
    taylor = TAYLOR_HEADER in names and b"GW_TL_NVAR" in zf.read(TAYLOR_HEADER)
    modes = MODEL_SOURCE in names and MODES_ABSENT not in zf.read(MODEL_SOURCE)
    return taylor, modes


def read_info(fmu: str | Path) -> FmuInfo:
    """Describe the FMU at `fmu` (see FmuInfo). Raises FmuError naming the file when it is not
    an FMI 2.0 or 3.0 FMU gyrowheel can read (open_fmu)."""
    checked = open_fmu(fmu)
    path, md, names = checked.path, checked.model_description, checked.names
    try:
        with zipfile.ZipFile(path) as zf:
            index = (zf.read("documentation/index.html").decode("utf-8", "replace")
                     if "documentation/index.html" in names else "")
            taylor, modes = kernel_and_modes(zf, names)
    except (zipfile.BadZipFile, OSError) as exc:  # an archive changed or broken since it was opened
        raise FmuError(f"{path}: not a readable FMU: {exc}", argument="fmu") from None
    types = {t.name: t for t in md.typeDefinitions}
    variables = []
    for v in md.modelVariables:
        declared = v.declaredType.name if v.declaredType is not None else None
        items = ({i.name: int(i.value) for i in types[declared].items}
                 if v.type == "Enumeration" and declared in types else None)
        variables.append(VariableInfo(
            name=v.name, type=v.type, causality=v.causality, variability=v.variability, initial=v.initial,
            start=_typed(v.start, v.type), unit=v.unit or (v.declaredType.unit if v.declaredType else None),
            description=v.description, value_reference=int(v.valueReference), declared_type=declared,
            items=items, dimensions=tuple(int(d.start) for d in (v.dimensions or ()))))
    solver = next((v for v in variables if v.name == "solver" and v.items), None)
    exp = md.defaultExperiment
    platforms = platform_infos(names)
    return FmuInfo(
        path=path, model_name=md.modelName, description=md.description, fmi_version=md.fmiVersion,
        generation_tool=md.generationTool, generation_date=md.generationDateAndTime, guid=md.guid,
        co_simulation=md.coSimulation.modelIdentifier if md.coSimulation is not None else None,
        model_exchange=md.modelExchange.modelIdentifier if md.modelExchange is not None else None,
        default_experiment=None if exp is None else DefaultExperiment(
            _number(exp.startTime), _number(exp.stopTime), _number(exp.stepSize), _number(exp.tolerance)),
        variables=tuple(variables), effects=_effects(index) if index else None,
        solvers=tuple(solver.items) if solver is not None else (), platforms=tuple(platforms),
        sources=any(n.startswith("sources/") and not n.endswith("/") for n in names), taylor=taylor, modes=modes)
