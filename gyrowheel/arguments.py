"""The checks every verb of gyrowheel makes of its arguments, in one place.

Types and ranges (number, whole, flag, path), the file an argument names (existing_file: no such
file, a directory, a file of another kind: a scene where an FMU goes, an FMU where a system goes),
and the one rule on the size of a run's result (check_memory), which simulate, system_run, the
sweep and the Ensemble apply before they collect a single row.

Each check raises a GyrowheelError (gyrowheel/errors.py) whose message begins with what it
checks: ArgumentTypeError for a value of the wrong type, else the caller's class (ArgumentError
by default; SweepSpecError in the sweep engine, FmuError for an FMU, ...). `name` is how the
message names the value: an argument of the function called ('stop_time', 'grid'), or in the
sweep engine, whose errors `gyrowheel sweep` prints, its flag ('--stop-time'; gyrowheel.wording
words it as the argument for gyrowheel.sweep). `argument`, the error's attribute, is `name`
when that is an identifier, unless given.

Only the standard library is used: every room may import this module.
"""
from __future__ import annotations

import math
import numbers
import os
import zipfile
from pathlib import Path

from gyrowheel.errors import ArgumentError, ArgumentTypeError

# -- types and ranges -----------------------------------------------------------------------------


def _argument(name: str, argument: str | None) -> str | None:
    return argument if argument is not None else name if name.isidentifier() else None


def shown(value) -> str:
    """A value in a message: its type and repr, e.g. "str '5'" (a long repr cut short)."""
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def number(value, name: str, *, what: str = "a number", finite: bool = True, argument: str | None = None,
           error: type = ArgumentError) -> float:
    """A real number (int, float, a numpy number; not bool, not text) as a float.

    what: how the message calls the expected value ('a number of seconds'). finite: refuse inf
    and NaN (with `error`). Raises ArgumentTypeError for anything that is not a number:
    `stop_time must be a number of seconds, got str '5'`."""
    if type(value) is not float and type(value) is not int:  # (the usual types skip the ABC's check)
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ArgumentTypeError(f"{name} must be {what}, got {shown(value)}", argument=_argument(name, argument))
    value = float(value)
    if finite and not math.isfinite(value):
        raise error(f"{name} must be finite, got {value!r}", argument=_argument(name, argument))
    return value


def whole(value, name: str, *, minimum: int | None = None, what: str | None = None, argument: str | None = None,
          error: type = ArgumentError) -> int:
    """A whole number (int or a numpy integer; not bool, not 2.0) >= minimum, as an int.

    Raises ArgumentTypeError for a value that is not a number, `error` for a number that is not
    whole (`workers must be a whole number >= 0, got 1.5`) or below minimum (`workers must be
    >= 0, got -1`). what: the expected value in words, for every message (default 'a whole
    number >= minimum')."""
    expected = what or "a whole number" + ("" if minimum is None else f" >= {minimum}")
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ArgumentTypeError(f"{name} must be {expected}, got {shown(value)}", argument=_argument(name, argument))
    if not isinstance(value, numbers.Integral):
        raise error(f"{name} must be {expected}, got {value!r}", argument=_argument(name, argument))
    value = int(value)
    if minimum is not None and value < minimum:
        raise error(f"{name} must be {what or f'>= {minimum}'}, got {value}", argument=_argument(name, argument))
    return value


def flag(value, name: str, *, argument: str | None = None) -> bool:
    """True or False (numpy's bool too); ArgumentTypeError for anything else ('yes', 1, None)."""
    if type(value).__name__ == "bool_":  # numpy.bool_, without importing numpy
        value = bool(value)
    if not isinstance(value, bool):
        raise ArgumentTypeError(f"{name} must be True or False, got {shown(value)}", argument=_argument(name, argument))
    return value


def lookup_name(value, name: str, what: str) -> str:
    """A name to look up (a variable's, an output's): a str; ArgumentTypeError otherwise, before
    any lookup, so that a wrong type is not reported as a name that is not there (`name must be
    a variable's name (str), got int 3`). what: whose name, in words."""
    if isinstance(value, str):
        return value
    raise ArgumentTypeError(f"{name} must be {what} (str), got {shown(value)}", argument=_argument(name, None))


def path(value, name: str, what: str = "a file path", *, argument: str | None = None) -> Path:
    """A str or os.PathLike (a BuildResult is one) as a Path; ArgumentTypeError otherwise
    (`output must be a file path, got int`)."""
    if isinstance(value, (str, os.PathLike)):
        return Path(value)
    raise ArgumentTypeError(f"{name} must be {what}, got {type(value).__name__}", argument=_argument(name, argument))


# -- the file an argument names ---------------------------------------------------------------------

# kind -> (the noun of "no such ... file", the kind with its article, "not ..." of a directory)
KINDS = {"scene": ("scene", "a scene", "a scene file"), "fmu": ("FMU", "an FMU", "an FMU file"),
         "ssp": ("SSP", "an SSP system", "an SSP file"), "result": ("result", "a result CSV", "a result file")}
# (the file's kind, the kind expected) -> what to do instead
ADVICE = {("scene", "fmu"): "build its FMU first",
          ("scene", "ssp"): "build its FMU first",
          ("fmu", "ssp"): "simulate it with gyrowheel.simulate (`gyrowheel simulate`)",
          ("ssp", "fmu"): "run it with gyrowheel.system_run (`gyrowheel system run`)"}


def file_kind(path: Path) -> str | None:
    """What a file is, from its content where it tells: 'directory'; 'fmu' (a zip archive with
    modelDescription.xml, FMI 2.0.4 section 2.3), 'ssp' (with SystemStructure.ssd, SSP 1.0
    section 2), 'zip' (another archive); else by its suffix: 'scene' (.toml), 'result' (.csv),
    'fmu', 'ssp'; None when nothing tells (or there is no such file)."""
    if path.is_dir():
        return "directory"
    try:
        with zipfile.ZipFile(path) as zf:
            names = set(zf.namelist())
    except (zipfile.BadZipFile, OSError):
        names = None
    if names is not None:
        return "fmu" if "modelDescription.xml" in names else "ssp" if "SystemStructure.ssd" in names else "zip"
    return {".toml": "scene", ".csv": "result", ".fmu": "fmu", ".ssp": "ssp"}.get(path.suffix.lower())


def existing_file(value, name: str, expected: str, *, what: str, error: type, argument: str | None = None) -> Path:
    """The path of an existing file of kind `expected` ('fmu', 'ssp'; a scene and a result CSV
    are checked by their readers: gyrowheel.fmu_build.scene.load_scene, the animation's).

    value: a str or os.PathLike (else ArgumentTypeError: `{name} must be {what}`). Raises
    `error` with the message beginning with the file: `x.fmu: no such FMU file`, `out: is a
    directory, not an FMU file`, `moon.toml: a scene, not an FMU; build its FMU first` (a file
    of another known kind; one of no known kind is left to the reader, which says what is
    wrong with it)."""
    path_ = path(value, name, what, argument=argument)
    noun, _, a_file = KINDS[expected]
    argument = _argument(name, argument)
    if not path_.exists():
        raise error(f"{path_}: no such {noun} file", argument=argument)
    kind = file_kind(path_)
    if kind == "directory":
        raise error(f"{path_}: is a directory, not {a_file}", argument=argument)
    if kind in KINDS and kind != expected:
        advice = ADVICE.get((kind, expected))
        raise error(f"{path_}: {KINDS[kind][1]}, not {KINDS[expected][1]}" + (f"; {advice}" if advice else ""),
                    argument=argument)
    return path_


# -- the size of a run's result ---------------------------------------------------------------------

# fmpy's recorder keeps each row as a tuple of Python floats until the run ends, then makes the
# array: 41.7 bytes a value at its peak (tracemalloc, 200001 rows of 14 columns), taken as 48
FMPY_BYTES_PER_VALUE = 48


def physical_memory() -> int:
    """Bytes of physical memory (0 where the platform does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


def count(n: float) -> str:
    """A count in a message: every digit up to 12 of them (60000000001), else 3 significant ones
    (1e+302, not 303 digits)."""
    return f"{int(n)}" if n < 1e12 else f"{n:.3g}"


def check_memory(values: float, bytes_per_value: float, what: str, advice: str, *, argument: str | None,
                 error: type = ArgumentError) -> None:
    """The one rule on a result's size: a run that would hold more than half of this machine's
    physical memory in its result is refused before it starts, not left to fill the memory.

    values: numbers the run holds at once (rows x columns x runs at once); bytes_per_value: what
    each costs where the run keeps it (8 in a float64 array, FMPY_BYTES_PER_VALUE in fmpy's
    recorder). what: the run's size in words, the message's beginning (`stop_time = 1e+300 s:
    1e+302 communication points of 14 columns`); advice: what to change, naming the arguments.
    Raises `error` (argument: `argument`):
    `... would take 1.2e+295 GiB, more than half of this machine's 23.5 GiB: choose ...`."""
    need, have = values * bytes_per_value, physical_memory()
    if have and need > have / 2:
        raise error(f"{what} would take {need / 2**30:.3g} GiB, more than half of this machine's "
                    f"{have / 2**30:.3g} GiB: {advice}", argument=argument)


# -- the solver an FMU does not have ----------------------------------------------------------------

# how to get an FMU with the Taylor kernel (solver taylor, the Ensemble), in the API's words and the command's
TAYLOR_BUILD = ("gyrowheel.build(scene, output, taylor=True) or `gyrowheel build --taylor SCENE -o FMU` (or "
                "solver = \"taylor\" in the scene's [experiment])")
TAYLOR_HINT = f"taylor needs an FMU built with the Taylor kernel: {TAYLOR_BUILD}"


def missing_item_hint(variable: str, value) -> str:
    """For a solver an FMU does not offer, how to get it ('; taylor needs ...'), else ''."""
    return f"; {TAYLOR_HINT}" if variable == "solver" and str(value).strip() in ("taylor", "6") else ""
