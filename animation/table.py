"""A result table (CSV as `gyrowheel simulate` writes it) and the parameters its picture needs.

Columns are read by name (docs/interface.md): time, x, y, alpha, beta, gamma are required; the Gyrover's
theta_p and tilt (model/effects/gyrover.py) add the flywheel; z, contact_x, contact_y, vx, vy are
used when present. A system's result (`gyrowheel system run`: "<component>.<variable>" columns)
is read through the component whose columns carry the wheel (chosen by name when several do).
Every fault is an AnimationError with a one-line message naming the file, column and row.
"""
from __future__ import annotations

import csv
import io
import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrowheel.errors import GyrowheelError

REQUIRED = ("time", "x", "y", "alpha", "beta", "gamma")
ZIP_MAGIC = b"PK\x03\x04"  # the first bytes of a zip archive: an FMU, an .ssp
GYROVER = ("theta_p", "tilt")
FLYWHEEL_PARAMETERS = ("L_pend", "m_fly", "I_fly_axial")


class AnimationError(GyrowheelError, ValueError):
    """Bad input to the animation (file, columns, parameters, options): a one-line message."""


@dataclass
class ResultTable:
    """The columns of a result CSV as text; `number(name)` converts and checks one column."""

    path: Path
    text: dict[str, list[str]]
    rows: int
    component: str | None = None  # the system component whose columns these are (system results)

    def __contains__(self, name: str) -> bool:
        return name in self.text

    def number(self, name: str) -> np.ndarray:
        """Column `name` as floats, shape (rows,); 'true'/'false' read as 1/0. Raises AnimationError."""
        out = np.empty(self.rows)
        for i, cell in enumerate(self.text[name]):
            word = cell.strip().lower()
            try:
                out[i] = {"true": 1.0, "false": 0.0}[word] if word in ("true", "false") else float(word)
            except ValueError:
                raise AnimationError(f"{self.path}: row {i + 2}, column {name!r}: {cell!r} is not a number") from None
            if not math.isfinite(out[i]):
                raise AnimationError(f"{self.path}: row {i + 2}, column {name!r} is {cell.strip()} (not finite)")
        return out


def _text(path: Path) -> str:
    """The text of a result CSV (UTF-8, a byte order mark allowed); AnimationError saying what the
    file is when it is none: a directory, a device or FIFO, an FMU or .ssp (a zip archive: its
    run's result is wanted), a binary file."""
    if path.is_dir():
        raise AnimationError(f"{path}: is a directory, not a result CSV")
    if not path.is_file():
        if path.exists():  # reading a FIFO or a device could block or never end
            raise AnimationError(f"{path}: not a regular file (a device, FIFO or socket), not a result CSV")
        raise AnimationError(f"{path}: no such result file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise AnimationError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if raw.startswith(ZIP_MAGIC):
        suffix = path.suffix.lower()
        if suffix == ".fmu":
            raise AnimationError(f"{path}: an FMU, not a result CSV: animate draws a run; simulate the FMU first "
                                 "(gyrowheel simulate, gyrowheel.simulate) and give its result")
        if suffix == ".ssp":
            raise AnimationError(f"{path}: an SSP system, not a result CSV: animate draws a run; run the system "
                                 "first (gyrowheel system run, gyrowheel.system_run) and give its result")
        raise AnimationError(f"{path}: a zip archive, not a result CSV (a text table, as gyrowheel simulate writes)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise AnimationError(f"{path}: not a text file (a result CSV is UTF-8 text): {exc.reason} at byte "
                             f"{exc.start}") from None
    if text.startswith("\ufeff"):  # UTF-8's byte order mark (spreadsheets write one): not part of the header
        text = text[1:]
    if "\0" in text:
        raise AnimationError(f"{path}: not a text file (a result CSV is UTF-8 text): a NUL byte at byte "
                             f"{raw.index(0)}")
    return text


def read_result(path: str | Path, component: str | None = None) -> ResultTable:
    """Read a result CSV (header row, then one row per output time). Raises AnimationError.

    component: for a system's result ("<component>.<variable>" columns), the component to draw
    (default: the only one with the required columns). A file that is no text CSV is refused
    saying what it is (a directory, an FMU, an .ssp, a binary file)."""
    path = Path(path)
    rows = [r for r in csv.reader(io.StringIO(_text(path), newline="")) if r]
    if not rows:
        raise AnimationError(f"{path}: empty file (expected a CSV header and rows, as gyrowheel simulate writes)")
    header = [h.strip() for h in rows[0]]
    if len(set(header)) != len(header):
        raise AnimationError(f"{path}: repeated column {next(h for h in header if header.count(h) > 1)!r}")
    names, component = _component_columns(path, header, component)
    body = rows[1:]
    if not body:
        raise AnimationError(f"{path}: a header but no rows")
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise AnimationError(f"{path}: row {i + 2} has {len(r)} fields, the header {len(header)}")
    return ResultTable(path, {names[j]: [r[j] for r in body] for j in range(len(header)) if names[j]}, len(body),
                       component)


def _component_columns(path: Path, header: list[str], component: str | None) -> tuple[list, str | None]:
    """(the name each column is read as, the component): a column's own name, or for a system
    result the chosen component's columns without the "<component>." prefix (other components'
    columns: None, not read)."""
    systems = sorted({h.split(".", 1)[0] for h in header if "." in h})
    has = [c for c in systems if all(f"{c}.{n}" in header for n in REQUIRED[1:])]
    if component is None:
        if all(c in header for c in REQUIRED):
            return list(header), None
        if len(has) > 1:
            raise AnimationError(f"{path}: components {', '.join(has)} all have the wheel's columns: "
                                 "choose one with --component")
        if not has:
            missing = [c for c in REQUIRED if c not in header]
            raise AnimationError(f"{path}: missing column{'s' * (len(missing) > 1)} {', '.join(missing)} "
                                 f"(needs {', '.join(REQUIRED)}); a system's result needs "
                                 f"<component>.x, .y, .alpha, .beta, .gamma")
        component = has[0]
    elif component not in has:
        raise AnimationError(f"{path}: no component {component!r} with the wheel's columns "
                             f"({', '.join(REQUIRED[1:])}); components that have them: {', '.join(has) or 'none'}")
    if "time" not in header:
        raise AnimationError(f"{path}: missing column time")
    prefix = f"{component}."
    return ["time" if h == "time" else h[len(prefix):] if h.startswith(prefix) else None for h in header], component


@dataclass
class Parameters:
    """What the drawing needs beyond the columns, with where each value came from."""

    R: float
    L_pend: float = 0.0
    m_fly: float = 0.0
    I_fly_axial: float = 0.0
    source: dict[str, str] = field(default_factory=dict)


def _fmu_parameters(fmu: Path, component: str | None = None) -> dict[str, float]:
    """R and the flywheel's parameters from an FMU's start values, or from a system's (.ssp)
    component's FMU and its parameter bindings."""
    from fmpy import read_model_description
    if fmu.is_dir():
        raise AnimationError(f"{fmu}: is a directory, not an FMU")
    if not fmu.is_file():
        raise AnimationError(f"{fmu}: no such FMU file")
    names = ("R",) + FLYWHEEL_PARAMETERS
    if fmu.suffix.lower() == ".ssp":
        from gyrowheel.cosim.system import SystemFileError
        from gyrowheel.cosim.ssp import read_ssp
        from gyrowheel.scratch import temporary_directory
        with temporary_directory("animate") as tmp:
            try:
                system = read_ssp(fmu, tmp)
            except SystemFileError as exc:
                raise AnimationError(str(exc)) from None
            choices = [c for c in system.components if component is None or c.name == component]
            for c in choices:
                values = _fmu_parameters(c.fmu)
                if "R" in values:
                    values.update({k: float(v) for k, v in c.start_values.items() if k in names})
                    return values
        raise AnimationError(f"{fmu}: no component{' ' + repr(component) if component else ''} with the "
                             "wheel's parameter R")
    try:
        md = read_model_description(str(fmu))
    except Exception as exc:  # fmpy raises plain Exceptions for broken archives
        raise AnimationError(f"{fmu}: not a readable FMU: {exc}") from None
    return {v.name: float(v.start) for v in md.modelVariables if v.name in names and v.start is not None}


def _constant_column(table: ResultTable, name: str) -> float | None:
    if name not in table:
        return None
    values = table.number(name)
    if np.ptp(values) > 1e-12 * max(1.0, abs(values[0])):
        raise AnimationError(f"{table.path}: column {name!r} is a parameter of the drawing but varies over the run")
    return float(values[0])


def _given_radius(R) -> float:
    """The radius given as an option: a finite number > 0 (m); AnimationError naming --R."""
    if isinstance(R, bool) or not isinstance(R, numbers.Real) or not (math.isfinite(R) and R > 0):
        got = f"{R:g}" if isinstance(R, numbers.Real) and not isinstance(R, bool) else f"{type(R).__name__} {R!r}"
        raise AnimationError(f"--R must be a finite number > 0 (the wheel radius in m), got {got}")
    return float(R)


def resolve_parameters(table: ResultTable, R: float | None = None, fmu: str | Path | None = None) -> Parameters:
    """R and the flywheel's geometry: option, else FMU start values, else a constant CSV column, else
    (R only) z / sin(beta) from the CSV (z = R sin beta, eq. 21); the flywheel's by the model's
    defaults when nothing names them. A given R must be a finite number > 0. A given fmu must
    give what neither R nor a column gives (a foreign FMU is refused, not passed over for the
    guesses). A given R that contradicts the CSV's z raises AnimationError.
    """
    if R is not None:
        R = _given_radius(R)
    from_fmu = _fmu_parameters(Path(fmu), table.component) if fmu is not None else {}
    gyrover = all(c in table for c in GYROVER)
    source: dict[str, str] = {}
    values: dict[str, float] = {}
    for name in ("R",) + FLYWHEEL_PARAMETERS:
        column = _constant_column(table, name)
        if name == "R" and R is not None:
            values[name], source[name] = R, "--R"
        elif name in from_fmu:
            values[name], source[name] = from_fmu[name], f"{Path(fmu).name}"
        elif column is not None:
            values[name], source[name] = column, "CSV column"
    if fmu is not None:
        _fmu_gives_the_rest(Path(fmu), from_fmu, values, gyrover)
    beta = table.number("beta")
    inferred = None
    if "z" in table:
        z, s = table.number("z"), np.sin(beta)
        ok = np.abs(s) > 1e-3
        if ok.any():
            inferred = float(np.median(z[ok] / s[ok]))
            if "R" not in values:
                values["R"], source["R"] = inferred, "z / sin(beta)"
    if "R" not in values:
        raise AnimationError(f"{table.path}: the wheel radius is unknown (no z column): pass --R or --fmu")
    if not (values["R"] > 0 and math.isfinite(values["R"])):
        raise AnimationError(f"R = {values['R']:g} m (from {source['R']}): must be a finite number > 0")
    if inferred is not None:
        error = np.max(np.abs(z[ok] - values["R"] * s[ok]))
        if error > 1e-4 * values["R"]:
            raise AnimationError(f"R = {values['R']:g} m (from {source['R']}) contradicts {table.path}: "
                                 f"z = R sin(beta) gives R = {inferred:g} m")
    if gyrover:
        from gyrowheel.model.effects.gyrover import Gyrover
        for q in Gyrover.parameters():
            if q.name in FLYWHEEL_PARAMETERS and q.name not in values:
                values[q.name], source[q.name] = float(q.start), "model default"
    return Parameters(**values, source=source)


def _fmu_gives_the_rest(fmu: Path, from_fmu: dict[str, float], values: dict[str, float], gyrover: bool) -> None:
    """An FMU given for the drawing's parameters must be a wheel's (a start value of R) and, for
    a Gyrover run (theta_p, tilt columns), give the flywheel's that no column gives.
    AnimationError naming --fmu otherwise (an FMU of another model: no silent fallback to
    z / sin(beta) or the model's defaults)."""
    if "R" not in from_fmu:
        raise AnimationError(f"--fmu {fmu}: no start value of R (the wheel radius): not a wheel FMU built by "
                             "gyrowheel; give --R, or leave out --fmu (R from z / sin(beta))")
    missing = [n for n in FLYWHEEL_PARAMETERS if n not in values] if gyrover else []
    if missing:
        raise AnimationError(f"--fmu {fmu}: no start value of {', '.join(missing)} (the Gyrover's flywheel), which "
                             "this result's theta_p and tilt columns need: not the FMU of this run (a Gyrover's); "
                             "leave out --fmu to draw the flywheel with the model's defaults")
