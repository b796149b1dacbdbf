"""Solver item auto (7), the default: what it integrates with and that it is that solver.

The rule (c_src gw_solver_auto, docs/accuracy.md "Solver auto"): taylor where the FMU has the
Taylor kernel and its model no mode switches (update events: the contact modes), dop853 otherwise,
at every rel_tol.  Checked through the FMU alone: the
logSolver line of every communication step names the solver that integrated, `gyrowheel info`
names auto's pick, and auto's trajectory equals the named solver's bit for bit (the same steps,
the same events located at the same times), while another solver's differs.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from fmpy.fmi2 import fmi2LastSuccessfulTime

from fmi_helpers import Slave
from gyrowheel.description import read_info
from gyrowheel.fmu_build import build_fmu, parse_scene

ROOT = Path(__file__).resolve().parent.parent
STATES = ("x", "y", "alpha", "beta", "gamma", "alpha_dot", "beta_dot", "gamma_dot")
CODES = {"dopri5": 3, "dop853": 5, "taylor": 6, "auto": 7}
# the paper wheel leaning 30 deg, rolling slowly: it falls to beta_min = 0.3 rad (the terminating
# event) after about 0.1 s
FALLING = ('[model]\nname = "falls"\n[wheel]\nbeta_min = 0.3\n[effects.gravity]\n'
           '[initial]\nbeta_deg = 30.0\ngamma_dot = 1.0\n')


@pytest.fixture(scope="module")
def fmus(tmp_path_factory, example_build):
    """The paper's earth scene (no solver named: auto) with the Taylor kernel (the default
    build) and without it (taylor=False), the run's shared builds (conftest example_build), and
    a falling wheel's scene both ways."""
    work = tmp_path_factory.mktemp("auto")
    falls = parse_scene(FALLING, "falls.toml")
    built = {("falls", kernel): build_fmu(falls, work / f"falls_{kernel}.fmu", taylor=None if kernel else False).fmu
             for kernel in (True, False)}
    return {**built, ("earth", True): example_build("paper_earth").fmu,
            ("earth", False): example_build("paper_earth", taylor=False).fmu}


def run(fmu, stop: float, steps: int = 4, logged: bool = False, **values):
    """The states after `steps` equal communication steps to `stop` (fewer if the wheel falls),
    the time reached, and the logSolver lines."""
    s = Slave(fmu)
    if logged:
        s.slave.setDebugLogging(True, ["logSolver"])
    s.init(**values)
    t, h = 0.0, stop / steps
    for _ in range(steps):
        if s.raw("fmi2DoStep", _c(t), _c(h), 1) != 0:  # fmi2Discard: the fall ended the run
            t = s.slave.getRealStatus(fmi2LastSuccessfulTime)
            break
        t += h
    out = [s.get(n) for n in STATES], t, [m for m in s.log_text().splitlines() if "solver=" in m]
    s.free()
    return out


def _c(v: float):
    import ctypes
    return ctypes.c_double(v)


def solvers_logged(lines: list[str]) -> set[str]:
    return {re.search(r"solver=(\w+)", line).group(1) for line in lines}


@pytest.mark.parametrize("kernel, picked", [(True, "taylor"), (False, "dop853")])
@pytest.mark.parametrize("rel_tol", [1e-3, 1e-8, 1e-13])
def test_auto_integrates_with_the_documented_solver(fmus, kernel, picked, rel_tol):
    """The default solver is auto; every step's log names the solver of the rule, and the run
    equals that solver's to the last bit (and differs from the other explicit solver's)."""
    fmu = fmus[("earth", kernel)]
    s = Slave(fmu, logging_on=False)
    assert s.get("solver") == CODES["auto"]  # the FMU's default, no solver named in the scene
    s.free()
    auto, _, lines = run(fmu, 2.0, logged=True, rel_tol=rel_tol)
    assert lines and solvers_logged(lines) == {picked}
    named, _, _ = run(fmu, 2.0, rel_tol=rel_tol, solver=CODES[picked])
    assert auto == named
    other, _, _ = run(fmu, 2.0, rel_tol=rel_tol, solver=CODES["dopri5"])
    assert other != auto


@pytest.mark.parametrize("kernel, picked", [(True, "taylor"), (False, "dop853")])
def test_auto_locates_the_fall_as_its_solver_does(fmus, kernel, picked):
    """A terminating event: auto stops at the very time the chosen solver locates it, and that
    time is the fall's (beta = beta_min) to the tolerance: both solvers agree to 1e-9 s."""
    fmu = fmus[("falls", kernel)]
    auto, t_auto, _ = run(fmu, 1.0, steps=1, rel_tol=1e-12)
    named, t_named, _ = run(fmu, 1.0, steps=1, rel_tol=1e-12, solver=CODES[picked])
    assert 0.0 < t_auto < 1.0 and (auto, t_auto) == (named, t_named)
    other = "dop853" if picked == "taylor" else "dopri5"
    _, t_other, _ = run(fmu, 1.0, steps=1, rel_tol=1e-12, solver=CODES[other])
    assert abs(t_other - t_auto) < 1e-9


def test_reset_goes_back_to_auto(fmus):
    """fmi2Reset restores the default solver auto after a run with another: the runs before and
    after the reset are integrated by dopri5 and by taylor (the logged names)."""
    s = Slave(fmus[("earth", True)])
    s.slave.setDebugLogging(True, ["logSolver"])
    names = []
    for solver in ("dopri5", None):
        s.init(rel_tol=1e-10, **({} if solver is None else {"solver": CODES[solver]}))
        s.slave.doStep(0.0, 0.1)
        names.append(re.findall(r"solver=(\w+)", s.log_text())[-1])
        s.slave.reset()
    assert names == ["dopri5", "taylor"]
    s.free()


def test_fmu_state_keeps_auto(fmus):
    """fmi2GetFMUstate / SetFMUstate / (de)serialise keep the setting auto: a state saved under
    auto, restored into an instance set up with dopri5, reads solver = auto and continues exactly
    as the run that was never interrupted (and not as dopri5 does)."""
    fmu = fmus[("earth", True)]
    ref = Slave(fmu, logging_on=False)
    ref.init(rel_tol=1e-10)
    ref.slave.doStep(0.0, 0.5)
    blob = ref.slave.serializeFMUstate(ref.slave.getFMUstate())
    ref.slave.doStep(0.5, 0.5)
    expected = [ref.get(n) for n in STATES]
    ref.free()
    s = Slave(fmu, logging_on=False)
    s.init(rel_tol=1e-10, solver=CODES["dopri5"])
    s.slave.doStep(0.0, 0.5)
    s.slave.doStep(0.5, 0.5)
    assert s.get("solver") == CODES["dopri5"] and [s.get(n) for n in STATES] != expected
    s.slave.setFMUstate(s.slave.deSerializeFMUstate(blob))
    assert s.get("solver") == CODES["auto"]
    s.slave.doStep(0.5, 0.5)
    assert [s.get(n) for n in STATES] == expected
    s.free()


def test_info_names_autos_pick_and_the_rule(fmus):
    with_kernel, without = read_info(fmus[("earth", True)]), read_info(fmus[("earth", False)])
    assert (with_kernel.auto_solver, without.auto_solver) == ("taylor", "dop853")
    assert "auto         taylor at the default tolerance 1e-08 (rule: taylor at every rel_tol" in str(with_kernel)
    assert "auto         dop853 at the default tolerance 1e-08" in str(without)
    assert "taylor" not in without.solvers and "auto" in without.solvers


def test_a_scene_naming_its_solver_keeps_it():
    """solver = "dopri5": the FMU's default stays dopri5, it gets no Taylor kernel (its generated
    C is as before auto existed), max_step keeps its fixed default 0.01 s; without a solver
    line the solver is auto and max_step the run's length (stop_time - start_time)."""
    from gyrowheel.fmu_build.codegen import kernel_choice
    named = parse_scene('[effects.gravity]\n[experiment]\nsolver = "dopri5"\nstop_time = 7.0\n', "s.toml")
    assert (named.experiment.solver, named.experiment.max_step_in_force) == ("dopri5", 0.01)
    assert kernel_choice(named.experiment.solver, named.taylor) is False
    default = parse_scene('[effects.gravity]\n[experiment]\nstart_time = 1.0\nstop_time = 7.0\n', "s.toml")
    assert (default.experiment.solver, default.experiment.max_step_in_force) == ("auto", 6.0)
    assert kernel_choice(default.experiment.solver, default.taylor) is None  # where the model allows it
    off = parse_scene('[effects.gravity]\n[build]\ntaylor = false\n', "s.toml")
    assert kernel_choice(off.experiment.solver, off.taylor) is False


def test_taylor_false_with_solver_taylor_is_refused(tmp_path):
    from gyrowheel.errors import ArgumentError
    scene = parse_scene('[effects.gravity]\n[experiment]\nsolver = "taylor"\n', "s.toml")
    with pytest.raises(ArgumentError, match="taylor: false leaves out the Taylor kernel"):
        build_fmu(scene, tmp_path / "s.fmu", taylor=False)
    with pytest.raises(Exception, match=r"\[build\] taylor: must be true or false, got 'no'"):
        parse_scene('[effects.gravity]\n[build]\ntaylor = "no"\n', "s.toml")


def test_a_scene_naming_its_solver_generates_what_it_did(tmp_path, monkeypatch):
    """The paper's earth scene as it was written before auto (solver = "dopri5", abs_tol 1e-10,
    max_step 0.05 s) builds the FMU it built then: the GUID hashes the generated C, the variable
    table and the experiment, and equals the one recorded then (no compile: binaries do not enter
    it). Without those lines the scene runs auto, and the GUID differs."""
    from fmpy import read_model_description

    from gyrowheel.fmu_build import builder
    monkeypatch.setattr(builder, "write_binaries", lambda *args, **kwargs: None)
    text = (ROOT / "examples" / "scenes" / "paper_earth.toml").read_text()
    named = text.replace("[experiment]\n", '[experiment]\nsolver = "dopri5"\nabs_tol = 1e-10\nmax_step = 0.05\n')
    guids = [read_model_description(str(build_fmu(parse_scene(t, "paper_earth.toml"), tmp_path / f"{k}.fmu",
                                                   build_dir=tmp_path / str(k)).fmu)).guid
             for k, t in enumerate((named, text))]
    assert guids[0] == "{27c0c82f-d150-5df2-b0bc-f210ed2ed844}" != guids[1]
    assert "GW_TL_NVAR" not in (tmp_path / "0" / "fmu" / "sources" / "gw_taylor_model.h").read_text()


def test_contact_modes_take_dop853(tmp_path):
    """A scene with the sliding mode (update events) gets no kernel by default and auto runs
    dop853 there, also in an FMU built with the kernel: the upright wheel on an incline just past
    its friction limit slides from t = 0 at zero slip, where the slip direction's Taylor series
    diverge (solver taylor refuses the step); auto equals dop853 bit for bit, and the centre
    accelerates at g (sin th - mu_k cos th), the closed form, to 1e-9."""
    import math

    from test_contact_sliding import KA, MU, SLIDE, WHEEL, G
    scene = parse_scene('[model]\nname = "sliding"\n' + WHEEL + SLIDE, "sliding.toml")
    # at -O1, as tests/test_contact_sliding.py builds this scene: its compile is shared (conftest
    # _build_cache), and nothing here times the FMUs or compares them with another build
    plain = build_fmu(scene, tmp_path / "plain.fmu").fmu
    kernel = build_fmu(scene, tmp_path / "kernel.fmu", taylor=True).fmu
    assert (read_info(plain).taylor, read_info(kernel).taylor) == (False, True)
    assert read_info(plain).auto_solver == read_info(kernel).auto_solver == "dop853"
    above = math.atan(MU * (1 + KA) / KA) * (1 + 1e-6)
    start = dict(rel_tol=1e-12, abs_tol=1e-14, beta=math.pi / 2, gamma_dot=0.0, slope_angle=above, mu_k=MU)
    for fmu in (plain, kernel):
        auto, t, lines = run(fmu, 0.5, steps=5, logged=True, **start)
        assert t == 0.5 and solvers_logged(lines) == {"dop853"}
        assert auto == run(fmu, 0.5, steps=5, solver=CODES["dop853"], **start)[0]
        a = G * (math.sin(above) - MU * math.cos(above))
        assert abs(auto[0] - 0.5 * a * 0.5**2) < 1e-9 * 0.5 * a * 0.5**2  # x, down the incline
    _, t_taylor, _ = run(kernel, 0.5, steps=5, solver=CODES["taylor"], **start)
    assert t_taylor == 0.0  # taylor fails at the first step: why auto does not pick it here
