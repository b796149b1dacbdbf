"""Solver taylor (c_src/gw_solver_taylor.c) on the wheel, through the FMU.

- convergence on the paper scenario against scipy's DOP853 and the energy drift; the fall
  located like DOP853's (1e-9 s);
- only an FMU built with the kernel has it, a default one refuses solver taylor with the reason;
- scenes with contact forces, drag, rolling resistance and slope run briefly like DOP853;
- the solver loop's contract (many communication steps equal one, a saved state restores the
  run bit for bit, the budget); a loose tolerance costs no more than order three; the step size
  follows rel_tol between orders;
- the kernel's sources: warning-clean with gcc and clang, plain C99 for tcc, the target clones'
  portable default equal to the x86-64-v3 clone to rounding; a kernel of constant derivatives
  builds and integrates.
"""
from __future__ import annotations

import re
import subprocess
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import SCENES, STATES, CasadiWheel
from gyrowheel.fmu_build import build_fmu, parse_scene
from gyrowheel.fmu_build.builder import build_spec_fmu
from gyrowheel.fmu_build.compiler import compiler
from gyrowheel.model.system import System
from gyrowheel.taylor.ensemble import Ensemble, EnsembleError, library_source
from taylor_helpers import TAYLOR, fmu_runner, one_step


@pytest.fixture(scope="module")
def paper(example_build):
    built = example_build("paper_earth", taylor=True)
    return built, fmu_runner(built.fmu)


def test_paper_convergence_and_energy(paper):
    """Error at t = 20 s against scipy DOP853 (rtol 1e-13) follows the tolerance; energy kept."""
    _, runner = paper
    wheel = CasadiWheel()
    sol = wheel.integrate(wheel.x0(), 20.0, rtol=1e-13, atol=1e-15)
    ref = np.array([wheel.out(sol.y[:, -1])[n] for n in STATES])
    errors = {}
    for tol in (1e-4, 1e-7, 1e-10, 1e-12):
        v = one_step(runner, 20.0, STATES + ["energy"], solver=TAYLOR, rel_tol=tol, abs_tol=tol * 1e-2)
        errors[tol] = np.max(np.abs(v[:8] - ref))
        assert errors[tol] < 30 * tol, (tol, errors[tol])
    tight = one_step(runner, 20.0, STATES + ["energy"], solver=TAYLOR, rel_tol=1e-14, abs_tol=1e-16)
    assert np.max(np.abs(tight[:8] - ref)) < 5e-11  # scipy's own accuracy bounds this check
    E0 = wheel.out(wheel.x0())["energy"]
    assert abs(tight[8] - E0) / abs(E0) < 1e-13  # conservative rolling: energy is constant


def test_fall_located_like_dop853(paper):
    _, runner = paper
    names = ["fallen"]
    times = {}
    for solver in (5, TAYLOR):
        runner.start(solver=solver, rel_tol=1e-12, abs_tol=1e-14, max_step=20.0, gamma_dot=1.0, beta_min=0.1)
        from fmpy.fmi2 import fmi2LastSuccessfulTime
        try:
            runner.slave.doStep(0.0, 20.0)
        except Exception:
            pass
        times[solver] = runner.slave.getRealStatus(fmi2LastSuccessfulTime)
        assert runner.slave.getBoolean([runner.vr[names[0]]])[0]
    assert abs(times[5] - times[TAYLOR]) < 1e-9, times


def _kernel_in(fmu: Path) -> dict[str, bool]:
    """Whether an FMU carries the Taylor kernel: its source, its slot, its compiled code."""
    with zipfile.ZipFile(fmu) as zf:
        source = zf.read("sources/gw_taylor_model.h").decode()
        desc = zf.read("sources/model_desc.c").decode()
        binary = [n for n in zf.namelist() if n.startswith("binaries/") and n.endswith(".so")][0]
        with tempfile.TemporaryDirectory() as tmp:
            so = Path(zf.extract(binary, tmp))
            symbols = subprocess.run(["nm", str(so)], capture_output=True, text=True).stdout
        xml = zf.read("modelDescription.xml").decode()
    return {"source": "GW_TL_NVAR" in source, "slot": ".taylor = {gw_tl1_jet, gw_tl1_cst" in desc,
            "code": "gw_tl1_jet" in symbols, "item": '<Item name="taylor" value="6"' in xml}


def test_fmu_without_kernel_refuses_taylor(earth_fmu, paper, tmp_path):
    """Only an FMU that asks for it carries the Taylor kernel (build time: docs/taylor.md): the
    paper scene names no solver (auto), so its default build has it, as one built with
    taylor=True; built with taylor=False it has none and refuses solver 6 at the call, with the
    reason and how to get the kernel."""
    from fmpy.fmi1 import FMICallException

    from gyrowheel.fmu_build import load_scene
    plain = build_fmu(load_scene(SCENES / "paper_earth.toml"), tmp_path / "plain.fmu", taylor=False).fmu
    assert _kernel_in(plain) == {"source": False, "slot": False, "code": False, "item": False}
    with zipfile.ZipFile(plain) as zf:  # nor the recurrences and the ensemble's sources
        assert not {"sources/gw_taylor_ops.h", "sources/gw_ensemble.c"} & set(zf.namelist())
    for fmu in (earth_fmu, paper[0].fmu):  # the default build (auto), taylor=True
        assert _kernel_in(fmu) == {"source": True, "slot": True, "code": True, "item": True}
    runner = fmu_runner(plain)
    with pytest.raises(FMICallException):
        runner.start(solver=TAYLOR)
    with pytest.raises(EnsembleError, match="no Taylor kernel.*gyrowheel build --taylor"):
        Ensemble(plain)


@pytest.mark.parametrize("name", ["lunar_rover", "euler_disk"])
def test_scenes_run_briefly_with_taylor(name, tmp_path):
    """Scenes with contact forces, drag, rolling resistance and slope simulate with taylor like
    DOP853 for 0.5 s (the Gyrover scenes: their decomposition above; their FMU build is slow).
    euler_disk's scene names solver = "taylor" (its FMU gets the kernel from that alone),
    lunar_rover's does not (built with taylor=True)."""
    text = (SCENES / f"{name}.toml").read_text()
    if name == "euler_disk":
        assert 'solver = "dopri5"' in text
        text = text.replace('solver = "dopri5"', 'solver = "taylor"')
    built = build_fmu(parse_scene(text, f"{name}.toml"), tmp_path / f"{name}.fmu", build_dir=tmp_path / "b",
                      taylor=True if name == "lunar_rover" else None)
    assert _kernel_in(built.fmu) == {"source": True, "slot": True, "code": True, "item": True}
    runner = fmu_runner(built.fmu)
    a = one_step(runner, 0.5, STATES, solver=TAYLOR, rel_tol=1e-10, abs_tol=1e-12)
    b = one_step(runner, 0.5, STATES, solver=5, rel_tol=1e-10, abs_tol=1e-12)
    assert np.all(np.isfinite(a)) and np.max(np.abs(a - b)) < 1e-7


def test_solver_loop_contract_state_budget_and_steps(paper):
    """Solver taylor keeps main's solver-loop contract: many communication steps equal one
    (dense landing, the TwoSum compensation xc carried in the state), a saved state (layout v3)
    restores the run bit for bit, and max_internal_steps stops a call with fmi2Error, the state
    left at the step's start."""
    from fmpy.fmi1 import FMICallException
    _, runner = paper
    vrs = [runner.vr[n] for n in STATES]
    one = one_step(runner, 2.0, STATES, solver=TAYLOR, rel_tol=1e-12, abs_tol=1e-14, max_step=0.5)
    runner.start(solver=TAYLOR, rel_tol=1e-12, abs_tol=1e-14, max_step=0.5)
    s = runner.slave
    for k in range(40):
        s.doStep(k * 0.05, 0.05)
    many = np.array(s.getReal(vrs))
    assert np.max(np.abs(many - one)) < 1e-11
    state = s.getFMUstate()
    for k in range(40, 80):
        s.doStep(k * 0.05, 0.05)
    first = np.array(s.getReal(vrs))
    s.setFMUstate(state)
    for k in range(40, 80):
        s.doStep(k * 0.05, 0.05)
    assert np.array_equal(first, np.array(s.getReal(vrs)))  # bit for bit
    s.freeFMUstate(state)
    runner.start(solver=TAYLOR, rel_tol=1e-12, abs_tol=1e-14, max_step=20.0, max_internal_steps=5)
    s = runner.slave
    x0 = np.array(s.getReal(vrs))
    with pytest.raises(FMICallException):
        s.doStep(0.0, 20.0)
    assert np.array_equal(x0, np.array(s.getReal(vrs)))


def test_a_loose_tolerance_costs_no_more_than_order_three(paper):
    """The order is at least 3: at order 2 (rel_tol > e^-2) the step h ~ 0.07 (|x_i| + floor) /
    |x_i'| would close in on every zero of a state geometrically (floor = abs_tol / rel_tol, 1e-10
    here): the paper's 20 s at rel_tol 0.5 took 48,041 steps at order 2 against 3,182 at rel_tol
    0.1.  rel_tol 0.5 and 1 cost what 0.1 costs, and the lean lands within 1e-2 rad of scipy
    DOP853 at rtol 1e-13 (order 3 at these tolerances over 20 s: 2e-3).  (The same dip of h in a
    1 s step at rel_tol 0.5 would make the budget guard refuse the call after 330 steps, "the
    step size has settled", but for the guard's window restarting when h halves, gw_budget.c.)"""
    import re

    from fmi_helpers import Slave
    built, _ = paper
    wheel = CasadiWheel()
    sol = wheel.integrate(wheel.x0(), 20.0, rtol=1e-13, atol=1e-15)
    ref = np.array([wheel.out(sol.y[:, -1])[n] for n in STATES])
    steps = {}
    for tol in (1.0, 0.5, 0.1):
        s = Slave(built.fmu)
        try:
            s.init(solver=TAYLOR, rel_tol=tol, abs_tol=1e-10, max_step=20.0)
            s.slave.doStep(0.0, 20.0)
            log = [m for _, _, m in s.messages if "accepted=" in m][-1]
            steps[tol] = int(re.search(r"accepted=(\d+)", log).group(1))
            assert abs(s.get("beta") - ref[3]) < 1e-2, tol  # the lean (angles drift in phase)
        finally:
            s.free()
    assert steps[1.0] <= 1.01 * steps[0.1] and steps[0.5] <= 1.01 * steps[0.1], steps


def _taylor_run_log(fmu, rel_tol):
    """(accepted steps, order) of one fmi2DoStep(0, 20) with solver taylor at rel_tol"""
    from fmi_helpers import Slave
    s = Slave(fmu)
    try:
        s.init(solver=TAYLOR, rel_tol=rel_tol, abs_tol=rel_tol * 1e-2, max_step=20.0)
        s.slave.doStep(0.0, 20.0)
        steps = int(re.search(r"accepted=(\d+)", [m for _, _, m in s.messages if "accepted=" in m][-1])[1])
        order = int(re.search(r"order=(\d+)", [m for _, _, m in s.messages if "order=" in m][-1])[1])
        return steps, order
    finally:
        s.free()


def test_step_size_follows_rel_tol_between_orders(paper):
    """The step's neglected term follows rel_tol continuously (Jorba & Zou's rule at q =
    -ln(rel_tol)/2 + 3/2, not at the integer order p0, with which every rel_tol of one p0, here
    3e-4 .. 4.6e-5, all order 10, would take the same 287 steps and the neglected term would
    fall e^2 at each p0): tightening rel_tol within one order takes more steps.  (The error at
    20 s is not checked here: it varies several-fold between neighbouring tolerances, 8e-6 at
    rel_tol 4.6e-5 and 5e-5 at 4.5e-5; test_paper_convergence_and_energy bounds it.)"""
    built, _ = paper
    runs = {tol: _taylor_run_log(built.fmu, tol) for tol in (3e-4, 1e-4, 4.6e-5, 4.5e-5)}
    assert [o for _, o in runs.values()] == [10, 10, 10, 11], runs
    steps = [n for n, _ in runs.values()]
    assert steps[0] < steps[1] < steps[2], runs  # one order, three tolerances: three step counts


@pytest.mark.parametrize("cc", ["gcc", "clang"])
def test_kernel_and_ensemble_sources_warning_clean(cc, paper, tmp_path):
    """An FMU with the kernel and its ensemble library build under -std=c99 -Wall -Wextra
    -Wpedantic -Werror with gcc and clang (the target_clones kernel included)."""
    import shutil
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} is not installed (make test installs it: Debian package {cc})")
    src = paper[0].sources
    strict = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-O2", "-shared", "-fPIC", f"-I{src}"]
    unity = tmp_path / "ens.c"
    unity.write_text(library_source(paper[0].identifier, 8))
    for source in (src / "gw_fmu.c", unity):
        r = subprocess.run([cc, *strict, str(source), "-o", str(tmp_path / "x.so"), "-lm"],
                           capture_output=True, text=True)
        assert r.returncode == 0, f"{cc} {source.name}:\n{r.stderr}"


def _final_states(fmu, unzipdir=None, **values):
    """The 8 states and the accepted-step count after one fmi2DoStep(0, 20) of `fmu` (optionally
    its binary from `unzipdir`)."""
    from fmi_helpers import Slave
    s = Slave(fmu, unzipdir=unzipdir)
    try:
        s.init(**values)
        s.slave.doStep(0.0, 20.0)
        log = " ".join(m for _, _, m in s.messages)
        return np.array(s.get(*STATES)), int(re.findall(r"accepted=(\d+)", log)[-1])
    finally:
        s.free()


def _rebuilt(built, tmp_path: Path, cmd: list[str]) -> Path:
    """The FMU unpacked into tmp_path with its binary rebuilt from its sources by `cmd` (the
    compiler and its flags; the source, includes and output are added).  Returns the directory."""
    unz = tmp_path / "fmu"
    with zipfile.ZipFile(built.fmu) as z:
        z.extractall(unz)
    lib = next((unz / "binaries" / "linux64").glob("*.so"))
    lib.unlink()
    r = subprocess.run([*cmd, "-shared", "-fPIC", f"-I{built.sources}", str(built.sources / "gw_fmu.c"),
                        "-o", str(lib), "-lm"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return unz


_SETTINGS = dict(solver=TAYLOR, rel_tol=1e-10, abs_tol=1e-12, max_step=20.0)


def test_sources_build_and_run_without_gnu_vector_extensions(paper, tmp_path):
    """The FMU's sources are plain C99 for a compiler without GCC's vector extension (tcc here,
    MSVC alike): the increment's SSE2 pairs and their x86-64-v3 clone (loose4) stood outside the
    __GNUC__ guard, so no FMU, with or without the kernel, compiled there ("';' expected (got
    "hv")").  Built by tcc, the portable path (scalar increment on the kernel's order-major
    series) gives the gcc build's trajectory to rounding, with the same steps."""
    import shutil
    tcc = shutil.which("tcc")
    if tcc is None:
        pytest.skip("tcc is not installed (make test installs it: Debian package tcc)")
    unz = _rebuilt(paper[0], tmp_path, [tcc, "-std=c99", "-Wall"])
    x_tcc, n_tcc = _final_states(paper[0].fmu, unz, **_SETTINGS)
    x_gcc, n_gcc = _final_states(paper[0].fmu, **_SETTINGS)
    assert n_tcc == n_gcc
    np.testing.assert_allclose(x_tcc, x_gcc, rtol=1e-11, atol=1e-11)


def test_generic_clone_equals_the_x86_64_v3_one_to_rounding(paper, tmp_path):
    """A CPU without AVX2/FMA runs the target clones' portable default (kernel and increment):
    built with GW_NO_CLONES (what the default clone compiles to: SSE2, no contraction) the run
    takes the same steps and ends within rounding of the FMU's own binary (on this machine its
    x86-64-v3 clone, fused multiply-adds), and within rel_tol of scipy's DOP853 at 1e-13."""
    from gyrowheel.fmu_build.compiler import OPTIMISE, STANDARD
    unz = _rebuilt(paper[0], tmp_path, [compiler(), *STANDARD, *OPTIMISE, "-DGW_NO_CLONES"])
    x_generic, n_generic = _final_states(paper[0].fmu, unz, **_SETTINGS)
    x_own, n_own = _final_states(paper[0].fmu, **_SETTINGS)
    assert abs(n_generic - n_own) <= 1  # a step count a rounding apart at most
    np.testing.assert_allclose(x_generic, x_own, rtol=1e-11, atol=1e-11)
    wheel = CasadiWheel()
    sol = wheel.integrate(wheel.x0(), 20.0, rtol=1e-13, atol=1e-15)
    ref = np.array([wheel.out(sol.y[:, -1])[n] for n in STATES])
    assert np.max(np.abs(x_generic - ref)) < 30 * 1e-10


def test_kernel_of_constant_derivatives_builds_and_integrates(tmp_path):
    """x' = k: no node of the kernel has a series; its FMU still compiles under -Werror (a
    variable set but never read would fail it) and integrates exactly."""
    s = System("ramp", "x' = k")
    k = s.parameter("k", 2.0, "1/s", "rate")
    x = s.state("x", 0.5, "1", "value")
    s.der(x, k)
    fmu = build_spec_fmu(s.spec(), tmp_path / "ramp.fmu", taylor=True).fmu
    r = simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.25, start_values={"solver": 6})
    np.testing.assert_allclose(r["x"], 0.5 + 2.0 * r["time"], rtol=0, atol=1e-14)
