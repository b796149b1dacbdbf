"""Metrics: numbers computed from one run's trajectory, one or more table columns each.

Built in (all SI, angles in rad; beta is the paper's lean angle, pi/2 upright):
    survived        bool   reached the stop time without a terminating event
    fall_time       s      time of the fall (the FMU's located event time), NaN if it did not fall
    end_time        s      time reached (stop time, or the time of a terminating event)
    event                  Boolean outputs true at the end, e.g. 'fallen', 'slipping' ('' if none):
                           terminating and warning events alike (each flag stays true once fired)
    min_beta, max_beta     extremes of beta over the communication points
    max_lean        rad    max |beta - pi/2|: the largest lean away from upright
    final_position  m      columns final_x, final_y (the centre at the end)
    energy_drift    1      max |B(t) - B(0)| / |B(0)| over the communication points, B the energy
                           balance energy + dissipated_energy - actuator_work (each of the two last
                           terms where the unit outputs it; B = energy without them), constant in
                           exact arithmetic (docs/effects.md, "energy")
    final:NAME             any Real output at the end (column final_NAME); an Integer output's
                           value (int), an Enumeration output's item name (str, e.g. 'rolling'),
                           a Boolean output's value (bool, e.g. final:slipping)
    max:NAME, min:NAME, mean:NAME   a Real output over the communication points (column max_NAME, ...)
A user's function (module:function or path/to/file.py:function, or a Python callable through
the API) receives the trajectory as a numpy structured array (fields 'time' and every Real
output, as fmpy.simulate_fmu returns) and, if it takes a second argument, the point's inputs
as given (dict); it returns a number or a dict of numbers (one column each); anything else
fails the point, with the reason.
Extremes are taken over the communication points (the output interval), not between them.
"""
from __future__ import annotations

import hashlib
import importlib
import inspect
import math
import numbers
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from gyrowheel.arguments import shown
from gyrowheel.studies.spec import SweepSpecError, items_of

BUILTIN = ("survived", "fall_time", "end_time", "event", "min_beta", "max_beta", "max_lean",
           "final_position", "energy_drift")
DEFAULT = ("survived", "fall_time", "end_time", "event", "min_beta", "max_lean", "final_position", "energy_drift")
REDUCERS = {"final": lambda v: v[-1], "max": np.max, "min": np.min, "mean": np.mean}
NEEDS = {"min_beta": "beta", "max_beta": "beta", "max_lean": "beta", "final_position": ("x", "y"),
         "energy_drift": "energy"}


@dataclass
class Run:
    """One finished run: communication times (k,), Real outputs (k, n_out), how it ended."""

    time: np.ndarray
    outputs: np.ndarray
    names: list[str]
    stop_time: float
    terminated: bool
    flags: list[str]  # the Boolean outputs true at the end (fired flags), terminating or not
    finals: dict = field(default_factory=dict)  # Integer/Enumeration outputs at the end, by name

    def column(self, name: str) -> np.ndarray:
        return self.outputs[:, self.names.index(name)]

    def structured(self) -> np.ndarray:
        dtype = [("time", "f8")] + [(n, "f8") for n in self.names]
        arr = np.empty(len(self.time), dtype=dtype)
        arr["time"] = self.time
        for i, n in enumerate(self.names):
            arr[n] = self.outputs[:, i]
        return arr


def _builtin(name: str, run: Run, booleans=()) -> dict[str, object]:
    if name == "survived":
        return {"survived": not run.terminated}
    if name == "fall_time":
        return {"fall_time": float(run.time[-1]) if run.terminated and "fallen" in run.flags else math.nan}
    if name == "end_time":
        return {"end_time": float(run.time[-1])}
    if name == "event":
        return {"event": ",".join(run.flags)}
    if name in ("min_beta", "max_beta"):
        beta = run.column("beta")
        return {name: float(beta.min() if name == "min_beta" else beta.max())}
    if name == "max_lean":
        return {"max_lean": float(np.max(np.abs(run.column("beta") - math.pi / 2)))}
    if name == "final_position":
        return {"final_x": float(run.column("x")[-1]), "final_y": float(run.column("y")[-1])}
    if name == "energy_drift":
        balance = energy_balance(run)
        return {"energy_drift": float(np.max(np.abs(balance - balance[0])) / abs(balance[0]))}
    kind, var = name.split(":", 1)
    if var in booleans:  # a Boolean output (final: only): true at the end
        return {f"{kind}_{var}": var in run.flags}
    if var in run.finals:
        return {f"{kind}_{var}": run.finals[var]}
    return {f"{kind}_{var}": float(REDUCERS[kind](run.column(var)))}


def energy_balance(run: Run) -> np.ndarray:
    """B(t) = energy + dissipated_energy - actuator_work (k,) [J], the terms the unit outputs:
    constant in exact arithmetic, with or without dissipative and actuator effects."""
    balance = run.column("energy").copy()
    if "dissipated_energy" in run.names:
        balance += run.column("dissipated_energy")
    if "actuator_work" in run.names:
        balance -= run.column("actuator_work")
    return balance


@dataclass
class UserFunction:
    """A user's Python function, resolved lazily where it runs (client or worker).

    `ref` is 'module:function' (importable on every worker) or 'path/file.py:function' (the file's
    text is read on the client and travels with the sweep, so remote workers need no copy).
    """

    ref: str
    source: str | None = None
    function: Callable | None = None
    _resolved: Callable | None = field(default=None, repr=False, compare=False)

    @classmethod
    def parse(cls, ref, flag: str = "--metric-function") -> "UserFunction":
        if callable(ref):
            return cls(ref=getattr(ref, "__name__", repr(ref)), function=ref)
        if not isinstance(ref, str) or ":" not in ref:
            raise SweepSpecError(f"{flag} {ref!r}: expected module:function or path/to/file.py:function")
        where, name = ref.rsplit(":", 1)
        if not name.isidentifier():
            raise SweepSpecError(f"{flag} {ref!r}: {name!r} is not a function name")
        if where.endswith(".py"):
            try:
                source = Path(where).read_text(encoding="utf-8")
            except OSError as exc:
                raise SweepSpecError(f"{flag} {ref!r}: cannot read {where}: {exc.strerror}") from None
            fn = cls(ref=ref, source=source)
        else:
            fn = cls(ref=ref)
        fn.resolve(flag)  # fail on the client, with the flag named, not on every worker
        return fn

    @property
    def name(self) -> str:
        return self.ref.rsplit(":", 1)[-1] if self.function is None else self.ref

    def resolve(self, flag: str = "--metric-function") -> Callable:
        if self.function is not None:
            return self.function
        if self._resolved is None:
            where, name = self.ref.rsplit(":", 1)
            try:
                if self.source is not None:
                    module = _module_from_source(where, self.source)
                else:
                    module = importlib.import_module(where)
            except Exception as exc:
                raise SweepSpecError(f"{flag} {self.ref!r}: cannot load {where}: "
                                     f"{type(exc).__name__}: {exc}") from None
            fn = getattr(module, name, None)
            if not callable(fn):
                raise SweepSpecError(f"{flag} {self.ref!r}: {where} has no function {name!r}")
            self._resolved = fn
        return self._resolved

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_resolved"] = None
        return state

    def call(self, *args):
        fn = self.resolve()
        try:
            n = len(inspect.signature(fn).parameters)
        except (TypeError, ValueError):
            n = len(args)
        return fn(*args[:max(1, n)])


_MODULES: dict[str, types.ModuleType] = {}


def _module_from_source(path: str, source: str) -> types.ModuleType:
    key = hashlib.sha256(source.encode()).hexdigest()
    if key not in _MODULES:
        module = types.ModuleType(Path(path).stem)
        module.__file__ = path
        exec(compile(source, path, "exec"), module.__dict__)
        _MODULES[key] = module
    return _MODULES[key]


def _needed(name: str) -> tuple[str, ...]:
    needed = NEEDS.get(name, ())
    return (needed,) if isinstance(needed, str) else needed


@dataclass
class MetricSet:
    """The metrics of a sweep: built-in names and user functions, checked against the outputs."""

    names: tuple[str, ...] = DEFAULT
    functions: tuple[UserFunction, ...] = ()
    discrete: dict = field(default_factory=dict)  # the final:NAME of Integer/Enumeration outputs: {NAME: items}
    booleans: tuple[str, ...] = ()  # the final:NAME of Boolean outputs (read from Run.flags)

    @classmethod
    def parse(cls, names, functions=(), outputs: list[str] | None = None,
              discrete: dict | None = None, booleans=None) -> "MetricSet":
        """The metrics `names` (None: the defaults the unit's outputs allow) and user `functions`,
        checked against the unit's Real `outputs`, its Integer/Enumeration outputs `discrete`
        ({name: {value: item}}, {} for an Integer) and its Boolean outputs `booleans` (names), the
        last two read by final:NAME only. SweepSpecError naming the metric for anything the unit
        cannot give."""
        discrete = discrete or {}
        booleans = tuple(booleans or ())
        used, used_booleans = {}, []
        defaulted = names is None
        if defaulted:
            names = DEFAULT
        elif isinstance(names, str):
            names = [n.strip() for n in names.split(",") if n.strip()]
        names = tuple(names)
        for name in names:
            if ":" in name:
                kind, var = name.split(":", 1)
                if kind not in REDUCERS:
                    raise SweepSpecError(f"--metrics {name!r}: unknown; use final:NAME, max:NAME, min:NAME, mean:NAME "
                                         "(user functions go in --metric-function)")
                if var in discrete:
                    if kind != "final":
                        raise SweepSpecError(f"--metrics {name!r}: {var!r} is an Integer/Enumeration output, read "
                                             f"at the end only: use final:{var}")
                    used[var] = discrete[var]
                    continue
                if var in booleans:
                    if kind != "final":
                        raise SweepSpecError(f"--metrics {name!r}: {var!r} is a Boolean output, read at the end "
                                             f"only: use final:{var} (true or false) or the metric event")
                    used_booleans.append(var)
                    continue
                needed = (var,)
            elif name not in BUILTIN:
                raise SweepSpecError(f"--metrics {name!r}: unknown metric; valid: {', '.join(BUILTIN)}, "
                                     "final:NAME, max:NAME, min:NAME, mean:NAME")
            else:
                needed = _needed(name)
            if outputs is not None:
                for var in needed:
                    if var not in outputs:
                        raise SweepSpecError(f"--metrics {name!r}: the unit has no Real output {var!r}; "
                                             f"outputs: {', '.join(outputs)}"
                                             + (f"; Integer/Enumeration outputs (final: only): {', '.join(discrete)}"
                                                if discrete else "")
                                             + (f"; Boolean outputs (final: only): {', '.join(booleans)}"
                                                if booleans else ""))
        if defaulted and outputs is not None:  # the defaults adapt to what the unit outputs
            names = tuple(n for n in names if all(v in outputs for v in _needed(n)))
        if functions and not isinstance(functions, UserFunction):
            functions = items_of(functions, "--metric-function",
                                 "a list of 'module:function' references or functions")
        funcs = tuple(f if isinstance(f, UserFunction) else UserFunction.parse(f) for f in functions or ())
        return cls(names, funcs, used, tuple(used_booleans))

    def columns(self) -> dict[str, str]:
        """The table's metric columns known before anything runs, in order, {column: kind}: kind
        'bool' (survived, final: of a Boolean output), 'text' (event) or 'number'. Every built-in metric's, and a user
        function's own name for one that returns a number; the columns of a function that returns
        a dict are its keys, known once a point has run."""
        out: dict[str, str] = {}
        for name in self.names:
            if name == "final_position":
                out.update(final_x="number", final_y="number")
            elif ":" in name:
                kind, var = name.split(":", 1)
                out[f"{kind}_{var}"] = ("bool" if var in self.booleans else
                                        "text" if self.discrete.get(var) else "number")
            else:
                out[name] = {"survived": "bool", "event": "text"}.get(name, "number")
        return out

    def evaluate(self, run: Run, point: dict) -> dict[str, object]:
        """All metric columns of one run; a user function that raises fails the point (PointFailure)."""
        from gyrowheel.studies.target import PointFailure

        out: dict[str, object] = {}
        for name in self.names:
            out.update(_builtin(name, run, self.booleans))
        if self.functions:
            traj = run.structured()
            for fn in self.functions:
                try:
                    value = fn.call(traj, dict(point))
                except Exception as exc:
                    raise PointFailure(f"metric function {fn.ref}: {type(exc).__name__}: {exc}") from None
                values = value if isinstance(value, dict) else {fn.name: value}
                for column, v in values.items():
                    if not isinstance(column, str) or not _is_number(v):
                        raise PointFailure(f"metric function {fn.ref}: returned {shown(value)}, not a number or a "
                                           "dict of numbers {column name: number}")
                out.update(values)
        return out


def _is_number(value) -> bool:
    """A value a metric column holds: a real number (NaN too), a bool, or numpy's."""
    return isinstance(value, (bool, np.bool_, numbers.Real)) and not isinstance(value, np.ndarray)
