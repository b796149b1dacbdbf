"""Scenes: TOML files that name a wheel, its effects, initial state and experiment, and the
Scene objects they are read into (docs/scenes.md).

    [model]       name, description, formulation ("reduced" | "multipliers")
    [wheel]       M, R, k_diam, k_axial, beta_min
    [effects.X]   one table per effect X, its parameters (see gyrowheel.model.effects)
    [initial]     x, y, alpha, beta, gamma, alpha_dot, beta_dot, gamma_dot
                  (angles also as <name>_deg); never x_dot/y_dot: rolling fixes them
    [experiment]  start_time, stop_time, output_interval, solver, rel_tol, abs_tol, max_step,
                  max_internal_steps
    [outputs]     keep = [...] to expose only some outputs (optional)
    [build]       platforms = "all", "host" or platform tuples (a list, or comma-separated): the
                  binaries the FMU carries (optional; default the host only; `gyrowheel build
                  --platforms` overrides it)
                  fmi = 2 or 3: the FMI version of the FMU (optional; default 2; `gyrowheel
                  build --fmi` overrides it)
                  arrays = true or false: an FMI 3 FMU's array outputs x_state and
                  contact_force (optional; default true; `gyrowheel build --no-arrays` leaves
                  them out; an FMI 2 FMU has none)
                  taylor = true or false: the Taylor kernel in the FMU (optional; default:
                  where the solver is taylor, or auto and the kernel supports the model;
                  `gyrowheel build --taylor / --no-taylor` overrides it)

One set of rules serves both ways in: parse_scene reads a file's tables through it, and
check_scene puts a Scene made or changed in Python (dataclasses.replace, attribute assignment)
through the same rules, so an object is refused exactly where its file would be, and builds
exactly as its file would. Every error names the file (or the scene), the table and the key,
and lists the valid choices.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
import os
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from gyrowheel.errors import GyrowheelError
from gyrowheel.fmu_build.experiment import FIXED_SOLVER_MAX_STEP, SOLVERS, Experiment  # noqa: F401 (API)
from gyrowheel.fmu_build.platforms import parse_platforms
from gyrowheel.fmu_build.scene_toml import scene_toml  # noqa: F401 (part of this module's API)
from gyrowheel.model.build import (BETA_MIN_DEFAULT, FORMULATIONS, MASS_REFUSAL, RIM_SPEED_REFUSAL, SLIDE_NEEDS_REDUCED,
                                   SPEED_REFUSAL, SPEEDS, start_values, touchdown_lean, wheel_parameters)
from gyrowheel.model.effects import CATALOGUE, lift_off_conflict
from gyrowheel.model.spec import MASS_RANGE, SPEED_OF_LIGHT, range_refusal

ANGLES = {"alpha", "beta", "gamma", "beta_min"}
TOUCHDOWN = "touchdown"  # [wheel] beta_min preset: the lean at which the body must touch the ground
TABLES = ("model", "wheel", "effects", "initial", "experiment", "outputs", "build")
ZIP_MAGIC = b"PK\x03\x04"  # the start of a zip archive (an FMU, an .ssp)
# The model name is the FMU's modelIdentifier, "a short class name according to C syntax"
# (FMI 2.0.4, section 2.2.1): its binary's file name and the prefix of the C API of export-c,
# so ASCII letters, digits and _ only (Python's str.isidentifier also takes 'Ωwheel').
C_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
# [model] description is an attribute of modelDescription.xml's root element. libxml2, the XML
# reader of fmpy (through lxml) and of many importers, refuses a start tag of 10,000,000 bytes
# or more without its XML_PARSE_HUGE option (XML_MAX_TEXT_LENGTH, "Buffer size limit
# exceeded"); a character takes at most 6 bytes there (&quot;), so 1,000,000 characters leave
# the root's other attributes ample room.
DESCRIPTION_MAX = 1_000_000


class SceneError(GyrowheelError, ValueError):
    """A scene that cannot be used; the message says where and why: the file (or, for a Scene
    object, `scene 'NAME'`), the table and the key, e.g.
    `paper.toml: [wheel] M: must be > 0, got -1.0`."""




@dataclass
class Scene:
    """A scene: what gyrowheel.build (build_fmu) and export_c turn into an FMU or C code.

    Read from a file by load_scene / parse_scene, or made in Python; build_fmu and export_c
    check it with check_scene (the file's rules), so a Scene changed with dataclasses.replace
    is refused where its file would be. Values are in SI units, angles in rad (the file's
    <angle>_deg keys and presets are converted when it is read).

    name         the FMU's modelIdentifier and modelName: a C identifier (letters, digits, _);
                 a file's [model] name, default its file name without .toml
    description  free text: modelDescription.xml's description
    formulation  "reduced" (Kane/Maggi null space) or "multipliers" (Lagrange multipliers with
                 stabilisation), docs/model.md
    wheel        {name: value} of the base wheel's parameters: M kg, R m, k_diam 1, k_axial 1
                 (I_diam = k_diam M R^2, I_axial = k_axial M R^2), beta_min rad (the lean at
                 which the wheel counts as fallen; < pi/2); each > 0; missing ones keep the
                 paper's defaults (docs/interface.md)
    initial      {name: value} of start values: x, y m; alpha, beta, gamma rad (beta in
                 (0, pi), pi/2 upright); alpha_dot, beta_dot, gamma_dot rad/s; and the start
                 values the effects add (docs/effects.md); missing ones keep their defaults
    effects      {effect: {parameter or choice: value}}: the effects built in, by their
                 catalogue name (gyrowheel.model.effects.CATALOGUE), each with its parameters
                 (SI numbers) and string choices; "gravity" is required (every FMU exposes g)
    experiment   an Experiment: DefaultExperiment and the solver parameters' defaults
    outputs      the optional outputs to expose ([outputs] keep), or None: all of them; the
                 names are checked when the FMU is built
    platforms    the platforms whose binaries the FMU carries ([build] platforms): "all",
                 "host", or FMI 3.0 platform tuples, a list or comma-separated
                 (gyrowheel.fmu_build.platforms: x86_64-linux, aarch64-linux, x86_64-windows,
                 ...); None (the default): the host only; a `platforms` argument of build_fmu /
                 gyrowheel.build overrides it
    fmi          the FMI version of the FMU ([build] fmi): 2 (the default: FMI 2.0.4) or 3
                 (FMI 3.0.2, Co-Simulation and Model Exchange from the same model); an `fmi`
                 argument of build_fmu / gyrowheel.build overrides it
    arrays       ([build] arrays) an FMI 3 FMU has the array outputs x_state and contact_force
                 (True, the default) or not (False: for importers that read no arrays); an
                 `arrays` argument of build_fmu / gyrowheel.build overrides it
    source       the scene's TOML text, shipped in the FMU's documentation/index.html
                 ("Built from"); check_scene writes it anew when it no longer describes the
                 scene (a Scene changed in Python, or made there)
    taylor       [build] taylor: True, the Taylor kernel in the FMU whatever the solver; False,
                 none (refused with solver taylor); None (the default): the kernel for solver
                 taylor, and for solver auto where the model's operations allow it
                 (gyrowheel.fmu_build.codegen.kernel_choice)
    file         the scene file it was loaded from (load_scene), or None; build_fmu refuses to
                 write the FMU over it
    """

    name: str = "wheel"
    description: str = "Gyrover wheel rolling without slip"
    formulation: str = "reduced"
    wheel: dict[str, float] = field(default_factory=dict)
    initial: dict[str, float] = field(default_factory=dict)
    effects: dict[str, dict] = field(default_factory=lambda: {"gravity": {}})
    experiment: Experiment = field(default_factory=Experiment)
    outputs: list[str] | None = None
    platforms: str | list[str] | None = None
    taylor: bool | None = None  # [build] taylor; None: where the solver needs it (builder.kernel_choice)
    fmi: int = 2
    arrays: bool = True
    source: str = ""  # the TOML text, shipped in the FMU's documentation
    file: Path | None = field(default=None, compare=False)  # where load_scene read it from


class _Reader:
    """The rules' error messages: `where` names the file or the scene; `mapping` is what a table
    is in its words ("table" in a file, "dict" in a Scene object)."""

    def __init__(self, where: str, mapping: str = "table"):
        self.where, self.mapping = where, mapping
        self.degrees: dict[tuple[str, str], float] = {}  # (table, angle) -> the value given as <angle>_deg

    def fail(self, table: str, key: str | None, problem: str) -> SceneError:
        """The error at [table] key. An angle given in degrees is named as it was written: the
        rules check it in rad, so the message adds the value in degrees the user wrote."""
        deg = self.degrees.get((table, key)) if key else None
        if deg is not None:
            key, problem = f"{key}_deg", f"{problem} (rad; given as {key}_deg = {deg!r} deg)"
        loc = f"[{table}]" + (f" {key}" if key else "")
        return SceneError(f"{self.where}: {loc}: {problem}")

    def in_degrees(self, table: str, key: str, value) -> float:
        """<angle>_deg = value: the angle in rad, remembered as given in degrees (see fail)."""
        deg = self.number(table, f"{key}_deg", value)
        self.degrees[(table, key)] = deg
        return math.radians(deg)

    def table(self, data: dict, name: str) -> dict:
        value = data.get(name, {})
        if not isinstance(value, dict):
            raise self.fail(name, None, f"must be a {self.mapping}")
        return value

    def number(self, table: str, key: str, value) -> float:
        if isinstance(value, bool) or not isinstance(value, numbers.Real):  # (a Scene object's numpy numbers too)
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
        out[name] = r.in_degrees(table, name, value) if key.endswith("_deg") else r.number(table, key, value)
    return out


def _wheel(r: _Reader, data: dict) -> dict[str, float]:
    data = dict(data)
    touchdown = data.get("beta_min") == TOUCHDOWN
    if touchdown:
        del data["beta_min"]
    elif isinstance(data.get("beta_min"), str):
        raise r.fail("wheel", "beta_min", f"unknown preset {data['beta_min']!r}; valid: {TOUCHDOWN} or a number")
    wheel = _numbers_with_degrees(r, "wheel", data, [q.name for q in wheel_parameters()])
    defaults = {q.name: q.start for q in wheel_parameters()}
    for key in ("M", "R", "k_diam", "k_axial", "beta_min"):
        if key in wheel and wheel[key] <= 0:
            raise r.fail("wheel", key, f"must be > 0, got {wheel[key]!r}")
    for q in wheel_parameters():
        if q.name in wheel:
            _in_limits(r, "wheel", q, wheel[q.name])
    if touchdown:
        if "beta_min_deg" in data:
            raise r.fail("wheel", "beta_min_deg", "beta_min given twice (as a preset and in deg)")
        try:  # where the body touches the ground (gyrowheel.model.build.touchdown_lean), not below the default
            lean = touchdown_lean(wheel.get("k_diam", defaults["k_diam"]), wheel.get("k_axial", defaults["k_axial"]))
        except ValueError as exc:
            raise r.fail("wheel", "beta_min", str(exc)) from None
        wheel["beta_min"] = max(lean, BETA_MIN_DEFAULT)
    if wheel.get("beta_min", 0.0) >= math.pi / 2:
        raise r.fail("wheel", "beta_min", "must be < pi/2 (90 deg)")
    k_diam, k_axial = (wheel.get(k, defaults[k]) for k in ("k_diam", "k_axial"))
    if k_axial > 1:
        raise r.fail("wheel", "k_axial", f"must be <= 1 (a ring, all mass at radius R, is the limit), got {k_axial!r}")
    if k_axial > 2 * k_diam:
        raise r.fail("wheel", "k_axial", f"must be <= 2 k_diam (I_axial <= 2 I_diam for any rigid body), "
                     f"got {k_axial!r} with k_diam {k_diam!r} ({_source(data, 'k_diam')})")
    return wheel


def _source(table: dict, key: str) -> str:
    """Where a scene value of a combination refusal came from: the table (given) or the default."""
    return "the scene's" if key in table or f"{key}_deg" in table else "the default"


def _initial(r: _Reader, data: dict, effects: dict[str, dict]) -> dict[str, float]:
    for key in ("x_dot", "y_dot", "vx", "vy"):
        if key in data and effects.get("contact_forces", {}).get("on_slip") == "slide":
            raise r.fail("initial", key, "is not a start value: the centre velocity is the rolling one "
                         "(from alpha_dot, beta_dot, gamma_dot) plus the start slip slip_long, slip_lat")
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
    for q in quantities:
        if q.name in initial:
            _in_limits(r, "initial", q, initial[q.name])
    if initial.get("vz", 0.0) != 0.0 and not initial.get("height", 0.0) > 0.0:
        raise r.fail("initial", "vz", f"must be 0 unless height > 0 (in contact the centre's vertical velocity "
                     f"follows the lean rate), got {initial['vz']!r} with height {initial.get('height', 0.0)!r}")
    return initial


def _in_limits(r: _Reader, table: str, quantity, value: float) -> None:
    """Refuse a value outside the quantity's inclusive limits (Quantity.minimum, .maximum), as
    the FMU's checks at initialisation would (model/effects/base.py, Effect.declare; the
    physical ranges of mass and start speeds, model/build.py), with the FMU's reason."""
    if quantity.name == "M" and not MASS_RANGE[0] <= value <= MASS_RANGE[1]:
        raise r.fail(table, quantity.name, f"{MASS_REFUSAL.removeprefix('M (mass) ')}, got {value!r}")
    if quantity.unit == "m/s" and (quantity.minimum, quantity.maximum) == (-SPEED_OF_LIGHT, SPEED_OF_LIGHT) \
            and not abs(value) <= SPEED_OF_LIGHT:
        raise r.fail(table, quantity.name, f"{SPEED_REFUSAL}, got {value!r}")
    if quantity.closed_range and not quantity.minimum <= value <= quantity.maximum:
        refusal = range_refusal(quantity.name, quantity.minimum, quantity.maximum, quantity.unit)
        raise r.fail(table, quantity.name, f"{refusal.removeprefix(quantity.name + ' ')}, got {value!r}")
    if quantity.minimum is not None and value < quantity.minimum:
        raise r.fail(table, quantity.name, f"must be >= {quantity.minimum:g}, got {value!r}")
    if quantity.maximum is not None and value > quantity.maximum:
        raise r.fail(table, quantity.name, f"must be <= {quantity.maximum:g}, got {value!r}")


def _lean_above_fall(r: _Reader, scene: Scene) -> None:
    """The start lean strictly between beta_min and pi - beta_min (the FMU's check at
    initialisation, model/build.py): a wheel that starts at or below the fall lean has fallen."""
    beta = scene.initial.get("beta", next(q.start for q in start_values() if q.name == "beta"))
    beta_min = scene.wheel.get("beta_min", BETA_MIN_DEFAULT)
    if not math.sin(beta) > math.sin(beta_min):
        raise r.fail("initial", "beta", f"must lie between beta_min and pi - beta_min ({beta_min!r} .. "
                     f"{math.pi - beta_min!r} rad): the wheel would start fallen, got {beta!r}")


def _rim_below_light(r: _Reader, scene: Scene) -> None:
    """Each start rate's rim speed R |rate| at most the speed of light (the FMU's check at
    initialisation, model/build.py RIM_SPEED_REFUSAL)."""
    radius = scene.wheel.get("R", next(q.start for q in wheel_parameters() if q.name == "R"))
    for speed in SPEEDS:
        rate = scene.initial.get(speed, 0.0)
        if not radius * abs(rate) <= SPEED_OF_LIGHT:
            raise r.fail("initial", speed, f"|{speed}| {RIM_SPEED_REFUSAL}, got {rate!r} with R = {radius!r}")


def _effect_value(r: _Reader, table: str, key: str, value, cls) -> float | str:
    choices = cls.choices()
    if key in choices:
        if value not in choices[key]:
            raise r.fail(table, key, f"unknown choice {value!r}; valid: {', '.join(choices[key])}")
        return value
    presets = cls.presets().get(key, {})
    if isinstance(value, str):
        if not presets:  # a string where only a number can go: no preset was meant
            raise r.fail(table, key, f"must be a number (no presets), got str {value!r}")
        if value not in presets:
            raise r.fail(table, key, f"unknown preset {value!r}; valid: {', '.join(presets)} or a number")
        return presets[value]
    quantity = next(q for q in cls.parameters() if q.name == key)
    v = r.number(table, key, value)
    _in_limits(r, table, quantity, v)
    return v


def _effects(r: _Reader, data: dict) -> dict[str, dict]:
    effects: dict[str, dict] = {}
    for name, options in data.items():
        table = f"effects.{name}"
        if name not in CATALOGUE:
            raise r.fail(table, None, f"unknown effect; valid: {', '.join(CATALOGUE)}")
        if not isinstance(options, dict):
            raise r.fail(table, None, f"must be a {r.mapping}")
        cls = CATALOGUE[name]
        angles = {q.name for q in cls.parameters() if q.unit == "rad"}  # also as <name>_deg, in degrees
        r.unknown(table, options, {q.name for q in cls.parameters()} | set(cls.choices())
                  | {f"{a}_deg" for a in angles})
        effects[name] = {}
        for key, value in options.items():
            base = key[:-4] if key.endswith("_deg") and key[:-4] in angles else key
            if base in effects[name]:
                raise r.fail(table, key, f"{base} given twice (in rad and in deg)")
            if base != key:
                value = r.in_degrees(table, base, value)
            effects[name][base] = _effect_value(r, table, base, value, cls)
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


def _sliding(r: _Reader, scene: Scene) -> None:
    """The sliding (flight) mode's start values need on_slip = "slide" (on_lift_off = "fly"); sliding
    needs the reduced formulation."""
    slide = scene.effects.get("contact_forces", {}).get("on_slip") == "slide"
    for key in ("slip_long", "slip_lat"):
        if key in scene.initial and not slide:
            raise r.fail("initial", key, 'is a start value of the sliding mode: it needs [effects.contact_forces] '
                         'on_slip = "slide"')
    fly = scene.effects.get("contact_forces", {}).get("on_lift_off") == "fly"
    for key in ("height", "vz"):
        if key in scene.initial and not fly:
            raise r.fail("initial", key, 'is a start value of the flight mode: it needs [effects.contact_forces] '
                         'on_lift_off = "fly"')
    if slide and scene.formulation != "reduced":
        raise r.fail("effects.contact_forces", "on_slip", SLIDE_NEEDS_REDUCED)


# valid ranges of the FMU's settings (c_src/gw_core.h GW_REL_TOL_MIN ...); abs_tol may also be
# exactly 0, its default: follow rel_tol (rel_tol / 100)
TOLERANCE_RANGES = {"rel_tol": (2.220446049250313e-15, 1.0), "abs_tol": (1e-30, 1.0)}
MAX_INTERNAL_STEPS_RANGE = (1, 2**31 - 1)  # an fmi2Integer (GW_MAX_INTERNAL_STEPS_MIN/_MAX)


def _experiment(r: _Reader, data: dict) -> Experiment:
    r.unknown("experiment", data, set(Experiment.__dataclass_fields__))
    values: dict = {}
    for key, value in data.items():
        if key == "solver":
            if not isinstance(value, str) or value not in SOLVERS:
                raise r.fail("experiment", key, f"unknown solver {value!r}; valid: {', '.join(SOLVERS)}")
            values[key] = value
        elif key == "start_time":
            values[key] = r.number("experiment", key, value)
        elif key == "max_internal_steps":
            low, high = MAX_INTERNAL_STEPS_RANGE
            if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not low <= value <= high:
                raise r.fail("experiment", key, f"must be a whole number from {low} to {high}, got {value!r}")
            values[key] = int(value)
        elif key == "abs_tol":  # 0 allowed (follow rel_tol); the range below
            values[key] = r.number("experiment", key, value)
        else:
            values[key] = r.positive("experiment", key, value)
    exp = Experiment(**values)  # the max_step default follows the solver and the run (Experiment)
    if exp.stop_time <= exp.start_time:
        raise r.fail("experiment", "stop_time", "must be greater than start_time")
    for key, (low, high) in TOLERANCE_RANGES.items():  # the FMU refuses others (docs/fmi.md)
        v = getattr(exp, key)
        if not (low <= v <= high or (key == "abs_tol" and v == 0.0)):
            zero = " or be 0 (follow rel_tol)" if key == "abs_tol" else ""
            raise r.fail("experiment", key, f"must lie in [{low:.3g}, {high:g}]{zero}, got {v!r}")
    return exp


def _validate(r: _Reader, data: dict, default_name: str) -> Scene:
    """The scene of `data`, a file's tables ({table: {key: value}}), every rule applied: the one
    validator of parse_scene and check_scene. Raises SceneError naming table and key."""
    r.unknown("<top level>", data, set(TABLES))
    scene = Scene()
    meta = r.table(data, "model")
    r.unknown("model", meta, {"name", "description", "formulation"})
    for key in ("name", "description", "formulation"):
        if key in meta and not isinstance(meta[key], str):
            raise r.fail("model", key, "must be a string")
    scene.name = meta.get("name", default_name)
    if not C_IDENTIFIER.fullmatch(scene.name):
        letters = "ASCII letters" if scene.name.isidentifier() else "letters"  # 'Ωwheel': say which letters
        raise r.fail("model", "name", f"must be a C identifier ({letters}, digits, _), got {scene.name!r}")
    scene.description = meta.get("description", scene.description)
    if len(scene.description) > DESCRIPTION_MAX:
        raise r.fail("model", "description", f"has {len(scene.description)} characters, more than the "
                     f"{DESCRIPTION_MAX} modelDescription.xml readers take (docs/scenes.md)")
    scene.formulation = meta.get("formulation", scene.formulation)
    if scene.formulation not in FORMULATIONS:
        raise r.fail("model", "formulation", f"unknown {scene.formulation!r}; valid: {', '.join(FORMULATIONS)}")
    scene.wheel = _wheel(r, r.table(data, "wheel"))
    if "effects" in data:
        scene.effects = _effects(r, r.table(data, "effects"))
    scene.initial = _initial(r, r.table(data, "initial"), scene.effects)
    _sliding(r, scene)
    _lean_above_fall(r, scene)
    _rim_below_light(r, scene)
    scene.experiment = _experiment(r, r.table(data, "experiment"))
    outputs = r.table(data, "outputs")
    r.unknown("outputs", outputs, {"keep"})
    if "keep" in outputs:
        keep = outputs["keep"]
        if not isinstance(keep, list) or not all(isinstance(k, str) for k in keep):
            raise r.fail("outputs", "keep", "must be a list of output names")
        scene.outputs = list(keep)
    build = r.table(data, "build")
    r.unknown("build", build, {"platforms", "fmi", "arrays", "taylor"})
    if "platforms" in build:
        scene.platforms = _platforms(r, build["platforms"])
    if "fmi" in build:
        scene.fmi = _fmi(r, build["fmi"])
    if "arrays" in build:
        if not isinstance(build["arrays"], bool):
            raise r.fail("build", "arrays", f"must be true or false, got {build['arrays']!r}")
        scene.arrays = build["arrays"]
    if "taylor" in build:
        if not isinstance(build["taylor"], bool):
            raise r.fail("build", "taylor", f"must be true or false, got {build['taylor']!r}")
        scene.taylor = build["taylor"]
    return scene


FMI_VERSIONS = (2, 3)  # the FMI versions an FMU can be built for: 2.0.4 and 3.0.2


def fmi_problem(value) -> str | None:
    """Why `value` is no FMI version an FMU can be built for (FMI_VERSIONS: the integer 2 or
    3), or None when it is one."""
    if isinstance(value, bool) or value not in FMI_VERSIONS or not isinstance(value, numbers.Integral):
        return f"must be 2 or 3 (the FMI version), got {value!r}"
    return None


def _fmi(r: _Reader, value) -> int:
    """[build] fmi: 2 or 3, an integer (fmi_problem)."""
    problem = fmi_problem(value)
    if problem is not None:
        raise r.fail("build", "fmi", problem)
    return int(value)


def _platforms(r: _Reader, value) -> str | list[str]:
    """[build] platforms: a string as `gyrowheel build --platforms` takes it ("all", "host", a
    platform or several, comma-separated) or a list of platform names, each checked against
    gyrowheel.fmu_build.platforms.PLATFORMS; kept as given."""
    if not (isinstance(value, str) or (isinstance(value, list) and value and all(isinstance(v, str) for v in value))):
        raise r.fail("build", "platforms", f'must be "all", "host" or a list of platform names, got {value!r}')
    try:
        parse_platforms(value)
    except ValueError as exc:  # ArgumentError: "platforms: unknown platform 'x'; valid: ..."
        raise r.fail("build", "platforms", str(exc).split(": ", 1)[1]) from None
    return value if isinstance(value, str) else list(value)


def parse_scene(text: str, where: str = "<scene>") -> Scene:
    """The Scene of a scene file's TOML text, every rule of docs/scenes.md applied.

    text: the TOML (str); where: how errors name the file (e.g. its path); its stem is the
    model name when [model] name is not given (the default "<scene>": name "wheel").
    Returns the Scene: angles in rad (<angle>_deg converted), presets resolved (g = "moon" ->
    1.625, beta_min = "touchdown" -> the lean), defaults filled in, source = text, file None
    (load_scene sets it).
    Raises SceneError, one line naming `where`, the table and the key, and the valid choices
    where there is a list (docs/scenes.md, "Rules: what is refused"), e.g.
        s.toml: not valid TOML: Expected ']' at the end of a table declaration (at line 1, column 7)
        s.toml: [wheel] M: must be > 0, got 0.0
        s.toml: [effects.gravity] g: unknown preset 'jupiter'; valid: earth, mars, moon or a number
        s.toml: [effects]: [effects.gravity] is required: every FMU exposes g (docs/interface.md); ...
        s.toml: [experiment] solver: unknown solver 'rk45'; valid: euler, rk4, dopri5, rosenbrock, dop853, taylor
    Combinations only the model can judge (an [outputs] keep name, k_axial > 2 k_diam) are
    refused when the FMU is built or initialised, not here.
    """
    if not isinstance(text, str):
        raise SceneError(f"{where}: the scene text must be a str, got {type(text).__name__}")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{where}: not valid TOML: {exc}") from None
    except RecursionError:  # tomllib parses nested arrays and inline tables recursively
        raise SceneError(f"{where}: arrays or inline tables nested too deep for the TOML reader "
                         "(no scene needs more than keep = [...])") from None
    scene = _validate(_Reader(where), data, Path(where).stem if where != "<scene>" else Scene.name)
    scene.source = text
    return scene


def _tables(r: _Reader, scene: Scene) -> dict:
    """A Scene object's fields as a file's tables (what _validate reads)."""
    if not isinstance(scene.experiment, Experiment):
        raise r.fail("experiment", None, f"must be an Experiment (gyrowheel.fmu_build.scene.Experiment), "
                                         f"got {type(scene.experiment).__name__}")
    return {"model": {"name": scene.name, "description": scene.description, "formulation": scene.formulation},
            "wheel": scene.wheel, "effects": scene.effects, "initial": scene.initial,
            "experiment": {f.name: getattr(scene.experiment, f.name) for f in dataclasses.fields(Experiment)
                           if getattr(scene.experiment, f.name) is not None},  # None: the default
            "outputs": {} if scene.outputs is None else {"keep": scene.outputs},
            "build": {**({} if scene.platforms is None else {"platforms": scene.platforms}), "fmi": scene.fmi,
                      "arrays": scene.arrays, **({} if scene.taylor is None else {"taylor": scene.taylor})}}


def _content(scene: Scene) -> tuple:
    """What a scene builds (every field but its source text and file)."""
    return tuple(getattr(scene, f.name) for f in dataclasses.fields(Scene) if f.name not in ("source", "file"))


def check_scene(scene: Scene) -> Scene:
    """A Scene object checked by the rules a scene file is read by (parse_scene), whether it was
    loaded, made in Python or changed since (dataclasses.replace, assignment).

    scene: a Scene. Returns a new Scene (the argument is not changed) that builds exactly as the
    scene file saying the same would: numbers as floats, angles in rad, presets resolved
    (wheel beta_min = "touchdown", an effect's preset such as g = "moon", <angle>_deg keys
    converted), its own dicts and lists; source the given TOML text if that still describes it,
    else a TOML text written from it (so the FMU's documentation shows what was built); file
    kept. Checking a checked scene returns an equal one.
    Raises SceneError with parse_scene's messages, the scene named by its name, e.g.
        scene 'paper_moon': [wheel] M: must be > 0, got -1.0
        scene 'paper_moon': [effects]: [effects.gravity] is required: every FMU exposes g ...
        scene 'a b': [model] name: must be a C identifier (letters, digits, _), got 'a b'
        scene 'paper_moon': [experiment] solver: unknown solver 'bogus'; valid: euler, rk4, ...
        scene 'paper_moon': [wheel] M: must be a number, got str 'a'
    and for a scene that is not a Scene (its type named). Source: docs/scenes.md.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene must be a gyrowheel.Scene, got {type(scene).__name__}", argument="scene")
    r = _Reader(f"scene {scene.name!r}", mapping="dict")
    checked = _validate(r, _tables(r, scene), Scene.name)
    if not isinstance(scene.source, str):
        raise SceneError(f"{r.where}: source must be the scene's TOML text (a str), got {type(scene.source).__name__}")
    if scene.file is not None and not isinstance(scene.file, (str, os.PathLike)):
        raise SceneError(f"{r.where}: file must be a path or None, got {type(scene.file).__name__}")
    checked.file = None if scene.file is None else Path(scene.file)
    checked.source = scene.source if _describes(scene.source, checked) else scene_toml(checked)
    return checked


def _describes(text: str, scene: Scene) -> bool:
    """Whether the TOML `text` reads as `scene` (its name from [model] name or, as a file named
    after the scene would give it, from the file name)."""
    if not text:
        return False
    try:
        return _content(parse_scene(text, f"{scene.name}.toml")) == _content(scene)
    except SceneError:
        return False


def load_scene(path: str | Path) -> Scene:
    """Read and check a scene file (UTF-8 TOML, docs/scenes.md): parse_scene of its text.

    path: the file (str or os.PathLike). Returns its Scene, with file = the path and source =
    the file's text.
    Raises SceneError, one line beginning with the path: `PATH: no such scene file`,
    `PATH: cannot read: Is a directory`, `PATH: an FMU (a zip archive), not a scene file: ...`,
    `PATH: not a text file (TOML is UTF-8): invalid start byte at byte 0`, and every error of
    parse_scene (`PATH: [wheel] M: must be > 0, got 0.0`).
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise SceneError(f"{path}: no such scene file") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read: {exc.strerror}") from None
    if raw.startswith(ZIP_MAGIC):
        what = "an FMU" if path.suffix.lower() == ".fmu" else "an SSP system" if path.suffix.lower() == ".ssp" \
            else "a zip archive"
        raise SceneError(f"{path}: {what} (a zip archive), not a scene file: a scene is TOML text "
                         "(docs/scenes.md)")
    try:
        text = raw.decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")  # as text mode reads it
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not a text file (TOML is UTF-8): {exc.reason} at byte {exc.start}") from None
    scene = parse_scene(text, str(path))
    scene.file = path
    return scene
