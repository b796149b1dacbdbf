"""A result table (CSV as `gyrowheel simulate` writes it) and the parameters its picture needs.

Columns are read by name (docs/interface.md): time, x, y, alpha, beta, gamma are required; the Gyrover's
theta_p and tilt (model/effects/gyrover.py) add the flywheel; z, contact_x, contact_y, vx, vy are
used when present. A system's result (`gyrowheel system run`: "<component>.<variable>" columns)
is read through the component whose columns carry the wheel (chosen by name when several do).
Every fault is an AnimationError with a one-line message naming the file, column and row.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrowheel.errors import GyrowheelError

REQUIRED = ("time", "x", "y", "alpha", "beta", "gamma")
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


def read_result(path: str | Path, component: str | None = None) -> ResultTable:
    """Read a result CSV (header row, then one row per output time). Raises AnimationError.

    component: for a system's result ("<component>.<variable>" columns), the component to draw
    (default: the only one with the required columns)."""
    path = Path(path)
    if not path.is_file():
        raise AnimationError(f"{path}: no such result file")
    with path.open(newline="") as fh:
        rows = [r for r in csv.reader(fh) if r]
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
    if not fmu.is_file():
        raise AnimationError(f"{fmu}: no such FMU file")
    names = ("R",) + FLYWHEEL_PARAMETERS
    if fmu.suffix.lower() == ".ssp":
        import tempfile

        from gyrowheel.cosim.system import SystemFileError, read_ssp
        with tempfile.TemporaryDirectory(prefix="gyrowheel-animate-") as tmp:
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


def resolve_parameters(table: ResultTable, R: float | None = None, fmu: str | Path | None = None) -> Parameters:
    """R and the flywheel's geometry: option, else FMU start values, else a constant CSV column, else
    (R only) z / sin(beta) from the CSV (z = R sin beta, eq. 21); the flywheel's by the model's
    defaults when nothing names them. A given R that contradicts the CSV's z raises AnimationError.
    """
    from_fmu = _fmu_parameters(Path(fmu), table.component) if fmu is not None else {}
    source: dict[str, str] = {}
    values: dict[str, float] = {}
    for name in ("R",) + FLYWHEEL_PARAMETERS:
        column = _constant_column(table, name)
        if name == "R" and R is not None:
            values[name], source[name] = float(R), "--R"
        elif name in from_fmu:
            values[name], source[name] = from_fmu[name], f"{Path(fmu).name}"
        elif column is not None:
            values[name], source[name] = column, "CSV column"
    beta = table.number("beta")
    if "z" in table:
        z, s = table.number("z"), np.sin(beta)
        ok = np.abs(s) > 1e-3
        if ok.any():
            inferred = float(np.median(z[ok] / s[ok]))
            if "R" not in values:
                values["R"], source["R"] = inferred, "z / sin(beta)"
            error = np.max(np.abs(z[ok] - values["R"] * s[ok]))
            if error > 1e-4 * values["R"]:
                raise AnimationError(f"R = {values['R']:g} m (from {source['R']}) contradicts {table.path}: "
                                     f"z = R sin(beta) gives R = {inferred:g} m")
    if "R" not in values:
        raise AnimationError(f"{table.path}: the wheel radius is unknown (no z column): pass --R or --fmu")
    if not (values["R"] > 0 and math.isfinite(values["R"])):
        raise AnimationError(f"R must be a finite number > 0, got {values['R']:g}")
    if all(c in table for c in GYROVER):
        from gyrowheel.model.effects.gyrover import Gyrover
        for q in Gyrover.parameters():
            if q.name in FLYWHEEL_PARAMETERS and q.name not in values:
                values[q.name], source[q.name] = float(q.start), "model default"
    return Parameters(**values, source=source)
