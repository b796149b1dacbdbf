"""Scene files: valid ones load, bad ones fail with file, table and key named; Scene objects
are checked by the same rules (check_scene) and build as their files would."""
from __future__ import annotations

import dataclasses
import inspect
import math
import zipfile

import pytest

from conftest import SCENES
from gyrowheel.fmu_build.scene import Experiment, Scene, SceneError, check_scene, load_scene, parse_scene, scene_toml


@pytest.mark.parametrize("name,g", [("paper_earth", 9.81), ("paper_mars", 3.721), ("paper_moon", 1.625)])
def test_paper_scenes(name, g):
    scene = load_scene(SCENES / f"{name}.toml")
    assert scene.name == name
    assert scene.effects == {"gravity": {"g": g}}
    assert scene.initial["beta"] == pytest.approx(math.radians(80))
    assert scene.initial["gamma_dot"] == 6.0
    assert scene.wheel == {"M": 2.0, "R": 0.17, "k_diam": 0.25, "k_axial": 0.4}  # beta_min: the default
    assert scene.experiment.stop_time == 20.0


def test_defaults_are_the_paper_scenario():
    scene = parse_scene("")
    assert scene.effects == {"gravity": {}}
    assert scene.formulation == "reduced"
    assert scene.experiment.solver == "auto"
    assert scene.experiment.max_step is None  # the default, resolved when the FMU is built
    assert scene.experiment.max_step_in_force == scene.experiment.stop_time - scene.experiment.start_time


def test_default_max_step_follows_a_later_change_of_the_run():
    """max_step left to its default follows stop_time and the solver set after the scene is made."""
    scene = parse_scene("")
    scene.experiment.stop_time = 3.0
    assert scene.experiment.max_step_in_force == 3.0
    scene.experiment.solver = "rk4"
    assert scene.experiment.max_step_in_force == 0.01


@pytest.mark.parametrize("text,fragment", [
    ("[wheel]\nmass = 2", "[wheel] mass: unknown key; valid: M, R, beta_min"),
    ("[wheel]\nM = 'heavy'", "[wheel] M: must be a number, got str 'heavy'"),
    ("[wheel]\nM = -1.0", "[wheel] M: must be > 0"),
    ("[wheel]\nR = nan", "[wheel] R: must be finite"),
    ("[wheel]\nM = true", "[wheel] M: must be a number, got bool"),
    ("[effects.drag]\nc = 1", "[effects.drag]: unknown effect; valid: gravity, slope, gyrover"),
    ("[effects.air_drag]\n", "[effects]: [effects.gravity] is required"),
    ("[effects.gravity]\ng = 'jupiter'", "[effects.gravity] g: unknown preset 'jupiter'; valid: earth, mars, moon"),
    ("[effects.gravity]\ng = -1.0", "[effects.gravity] g: must be >= 0, got -1.0"),
    ("[effects.gravity]\nrho = 1.0", "[effects.gravity] rho: unknown key; valid: g"),
    ("[effects.gravity]\n[effects.gyrover]\n[initial]\ntilt_deg = 'x'", "[initial] tilt_deg: must be a number"),
    ("[initial]\nx_dot = 1.0", "[initial] x_dot: is not free: rolling without slip"),
    ("[initial]\nbeta = 0.0", "[initial] beta: must lie in (0, pi)"),
    ("[initial]\nbeta = 1.0\nbeta_deg = 50", "given twice"),
    ("[initial]\nomega = 1", "[initial] omega: unknown key"),
    ("[experiment]\nsolver = 'rk45'", "[experiment] solver: unknown solver 'rk45'; valid: euler, rk4, dopri5, rosenbrock, dop853"),
    ("[experiment]\nrel_tol = 0", "[experiment] rel_tol: must be > 0"),
    ("[experiment]\nstop_time = -1", "[experiment] stop_time: must be > 0"),
    ("[experiment]\nstart_time = 5\nstop_time = 2", "[experiment] stop_time: must be greater than start_time"),
    ("[model]\nformulation = 'hamilton'", "[model] formulation: unknown 'hamilton'; valid: reduced, multipliers"),
    ("[model]\nname = 'my wheel'", "[model] name: must be a C identifier"),
    ("[outputs]\nkeep = 'x'", "[outputs] keep: must be a list"),
    ("[sky]\ncolour = 1", "[<top level>] sky: unknown key"),
    ("wheel = 3", "[wheel]: must be a table"),
    ("[wheel\nM = 1", "not valid TOML"),
])
def test_bad_scenes_name_file_table_and_key(text, fragment):
    with pytest.raises(SceneError) as err:
        parse_scene(text, "bad.toml")
    message = str(err.value)
    assert message.startswith("bad.toml: ")
    assert fragment in message


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match="no such scene file"):
        load_scene(tmp_path / "nope.toml")


def test_effect_angles_in_degrees():
    scene = parse_scene("[effects.gravity]\n[effects.gyrover]\n[initial]\ntilt_deg = 30\ntheta_p_deg = -10\n")
    assert scene.initial["tilt"] == pytest.approx(math.radians(30))
    assert scene.initial["theta_p"] == pytest.approx(math.radians(-10))


def test_degrees_and_presets():
    scene = parse_scene("[initial]\nbeta_deg = 45\nalpha_deg = 90\n[effects.gravity]\ng = 'moon'\n")
    assert scene.initial["beta"] == pytest.approx(math.pi / 4)
    assert scene.initial["alpha"] == pytest.approx(math.pi / 2)
    assert scene.effects["gravity"]["g"] == 1.625


def test_a_zip_or_binary_file_is_said_to_be_no_scene(tmp_path):
    fmu = tmp_path / "moon.fmu"
    with zipfile.ZipFile(fmu, "w") as zf:
        zf.writestr("modelDescription.xml", "<fmiModelDescription/>")
    with pytest.raises(SceneError, match=r"moon.fmu: an FMU \(a zip archive\), not a scene file: a scene is TOML"):
        load_scene(fmu)
    binary = tmp_path / "b.toml"
    binary.write_bytes(b"\xd0\xcf\x11\xe0 binary")
    with pytest.raises(SceneError, match=r"b.toml: not a text file \(TOML is UTF-8\): invalid continuation byte "
                                         r"at byte 0"):
        load_scene(binary)


# -- Scene objects: check_scene --------------------------------------------------------------------

@pytest.fixture(scope="module")
def moon():
    return load_scene(SCENES / "paper_moon.toml")


@pytest.mark.parametrize("change,message", [
    (dict(effects={}), "[effects]: [effects.gravity] is required: every FMU exposes g (docs/interface.md); "
                       "use g = 0 for a weightless wheel"),
    (dict(name="a b"), "[model] name: must be a C identifier (letters, digits, _), got 'a b'"),
    (dict(experiment=Experiment(stop_time=-1)), "[experiment] stop_time: must be > 0, got -1.0"),
    (dict(wheel={"M": -1}), "[wheel] M: must be > 0, got -1.0"),
    (dict(experiment=Experiment(solver="bogus")),
     "[experiment] solver: unknown solver 'bogus'; valid: euler, rk4, dopri5, rosenbrock, dop853, taylor"),
    (dict(wheel={"M": "a"}), "[wheel] M: must be a number, got str 'a'"),
    (dict(experiment=Experiment(start_time=5, stop_time=2)), "[experiment] stop_time: must be greater than start_time"),
    (dict(effects={"gravity": {"g": -1.0}}), "[effects.gravity] g: must be >= 0, got -1.0"),
    (dict(effects={"gravity": {}, "drag": {}}), "[effects.drag]: unknown effect; valid: gravity, slope"),
    (dict(initial={"theta_p": 0.1}), "[initial] theta_p: unknown key; valid: alpha"),
    (dict(initial={"x_dot": 1.0}), "[initial] x_dot: is not free"),
    (dict(formulation="kane"), "[model] formulation: unknown 'kane'; valid: reduced, multipliers"),
    (dict(outputs="x"), "[outputs] keep: must be a list of output names"),
    (dict(wheel=3), "[wheel]: must be a dict"),
    (dict(effects={"gravity": 3}), "[effects.gravity]: must be a dict"),
    (dict(experiment={"stop_time": 5.0}), "[experiment]: must be an Experiment (gyrowheel.fmu_build.scene.Experiment), "
                                          "got dict"),
    (dict(source=None), "source must be the scene's TOML text (a str), got NoneType"),
])
def test_scene_objects_are_checked_as_files_are(moon, change, message):
    """A Scene changed in Python (dataclasses.replace) is refused where its file would be, the
    message naming the scene and the field."""
    with pytest.raises(SceneError) as err:
        check_scene(dataclasses.replace(moon, **change))
    name = change.get("name", "paper_moon")
    assert str(err.value).startswith(f"scene {name!r}: {message}"), str(err.value)


def test_check_scene_refuses_what_is_no_scene():
    with pytest.raises(SceneError, match="scene must be a gyrowheel.Scene, got dict") as err:
        check_scene({"name": "wheel"})
    assert err.value.argument == "scene"


@pytest.mark.parametrize("path", sorted(SCENES.glob("*.toml")), ids=lambda p: p.stem)
def test_a_loaded_scene_passes_unchanged(path):
    scene = load_scene(path)
    checked = check_scene(scene)
    assert checked == scene and checked.source == scene.source and checked.file == path
    assert checked is not scene and checked.wheel is not scene.wheel  # its own dicts
    assert check_scene(checked) == checked
    assert parse_scene(scene_toml(checked), "x.toml") == dataclasses.replace(checked, source=scene_toml(checked))


def test_a_changed_scene_reads_as_its_file_would(moon):
    """Presets, degrees and integers as a file gives them; the source shipped in the FMU is
    written anew when the given one no longer describes the scene; the argument is unchanged."""
    changed = dataclasses.replace(moon, wheel={"M": 3, "beta_min": "touchdown"}, initial={"beta_deg": 45},
                                  effects={"gravity": {"g": "mars"}, "energy": {}})
    checked = check_scene(changed)
    assert checked.wheel == {"M": 3.0, "beta_min": pytest.approx(0.281034901502813)}
    assert isinstance(checked.wheel["M"], float)
    assert checked.initial == {"beta": pytest.approx(math.pi / 4)}
    assert checked.effects == {"gravity": {"g": 3.721}, "energy": {}}
    assert changed.wheel == {"M": 3, "beta_min": "touchdown"}  # not changed in place
    assert checked.source != moon.source and checked.source.startswith("# written by gyrowheel from a Scene object")
    assert parse_scene(checked.source, "paper_moon.toml") == dataclasses.replace(checked, file=None)
    made = check_scene(Scene())  # made in Python, no source: the defaults' file
    assert made.source == scene_toml(made) and parse_scene(made.source) == made


def test_numpy_numbers_in_a_scene_object_are_numbers():
    """A sweep's values are numpy scalars: read as the Python numbers a file would give."""
    import numpy as np
    checked = check_scene(Scene(wheel={"M": np.float32(2.5), "R": np.int64(1)},
                                experiment=Experiment(max_internal_steps=np.int32(5))))
    assert checked.wheel == {"M": 2.5, "R": 1.0} and type(checked.wheel["M"]) is float
    assert checked.experiment.max_internal_steps == 5 and type(checked.experiment.max_internal_steps) is int
    with pytest.raises(SceneError, match=r"\[wheel\] M: must be a number, got bool"):
        check_scene(Scene(wheel={"M": np.bool_(True)}))


def test_public_dataclasses_document_every_field():
    """help() of a result or scene type says what each field is, not only the signature."""
    from gyrowheel.cosim.system import SystemDescription
    from gyrowheel.fmu_build.builder import BuildResult
    from gyrowheel.fmu_build.export_c import ExportResult
    from gyrowheel.taylor.ensemble import EnsembleResult
    for cls in (Scene, Experiment, BuildResult, ExportResult, EnsembleResult, SystemDescription):
        doc = inspect.getdoc(cls)
        assert doc and not doc.startswith(cls.__name__ + "("), cls  # its own, not the dataclass signature
        for f in dataclasses.fields(cls):
            assert f.name in doc, f"{cls.__name__}.{f.name}"
    for fn in (load_scene, parse_scene, check_scene):
        doc = inspect.getdoc(fn)
        assert "Returns" in doc and "Raises" in doc and "docs/scenes.md" in doc, fn.__name__
