"""Scene files: TOML that names a wheel, its effects, initial state and experiment.

    [model]       name, description, formulation ("reduced" | "multipliers")
    [wheel]       M, R, k_diam, k_axial, beta_min
    [effects.X]   one table per effect X, its parameters (see gyrowheel.model.effects)
    [initial]     x, y, alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot
                  (angles also as <name>_deg); never x_dot/y_dot: rolling fixes them
    [experiment]  start_time, stop_time, output_interval, solver, rel_tol, abs_tol, max_step,
                  max_internal_steps
    [outputs]     keep = [...] to expose only some outputs (optional)

Every error names the file, the table and the key, and lists the valid choices.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from gyrowheel.errors import GyrowheelError
from gyrowheel.model.build import BETA_MIN_DEFAULT, FORMULATIONS, start_values, touchdown_lean, wheel_parameters
from gyrowheel.model.effects import CATALOGUE, lift_off_conflict

SOLVERS = {"euler": 1, "rk4": 2, "dopri5": 3, "rosenbrock": 4, "dop853": 5, "taylor": 6}
ANGLES = {"alpha", "beta", "gamma", "beta_min"}
TOUCHDOWN = "touchdown"  # [wheel] beta_min preset: the lean at which the body must touch the ground


class SceneError(GyrowheelError, ValueError):
    """A scene file that cannot be used; the message says where and why."""


@dataclass
class Experiment:
    start_time: float = 0.0
    stop_time: float = 20.0
    output_interval: float = 0.01
    solver: str = "dopri5"
    rel_tol: float = 1e-8
    abs_tol: float = 0.0  # 0: follow rel_tol (rel_tol / 100, so a tolerance-only run has no floor)
    max_step: float = 0.01
    max_internal_steps: int = 1_000_000  # budget of internal steps of one fmi2DoStep (docs/fmi.md)


@dataclass
class Scene:
    name: str = "wheel"
    description: str = "Gyrover wheel rolling without slip"
    formulation: str = "reduced"
    wheel: dict[str, float] = field(default_factory=dict)
    initial: dict[str, float] = field(default_factory=dict)
    effects: dict[str, dict] = field(default_factory=lambda: {"gravity": {}})
    experiment: Experiment = field(default_factory=Experiment)
    outputs: list[str] | None = None
    source: str = ""  # the TOML text, shipped in the FMU's documentation


class _Reader:
    def __init__(self, where: str):
        self.where = where

    def fail(self, table: str, key: str | None, problem: str) -> SceneError:
        loc = f"[{table}]" + (f" {key}" if key else "")
        return SceneError(f"{self.where}: {loc}: {problem}")

    def table(self, data: dict, name: str) -> dict:
        value = data.get(name, {})
        if not isinstance(value, dict):
            raise self.fail(name, None, "must be a table")
        return value

    def number(self, table: str, key: str, value) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(table, key, f"must be a number, got {type(value).__name__} {value!r}")
        if not math.isfinite(value):
            raise self.fail(table, key, f"must be finite, got {value!r}")
        return float(value)

    def positive(self, table: str, key: str, value) -> float:
        v = self.number(table, key, value)
        if v <= 0:
            raise self.fail(table, key, f"must be > 0, got {v!r}")
        return v

    def unknown(self, table: str, keys, valid) -> None:
        for key in keys:
            if key not in valid:
                raise self.fail(table, key, f"unknown key; valid: {', '.join(sorted(valid))}")


def _numbers_with_degrees(r: _Reader, table: str, data: dict, names: list[str],
                          angles: set[str] = ANGLES) -> dict[str, float]:
    """Numbers by name; every angle (unit rad) may be given in degrees as <name>_deg."""
    valid = set(names) | {f"{n}_deg" for n in names if n in angles}
    r.unknown(table, data, valid)
    out: dict[str, float] = {}
    for key, value in data.items():
        name = key[:-4] if key.endswith("_deg") else key
        if name in out:
            raise r.fail(table, key, f"{name} given twice (in rad and in deg)")
        v = r.number(table, key, value)
        out[name] = math.radians(v) if key.endswith("_deg") else v
    return out


def _wheel(r: _Reader, data: dict) -> dict[str, float]:
    data = dict(data)
    touchdown = data.get("beta_min") == TOUCHDOWN
    if touchdown:
        del data["beta_min"]
    elif isinstance(data.get("beta_min"), str):
        raise r.fail("wheel", "beta_min", f"unknown preset {data['beta_min']!r}; valid: {TOUCHDOWN} or a number")
    wheel = _numbers_with_degrees(r, "wheel", data, [q.name for q in wheel_parameters()])
    for key in ("M", "R", "k_diam", "k_axial", "beta_min"):
        if key in wheel and wheel[key] <= 0:
            raise r.fail("wheel", key, f"must be > 0, got {wheel[key]!r}")
    if touchdown:
        if "beta_min_deg" in data:
            raise r.fail("wheel", "beta_min_deg", "beta_min given twice (as a preset and in deg)")
        defaults = {q.name: q.start for q in wheel_parameters()}
        try:  # where the body touches the ground (gyrowheel.model.build.touchdown_lean), not below the default
            lean = touchdown_lean(wheel.get("k_diam", defaults["k_diam"]), wheel.get("k_axial", defaults["k_axial"]))
        except ValueError as exc:
            raise r.fail("wheel", "beta_min", str(exc)) from None
        wheel["beta_min"] = max(lean, BETA_MIN_DEFAULT)
    if wheel.get("beta_min", 0.0) >= math.pi / 2:
        raise r.fail("wheel", "beta_min", "must be < pi/2 (90 deg)")
    return wheel


def _initial(r: _Reader, data: dict, effects: dict[str, dict]) -> dict[str, float]:
    for key in ("x_dot", "y_dot", "vx", "vy"):
        if key in data:
            raise r.fail("initial", key, "is not free: rolling without slip fixes the centre "
                         "velocity from alpha_dot, beta_dot, gamma_dot")
    quantities = start_values()
    for effect in effects:
        quantities += CATALOGUE[effect].starts()
    angles = {q.name for q in quantities if q.unit == "rad"}
    initial = _numbers_with_degrees(r, "initial", data, [q.name for q in quantities], angles)
    beta = initial.get("beta")
    if beta is not None and not 0 < beta < math.pi:
        raise r.fail("initial", "beta", f"must lie in (0, pi) (0 and pi are lying flat), got {beta!r}")
    return initial


def _effect_value(r: _Reader, table: str, key: str, value, cls) -> float | str:
    choices = cls.choices()
    if key in choices:
        if value not in choices[key]:
            raise r.fail(table, key, f"unknown choice {value!r}; valid: {', '.join(choices[key])}")
        return value
    presets = cls.presets().get(key, {})
    if isinstance(value, str):
        if value not in presets:
            valid = f"{', '.join(presets)} or a number" if presets else "a number"
            raise r.fail(table, key, f"unknown preset {value!r}; valid: {valid}")
        return presets[value]
    quantity = next(q for q in cls.parameters() if q.name == key)
    v = r.number(table, key, value)
    if quantity.minimum is not None and v < quantity.minimum:
        raise r.fail(table, key, f"must be >= {quantity.minimum:g}, got {v!r}")
    if quantity.maximum is not None and v > quantity.maximum:
        raise r.fail(table, key, f"must be <= {quantity.maximum:g}, got {v!r}")
    return v


def _effects(r: _Reader, data: dict) -> dict[str, dict]:
    effects: dict[str, dict] = {}
    for name, options in data.items():
        table = f"effects.{name}"
        if name not in CATALOGUE:
            raise r.fail(table, None, f"unknown effect; valid: {', '.join(CATALOGUE)}")
        if not isinstance(options, dict):
            raise r.fail(table, None, "must be a table")
        cls = CATALOGUE[name]
        r.unknown(table, options, {q.name for q in cls.parameters()} | set(cls.choices()))
        effects[name] = {key: _effect_value(r, table, key, value, cls) for key, value in options.items()}
        conflict = cls.option_conflict(effects[name])
        if conflict:
            raise r.fail(table, conflict[0], conflict[1])
    if "gravity" not in effects:
        raise r.fail("effects", None, "[effects.gravity] is required: every FMU exposes g "
                     "(docs/interface.md); use g = 0 for a weightless wheel")
    conflict = lift_off_conflict(effects)
    if conflict:
        raise r.fail("effects.contact_forces", "on_lift_off", conflict)
    return effects


# valid ranges of the FMU's settings (c_src/gw_core.h GW_REL_TOL_MIN ...); abs_tol may also be
# exactly 0, its default: follow rel_tol (rel_tol / 100)
TOLERANCE_RANGES = {"rel_tol": (2.220446049250313e-15, 1.0), "abs_tol": (1e-30, 1.0)}
MAX_INTERNAL_STEPS_RANGE = (1, 2**31 - 1)  # an fmi2Integer (GW_MAX_INTERNAL_STEPS_MIN/_MAX)


def _experiment(r: _Reader, data: dict) -> Experiment:
    exp = Experiment()
    r.unknown("experiment", data, set(Experiment.__dataclass_fields__))
    for key, value in data.items():
        if key == "solver":
            if not isinstance(value, str) or value not in SOLVERS:
                raise r.fail("experiment", key, f"unknown solver {value!r}; valid: {', '.join(SOLVERS)}")
            exp.solver = value
        elif key == "start_time":
            exp.start_time = r.number("experiment", key, value)
        elif key == "max_internal_steps":
            low, high = MAX_INTERNAL_STEPS_RANGE
            if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
                raise r.fail("experiment", key, f"must be a whole number from {low} to {high}, got {value!r}")
            exp.max_internal_steps = value
        elif key == "abs_tol":  # 0 allowed (follow rel_tol); the range below
            exp.abs_tol = r.number("experiment", key, value)
        else:
            setattr(exp, key, r.positive("experiment", key, value))
    if exp.stop_time <= exp.start_time:
        raise r.fail("experiment", "stop_time", "must be greater than start_time")
    for key, (low, high) in TOLERANCE_RANGES.items():  # the FMU refuses others (docs/fmi.md)
        v = getattr(exp, key)
        if not (low <= v <= high or (key == "abs_tol" and v == 0.0)):
            zero = " or be 0 (follow rel_tol)" if key == "abs_tol" else ""
            raise r.fail("experiment", key, f"must lie in [{low:.3g}, {high:g}]{zero}, got {v!r}")
    return exp


def parse_scene(text: str, where: str = "<scene>") -> Scene:
    """Scene from TOML text; `where` names the file in error messages."""
    r = _Reader(where)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{where}: not valid TOML: {exc}") from None
    r.unknown("<top level>", data, {"model", "wheel", "effects", "initial", "experiment", "outputs"})
    scene = Scene(source=text)
    meta = r.table(data, "model")
    r.unknown("model", meta, {"name", "description", "formulation"})
    for key in ("name", "description", "formulation"):
        if key in meta and not isinstance(meta[key], str):
            raise r.fail("model", key, "must be a string")
    scene.name = meta.get("name", Path(where).stem if where != "<scene>" else scene.name)
    if not scene.name.isidentifier():
        raise r.fail("model", "name", f"must be a C identifier (letters, digits, _), got {scene.name!r}")
    scene.description = meta.get("description", scene.description)
    scene.formulation = meta.get("formulation", scene.formulation)
    if scene.formulation not in FORMULATIONS:
        raise r.fail("model", "formulation", f"unknown {scene.formulation!r}; valid: {', '.join(FORMULATIONS)}")
    scene.wheel = _wheel(r, r.table(data, "wheel"))
    if "effects" in data:
        scene.effects = _effects(r, r.table(data, "effects"))
    scene.initial = _initial(r, r.table(data, "initial"), scene.effects)
    scene.experiment = _experiment(r, r.table(data, "experiment"))
    outputs = r.table(data, "outputs")
    r.unknown("outputs", outputs, {"keep"})
    if "keep" in outputs:
        keep = outputs["keep"]
        if not isinstance(keep, list) or not all(isinstance(k, str) for k in keep):
            raise r.fail("outputs", "keep", "must be a list of output names")
        scene.outputs = keep
    return scene


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(f"{path}: no such scene file") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read: {exc.strerror}") from None
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not a text file (TOML is UTF-8): {exc.reason} at byte {exc.start}") from None
    return parse_scene(text, str(path))
