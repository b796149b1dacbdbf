"""Many trajectories of one FMU's model at once: the ensemble path (c_src/gw_ensemble.c).

An FMU built by gyrowheel carries its C sources; `Ensemble(fmu)` compiles them once into a
small shared library next to the FMU's cache (the model, the core, the Taylor kernel with
GW_ENSEMBLE_LANES lanes, and the front end c_src/gw_ensemble_lib.c, whose functions
`<id>_ensemble_*` are the only ones exported), then runs any number of trajectories with solver
taylor, each with its own parameters and start values:

    ens = Ensemble("paper_earth.fmu")
    res = ens.run(20.0, parameters={"g": [9.81, 3.721]}, starts={"gamma_dot": [6.0, 3.0]},
                  rel_tol=1e-10)
    res.status      # (N,) STATUS_OK, STATUS_TERMINATED (fallen: a terminating event), STATUS_ERROR
    res.t_final     # (N,) s: t_end or the time of the terminating event
    res.output("beta")  # (N,) an output at t_final

Each trajectory is exactly the FMU's run with solver taylor (same initialisation, checks,
events, outputs); the lanes share only the Taylor coefficients' computation, vectorised across
trajectories.  The sweep engine (studies) calls `Ensemble.run`.
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import re
import shutil
import tempfile
import threading
import weakref
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrowheel import arguments
from gyrowheel.errors import ArgumentError, ArgumentTypeError, FmuError, GyrowheelError, UnknownArgumentNameError
from gyrowheel.fmu_build.compiler import compile_shared
from gyrowheel.fmu_build.runtime import RUNTIME_DIR
from gyrowheel.scratch import temporary_directory
from gyrowheel.taylor.ensemble_job import check_job, numbers
from gyrowheel.taylor.ensemble_messages import advice, named_as_given

__all__ = ["Ensemble", "EnsembleResult", "EnsembleError", "STATUS_OK", "STATUS_TERMINATED",
           "STATUS_ERROR", "LANES"]

STATUS_OK, STATUS_TERMINATED, STATUS_ERROR = 0, 2, 3  # gw_status values
# trajectories advanced together (GW_ENSEMBLE_LANES) by default: the machine's count, chosen at
# run time (gyrowheel.taylor.lanes.ensemble_lanes: 4 with AVX2, 8 or 4 with AVX-512F as they
# measure, else 2); LANES = None
# means that choice, an integer passed as `lanes` overrides it.  docs/performance.md, "The
# ensemble's lane count"
LANES = None
KIND_PARAM, KIND_START, KIND_OUTPUT, KIND_EVENT = 0, 1, 3, 5  # gw_kind
FLAGS = ["-O3", "-ffp-contract=fast"]  # portable: the x86-64-v3 kernel is a target clone

_LOGGER = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                           ctypes.c_char_p)
_D = ctypes.POINTER(ctypes.c_double)
# C's long and unsigned long (steps, n_rows, status: counts, read as signed)
_LONG = ctypes.sizeof(ctypes.c_long)
_LONG_DTYPE = np.int64 if _LONG == 8 else np.int32

# the library's front end (its exported functions and the packed run's layout): one C file of the
# runtime, compiled for a model through the unity file library_source writes
LIBRARY_SOURCE = "gw_ensemble_lib.c"
# what an FMU without the Taylor kernel is told, in the Python API's words and the command's
NO_KERNEL = f"which the ensemble path needs: build its scene with the kernel, {arguments.TAYLOR_BUILD}"
_C_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def library_source(identifier: str, lanes: int, defines: dict | None = None) -> str:
    """The unity file of model `identifier`'s ensemble library (C text): the extra `defines`
    ({name: value}, each a #define, in the given order), GW_ENSEMBLE_ID and GW_ENSEMBLE_LANES,
    then c_src/gw_ensemble_lib.c, which includes the model (the FMU's gw_funcs.c, gw_taylor.c,
    model_desc.c) and the runtime.  Compiled with the FMU's sources/ and gw_ensemble_lib.c on
    the include path.  Raises ArgumentError (a ValueError) naming the field for an identifier or a define name
    that is not a C identifier, lanes not an integer >= 1, or a value that is not an integer or
    a one-line string."""
    if not isinstance(identifier, str) or not _C_NAME.fullmatch(identifier):
        raise ArgumentError(f"identifier must be a C identifier (the FMU's modelIdentifier), got {identifier!r}",
                            argument="identifier")
    _check_lanes(lanes)
    lines = [f"/* The ensemble library of model {identifier}: written by gyrowheel.taylor.ensemble. */"]
    for name, value in _checked_defines(defines).items():
        lines.append(f"#define {name} {value}")
    lines += [f"#define GW_ENSEMBLE_ID {identifier}", f"#define GW_ENSEMBLE_LANES {int(lanes)}",
              f'#include "{LIBRARY_SOURCE}"', ""]
    return "\n".join(lines)


def _check_lanes(lanes) -> None:
    """lanes becomes GW_ENSEMBLE_LANES, so it is checked here: 0 or less would fail in the
    compiler with the compiler's message, 2.5 would be truncated to 2 without a word."""
    if isinstance(lanes, bool) or not isinstance(lanes, (int, np.integer)) or lanes < 1:
        raise ArgumentError(f"lanes must be an integer >= 1 (trajectories advanced together), got {lanes!r}",
                            argument="lanes")


# the unity file's own macros (library_source): a define of either would be a redefinition
_RESERVED_DEFINES = {"GW_ENSEMBLE_LANES": "the lanes argument", "GW_ENSEMBLE_ID": "the FMU's model identifier"}


def _checked_defines(defines) -> dict:
    """defines as {name: value text}; ArgumentError naming the field for anything else."""
    if defines is None:
        return {}
    if not isinstance(defines, dict):
        raise ArgumentError(f"defines must be a {{name: value}} dict of C macros, got {defines!r}", argument="defines")
    out = {}
    for name, value in defines.items():
        if not isinstance(name, str) or not _C_NAME.fullmatch(name):
            raise ArgumentError(f"defines: {name!r} is not a C identifier", argument="defines")
        if name in _RESERVED_DEFINES:
            raise ArgumentError(f"defines: {name} is set by Ensemble itself ({_RESERVED_DEFINES[name]})",
                                argument="defines")
        if isinstance(value, bool) or not isinstance(value, (int, np.integer, str)) or \
                (isinstance(value, str) and ("\n" in value or "\\" in value)):
            raise ArgumentError(f"defines: {name} must be an integer or a one-line string, got {value!r}",
                                argument="defines")
        out[name] = str(int(value)) if not isinstance(value, str) else value
    return out


class EnsembleError(GyrowheelError, RuntimeError):
    """The ensemble library could not be built or a job was refused (the reason is given)."""


@dataclass
class EnsembleResult:
    """What Ensemble.run returns: N trajectories' final values (row j: trajectory j of the
    inputs) and, with a communication grid, their outputs at its points.

    status        (N,) int: STATUS_OK (reached t_end), STATUS_TERMINATED (stopped by a
                  terminating event: the wheel fell, a lift-off ...), STATUS_ERROR (refused or
                  failed: the reason is in messages)
    t_final       (N,) s: t_end, the time of the terminating event, or where it failed
    x_final       (N, nx): the continuous states at t_final, in state_names order
    y_final       (N, ny): the outputs at t_final, in output_names order (NaN after an error)
    steps         (N,) int: Taylor steps taken
    output_names  the outputs' names (the FMU's, y's order); state_names: the states'
    messages      the errors logged, one "ensemble trajectory <j>: ..." each
    grid          with run(..., grid=...): (G + 1,) s, t_start and the G communication points;
                  None without a grid
    y_grid        with a grid: (N, G + 1, ny) the outputs at t_start and at each point; rows
                  from n_rows[j] on are NaN (trajectory j ended before them); else None
    n_rows        with a grid: (N,) int, the rows of y_grid written for each trajectory (t_start's
                  and the points reached); else None
    flags         (N, ne) bool: which events (event_names: their Boolean outputs, such as
                  fallen) have fired by t_final
    event_names   the events' flags' names, flags' column order
    """

    status: np.ndarray  # (N,) int: STATUS_OK, STATUS_TERMINATED, STATUS_ERROR
    t_final: np.ndarray  # (N,) s
    x_final: np.ndarray  # (N, nx) states
    y_final: np.ndarray  # (N, ny) outputs (NaN after an error)
    steps: np.ndarray  # (N,) Taylor steps
    output_names: list[str]
    state_names: list[str]
    messages: list[str] = field(default_factory=list)  # errors, "ensemble trajectory <j>: ..."
    # with a communication grid (run(..., grid=...)): times (n_grid + 1,), outputs there
    # (N, n_grid + 1, ny; rows past n_rows[j] are NaN), rows written (N,), fired events (N, ne)
    grid: np.ndarray | None = None
    y_grid: np.ndarray | None = None
    n_rows: np.ndarray | None = None
    flags: np.ndarray | None = None
    event_names: list[str] = field(default_factory=list)

    def output(self, name: str) -> np.ndarray:
        """(N,) values of one output at t_final. Raises UnknownArgumentNameError (a KeyError and a
        ValueError, argument 'name') listing the names when there is none; ArgumentTypeError (a
        TypeError) naming `name` for a name that is no str (output(3))."""
        arguments.lookup_name(name, "name", "an output's name")
        if name not in self.output_names:
            raise UnknownArgumentNameError(f"no output {name!r}; outputs: {', '.join(self.output_names)}",
                                           argument="name")
        return self.y_final[:, self.output_names.index(name)]

    @property
    def terminated(self) -> np.ndarray:
        """(N,) bool: stopped by a terminating event (the wheel fell, a lift-off...)."""
        return self.status == STATUS_TERMINATED


def _address(a: np.ndarray) -> int:
    """The address of a contiguous writable array's data (a quarter of ndarray.ctypes.data's
    cost; the array stays alive with the caller's reference)."""
    return ctypes.addressof(ctypes.c_char.from_buffer(a))


def _fmu_path(fmu) -> Path:
    """The fmu argument (a path; a gyrowheel.BuildResult is one) as a Path: a scene (a .toml, a
    gyrowheel.Scene) is refused naming how to build the FMU the ensemble needs, anything else
    that is no path with an ArgumentTypeError."""
    build = f"build its FMU with the Taylor kernel first: {arguments.TAYLOR_BUILD}"
    if not isinstance(fmu, (str, os.PathLike)):
        from gyrowheel.fmu_build.scene import Scene
        if isinstance(fmu, Scene):
            raise FmuError(f"fmu: a gyrowheel.Scene, not an FMU; {build}", argument="fmu")
        raise ArgumentTypeError(f"fmu must be a path to an FMU (.fmu) or the gyrowheel.BuildResult of one, "
                                f"got {type(fmu).__name__}", argument="fmu")
    path = Path(fmu)
    if path.suffix.lower() == ".toml":
        raise FmuError(f"{path}: a scene, not an FMU; {build}", argument="fmu")
    return path


def _start_value(md, name: str) -> float | None:
    """The start value of variable `name` in a parsed modelDescription.xml (FMI 2: on its type
    element, FMI 3: on the variable), None if it has none."""
    for v in md.iter():
        if v.get("name") == name:
            start = v.get("start") or next((c.get("start") for c in v if c.get("start")), None)
            return float(start) if start else None
    return None


def _sources(fmu: Path, work: Path) -> tuple[Path, str, str, dict]:
    """Extract sources/ and read (identifier, guid, {setting: start value}) from
    modelDescription.xml (the settings rel_tol and abs_tol, when the FMU has them)."""
    import xml.etree.ElementTree as ET
    try:
        zf = zipfile.ZipFile(fmu)
    except FileNotFoundError:
        raise FmuError(f"{fmu}: no such FMU file", argument="fmu") from None
    except IsADirectoryError:
        raise FmuError(f"{fmu}: is a directory, not an FMU file", argument="fmu") from None
    except zipfile.BadZipFile:
        raise FmuError(f"{fmu}: not an FMU (not a zip archive)", argument="fmu") from None
    with zf:
        try:
            md = ET.fromstring(zf.read("modelDescription.xml"))
        except KeyError:
            raise FmuError(f"{fmu}: not an FMU (no modelDescription.xml)", argument="fmu") from None
        except ET.ParseError as exc:
            raise FmuError(f"{fmu}: modelDescription.xml is not readable XML ({exc})", argument="fmu") from None
        names = [n for n in zf.namelist() if n.startswith("sources/")]
        if not names:
            raise EnsembleError(f"{fmu}: the FMU carries no sources/ (not built by gyrowheel?)", argument="fmu")
        zf.extractall(work, names)
    cs = md.find("CoSimulation")
    identifier = cs.get("modelIdentifier") if cs is not None else md.get("modelName")
    settings = {k: v for k in ("rel_tol", "abs_tol") if (v := _start_value(md, k)) is not None}
    return work / "sources", identifier, md.get("guid", ""), settings


def _cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    path = Path(base) / "gyrowheel" / "ensemble"
    try:
        path.mkdir(parents=True, exist_ok=True)
        return path
    except OSError:
        return Path(tempfile.gettempdir()) / "gyrowheel-ensemble"


class _Context:
    """One C context of the ensemble library (NULL if out of memory: each run then makes and
    frees its memory) and its logger, which collects one run's messages."""

    def __init__(self, ptr):
        self.ptr, self.messages = ptr, []

        @_LOGGER
        def logger(env, instance, st, category, message):
            # "ensemble trajectory <j>: ..." (the lane's instance is named after its trajectory)
            text, who = message.decode(errors="replace"), (instance or b"").decode(errors="replace")
            self.messages.append(text if not who or text.startswith(who) else f"{who}: {text}")
        self.logger = logger


def _free_contexts(free, contexts: list) -> None:
    while contexts:
        ptr = contexts.pop().ptr
        if ptr:
            free(ptr)


class Ensemble:
    """The ensemble library of one FMU built by gyrowheel (compiled once, cached by content).

    fmu: the .fmu, built by gyrowheel with the Taylor kernel (gyrowheel.build(..., taylor=True)):
    a path (str or os.PathLike) or the BuildResult of gyrowheel.build; lanes: trajectories
    advanced together (default None: this machine's count, gyrowheel.taylor.lanes.ensemble_lanes:
    8 with AVX-512F where the model's 8-lane kernel call measures at most 0.7x two 4-lane calls,
    otherwise 4 there and with AVX2, PORTABLE_LANES without either; any integer >= 1 overrides
    it, each width its own
    cached library; `self.lanes` is the count built; a trajectory's result is the same bit for
    bit in any job and on 2 to 16 lanes; on 1 lane equal to rounding); cache: where the library
    (and the lane-count probe) is kept (default ~/.cache/gyrowheel/ensemble);
    defines: extra C macros of this build, {name: integer or one-line string} (switches of the
    ensemble path and the solver, e.g.
    {"GW_ENSEMBLE_LANE_STEPS": 1}: every lane-step through the solver code), part of the
    library's cache key.  Raises ArgumentError (a ValueError) for lanes not an integer >= 1 or a
    bad define (naming it), FmuError for a file that is not an FMU, EnsembleError if the FMU has
    no sources or its model no Taylor kernel, CompileError if the compiler fails.
    """

    def __init__(self, fmu: str | Path, lanes: int | None = LANES, cache: str | Path | None = None,
                 defines: dict | None = None):
        from gyrowheel.taylor.lanes import ensemble_lanes, slice_defines
        defines, fmu = _checked_defines(defines), _fmu_path(fmu)
        if lanes is None:
            lanes = ensemble_lanes(fmu, cache, defines, check=False)  # faults named below
        _check_lanes(lanes)
        lanes = int(lanes)
        # the CPU's slice width (8 lanes per vector with AVX-512F), unless the caller's defines say
        defines = {**{k: str(v) for k, v in slice_defines(lanes, cache).items()}, **defines}
        # the front end is the installed runtime's (its functions and layout are what this class
        # reads), compiled with the FMU's model and runtime
        front = RUNTIME_DIR / LIBRARY_SOURCE
        with temporary_directory("ens") as tmp:
            src, self.identifier, self.guid, settings = _sources(fmu, Path(tmp))
            unity_text = library_source(self.identifier, lanes, defines)
            digest = hashlib.sha256(fmu.read_bytes() + unity_text.encode() + front.read_bytes()
                                    + " ".join(FLAGS).encode()).hexdigest()[:20]
            lib = (Path(cache) if cache else _cache_dir()) / digest / "libensemble.so"
            kernel = src / "gw_taylor_model.h"
            if not kernel.is_file() or "GW_TL_NVAR" not in kernel.read_text():
                raise EnsembleError(f"{fmu}: the FMU has no Taylor kernel (solver taylor), {NO_KERNEL}", argument="fmu")
            if not lib.exists():
                shutil.copyfile(front, src / LIBRARY_SOURCE)
                unity = src / f"{self.identifier}_ensemble.c"
                unity.write_text(unity_text)
                # a name of this process and thread: Ensembles made at once by threads of one
                # process (a cold cache) compiled into one .part file, and one's replace() then
                # failed (FileNotFoundError) or moved another's half-written library
                part = lib.with_suffix(f".{os.getpid()}.{threading.get_ident()}.part")
                compile_shared(unity, [src], part, extra_flags=FLAGS)
                part.replace(lib)
        self.library = lib
        self.fmu = fmu
        # run()'s default tolerances: the FMU's own (its rel_tol; its abs_tol, 0 following
        # rel_tol / 100), so that a run without them is the FMU's run with solver taylor
        self.rel_tol, self.abs_tol = settings.get("rel_tol", 1e-8), settings.get("abs_tol", 0.0)
        self._variables: dict | None = None  # the FMU's variables by name, for NAME_deg
        self._lib = ctypes.CDLL(str(lib))
        fn = lambda name: getattr(self._lib, f"{self.identifier}_ensemble_{name}")  # noqa: E731
        sizes = (ctypes.c_int * 8)()
        fn("sizes")(sizes)
        self.nx, self.ns, self.nu, self.np, self.ny, self.lanes, has_taylor, self.ne = list(sizes)
        if not has_taylor:
            raise EnsembleError(f"{fmu}: the model has no Taylor kernel (solver taylor), {NO_KERNEL}", argument="fmu")
        name = fn("name")
        name.restype = ctypes.c_char_p

        def names(kind: int, n: int) -> list[str]:
            return [(name(kind, i) or b"?").decode() for i in range(n)]
        self.parameter_names = names(KIND_PARAM, self.np)
        self.start_names = names(KIND_START, self.ns)
        self.output_names = names(KIND_OUTPUT, self.ny)
        self.event_names = names(KIND_EVENT, self.ne)  # the Boolean outputs (flags), e.g. fallen
        self.state_names = names(-1, self.nx)
        p0, s0 = np.zeros(max(self.np, 1)), np.zeros(max(self.ns, 1))
        fn("defaults")(p0.ctypes.data_as(_D), s0.ctypes.data_as(_D))
        self.default_parameters, self.default_starts = p0[: self.np], s0[: self.ns]
        # the run with its arrays in one buffer at the places the library computes (run_packed,
        # layout): five arguments, the buffer passed as an address
        self._run = fn("run_packed")
        self._run.restype = ctypes.c_int
        vp = ctypes.c_void_p
        self._run.argtypes = [vp, ctypes.c_long, ctypes.c_int, vp, _LOGGER]
        fn("layout_names").restype = ctypes.c_char_p
        self._sections = fn("layout_names")().decode().split()
        self._c_layout = fn("layout")
        self._c_layout.argtypes = [ctypes.c_long, ctypes.c_int, ctypes.POINTER(ctypes.c_long)]
        self._layouts: dict[tuple[int, int], tuple] = {}
        # C contexts (gw_ensemble_new: the lanes' instances and the batch memory kept between
        # runs, 0.017 ms less per run), each with its logger; a run takes one from the pool, so
        # runs from several threads at once each have their own
        self._new_context, free = fn("new"), fn("free")
        self._new_context.restype = vp
        free.argtypes = [vp]
        self._contexts: list[_Context] = []
        self._default_tables: dict[tuple[str, int], np.ndarray] = {}
        weakref.finalize(self, _free_contexts, free, self._contexts)

    @staticmethod
    def _trajectories(parameters, starts) -> int:
        """N, the number of trajectories: the length of every column given with more than one
        value (a dict's value) and the rows of an array given; 1 when every value is one value.
        Raises ArgumentError naming the columns when they give different numbers."""
        lengths: dict[str, int] = {}
        for what, values in (("parameters", parameters), ("starts", starts)):
            items = values.items() if isinstance(values, dict) else [] if values is None else [(None, values)]
            for k, v in items:
                try:
                    shape = np.shape(v)
                except ValueError:  # (ragged lists: _table names the field)
                    continue
                if k is None and len(shape) == 2:
                    lengths[f"{what} ({shape[0]} rows)"] = shape[0]
                elif k is not None and len(shape) == 1 and shape[0] != 1:
                    lengths[f"{what}[{k!r}] ({shape[0]} values)"] = shape[0]
        if len(set(lengths.values())) > 1:
            raise ArgumentError(f"parameters and starts give different numbers of trajectories: "
                                f"{', '.join(lengths)}; give each column one value per trajectory, or one "
                                f"value for all", argument="starts" if starts is not None else "parameters")
        return next(iter(lengths.values()), 1)

    def _table(self, what: str, values, names: list[str], default: np.ndarray, n: int):
        """(n, len(names)) from an array of that shape or a {name: scalar or (n,)} dict (n from
        _trajectories), the defaults' table for None.  Errors name `argument`, the run's argument
        these values came in ('parameters' or 'starts')."""
        argument = "parameters" if what == "parameter" else "starts"
        if values is None:
            key = (what, n)  # the defaults' table of N rows, made once (the C side only reads it)
            table = self._default_tables.get(key)  # one look-up: another thread may clear the
            if table is None:                      # cache between a test and a read (KeyError)
                if len(self._default_tables) > 16:
                    self._default_tables.clear()
                table = np.tile(default, (n, 1))
                table.flags.writeable = False
                self._default_tables[key] = table
            return table
        if isinstance(values, dict):
            cols = {}
            for k, v in values.items():
                if not isinstance(k, str):
                    raise ArgumentTypeError(f"{what} names must be strings, got {arguments.shown(k)}",
                                            argument=argument)
                given, deg = k, False
                if k not in names and what == "start value":
                    k, deg = self._in_radians(k)
                    if deg and k in values:
                        raise ArgumentError(f"start value {k!r} given twice: as {k!r} and as {given!r}",
                                            argument=argument)
                if k not in names:
                    raise UnknownArgumentNameError(f"unknown {what} {k!r}; {what}s: {', '.join(names)}"
                                                   + (" (angles also as NAME_deg, in degrees)"
                                                      if what == "start value" else ""), argument=argument)
                try:  # (a string, None, a 2-D array: numpy's message named no field, or none came)
                    cols[k] = np.atleast_1d(numbers(v).astype(float))
                    if deg:
                        cols[k] = np.radians(cols[k])
                    if cols[k].ndim != 1:
                        raise ValueError(v)  # named below
                except ValueError:
                    raise ArgumentError(f"{what} {given!r} must be a number or a 1-D sequence of numbers "
                                        f"(one per trajectory), got {v!r}", argument=argument) from None
            table = np.tile(default, (n, 1))  # (every column of one value or n: _trajectories)
            for k, c in cols.items():
                table[:, names.index(k)] = c
            return table
        try:
            table = numbers(values).astype(float)
        except ValueError:
            raise ArgumentError(f"{what}s must be an (N, {len(names)}) array of numbers ({', '.join(names)}) "
                                f"or a {{name: values}} dict, got {values!r}", argument=argument) from None
        if table.ndim != 2 or table.shape[1] != len(names) or table.shape[0] != n:
            raise ArgumentError(f"{what}s must have shape (N, {len(names)}) ({', '.join(names)}), N = {n} "
                                f"trajectories, got {table.shape}", argument=argument)
        return table

    def _in_radians(self, name: str) -> tuple[str, bool]:
        """(the start value, whether `name` gives it in degrees): NAME_deg names the angle NAME
        (unit rad) in degrees, as scenes, simulate and sweep take it (beta_deg = 80), by the rule
        simulate applies (gyrowheel.simulation._angle_name) to the FMU's variables, read from its
        modelDescription.xml once, when first asked."""
        from gyrowheel.simulation import _angle_name
        if self._variables is None:
            from fmpy import read_model_description
            self._variables = {v.name: v for v in read_model_description(str(self.fmu)).modelVariables}
        return _angle_name(name, self._variables)

    def run(self, t_end: float, parameters=None, starts=None, *, t_start: float = 0.0,
            rel_tol: float | None = None, abs_tol: float | None = None,
            max_step: float | None = None, grid=None) -> EnsembleResult:
        """Integrate every trajectory from t_start to t_end (s) with solver taylor.

        parameters: (N, np) array in `parameter_names` order, or {name: value or (N,) values}
        over the defaults; starts likewise ((N, ns), `start_names`; in the dict an angle, unit
        rad, also as NAME_deg in degrees: {"beta_deg": [70, 80]}).  N is taken from them
        (1 if both are None).  rel_tol defaults to the FMU's (`self.rel_tol`, its parameter
        rel_tol: a run as simulate's with solver taylor), abs_tol to the FMU's (`self.abs_tol`)
        when rel_tol is not given and that is not 0, else to rel_tol * 1e-2 (the FMU's rule for
        abs_tol 0); max_step to the span.
        grid: communication points (s) after t_start, increasing, the last == t_end: each
        trajectory then advances as through fmi2DoStep from point to point and the result holds
        the outputs at t_start and at every point reached (y_grid, n_rows) and the fired events.
        A trajectory that the budget of internal steps (the FMU's max_internal_steps, per
        communication step) cannot carry to its next point ends with STATUS_ERROR, its message
        advising a grid of shorter communication steps.
        Raises ArgumentError (a ValueError) naming a bad value or shape (rel_tol outside the
        FMU's range [10 eps, 1] included, once for the job; a grid not 1-D), or a grid whose
        outputs would take more than half of this machine's memory; ArgumentTypeError (also a
        TypeError) for a value that is no number (the string '10' too);
        UnknownArgumentNameError (a KeyError) for an unknown name; EnsembleError for a refused
        job.  Each error's `argument` is the argument it is about ('t_end', 'grid',
        'parameters', ...; None only where t_start and t_end are both at fault).
        """
        if rel_tol is None:
            rel_tol = self.rel_tol
            if abs_tol is None and self.abs_tol > 0:
                abs_tol = self.abs_tol
        g = check_job(t_start, t_end, rel_tol, abs_tol, max_step, grid)
        t_start, t_end, rel_tol = float(t_start), float(t_end), float(rel_tol)  # (numpy's numbers too)
        try:  # (the tables of values given as one huge array: numpy's bare MemoryError otherwise)
            n = self._trajectories(parameters, starts)
            P = self._table("parameter", parameters, self.parameter_names, self.default_parameters, n)
            S = self._table("start value", starts, self.start_names, self.default_starts, n)
        except MemoryError:
            raise ArgumentError("parameters, starts: the trajectories' values do not fit in this process's "
                                "memory: run fewer trajectories per call", argument="parameters") from None
        n, G = P.shape[0], g.size
        # the run's buffer (the values in, the final states and outputs out): the memory rule,
        # asked only past 32 MiB (it reads the machine's memory: 1 us, 7 % of a small run's cost)
        values = n * (self.np + self.ns + 2 * self.nx + self.ny + self.ne + 8)
        if values > 1 << 22:
            arguments.check_memory(values, 8, f"{n} trajectories", "run fewer trajectories per call",
                                   argument="parameters")
        lay = self._layouts.get((n, G))
        if lay is None:
            lay = self._layout(n, G)
        (grid_at, p_at, s_at, tf_at, xf_at, yf_at, yg_at, floats_end,
         steps_b, rows_b, status_b, flags_b, size) = lay
        if G:  # the outputs at every communication point of every trajectory: the memory rule
            arguments.check_memory(size, 8, f"grid: {n} trajectories of {arguments.count(G + 1)} communication "
                                   f"points of {self.ny} outputs", "give a coarser grid, or fewer trajectories "
                                   "per run", argument="grid")
        # one buffer, one address (ctypes.c_char.from_buffer: 0.25 us, ndarray.ctypes.data
        # 1 us): the scalars, the grid, P and S (copied: cheaper than their addresses), the
        # float outputs (NaN until written), then the C longs and ints, which the C side writes
        # for every trajectory of a run it accepts (run_packed)
        try:
            f = np.empty(size)
        except MemoryError:  # (a process limit below the machine's memory: ulimit -v, a container)
            raise ArgumentError(f"{n} trajectories" + (f" of {arguments.count(G + 1)} communication points" if G else "")
                                + f": the run's {size * 8 / 2**30:.3g} GiB do not fit in this process's memory: "
                                "run fewer trajectories per call" + (", or give a coarser grid" if G else ""),
                                argument="grid" if G else "parameters") from None
        f[:5] = (t_start, t_end, rel_tol, rel_tol * 1e-2 if abs_tol is None else float(abs_tol),
                 (t_end - t_start) if max_step is None else float(max_step))
        if G:
            f[grid_at:p_at] = g
        f[p_at:s_at] = P.ravel()
        f[s_at:tf_at] = S.ravel()
        f[tf_at:floats_end] = np.nan
        try:  # (another thread may take the last one between a test and pop)
            ctx = self._contexts.pop()
        except IndexError:
            ctx = _Context(self._new_context())
        messages = ctx.messages = []
        try:  # back to the pool also when Ctrl-C's KeyboardInterrupt, raised as the C call returns,
            # cuts the run short (else the context, never freed, was lost at each interrupt)
            rc = self._run(ctx.ptr, n, G, _address(f), ctx.logger)
        finally:
            self._contexts.append(ctx)
        messages[:] = [advice(m) for m in messages]
        if messages and isinstance(starts, dict):  # a start given in degrees: named as given
            messages[:] = named_as_given(messages, {name: k for k in starts if k not in self.start_names
                                                    for name, deg in [self._in_radians(k)] if deg})
        if rc >= STATUS_ERROR:
            raise EnsembleError("; ".join(messages) or f"ensemble run failed (status {rc})")
        nd, ne = np.ndarray, max(self.ne, 1)
        steps, status = nd(n, _LONG_DTYPE, f, steps_b), nd(n, _LONG_DTYPE, f, status_b)
        n_rows = nd(n, _LONG_DTYPE, f, rows_b) if G else None
        if _LONG != 8:
            steps, status = steps.astype(np.int64), status.astype(int)
            n_rows = None if n_rows is None else n_rows.astype(np.int64)
        flags = nd((n, ne), np.bool_, f, flags_b)
        return EnsembleResult(status=status, t_final=f[tf_at:xf_at],
                              x_final=nd((n, self.nx), np.float64, f, 8 * xf_at),
                              y_final=nd((n, self.ny), np.float64, f, 8 * yf_at), steps=steps,
                              output_names=self.output_names, state_names=self.state_names,
                              messages=messages,
                              grid=np.concatenate([[t_start], g]) if G else None,
                              y_grid=nd((n, G + 1, self.ny), np.float64, f, 8 * yg_at) if G else None,
                              n_rows=n_rows, flags=flags if self.ne else flags[:, :0],
                              event_names=self.event_names)

    def _layout(self, n: int, G: int) -> tuple:
        """The packed run's buffer for n trajectories and G communication points, as the library
        lays it out (<id>_ensemble_layout: each section's start in bytes, c_src/gw_ensemble_lib.c):
        the float sections' starts in doubles (grid, p, s, t_final, x_final, y_final, y_grid,
        and their end), the byte offsets of steps, n_rows, status and the flags' bytes, the
        buffer's size in doubles.  Kept per (n, G), a few."""
        out = (ctypes.c_long * len(self._sections))()
        self._c_layout(n, G, out)
        at = dict(zip(self._sections, out))
        lay = (*(at[k] // 8 for k in ("grid", "p", "s", "t_final", "x_final", "y_final", "y_grid", "steps")),
               *(at[k] for k in ("steps", "n_rows", "status", "flags")), at["end"] // 8)
        if len(self._layouts) > 16:
            self._layouts.clear()
        self._layouts[(n, G)] = lay
        return lay
