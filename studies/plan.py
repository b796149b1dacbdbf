"""From what the user asked to what the workers run: FMU values for every point.

Input names are the unit's settable variables (parameters, start values, inputs), angles also
as <name>_deg (degrees, as the scenes write them: beta_deg), gravity presets by name (g=moon)
and enumeration items by name (solver=rk4). Names the unit does not have are allowed only with a
derive function, which turns a point's inputs into unit values (e.g. rho -> the steady
precession rates of eq. 52); it runs on the client, once per point.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import pandas as pd

from gyrowheel.arguments import missing_item_hint, number
from gyrowheel.fmi_types import out_of_range
from gyrowheel.studies.batch import Settings
from gyrowheel.studies.metrics import MetricSet, UserFunction
from gyrowheel.studies.spec import SweepSpecError


def _presets() -> dict[str, dict[str, float]]:
    from gyrowheel.model.effects import CATALOGUE
    out: dict[str, dict[str, float]] = {}
    for cls in CATALOGUE.values():
        for name, table in cls.presets().items():
            out.setdefault(name, {}).update(table)
    return out


class Resolver:
    """Maps one input (name, value) to (unit variable, typed value), or explains why not."""

    def __init__(self, variables: dict):
        self.variables = variables
        self.presets = _presets()

    def settable(self) -> list[str]:
        return sorted(n for n, v in self.variables.items() if v.settable)

    def known(self, name: str) -> bool:
        return self.target_name(name) is not None

    def target_name(self, name: str) -> str | None:
        v = self.variables.get(name)
        if v is not None:
            return name
        if name.endswith("_deg"):
            base = self.variables.get(name[:-4])
            if base is not None and base.unit == "rad":
                return base.name
        return None

    def resolve(self, name: str, value, where: str) -> tuple[str, object]:
        base = self.target_name(name)
        if base is None:
            raise SweepSpecError(f"{where}: unknown variable {name!r}; settable: {', '.join(self.settable())} "
                                 "(angles also as NAME_deg)")
        v = self.variables[base]
        if not v.settable:
            raise SweepSpecError(f"{where}: {name!r} is a calculated {v.causality} and cannot be set")
        if isinstance(value, str):
            if v.type == "Enumeration" and value in v.items:
                return base, v.items[value]
            if value in self.presets.get(base, {}):
                return base, float(self.presets[base][value])
            if v.type == "Boolean" and value.lower() in ("true", "false"):
                return base, value.lower() == "true"
            if v.type == "Enumeration":
                raise SweepSpecError(f"{where}: value {value!r} for {name!r} is not one of its items; valid: "
                                     f"{', '.join(v.items)} (or their numbers){missing_item_hint(base, value)}")
            choices = list(self.presets.get(base, {}))
            extra = f"; valid: {', '.join(choices)} or a number" if choices else ""
            raise SweepSpecError(f"{where}: value {value!r} for {name!r} is not a number{extra}")
        value = float(value)
        if not math.isfinite(value):
            raise SweepSpecError(f"{where}: value {value!r} for {name!r} is not finite")
        if name != base:
            value = math.radians(value)
        if v.type in ("Integer", "Enumeration"):
            if value != int(value):
                raise SweepSpecError(f"{where}: {name!r} is an {v.type} and {value!r} is not an integer")
            outside = out_of_range(v, int(value))  # an fmi2Integer: ctypes would wrap it (3e9 -> -1294967296)
            if outside:
                raise SweepSpecError(f"{where}: value {value!r} for {name!r} is {outside}")
            value = int(value)
            if v.type == "Enumeration" and v.items and value not in v.items.values():
                raise SweepSpecError(f"{where}: {value} is not an item of {name!r}; valid: "
                                     + ", ".join(f"{k}={i}" for k, i in v.items.items())
                                     + missing_item_hint(base, value))
        elif v.type == "Boolean":
            value = bool(value)
        return base, value


@dataclass
class Plan:
    """Everything a sweep runs: the target, its settings and metrics, and the points."""

    target: object
    settings: Settings
    metrics: MetricSet
    inputs: pd.DataFrame  # one row per point, the inputs as given (index: point number)
    values: list  # per point: {unit variable: value}

    def tasks(self, batch_size: int) -> list[list]:
        """Batches of (point, values, inputs) in point order."""
        records = self.inputs.to_dict("records")
        items = [(int(p), v, r) for p, v, r in zip(self.inputs.index, self.values, records)]
        return [items[i:i + batch_size] for i in range(0, len(items), batch_size)]


def _missing(value) -> bool:
    """A cell a point left empty (a key it does not have, None, NaN): the unit's start value applies."""
    return value is None or (not isinstance(value, str) and bool(pd.isna(value)))


def _times(target, stop_time, output_interval, start_time) -> tuple[float, float]:
    """(stop time, output interval) [s]: given, or the unit's DefaultExperiment; finite and ordered."""
    for flag, value in (("--stop-time", stop_time), ("--output-interval", output_interval), ("start_time", start_time)):
        if value is not None:  # their types; finite and ordered: below
            number(value, flag, what="a number of seconds", finite=False)
    stop = stop_time if stop_time is not None else getattr(target, "default_stop_time", None)
    if stop is None:
        raise SweepSpecError("no stop time: give --stop-time (the unit declares none)")
    if not math.isfinite(start_time):
        raise SweepSpecError(f"the start time must be finite, got {start_time!r}")
    if not (math.isfinite(stop) and stop > start_time):
        raise SweepSpecError(f"--stop-time must be finite and greater than the start time {start_time:g}, got {stop:g}")
    if output_interval is None:  # the unit's step, or a single step when it has none
        output_interval = getattr(target, "default_step", None) or (stop - start_time)
    if not (math.isfinite(output_interval) and output_interval > 0):
        raise SweepSpecError(f"--output-interval must be > 0 and finite, got {output_interval:g}")
    return float(stop), float(min(output_interval, stop - start_time))


def _as_given(value):
    """A value as the user gave it, for an error message: a number's text as the number."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return value


def _check_fixed(target, fixed: dict, where: dict, values: list, start_time: float, shown: dict) -> None:
    """SweepSpecError when the unit refuses the values every point sets (`fixed`, named as
    `where` says, quoted as `shown` has them where given in other units), as they are set or at
    initialisation with the points' values (`values`): the target's optional
    refused(values, start_time, points), FmuTarget.refused."""
    refused = getattr(target, "refused", None)
    found = refused(fixed, start_time, values) if refused is not None and fixed else None
    if found is None:
        return
    name, reason = found
    if name is None:  # only their combination
        raise SweepSpecError(f"{', '.join(where[n] for n in fixed)}: the unit refuses these values together for "
                             f"every point: {reason}")
    raise SweepSpecError(f"{where[name]}: the unit refuses {shown.get(name, fixed[name])!r} for every point: {reason}")


def make_plan(target, inputs: pd.DataFrame, *, fixed: Mapping | None = None, solver_settings: Mapping | None = None,
              derive=None, stop_time: float | None = None, output_interval: float | None = None,
              start_time: float = 0.0, metrics=None, metric_functions=(), ensemble: bool = True) -> Plan:
    """Check every name and value against the unit and convert the points to unit values.

    fixed: values every point sets (--set); solver_settings: the solver settings every point sets
    ({'solver': 'rk4', 'rel_tol': 1e-8, ...}: --solver, --rel-tol, --abs-tol, --max-step), named
    by their flags in errors. A value of these that the unit refuses, as it is set (e.g. rel_tol
    -1, outside its range) or at initialisation with a point's values (e.g. R -1: R must be > 0),
    is refused here, before anything runs: every point would fail with it (the target's optional
    refused(values, start_time, points): FmuTarget.refused). A point's own value the unit
    refuses is no error here: that point fails, the others run.
    A point's empty cell (a key other points have, None, NaN) leaves that variable at the unit's
    start value. A variable with two names (beta and beta_deg; M and wheel.M in a system, through
    the target's optional canonical(name)) may be given only once.
    ensemble: let batches take the ensemble path where it applies (the unit's solver is taylor).
    """
    variables = target.variables()
    res = Resolver(variables)
    canonical = getattr(target, "canonical", lambda name: name)
    derive_fn = UserFunction.parse(derive, "--derive") if derive is not None else None
    fixed_values: dict = {}
    where: dict = {}  # unit variable -> how the sweep's errors name where it was given
    shown: dict = {}  # unit variable -> its value as given, where that is not the unit's (degrees)
    given = [(n, v, f"--set {n}") for n, v in (fixed or {}).items()]
    given += [(n, v, f"--{n.replace('_', '-')}") for n, v in (solver_settings or {}).items()]
    for n, v, flag in given:
        base, value = res.resolve(n, v, flag)
        if any(canonical(base) == canonical(other) for other in fixed_values):
            raise SweepSpecError(f"{base!r} given twice (--set, --solver/--rel-tol/--abs-tol/--max-step, "
                                 "or under another name)")
        fixed_values[base], where[base] = value, flag
        if n != base:  # given under another name (beta_min_deg): its errors quote the value as given
            shown[base] = _as_given(v)
    direct = [c for c in inputs.columns if res.known(c)]
    unknown = [c for c in inputs.columns if not res.known(c)]
    if unknown and derive_fn is None:
        res.resolve(unknown[0], 0.0, f"input {unknown[0]!r}")  # raises: unknown variable
    targets = [canonical(res.target_name(c)) for c in direct]
    fixed_targets = {canonical(n) for n in fixed_values}
    for name in set(targets):
        if targets.count(name) > 1:
            raise SweepSpecError(f"{name!r} is swept twice (in rad and in deg, or under another name)")
        if name in fixed_targets:
            raise SweepSpecError(f"{name!r} is both swept and fixed with --set")
    stop, interval = _times(target, stop_time, output_interval, start_time)
    starts = {n: v.start for n, v in variables.items() if v.start is not None and v.type != "String"}
    values = []
    for point, row in zip(inputs.index, inputs.to_dict("records")):
        own = dict(res.resolve(c, row[c], f"point {point}: {c}") for c in direct if not _missing(row[c]))
        if derive_fn is not None:
            seen = {**starts, **fixed_values, **own}
            try:
                extra = derive_fn.call(row, seen)
            except Exception as exc:
                raise SweepSpecError(f"--derive {derive_fn.ref}: point {point}: {type(exc).__name__}: {exc}") from None
            if not isinstance(extra, Mapping):
                raise SweepSpecError(f"--derive {derive_fn.ref}: must return a dict of unit values, got {extra!r}")
            own.update(res.resolve(n, v, f"--derive {derive_fn.ref}: point {point}: {n}") for n, v in extra.items())
        values.append(own)
    _check_fixed(target, fixed_values, where, values, float(start_time), shown)
    settings = Settings(stop_time=stop, output_interval=interval, start_time=float(start_time), fixed=fixed_values,
                        ensemble=ensemble)
    metric_set = MetricSet.parse(metrics, metric_functions, outputs=list(target.outputs),
                                 discrete=getattr(target, "discrete_outputs", None),
                                 booleans=getattr(target, "flag_names", None))
    return Plan(target, settings, metric_set, inputs, values)
