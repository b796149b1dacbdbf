"""One tolerance precedence for every importer (docs/fmi.md, "Tolerances").

DefaultExperiment declares the scene's rel_tol. At initialisation, whatever the order of the calls:
  rel_tol set explicitly                      -> that rel_tol (and abs_tol as set or the scene's)
  else fmi2SetupExperiment(tolerance = T)     -> rel_tol = T, abs_tol = scene abs_tol * T / scene rel_tol
                                                 (so the declared default T keeps the scene's accuracy)
  else                                        -> the scene's rel_tol and abs_tol.
abs_tol = 0 (the scenes' default; lunar_rover has it) follows the rel_tol in force as rel_tol / 100,
and scales to 0: it follows a forwarded T too.

Importers, reproduced as call sequences (communication step 0.01 s, the scenes' stop times):
  PyFMI 2.21, OMSimulator 3.0   forward DefaultExperiment's tolerance, 1e-4 when none is declared.
      the run is identical to the scene's (were no tolerance declared, 1e-4 would put the final
      states off by 3.8e-7 (paper_earth with dopri5, alpha) and 7e-6 (lunar_rover, solver auto:
      taylor, whose one step per 0.01 s communication step is accurate far below 1e-4)).
  a tool passing its own 1e-4 gets 1e-4 (errors of that size, by design).
  fmpy                          setupExperiment(tolerance) first, then the user's start values:
      a user's rel_tol wins over the forwarded tolerance; OMSimulator sets start values before
      setupExperiment: the same result.
"""
from __future__ import annotations

import numpy as np
import pytest
from fmpy import read_model_description

from conftest import SCENES, STATES
from fmi_helpers import Slave
from gyrowheel.fmu_build import load_scene

H = 0.01


@pytest.fixture(scope="module")
def lunar_fmu(example_build):
    return example_build("lunar_rover").fmu


@pytest.fixture(scope="module")
def earth_abs_fmu(tmp_path_factory):
    """paper_earth with solver dopri5, an explicit abs_tol = 1e-10 and max_step 0.05 s (the scene
    itself runs auto, its abs_tol following rel_tol: 0)."""
    from gyrowheel.fmu_build import build_fmu, parse_scene
    text = (SCENES / "paper_earth.toml").read_text().replace(
        "[experiment]\n", '[experiment]\nsolver = "dopri5"\nabs_tol = 1e-10\nmax_step = 0.05\n')
    return build_fmu(parse_scene(text, "paper_earth.toml"), tmp_path_factory.mktemp("abs") / "earth.fmu").fmu


def _final(fmu, tolerance=None, before_setup=None, after_setup=None, read=("rel_tol", "abs_tol")):
    """Step a Co-Simulation instance to the stop time (or the terminating event) with a fixed
    communication step; the final states and the settings in force."""
    s = Slave(fmu, logging_on=False)
    try:
        stop = float(s.md.defaultExperiment.stopTime)
        s.set(**(before_setup or {}))
        s.slave.setupExperiment(tolerance=tolerance, startTime=0.0)
        s.set(**(after_setup or {}))
        s.slave.enterInitializationMode()
        s.slave.exitInitializationMode()
        n = round(stop / H)
        for k in range(n):
            try:
                s.slave.doStep(k * H, H)
            except Exception:
                break
        return np.array(s.get(*STATES)), dict(zip(read, s.get(*read)))
    finally:
        s.free()


# lunar_rover with beta_min = 0.02: it falls at 17.46 s, where a loose tolerance shows most (with the
# default 1e-3 it rolls on and 1e-4 costs only 3.4e-6 at the end, measured with dopri5)
@pytest.mark.parametrize("scene,fixture,undeclared,values", [("paper_earth", "earth_abs_fmu", 3.8e-7, {}),
                                                             ("lunar_rover", "lunar_fmu", 7e-6, {"beta_min": 0.02})])
def test_forwarded_default_gets_the_scenes_accuracy(scene, fixture, undeclared, values, request):
    """PyFMI / OMSimulator: fmi2SetupExperiment(toleranceDefined, DefaultExperiment's tolerance)."""
    fmu = request.getfixturevalue(fixture)
    exp = load_scene(SCENES / f"{scene}.toml").experiment
    exp.abs_tol = {"paper_earth": 1e-10, "lunar_rover": 0.0}[scene]  # explicit (earth_abs_fmu); follows rel_tol
    declared = float(read_model_description(str(fmu)).defaultExperiment.tolerance)
    assert declared == exp.rel_tol == 1e-8
    scene_run, _ = _final(fmu, before_setup=values)
    forwarded, settings = _final(fmu, tolerance=declared, before_setup=values)
    assert np.array_equal(forwarded, scene_run)  # 0 (not `undeclared`, see below)
    assert settings == {"rel_tol": exp.rel_tol, "abs_tol": exp.abs_tol}  # exactly the scene's
    # what the importers forward when DefaultExperiment declares no tolerance (FMIL's 1e-4):
    own, settings = _final(fmu, tolerance=1e-4, before_setup=values)
    err = float(np.max(np.abs(own - scene_run)))
    print(f"{scene}: forwarded default 0, own tolerance 1e-4 {err:.3g} (expected about {undeclared:.2g})")
    # abs_tol scaled alike: 1e-10 -> 1e-6; 0 stays 0 (absolute 1e-4 / 100 = 1e-6 in force alike)
    assert settings == {"rel_tol": 1e-4, "abs_tol": pytest.approx(exp.abs_tol * 1e4, rel=1e-12, abs=0.0)}
    # a tool's own tolerance applies: an error of that tolerance's size
    assert undeclared / 30 < err < undeclared * 30


def test_user_rel_tol_wins_over_a_forwarded_tolerance(earth_abs_fmu):
    """fmpy's order (setupExperiment first, then start values) and OMSimulator's (start values
    first): the user's rel_tol is used; abs_tol keeps the scene's value unless also set."""
    alone, settings = _final(earth_abs_fmu, after_setup={"rel_tol": 1e-6})
    assert settings == {"rel_tol": 1e-6, "abs_tol": 1e-10}
    fmpy_order, settings = _final(earth_abs_fmu, tolerance=1e-8, after_setup={"rel_tol": 1e-6})
    assert settings == {"rel_tol": 1e-6, "abs_tol": 1e-10}
    oms_order, settings = _final(earth_abs_fmu, tolerance=1e-4, before_setup={"rel_tol": 1e-6})
    assert settings == {"rel_tol": 1e-6, "abs_tol": 1e-10}
    assert np.array_equal(fmpy_order, alone) and np.array_equal(oms_order, alone)
    both, settings = _final(earth_abs_fmu, tolerance=1e-4, after_setup={"abs_tol": 1e-12})
    assert settings == {"rel_tol": 1e-4, "abs_tol": 1e-12}  # an explicit abs_tol is kept


@pytest.mark.parametrize("tolerance", [1e-4, 1e-6])
def test_abs_tol_zero_follows_a_forwarded_tolerance(lunar_fmu, tolerance):
    """lunar_rover's abs_tol = 0: a forwarded T runs exactly as rel_tol = T, abs_tol = T / 100 set
    by hand (the absolute tolerance in force is GW_ATOL_PER_RTOL * T, bit for bit), and unlike a
    fixed abs_tol of the scene's rel_tol / 100 (1e-10), which would floor a loose run."""
    values = {"beta_min": 0.02}
    forwarded, settings = _final(lunar_fmu, tolerance=tolerance, before_setup=values)
    assert settings == {"rel_tol": tolerance, "abs_tol": 0.0}
    by_hand, _ = _final(lunar_fmu, before_setup={**values, "rel_tol": tolerance, "abs_tol": 1e-2 * tolerance})
    assert np.array_equal(forwarded, by_hand)
    fixed, _ = _final(lunar_fmu, before_setup={**values, "rel_tol": tolerance, "abs_tol": 1e-10})
    assert not np.array_equal(forwarded, fixed)


def test_abs_tol_zero_is_a_valid_setting(earth_fmu):
    """fmi2SetReal(abs_tol, 0) is accepted at the call (not refused as below 1e-30) and means
    rel_tol / 100: the same run as abs_tol = rel_tol / 100 set explicitly."""
    zero, settings = _final(earth_fmu, after_setup={"rel_tol": 1e-6, "abs_tol": 0.0})
    assert settings == {"rel_tol": 1e-6, "abs_tol": 0.0}
    explicit, _ = _final(earth_fmu, after_setup={"rel_tol": 1e-6, "abs_tol": 1e-2 * 1e-6})
    assert np.array_equal(zero, explicit)


def test_simulate_fmu_forwards_the_declared_tolerance(earth_fmu):
    """fmpy.simulate_fmu passes DefaultExperiment's tolerance; relative_tolerance= is a tool's own."""
    from fmpy import simulate_fmu
    plain = simulate_fmu(str(earth_fmu), stop_time=2.0, output_interval=H, output=STATES)
    scene_run = simulate_fmu(str(earth_fmu), stop_time=2.0, output_interval=H, output=STATES,
                             start_values={"rel_tol": 1e-8})
    own = simulate_fmu(str(earth_fmu), stop_time=2.0, output_interval=H, output=STATES,
                       relative_tolerance=1e-5)
    assert all(plain[n][-1] == scene_run[n][-1] for n in STATES)
    assert any(own[n][-1] != scene_run[n][-1] for n in STATES)


@pytest.mark.parametrize("tolerance", [0.0, -1.0, 2.0, 1e-16])
def test_setup_experiment_refuses_a_tolerance_outside_rel_tols_range(earth_fmu, tolerance):
    s = Slave(earth_fmu)
    try:
        with pytest.raises(Exception):
            s.slave.setupExperiment(tolerance=tolerance, startTime=0.0)
        assert "is outside the valid range of a relative tolerance" in s.log_text()
    finally:
        s.free()


@pytest.mark.parametrize("key,value", [("rel_tol", 2.0), ("rel_tol", 1e-16), ("abs_tol", 5.0)])
def test_scene_tolerances_outside_the_fmus_ranges_are_refused(key, value):
    from gyrowheel.fmu_build import parse_scene
    from gyrowheel.fmu_build.scene import SceneError
    text = f'[model]\nname = "t"\n[effects.gravity]\ng = 9.81\n[experiment]\n{key} = {value!r}\n'
    with pytest.raises(SceneError, match=f"{key}: must lie in"):
        parse_scene(text, "t.toml")
