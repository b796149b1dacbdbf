"""Scene files: valid ones load, bad ones fail with file, table and key named."""
from __future__ import annotations

import math

import pytest

from conftest import SCENES
from gyrowheel.fmu_build.scene import SceneError, load_scene, parse_scene


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
    assert scene.experiment.solver == "dopri5"


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
