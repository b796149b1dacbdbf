"""A stiff mode's transient is not a settled step size (the budget projection, docs/fmi.md).

The projection of the budget of internal steps (c_src/gw_budget.c, gw_budget_projection) refuses a
call early when the step size has settled at a size that projects far beyond the budget. A stiff
mode resolved while it decays holds the step size nearly constant too, for a number of attempts
that grows like rel_tol^(-1/q) with the solver's order q (the state decays relative to itself at a
constant step), and then the step grows by orders of magnitude: Rosenbrock (L-stable) leaves the
decayed mode behind. The window of a settled step size is at least GW_SETTLE_SPANS = 20 such time
scales, 20 rel_tol^(-1/q) attempts (2000 for Rosenbrock at rel_tol 1e-8).

The case: a 1e-3 kg wheel (scene defaults otherwise: R = 0.17 m, k_axial = 0.4, lean 80 deg,
gamma_dot = 6 rad/s) with a linear air drag c_lin = 1e6 N s/m. Rolling, the centre moves at
v = R gamma_dot, and the drag -c_lin v on the centre against the rolling inertia M (1 + k_axial)
stops it with the relaxation time tau = M (1 + k_axial) / c_lin (1.4e-9 s): the wheel rolls
v0 tau further, gamma gains gamma_dot0 tau, and then stands. Gravity then tips it over against the
drag at the overdamped rate |beta_dot| = M g cos(beta) / (c_lin R) (gravity's torque about the
contact point M g R cos(beta) against the drag's c_lin R^2 beta_dot): 1e-11 rad/s here, nothing
in 1 s. The independent check is tau, from the scene's numbers, not from the solver.
"""
from __future__ import annotations

import math
import re

import pytest
from fmpy.fmi1 import FMICallException

from fmi_helpers import Slave
from gyrowheel.fmu_build import build_fmu, parse_scene

SCENE = '[model]\nname = "drag0"\n[effects.gravity]\n[effects.air_drag]\n'
C_LIN = 1e6  # N s/m
R, K_AXIAL, GAMMA_DOT0, BETA0, G = 0.17, 0.4, 6.0, math.radians(80.0), 9.81  # the scene defaults
ROSENBROCK, DOP853 = 4, 5


@pytest.fixture(scope="module")
def drag0(tmp_path_factory):
    """the new user's scene: gravity and air drag with every default"""
    root = tmp_path_factory.mktemp("drag0")
    return str(build_fmu(parse_scene(SCENE, "drag0.toml"), root / "drag0.fmu").fmu)


def relaxation_time(M: float) -> float:
    """s: the rolling speed's decay time under the linear drag, M (1 + k_axial) / c_lin"""
    return M * (1.0 + K_AXIAL) / C_LIN


def steps(log: str) -> tuple[int, int]:
    """(accepted, rejected) internal steps of the one fmi2DoStep in the solver log"""
    accepted, rejected = re.findall(r"accepted=(\d+) rejected=(\d+)", log)[-1]
    return int(accepted), int(rejected)


def one_second(fmu: str, M: float, **settings) -> tuple[Slave, str | None]:
    """fmi2DoStep(0, 1) of the drag0 wheel of mass M; (the instance, the error logged or None)"""
    s = Slave(fmu)
    s.init(M=M, c_lin=C_LIN, **settings)
    try:
        s.slave.doStep(0.0, 1.0)
    except FMICallException as exc:
        assert exc.status == 3
        return s, s.log_text()
    return s, None


def assert_relaxed(s: Slave, M: float) -> None:
    """After 1 s: gamma gained gamma_dot0 tau and the centre rolled R gamma_dot0 tau along x (to
    1e-6, or 1e-12 where that is below the tolerance's reach), the spin stopped, and the wheel
    tips over at the overdamped rate, beta_dot = -M g cos(beta) / (c_lin R), its centre moving
    R sin(beta) (beta - beta0) along y."""
    gamma, gamma_dot, beta, beta_dot, x, y = s.get("gamma", "gamma_dot", "beta", "beta_dot", "x", "y")
    rolled = GAMMA_DOT0 * relaxation_time(M)  # rad
    assert gamma == pytest.approx(rolled, rel=1e-6, abs=1e-12)
    assert x == pytest.approx(R * rolled, rel=1e-6, abs=1e-12)
    assert abs(gamma_dot) < 1e-9
    fall = -M * G * math.cos(BETA0) / (C_LIN * R)  # rad/s
    assert beta_dot == pytest.approx(fall, rel=1e-3, abs=1e-13)
    assert beta - BETA0 == pytest.approx(fall * 1.0, rel=1e-3, abs=1e-13)
    assert y == pytest.approx(R * math.sin(BETA0) * fall * 1.0, rel=1e-3, abs=1e-13)


def test_the_reported_input_finishes_with_rosenbrock(drag0):
    """M = 1e-3, c_lin = 1e6, rosenbrock, one fmi2DoStep(0, 1) at the default budget (1e6): it
    finishes, in 193 accepted + 3 rejected steps (measured): ~140 attempts at h = 6.3e-11 s =
    tau / 22 while the drag's mode decays (the window of a settled step at rel_tol 1e-8 is 2000), then
    h grows by orders of magnitude to t = 1 s."""
    s, error = one_second(drag0, 1e-3, solver=ROSENBROCK)
    try:
        assert error is None, error[-600:]
        accepted, rejected = steps(s.log_text())
        assert 150 <= accepted <= 300 and rejected <= 10, (accepted, rejected)
        assert_relaxed(s, 1e-3)
    finally:
        s.free()


def test_the_reported_command_exits_0(drag0, tmp_path, capsys):
    """gyrowheel simulate drag0.fmu --set M=1e-3 --set c_lin=1e6 --set solver=rosenbrock
    --stop-time 1: 0.01 s communication steps to t = 1 s, exit 0."""
    from gyrowheel.cli import main
    out = tmp_path / "drag0.csv"
    code = main(["simulate", drag0, "--set", "M=1e-3", "--set", "c_lin=1e6", "--set", "solver=rosenbrock",
                 "--stop-time", "1", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    assert "101 rows, t = 0 .. 1 s" in capsys.readouterr().out


@pytest.mark.parametrize("M", [0.1, 1e-2, 1e-3, 1e-6, 1e-20, 1e-30])
def test_mass_sweep_relaxes_with_rosenbrock(drag0, M):
    """rel_tol 1e-8 (the scene's): tau from 1.4e-7 s down to 1.4e-35 s. M = 1e-3 and 1e-6 resolve the
    transient (the same number of steps: h scales with tau); M = 1e-20 and 1e-30 put tau far below
    the first step (3.6e-12 s), where the L-stable method damps the mode within the tolerance."""
    s, error = one_second(drag0, M, solver=ROSENBROCK, rel_tol=1e-8)
    try:
        assert error is None, error[-600:]
        assert_relaxed(s, M)
    finally:
        s.free()


def test_mass_1e_12_is_below_the_step_size_floor(drag0):
    """M = 1e-12: tau = 1.4e-18 s, below the smallest step 16 eps max(|t|, 1) = 3.6e-15 s near t = 0,
    so it cannot be resolved; nor is it damped within the tolerance at the steps the floor allows
    (h / tau from 2.5e6 at the first step, 3.6e-12 s, down to 1.6e3: all 5 attempts rejected, error
    norm 2e4 at h = 2.2e-15 s), unlike M = 1e-20 (h / tau = 2.5e14 at the first step): a step size
    underflow, not the budget. The refusal says so."""
    s, error = one_second(drag0, 1e-12, solver=ROSENBROCK, rel_tol=1e-8)
    try:
        assert error is not None
        assert "step size underflow at t=0" in error and "would need about" not in error, error[-600:]
    finally:
        s.free()


def test_mass_1e_12_message_names_the_time_scale(drag0, tmp_path, capsys):
    """gyrowheel simulate says why: the fastest time scale is below the smallest step."""
    from gyrowheel.cli import main
    code = main(["simulate", drag0, "--set", "M=1e-12", "--set", "c_lin=1e6", "--set", "solver=rosenbrock",
                 "--stop-time", "1", "-o", str(tmp_path / "d.csv")])
    err = capsys.readouterr().err
    assert code == 1
    assert "step size underflow" in err and "fastest time scale is shorter than the solver's smallest step" in err


def test_an_explicit_solver_is_still_refused_early_and_sent_to_rosenbrock(drag0):
    """DOP853 on the same wheel: once the mode has decayed its step stays at the stability bound
    (h = 8e-9 s = 5.7 tau measured), a settled step: one fmi2DoStep(0, 1) needs ~1.2e8 steps; with
    a budget of 20000 the projection refuses it after the window (DOP853 at rel_tol 1e-8:
    20 x 1e-8^(-1/8) = 200 attempts), well before the budget is spent, and names
    rosenbrock, which finishes (test_the_reported_input_finishes_with_rosenbrock)."""
    s, error = one_second(drag0, 1e-3, solver=DOP853, max_internal_steps=20000)
    try:
        assert error is not None
        assert "the step size has settled" in error and "try solver rosenbrock" in error, error[-600:]
        taken = int(re.search(r"\((\d+) steps taken in this call\)", error)[1])
        assert taken < 2000, taken
    finally:
        s.free()


@pytest.mark.parametrize("solver, rel_tol, window", [(3, 1e-8, 796), (5, 1e-8, 200), (5, 1e-14, 1125),
                                                     (ROSENBROCK, 1e-14, 63246)])
def test_a_settled_step_is_still_refused_within_its_window(earth_fmu, solver, rel_tol, window):
    """The paper's earth wheel spinning at 1e9 rad/s (its nutation holds h ~ 1e-9 s for good): one
    fmi2DoStep(0, 1) is refused by the projection ("the step size has settled") once the window of
    20 rel_tol^(-1/q) attempts is full (dopri5 q = 5, dop853 q = 8, rosenbrock q = 4), long before the
    budget of 1e6: at most the window and the attempts before h settled (measured: 989, 246, 1131,
    63247 attempts; the last takes 0.09 s of CPU)."""
    s = Slave(earth_fmu)
    try:
        s.init(solver=solver, rel_tol=rel_tol, gamma_dot=1e9)
        with pytest.raises(FMICallException):
            s.slave.doStep(0.0, 1.0)
        log = s.log_text()
        assert "the step size has settled" in log, log[-600:]
        taken = int(re.search(r"\((\d+) steps taken in this call\)", log)[1])
        assert window <= taken <= window + 1000, taken
    finally:
        s.free()
