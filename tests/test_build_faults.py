"""Every scene either builds or is refused in one line; the lift-off policies hold.

- every formulation x effect combination builds, and the multiplier form of the Gyrover (a system
  with a driven coordinate, whose multipliers must not be left in placeholder symbols: CasADi's
  "variables [tilt] are free") follows the reduced form with the tilt input driven.
- on_lift_off = "ignore" means no event and no flag, also with the load-proportional laws that add
  a lift-off stop of their own; a law that cannot go on past lift-off makes the scene reader
  refuse the policy, naming the key.
- a Scene object goes through the scene file's rules wherever it is built (build_fmu, export_c,
  gyrowheel.build), answers every odd value as its file does, and builds the FMU its file would;
  an output that is no .fmu name or is the scene file itself is refused before anything is built.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import re
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from scipy.integrate import solve_ivp

import gyrowheel
from conftest import SCENES
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.cli import main
from gyrowheel.errors import ArgumentError
from gyrowheel.fmu_build.platforms import host_platform
from gyrowheel.fmu_build.scene import Experiment, Scene, SceneError, check_scene, load_scene
from gyrowheel.model import build_model
from gyrowheel.model.build import FORMULATIONS
from gyrowheel.model.effects import CATALOGUE

OPTIONAL = [name for name in CATALOGUE if name != "gravity"]
COMBINATIONS = [()] + [(e,) for e in OPTIONAL] + list(itertools.combinations(OPTIONAL, 2)) + [tuple(OPTIONAL)]


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_every_formulation_and_effect_combination_builds(formulation):
    """Gravity plus none, one, any two or all effects: the model and its generated Functions build."""
    failures = []
    for combo in COMBINATIONS:
        effects = {"gravity": {}, **{name: {} for name in combo}}
        try:
            build_model(effects=effects, formulation=formulation).functions()
        except Exception as exc:  # noqa: BLE001 - collect every kind of failure
            failures.append(f"{'+'.join(combo) or 'gravity'}: {type(exc).__name__}: {str(exc).splitlines()[-1]}")
    assert not failures, "\n".join(failures)


def _trajectory(formulation: str, t_eval: np.ndarray) -> dict[str, np.ndarray]:
    spec = build_model(effects={"gravity": {}, "gyrover": {}}, formulation=formulation)
    fns = spec.functions()
    p = np.array([q.start for q in spec.parameters], dtype=float)
    start = {"beta": 1.45, "gamma_dot": 8.0, "theta_p": 0.1}
    x0 = np.array(fns["init"]([start.get(q.name, q.start) for q in spec.starts], p)).ravel()

    def u(t):  # tilt_cmd, drive_torque: the servo is driven all the time
        return [0.3 * math.sin(4.0 * t), 0.02]

    sol = solve_ivp(lambda t, x: np.array(fns["ode"](t, x, u(t), p)).ravel(), (0.0, t_eval[-1]), x0,
                    method="DOP853", rtol=1e-11, atol=1e-12, t_eval=t_eval)
    assert sol.success, sol.message
    names = [q.name for q, _ in spec.outputs]
    y = np.array([np.array(fns["out"](t, x, u(t), p)).ravel() for t, x in zip(sol.t, sol.y.T)])
    return {name: y[:, i] for i, name in enumerate(names)}


def test_gyrover_multiplier_form_follows_the_reduced_form():
    """3 s with tilt_cmd = 0.3 sin(4 t) and a drive torque: every common output agrees to 1e-8 relative."""
    t = np.linspace(0.0, 3.0, 31)
    reduced, multipliers = _trajectory("reduced", t), _trajectory("multipliers", t)
    assert np.ptp(reduced["tilt"]) > 0.4 and np.ptp(reduced["beta"]) > 0.01  # the input really acts
    for name, values in reduced.items():
        scale = max(np.abs(values).max(), 1e-3)
        assert np.abs(multipliers[name] - values).max() < 1e-8 * scale, name
    assert multipliers["constraint_violation"].max() < 1e-10


# -- no traceback, whatever the scene -------------------------------------------------------

def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("gyrowheel: error: "), err
    assert "Traceback" not in err
    return lines[0]


ODD_VALUES = ["[]", "{}", '"x"', "true", "1", "1.5", "-1", "0", "1e308", "inf", "nan", "1979-05-27", "[1, 2]",
              '"touchdown"', '"ignore"', '"earth"']


NEIGHBOURS = ("effects.gravity", "effects.rolling_resistance")  # the effect tables beside an effect's own


def _odd_scenes():
    """(table, key, value's TOML text, the scene file's text): every key of every table with
    every odd value (an effect's table beside NEIGHBOURS)."""
    keys = {"model": ["name", "description", "formulation"],
            "wheel": ["M", "R", "k_diam", "k_axial", "beta_min", "beta_min_deg"],
            "initial": ["beta", "beta_deg", "gamma_dot", "x_dot"],
            "experiment": ["start_time", "stop_time", "output_interval", "solver", "rel_tol", "abs_tol", "max_step",
                           "max_internal_steps"],
            "outputs": ["keep"]}
    keys.update({f"effects.{name}": [q.name for q in cls.parameters()] + list(cls.choices())
                 for name, cls in CATALOGUE.items()})
    for table, names in keys.items():
        prefix = "".join(f"[{t}]\n" for t in NEIGHBOURS if t != table) if table.startswith("effects.") else ""
        for key, value in itertools.product(names, ODD_VALUES):
            yield table, key, value, f"{prefix}[{table}]\n{key} = {value}\n"


def test_reader_answers_every_odd_value_with_a_scene_error():
    """Every key of every table with values of every TOML type: a SceneError or a scene, nothing else
    (a list as solver, for one, must not escape as TypeError: unhashable type)."""
    escaped = []
    for table, key, value, text in _odd_scenes():
        try:
            parse_scene(text, "s.toml")
        except SceneError:
            pass
        except Exception as exc:  # noqa: BLE001
            escaped.append(f"[{table}] {key} = {value}: {type(exc).__name__}: {exc}")
    assert not escaped, "\n".join(escaped)


def _object(table: str, key: str, value) -> Scene:
    """The Scene object saying what `[table] key = value` says in the file (with the same
    neighbouring effect tables as the file)."""
    if table == "model":
        return dataclasses.replace(Scene(), **{key: value})
    if table == "experiment":
        experiment = Experiment()
        setattr(experiment, key, value)
        return Scene(experiment=experiment)
    if table == "outputs":
        return Scene(outputs=value)
    if table.startswith("effects."):
        effects = {t.split(".", 1)[1]: {} for t in NEIGHBOURS if t != table}
        effects[table.split(".", 1)[1]] = {key: value}
        return Scene(effects=effects)
    return dataclasses.replace(Scene(), **{table: {key: value}})


def test_objects_answer_every_odd_value_as_their_files():
    """One rule set: a Scene object holding each odd value where its file has it is refused with
    the file's message (after the name of the file or scene), or read as the same scene."""
    import tomllib
    differ = []
    for table, key, text, scene_text in _odd_scenes():
        value = tomllib.loads(f"v = {text}")["v"]
        try:
            expected = parse_scene(scene_text, "wheel.toml")
        except SceneError as exc:
            expected = str(exc).split(": ", 1)[1]
        try:
            got = check_scene(_object(table, key, value))
        except SceneError as exc:
            got = re.sub(r"^scene .*?: \[", "[", str(exc))
        if isinstance(expected, Scene) and isinstance(got, Scene):
            same = dataclasses.replace(got, source="") == dataclasses.replace(expected, source="")
        else:
            same = got == expected
        if not same:
            differ.append(f"[{table}] {key} = {text}: file {expected!r}, object {got!r}")
    assert not differ, "\n".join(differ)


# -- what is built where ---------------------------------------------------------------------

@pytest.mark.parametrize("name,fragment", [
    ("out.toml", "ends in '.toml'; an FMU's file name ends in .fmu (FMI 2.0.4, section 2.1)"),
    ("noext", "has no extension; an FMU's file name ends in .fmu (FMI 2.0.4, section 2.1)"),
])
def test_an_fmu_is_written_only_to_an_fmu_name(tmp_path, name, fragment):
    scene = load_scene(SCENES / "paper_moon.toml")
    for build in (build_fmu, gyrowheel.build):
        with pytest.raises(ArgumentError) as err:
            build(scene, tmp_path / name)
        assert str(err.value) == f"output {tmp_path / name}: {fragment}" and err.value.argument == "output"
    assert list(tmp_path.iterdir()) == []


def test_the_scene_file_is_never_overwritten(tmp_path, capsys):
    """`gyrowheel build my2.toml -o my2.toml`: refused in one line naming -o, the scene unchanged;
    a scene file named like an FMU is not overwritten by its own FMU either."""
    scene = tmp_path / "my2.toml"
    scene.write_text("[effects.gravity]\n")
    assert main(["build", str(scene), "-o", str(scene)]) != 0
    assert _one_error_line(capsys).startswith(f"gyrowheel: error: -o {scene}: is the scene file the FMU is built "
                                              "from; writing the FMU there would overwrite it")
    assert scene.read_text() == "[effects.gravity]\n"
    odd = tmp_path / "odd.fmu"
    odd.write_text("[effects.gravity]\n")
    with pytest.raises(ArgumentError, match="is the scene file the FMU is built from"):
        build_fmu(load_scene(odd), odd)
    assert odd.read_text() == "[effects.gravity]\n"


@pytest.mark.parametrize("change,message", [
    (dict(effects={}), "scene 'paper_moon': [effects]: [effects.gravity] is required"),
    (dict(name="a b"), "scene 'a b': [model] name: must be a C identifier (letters, digits, _), got 'a b'"),
    (dict(wheel={"M": -1.0}), "scene 'paper_moon': [wheel] M: must be > 0, got -1.0"),
])
def test_every_build_path_checks_the_scene_object(tmp_path, change, message):
    """build_fmu, export_c and gyrowheel.build / export_c refuse a Scene its file would be
    refused for, before anything is written."""
    from gyrowheel.fmu_build.export_c import export_c
    scene = dataclasses.replace(load_scene(SCENES / "paper_moon.toml"), **change)
    for build, out in ((build_fmu, "x.fmu"), (gyrowheel.build, "x.fmu"), (export_c, "x_c"),
                       (gyrowheel.export_c, "x_c")):
        with pytest.raises(SceneError) as err:
            build(scene, tmp_path / out)
        assert str(err.value).startswith(message), (build, str(err.value))
    assert list(tmp_path.iterdir()) == []


def _members(fmu) -> dict[str, bytes]:
    with zipfile.ZipFile(fmu) as zf:
        return {n: re.sub(rb'generationDateAndTime="[^"]*"', b"", zf.read(n)) for n in zf.namelist()}


def test_a_scene_object_builds_the_fmu_of_its_file(tmp_path):
    """A changed Scene builds exactly the FMU of the scene file saying the same (its documentation
    shows that file); without build_dir no sources directory is pointed to; repr is short."""
    moon = load_scene(SCENES / "paper_moon.toml")
    changed = dataclasses.replace(moon, wheel={**moon.wheel, "M": 3}, initial={**moon.initial, "gamma_dot": 7})
    built = build_fmu(changed, tmp_path / "object.fmu")
    text = check_scene(changed).source
    assert "M = 3.0" in text and "gamma_dot = 7.0" in text
    (tmp_path / "paper_moon.toml").write_text(text)
    from_file = build_fmu(load_scene(tmp_path / "paper_moon.toml"), tmp_path / "file.fmu", build_dir=tmp_path / "b")
    assert _members(built.fmu) == _members(from_file.fmu)
    assert built.sources is None and from_file.sources == tmp_path / "b" / "fmu" / "sources"
    assert (from_file.sources / "gw_funcs.c").is_file()
    assert repr(built) == (f"BuildResult(fmu={tmp_path / 'object.fmu'!r}, identifier='paper_moon', "
                           f"platforms=({host_platform().name!r},))")


def test_unexpected_build_failure_is_one_line(tmp_path, capsys, monkeypatch):
    """Whatever escapes model building (a CasADi RuntimeError here) becomes one line and exit 1."""
    import gyrowheel.fmu_build.builder

    def broken(*args, **kwargs):
        raise RuntimeError("Error in Function::Function for 'gw_out' [SXFunction]\n...\n"
                           "gw_out::init: Initialization failed since variables [tilt] are free.")
    monkeypatch.setattr(gyrowheel.fmu_build.builder, "build_fmu", broken)
    scene = tmp_path / "s.toml"
    scene.write_text("[effects.gravity]\n")
    assert main(["build", str(scene), "-o", str(tmp_path / "s.fmu")]) == 1
    line = _one_error_line(capsys)
    assert "variables [tilt] are free" in line and "RuntimeError" in line


@pytest.mark.parametrize("setup,fragment", [
    (lambda p: p.write_bytes(b"\xd0\xcf\x11\xe0 binary"), "not a text file"),
    (lambda p: p.mkdir(), "cannot read"),
])
def test_unreadable_scene_is_one_line(tmp_path, capsys, setup, fragment):
    scene = tmp_path / "s.toml"
    setup(scene)
    assert main(["build", str(scene)]) == 2
    assert fragment in _one_error_line(capsys)


def test_unwritable_output_is_one_line(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text("[effects.gravity]\n")
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["build", str(scene), "-o", str(blocker / "s.fmu")]) == 2  # bad input, as for simulate -o
    assert "cannot write" in _one_error_line(capsys)


# -- lift-off ---------------------------------------------------------------------------------

@pytest.mark.parametrize("law", ["rolling_resistance", "spin_friction"])
@pytest.mark.parametrize("policy", ["ignore", "warn"])
def test_load_proportional_law_refuses_going_on_past_lift_off(law, policy):
    """The reader names the key; the Python API refuses the same combination."""
    text = f'[effects.gravity]\n[effects.{law}]\n[effects.contact_forces]\non_lift_off = "{policy}"\n'
    with pytest.raises(SceneError) as err:
        parse_scene(text, "s.toml")
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(f"s.toml: [effects.contact_forces] on_lift_off: '{policy}' is not possible with {law}")
    with pytest.raises(ValueError, match="on_lift_off"):
        build_model(effects={"gravity": {}, law: {}, "contact_forces": {"on_lift_off": policy}})


@pytest.mark.parametrize("policy,events", [
    ("terminate", {"fall": "terminate", "lift_off": "terminate", "slip": "warn"}),
    ("warn", {"fall": "terminate", "lift_off": "warn", "slip": "warn"}),
    ("ignore", {"fall": "terminate", "slip": "warn"}),
])
def test_lift_off_policy_decides_the_event(policy, events):
    spec = build_model(effects={"gravity": {}, "contact_forces": {"on_lift_off": policy}})
    assert {ev.name: ev.action for ev in spec.events} == events


@pytest.mark.parametrize("law,events", [
    ("smoothed", {"fall": "terminate", "lift_off": "terminate"}),
    ("stiction", {"fall": "terminate", "rolling_stiction": "update", "lift_off": "terminate"}),
])
def test_load_proportional_law_alone_stops_at_lift_off(law, events):
    spec = build_model(effects={"gravity": {}, "rolling_resistance": {"law": law}})
    assert {ev.name: ev.action for ev in spec.events} == events


def test_ignored_lift_off_runs_on(tmp_path):
    """An upright wheel tipped over at 6 rad/s: F_n reaches 0 at about 0.094 s. With "ignore" the FMU
    has no lifted_off flag and runs on (bilateral contact, F_n < 0) until the fall event."""
    scene = parse_scene('[model]\nname = "ignore_lift"\n[effects.gravity]\n[effects.contact_forces]\n'
                        'on_lift_off = "ignore"\n', "ignore_lift.toml")
    fmu = build_fmu(scene, tmp_path / "ignore_lift.fmu").fmu
    assert "lifted_off" not in {v.name for v in read_model_description(str(fmu)).modelVariables}
    r = simulate_fmu(str(fmu), stop_time=1.0, output_interval=1e-3,
                     start_values={"beta": math.pi / 2, "beta_dot": 6.0, "gamma_dot": 0.0})
    lifted = np.flatnonzero(r["F_n"] < 0)
    assert lifted.size and r["time"][lifted[0]] == pytest.approx(0.094, abs=2e-3)
    assert r["fallen"][-1] and r["time"][-1] > r["time"][lifted[0]] + 0.05  # went on past lift-off
