"""The errors gyrowheel raises: one base, GyrowheelError, under every one of them.

Each error keeps the built-in class it has always been (a scene that cannot be read is still a
ValueError, a failing FMU still a RuntimeError), so `except ValueError` goes on working, and adds
GyrowheelError, so `except gyrowheel.GyrowheelError` catches whatever gyrowheel reports:

    GyrowheelError                      the base (Exception)
      ArgumentError (ValueError)        an argument of a gyrowheel function that cannot be used
        ArgumentTypeError (TypeError)   ... because it is of the wrong type (text where a number goes)
      FmuError (ValueError)             an `fmu` argument that is not a usable FMI 2.0 or 3.0 FMU
      SweepSpecError (ValueError)       a sweep that cannot be run as specified
      UnknownNameError (KeyError)       a name (variable, parameter, output, extra) that is not there
        UnknownArgumentNameError        ... given in an argument (also an ArgumentError)
      MissingExtraError (ImportError)   an optional part of gyrowheel is not installed
    and, defined beside the code that raises them: SceneError, ExportError, AnimationError,
    SystemFileError (ValueErrors), SimulationError, MasterError, EnsembleError, CompileError
    (RuntimeErrors).

A Ctrl-C is no error: a sweep it stops raises SweepInterrupted, a KeyboardInterrupt (not an
Exception, so `except Exception` does not swallow it) that carries the points done.

This module imports nothing but the standard library: the classes are there in the core install.
"""
from __future__ import annotations


class GyrowheelError(Exception):
    """Base of every error gyrowheel raises; the message is one line saying what and where.

    argument: when the error is about one argument of the gyrowheel function called (its name,
    e.g. 'stop_time', 'grid', 'output'), that name, else None. The message names it, as a rule
    first (`grid['beta_deg'] = '60:89': ...`, `output out/: is a directory`), or begins with the
    file the argument names (`missing.fmu: no such FMU file`).
    """

    def __init__(self, *args: object, argument: str | None = None):
        super().__init__(*args)
        self.argument = argument


class ArgumentError(GyrowheelError, ValueError):
    """An argument of a gyrowheel function that cannot be used (a value out of range, an output
    path that cannot be written); `argument` names it."""


class ArgumentTypeError(ArgumentError, TypeError):
    """An argument of a gyrowheel function of the wrong type ('5' or None where a number goes,
    an int where a path goes); a TypeError, as Python's own for a wrong type, and an
    ArgumentError (so a ValueError too) naming the argument."""


class FmuError(GyrowheelError, ValueError):
    """An `fmu` argument that is not a usable FMU: no such file, not an FMU archive, another
    FMI version than 2.0 and 3.0 (or one the function does not run: a sweep runs FMI 2.0), no
    Co-Simulation or no binary for this platform where the FMU is to run, or a scene where an
    FMU is expected."""


class UnknownNameError(GyrowheelError, KeyError):
    """A name looked up that is not there (a variable of an FMU, a parameter, start value or
    output of an Ensemble, an optional part); a KeyError, as a failed lookup by name is. The
    message lists the names there are."""

    def __str__(self) -> str:  # KeyError's str() would quote the whole message
        return str(self.args[0]) if self.args else ""


class UnknownArgumentNameError(ArgumentError, UnknownNameError):
    """An argument that names what is not there (start_values={'nosuch': 1}): an ArgumentError
    naming the argument and an UnknownNameError, so a ValueError and a KeyError both."""


class SweepSpecError(GyrowheelError, ValueError):
    """A sweep that cannot be run as specified; the message names the value and where it was
    given: gyrowheel.sweep's argument (`grid['beta_deg']`), or in the sweep engine's own errors
    (gyrowheel.studies, which `gyrowheel sweep` prints) the command's flag (`--grid`)."""


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C (KeyboardInterrupt) stopped a sweep. It is a KeyboardInterrupt, so a program that
    does not ask goes on stopping as before; a program that does gets the points done:

    table    the result table of the points finished (pandas.DataFrame), in point order
    written  rows of it on disk in `output` (all of them, or 0 without an output file)
    total    points the sweep had
    output   the table's file (pathlib.Path), or None
    """

    def __init__(self, table, written: int, total: int, output):
        super().__init__(f"sweep interrupted: {written} of {total} points written"
                         + (f" to {output}" if output is not None else ""))
        self.table, self.written, self.total, self.output = table, written, total, output

    def __reduce__(self):
        return type(self), (self.table, self.written, self.total, self.output)


class MissingExtraError(GyrowheelError, ImportError):
    """An optional part of gyrowheel (a pip extra) is not installed. The message says which and
    the command that installs it:

        `gyrowheel sweep` needs the optional part 'sweep': pip install "gyrowheel[sweep]"

    extra: the extra's name; missing: the import names not found (e.g. ['dask', 'pandas']);
    name: the first of them (ImportError's attribute).
    """

    def __init__(self, extra: str, verb: str, missing: list[str]):
        super().__init__(f"`{verb}` needs the optional part '{extra}': pip install \"gyrowheel[{extra}]\"")
        self.extra, self.verb, self.missing = extra, verb, list(missing)
        self.name = self.missing[0] if self.missing else None

    def __reduce__(self):
        return type(self), (self.extra, self.verb, self.missing)
